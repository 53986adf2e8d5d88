//! The joiner's side: a vehicle outside the platoon that asks to join, approaches its slot and
//! becomes a member when the leader announces it.
use crate::message::Outbox;
use crate::{Body, Change, Message, Refusal, SeqFilter, Timing};
use platoon_model::VehicleId;

/// Why a join ended without the joiner in the platoon.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JoinFailure {
    /// The leader refused.
    Refused(Refusal),
    /// The leader did not answer the request (every try timed out).
    NoReply,
    /// The leader called the join off.
    CalledOff,
    /// The join took longer than the maneuver may.
    TimedOut,
    /// The joiner said it was in position and never heard the update (it sent a leave notice).
    NoUpdate,
}

/// What the joiner is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JoinerState {
    /// Not asked yet.
    Idle,
    /// Asked; waiting for the answer.
    Requested {
        /// Requests sent so far.
        tries: u32,
        /// When it asks again (or gives up).
        retry_at: u64,
    },
    /// Accepted in the middle: keeping beside the slot until the gap is open.
    WaitingForGap {
        /// When it gives up.
        deadline: u64,
    },
    /// Accepted (at the tail), or told to move in: driving into its slot.
    Approaching {
        /// When it gives up.
        deadline: u64,
    },
    /// In its slot; waiting for the leader's update.
    InPosition {
        /// Notices sent so far.
        tries: u32,
        /// When it says so again (or gives up).
        retry_at: u64,
    },
    /// It reported in position and heard no update: it withdraws with leave notices (the
    /// leader may have admitted it), then fails with [`JoinFailure::NoUpdate`].
    Withdrawing {
        /// Notices sent so far.
        tries: u32,
        /// When it sends the next (or stops).
        retry_at: u64,
    },
    /// A member: the leader's update of this `generation` admitted it.
    Joined {
        /// The update that admitted it.
        generation: u16,
    },
    /// The join ended without it.
    Failed(JoinFailure),
}

/// What the joiner's controller does in each state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JoinerPhase {
    /// Driving on its own, outside the platoon (asking, waiting, refused, failed).
    Outside,
    /// Driving into its slot behind the member it will follow (not yet hearing it as a member).
    Approaching,
    /// A member under the platoon's law.
    Member,
}

/// The joiner's state machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Joiner {
    me: VehicleId,
    leader: VehicleId,
    behind: VehicleId,
    /// A head merging its platoon: that platoon's last vehicle.
    tail: Option<VehicleId>,
    /// The merge update it passes on to the followers of its platoon, how many more times,
    /// and when next.
    relay: Option<(Body, u32, u64)>,
    timing: Timing,
    state: JoinerState,
    filter: SeqFilter,
    outbox: Outbox,
}

impl Joiner {
    /// Vehicle `me`, which will ask `leader` for the slot behind `behind`.
    pub fn new(me: VehicleId, leader: VehicleId, behind: VehicleId, timing: Timing) -> Self {
        Self {
            me,
            leader,
            behind,
            tail: None,
            relay: None,
            timing,
            state: JoinerState::Idle,
            filter: SeqFilter::default(),
            outbox: Outbox::default(),
        }
    }

    /// The head `me` of a platoon that ends at `tail`, merging it behind `behind` (the tail of
    /// `leader`'s platoon): it asks with [`Body::MergeRequest`] and is admitted by
    /// [`crate::Change::Merged`]; otherwise a join at the tail.
    pub fn merging(
        me: VehicleId,
        leader: VehicleId,
        behind: VehicleId,
        tail: VehicleId,
        timing: Timing,
    ) -> Self {
        Self {
            tail: Some(tail),
            ..Self::new(me, leader, behind, timing)
        }
    }

    /// The last vehicle of the platoon it heads, when it merges one.
    pub fn tail(&self) -> Option<VehicleId> {
        self.tail
    }

    /// What it is doing.
    pub fn state(&self) -> JoinerState {
        self.state
    }

    /// The member it follows (once accepted).
    pub fn behind(&self) -> VehicleId {
        self.behind
    }

    /// What its controller does.
    pub fn phase(&self) -> JoinerPhase {
        match self.state {
            JoinerState::Approaching { .. } | JoinerState::InPosition { .. } => {
                JoinerPhase::Approaching
            }
            JoinerState::Joined { .. } => JoinerPhase::Member,
            _ => JoinerPhase::Outside,
        }
    }

    fn send(&mut self, out: &mut Vec<Message>, body: Body) {
        self.outbox.send(out, self.me, self.leader, body);
    }

    /// Asks to join (at `step`); nothing if it has asked already.
    pub fn request(&mut self, step: u64, out: &mut Vec<Message>) {
        if self.state == JoinerState::Idle {
            self.ask(step, 0, out);
        }
    }

    fn ask(&mut self, step: u64, tries: u32, out: &mut Vec<Message>) {
        let behind = self.behind;
        let body = match self.tail {
            Some(tail) => Body::MergeRequest { behind, tail },
            None => Body::JoinRequest { behind },
        };
        self.send(out, body);
        self.state = JoinerState::Requested {
            tries: tries + 1,
            retry_at: step.saturating_add(self.timing.reply_steps),
        };
    }

    /// The leader may have admitted it: a leave notice takes it out again.
    fn withdraw(&mut self, step: u64, tries: u32, out: &mut Vec<Message>) {
        self.send(out, Body::LeaveNotice);
        self.state = JoinerState::Withdrawing {
            tries: tries + 1,
            retry_at: step.saturating_add(self.timing.reply_steps),
        };
    }

    fn fail(&mut self, why: JoinFailure) {
        self.state = JoinerState::Failed(why);
    }

    /// The places in the last step's inbox of the leader's messages for it that its sequence
    /// filter dropped as old.
    pub fn dropped_as_old(&self) -> &[usize] {
        self.filter.dropped()
    }

    /// One step: acts on `inbox` (everything received, in order); `in_position` is its
    /// controller's judgement that it holds its slot (the gap to the member ahead near the
    /// law's, the speeds matched). Appends what it sends to `out`.
    pub fn step(
        &mut self,
        step: u64,
        inbox: &[Message],
        in_position: bool,
        out: &mut Vec<Message>,
    ) {
        self.filter.begin_step();
        for (i, m) in inbox.iter().enumerate() {
            if m.sender == self.leader && m.is_for(self.me) && self.filter.fresh_in(i, m) {
                self.handle(step, m);
            }
        }
        if let Some((update, left, at)) = self.relay {
            // The head of a merged platoon tells its followers, which hear only their head, as
            // many times as the leader announces a change.
            if step >= at {
                self.outbox.send(out, self.me, crate::EVERYONE, update);
                self.relay = (left > 1).then_some((
                    update,
                    left - 1,
                    step.saturating_add(self.timing.reply_steps),
                ));
            }
        }
        match self.state {
            JoinerState::Requested { tries, retry_at } if step >= retry_at => {
                if tries < self.timing.tries {
                    self.ask(step, tries, out);
                } else {
                    self.fail(JoinFailure::NoReply);
                }
            }
            JoinerState::WaitingForGap { deadline } | JoinerState::Approaching { deadline }
                if step >= deadline =>
            {
                self.fail(JoinFailure::TimedOut);
            }
            JoinerState::Approaching { .. } if in_position => {
                self.send(out, Body::InPosition);
                self.state = JoinerState::InPosition {
                    tries: 1,
                    retry_at: step.saturating_add(self.timing.reply_steps),
                };
            }
            JoinerState::InPosition { tries, retry_at } if step >= retry_at => {
                if tries < self.timing.tries {
                    self.send(out, Body::InPosition);
                    self.state = JoinerState::InPosition {
                        tries: tries + 1,
                        retry_at: step.saturating_add(self.timing.reply_steps),
                    };
                } else {
                    self.withdraw(step, 0, out);
                }
            }
            JoinerState::Withdrawing { tries, retry_at } if step >= retry_at => {
                if tries < self.timing.tries {
                    self.withdraw(step, tries, out);
                } else {
                    self.fail(JoinFailure::NoUpdate);
                }
            }
            _ => {}
        }
    }

    fn handle(&mut self, step: u64, m: &Message) {
        let deadline = step.saturating_add(self.timing.maneuver_steps);
        match (m.body, self.state) {
            (Body::JoinAccept { behind, middle }, JoinerState::Requested { .. })
                if behind == self.behind =>
            {
                self.state = if middle {
                    JoinerState::WaitingForGap { deadline }
                } else {
                    JoinerState::Approaching { deadline }
                };
            }
            (Body::JoinRefuse { reason }, JoinerState::Requested { .. }) => {
                self.fail(JoinFailure::Refused(reason));
            }
            (Body::MoveIn, JoinerState::WaitingForGap { deadline }) => {
                self.state = JoinerState::Approaching { deadline };
            }
            (
                Body::Update {
                    change: Change::Left { vehicle } | Change::Split { head: vehicle },
                    ..
                },
                JoinerState::Withdrawing { .. },
            ) if vehicle == self.me => self.fail(JoinFailure::NoUpdate),
            (Body::Abort { .. }, JoinerState::Joined { .. } | JoinerState::Withdrawing { .. }) => {}
            (Body::Abort { joiner }, s)
                if joiner == self.me && !matches!(s, JoinerState::Failed(_)) =>
            {
                self.fail(JoinFailure::CalledOff);
            }
            (
                Body::Update {
                    generation,
                    change: Change::Joined { vehicle, .. },
                },
                JoinerState::InPosition { .. },
            ) if vehicle == self.me => {
                self.state = JoinerState::Joined { generation };
            }
            (
                Body::Update {
                    generation,
                    change: Change::Merged { head, .. },
                },
                JoinerState::InPosition { .. },
            ) if head == self.me => {
                // Only once in its slot: an update that comes earlier (a forged report, say) is
                // not passed on, so its platoon keeps following it.
                self.state = JoinerState::Joined { generation };
                self.relay = Some((m.body, self.timing.tries, step));
            }
            _ => {}
        }
    }
}
