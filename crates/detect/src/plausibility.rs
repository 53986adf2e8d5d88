//! F2MD's legacy checks (the "legacy" plausibility and consistency checks of Kamel et al.'s F2MD,
//! after So, Sharman and Petit's VeReMi baseline): each is a yes/no on one packet or on a packet
//! and the last one accepted from its sender. The bounds are physical, not comfort bounds: a
//! platoon's emergency braking or its guard must not be taken for an attack.

use crate::{check, Detector, Observation, ParamError, Verdict};
use platoon_model::VehicleId;
use std::collections::BTreeMap;

/// The detector's name and `kind`.
pub(crate) const NAME: &str = "plausibility";

/// `[detection.plausibility]`: which checks run and their bounds. Every key is optional.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct PlausibilityParams {
    /// Speed plausibility: the claimed speed is within `[v_min_mps, v_max_mps]` (default on).
    pub check_speed: bool,
    /// The lowest plausible speed (m/s; default 0: vehicles do not reverse in a platoon). The
    /// exact plant does not clamp a stopping vehicle's speed at 0, so a run that brings vehicles
    /// to a stop on it should lower this. Below `v_max_mps`.
    pub v_min_mps: f64,
    /// The highest plausible speed (m/s; default 70, 252 km/h: no road vehicle of a platoon goes
    /// faster). > 0.
    pub v_max_mps: f64,
    /// Acceleration plausibility: the claimed acceleration is within
    /// `[-decel_max_mps2, accel_max_mps2]` (default on).
    pub check_acceleration: bool,
    /// The largest plausible acceleration (m/s^2; default 5: a sports car's, twice a truck's or
    /// bus's). > 0.
    pub accel_max_mps2: f64,
    /// The largest plausible deceleration (m/s^2; default 9: about the friction limit on dry
    /// asphalt, 0.9 g; F2MD's legacy 4.5 is a comfort bound a platoon's emergency braking
    /// exceeds). > 0.
    pub decel_max_mps2: f64,
    /// Range plausibility: the claimed position is within `range_m` of the receiver's own
    /// (default on).
    pub check_range: bool,
    /// The radio range (m; default 500, F2MD's and VeReMi's). > 0.
    pub range_m: f64,
    /// Position-speed consistency with the last accepted packet, `Δt` apart: the distance moved
    /// is what the two speeds give, `|Δp - (v_last + v) Δt / 2| <= position_tol_m + a_max Δt^2 /
    /// 2` with `a_max` the larger of the two bounds (default on).
    pub check_position_speed: bool,
    /// The slack of the position-speed check (m; default 1: the sum of two positions' errors
    /// with a good GNSS; the simulated states are exact). >= 0.
    pub position_tol_m: f64,
    /// Speed consistency with the last accepted packet: `-decel_max_mps2 Δt - speed_tol_mps <=
    /// v - v_last <= accel_max_mps2 Δt + speed_tol_mps` (default on).
    pub check_speed_change: bool,
    /// The slack of the speed-consistency check (m/s; default 0.5). >= 0.
    pub speed_tol_mps: f64,
    /// Beacon frequency: a packet received from the same sender less than this after the
    /// previous one (s) fails. Default 0: off, since an event-triggered sender may legitimately
    /// send at every step (the paper's triggers do, in a manoeuvre), unlike a CAM's 100 ms
    /// minimum. >= 0.
    pub min_interval_s: f64,
    /// Sudden appearance: the first packet of a sender that claims to be closer than this to
    /// the receiver (m) fails. Default 0: off, since every platoon member appears close by at
    /// the start of a run; set it below the platoon's gaps to catch a ghost vehicle that shows
    /// up inside the platoon later. >= 0.
    pub appear_m: f64,
}

impl Default for PlausibilityParams {
    fn default() -> Self {
        Self {
            check_speed: true,
            v_min_mps: 0.0,
            v_max_mps: 70.0,
            check_acceleration: true,
            accel_max_mps2: 5.0,
            decel_max_mps2: 9.0,
            check_range: true,
            range_m: 500.0,
            check_position_speed: true,
            position_tol_m: 1.0,
            check_speed_change: true,
            speed_tol_mps: 0.5,
            min_interval_s: 0.0,
            appear_m: 0.0,
        }
    }
}

impl PlausibilityParams {
    /// Checks every bound; the error names the field at fault.
    pub fn validate(&self) -> Result<(), ParamError> {
        let p = self;
        check(
            NAME,
            "v_max_mps",
            p.v_max_mps,
            p.v_max_mps > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "v_min_mps",
            p.v_min_mps,
            p.v_min_mps < p.v_max_mps,
            "must be below v_max_mps",
        )?;
        check(
            NAME,
            "accel_max_mps2",
            p.accel_max_mps2,
            p.accel_max_mps2 > 0.0,
            "must be > 0",
        )?;
        check(
            NAME,
            "decel_max_mps2",
            p.decel_max_mps2,
            p.decel_max_mps2 > 0.0,
            "must be > 0",
        )?;
        check(NAME, "range_m", p.range_m, p.range_m > 0.0, "must be > 0")?;
        check(
            NAME,
            "position_tol_m",
            p.position_tol_m,
            p.position_tol_m >= 0.0,
            "must be >= 0",
        )?;
        check(
            NAME,
            "speed_tol_mps",
            p.speed_tol_mps,
            p.speed_tol_mps >= 0.0,
            "must be >= 0",
        )?;
        check(
            NAME,
            "min_interval_s",
            p.min_interval_s,
            p.min_interval_s >= 0.0,
            "must be >= 0 (0: off)",
        )?;
        check(
            NAME,
            "appear_m",
            p.appear_m,
            p.appear_m >= 0.0,
            "must be >= 0 (0: off)",
        )?;
        Ok(())
    }
}

/// Which of [`Plausibility`]'s checks one packet failed (a check that is off, or that had
/// nothing to compare with, passes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PlausibilityFailures {
    /// The claimed speed is out of `[v_min_mps, v_max_mps]`.
    pub speed: bool,
    /// The claimed acceleration is out of `[-decel_max_mps2, accel_max_mps2]`.
    pub acceleration: bool,
    /// The sender claims to be beyond the radio range.
    pub range: bool,
    /// The distance moved since the last accepted packet does not match the speeds.
    pub position_speed: bool,
    /// The speed changed more than the acceleration bounds allow since the last accepted packet.
    pub speed_change: bool,
    /// The packet came sooner than `min_interval_s` after the sender's previous one.
    pub frequency: bool,
    /// The sender's first packet claims it is closer than `appear_m`.
    pub appearance: bool,
}

impl PlausibilityFailures {
    /// How many checks failed.
    pub fn count(&self) -> u32 {
        [
            self.speed,
            self.acceleration,
            self.range,
            self.position_speed,
            self.speed_change,
            self.frequency,
            self.appearance,
        ]
        .into_iter()
        .map(u32::from)
        .sum()
    }
}

/// F2MD's legacy checks. The verdict's score is the number of checks failed
/// ([`PlausibilityFailures::count`]); flagged when at least one failed. A non-finite claim fails
/// every check that reads it.
///
/// Per (receiver, sender) it remembers the step at which the last packet was received, for the
/// beacon-frequency and sudden-appearance checks (which are off by default).
#[derive(Debug, Clone)]
pub struct Plausibility {
    params: PlausibilityParams,
    /// The receive step of the last packet inspected, per (receiver, sender).
    seen: BTreeMap<(VehicleId, VehicleId), u64>,
}

impl Plausibility {
    /// The checks with these bounds, checked.
    pub fn new(params: PlausibilityParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self {
            params,
            seen: BTreeMap::new(),
        })
    }

    /// Its parameters.
    pub fn params(&self) -> &PlausibilityParams {
        &self.params
    }

    /// Runs every check on `obs` and says which failed (and remembers the packet for the
    /// frequency and appearance checks).
    pub fn failures(&mut self, obs: &Observation) -> PlausibilityFailures {
        let p = &self.params;
        let [cp, cv, ca] = [
            obs.packet.state[0],
            obs.packet.state[1],
            obs.packet.state[2],
        ];
        let distance = (obs.claim_now()[0] - obs.own[0]).abs();
        // Each check is "not within", so that NaN fails.
        let (position_speed, speed_change) = match obs.last {
            Some(last) => {
                let t = obs.packet.step.saturating_sub(last.step) as f64 * obs.dt;
                let [lp, lv] = [last.state[0], last.state[1]];
                let a_max = p.accel_max_mps2.max(p.decel_max_mps2);
                let moved = cp - lp - 0.5 * (lv + cv) * t;
                let slack = p.position_tol_m + 0.5 * a_max * t * t;
                let dv_min = -p.decel_max_mps2 * t - p.speed_tol_mps;
                let dv_max = p.accel_max_mps2 * t + p.speed_tol_mps;
                (
                    p.check_position_speed && !within(moved, -slack, slack),
                    p.check_speed_change && !within(cv - lv, dv_min, dv_max),
                )
            }
            None => (false, false),
        };
        let (frequency, appearance) = match self.seen.insert((obs.receiver, obs.sender()), obs.k) {
            Some(previous) => {
                let since = obs.k.saturating_sub(previous) as f64 * obs.dt;
                // A hair of slack so that an interval of exactly min_interval_s passes.
                (
                    p.min_interval_s > 0.0 && since < p.min_interval_s - 1e-9,
                    false,
                )
            }
            None => (
                false,
                p.appear_m > 0.0 && !within(distance, p.appear_m, f64::INFINITY),
            ),
        };
        PlausibilityFailures {
            speed: p.check_speed && !within(cv, p.v_min_mps, p.v_max_mps),
            acceleration: p.check_acceleration && !within(ca, -p.decel_max_mps2, p.accel_max_mps2),
            range: p.check_range && !within(distance, 0.0, p.range_m),
            position_speed,
            speed_change,
            frequency,
            appearance,
        }
    }
}

/// Whether `lo <= x <= hi` (false for a NaN).
fn within(x: f64, lo: f64, hi: f64) -> bool {
    x >= lo && x <= hi
}

impl Detector for Plausibility {
    fn name(&self) -> &'static str {
        NAME
    }

    fn inspect(&mut self, obs: &Observation) -> Verdict {
        let n = self.failures(obs).count();
        Verdict {
            flagged: n > 0,
            score: f64::from(n),
        }
    }
}
