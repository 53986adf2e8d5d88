//! The field's classic platoon control laws, computed exactly as Plexe computes them.
//!
//! Plexe ships inside SUMO as the car-following model `CC` (`MSCFModel_CC`); its parameter
//! `ccac` selects the active controller. Each function here is one of those controllers as a
//! pure function of plain numbers: it returns the commanded acceleration `u` (m/s^2) for one
//! step. Each parameter struct defaults to SUMO's defaults. The arithmetic follows SUMO's
//! operation by operation, so that a loop with SUMO's discretisation reproduces SUMO's
//! trajectories to rounding (`tests/plexe_agreement.rs` runs SUMO 1.28 and checks it).
//!
//! Conventions, shared by every law:
//!
//! - `gap` is bumper to bumper: the predecessor's rear minus the own front (SUMO's gap with
//!   `minGap = 0`), m.
//! - `v`, `a` are the own speed (m/s) and actual acceleration (m/s^2) at the start of the step;
//!   `v_pred`/`v_lead` the predecessor's/leader's speed, and `a_pred`/`a_lead`/`u_pred` their
//!   acceleration as received. Plexe sends the *controller* acceleration by default
//!   (`useControllerAcceleration = true`), and, because SUMO computes every vehicle's command
//!   before any of them moves, what a follower receives at step `k` is the sender's command of
//!   step `k - 1`.
//!
//! | law | Plexe `ccac` | function |
//! |---|---|---|
//! | ACC (cruise control + constant time headway) | 1 `ACC` | [`plexe_acc`] |
//! | PATH CACC (constant spacing) | 2 `CACC` | [`path_cacc`] |
//! | Ploeg's CACC (time headway, dynamic) | 4 `PLOEG` | [`ploeg`] |
//! | consensus | 5 `CONSENSUS` | [`consensus`] |
//! | flatbed tow truck | 6 `FLATBED` | [`flatbed`] |
use serde::{Deserialize, Serialize};

/// Plexe's ACC (`ccac = 1`): a cruise control towards a set speed, overridden by a
/// constant-time-headway ACC whenever the latter asks for less.
///
/// The cruise control is R. Rajamani, *Vehicle Dynamics and Control* (Springer), eq. 5.5 with no
/// integral term, clamped; the ACC is eq. 6.18 of the same book (the constant-time-gap law of
/// Rajamani and Zhu, "Semi-autonomous adaptive cruise control systems", IEEE TVT 2002), with a
/// fixed 2 m standstill distance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct PlexeAccParams {
    /// Time headway h of the ACC (s), > 0. SUMO: 1.5 (`ccaht`).
    pub headway_s: f64,
    /// lambda, the ACC's gain on the spacing error (1/s). SUMO: 0.1 (vType `lambda`).
    pub lambda_per_s: f64,
    /// The ACC's standstill distance (m). Plexe: 2, a constant in its source.
    pub standstill_m: f64,
    /// The cruise control's set speed (m/s). SUMO: 14 (`ccds`).
    pub desired_speed_mps: f64,
    /// The cruise control's gain on the speed error (1/s). SUMO: 1 (vType `kp`).
    pub cc_kp_per_s: f64,
    /// The cruise control's largest acceleration (m/s^2). SUMO: 1.5 (vType `ccAccel`).
    pub cc_accel_mps2: f64,
    /// The cruise control's largest deceleration, positive (m/s^2). SUMO: 1.5 (vType
    /// `ccDecel`).
    pub cc_decel_mps2: f64,
    /// Beyond this gap the ACC is ignored (m): Plexe's radar range, 250.
    pub radar_range_m: f64,
}

impl Default for PlexeAccParams {
    /// SUMO's defaults.
    fn default() -> Self {
        Self {
            headway_s: 1.5,
            lambda_per_s: 0.1,
            standstill_m: 2.0,
            desired_speed_mps: 14.0,
            cc_kp_per_s: 1.0,
            cc_accel_mps2: 1.5,
            cc_decel_mps2: 1.5,
            radar_range_m: 250.0,
        }
    }
}

/// Plexe's cruise control: `u = clamp(-kp (v - v_des), -cc_decel, cc_accel)`.
pub fn cruise(p: &PlexeAccParams, v: f64) -> f64 {
    p.cc_accel_mps2
        .min((-p.cc_decel_mps2).max(-p.cc_kp_per_s * (v - p.desired_speed_mps)))
}

/// The constant-time-headway ACC term alone:
/// `u = -(1/h) (v - v_pred + lambda (h v + s0 - gap))`.
pub fn acc_headway(p: &PlexeAccParams, v: f64, gap: f64, v_pred: f64) -> f64 {
    -1.0 / p.headway_s * (v - v_pred + p.lambda_per_s * (-gap + p.headway_s * v + p.standstill_m))
}

/// Plexe's ACC: the cruise control when nothing is ahead within radar range (`gap` beyond
/// [`PlexeAccParams::radar_range_m`], e.g. infinite) or when it asks for less than the ACC
/// term, the ACC term otherwise. Reads the radar only (gap and the predecessor's speed).
pub fn plexe_acc(p: &PlexeAccParams, v: f64, gap: f64, v_pred: f64) -> f64 {
    let cc = cruise(p, v);
    if gap > p.radar_range_m {
        return cc;
    }
    let acc = acc_headway(p, v, gap, v_pred);
    if cc < acc {
        cc
    } else {
        acc
    }
}

/// The PATH constant-spacing CACC (`ccac = 2`): R. Rajamani, *Vehicle Dynamics and Control*,
/// eq. 7.39, the controller of the California PATH platoon demonstrations (Rajamani, Tan, Law,
/// Zhang, IEEE TCST 2000).
///
/// ```text
/// u = a1 a_pred + a2 a_lead + a3 (v - v_pred) + a4 (v - v_lead) + a5 (spacing - gap)
/// a1 = 1 - C1,  a2 = C1,  a3 = -(2 xi - C1 (xi + sqrt(xi^2 - 1))) wn,
/// a4 = -(xi + sqrt(xi^2 - 1)) wn C1,  a5 = -wn^2
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct PathCaccParams {
    /// C1, the weight of the leader's acceleration against the predecessor's, in [0, 1]
    /// (dimensionless). SUMO: 0.5 (vType `c1`, `ccc1`).
    pub c1: f64,
    /// xi, the damping ratio, >= 1 (dimensionless). SUMO: 1 (vType `xi`, `ccxi`).
    pub xi: f64,
    /// omega_n, the bandwidth (rad/s), > 0. SUMO: 0.2 (vType `omegaN`, `ccon`).
    pub omega_n_radps: f64,
    /// The desired bumper-to-bumper gap (m). SUMO: 5 (vType `constSpacing`, `ccsp`).
    pub spacing_m: f64,
}

impl Default for PathCaccParams {
    /// SUMO's defaults.
    fn default() -> Self {
        Self {
            c1: 0.5,
            xi: 1.0,
            omega_n_radps: 0.2,
            spacing_m: 5.0,
        }
    }
}

impl PathCaccParams {
    /// The gains `[a1, a2, a3 (1/s), a4 (1/s), a5 (1/s^2)]`, as SUMO computes them.
    pub fn gains(&self) -> [f64; 5] {
        let (c1, xi, wn) = (self.c1, self.xi, self.omega_n_radps);
        let root = (xi * xi - 1.0).sqrt();
        [
            1.0 - c1,
            c1,
            -(2.0 * xi - c1 * (xi + root)) * wn,
            -(xi + root) * wn * c1,
            -wn * wn,
        ]
    }
}

/// The PATH CACC's command. Reads the radar's gap, the predecessor's speed and acceleration and
/// the leader's speed and acceleration (in Plexe: the senders' controller accelerations of the
/// previous step, see the module documentation).
pub fn path_cacc(
    p: &PathCaccParams,
    v: f64,
    gap: f64,
    v_pred: f64,
    a_pred: f64,
    v_lead: f64,
    a_lead: f64,
) -> f64 {
    let [a1, a2, a3, a4, a5] = p.gains();
    let epsilon = -gap + p.spacing_m;
    let epsilon_dot = v - v_pred;
    a1 * a_pred + a2 * a_lead + a3 * epsilon_dot + a4 * (v - v_lead) + a5 * epsilon
}

/// Ploeg's CACC (`ccac = 4`): J. Ploeg, B. Scheepers, E. van Nunen, N. van de Wouw,
/// H. Nijmeijer, "Design and experimental evaluation of cooperative adaptive cruise control",
/// IEEE ITSC 2011. A dynamic controller in the command itself:
///
/// ```text
/// du/dt = (1/h) (-u + kp e + kd e' + u_pred),
/// e = gap - (s0 + h v),   e' = v_pred - v - h a
/// ```
///
/// integrated by Plexe with one forward-Euler step of the simulation step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct PloegParams {
    /// Time headway h (s), > 0. SUMO: 0.5 (vType `ploegH`, `ccph`).
    pub headway_s: f64,
    /// kp, the gain on the spacing error (1/s^2). SUMO: 0.2 (vType `ploegKp`, `ccpkp`).
    pub kp_per_s2: f64,
    /// kd, the gain on its derivative (1/s). SUMO: 0.7 (vType `ploegKd`, `ccpkd`).
    pub kd_per_s: f64,
    /// The standstill distance s0 (m). Plexe: 2, a constant in its source.
    pub standstill_m: f64,
}

impl Default for PloegParams {
    /// SUMO's defaults.
    fn default() -> Self {
        Self {
            headway_s: 0.5,
            kp_per_s2: 0.2,
            kd_per_s: 0.7,
            standstill_m: 2.0,
        }
    }
}

/// What Ploeg's controller reads at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PloegInput {
    /// Its own previous command (m/s^2; 0 before the first).
    pub u_prev: f64,
    /// Its speed (m/s).
    pub v: f64,
    /// Its actual acceleration (m/s^2).
    pub a: f64,
    /// The gap to the predecessor (m).
    pub gap: f64,
    /// The predecessor's speed (m/s).
    pub v_pred: f64,
    /// The predecessor's *command* (m/s^2; in Plexe: the previous step's).
    pub u_pred: f64,
}

/// Ploeg's command for this step: `u = u_prev + dt du/dt`, with `du/dt` the right-hand side of
/// Ploeg's controller (m/s^3) from what it reads (`x`); `dt` is the step (s).
pub fn ploeg(p: &PloegParams, dt: f64, x: &PloegInput) -> f64 {
    let PloegInput {
        u_prev,
        v,
        a,
        gap,
        v_pred,
        u_pred,
    } = *x;
    let h = p.headway_s;
    let rate = 1.0 / h
        * (-u_prev
            + p.kp_per_s2 * (gap - (p.standstill_m + h * v))
            + p.kd_per_s * (v_pred - v - h * a)
            + u_pred);
    u_prev + rate * dt
}

/// Plexe's default number of platoon slots of the consensus controller.
const CONSENSUS_SLOTS: usize = 8;

/// The consensus controller (`ccac = 5`): S. Santini, A. Salvi, A. S. Valente, A. Pescapè,
/// M. Segata, R. Lo Cigno, "A consensus-based approach for platooning with inter-vehicular
/// communications", IEEE INFOCOM 2015 (journal version: IEEE TVT 2017). For vehicle `i` of a
/// platoon (0 = leader), with `x^_j` the positions predicted to the end of the step:
///
/// ```text
/// u_i = ( -b_i (v_i - v_0)
///         + (1/d_i) sum_{j != i} k_ij a_ij ((x^_j - x^_i) - d_ij) ) / scale     (vehicles in order)
/// d_i = sum_{j != i} a_ij,   d_ij = sum_{k=j}^{i-1} (h_k v_0 + l_k + s0)   for j < i
/// ```
///
/// where `l_k` is vehicle k's length. The distance term is Plexe's
/// `-|x^_i - x^_j| sgn(j - i)`, i.e. a plain difference only while the vehicles keep their
/// order; [`consensus`] computes it that way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct ConsensusParams {
    /// k_ij, row i = vehicle i's gains on the others' positions (kg/s^2 before the division
    /// by `scale`, i.e. `k_ij / scale` in 1/s^2). SUMO: row 1 = [460, 0, ...], row i >= 2 = 80
    /// on the leader and 860 on the predecessor, 8 x 8.
    pub gains: Vec<Vec<f64>>,
    /// a_ij, row i = whom vehicle i listens to (0 or 1, dimensionless). SUMO: the leader and the
    /// predecessor, 8 x 8.
    pub adjacency: Vec<Vec<f64>>,
    /// b_i, the gains on the speed error to the leader (kg/s before the division by `scale`).
    /// SUMO: 1800 for every vehicle, 8 entries.
    pub speed_gains: Vec<f64>,
    /// h_k, the time headway each vehicle k adds to the desired distances behind it (s). SUMO:
    /// 0.8 for every vehicle, 8 entries.
    pub headways_s: Vec<f64>,
    /// s0, the standstill distance added per vehicle (m). Plexe: 15, a constant in its source.
    pub standstill_m: f64,
    /// The divisor of the whole sum (kg: the gains are forces per unit error). Plexe: 1000.
    pub scale: f64,
}

impl Default for ConsensusParams {
    /// SUMO's defaults (`CC_VehicleVariables`).
    fn default() -> Self {
        let n = CONSENSUS_SLOTS;
        let mut gains = vec![vec![0.0; n]; n];
        let mut adjacency = vec![vec![0.0; n]; n];
        gains[1][0] = 460.0;
        adjacency[1][0] = 1.0;
        for i in 2..n {
            gains[i][0] = 80.0;
            gains[i][i - 1] = 860.0;
            adjacency[i][0] = 1.0;
            adjacency[i][i - 1] = 1.0;
        }
        Self {
            gains,
            adjacency,
            speed_gains: vec![1800.0; n],
            headways_s: vec![0.8; n],
            standstill_m: 15.0,
            scale: 1000.0,
        }
    }
}

impl ConsensusParams {
    /// Whether these parameters serve a platoon of `n` vehicles (leader included): square
    /// matrices and vectors of at least `n` entries, every row with a neighbour.
    pub fn check(&self, n: usize) -> Result<(), (&'static str, String)> {
        let short = |what: &'static str, len: usize| {
            Err((
                what,
                format!("has {len} entries, the platoon {n} vehicles (one per vehicle at least)"),
            ))
        };
        if self.gains.len() < n {
            return short("gains", self.gains.len());
        }
        if self.adjacency.len() < n {
            return short("adjacency", self.adjacency.len());
        }
        if self.speed_gains.len() < n {
            return short("speed_gains", self.speed_gains.len());
        }
        if self.headways_s.len() < n {
            return short("headways_s", self.headways_s.len());
        }
        for i in 1..n {
            if self.gains[i].len() < n {
                return Err(("gains", format!("row {i} has fewer than {n} columns")));
            }
            if self.adjacency[i].len() < n {
                return Err(("adjacency", format!("row {i} has fewer than {n} columns")));
            }
            if (0..n)
                .filter(|&j| j != i)
                .map(|j| self.adjacency[i][j])
                .sum::<f64>()
                == 0.0
            {
                return Err(("adjacency", format!("row {i} has no neighbour")));
            }
        }
        Ok(())
    }
}

/// One vehicle as the consensus controller sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConsensusVehicle {
    /// Front-bumper position along the road, predicted to the end of the current step (m).
    /// Plexe predicts with the speed only: `x + v (t_end - t_sampled)`, for the own position
    /// `x + v dt`.
    pub position: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// Length (m).
    pub length: f64,
}

/// The consensus command of vehicle `i` (>= 1) of `vehicles` (index 0 = leader). Reads only
/// positions, lengths, the own speed and the leader's speed; every vehicle's entry must be
/// current (Plexe answers 0 until it has heard from all of them).
///
/// # Panics
///
/// If `i` is 0 or out of range, or the parameters are too small for `vehicles` (see
/// [`ConsensusParams::check`]).
pub fn consensus(p: &ConsensusParams, i: usize, vehicles: &[ConsensusVehicle]) -> f64 {
    assert!(
        i >= 1 && i < vehicles.len(),
        "consensus: vehicle {i} of {}",
        vehicles.len()
    );
    let n = vehicles.len();
    let v0 = vehicles[0].speed;
    // d_ij: the desired distance from i to j, positive when j is ahead.
    let desired = |j: usize| {
        let (lo, hi) = if j < i { (j, i - 1) } else { (i, j - 1) };
        let mut d = 0.0;
        for (h, car) in p.headways_s[lo..=hi].iter().zip(&vehicles[lo..=hi]) {
            d += h * v0 + car.length + p.standstill_m;
        }
        if j < i {
            d
        } else {
            -d
        }
    };
    let speed_error = -p.speed_gains[i] * (vehicles[i].speed - v0);
    let mut degree = 0.0;
    let mut desired_term = 0.0;
    for j in (0..n).filter(|&j| j != i) {
        degree += p.adjacency[i][j];
        desired_term -= p.gains[i][j] * p.adjacency[i][j] * desired(j);
    }
    desired_term /= degree;
    let mut actual_term = 0.0;
    for j in (0..n).filter(|&j| j != i) {
        let sign = if j > i { 1.0 } else { -1.0 };
        let distance = (vehicles[i].position - vehicles[j].position).abs() * sign;
        actual_term -= p.gains[i][j] * p.adjacency[i][j] * distance;
    }
    actual_term /= degree;
    (speed_error + desired_term + actual_term) / p.scale
}

/// The flatbed tow-truck controller (`ccac = 6`): A. Ali, G. Garcia, P. Martinet, "The flatbed
/// platoon towing model for safe and dense platooning on highways", IEEE ITS Magazine 2015, in
/// the form with an acceleration feedback for actuator lag ("Modified flatbed tow truck model
/// for stable and safe platooning in presences of lags, communication and sensing delays",
/// ACC 2015):
///
/// ```text
/// u = -ka a + kv (v_pred - v) + kp (gap - d - h (v - v_lead))
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields, default)]
pub struct FlatbedParams {
    /// ka, the gain on the own actual acceleration (dimensionless). SUMO: 2.4 (vType
    /// `flatbedKa`, `ccfka`).
    pub ka: f64,
    /// kv, the gain on the speed difference to the predecessor (1/s). SUMO: 0.6 (vType
    /// `flatbedKv`, `ccfkv`).
    pub kv_per_s: f64,
    /// kp, the gain on the spacing error (1/s^2). SUMO: 12 (vType `flatbedKp`, `ccfkp`).
    pub kp_per_s2: f64,
    /// h, the headway on the speed difference to the leader (s). SUMO: 4 (vType `flatbedH`,
    /// `ccfh`).
    pub headway_s: f64,
    /// d, the desired bumper-to-bumper gap at equal speeds (m). SUMO: 5 (vType `flatbedD`,
    /// `ccfd`).
    pub spacing_m: f64,
}

impl Default for FlatbedParams {
    /// SUMO's defaults.
    fn default() -> Self {
        Self {
            ka: 2.4,
            kv_per_s: 0.6,
            kp_per_s2: 12.0,
            headway_s: 4.0,
            spacing_m: 5.0,
        }
    }
}

/// The flatbed command, from the own speed and actual acceleration, the radar's gap, and the
/// predecessor's and leader's speeds (received).
pub fn flatbed(p: &FlatbedParams, v: f64, a: f64, gap: f64, v_pred: f64, v_lead: f64) -> f64 {
    -p.ka * a
        + p.kv_per_s * (v_pred - v)
        + p.kp_per_s2 * (gap - p.spacing_m - p.headway_s * (v - v_lead))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_gains_at_sumo_defaults() {
        let g = PathCaccParams::default().gains();
        let want = [0.5, 0.5, -0.3, -0.1, -0.04];
        for (x, w) in g.iter().zip(want) {
            assert!((x - w).abs() < 1e-15, "{g:?}");
        }
    }

    #[test]
    fn every_law_is_at_rest_in_its_equilibrium() {
        let v = 20.0;
        // PATH: the constant spacing, everyone at the same speed, no acceleration.
        let p = PathCaccParams::default();
        assert_eq!(path_cacc(&p, v, p.spacing_m, v, 0.0, v, 0.0), 0.0);
        // Ploeg: s0 + h v.
        let p = PloegParams::default();
        let gap = p.standstill_m + p.headway_s * v;
        let rest = PloegInput {
            u_prev: 0.0,
            v,
            a: 0.0,
            gap,
            v_pred: v,
            u_pred: 0.0,
        };
        assert_eq!(ploeg(&p, 0.01, &rest), 0.0);
        // Flatbed: d.
        let p = FlatbedParams::default();
        assert_eq!(flatbed(&p, v, 0.0, p.spacing_m, v, v), 0.0);
        // ACC: s0 + h v, below the set speed (the ACC term wins at 0 < cc).
        let p = PlexeAccParams {
            desired_speed_mps: 30.0,
            ..Default::default()
        };
        let gap = p.standstill_m + p.headway_s * v;
        assert!(plexe_acc(&p, v, gap, v).abs() < 1e-15);
        // Consensus: h v0 + l + s0 front to front behind every vehicle.
        let p = ConsensusParams::default();
        let step = 0.8 * v + 4.0 + 15.0;
        let cars: Vec<_> = (0..5)
            .map(|k| ConsensusVehicle {
                position: 1000.0 - k as f64 * step,
                speed: v,
                length: 4.0,
            })
            .collect();
        for i in 1..5 {
            assert!(consensus(&p, i, &cars).abs() < 1e-12, "vehicle {i}");
        }
    }

    #[test]
    fn acc_takes_the_smaller_command_and_cruises_when_alone() {
        let p = PlexeAccParams {
            desired_speed_mps: 30.0,
            ..Default::default()
        };
        // Far below the set speed, nothing ahead: the cruise control's limit.
        assert_eq!(plexe_acc(&p, 10.0, f64::INFINITY, 0.0), 1.5);
        assert_eq!(plexe_acc(&p, 10.0, 251.0, 0.0), 1.5);
        // A slower car close ahead: the ACC brakes.
        let u = plexe_acc(&p, 20.0, 10.0, 15.0);
        assert_eq!(u, acc_headway(&p, 20.0, 10.0, 15.0));
        assert!(u < -3.0);
        // A large gap: the ACC would accelerate harder than the cruise control allows.
        assert_eq!(plexe_acc(&p, 20.0, 200.0, 20.0), 1.5);
        // Above the set speed: the cruise control brakes, at most 1.5.
        assert_eq!(cruise(&p, 40.0), -1.5);
        assert_eq!(cruise(&p, 29.0), 1.0);
    }

    #[test]
    fn path_cacc_terms_have_their_signs() {
        let p = PathCaccParams::default();
        // Too far: accelerate by wn^2 per metre.
        let u = path_cacc(&p, 20.0, 6.0, 20.0, 0.0, 20.0, 0.0);
        assert!((u - 0.04).abs() < 1e-15);
        // The feed-forward: half the predecessor's, half the leader's acceleration.
        let u = path_cacc(&p, 20.0, 5.0, 20.0, 1.0, 20.0, 3.0);
        assert!((u - 2.0).abs() < 1e-15);
    }

    #[test]
    fn ploeg_integrates_towards_the_predecessors_command() {
        let p = PloegParams::default();
        let gap = p.standstill_m + p.headway_s * 20.0;
        let mut u = 0.0;
        for _ in 0..10_000 {
            let x = PloegInput {
                u_prev: u,
                v: 20.0,
                a: 0.0,
                gap,
                v_pred: 20.0,
                u_pred: 1.0,
            };
            u = ploeg(&p, 0.01, &x);
        }
        assert!((u - 1.0).abs() < 1e-9, "{u}");
    }

    #[test]
    fn consensus_defaults_and_checks() {
        let p = ConsensusParams::default();
        assert!(p.check(5).is_ok());
        assert!(p.check(8).is_ok());
        assert!(p.check(9).is_err());
        // Follower 1 listens to the leader alone (k = 460), follower 3 to the leader (80) and
        // follower 2 (860).
        assert_eq!(
            (p.gains[1][0], p.adjacency[1].iter().sum::<f64>()),
            (460.0, 1.0)
        );
        assert_eq!(
            (p.gains[3][0], p.gains[3][2], p.gains[3][1]),
            (80.0, 860.0, 0.0)
        );
        // One metre too far behind the predecessor (who is in place): + 860 / 2 / 1000.
        let v = 15.0;
        let step = 0.8 * v + 4.0 + 15.0;
        let mut cars: Vec<_> = (0..4)
            .map(|k| ConsensusVehicle {
                position: 500.0 - k as f64 * step,
                speed: v,
                length: 4.0,
            })
            .collect();
        cars[3].position -= 1.0;
        let u = consensus(&p, 3, &cars);
        assert!((u - (80.0 + 860.0) / 2.0 / 1000.0).abs() < 1e-12, "{u}");
        // Faster than the leader: b (v - v0) / 1000 of braking.
        cars[3].position += 1.0;
        cars[3].speed = v + 1.0;
        assert!((consensus(&p, 3, &cars) + 1.8).abs() < 1e-12);
    }

    #[test]
    fn params_fill_defaults_and_refuse_unknown_keys() {
        use serde::de::value::{Error, MapDeserializer};
        let given = MapDeserializer::<_, Error>::new(vec![("headway_s", 0.7)].into_iter());
        let p = PloegParams::deserialize(given).unwrap();
        assert_eq!(
            p,
            PloegParams {
                headway_s: 0.7,
                ..Default::default()
            }
        );
        let unknown = MapDeserializer::<_, Error>::new(vec![("k", 1.0)].into_iter());
        assert!(FlatbedParams::deserialize(unknown).is_err());
    }
}
