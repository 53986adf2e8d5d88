//! The leader's side: it owns the formation, admits one join at a time and announces every
//! change.
use crate::message::Outbox;
use crate::{Body, Change, Formation, Message, Refusal, SeqFilter, Timing, EVERYONE};
use platoon_model::VehicleId;

/// What the leader is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LeaderState {
    /// No maneuver under way.
    Idle,
    /// A join is under way.
    Joining {
        /// Who joins.
        joiner: VehicleId,
        /// The member it will follow.
        behind: VehicleId,
        /// The member behind the slot, which opens the gap (none at the tail).
        opener: Option<VehicleId>,
        /// Whether the opener said its gap is open.
        gap_ready: bool,
        /// The step at which the leader calls the join off.
        deadline: u64,
        /// When it asks again for the step the join waits on (the gap, the move in), and
        /// how many times it has asked.
        ask_at: u64,
        /// Requests for that step sent so far.
        asks: u32,
        /// A merge: the last vehicle of the platoon the joiner heads.
        tail: Option<VehicleId>,
    },
}

/// The leader's state machine (the platoon manager of Plexe's and VENTOS's maneuvers).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Leader {
    formation: Formation,
    generation: u16,
    max_members: usize,
    timing: Timing,
    state: LeaderState,
    filter: SeqFilter,
    outbox: Outbox,
    /// The last update, and the steps at which it is sent again.
    last_update: Option<(Change, u16)>,
    /// The head of the last platoon that merged into this one, until the step by which it
    /// would have withdrawn had it missed the update.
    merged: Option<(VehicleId, u64)>,
    repeats_left: u32,
    next_repeat: u64,
}

impl Leader {
    /// The leader of `formation`, admitting members up to `max_members` (the head counted).
    pub fn new(formation: Formation, max_members: usize, timing: Timing) -> Self {
        Self {
            formation,
            generation: 0,
            max_members,
            timing,
            state: LeaderState::Idle,
            filter: SeqFilter::default(),
            outbox: Outbox::default(),
            last_update: None,
            merged: None,
            repeats_left: 0,
            next_repeat: 0,
        }
    }

    /// The formation as the leader knows it: the platoon's own.
    pub fn formation(&self) -> &Formation {
        &self.formation
    }

    /// How many changes the formation has had.
    pub fn generation(&self) -> u16 {
        self.generation
    }

    /// What it is doing.
    pub fn state(&self) -> LeaderState {
        self.state
    }

    fn me(&self) -> VehicleId {
        self.formation.head()
    }

    fn send(&mut self, out: &mut Vec<Message>, to: VehicleId, body: Body) {
        let me = self.me();
        self.outbox.send(out, me, to, body);
    }

    /// Commits `change` and announces it (now and `timing.tries - 1` times more).
    fn commit(&mut self, step: u64, change: Change, out: &mut Vec<Message>) {
        // A change the formation refuses is never announced: the members' copies stay valid.
        let Ok(next) = self.formation.apply(change, self.me()) else {
            return;
        };
        self.formation = next;
        if let Change::Merged { head, .. } = change {
            // Its in-position reports, then its leave notices, each up to the tries.
            let window = self
                .timing
                .reply_steps
                .saturating_mul(2 * u64::from(self.timing.tries) + 1);
            self.merged = Some((head, step.saturating_add(window)));
        }
        self.generation = self.generation.wrapping_add(1);
        self.last_update = Some((change, self.generation));
        self.repeats_left = self.timing.tries.saturating_sub(1);
        self.next_repeat = step.saturating_add(self.timing.reply_steps);
        let generation = self.generation;
        self.send(out, EVERYONE, Body::Update { generation, change });
    }

    /// Sends the last update again (a member that missed it, or asks again).
    fn repeat(&mut self, out: &mut Vec<Message>) {
        if let Some((change, generation)) = self.last_update {
            self.send(out, EVERYONE, Body::Update { generation, change });
        }
    }

    /// The places in the last step's inbox of the messages for it that its sequence filter
    /// dropped as old (a replay, a duplicate, or a message numbered below one it took).
    pub fn dropped_as_old(&self) -> &[usize] {
        self.filter.dropped()
    }

    /// One step: acts on what reached the leader (`inbox`: everything received, in order) and
    /// appends what it sends to `out`.
    pub fn step(&mut self, step: u64, inbox: &[Message], out: &mut Vec<Message>) {
        let me = self.me();
        self.filter.begin_step();
        for (i, m) in inbox.iter().enumerate() {
            if m.is_for(me) && self.filter.fresh_in(i, m) {
                self.handle(step, m, out);
            }
        }
        if let LeaderState::Joining {
            joiner,
            behind,
            opener: Some(opener),
            gap_ready,
            deadline,
            ask_at,
            asks,
            tail,
        } = self.state
        {
            if step < deadline && step >= ask_at && asks < self.timing.tries {
                // A middle join waits on the opener, then on the joiner: ask again.
                self.state = LeaderState::Joining {
                    joiner,
                    behind,
                    opener: Some(opener),
                    gap_ready,
                    deadline,
                    ask_at: step.saturating_add(self.timing.reply_steps),
                    asks: asks + 1,
                    tail,
                };
                match gap_ready {
                    false => self.send(out, opener, Body::OpenGap { joiner }),
                    true => self.send(out, joiner, Body::MoveIn),
                }
            }
        }
        if let LeaderState::Joining {
            joiner, deadline, ..
        } = self.state
        {
            if step >= deadline {
                self.state = LeaderState::Idle;
                self.send(out, EVERYONE, Body::Abort { joiner });
            }
        }
        if self.repeats_left > 0 && step >= self.next_repeat {
            self.repeats_left -= 1;
            self.next_repeat = step.saturating_add(self.timing.reply_steps);
            self.repeat(out);
        }
    }

    /// A platoon asks to merge at the back, numbered on from this one (`Change::Merged`): its
    /// head `from`, the member it asks to follow (`behind`) and its last vehicle (`tail`).
    fn merge_request(
        &mut self,
        step: u64,
        from: VehicleId,
        behind: VehicleId,
        tail: VehicleId,
        out: &mut Vec<Message>,
    ) {
        let size = usize::from(tail.0).saturating_sub(usize::from(from.0)) + 1;
        if self.formation.contains(from) {
            self.refuse(from, Refusal::Member, out);
        } else if self.formation.members().len() + size > self.max_members {
            self.refuse(from, Refusal::Full, out);
        } else if behind != self.formation.tail() || self.formation.merged(from, tail).is_err() {
            self.refuse(from, Refusal::NoSlot, out);
        } else {
            self.state = LeaderState::Joining {
                joiner: from,
                behind,
                opener: None,
                gap_ready: false,
                deadline: step.saturating_add(self.timing.maneuver_steps),
                ask_at: step.saturating_add(self.timing.reply_steps),
                asks: 1,
                tail: Some(tail),
            };
            self.accept_merge(from, behind, out);
        }
    }

    /// `from` asks to join behind `behind`; a join in the middle asks the member there to open
    /// a gap.
    fn join_request(
        &mut self,
        step: u64,
        from: VehicleId,
        behind: VehicleId,
        out: &mut Vec<Message>,
    ) {
        if self.formation.contains(from) {
            self.refuse(from, Refusal::Member, out);
        } else if self.formation.members().len() >= self.max_members {
            self.refuse(from, Refusal::Full, out);
        } else if !self.formation.contains(behind) {
            self.refuse(from, Refusal::NoSlot, out);
        } else {
            let opener = self.formation.successor(behind);
            self.state = LeaderState::Joining {
                joiner: from,
                behind,
                opener,
                gap_ready: false,
                deadline: step.saturating_add(self.timing.maneuver_steps),
                ask_at: step.saturating_add(self.timing.reply_steps),
                asks: 1,
                tail: None,
            };
            let middle = opener.is_some();
            self.send(out, from, Body::JoinAccept { behind, middle });
            if let Some(opener) = opener {
                self.send(out, opener, Body::OpenGap { joiner: from });
            }
        }
    }

    /// Member `from` leaves, or splits off with the members behind it (`split_notice`), while
    /// the leader is in `state`: a join whose slot goes with it is called off first.
    /// Ejects `member` from the platoon at `step` (the misbehaviour authority revoked it): the
    /// formation update of a leave goes to everyone, and the member drives out as a leaver
    /// does. Nothing for the leader itself or a vehicle outside the formation.
    pub fn eject(&mut self, step: u64, member: VehicleId, out: &mut Vec<Message>) {
        if self.formation.contains(member) && member != self.me() {
            let state = self.state;
            self.member_goes(step, member, false, state, out);
        }
    }

    fn member_goes(
        &mut self,
        step: u64,
        from: VehicleId,
        split_notice: bool,
        state: LeaderState,
        out: &mut Vec<Message>,
    ) {
        // A split takes the members from `from` on; so does the withdrawal of the head of a
        // platoon that just merged (its platoon goes with it).
        let withdrawn = self
            .merged
            .is_some_and(|(h, until)| h == from && step <= until);
        let split = split_notice || withdrawn;
        if let LeaderState::Joining {
            joiner,
            behind,
            opener,
            ..
        } = state
        {
            let gone = |v: VehicleId| match split {
                true => self.formation.position(v) >= self.formation.position(from),
                false => v == from,
            };
            if gone(behind) || opener.is_some_and(gone) {
                // The slot goes with the members leaving: the join is called off first.
                self.state = LeaderState::Idle;
                self.send(out, EVERYONE, Body::Abort { joiner });
            }
        }
        let change = match split {
            true => Change::Split { head: from },
            false => Change::Left { vehicle: from },
        };
        self.commit(step, change, out);
    }

    fn handle(&mut self, step: u64, m: &Message, out: &mut Vec<Message>) {
        let from = m.sender;
        match (m.body, self.state) {
            (Body::JoinRequest { behind }, LeaderState::Joining { joiner, opener, .. })
                if joiner == from =>
            {
                // The accept was lost: say it again.
                let middle = opener.is_some();
                self.send(out, from, Body::JoinAccept { behind, middle });
            }
            (Body::MergeRequest { behind, .. }, LeaderState::Joining { joiner, .. })
                if joiner == from =>
            {
                self.accept_merge(from, behind, out);
            }
            (Body::JoinRequest { .. } | Body::MergeRequest { .. }, LeaderState::Joining { .. }) => {
                self.refuse(from, Refusal::Busy, out);
            }
            (Body::MergeRequest { behind, tail }, LeaderState::Idle) => {
                self.merge_request(step, from, behind, tail, out);
            }
            (Body::JoinRequest { behind }, LeaderState::Idle) => {
                self.join_request(step, from, behind, out);
            }
            (
                Body::GapReady { joiner: j },
                LeaderState::Joining {
                    joiner,
                    opener,
                    behind,
                    deadline,
                    gap_ready: false,
                    tail,
                    ..
                },
            ) if j == joiner && opener == Some(from) => {
                self.state = LeaderState::Joining {
                    joiner,
                    behind,
                    opener,
                    gap_ready: true,
                    deadline,
                    ask_at: step.saturating_add(self.timing.reply_steps),
                    asks: 1,
                    tail,
                };
                self.send(out, joiner, Body::MoveIn);
            }
            (
                Body::InPosition,
                LeaderState::Joining {
                    joiner,
                    behind,
                    opener,
                    gap_ready,
                    tail,
                    ..
                },
            ) if joiner == from && (opener.is_none() || gap_ready) => {
                self.state = LeaderState::Idle;
                let change = match tail {
                    Some(tail) => Change::Merged { head: from, tail },
                    None => Change::Joined {
                        vehicle: from,
                        behind,
                    },
                };
                self.commit(step, change, out);
            }
            (Body::InPosition, _) if self.formation.contains(from) => {
                // It joined and missed the update.
                self.repeat(out);
            }
            (Body::InPosition, _) => {
                // A join the leader no longer runs (it timed out): the sender stays out.
                self.send(out, EVERYONE, Body::Abort { joiner: from });
            }
            (Body::LeaveNotice | Body::SplitNotice, state)
                if self.formation.contains(from) && from != self.me() =>
            {
                self.member_goes(step, from, m.body == Body::SplitNotice, state, out);
            }
            (Body::LeaveNotice | Body::SplitNotice, _)
                if self.last_update.is_some_and(|(c, _)| {
                    c == Change::Left { vehicle: from } || c == Change::Split { head: from }
                }) =>
            {
                // It left (or split off) and missed the update: say it again.
                self.repeat(out);
            }
            (Body::LeaveNotice, LeaderState::Joining { joiner, .. }) if joiner == from => {
                // The joiner gave up.
                self.state = LeaderState::Idle;
                self.send(out, EVERYONE, Body::Abort { joiner });
            }
            // Messages for others, late ones and implausible ones (a gap the leader did not
            // ask for, a leave from a stranger) change nothing.
            _ => {}
        }
    }

    /// Accepts `head`'s merge behind `behind`: as a join at the tail.
    fn accept_merge(&mut self, head: VehicleId, behind: VehicleId, out: &mut Vec<Message>) {
        let middle = false;
        self.send(out, head, Body::JoinAccept { behind, middle });
    }

    fn refuse(&mut self, to: VehicleId, reason: Refusal, out: &mut Vec<Message>) {
        self.send(out, to, Body::JoinRefuse { reason });
    }
}
