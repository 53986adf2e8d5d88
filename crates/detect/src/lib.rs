//! Misbehaviour detectors for the V2V receive path, as a pure library (no I/O, clocks or
//! threads; deterministic).
//!
//! A follower that receives a packet at step `k` knows what the packet claims (the sender's
//! sampled state `[p, v, a]` at the packet's step), its own state from its own sensors, the last
//! packet it accepted from that sender and, when the sender is its predecessor, what its radar
//! measures of it. That is an [`Observation`]. A [`Detector`] inspects one and gives a
//! [`Verdict`]: flagged or not, and the test statistic behind the decision (its `score`), so that
//! ROC curves can be drawn offline by sweeping a threshold over the scores.
//!
//! The detectors follow F2MD (the V2X misbehaviour-detection framework of Kamel et al.):
//! plausibility checks of one message and consistency checks between messages, plus the two
//! checks a platoon affords beyond a CAM: the follower's radar, and a model of how a vehicle
//! can move between two of its packets.
//!
//! They come after `platoon_control::checks::PacketChecks::admit`, which already refuses
//! non-finite states, unknown senders, packets from the future, stale or replayed ones,
//! impossible sequence numbers and states beyond 5 g of the last accepted one: a detector only
//! sees packets that passed those. It still never panics on any input (NaN, infinities, huge
//! values: a property test says so), and flags a non-finite claim.
//!
//! # The detectors
//!
//! - [`Plausibility`] (`plausibility`): F2MD's legacy checks, binary, on one packet and the last
//!   accepted one: speed within `[v_min_mps, v_max_mps]`, acceleration within
//!   `[-decel_max_mps2, accel_max_mps2]`, the sender within radio range, its position change
//!   consistent with its speeds, its speed change consistent with the acceleration bounds, the
//!   beacon frequency, and a sender that suddenly appears close by. Its score is the number of
//!   checks that failed ([`PlausibilityFailures`] names them).
//! - [`RadarCross`] (`radar_cross`): the claimed position and speed of the predecessor against
//!   the follower's own radar (gap and closing speed), in multiples of the radar's noise.
//! - [`Residual`] (`residual`): a chi-square test of the innovation of the claim against a
//!   constant-acceleration prediction from the last accepted packet, with a white-jerk process
//!   noise and a measurement noise; its threshold is the chi-square(3) quantile at `1 - alpha`
//!   for the false-alarm rate `alpha` the user sets.
//!
//! Each has a params struct ([`PlausibilityParams`], [`RadarCrossParams`], [`ResidualParams`]:
//! serde with `deny_unknown_fields`, every field defaulted, `validate()` naming the field at
//! fault) that a config embeds as a `[detection.<name>]` table ([`Detection`]), or lists as
//! tagged tables ([`DetectorSpec`], tagged by `kind`). [`build`] makes the detector a spec
//! names; [`Detectors`] runs several on each observation.
//!
//! # What they cannot see
//!
//! - An insider that lies consistently: a claimed trajectory that is a genuine vehicle's
//!   trajectory (smooth, within the physical bounds, its jerk within the residual's process
//!   noise) passes the plausibility and residual checks whatever it is offset from the truth by,
//!   once the offset is in place. Only the radar sees the truth, and only for the predecessor.
//! - A slow drift: an offset that grows by less than the residual's noise between packets (a
//!   position that creeps by centimetres per packet, a speed by a few cm/s) is never flagged by
//!   the residual, which compares each packet with the previous one; the plausibility checks are
//!   wider still. Against the predecessor the radar catches the drift once it exceeds
//!   `k_sigma` times the radar's noise.
//! - An attack at the onset only: the residual and the consistency checks compare a packet with
//!   the last one *accepted*. If a forged packet is accepted (the caller does not drop flagged
//!   packets), the next forged packets are consistent with it and only the onset is flagged; if
//!   flagged packets are dropped, an offset attack is flagged on every packet, but so is the
//!   first genuine packet after a long gap in a manoeuvre. Which `last` to pass is the caller's
//!   choice.
//! - Anything about vehicles the receiver has no radar on (all but its predecessor), beyond
//!   what the claims say of themselves.
//! - Delays and replays: the packet checks before these detectors handle freshness.
//!
//! The docs page `docs/detection.md` has the equations and the reasons behind the defaults.
//!
//! ```
//! use platoon_detect::{build, DetectorSpec, Last, Observation, ResidualParams};
//! use platoon_model::{State, VehicleId};
//! use platoon_v2v::Packet;
//!
//! let mut residual = build(&DetectorSpec::Residual(ResidualParams::default()))?;
//! let last = Last { step: 100, state: State::new(100.0, 20.0, 0.0) };
//! // 10 steps later, the sender claims to brake at 8 m/s^2 out of the blue.
//! let packet = Packet::beacon(VehicleId(0), 7, 110, State::new(102.0, 20.0, -8.0));
//! let obs = Observation {
//!     k: 110,
//!     dt: 0.01,
//!     receiver: VehicleId(1),
//!     own: State::new(80.0, 20.0, 0.0),
//!     packet: &packet,
//!     last: Some(last),
//!     radar: None,
//! };
//! assert!(residual.inspect(&obs).flagged);
//! # Ok::<(), platoon_detect::ParamError>(())
//! ```
#![warn(missing_docs)]

/// F2MD's legacy plausibility and consistency checks.
pub mod plausibility;
/// The predecessor's claim against the follower's radar.
pub mod radar;
/// The model-based residual (chi-square) test.
pub mod residual;

#[cfg(test)]
mod testkit;
#[cfg(test)]
mod tests;

pub use plausibility::{Plausibility, PlausibilityFailures, PlausibilityParams};
pub use radar::{RadarCross, RadarCrossParams};
pub use residual::{Residual, ResidualParams};

use platoon_model::{State, VehicleId};
use platoon_v2v::Packet;
use std::fmt::Debug;

/// The last packet a receiver accepted from a sender: when it was sampled and what it said.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Last {
    /// The step it was sampled at (its [`Packet::step`]).
    pub step: u64,
    /// Its state `[p, v, a]`.
    pub state: State,
}

impl From<&Packet> for Last {
    fn from(p: &Packet) -> Self {
        Self {
            step: p.step,
            state: p.state,
        }
    }
}

/// What the receiver's radar measures of the vehicle ahead (given only when the sender is the
/// receiver's predecessor and the radar sees it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadarReading {
    /// The measured gap, bumper to bumper (m).
    pub gap_m: f64,
    /// The measured closing speed, `v_receiver - v_ahead` (m/s): positive while closing in.
    pub closing_mps: f64,
    /// The length of the vehicle ahead (m): its position is `p_receiver + gap + length`.
    pub vehicle_length_m: f64,
    /// How long ago the measurement was taken (s; 0 for one taken at this step). A radar that
    /// measures every few steps holds its reading in between; the detector brings it forward.
    pub age_s: f64,
}

/// Everything a receiver knows when a packet arrives at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    /// The step at which the packet is received.
    pub k: u64,
    /// The step length (s).
    pub dt: f64,
    /// Who received it. Its index is its place in the platoon (0 the leader; vehicle `i` is
    /// ahead of `i + 1`), as is the sender's ([`Packet::sender`]).
    pub receiver: VehicleId,
    /// The receiver's own state `[p, v, a]` at step `k`, from its own sensors.
    pub own: State,
    /// The packet: who sent it, its sequence number and step, the claimed state and command.
    pub packet: &'a Packet,
    /// The last packet accepted from this sender, if any.
    pub last: Option<Last>,
    /// The receiver's radar on the sender, when the sender is its predecessor and the radar
    /// sees it (`None` otherwise).
    pub radar: Option<RadarReading>,
}

impl Observation<'_> {
    /// The sender.
    pub fn sender(&self) -> VehicleId {
        self.packet.sender
    }

    /// Whether the sender is the vehicle just ahead of the receiver.
    pub fn from_predecessor(&self) -> bool {
        self.packet.sender.index() + 1 == self.receiver.index()
    }

    /// How long before the receive step the packet's state was sampled (s; 0 for a packet of
    /// this step or, impossibly, a later one).
    pub fn age_s(&self) -> f64 {
        self.k.saturating_sub(self.packet.step) as f64 * self.dt
    }

    /// The claimed state brought forward to the receive step with its own acceleration
    /// (`p + v t + a t^2 / 2`, `v + a t`, `a`, with `t` = [`Observation::age_s`]).
    pub fn claim_now(&self) -> State {
        predict(&self.packet.state, self.age_s())
    }
}

/// The state `x` after `t` seconds at constant acceleration.
pub(crate) fn predict(x: &State, t: f64) -> State {
    State::new(x[0] + x[1] * t + 0.5 * x[2] * t * t, x[1] + x[2] * t, x[2])
}

/// What a detector says of one observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// Whether the packet looks forged.
    pub flagged: bool,
    /// The test statistic behind the decision (larger: more suspicious), for ROC analysis
    /// offline. Each detector documents its own; NaN when the detector had nothing to test
    /// (no radar reading, no earlier packet), +inf when the observation is not finite.
    pub score: f64,
}

impl Verdict {
    /// Nothing to test: not flagged, score NaN.
    pub const NOT_TESTED: Verdict = Verdict {
        flagged: false,
        score: f64::NAN,
    };

    /// Whether the detector tested anything (the score is not NaN).
    pub fn tested(&self) -> bool {
        !self.score.is_nan()
    }

    /// The verdict of a statistic against a threshold: flagged above it. A NaN statistic (a
    /// non-finite input) is flagged with score +inf.
    pub(crate) fn above(statistic: f64, threshold: f64) -> Verdict {
        if statistic.is_nan() {
            Verdict {
                flagged: true,
                score: f64::INFINITY,
            }
        } else {
            Verdict {
                flagged: statistic > threshold,
                score: statistic,
            }
        }
    }
}

/// A misbehaviour detector: built once per platoon, it sees every packet that the platoon's
/// followers accept (the packet checks first) and keeps whatever per-(receiver, sender) state it
/// needs inside itself.
pub trait Detector: Debug + Send + dyn_clone::DynClone {
    /// Its name, as its `kind` in a [`DetectorSpec`] (`plausibility`, `radar_cross`,
    /// `residual`).
    fn name(&self) -> &'static str;

    /// Inspects one observation.
    fn inspect(&mut self, obs: &Observation) -> Verdict;
}

dyn_clone::clone_trait_object!(Detector);

/// A parameter out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("detection.{detector}.{field} = {value}: {requirement}")]
pub struct ParamError {
    /// The detector (`residual`).
    pub detector: &'static str,
    /// The field at fault (`alpha`).
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What it must be.
    pub requirement: &'static str,
}

/// `Ok` when `ok` holds and `value` is finite, else the error naming the field.
pub(crate) fn check(
    detector: &'static str,
    field: &'static str,
    value: f64,
    ok: bool,
    requirement: &'static str,
) -> Result<(), ParamError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(ParamError {
            detector,
            field,
            value,
            requirement,
        })
    }
}

/// One detector and its parameters, tagged by `kind` (its name).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DetectorSpec {
    /// F2MD's legacy plausibility and consistency checks ([`Plausibility`]).
    Plausibility(PlausibilityParams),
    /// The predecessor's claim against the receiver's radar ([`RadarCross`]).
    RadarCross(RadarCrossParams),
    /// The chi-square test of the claim against a constant-acceleration prediction
    /// ([`Residual`]).
    Residual(ResidualParams),
}

impl DetectorSpec {
    /// The names of the built-in detectors, in the order of [`Detection::specs`].
    pub const NAMES: [&'static str; 3] = [plausibility::NAME, radar::NAME, residual::NAME];

    /// The detector's name (its `kind`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Plausibility(_) => plausibility::NAME,
            Self::RadarCross(_) => radar::NAME,
            Self::Residual(_) => residual::NAME,
        }
    }

    /// Checks the parameters; the error names the field at fault.
    pub fn validate(&self) -> Result<(), ParamError> {
        match self {
            Self::Plausibility(p) => p.validate(),
            Self::RadarCross(p) => p.validate(),
            Self::Residual(p) => p.validate(),
        }
    }
}

/// The detector a spec names, with its parameters checked.
pub fn build(spec: &DetectorSpec) -> Result<Box<dyn Detector>, ParamError> {
    Ok(match spec {
        DetectorSpec::Plausibility(p) => Box::new(Plausibility::new(*p)?),
        DetectorSpec::RadarCross(p) => Box::new(RadarCross::new(*p)?),
        DetectorSpec::Residual(p) => Box::new(Residual::new(*p)?),
    })
}

/// The detectors of a config as `[detection.<name>]` tables: each present table turns its
/// detector on (an empty table: with the defaults).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct Detection {
    /// `[detection.plausibility]`: F2MD's legacy checks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plausibility: Option<PlausibilityParams>,
    /// `[detection.radar_cross]`: the predecessor's claim against the radar.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radar_cross: Option<RadarCrossParams>,
    /// `[detection.residual]`: the chi-square test against a constant-acceleration prediction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<ResidualParams>,
}

impl Detection {
    /// The detectors turned on, in the order plausibility, radar_cross, residual.
    pub fn specs(&self) -> Vec<DetectorSpec> {
        let mut specs = Vec::new();
        if let Some(p) = self.plausibility {
            specs.push(DetectorSpec::Plausibility(p));
        }
        if let Some(p) = self.radar_cross {
            specs.push(DetectorSpec::RadarCross(p));
        }
        if let Some(p) = self.residual {
            specs.push(DetectorSpec::Residual(p));
        }
        specs
    }

    /// Whether no detector is on.
    pub fn is_empty(&self) -> bool {
        self.specs().is_empty()
    }

    /// Checks every table; the error names the detector and field at fault.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.specs().iter().try_for_each(DetectorSpec::validate)
    }
}

/// Several detectors run on every observation, in order.
#[derive(Debug, Clone, Default)]
pub struct Detectors(Vec<Box<dyn Detector>>);

impl Detectors {
    /// These detectors.
    pub fn new(detectors: Vec<Box<dyn Detector>>) -> Self {
        Self(detectors)
    }

    /// The detectors the specs name, in their order.
    pub fn from_specs(specs: &[DetectorSpec]) -> Result<Self, ParamError> {
        specs.iter().map(build).collect::<Result<_, _>>().map(Self)
    }

    /// Adds one at the end.
    pub fn push(&mut self, detector: Box<dyn Detector>) {
        self.0.push(detector);
    }

    /// How many there are.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Their names, in order (the order of [`Detectors::inspect_all`]'s verdicts).
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.0.iter().map(|d| d.name())
    }

    /// Every detector's verdict on `obs`, in order, into `out` (cleared first; no allocation
    /// once `out` has grown to [`Detectors::len`]). Returns whether any flagged it.
    pub fn inspect_all(&mut self, obs: &Observation, out: &mut Vec<Verdict>) -> bool {
        out.clear();
        out.extend(self.0.iter_mut().map(|d| d.inspect(obs)));
        out.iter().any(|v| v.flagged)
    }
}

impl TryFrom<&Detection> for Detectors {
    type Error = ParamError;

    fn try_from(d: &Detection) -> Result<Self, ParamError> {
        Self::from_specs(&d.specs())
    }
}
