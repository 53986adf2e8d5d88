//! The parts a user swaps in the one follower pipeline: what a law sees ([`View`]), the law
//! ([`Law`], with the hooks an estimating, event-triggered law such as the paper's needs), a
//! law's own triggering ([`Triggering`]), the beaconing of the others ([`Beaconing`],
//! [`Periodic`], ETSI's CAM rules) and the rest of a [`Composition`].
use crate::checks::Heard;
use crate::fallback::{RadarTruth, Return};
use crate::{FallbackParams, Packet};
use platoon_model::{State, VehicleId};
use platoon_topology::Topology;

/// What one follower knows when its law decides at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The step.
    pub k: u64,
    /// The step length (s).
    pub dt: f64,
    /// The follower (1-based).
    pub id: VehicleId,
    /// Vehicles in its platoon, the leader included.
    pub vehicles: usize,
    /// Its own measured state `[p, v, a]` (p: front bumper).
    pub own: State,
    /// Its own command of the step before (m/s^2).
    pub last_u: f64,
    /// What an ideal radar sees of the vehicle ahead (bumper-to-bumper gap, closing speed), as
    /// the plant measured it (`None`: nothing ahead). After a member ahead left, the gap less
    /// the room still to close (`[maneuvers]`): the law closes it gradually.
    pub radar: Option<RadarTruth>,
    /// The member it follows: the vehicle ahead of it (`id - 1`), or, after members ahead of
    /// it left, the member ahead of it in the formation.
    pub ahead: VehicleId,
    /// The last packet accepted from `ahead` (in a platoon that negotiates maneuvers, from
    /// whichever member it is, a neighbour in the graph or not).
    pub ahead_heard: Option<&'a Heard>,
    /// Who it hears from, in the order of `heard`.
    pub neighbours: &'a [VehicleId],
    /// The last packet accepted from each neighbour (at first the initial state).
    pub heard: &'a [Heard],
    /// The member that heads its part of a split platoon (`[fallback.cut_in] split`), with
    /// the last packet accepted from it; `None` while the platoon's leader heads it.
    pub head: Option<(VehicleId, &'a Heard)>,
    /// Its part of the platoon, members in road order from the head it follows, when that is
    /// not the platoon it started in: in a platoon that negotiates maneuvers, its copy of the
    /// formation (from the head of its part); while a member ahead heads the part split
    /// behind a cut-in, that member and everyone behind it. `None`: the platoon as it started,
    /// the leader at its head.
    pub part: Option<&'a [VehicleId]>,
    /// The room it keeps beyond its law's to every vehicle ahead of it while a room offset
    /// moves (`[maneuvers]`: a gap it opens for a joiner, room left by a member that left, or
    /// given to one that moved in), as `[gap (m), its rate (m/s), its rate's rate (m/s^2)]`:
    /// what `radar` and `ahead_heard` are already shifted by, for a law that reads vehicles
    /// ahead by other means (zero otherwise).
    pub room: State,
}

impl View<'_> {
    /// The last packet accepted from vehicle `j`, if `j` is a neighbour.
    pub fn from(&self, j: VehicleId) -> Option<&Heard> {
        self.neighbours
            .iter()
            .position(|&n| n == j)
            .map(|s| &self.heard[s])
    }

    /// The last packet accepted from the member it follows ([`View::ahead`]), if it hears it.
    pub fn predecessor(&self) -> Option<&Heard> {
        self.ahead_heard
    }

    /// The last packet accepted from its leader: the member that heads its part of a split
    /// platoon ([`View::head`]), else the platoon's leader if it is a neighbour.
    pub fn leader(&self) -> Option<&Heard> {
        match self.head {
            Some((_, h)) => Some(h),
            None => self.from(VehicleId::LEADER),
        }
    }
}

/// A control law: a follower's command from what it knows. Pure: no I/O, no clocks; the same
/// views give the same commands.
///
/// Each follower runs its own clone. Only [`Law::command`] is required; the other methods
/// are hooks with defaults for a law that keeps state of its own between packets (the paper's
/// estimators, [`crate::PaperLaw`]) or decides itself when its follower broadcasts
/// ([`Law::triggering`]).
pub trait Law: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// The command `u_i[k]` (m/s^2).
    fn command(&mut self, view: &View<'_>) -> f64;

    /// Whether it reads V2V packets at all: a law on the radar alone (an ACC) is never
    /// affected by a jammed channel, so it never falls back.
    fn uses_v2v(&self) -> bool {
        true
    }

    /// Once, before the first step: this clone is follower `id`'s, in `topology`, hearing
    /// `heard` (the slots of [`Law::heard`], the graph's neighbours first), all starting from
    /// `initial` (leader first).
    fn start(
        &mut self,
        id: VehicleId,
        topology: &Topology,
        heard: &[VehicleId],
        initial: &[State],
    ) {
        let _ = (id, topology, heard, initial);
    }

    /// How it comes back from a fallback: blending commands (the default), or offsetting its
    /// spacing reference ([`Return::SpacingOffset`], which needs [`Law::tracking_error`] and
    /// [`Law::command_offset`]).
    fn way_back(&self) -> Return {
        Return::CommandBlend
    }

    /// Its tracking error `q` at the last [`Law::command`] (zero for a law without one).
    fn tracking_error(&self) -> State {
        State::zeros()
    }

    /// The last command's law with its spacing reference offset by `offset` (called only with
    /// [`Return::SpacingOffset`]; by default the offset is ignored).
    fn command_offset(&mut self, offset: State) -> f64 {
        let _ = offset;
        0.0
    }

    /// At step `k` its follower's checks accepted `packet`, from the vehicle at `slot` among
    /// those it hears.
    fn heard(&mut self, k: u64, slot: usize, packet: &Packet) {
        let _ = (k, slot, packet);
    }

    /// The end of the step: whatever it predicts moves on to the next one.
    fn end_step(&mut self) {}

    /// Its own triggering, when it decides from its own state when its follower broadcasts
    /// (the [`Beaconing`] of the [`Composition`] is then not asked).
    fn triggering(&mut self) -> Option<&mut dyn Triggering> {
        None
    }
}

dyn_clone::clone_trait_object!(Law);

/// When a law's follower broadcasts, decided on the law's own state (the paper's event
/// triggers on its estimates, with the resilient mechanism (11)).
pub trait Triggering {
    /// Its internal variable (`theta_i`; 0 for rules without one).
    fn theta(&self) -> f64;

    /// Whether it broadcasts at step `k` with the true state `x`, its spacing reference
    /// offset by `offset` (on the way back from a fallback) and the part it follows (as in
    /// [`View::part`]).
    fn fires(&mut self, k: u64, x: &State, offset: State, part: Option<&[VehicleId]>) -> bool;

    /// It broadcast `x` at step `k`.
    fn sent(&mut self, k: u64, x: &State);

    /// At step `k`, after it broadcast (`triggered`) or not, with its channel `jammed` or not:
    /// whether it counts itself attacked.
    fn attacked(&mut self, k: u64, triggered: bool, jammed: bool) -> bool;

    /// After the step's command, at the true state `x`, `affected` or not, with the spacing
    /// offset the way back left.
    fn settle(&mut self, x: &State, affected: bool, offset: State);
}

/// When a follower broadcasts: a part of a [`crate::ComposedController`] of its own, so a
/// triggering scheme can be tried with any law. Pure, like a [`Law`].
pub trait Beaconing: std::fmt::Debug + Send + dyn_clone::DynClone {
    /// Whether follower `id` broadcasts at step `k`, with its state `own` now and what it last
    /// broadcast (`(step, state)`, `None` before its first).
    fn fires(&mut self, k: u64, id: VehicleId, own: &State, last: Option<(u64, &State)>) -> bool;
}

dyn_clone::clone_trait_object!(Beaconing);

/// Every follower broadcasts every `steps` steps, from step 0 (CAM-like beacons).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Periodic {
    /// The period in steps, >= 1.
    pub steps: u32,
}

impl Beaconing for Periodic {
    fn fires(&mut self, k: u64, _: VehicleId, _: &State, _: Option<(u64, &State)>) -> bool {
        k.is_multiple_of(u64::from(self.steps.max(1)))
    }
}

/// ETSI's CAM rules as beacons (the first at step 0).
impl Beaconing for crate::CamRule {
    fn fires(&mut self, k: u64, _: VehicleId, own: &State, last: Option<(u64, &State)>) -> bool {
        last.is_none_or(|(step, x)| crate::CamRule::fires(self, k - step, own, x))
    }
}

/// The parts a [`crate::ComposedController`] is made of besides its law.
#[derive(Debug, Clone)]
pub struct Composition {
    /// Step length (s).
    pub dt: f64,
    /// When followers broadcast (e.g. [`Periodic`]), unless the law triggers itself.
    pub beaconing: Box<dyn Beaconing>,
    /// The leader broadcasts every this many steps.
    pub leader_broadcast_steps: u32,
    /// The platoon's spacing `l` (m, front to front): the `acc` fallback keeps `l + h v`...
    pub spacing: f64,
    /// ...with `h` never below the platoon's own time headway (s; 0 for constant spacing).
    pub headway: f64,
    /// What a follower does while affected, and how it comes back (`closing_mps` is used by
    /// a law that returns by a spacing offset, and by the room offsets of maneuvers).
    pub fallback: FallbackParams,
    /// Misbehaviour detection in the receive path (off by default).
    pub detection: crate::DetectionParams,
    /// The platoon's maneuvers (`[maneuvers]`: joins at the tail; none by default).
    pub maneuvers: Option<crate::ManeuverParams>,
    /// Signed V2V (`[security]`; none by default): every vehicle signs its broadcasts, every
    /// receiver checks their seals ([`crate::security`]).
    pub security: Option<crate::SecurityParams>,
}
