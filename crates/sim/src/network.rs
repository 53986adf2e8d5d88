use platoon_attacks::DosSchedule;
use platoon_control::{Delivery, Packet};
use platoon_topology::Topology;

/// The in-process network: every broadcast reaches every out-neighbour of its sender, except
/// while the DoS schedule jams the channel, when nothing gets through.
#[derive(Debug, Clone)]
pub struct DosNetwork {
    schedule: DosSchedule,
}

impl DosNetwork {
    /// A network jammed on `schedule`.
    pub fn new(schedule: DosSchedule) -> Self {
        Self { schedule }
    }

    /// Delivers `tx` (sent at time t) into `out`; returns whether the channel was jammed.
    pub fn gate(
        &self,
        t: f64,
        topology: &Topology,
        tx: &[Packet],
        out: &mut Vec<Delivery>,
    ) -> bool {
        let jammed = self.schedule.is_active(t);
        if !jammed {
            for p in tx {
                for &receiver in topology.out_neighbours(p.sender) {
                    out.push(Delivery {
                        receiver,
                        packet: *p,
                    });
                }
            }
        }
        jammed
    }
}
