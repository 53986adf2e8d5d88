//! The tally of what the channel did, measured where it happened: between the links the
//! controllers broadcast and what they received, whatever injector stood in between. Both
//! runtimes feed the same function, so `summary.json` and `wire.csv` agree bit for bit.
use platoon_control::{Delivery, Packet};
use platoon_model::VehicleId;
use serde::{Deserialize, Serialize};

/// One receiver's link packets in one step (or summed over a run).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireCounts {
    /// Link packets broadcast to it (one per sender that broadcast).
    pub sent: u64,
    /// Delivered exactly as sent, in the step they were sent.
    pub delivered_as_sent: u64,
    /// Delivered in the step they were sent with a field changed: the state, the command `u`,
    /// the sampling step, the head or the maneuver message.
    pub altered: u64,
    /// Sent and not delivered in that step (dropped, or delayed to a later step).
    pub dropped: u64,
    /// Delivered with no broadcast of that step behind them (delayed, replayed or forged).
    pub injected: u64,
    /// Steps in which it was told its channel was jammed.
    pub jammed: u64,
}

impl WireCounts {
    /// Anything but clean delivery.
    pub fn is_eventful(&self) -> bool {
        self.altered + self.dropped + self.injected + self.jammed > 0
    }

    /// Adds `other`.
    pub fn add(&mut self, other: &WireCounts) {
        self.sent += other.sent;
        self.delivered_as_sent += other.delivered_as_sent;
        self.altered += other.altered;
        self.dropped += other.dropped;
        self.injected += other.injected;
        self.jammed += other.jammed;
    }
}

/// Counts steps of the wire, reusing its buffer of the step's links (it runs every step).
#[derive(Debug, Clone, Default)]
pub struct WireCounter {
    open: Vec<(VehicleId, Packet, bool)>,
}

impl WireCounter {
    /// Counts one step of one platoon into `per_vehicle` (index = vehicle within the platoon, leader
    /// first; zeroed first). `links` are the broadcasts as (receiver, packet), one per link;
    /// `deliveries` what the controllers got; `jammed` who was told its channel was jammed. A
    /// delivery matches the first unmatched link with its receiver, sender and sequence number;
    /// deliveries to receivers outside the platoon are counted in `outside`.
    pub fn count(
        &mut self,
        links: impl Iterator<Item = (VehicleId, Packet)>,
        deliveries: &[Delivery],
        jammed: &[bool],
        per_vehicle: &mut [WireCounts],
        outside: &mut WireCounts,
    ) {
        per_vehicle.fill(WireCounts::default());
        let open = &mut self.open;
        open.clear();
        open.extend(links.map(|(r, p)| (r, p, false)));
        for (r, _, _) in open.iter() {
            if let Some(c) = per_vehicle.get_mut(r.index()) {
                c.sent += 1;
            }
        }
        for d in deliveries {
            let found = open.iter_mut().find(|(r, p, used)| {
                !*used && *r == d.receiver && p.sender == d.packet.sender && p.seq == d.packet.seq
            });
            let counts = match per_vehicle.get_mut(d.receiver.index()) {
                Some(c) => c,
                None => &mut *outside,
            };
            match found {
                Some((_, p, used)) => {
                    *used = true;
                    // Every field counts: state, `u`, sampling step, head, maneuver message.
                    if crate::truth::Fields::of_packets(p, &d.packet).is_empty() {
                        counts.delivered_as_sent += 1;
                    } else {
                        counts.altered += 1;
                    }
                }
                None => counts.injected += 1,
            }
        }
        for (r, _, used) in open.iter() {
            if !used {
                if let Some(c) = per_vehicle.get_mut(r.index()) {
                    c.dropped += 1;
                }
            }
        }
        for (c, &j) in per_vehicle.iter_mut().zip(jammed) {
            c.jammed += u64::from(j);
        }
    }
}

/// The links of a step's broadcasts: each packet to each of its sender's out-neighbours.
pub fn links<'a>(
    topology: &'a platoon_topology::Topology,
    tx: &'a [Packet],
) -> impl Iterator<Item = (VehicleId, Packet)> + 'a {
    tx.iter().flat_map(move |p| {
        topology
            .out_neighbours(p.sender)
            .iter()
            .map(move |&r| (r, *p))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_model::State;

    fn pk(sender: u16, seq: u32, p: f64) -> Packet {
        Packet::beacon(VehicleId(sender), seq, 3, State::new(p, 1.0, 0.0))
    }

    #[test]
    fn counts_delivered_altered_dropped_injected_and_jammed() {
        let links = vec![
            (VehicleId(1), pk(0, 4, 10.0)),
            (VehicleId(2), pk(0, 4, 10.0)),
            (VehicleId(2), pk(1, 2, 0.0)),
        ];
        let d = |r: u16, p: Packet| Delivery {
            receiver: VehicleId(r),
            packet: p,
        };
        let deliveries = vec![
            d(1, pk(0, 4, 10.0)), // as sent
            d(2, pk(0, 4, 12.0)), // altered
            d(2, pk(1, 1, 0.0)),  // an old seq: injected (and seq 2 dropped)
            d(9, pk(0, 4, 10.0)), // nobody in this platoon
        ];
        let mut per = vec![WireCounts::default(); 3];
        let mut outside = WireCounts::default();
        WireCounter::default().count(
            links.into_iter(),
            &deliveries,
            &[false, true, false],
            &mut per,
            &mut outside,
        );
        assert_eq!(per[1].delivered_as_sent, 1);
        assert_eq!((per[1].sent, per[1].jammed), (1, 1));
        assert_eq!(
            (per[2].sent, per[2].altered, per[2].injected, per[2].dropped),
            (2, 1, 1, 1)
        );
        assert_eq!(outside.injected, 1);
        assert!(!per[0].is_eventful() && per[2].is_eventful());
    }

    #[test]
    fn a_rewritten_maneuver_message_or_head_counts_as_altered() {
        let sent = pk(0, 4, 10.0);
        let mut maneuver = sent;
        maneuver.maneuver = Some(platoon_maneuver::Message {
            sender: VehicleId(0),
            to: VehicleId(1),
            seq: 1,
            body: platoon_maneuver::Body::LeaveNotice,
        });
        let mut head = sent;
        head.head = VehicleId(1);
        for altered in [maneuver, head] {
            let mut per = vec![WireCounts::default(); 2];
            WireCounter::default().count(
                [(VehicleId(1), sent)].into_iter(),
                &[Delivery {
                    receiver: VehicleId(1),
                    packet: altered,
                }],
                &[false, false],
                &mut per,
                &mut WireCounts::default(),
            );
            assert_eq!((per[1].altered, per[1].delivered_as_sent), (1, 0));
        }
    }
}
