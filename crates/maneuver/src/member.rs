//! A member's side: it keeps its copy of the formation from the leader's updates, opens a gap
//! when asked and leaves when it wants to.
use crate::message::Outbox;
use crate::{Body, Change, Formation, Message, SeqFilter, Timing};
use platoon_model::VehicleId;

/// What a member is doing besides following.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MemberState {
    /// Following under the platoon's law.
    Following,
    /// Opening a gap ahead of it for `joiner`.
    Opening {
        /// Whom the gap is for.
        joiner: VehicleId,
        /// When it closes the gap again if nothing happened.
        deadline: u64,
        /// How many times it told the leader the gap is open (again every reply time while the
        /// leader's update does not come, up to the tries: a lost report would otherwise leave
        /// the joiner waiting beside an open gap until the deadline).
        reports: u32,
        /// When it tells it again.
        report_at: u64,
    },
    /// Asked to leave; waiting for the leader's update.
    Leaving {
        /// When it asks again if no update came.
        ask_at: u64,
        /// Leave notices sent so far.
        asks: u32,
    },
    /// Told the leader it heads the members behind it off; waiting for the update.
    Splitting {
        /// When it tells it again if no update came.
        ask_at: u64,
        /// Split notices sent so far.
        asks: u32,
    },
    /// No longer a member (its leave was announced).
    Left,
}

/// A member's state machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Member {
    me: VehicleId,
    formation: Formation,
    generation: u16,
    timing: Timing,
    state: MemberState,
    filter: SeqFilter,
    outbox: Outbox,
    /// Whether its copy took on another platoon's numbering (its own merged into that one).
    adopted: bool,
    /// The member the leader asked to open a gap (its "open gap" heard on the way to that
    /// member), until the join's deadline, an abort or the update that admits the joiner.
    opener: Option<(VehicleId, u64)>,
}

impl Member {
    /// Member `me` of `formation` (generation 0, as the run starts).
    pub fn new(me: VehicleId, formation: Formation, timing: Timing) -> Self {
        Self::joined(me, formation, 0, timing)
    }

    /// Member `me` of `formation` as of the leader's update `generation` (a joiner once
    /// admitted).
    pub fn joined(me: VehicleId, formation: Formation, generation: u16, timing: Timing) -> Self {
        Self {
            me,
            formation,
            generation,
            timing,
            state: MemberState::Following,
            filter: SeqFilter::default(),
            outbox: Outbox::default(),
            adopted: false,
            opener: None,
        }
    }

    /// Its copy of the formation.
    pub fn formation(&self) -> &Formation {
        &self.formation
    }

    /// The generation of its copy.
    pub fn generation(&self) -> u16 {
        self.generation
    }

    /// What it is doing.
    pub fn state(&self) -> MemberState {
        self.state
    }

    /// Whom it opens a gap for, if it does (its controller adds a vehicle's room to its
    /// spacing).
    pub fn opening_for(&self) -> Option<VehicleId> {
        match self.state {
            MemberState::Opening { joiner, .. } => Some(joiner),
            _ => None,
        }
    }

    /// The member the leader asked to open a gap for a joiner, as this member heard it (the
    /// leader's "open gap" to that member), while the join lasts: until the update that admits
    /// the joiner, an abort, or the join's deadline.
    pub fn opener(&self) -> Option<VehicleId> {
        self.opener.map(|(o, _)| o)
    }

    /// Asks the leader to leave at `step`. It asks again every reply time while no update
    /// names it, up to the tries; then it stays (a leave the leader never heard of must not
    /// take a member out of the formation the others follow).
    pub fn leave(&mut self, step: u64, out: &mut Vec<Message>) {
        if matches!(
            self.state,
            MemberState::Following | MemberState::Opening { .. }
        ) {
            self.send(out, Body::LeaveNotice);
            self.state = MemberState::Leaving {
                ask_at: step.saturating_add(self.timing.reply_steps),
                asks: 1,
            };
        }
    }

    /// Tells the leader at `step` that it heads the members behind it off as a platoon of
    /// their own; again every reply time while no update says so, up to the tries, then it
    /// stays a member.
    pub fn split(&mut self, step: u64, out: &mut Vec<Message>) {
        if matches!(
            self.state,
            MemberState::Following | MemberState::Opening { .. }
        ) {
            self.send(out, Body::SplitNotice);
            self.state = MemberState::Splitting {
                ask_at: step.saturating_add(self.timing.reply_steps),
                asks: 1,
            };
        }
    }

    /// Whether it heads a platoon of its own (it split off, or heads a platoon that has not
    /// merged).
    pub fn heads(&self) -> bool {
        self.formation.head() == self.me
    }

    /// Whether its leave is announced: it is out of the formation.
    pub fn has_left(&self) -> bool {
        self.state == MemberState::Left
    }

    fn send(&mut self, out: &mut Vec<Message>, body: Body) {
        let leader = self.formation.head();
        self.outbox.send(out, self.me, leader, body);
    }

    /// The places in the last step's inbox of the leader's messages for it that its sequence
    /// filter dropped as old.
    pub fn dropped_as_old(&self) -> &[usize] {
        self.filter.dropped()
    }

    /// One step: acts on `inbox` (everything received, in order); `gap_open` is its
    /// controller's judgement that the gap it opens is wide enough. Appends what it sends.
    pub fn step(&mut self, step: u64, inbox: &[Message], gap_open: bool, out: &mut Vec<Message>) {
        let leader = self.formation.head();
        if self.opener.is_some_and(|(_, until)| step >= until) {
            self.opener = None;
        }
        self.filter.begin_step();
        for (i, m) in inbox.iter().enumerate() {
            if m.sender != leader {
                continue;
            }
            if m.is_for(self.me) {
                if self.filter.fresh_in(i, m) {
                    self.handle(step, m);
                }
            } else if let Body::OpenGap { .. } = m.body {
                // Overheard: who opens a gap ahead of or behind it.
                self.opener = Some((m.to, step.saturating_add(self.timing.maneuver_steps)));
            }
        }
        if let MemberState::Opening {
            joiner,
            deadline,
            reports,
            report_at,
        } = self.state
        {
            if step >= deadline {
                self.state = MemberState::Following;
            } else if gap_open && reports < self.timing.tries && step >= report_at {
                self.send(out, Body::GapReady { joiner });
                self.state = MemberState::Opening {
                    joiner,
                    deadline,
                    reports: reports + 1,
                    report_at: step.saturating_add(self.timing.reply_steps),
                };
            }
        }
        let asking = match self.state {
            MemberState::Leaving { ask_at, asks } => Some((ask_at, asks, Body::LeaveNotice)),
            MemberState::Splitting { ask_at, asks } => Some((ask_at, asks, Body::SplitNotice)),
            _ => None,
        };
        if let Some((ask_at, asks, body)) = asking {
            if step >= ask_at {
                self.state = if asks < self.timing.tries {
                    self.send(out, body);
                    let (ask_at, asks) = (step.saturating_add(self.timing.reply_steps), asks + 1);
                    match body {
                        Body::SplitNotice => MemberState::Splitting { ask_at, asks },
                        _ => MemberState::Leaving { ask_at, asks },
                    }
                } else {
                    // No update: the leader may never have heard it; it stays a member.
                    MemberState::Following
                };
            }
        }
    }

    fn handle(&mut self, step: u64, m: &Message) {
        match m.body {
            Body::OpenGap { joiner } if self.opening_for() == Some(joiner) => {
                // Asked again: the leader missed its report.
                if let MemberState::Opening {
                    joiner, deadline, ..
                } = self.state
                {
                    self.state = MemberState::Opening {
                        joiner,
                        deadline,
                        reports: 0,
                        report_at: step,
                    };
                }
            }
            Body::OpenGap { joiner } if self.state == MemberState::Following => {
                self.state = MemberState::Opening {
                    joiner,
                    deadline: step.saturating_add(self.timing.maneuver_steps),
                    reports: 0,
                    report_at: step,
                };
            }
            Body::Update { generation, change } => {
                if let Change::Joined { .. } = change {
                    self.opener = None;
                }
                self.update(generation, change)
            }
            Body::Abort { joiner } => {
                self.opener = None;
                if self.opening_for() == Some(joiner) {
                    self.state = MemberState::Following;
                }
            }
            _ => {}
        }
    }

    /// Applies the leader's update if it is the next one: so the copy is always a formation the
    /// leader had. An older one is in already; a later one means one was missed, and the copy
    /// stays as it is ([`Member::generation`] behind the leader's, which its beacons carry).
    fn update(&mut self, generation: u16, change: Change) {
        // The merge of its own platoon, passed on by its head, is numbered in the other
        // platoon's changes: the copy takes that numbering on, and that platoon's leader (once:
        // from then on its updates come in order like any other).
        let into_another = !self.adopted
            && matches!(change, Change::Merged { head, .. } if head == self.formation.head());
        if generation != self.generation.wrapping_add(1) && !into_another {
            return;
        }
        let Ok(next) = self.formation.apply(change, self.me) else {
            return;
        };
        self.formation = next;
        self.generation = generation;
        self.adopted |= into_another;
        match change {
            Change::Joined { vehicle, .. } if self.opening_for() == Some(vehicle) => {
                self.state = MemberState::Following;
            }
            Change::Left { vehicle } if vehicle == self.me => self.state = MemberState::Left,
            Change::Split { head } if head == self.me => self.state = MemberState::Following,
            _ => {}
        }
    }
}
