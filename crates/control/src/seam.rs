//! The boundary every front-end drives: one platoon's follower controllers, whatever law,
//! triggering or fallback they use.
//!
//! A co-simulation step `k` is two calls with the network in between (the module docs of the
//! crate): [`Controller::transmit`] decides who broadcasts, [`Controller::receive`] takes what
//! the network delivered and returns every follower's command. Between them the caller may give
//! the plant's radar view ([`Controller::set_radar_truth`]). After `receive`,
//! [`Controller::follower_step`] reports what each follower did, for the outputs, and
//! [`Controller::rejected`] how many packets its checks refused.
//!
//! Implementations are pure and deterministic: the same calls give the same results bit for
//! bit, whoever makes them (the in-process runner and the iceoryx2 controller node). The
//! built-in one is the pipeline every law runs on, [`crate::ComposedController`];
//! [`crate::build`] makes the one a [`crate::ControllerParams`] names.

use crate::fallback::RadarTruth;
use crate::fallback::{Role, Status};
use crate::{Delivery, Mode, Packet, PacketChecks, RejectCounts};
use platoon_model::{State, VehicleId};

/// What one follower did in a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FollowerStep {
    /// It broadcast its state in this step.
    pub triggered: bool,
    /// It was affected by an attack (`A*`): its fallback applies, theta frozen.
    pub affected: bool,
    /// The command `u_i[k]`.
    pub u: f64,
    /// `theta_i` at the start of the step (0 for rules without one).
    pub theta: f64,
    /// How its command was computed: cooperative law, a fallback, or blending back.
    pub mode: Mode,
    /// Where it stands in the platoon (a member but with `[maneuvers]`).
    pub role: Role,
    /// The emergency-braking guard overrode the command.
    pub guard: bool,
    /// Whom it took as its leader: the platoon's (the default), or the member heading its part
    /// of a platoon split behind a car that cut in (`[fallback.cut_in] split`).
    pub head: VehicleId,
    /// The misbehaviour authority has revoked its certificates (`[security.reports]`): every
    /// receiver refuses its packets.
    pub revoked: bool,
    /// The misbehaviour authority has revoked its platoon's leader (every follower says it:
    /// the leader has no command of its own to say it in).
    pub leader_revoked: bool,
}

impl FollowerStep {
    /// What the outputs and the wire say it did ([`Status`]).
    pub fn status(&self) -> Status {
        Status::new(self.role, self.mode)
    }
}

/// One platoon's follower controllers behind one boundary (module docs).
pub trait Controller: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// Phase 1 of step `k`: `states[v]` is vehicle v's true state (leader at 0). Appends the
    /// packets broadcast at this step to `out`: the leader's first (if it broadcasts), then the
    /// followers' in order.
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>);

    /// What each vehicle's radar would see in the coming [`receive`](Self::receive) (leader
    /// first), as the plant measured it. Without it, controllers that read a radar take the
    /// platoon's predecessor from the states (what the native plant gives).
    fn set_radar_truth(&mut self, truth: &[Option<RadarTruth>]) {
        let _ = truth;
    }

    /// Phase 2 of step `k`: applies the packets the network delivered (`jammed[v]`: vehicle v
    /// sensed its channel jammed during this step) and returns `u_i[k]` for followers 1..=N
    /// (index i-1).
    fn receive(&mut self, k: u64, states: &[State], rx: &[Delivery], jammed: &[bool]) -> &[f64];

    /// The commands of the last [`receive`](Self::receive), followers 1..=N at index i-1.
    fn commands(&self) -> &[f64];

    /// What follower `i` (1-based) did in the last step.
    fn follower_step(&self, i: VehicleId) -> FollowerStep;

    /// The packet checks it runs, if it runs [`PacketChecks`]: what the methods below report
    /// by default (nothing without them).
    fn checks(&self) -> Option<&PacketChecks> {
        None
    }

    /// Packets refused so far, by reason.
    fn rejected(&self) -> RejectCounts {
        self.checks()
            .map(PacketChecks::rejected)
            .unwrap_or_default()
    }

    /// What the seals of signed V2V did so far (`[security]` only): packets signed,
    /// signatures verified, refusals by reason.
    fn seals(&self) -> Option<crate::SealCounts> {
        self.checks().and_then(PacketChecks::seals)
    }

    /// Lends the seals of signed V2V the runtime's `clock` to time their cryptography with
    /// ([`Controller::crypto_time`]; `[security]` only). Nothing by default: a controller
    /// without seals has nothing to time, and the clock never changes what it computes.
    fn time_crypto(&mut self, clock: crate::CryptoClock) {
        let _ = clock;
    }

    /// The time its seals spent signing and verifying so far, by the clock of
    /// [`Controller::time_crypto`] (`[security]` only; 0 without a clock).
    fn crypto_time(&self) -> Option<crate::CryptoTime> {
        self.checks().and_then(PacketChecks::crypto_time)
    }

    /// What the misbehaviour detectors said of each packet of the last
    /// [`receive`](Self::receive) (`[detection]`; empty without detectors).
    fn inspections(&self) -> &[crate::Inspection] {
        self.checks().map_or(&[], PacketChecks::inspections)
    }

    /// The detectors' names, in the order of every inspection's verdicts.
    fn detector_names(&self) -> &[&'static str] {
        self.checks().map_or(&[], PacketChecks::detector_names)
    }

    /// Packets the detectors saw, flagged and had refused so far.
    fn screened(&self) -> crate::screening::ScreenCounts {
        self.checks()
            .map(PacketChecks::screened)
            .unwrap_or_default()
    }
}

dyn_clone::clone_trait_object!(Controller);
