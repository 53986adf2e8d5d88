//! The injector seam: what each receiver of one platoon gets from each broadcast, one step at a
//! time. Pure, on `platoon-v2v`'s [`Packet`] and [`Delivery`] with the platoon's own vehicle
//! ids (leader 0), so one implementation runs in process (`platoon_sim`: runs, campaigns,
//! `platoon search`) and as the injector process of a co-simulation (`platoon_runtime::injector`
//! adapts it to the wire). The built-in [`Channel`] is one.
use crate::channel::{Channel, ChannelEvent, ChannelStep, RadioStats};
use platoon_model::State;
use platoon_topology::Topology;
use platoon_v2v::{Delivery, Packet};

/// What an injector sees of one platoon at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct Step<'a> {
    /// The step.
    pub k: u64,
    /// Its time (s).
    pub t: f64,
    /// Who hears whom on the platoon's channel: each broadcast is meant for its sender's
    /// out-neighbours (the scenario's topology, plus every member ahead when the platoon splits
    /// behind a cut-in: `platoon_sim::Scenario::hearing`).
    pub topology: &'a Topology,
    /// Every vehicle's true state at step k, leader first.
    pub states: &'a [State],
    /// The broadcasts of step k, the leader's first (if it broadcast), then the followers' in
    /// order.
    pub tx: &'a [Packet],
    /// The road positions of SUMO's background vehicles at step k in the platoon's coordinates
    /// (`bg<b>` at index b, NaN: not on the road); empty without background traffic.
    pub background: &'a [f64],
}

/// What an injector hands back for one step of one platoon.
#[derive(Debug)]
pub struct Reception<'a> {
    /// What each receiver gets (empty on entry): a delivery per (packet, receiver); leave one
    /// out to drop it, alter, delay, replay or invent packets at will.
    pub deliveries: &'a mut Vec<Delivery>,
    /// Per vehicle (leader first; all false on entry): whether it senses its channel jammed
    /// at this step.
    pub jammed: &'a mut [bool],
    /// What the injector did to packets it did not deliver as sent (appended; the run's
    /// `channel.csv` and link outages read it). Optional: the run measures drops and
    /// alterations itself, between the broadcasts and the deliveries.
    pub log: &'a mut Vec<ChannelEvent>,
}

/// Why an injector failed: the run stops and names the injector.
#[derive(Debug, Clone, thiserror::Error)]
pub enum InjectError {
    /// Its input is not what it can work with (a sender or receiver it does not know, a state
    /// out of its range).
    #[error("cannot use its input: {0}")]
    Input(String),
    /// Writing what it records (a log of its own) failed.
    #[error("writing {what}: {source}")]
    Output {
        /// What was being written.
        what: String,
        /// The I/O error.
        source: std::sync::Arc<std::io::Error>,
    },
    /// An error of its own.
    #[error(transparent)]
    Other(std::sync::Arc<dyn std::error::Error + Send + Sync>),
}

impl InjectError {
    /// Writing `what` failed with `source`.
    pub fn output(what: impl Into<String>, source: std::io::Error) -> Self {
        Self::Output {
            what: what.into(),
            source: std::sync::Arc::new(source),
        }
    }
}

/// Equal when they say the same.
impl PartialEq for InjectError {
    fn eq(&self, other: &Self) -> bool {
        self.to_string() == other.to_string()
    }
}

impl From<String> for InjectError {
    fn from(message: String) -> Self {
        Self::Other(std::sync::Arc::from(Box::<
            dyn std::error::Error + Send + Sync,
        >::from(message)))
    }
}

impl From<&str> for InjectError {
    fn from(message: &str) -> Self {
        Self::from(message.to_string())
    }
}

/// An attack injector for one platoon: decides, every step, what each receiver gets.
pub trait Injector: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// Fills `out` with what the receivers get at `step.k`.
    fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError>;

    /// Called once after the last step (flush what it records here).
    fn finish(&mut self) -> Result<(), InjectError> {
        Ok(())
    }

    /// What its radio measured (the built-in channel with the 802.11p radio); `None` for an
    /// ideal radio.
    fn radio_stats(&self) -> Option<RadioStats> {
        None
    }

    /// The built-in channel, if this is it (a fleet's channels hear each other's load).
    fn channel(&self) -> Option<&Channel> {
        None
    }

    /// See [`Injector::channel`].
    fn channel_mut(&mut self) -> Option<&mut Channel> {
        None
    }
}

dyn_clone::clone_trait_object!(Injector);

impl Injector for Channel {
    fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError> {
        self.set_background(step.background);
        self.gate(
            &ChannelStep {
                k: step.k,
                t: step.t,
                topology: step.topology,
                states: step.states,
                tx: step.tx,
            },
            out.deliveries,
            out.jammed,
            out.log,
        );
        Ok(())
    }

    fn radio_stats(&self) -> Option<RadioStats> {
        Channel::radio_stats(self)
    }

    fn channel(&self) -> Option<&Channel> {
        Some(self)
    }

    fn channel_mut(&mut self) -> Option<&mut Channel> {
        Some(self)
    }
}

/// Lets every platoon's built-in channel of a fleet hear the others before step `k` is gated
/// ([`crate::channel::hear_fleet`]); injectors of the caller's are left out.
pub fn hear_fleet<'a>(
    k: u64,
    platoons: impl Iterator<Item = (&'a mut dyn Injector, &'a [State])>,
    beacons: &mut Vec<(f64, f64)>,
) {
    let mut channels: Vec<(&mut Channel, &[State])> = platoons
        .filter_map(|(i, s)| i.channel_mut().map(|c| (c, s)))
        .collect();
    crate::channel::hear_fleet(k, &mut channels, beacons);
}
