//! The event-based distributed platoon controller of Han et al. (2024), as a pure library.
//!
//! For each follower `i` it holds the open-loop estimators (2) of itself and of every vehicle it
//! receives from, computes the neighbourhood tracking error
//!
//! ```text
//! q_i = sum_j a_ij (x^_i - x^_j - l_ij) + h_i (x^_i - x^_0 - l_i0),   l_ij = [(j - i) l, 0, 0]
//! ```
//!
//! (the spacing sign of docs/paper-readings.md#R3: follower i sits i*l behind the leader),
//! applies the control law (1) with the sign of reading R1, `u_i = -K q_i`, and decides when
//! `i` broadcasts with one of the [`TriggerRule`]s, optionally wrapped in the resilient
//! mechanism (11).
//!
//! One co-simulation step `k` is two calls, so that a network (in process or across processes)
//! can sit in between:
//!
//! 1. [`Controller::transmit`]: every vehicle checks its triggering rule on its current
//!    estimates; the packets of those that fire (and the leader's) are returned.
//! 2. [`Controller::receive`]: the packets that the network delivered reset the receivers'
//!    estimators; each follower computes `u_i[k]`, updates its internal variable `theta_i`, and
//!    all estimators advance to step `k + 1`.
//!
//! The paper's law ([`PaperLaw`]) and the field's ([`laws`]) run on one follower pipeline,
//! [`ComposedController`]: maneuvers, the split behind a car that cut in, detectors and
//! fallbacks are written once and every law has them.
#![warn(missing_docs)]

mod build;
mod catalogue;
pub mod checks;
pub mod composed;
pub mod fallback;
pub mod formation_loop;
pub mod group_key;
pub mod laws;
pub mod maneuvers;
mod paper;
mod radar;
mod room;
pub mod screening;
pub mod seam;
pub mod security;
mod spacing;
mod trigger;

pub use build::{build, build_with, check_topology};
pub use catalogue::{LawName, LawParams, PaperParams};
pub use checks::{PacketChecks, RefusedBy, RejectCounts, PLAUSIBLE_ACCEL};
pub use composed::{Beaconing, ComposedController, Composition, Law, Periodic, Triggering, View};
pub use fallback::{FallbackMode, FallbackParams, Mode, Role, Status, UnknownStatus};
pub use maneuvers::{JoinSpec, LeaveSpec, ManeuverParams, MergeSpec, SplitSpec};
pub use paper::PaperLaw;
pub use screening::{DetectionParams, Inspection, Reaction};
pub use seam::{Controller, FollowerStep};
pub use security::{CryptoClock, CryptoTime, SealCounts, SecurityParams, SecurityPolicy};
pub use spacing::SpacingPolicy;
pub use trigger::{CamRule, ControllerParams, ParamsError, TriggerRule};

pub use platoon_v2v::{Delivery, Packet};
