use serde::{Deserialize, Serialize};
use std::fmt;

/// A vehicle of the platoon: 0 is the leader, 1..=N are the followers in platoon order.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
#[serde(transparent)]
#[repr(transparent)]
pub struct VehicleId(pub u16);

impl VehicleId {
    /// The leader, vehicle 0.
    pub const LEADER: VehicleId = VehicleId(0);

    /// Follower `i` (1-based, as in the paper).
    pub fn follower(i: usize) -> Self {
        debug_assert!(i >= 1);
        VehicleId(i as u16)
    }

    /// Whether this is the leader.
    pub fn is_leader(self) -> bool {
        self.0 == 0
    }

    /// Index into arrays that hold the leader at 0 and followers at 1..=N.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl fmt::Display for VehicleId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_leader() {
            write!(f, "leader")
        } else {
            write!(f, "follower {}", self.0)
        }
    }
}
