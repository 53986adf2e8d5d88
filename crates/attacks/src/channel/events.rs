//! The channel's log: what it did to each packet it did not deliver as sent.
use platoon_model::VehicleId;
use platoon_v2v::Packet;
use serde::Serialize;

/// What the channel did to one packet on one link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Action {
    /// Dropped: the DoS schedule jams the channel.
    DroppedDos,
    /// Dropped: the sender or receiver is within a range jammer's radius.
    DroppedJammed,
    /// Dropped: a jammer's interference (in the SINR with the 802.11p radio; within a reactive
    /// jammer's radius with the ideal one) lost a packet the radio would have delivered.
    DroppedInterference,
    /// Delivered: the first packet through on a link after jamming losses on it (logged only
    /// with `[[channel.jammers]]`, so each link's outage can be read from the log).
    Restored,
    /// Dropped: random loss (Bernoulli or Gilbert-Elliott).
    DroppedLoss,
    /// Dropped: lost on the radio (802.11p: propagation, collision, busy receiver, below the
    /// sensing threshold), drawn from the model's delivery ratio at the link's distance.
    DroppedRadio,
    /// Held back by the sender's DCC (its `T_off` since its last transmission had not passed):
    /// sent at a later step unless a newer packet replaces it.
    DccDeferred,
    /// A packet DCC had held back, dropped for a newer one of the same sender.
    DroppedDcc,
    /// Held back; delivered at a later step.
    Delayed,
    /// A held-back packet delivered now.
    DeliveredLate,
    /// Replaced by an older packet of the same sender.
    Replayed,
    /// Its state was altered (false data injection).
    Altered,
}

/// One line of the injector log: `step, platoon, sender, receiver, seq, action, detail`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct ChannelEvent {
    /// The step at which it happened.
    pub step: u64,
    /// The platoon (sender and receiver are its vehicle indices, 0 = its leader).
    pub platoon: u16,
    /// The packet's sender.
    pub sender: u16,
    /// The link's receiver.
    pub receiver: u16,
    /// The packet's sequence number (after replay: the old one).
    pub seq: u32,
    /// What happened.
    pub action: Action,
    /// For `delayed`: the step of delivery; for `replayed`: the step the old packet was sampled.
    pub detail: Option<u64>,
}

impl ChannelEvent {
    /// The columns of the log, in the order of the fields (a CSV's header).
    pub const COLUMNS: [&'static str; 7] = [
        "step", "platoon", "sender", "receiver", "seq", "action", "detail",
    ];
}

pub(super) fn event(
    (step, platoon): (u64, u16),
    p: &Packet,
    receiver: VehicleId,
    action: Action,
    detail: Option<u64>,
) -> ChannelEvent {
    ChannelEvent {
        step,
        platoon,
        sender: p.sender.0,
        receiver: receiver.0,
        seq: p.seq,
        action,
        detail,
    }
}
