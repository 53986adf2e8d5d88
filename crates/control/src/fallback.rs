//! Graceful degradation: what a follower does while it is affected by an attack (`A*`), its
//! on-board radar, the way back to cooperative control, and an emergency-braking guard.
//!
//! A follower is in one of the [`Mode`]s at every step. While it is affected it applies its
//! [`FallbackMode`]:
//!
//! - `zero`: `u = 0` (the paper);
//! - `hold`: the last input before the attack;
//! - `predict`: the cooperative law `u = -K q` on the open-loop estimates it already has (no
//!   packets needed; the estimators keep running);
//! - `acc`: adaptive cruise control on its own radar, never on V2V: with the gap `d` to the
//!   vehicle ahead, the closing speed `c = v_i - v_ahead` and a constant time headway `h`,
//!   `u = (lambda e - c) / h` with `e = d + L - l - h_ramp v_i` (Rajamani's CTH law:
//!   `kp = lambda / h`, `kd = 1 / h`), clamped to `[-max_decel, max_accel]`. `h_ramp` grows
//!   from 0 to `h` over `opening_s` after the switch, so the gap opens gently instead of with a
//!   brake step. String stable for the third-order model when `h >= 2 tau`
//!   ([`acc_string_gain`] checks `|G(jw)| <= 1` numerically).
//!
//! Once it is no longer affected it stays in its fallback for `dwell` steps (flapping links do
//! not chatter), then returns to the cooperative law bumplessly: at the hand-over step it
//! offsets its own spacing reference by `delta0 = (u_coop - u_fb) / K_p` (`K_p = K[0]`), so that
//! `u = -K (q + [delta, 0, 0]) = u_coop - K_p delta` equals the fallback's command, and shrinks
//! the offset linearly to 0 over `blend` steps, or more if needed so that it shrinks by at most
//! `closing_mps`. The command then moves by at most `|u_coop - u_fb| / blend` per step on top
//! of the cooperative law's own change, and the vehicle closes (or opens) the gap its fallback
//! left at most at `closing_mps` instead of in one jump of `K_p delta0`.
//!
//! That is the return of the paper's controller ([`Return::SpacingOffset`]); a composed law
//! ([`crate::composed`]) has no spacing reference to offset and blends commands instead
//! ([`Return::CommandBlend`]: the mismatch at the hand-over shrinks linearly to 0 over `blend`
//! steps). Either way one [`FallbackMachine`] per follower walks the way in and back.
//!
//! A cut-in takes the same way: when the radar's target is not the platoon's predecessor (a
//! vehicle from outside the platoon is between them, [`RadarTruth::intruder`]) and the
//! follower has [`CutInParams`], it runs the ACC above on that vehicle (mode
//! [`Mode::CutIn`]), whatever its law and its attack fallback, with the headway growing so the
//! gap opens gently; once the radar sees its predecessor again it stays `dwell` steps, then
//! returns over `blend` steps as from a fallback. An attack takes precedence: while affected the
//! follower runs its attack fallback (with `acc` that is the same vehicle ahead).
//!
//! The guard is independent of the mode: when the radar's time to collision `d / c` (closing
//! only) is below `ttc_s` it commands `min(u, -decel)`.
use serde::{Deserialize, Serialize};

use platoon_model::State;

pub(crate) use crate::radar::Truths;
pub use crate::radar::{radar_truth, Radar, RadarParams, RadarTruth, Reading};

/// What a follower applies while it is affected by an attack (`A*` of the paper).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum FallbackMode {
    /// `u_i = 0`, the paper's choice (Section II-E).
    #[default]
    Zero,
    /// Hold the last input computed before the attack.
    Hold,
    /// Keep applying the law on the open-loop estimates.
    Predict,
    /// Adaptive cruise control on the on-board radar.
    Acc,
}

impl FallbackMode {
    /// The mode this fallback puts a vehicle in.
    pub fn mode(self) -> Mode {
        match self {
            FallbackMode::Zero => Mode::Zero,
            FallbackMode::Hold => Mode::Hold,
            FallbackMode::Predict => Mode::Predict,
            FallbackMode::Acc => Mode::Acc,
        }
    }
}

/// How a follower's command is computed at a step: its law, a fallback, the blend back, or
/// the ACC on a car that cut in. Where it stands in the platoon is its [`Role`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// The cooperative law `u = -K q` (also the leader's row).
    #[default]
    Coop,
    /// Fallback `zero`.
    Zero,
    /// Fallback `hold`.
    Hold,
    /// Fallback `predict`.
    Predict,
    /// Fallback `acc`.
    Acc,
    /// Blending from the fallback back to the cooperative law.
    Blend,
    /// ACC on a vehicle that cut in ahead (not the platoon's predecessor).
    CutIn,
}

impl Mode {
    /// Every mode, in code order.
    pub const ALL: [Mode; 7] = [
        Mode::Coop,
        Mode::Zero,
        Mode::Hold,
        Mode::Predict,
        Mode::Acc,
        Mode::Blend,
        Mode::CutIn,
    ];

    /// Its name in outputs.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Coop => "coop",
            Mode::Zero => "zero",
            Mode::Hold => "hold",
            Mode::Predict => "predict",
            Mode::Acc => "acc",
            Mode::Blend => "blend",
            Mode::CutIn => "cut_in",
        }
    }
}

/// Where a follower stands in its platoon at a step (`[maneuvers]`): how its command is
/// computed is its [`Mode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Role {
    /// A member of the platoon (every follower without maneuvers).
    #[default]
    Member,
    /// Outside the platoon: a joiner on its ACC behind the vehicle it will follow, until the
    /// leader admits it, or a member that split off the members behind it, heading them.
    Outside,
    /// Left the platoon and its lane: it drives on in the next lane at its speed, and the
    /// radars of the lane no longer see it.
    Left,
    /// Outside the platoon in the lane beside it: a joiner waiting for the gap in the middle
    /// opening, then moving up beside it on what it hears; it changes lanes into the gap when
    /// it is in position.
    Beside,
}

impl Role {
    /// Its name in outputs.
    pub fn name(self) -> &'static str {
        match self {
            Role::Member => "member",
            Role::Outside => "outside",
            Role::Left => "left",
            Role::Beside => "beside",
        }
    }

    /// Whether a vehicle in this role drives in the lane beside the platoon's: `left` and
    /// `beside`.
    pub fn is_beside_the_lane(self) -> bool {
        matches!(self, Role::Left | Role::Beside)
    }
}

/// What the outputs and the wire say a follower did at a step (the trajectories' `mode`
/// column, `Command`'s mode code): its command's [`Mode`] while it is a member of the
/// platoon, its [`Role`] otherwise. Compares equal to a `Mode` for a member in that mode, and
/// to a `Role` in that role.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Status {
    role: Role,
    /// `Coop` when not a member: what it is not doing is not told.
    mode: Mode,
}

/// A wire code that names no [`Status`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("mode code {0} names no mode (0-9: coop, zero, hold, predict, acc, blend, cut_in, outside, left, beside)")]
pub struct UnknownStatus(pub u32);

impl Status {
    /// Every status, in code order: the modes of a member, then the roles outside.
    pub const ALL: [Status; 10] = [
        Status::member(Mode::Coop),
        Status::member(Mode::Zero),
        Status::member(Mode::Hold),
        Status::member(Mode::Predict),
        Status::member(Mode::Acc),
        Status::member(Mode::Blend),
        Status::member(Mode::CutIn),
        Status::outside(Role::Outside),
        Status::outside(Role::Left),
        Status::outside(Role::Beside),
    ];

    /// A member in `mode`.
    pub const fn member(mode: Mode) -> Self {
        Self {
            role: Role::Member,
            mode,
        }
    }

    const fn outside(role: Role) -> Self {
        Self {
            role,
            mode: Mode::Coop,
        }
    }

    /// A follower in `role`, its command computed in `mode`.
    pub fn new(role: Role, mode: Mode) -> Self {
        match role {
            Role::Member => Self::member(mode),
            _ => Self::outside(role),
        }
    }

    /// Where it stands.
    pub fn role(self) -> Role {
        self.role
    }

    /// How a member's command is computed (`None` outside the platoon).
    pub fn mode(self) -> Option<Mode> {
        (self.role == Role::Member).then_some(self.mode)
    }

    /// Its code on the wire (4 bits): the mode's (0-6) for a member, else 7 (outside), 8
    /// (left), 9 (beside).
    pub fn code(self) -> u32 {
        match self.role {
            Role::Member => self.mode as u32,
            Role::Outside => 7,
            Role::Left => 8,
            Role::Beside => 9,
        }
    }

    /// The status of a wire code; an unknown code is an error (a plug-in's mistake, never
    /// read as the cooperative law).
    pub fn from_code(code: u32) -> Result<Self, UnknownStatus> {
        Self::ALL
            .get(code as usize)
            .copied()
            .ok_or(UnknownStatus(code))
    }

    /// Its name in outputs.
    pub fn name(self) -> &'static str {
        match self.role {
            Role::Member => self.mode.name(),
            role => role.name(),
        }
    }

    /// Whether it drives in the lane beside the platoon's ([`Role::is_beside_the_lane`]).
    pub fn is_beside_the_lane(self) -> bool {
        self.role.is_beside_the_lane()
    }
}

impl From<Mode> for Status {
    fn from(mode: Mode) -> Self {
        Self::member(mode)
    }
}

impl PartialEq<Mode> for Status {
    fn eq(&self, mode: &Mode) -> bool {
        self.mode() == Some(*mode)
    }
}

impl PartialEq<Role> for Status {
    fn eq(&self, role: &Role) -> bool {
        self.role == *role
    }
}

/// A [`Status`] as outputs hold it: one name of ten (the enum the trajectories' `mode` column
/// has always had, so CSV and Parquet files keep their schema).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename = "Mode", rename_all = "snake_case")]
enum StatusName {
    Coop,
    Zero,
    Hold,
    Predict,
    Acc,
    Blend,
    CutIn,
    Outside,
    Left,
    Beside,
}

impl StatusName {
    const ALL: [StatusName; 10] = [
        StatusName::Coop,
        StatusName::Zero,
        StatusName::Hold,
        StatusName::Predict,
        StatusName::Acc,
        StatusName::Blend,
        StatusName::CutIn,
        StatusName::Outside,
        StatusName::Left,
        StatusName::Beside,
    ];
}

impl From<Status> for StatusName {
    fn from(s: Status) -> Self {
        StatusName::ALL[s.code() as usize]
    }
}

impl From<StatusName> for Status {
    fn from(n: StatusName) -> Self {
        Status::ALL[n as usize]
    }
}

impl Serialize for Status {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        StatusName::from(*self).serialize(s)
    }
}

impl<'de> Deserialize<'de> for Status {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        StatusName::deserialize(d).map(Status::from)
    }
}

/// The ACC fallback's law on the radar's gap and closing speed, `u = (lambda e - c) / h` with
/// `e` the gap's error to `h v` (Rajamani's constant-time-headway law, see
/// `platoon_control::fallback`); `[fallback.acc]` in a config, every key optional.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct AccParams {
    /// Constant time headway h (s), > 0.
    pub headway_s: f64,
    /// lambda: kp = lambda / h (1/s), > 0.
    pub lambda: f64,
    /// Time over which the headway grows from 0 to h after the switch (s), >= 0.
    pub opening_s: f64,
    /// Largest acceleration it commands (m/s^2), > 0.
    pub max_accel_mps2: f64,
    /// Largest deceleration it commands (m/s^2), > 0.
    pub max_decel_mps2: f64,
}

impl Default for AccParams {
    /// h = 2 s (string stable for tau up to 1 s, which covers the paper's 0.34-0.82 s), lambda
    /// = 0.2, the gap opened over 10 s, within +-3.5 m/s^2 (comfort braking).
    fn default() -> Self {
        Self {
            headway_s: 2.0,
            lambda: 0.2,
            opening_s: 10.0,
            max_accel_mps2: 2.0,
            max_decel_mps2: 3.5,
        }
    }
}

/// The emergency-braking guard.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GuardParams {
    /// It brakes when the radar's time to collision is below this (s), > 0.
    pub ttc_s: f64,
    /// With this deceleration (m/s^2), > 0.
    pub decel_mps2: f64,
}

impl GuardParams {
    /// The guard on a command: with the radar's `reading` closing in faster than `ttc_s`, at
    /// most `-decel_mps2`. Returns the command and whether the guard overrode it.
    pub fn apply(guard: Option<&GuardParams>, reading: Option<Reading>, u: f64) -> (f64, bool) {
        match (guard, reading) {
            (Some(g), Some(r)) if r.ttc() < g.ttc_s => (u.min(-g.decel_mps2), true),
            _ => (u, false),
        }
    }
}

/// How a follower handles a vehicle that cut in ahead of it (the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CutInParams {
    /// Steps it stays on the intruder's ACC once the radar sees its predecessor again.
    pub dwell_steps: u32,
    /// Steps over which it then returns to its law (at least the fallback's `blend_steps`).
    pub blend_steps: u32,
    /// Whether the platoon splits behind the car (`[fallback.cut_in] split`): the follower
    /// heads the followers behind it while it runs its ACC on the car.
    pub split: bool,
}

/// Everything about degradation, for every follower of a platoon.
#[derive(Debug, Clone, PartialEq)]
pub struct FallbackParams {
    /// The fallback of every follower...
    pub mode: FallbackMode,
    /// ...unless given here per follower (N entries, follower 1 first; empty: none).
    pub per_vehicle: Vec<FallbackMode>,
    /// Steps a vehicle stays in its fallback once it is no longer affected.
    pub dwell_steps: u32,
    /// Steps over which it then blends back to the cooperative law (0: at once)...
    pub blend_steps: u32,
    /// ...or longer, so that the spacing offset shrinks by at most this (m/s), > 0.
    pub closing_mps: f64,
    /// The ACC law.
    pub acc: AccParams,
    /// The radar.
    pub radar: RadarParams,
    /// The guard, if any.
    pub guard: Option<GuardParams>,
    /// How a follower handles a cut-in; `None`: it does not tell an intruder from its
    /// predecessor.
    pub cut_in: Option<CutInParams>,
    /// Vehicle length L (m): the radar measures bumper to bumper, `d = p_ahead - p_i - L`.
    pub vehicle_length: f64,
    /// Each vehicle's own length (m), leader first, with vehicle classes (`[vehicle_classes]`);
    /// empty: every vehicle is `vehicle_length` long.
    pub lengths: Vec<f64>,
    /// A follower whose law reads V2V is affected when the vehicle it follows, or its leader,
    /// has had no packet accepted for more than this many steps (`[fallback] silence_s`): a
    /// link that delivers nothing, or whose packets are all refused, as a jammed channel is.
    /// `None`: silence goes unnoticed (the law steers on what it last took).
    pub silence_steps: Option<u32>,
}

impl Default for FallbackParams {
    /// The paper: `zero`, back at once, no guard.
    fn default() -> Self {
        Self {
            mode: FallbackMode::Zero,
            per_vehicle: Vec::new(),
            dwell_steps: 0,
            blend_steps: 0,
            closing_mps: 2.0,
            acc: AccParams::default(),
            radar: RadarParams::default(),
            guard: None,
            cut_in: None,
            vehicle_length: 0.0,
            lengths: Vec::new(),
            silence_steps: None,
        }
    }
}

impl FallbackParams {
    /// Follower i's (1-based) fallback.
    pub fn of(&self, i: usize) -> FallbackMode {
        self.per_vehicle.get(i - 1).copied().unwrap_or(self.mode)
    }

    /// The length of vehicle `j` of the platoon (0: the leader), m.
    pub fn length(&self, j: usize) -> f64 {
        self.lengths.get(j).copied().unwrap_or(self.vehicle_length)
    }

    /// Whether anything reads the radar (the ACC fallback, the guard or the cut-in handling).
    pub fn uses_radar(&self) -> bool {
        self.guard.is_some()
            || self.cut_in.is_some()
            || self.mode == FallbackMode::Acc
            || self.per_vehicle.contains(&FallbackMode::Acc)
    }

    /// Checks ranges; the error names the config key (under `fallback.`).
    pub fn validate(&self, followers: usize) -> Result<(), (&'static str, String)> {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let nonneg = |x: f64| x.is_finite() && x >= 0.0;
        if !self.per_vehicle.is_empty() && self.per_vehicle.len() != followers {
            return Err((
                "per_vehicle",
                format!(
                    "needs one mode per follower ({followers}), got {}",
                    self.per_vehicle.len()
                ),
            ));
        }
        if !pos(self.closing_mps) {
            return Err((
                "closing_mps",
                format!("must be > 0 (got {})", self.closing_mps),
            ));
        }
        let a = &self.acc;
        for (key, x) in [
            ("acc.headway_s", a.headway_s),
            ("acc.lambda", a.lambda),
            ("acc.max_accel_mps2", a.max_accel_mps2),
            ("acc.max_decel_mps2", a.max_decel_mps2),
        ] {
            if !pos(x) {
                return Err((key, format!("must be > 0 (got {x})")));
            }
        }
        if !nonneg(a.opening_s) {
            return Err((
                "acc.opening_s",
                format!("must be >= 0 (got {})", a.opening_s),
            ));
        }
        let r = &self.radar;
        if !pos(r.range_m) {
            return Err(("radar.range_m", format!("must be > 0 (got {})", r.range_m)));
        }
        if r.period_steps == 0 {
            return Err(("radar.period_s", "must be at least one step".into()));
        }
        for (key, x) in [
            ("radar.noise_m", r.noise_m),
            ("radar.noise_mps", r.noise_mps),
        ] {
            if !nonneg(x) {
                return Err((key, format!("must be >= 0 (got {x})")));
            }
        }
        if !(r.dropout.is_finite() && (0.0..1.0).contains(&r.dropout)) {
            return Err((
                "radar.dropout",
                format!("must be in [0, 1) (got {})", r.dropout),
            ));
        }
        if let Some(g) = &self.guard {
            if !pos(g.ttc_s) {
                return Err(("guard.ttc_s", format!("must be > 0 (got {})", g.ttc_s)));
            }
            if !pos(g.decel_mps2) {
                return Err((
                    "guard.decel_mps2",
                    format!("must be > 0 (got {})", g.decel_mps2),
                ));
            }
        }
        if !self.vehicle_length.is_finite() || self.vehicle_length < 0.0 {
            return Err(("vehicle_length", "must be finite and >= 0".into()));
        }
        if self.lengths.iter().any(|l| !l.is_finite() || *l < 0.0) {
            return Err(("lengths", "every length must be finite and >= 0".into()));
        }
        Ok(())
    }
}

/// How far the ACC's headway has moved to its new value `elapsed_s` after a switch: from 0 to 1
/// over `opening_s` (at once without one).
pub fn opened(acc: &AccParams, elapsed_s: f64) -> f64 {
    if acc.opening_s > 0.0 {
        (elapsed_s / acc.opening_s).min(1.0)
    } else {
        1.0
    }
}

/// The ACC's headway `elapsed_s` after the switch to it: growing from 0 to `headway_s` over
/// `opening_s` (at once without one).
pub fn opened_headway(acc: &AccParams, elapsed_s: f64) -> f64 {
    acc.headway_s * opened(acc, elapsed_s)
}

/// How far the radar's gap `r` is beyond the one the ACC keeps at `headway` (s) and speed `v`
/// (m; `spacing` front to front, `vehicle_length` the length of the vehicle ahead).
pub fn gap_error(r: Reading, headway: f64, v: f64, spacing: f64, vehicle_length: f64) -> f64 {
    r.gap + vehicle_length - spacing - headway * v
}

/// The ACC law's command with the gap opened to `headway` (s); `v` is the own speed and
/// `spacing` the platoon's desired distance `l` between consecutive vehicles' positions.
pub fn acc_command(
    acc: &AccParams,
    reading: Option<Reading>,
    headway: f64,
    v: f64,
    spacing: f64,
    vehicle_length: f64,
) -> f64 {
    let Some(r) = reading else {
        return 0.0; // no target in range: keep the speed
    };
    let e = gap_error(r, headway, v, spacing, vehicle_length);
    let u = (acc.lambda * e - r.closing) / acc.headway_s;
    u.clamp(-acc.max_decel_mps2, acc.max_accel_mps2)
}

/// The peak over frequency of `|G(jw)|` with
/// `G(s) = (kd s + kp) / (tau s^3 + s^2 + (kd + kp h) s + kp)`, the transfer from the
/// acceleration of the vehicle ahead to the own under the ACC law (linear, unsaturated), and
/// the frequency where it peaks: string stable when the peak is <= 1. Evaluated on a log grid
/// from 1e-3 to 1e2 rad/s.
pub fn acc_string_gain(acc: &AccParams, tau: f64) -> (f64, f64) {
    let (kp, kd, h) = (
        acc.lambda / acc.headway_s,
        1.0 / acc.headway_s,
        acc.headway_s,
    );
    let mut best = (0.0, 0.0);
    for i in 0..=5000 {
        let w = 10f64.powf(-3.0 + 5.0 * f64::from(i) / 5000.0);
        // den(jw) = kp - w^2 + j (w (kd + kp h) - tau w^3), num(jw) = kp + j kd w
        let (dr, di) = (kp - w * w, w * (kd + kp * h) - tau * w * w * w);
        let g = ((kp * kp + kd * kd * w * w) / (dr * dr + di * di)).sqrt();
        if g > best.0 {
            best = (g, w);
        }
    }
    best
}

/// How a follower comes back from its fallback to its law, once `dwell` calm steps have
/// passed (the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Return {
    /// The paper's controller: at the hand-over its spacing reference is offset so that `q`
    /// reads 0 (the law starts from rest), and the offset shrinks to 0 over `blend` steps, or
    /// more so that it shrinks by at most `closing_mps`; the fallback's command at the
    /// hand-over is blended out over `blend` steps on top.
    SpacingOffset,
    /// A composed law: the command's mismatch at the hand-over (the fallback's minus the
    /// law's) shrinks linearly to 0 over `blend` steps.
    CommandBlend,
}

/// Where a follower is on its way through a fallback and back.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Law,
    /// In its fallback since `since` (on a cut-in's ACC with `cut_in`); unaffected (or with
    /// its predecessor back ahead) for the last `calm` steps.
    Fallback {
        since: u64,
        calm: u32,
        cut_in: bool,
    },
    /// On the way back since step `exit`: the spacing offset it started from (0 for
    /// [`Return::CommandBlend`]), shrunk to 0 over `steps`, and the command's mismatch then
    /// (m/s^2), shrunk to 0 over `blend` steps.
    Back {
        exit: u64,
        delta0: State,
        steps: u64,
        mismatch: f64,
        blend: u64,
    },
}

/// What a follower's law and sensors say at step `k`, for its [`FallbackMachine`].
#[derive(Debug, Clone, Copy)]
pub struct Situation<'a> {
    /// The step.
    pub k: u64,
    /// The step length (s).
    pub dt: f64,
    /// The platoon's degradation parameters.
    pub params: &'a FallbackParams,
    /// Whether the follower is affected at this step (jammed, or distrusting a neighbour).
    pub affected: bool,
    /// Whether its radar sees a vehicle that cut in ahead (handled with
    /// [`FallbackParams::cut_in`] only).
    pub cut_in: bool,
    /// The law's command at this step (what `predict` applies).
    pub law: f64,
    /// The tracking error the law regulates ([`Return::SpacingOffset`] cancels it at the
    /// hand-over; unused by [`Return::CommandBlend`]).
    pub q: State,
    /// The radar's reading, when something reads the radar.
    pub reading: Option<Reading>,
    /// The follower's own speed (m/s).
    pub speed: f64,
    /// The platoon's spacing `l` (m, front to front).
    pub spacing: f64,
    /// The platoon's time headway (s; the `acc` fallback never keeps a shorter one).
    pub headway: f64,
    /// The length of the platoon's vehicle ahead (m): the radar's gap plus it is the distance
    /// front to front.
    pub length_ahead: f64,
    /// Whether the law's reference changed at this step (a new leader after a split or its
    /// end): on its law the follower then blends from its last command to the law's over the
    /// cut-in's `blend` steps, as on the way back from a fallback. For a machine that returns
    /// by [`Return::CommandBlend`] only (a spacing offset has no reference to hand over).
    pub rebased: bool,
}

/// One follower's way into its fallback while affected and back to its law: the one state
/// machine of every built-in controller (the module docs), the return a [`Return`].
#[derive(Debug, Clone)]
pub struct FallbackMachine {
    mode: FallbackMode,
    back: Return,
    phase: Phase,
    /// What `hold` applies: the command of the step before the follower entered its fallback.
    held: f64,
    last_u: f64,
}

impl FallbackMachine {
    /// A follower on its law, falling back to `mode` and returning by `back`.
    pub fn new(mode: FallbackMode, back: Return) -> Self {
        Self {
            mode,
            back,
            phase: Phase::Law,
            held: 0.0,
            last_u: 0.0,
        }
    }

    /// The command of the last [`FallbackMachine::step`] (0 before the first).
    pub fn last_u(&self) -> f64 {
        self.last_u
    }

    /// The offset of the spacing reference at step `k` on the way back
    /// ([`Return::SpacingOffset`]; 0 outside it).
    pub fn offset(&self, k: u64) -> State {
        match self.phase {
            Phase::Back {
                exit,
                delta0,
                steps,
                ..
            } if self.back == Return::SpacingOffset => {
                delta0 * (1.0 - (k.saturating_sub(exit)) as f64 / steps as f64).max(0.0)
            }
            _ => State::zeros(),
        }
    }

    /// Step `k`: into the fallback when affected, out of it after `dwell` calm steps, back
    /// through `blend` steps (none: at once, the paper). Returns the mode, the command with
    /// the emergency-braking guard applied, and whether the guard overrode it. `law_at`
    /// gives the law's command with the spacing reference offset by its argument (called on
    /// the way back of a [`Return::SpacingOffset`] only).
    pub fn step(
        &mut self,
        s: &Situation<'_>,
        law_at: impl FnOnce(State) -> f64,
    ) -> (Mode, f64, bool) {
        let fb = s.params;
        // A cut-in's dwell and blend, or the attack fallback's.
        let dwell = |cut_in: bool| match fb.cut_in {
            Some(c) if cut_in => c.dwell_steps,
            _ => fb.dwell_steps,
        };
        let blend = |cut_in: bool| match fb.cut_in {
            Some(c) if cut_in => u64::from(c.blend_steps.max(fb.blend_steps)),
            _ => u64::from(fb.blend_steps),
        };
        let cut = s.cut_in && fb.cut_in.is_some();
        self.phase = match (self.phase, s.affected, cut) {
            (Phase::Fallback { since, cut_in, .. }, true, _) => {
                if cut_in {
                    self.held = self.last_u;
                }
                Phase::Fallback {
                    since,
                    calm: 0,
                    cut_in: false,
                }
            }
            (_, true, _) => {
                self.held = self.last_u;
                Phase::Fallback {
                    since: s.k,
                    calm: 0,
                    cut_in: false,
                }
            }
            // A cut-in keeps the headway ramp of a fallback it interrupts.
            (Phase::Fallback { since, .. }, false, true) => Phase::Fallback {
                since,
                calm: 0,
                cut_in: true,
            },
            (_, false, true) => Phase::Fallback {
                since: s.k,
                calm: 0,
                cut_in: true,
            },
            (
                Phase::Fallback {
                    since,
                    calm,
                    cut_in,
                },
                false,
                false,
            ) if calm < dwell(cut_in) => Phase::Fallback {
                since,
                calm: calm + 1,
                cut_in,
            },
            (Phase::Fallback { since, cut_in, .. }, false, false) if blend(cut_in) > 0 => {
                let blend = blend(cut_in);
                let fallback = self.fallback_u(s, since, cut_in);
                match self.back {
                    Return::SpacingOffset => {
                        // The offset cancels q (the law starts from 0); the spacing part
                        // closes at most at `closing_mps`.
                        let by_speed = (s.q[0].abs() / fb.closing_mps / s.dt).ceil();
                        Phase::Back {
                            exit: s.k,
                            delta0: -s.q,
                            steps: blend.max(by_speed.min(1e12) as u64),
                            mismatch: fallback,
                            blend,
                        }
                    }
                    Return::CommandBlend => Phase::Back {
                        exit: s.k,
                        delta0: State::zeros(),
                        steps: blend,
                        mismatch: fallback - s.law,
                        blend,
                    },
                }
            }
            // A new reference on the law: from the last command to the new law's, blended.
            (Phase::Law | Phase::Back { .. }, false, false) if s.rebased && blend(true) > 0 => {
                Phase::Back {
                    exit: s.k,
                    delta0: State::zeros(),
                    steps: blend(true),
                    mismatch: self.last_u - s.law,
                    blend: blend(true),
                }
            }
            (
                back @ Phase::Back {
                    exit, steps, blend, ..
                },
                false,
                false,
            ) if s.k - exit < steps.max(blend) => back,
            (_, false, false) => Phase::Law,
        };
        let (mode, u) = match self.phase {
            Phase::Law => (Mode::Coop, s.law),
            Phase::Fallback {
                since,
                cut_in: true,
                ..
            } => (Mode::CutIn, self.fallback_u(s, since, true)),
            Phase::Fallback { since, .. } => (self.mode.mode(), self.fallback_u(s, since, false)),
            Phase::Back {
                exit,
                mismatch,
                blend,
                ..
            } => {
                let j = (s.k - exit) as f64;
                let rest = mismatch * (1.0 - j / blend as f64).max(0.0);
                let law = match self.back {
                    Return::SpacingOffset => law_at(self.offset(s.k)),
                    Return::CommandBlend => s.law,
                };
                (Mode::Blend, law + rest)
            }
        };
        let (u, guard) = GuardParams::apply(fb.guard.as_ref(), s.reading, u);
        self.last_u = u;
        (mode, u, guard)
    }

    /// The fallback's command at step `s.k`, in it since `since` (a cut-in's: the ACC).
    fn fallback_u(&self, s: &Situation<'_>, since: u64, cut_in: bool) -> f64 {
        let fb = s.params;
        let mode = if cut_in { FallbackMode::Acc } else { self.mode };
        match mode {
            FallbackMode::Zero => 0.0,
            FallbackMode::Hold => self.held,
            FallbackMode::Predict => s.law,
            FallbackMode::Acc => {
                // The ACC headway grows from 0 to h over `opening_s` after the switch, never
                // below the platoon's own.
                let h = opened_headway(&fb.acc, (s.k - since) as f64 * s.dt).max(s.headway);
                acc_command(&fb.acc, s.reading, h, s.speed, s.spacing, s.length_ahead)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_acc_is_string_stable_over_the_papers_tau_and_a_short_headway_is_not() {
        let acc = AccParams::default();
        for tau in [0.1, 0.34, 0.5, 0.82, 1.0] {
            let (peak, _) = acc_string_gain(&acc, tau);
            assert!(peak <= 1.0 + 1e-9, "tau {tau}: peak {peak}");
        }
        let short = AccParams {
            headway_s: 0.8,
            ..acc
        };
        let (peak, w) = acc_string_gain(&short, 0.82);
        assert!(peak > 1.2, "{peak} at {w}");
    }

    #[test]
    fn acc_brakes_when_too_close_and_is_bounded() {
        let acc = AccParams::default();
        let close = Reading {
            gap: 5.0,
            closing: 3.0,
            intruder: false,
        };
        let u = acc_command(&acc, Some(close), 2.0, 25.0, 10.0, 0.0);
        assert_eq!(u, -acc.max_decel_mps2);
        let far = Reading {
            gap: 100.0,
            closing: -1.0,
            intruder: false,
        };
        assert!(acc_command(&acc, Some(far), 2.0, 25.0, 10.0, 0.0) > 0.0);
        assert_eq!(acc_command(&acc, None, 2.0, 25.0, 10.0, 0.0), 0.0);
        assert_eq!(
            Reading {
                gap: 10.0,
                closing: 2.0,
                intruder: false,
            }
            .ttc(),
            5.0
        );
        assert!(close.ttc() < 2.0 && far.ttc().is_infinite());
    }

    /// The role in the platoon and the command's mode are two questions; the outputs and the
    /// wire tell them as one status with the codes and names they always had, and an unknown
    /// code is an error, never read as the cooperative law.
    #[test]
    fn a_status_is_a_role_and_a_mode_and_unknown_codes_are_errors() {
        let names: Vec<&str> = Status::ALL.iter().map(|s| s.name()).collect();
        assert_eq!(
            names,
            [
                "coop", "zero", "hold", "predict", "acc", "blend", "cut_in", "outside", "left",
                "beside"
            ]
        );
        for (code, s) in Status::ALL.into_iter().enumerate() {
            assert_eq!(s.code(), code as u32);
            assert_eq!(Status::from_code(code as u32), Ok(s));
            let json = serde_json::to_string(&s).unwrap();
            assert_eq!(json, format!("\"{}\"", s.name()));
            assert_eq!(serde_json::from_str::<Status>(&json).unwrap(), s);
        }
        assert_eq!(Status::from_code(10), Err(UnknownStatus(10)));
        assert!(UnknownStatus(15).to_string().contains("15"));
        // Outside the platoon the mode is not told: a leaver blending is `left`.
        let left = Status::new(Role::Left, Mode::Blend);
        assert_eq!(
            (left.role(), left.mode(), left.code()),
            (Role::Left, None, 8)
        );
        assert!(left == Role::Left && left != Mode::Blend && left.is_beside_the_lane());
        let blending = Status::new(Role::Member, Mode::Blend);
        assert!(blending == Mode::Blend && blending == Role::Member);
    }

    #[test]
    fn bad_parameters_name_their_key() {
        let mut p = FallbackParams::default();
        p.acc.headway_s = 0.0;
        assert_eq!(p.validate(4).unwrap_err().0, "acc.headway_s");
        let mut p = FallbackParams::default();
        p.radar.range_m = -1.0;
        assert_eq!(p.validate(4).unwrap_err().0, "radar.range_m");
        let p = FallbackParams {
            per_vehicle: vec![FallbackMode::Acc],
            ..FallbackParams::default()
        };
        assert_eq!(p.validate(4).unwrap_err().0, "per_vehicle");
        let p = FallbackParams {
            guard: Some(GuardParams {
                ttc_s: 1.0,
                decel_mps2: f64::NAN,
            }),
            ..FallbackParams::default()
        };
        assert_eq!(p.validate(4).unwrap_err().0, "guard.decel_mps2");
    }
}
