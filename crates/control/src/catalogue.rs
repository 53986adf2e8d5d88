//! The built-in laws a config names (`[control] law`): the paper's, and the field's from
//! [`crate::laws`] as [`Law`]s on a [`crate::ComposedController`].
//!
//! What each of the field's laws reads, as Plexe does (docs/controllers.md): the radar's gap
//! and closing speed to the vehicle ahead (ideal: the plant's), its own speed and
//! acceleration, and the last packet accepted from the predecessor and the leader, whose
//! acceleration is the command they sent (Plexe's default, `useControllerAcceleration`).

use crate::composed::{Law, View};
use crate::laws::{
    consensus, flatbed, path_cacc, plexe_acc, ploeg, ConsensusParams, ConsensusVehicle,
    FlatbedParams, PathCaccParams, PlexeAccParams, PloegParams,
};
use platoon_model::VehicleId;
use serde::{Deserialize, Serialize};

/// `[control] law` and its keys (docs/controllers.md): the paper's (`gain`, `beta1`, `beta2`,
/// and the event triggers of `[trigger]`), or one of the field's, which beacon periodically or
/// by ETSI's CAM rules (`[trigger] rule = "periodic"` or `"cam"`); every key of a field's law
/// is optional, with SUMO's Plexe defaults. The one list of the laws: a config file holds it
/// and the controller runs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum LawParams {
    /// The paper's `u = -K q` on open-loop estimates, with its event triggers.
    Paper(PaperParams),
    /// Plexe's ACC: cruise control and a constant time headway on the radar, no V2V.
    Acc(PlexeAccParams),
    /// The PATH CACC (Rajamani et al.): constant spacing, predecessor and leader.
    PathCacc(PathCaccParams),
    /// Ploeg et al.'s CACC: time headway, the predecessor's command fed forward.
    Ploeg(PloegParams),
    /// The consensus law of Santini et al.
    Consensus(ConsensusParams),
    /// The flatbed controller of Ali, Garcia and Martinet (2015), as Plexe has it.
    Flatbed(FlatbedParams),
}

/// The paper's law with its Section IV values.
impl Default for LawParams {
    fn default() -> Self {
        Self::Paper(PaperParams::default())
    }
}

/// `law = "paper"`: the gain and the trigger conditions' weights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(
    feature = "schemars",
    derive(schemars::JsonSchema),
    schemars(rename = "PaperLaw")
)]
#[serde(default, deny_unknown_fields)]
pub struct PaperParams {
    /// K in `u_i = -K q_i` (docs/paper-readings.md#R1).
    pub gain: [f64; 3],
    /// Weight of |eps|^2 in the trigger conditions.
    pub beta1: f64,
    /// Weight of |q|^2 in the trigger conditions.
    pub beta2: f64,
}

/// The paper's values (Section IV).
impl Default for PaperParams {
    fn default() -> Self {
        Self {
            gain: [4.81, 9.12, 2.97],
            beta1: 319.38,
            beta2: 5.62,
        }
    }
}

/// Which law, without its parameters (a list of laws on the command line or in a search file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum LawName {
    /// The paper's.
    #[default]
    Paper,
    /// Plexe's ACC.
    Acc,
    /// The PATH CACC.
    PathCacc,
    /// Ploeg et al.'s CACC.
    Ploeg,
    /// The consensus law.
    Consensus,
    /// The flatbed controller.
    Flatbed,
}

impl LawName {
    /// Every law, the paper's first.
    pub const ALL: [LawName; 6] = [
        Self::Paper,
        Self::Acc,
        Self::PathCacc,
        Self::Ploeg,
        Self::Consensus,
        Self::Flatbed,
    ];

    /// The law of a config name (`ploeg`).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|l| l.name() == name)
    }

    /// The law with its default parameters (SUMO's Plexe defaults; the paper's own).
    pub fn defaults(self) -> LawParams {
        match self {
            Self::Paper => LawParams::Paper(Default::default()),
            Self::Acc => LawParams::Acc(Default::default()),
            Self::PathCacc => LawParams::PathCacc(Default::default()),
            Self::Ploeg => LawParams::Ploeg(Default::default()),
            Self::Consensus => LawParams::Consensus(Default::default()),
            Self::Flatbed => LawParams::Flatbed(Default::default()),
        }
    }

    /// Its config name (`[control] law`; serde's for [`LawParams`] and for this enum, which
    /// platoon-config's tests check against it).
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Acc => "acc",
            Self::PathCacc => "path_cacc",
            Self::Ploeg => "ploeg",
            Self::Consensus => "consensus",
            Self::Flatbed => "flatbed",
        }
    }
}

impl LawParams {
    /// Which law it is.
    pub fn kind(&self) -> LawName {
        match self {
            Self::Paper(_) => LawName::Paper,
            Self::Acc(_) => LawName::Acc,
            Self::PathCacc(_) => LawName::PathCacc,
            Self::Ploeg(_) => LawName::Ploeg,
            Self::Consensus(_) => LawName::Consensus,
            Self::Flatbed(_) => LawName::Flatbed,
        }
    }

    /// Its config name (`[control] law`).
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// Whether it is the paper's law (which triggers its broadcasts on its own estimates).
    pub fn is_paper(&self) -> bool {
        matches!(self, Self::Paper(_))
    }

    /// The [`Law`] of one of the field's laws (`None` for the paper's, which is a controller of
    /// its own).
    pub fn law(&self, vehicle_length: f64) -> Option<Box<dyn Law>> {
        Some(match self {
            Self::Paper(_) => return None,
            Self::Acc(p) => Box::new(Acc(*p)),
            Self::PathCacc(p) => Box::new(PathCacc(*p)),
            Self::Ploeg(p) => Box::new(Ploeg(*p)),
            Self::Consensus(p) => Box::new(Consensus {
                params: p.clone(),
                vehicle_length,
                scratch: Vec::new(),
            }),
            Self::Flatbed(p) => Box::new(Flatbed(*p)),
        })
    }

    /// The distance this law keeps between consecutive vehicles in steady state, as the
    /// platoon's spacing policy: `(l, h_t)` with the front-to-front distance `l + h_t v`, for
    /// vehicles `vehicle_length` long (`None` for the paper's, which takes the platoon's; a
    /// consensus law whose headways differ between vehicles has none).
    pub fn spacing_policy(&self, vehicle_length: f64) -> Option<(f64, f64)> {
        let l = vehicle_length;
        match self {
            Self::Paper(_) => None,
            Self::Acc(p) => Some((p.standstill_m + l, p.headway_s)),
            Self::PathCacc(p) => Some((p.spacing_m + l, 0.0)),
            Self::Ploeg(p) => Some((p.standstill_m + l, p.headway_s)),
            // d + h (v - v_lead): d at a common speed.
            Self::Flatbed(p) => Some((p.spacing_m + l, 0.0)),
            Self::Consensus(p) => {
                let h = *p.headways_s.first()?;
                p.headways_s
                    .iter()
                    .all(|&x| x == h)
                    .then_some((p.standstill_m + l, h))
            }
        }
    }

    /// Checks ranges; the error names the key (under `control.`).
    pub fn validate(&self) -> Result<(), crate::ParamsError> {
        let check = |field: &'static str, x: f64, ok: bool, what: &str| {
            if x.is_finite() && ok {
                Ok(())
            } else {
                Err(crate::ParamsError {
                    field,
                    message: format!("must be {what} (got {x})"),
                })
            }
        };
        match self {
            Self::Paper(_) => Ok(()),
            Self::Acc(p) => {
                check("headway_s", p.headway_s, p.headway_s > 0.0, "> 0")?;
                check("lambda_per_s", p.lambda_per_s, true, "finite")?;
                check("standstill_m", p.standstill_m, true, "finite")?;
                check("desired_speed_mps", p.desired_speed_mps, true, "finite")?;
                check("cc_kp_per_s", p.cc_kp_per_s, true, "finite")?;
                check(
                    "cc_accel_mps2",
                    p.cc_accel_mps2,
                    p.cc_accel_mps2 > 0.0,
                    "> 0",
                )?;
                check(
                    "cc_decel_mps2",
                    p.cc_decel_mps2,
                    p.cc_decel_mps2 > 0.0,
                    "> 0",
                )?;
                check(
                    "radar_range_m",
                    p.radar_range_m,
                    p.radar_range_m > 0.0,
                    "> 0",
                )
            }
            Self::PathCacc(p) => {
                check("c1", p.c1, (0.0..=1.0).contains(&p.c1), "in [0, 1]")?;
                check("xi", p.xi, p.xi >= 1.0, ">= 1")?;
                check(
                    "omega_n_radps",
                    p.omega_n_radps,
                    p.omega_n_radps > 0.0,
                    "> 0",
                )?;
                check("spacing_m", p.spacing_m, true, "finite")
            }
            Self::Ploeg(p) => {
                check("headway_s", p.headway_s, p.headway_s > 0.0, "> 0")?;
                check("kp_per_s2", p.kp_per_s2, true, "finite")?;
                check("kd_per_s", p.kd_per_s, true, "finite")?;
                check("standstill_m", p.standstill_m, true, "finite")
            }
            Self::Flatbed(p) => {
                check("ka", p.ka, true, "finite")?;
                check("kv_per_s", p.kv_per_s, true, "finite")?;
                check("kp_per_s2", p.kp_per_s2, true, "finite")?;
                check("headway_s", p.headway_s, true, "finite")?;
                check("spacing_m", p.spacing_m, true, "finite")
            }
            Self::Consensus(p) => {
                check("scale", p.scale, p.scale > 0.0, "> 0")?;
                check("standstill_m", p.standstill_m, true, "finite")?;
                let all = p.gains.iter().chain(&p.adjacency).flatten();
                for x in all.chain(&p.speed_gains).chain(&p.headways_s) {
                    check("gains", *x, true, "finite")?;
                }
                Ok(())
            }
        }
    }

    /// Whether a platoon split behind a cut-in (`[fallback.cut_in] split`) re-points a
    /// follower to the member heading its part: the PATH CACC and the flatbed controller read
    /// its packets as their leader's ([`View::leader`]); the paper's law and the consensus law
    /// couple the followers of that part only, the head in the leader's place ([`View::part`]).
    pub fn follows_head(&self) -> bool {
        matches!(
            self,
            Self::Paper(_) | Self::PathCacc(_) | Self::Flatbed(_) | Self::Consensus(_)
        )
    }

    /// Which vehicles a follower of this law must hear from (besides nobody for the ACC):
    /// `(predecessor, leader)`.
    pub fn needs(&self) -> (bool, bool) {
        match self {
            Self::Paper(_) | Self::Acc(_) => (false, false),
            Self::PathCacc(_) | Self::Flatbed(_) => (true, true),
            Self::Ploeg(_) => (true, false),
            Self::Consensus(_) => (false, true),
        }
    }
}

/// The radar's gap and the speed of the vehicle ahead it implies (`v - closing`), or nothing
/// ahead (an infinite gap, the own speed).
fn radar(view: &View<'_>) -> (f64, f64) {
    match view.radar {
        Some(r) => (r.gap, view.own[1] - r.closing),
        None => (f64::INFINITY, view.own[1]),
    }
}

/// The last packet from `who`, or the own state if `who` is not a neighbour (the law then
/// reads zero errors, never garbage: configs are checked against [`LawParams::needs`]).
fn heard(view: &View<'_>, who: Option<&crate::checks::Heard>) -> (f64, f64, f64) {
    match who {
        Some(h) => (h.state[1], h.u, h.state[0]),
        None => (view.own[1], view.last_u, view.own[0]),
    }
}

#[derive(Debug, Clone)]
struct Acc(PlexeAccParams);

impl Law for Acc {
    fn command(&mut self, view: &View<'_>) -> f64 {
        let (gap, v_pred) = radar(view);
        plexe_acc(&self.0, view.own[1], gap, v_pred)
    }

    fn uses_v2v(&self) -> bool {
        false
    }
}

#[derive(Debug, Clone)]
struct PathCacc(PathCaccParams);

impl Law for PathCacc {
    fn command(&mut self, view: &View<'_>) -> f64 {
        let (gap, _) = radar(view);
        let (v_pred, a_pred, _) = heard(view, view.predecessor());
        let (v_lead, a_lead, _) = heard(view, view.leader());
        path_cacc(&self.0, view.own[1], gap, v_pred, a_pred, v_lead, a_lead)
    }
}

#[derive(Debug, Clone)]
struct Ploeg(PloegParams);

impl Law for Ploeg {
    fn command(&mut self, view: &View<'_>) -> f64 {
        let (gap, _) = radar(view);
        let (v_pred, u_pred, _) = heard(view, view.predecessor());
        let own = view.own;
        let x = crate::laws::PloegInput {
            u_prev: view.last_u,
            v: own[1],
            a: own[2],
            gap,
            v_pred,
            u_pred,
        };
        ploeg(&self.0, view.dt, &x)
    }
}

#[derive(Debug, Clone)]
struct Flatbed(FlatbedParams);

impl Law for Flatbed {
    fn command(&mut self, view: &View<'_>) -> f64 {
        // The flatbed law reads speeds only: its own, the predecessor's and the leader's.
        let speed = |h| heard(view, h).0;
        let (v, a) = (view.own[1], view.own[2]);
        let gap = radar(view).0;
        flatbed(
            &self.0,
            v,
            a,
            gap,
            speed(view.predecessor()),
            speed(view.leader()),
        )
    }
}

#[derive(Debug, Clone)]
struct Consensus {
    params: ConsensusParams,
    vehicle_length: f64,
    scratch: Vec<ConsensusVehicle>,
}

impl Consensus {
    /// Vehicle `j` as follower `view.id` knows it, predicted with its speed to the end of the
    /// step (the own one by dt) from its packet `heard`; one it does not hear from has no
    /// weight (a_ij = 0 for it is checked with the config), so its entry only has to be finite.
    fn vehicle(
        &self,
        view: &View<'_>,
        j: VehicleId,
        heard: Option<&crate::checks::Heard>,
    ) -> ConsensusVehicle {
        let end = (view.k + 1) as f64 * view.dt;
        let (position, speed) = if j == view.id {
            (view.own[0] + view.own[1] * view.dt, view.own[1])
        } else {
            match heard {
                Some(h) => {
                    let sampled = h.step.unwrap_or(0) as f64 * view.dt;
                    (h.state[0] + h.state[1] * (end - sampled), h.state[1])
                }
                None => (view.own[0], view.own[1]),
            }
        };
        ConsensusVehicle {
            position,
            speed,
            length: self.vehicle_length,
        }
    }

    /// The command while a member ahead heads `part` (road order, the head first, this
    /// follower in it): Plexe's consensus on the part as a platoon of its own size, the head
    /// in the leader's place. The part takes the first places' gains, links, speed gains and
    /// headways of the platoon's (its second member is a first follower, and so on), and no
    /// vehicle ahead of the head counts.
    fn of_part(&mut self, view: &View<'_>, part: &[VehicleId], head: &crate::checks::Heard) -> f64 {
        let p = &self.params;
        let m = part.len();
        let first = |rows: &[Vec<f64>]| -> Vec<Vec<f64>> {
            rows[..m].iter().map(|r| r[..m].to_vec()).collect()
        };
        let sub = ConsensusParams {
            gains: first(&p.gains),
            adjacency: first(&p.adjacency),
            speed_gains: p.speed_gains[..m].to_vec(),
            headways_s: p.headways_s[..m].to_vec(),
            standstill_m: p.standstill_m,
            scale: p.scale,
        };
        let vehicles: Vec<ConsensusVehicle> = part
            .iter()
            .enumerate()
            .map(|(q, &v)| {
                let heard = if q == 0 { Some(head) } else { view.from(v) };
                self.vehicle(view, v, heard)
            })
            .collect();
        let i = part.iter().position(|&v| v == view.id).unwrap_or(1);
        consensus(&sub, i, &vehicles)
    }
}

impl Law for Consensus {
    fn command(&mut self, view: &View<'_>) -> f64 {
        if let (Some((_, head)), Some(part)) = (view.head, view.part) {
            if part.len() >= 2 && part.contains(&view.id) && part[0] != view.id {
                return self.of_part(view, part, head);
            }
        }
        let i = view.id.index();
        self.scratch.clear();
        for j in 0..view.vehicles {
            let v = VehicleId(j as u16);
            let vehicle = self.vehicle(view, v, view.from(v));
            self.scratch.push(vehicle);
        }
        consensus(&self.params, i, &self.scratch)
    }
}
