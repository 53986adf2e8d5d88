//! Platoon maneuvers as a protocol over V2V: who is in the platoon ([`Formation`]), the
//! messages of a join and a leave ([`Message`]: sequence-numbered, unicast to the leader or
//! broadcast by it) and the state machines of the three roles, each driven one step at a time
//! with what its vehicle received: the [`Leader`] (it owns the formation, admits one join at a
//! time, calls a join off at its deadline, announces every change a few times), the [`Joiner`]
//! (asks again while unanswered, approaches its slot, reports in position, becomes a member on
//! the update that names it) and every [`Member`] (its copy of the formation, a gap opened on
//! request, a leave).
//!
//! The maneuvers follow Plexe's join (request, the member behind the slot opens a gap, the
//! joiner moves in, the formation is announced) and VENTOS's leave. Nothing here moves a
//! vehicle: each machine says what its controller does (outside, approaching, opening a gap,
//! a member) and is told what the controller judged (in position, gap open). Pure: no I/O, no
//! clocks, time in steps.
#![warn(missing_docs)]

pub mod challenge;
mod formation;
mod joiner;
mod leader;
mod member;
mod message;

pub use challenge::{Challenge, ChallengeSpec, Verdict};
pub use formation::{Formation, FormationError};
pub use joiner::{JoinFailure, Joiner, JoinerPhase, JoinerState};
pub use leader::{Leader, LeaderState};
pub use member::{Member, MemberState};
pub use message::{Body, Change, Message, MessageKind, Refusal, SeqFilter, EVERYONE};

/// The protocol's timing, in steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// How long a sender waits for an answer before it asks again, and the spacing of the
    /// leader's repeats of an update.
    pub reply_steps: u64,
    /// How many times a message that wants an answer is sent (and an update announced) at
    /// most.
    pub tries: u32,
    /// How long a join may take from its accept: then the leader calls it off, the opener
    /// closes its gap and the joiner gives up.
    pub maneuver_steps: u64,
}

impl Timing {
    /// Plexe-like defaults at a step of `dt` seconds: answers within 0.5 s, 3 tries, a join
    /// within 30 s.
    pub fn with_step(dt: f64) -> Self {
        let steps = |s: f64| (s / dt).round().max(1.0) as u64;
        Self {
            reply_steps: steps(0.5),
            tries: 3,
            maneuver_steps: steps(30.0),
        }
    }
}
