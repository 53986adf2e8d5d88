//! The leader's beacons, which the pipeline sends for it.
use crate::Packet;
use platoon_model::{State, VehicleId};

/// The leader's beacons, which every built-in controller sends for it: its state every
/// `every` steps, with its acceleration over the step before as its command.
#[derive(Debug, Clone, Default)]
pub(super) struct LeaderBeacon {
    seq: u32,
    last_u: f64,
}

impl LeaderBeacon {
    /// Step `k` (`states[0]` is the leader's): appends its packet to `out` when it is due, or
    /// when it carries a maneuver message, or when `force`d (a renewed group key to send).
    pub(super) fn transmit_with(
        &mut self,
        k: u64,
        every: u32,
        states: &[State],
        maneuver: Option<crate::maneuvers::Message>,
        force: bool,
        out: &mut Vec<Packet>,
    ) {
        if k.is_multiple_of(u64::from(every)) || maneuver.is_some() || force {
            self.seq += 1;
            out.push(Packet {
                sender: VehicleId::LEADER,
                seq: self.seq,
                step: k,
                state: states[0],
                u: self.last_u,
                head: VehicleId::LEADER,
                maneuver,
                seal: None,
                group: None,
            });
        }
        self.last_u = states[0][2];
    }
}
