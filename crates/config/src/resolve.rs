//! Resolving a parsed config into the pure core's [`Scenario`]: one pass that lowers each table
//! and checks each value as it is lowered, so every error names the key whose value it read
//! (`(key, message)`), and fills the defaults that depend on other keys. One module per table
//! family (`channel`, `control`); the schema with its own defaults is `crate::schema`.
use crate::schema::*;
use nalgebra::RowVector3;
use platoon_attacks::{DosSchedule, RandomDos};
use platoon_control::{ControllerParams, TriggerRule};
use platoon_model::{LeaderProfile, State, TauSchedule};
use platoon_sim::Scenario;
use platoon_topology::Topology;

mod channel;
mod control;
mod vehicles;

use channel::{channel, jammers, radio};
use control::{detection, fallback, maneuvers};

pub(crate) type Invalid = (String, String);

pub(crate) fn bad<T>(key: &str, message: impl Into<String>) -> Result<T, Invalid> {
    Err((key.to_string(), message.into()))
}

pub(crate) fn finite(key: &str, x: f64) -> Result<f64, Invalid> {
    if x.is_finite() {
        Ok(x)
    } else {
        bad(key, format!("must be a finite number, got {x}"))
    }
}

pub(crate) fn positive(key: &str, x: f64) -> Result<f64, Invalid> {
    if finite(key, x)? > 0.0 {
        Ok(x)
    } else {
        bad(key, format!("must be > 0, got {x}"))
    }
}

/// A period as a whole number of steps of `dt`.
pub(crate) fn steps_of(key: &str, period: f64, dt: f64) -> Result<u32, Invalid> {
    positive(key, period)?;
    if period < dt * (1.0 - 1e-9) {
        return bad(
            key,
            format!("{period} s is shorter than the step simulation.dt_s = {dt} s"),
        );
    }
    let n = (period / dt).round();
    if (n * dt - period).abs() > 1e-9 * period.max(1.0) || n > f64::from(u32::MAX) {
        return bad(
            key,
            format!("{period} s must be a whole number of steps of {dt} s"),
        );
    }
    Ok(n as u32)
}

fn tau_schedule(key: &str, t: &TauConfig) -> Result<TauSchedule, Invalid> {
    let r = match t {
        TauConfig::Paper {} => Ok(TauSchedule::paper()),
        TauConfig::Constant { value_s } => TauSchedule::constant(*value_s),
        TauConfig::Knots {
            knots,
            interpolation,
        } => TauSchedule::new(knots.iter().map(|k| (k[0], k[1])).collect(), *interpolation),
    };
    r.or_else(|e| bad(key, e.to_string()))
}

fn leader_profile(profile: &LeaderProfileConfig) -> Result<LeaderProfile, Invalid> {
    Ok(match profile {
        LeaderProfileConfig::Paper {} => LeaderProfile::paper(),
        LeaderProfileConfig::Constant { speed_mps } => {
            LeaderProfile::constant(finite("leader.profile.speed_mps", *speed_mps)?)
        }
        LeaderProfileConfig::Waypoints { points } => {
            LeaderProfile::from_waypoints(points.iter().map(|w| (w[0], w[1])).collect())
                .or_else(|e| bad("leader.profile.points", e.to_string()))?
        }
    })
}

/// The states of `[platoon.formation]` (see [`Formation`]): the leader first.
fn formation(
    f: &Formation,
    n: usize,
    spacing: f64,
    length: f64,
    speed: f64,
) -> Result<Vec<State>, Invalid> {
    use rand::{Rng, SeedableRng};
    let p0 = finite("platoon.formation.leader_position_m", f.leader_position_m)?;
    let jp = finite("platoon.formation.position_jitter_m", f.position_jitter_m)?;
    let jv = finite("platoon.formation.speed_jitter_mps", f.speed_jitter_mps)?;
    if jp < 0.0 || jv < 0.0 {
        return bad(
            if jp < 0.0 {
                "platoon.formation.position_jitter_m"
            } else {
                "platoon.formation.speed_jitter_mps"
            },
            "must be >= 0",
        );
    }
    if jp >= (spacing - length) / 2.0 {
        return bad(
            "platoon.formation.position_jitter_m",
            format!(
                "{jp} m could make two vehicles touch: keep it below half the gap \
                 (the spacing in formation less the longest vehicle, {} m)",
                spacing - length
            ),
        );
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(f.seed);
    let mut draw = |half: f64| {
        let u: f64 = rng.gen_range(-1.0..=1.0);
        u * half
    };
    let mut states = vec![State::new(p0, speed, 0.0)];
    for i in 1..=n {
        let dp = draw(jp);
        let dv = draw(jv);
        states.push(State::new(p0 - i as f64 * spacing + dp, speed + dv, 0.0));
    }
    Ok(states)
}

/// Followers per platoon at most: the topology is a dense N x N matrix.
pub const MAX_FOLLOWERS: usize = 4096;
/// Vehicles of a whole fleet at most.
pub const MAX_VEHICLES: usize = 1_000_000;
/// Steps of a run at most (a year of simulated time at dt = 0.01 s would be 3e9).
pub const MAX_STEPS: f64 = 1e9;

/// Validates a parsed config, fills the defaults that depend on other keys (so the config is
/// resolved), and builds the scenario. Errors are `(key, message)`.
pub fn to_scenario(c: &mut Config) -> Result<Scenario, Invalid> {
    // [simulation]
    let dt = positive("simulation.dt_s", c.simulation.dt_s)?;
    let duration = positive("simulation.duration_s", c.simulation.duration_s)?;
    let steps = (duration / dt).round();
    if steps > MAX_STEPS {
        return bad(
            "simulation.duration_s",
            format!("{duration} s in steps of {dt} s is {steps:e} steps, more than {MAX_STEPS:e}"),
        );
    }
    if (steps * dt - duration).abs() > 1e-9 * duration.max(1.0) {
        return bad(
            "simulation.duration_s",
            format!("{duration} s is not a whole number of steps of {dt} s"),
        );
    }

    // [platoon]
    let p = &c.platoon;
    let n = p.followers;
    if n == 0 {
        return bad("platoon.followers", "a platoon needs at least one follower");
    }
    if n > MAX_FOLLOWERS {
        return bad(
            "platoon.followers",
            format!("{n} is more than {MAX_FOLLOWERS} (the graph is a dense N x N matrix); for more vehicles use [fleet] platoons"),
        );
    }
    let spacing = positive("platoon.spacing_m", p.spacing_m)?;
    let headway = match p.spacing {
        SpacingConfig::Constant {} => 0.0,
        SpacingConfig::TimeHeadway { time_headway_s } => {
            let h = positive("platoon.time_headway_s", time_headway_s)?;
            if h > 60.0 {
                return bad(
                    "platoon.time_headway_s",
                    format!(
                        "{h} s is not a time headway (vehicles keep 0.5 to 3 s); use at most 60"
                    ),
                );
            }
            h
        }
    };
    let vehicle_length = finite("platoon.vehicle_length_m", p.vehicle_length_m)?;
    if vehicle_length < 0.0 {
        return bad("platoon.vehicle_length_m", "must be >= 0");
    }
    let members = vehicles::members(c, n)?;
    // The longest vehicle: what the checks on whole-platoon room count.
    let longest = members.iter().map(|m| m.length()).fold(
        if members.is_empty() {
            vehicle_length
        } else {
            0.0
        },
        f64::max,
    );
    let p = &c.platoon;
    let leader = leader_profile(&c.leader.profile)?;
    let initial: Vec<State> = match (&p.initial_states, &p.formation) {
        (Some(_), Some(_)) => {
            return bad(
                "platoon.formation",
                "give either platoon.initial_states or [platoon.formation], not both",
            )
        }
        (None, None) => return bad(
            "platoon.initial_states",
            "missing: list the N + 1 initial states, or give [platoon.formation] to generate them",
        ),
        (Some(states), None) => {
            if states.len() != n + 1 {
                return bad(
                    "platoon.initial_states",
                    format!(
                        "lists {} states but platoon.followers = {n} needs {} (the leader first; \
                         [platoon.formation] generates them for any size)",
                        states.len(),
                        n + 1
                    ),
                );
            }
            for (i, s) in states.iter().enumerate() {
                if s.iter().any(|x| !x.is_finite()) {
                    return bad(
                        &format!("platoon.initial_states[{i}]"),
                        "must hold finite numbers",
                    );
                }
            }
            states
                .iter()
                .map(|s| State::new(s[0], s[1], s[2]))
                .collect()
        }
        (None, Some(f)) => {
            let v0 = leader.velocity_at(0.0);
            formation(f, n, spacing + headway * v0, longest, v0)?
        }
    };

    // [leader]
    if (leader.velocity_at(0.0) - initial[0][1]).abs() > 1e-9 {
        return bad(
            "leader.profile",
            format!(
                "starts at {} m/s but platoon.initial_states[0] gives the leader {} m/s",
                leader.velocity_at(0.0),
                initial[0][1]
            ),
        );
    }
    let leader_broadcast_steps = match c.leader.broadcast_period_s {
        None => 1,
        Some(s) => steps_of("leader.broadcast_period_s", s, dt)?,
    };

    // [topology]
    let topology = match (&c.topology, c.topology.preset()) {
        (TopologyConfig::Explicit { adjacency, pinning }, _) => {
            Topology::explicit(adjacency.clone(), pinning.clone())
        }
        (_, Some(preset)) => Topology::preset(preset, n),
        (_, None) => unreachable!("every topology but an explicit one is a preset"),
    }
    .or_else(|e| bad("topology", e.to_string()))?;
    if topology.followers() != n {
        return bad(
            "topology.adjacency",
            format!(
                "describes {} followers, platoon.followers = {n}",
                topology.followers()
            ),
        );
    }

    // [plant]
    let tau_nominal = positive("plant.tau_nominal_s", c.plant.tau_nominal_s)?;
    let mut taus: Vec<TauSchedule> = match &c.plant.tau_per_vehicle {
        None => {
            let s = tau_schedule("plant.tau", &c.plant.tau)?;
            vec![s; n]
        }
        Some(list) => {
            if list.len() != n {
                return bad(
                    "plant.tau_per_vehicle",
                    format!("has {} entries, platoon.followers = {n}", list.len()),
                );
            }
            list.iter()
                .enumerate()
                .map(|(i, t)| tau_schedule(&format!("plant.tau_per_vehicle[{i}]"), t))
                .collect::<Result<_, _>>()?
        }
    };

    // [vehicle_classes]
    let vehicles = vehicles::vehicles(c, &members, &mut taus, tau_nominal, &leader, &initial)?;
    drop(members);

    // [control] and [trigger]
    let k = c.control.paper_law();
    for (i, g) in k.gain.iter().enumerate() {
        finite(&format!("control.gain[{i}]"), *g)?;
    }
    let beta1 = positive("control.beta1", k.beta1)?;
    let beta2 = positive("control.beta2", k.beta2)?;
    let tr = &mut c.trigger;
    let check_period = *tr.check_period_s.get_or_insert(dt);
    let check_steps = steps_of("trigger.check_period_s", check_period, dt)?;
    let h_steps = steps_of("trigger.h_s", tr.h_s, dt)?;
    let rule = match tr.rule {
        RuleConfig::Dynamic {
            phi,
            rho,
            eta,
            theta0,
        } => TriggerRule::Dynamic {
            phi: finite("trigger.phi", phi)?,
            rho: finite("trigger.rho", rho)?,
            eta: finite("trigger.eta", eta)?,
            theta0: finite("trigger.theta0", theta0)?,
        },
        RuleConfig::Static {} => TriggerRule::Static,
        RuleConfig::Mixed { mu, alpha } => TriggerRule::Mixed {
            mu: finite("trigger.mu", mu)?,
            alpha: finite("trigger.alpha", alpha)?,
        },
        RuleConfig::Cam {
            min_interval_s,
            max_interval_s,
            position_m,
            speed_mps,
        } => TriggerRule::Cam(platoon_control::CamRule {
            min_steps: steps_of(
                "trigger.min_interval_s",
                finite("trigger.min_interval_s", min_interval_s)?,
                dt,
            )?,
            max_steps: steps_of(
                "trigger.max_interval_s",
                finite("trigger.max_interval_s", max_interval_s)?,
                dt,
            )?,
            position_m: finite("trigger.position_m", position_m)?,
            speed_mps: finite("trigger.speed_mps", speed_mps)?,
        }),
        RuleConfig::Periodic { period_s } => TriggerRule::Periodic {
            period_steps: steps_of(
                "trigger.period_s",
                finite("trigger.period_s", period_s)?,
                dt,
            )?,
        },
    };
    let resilient = tr.resilient;
    let gain = RowVector3::new(k.gain[0], k.gain[1], k.gain[2]);
    let mut fallback = fallback(c, dt, vehicle_length)?;
    fallback.lengths = vehicles.iter().map(|v| v.length_m).collect();
    // The resolved config says the mode under its current name.
    c.fallback.mode = Some(fallback.mode);
    c.control.attack_input = None;
    let law = c.control.law.params();
    if !law.follows_head() && fallback.cut_in.is_some_and(|h| h.split) {
        return bad(
            "fallback.cut_in.split",
            format!(
                "law = \"{}\" has no leader to re-point (it reads its predecessor, or every \
                 member by place): split behind a cut-in works with the laws that follow the \
                 head of their part, control.law = \"paper\", \"path_cacc\" or \"flatbed\"",
                law.name()
            ),
        );
    }
    if law != platoon_control::LawParams::Paper
        && vehicles.iter().any(|v| v.length_m != vehicle_length)
    {
        return bad(
            "platoon.members",
            format!(
                "law = \"{}\" keeps one vehicle length (platoon.vehicle_length_m = \
                 {vehicle_length} m), but the members' classes give others: use law = \"paper\" \
                 with vehicle classes of other lengths",
                law.name()
            ),
        );
    }
    if law != platoon_control::LawParams::Paper {
        // The outputs measure every law against the platoon's spacing policy: it must be the
        // one the law keeps.
        let name = law.name();
        let Some((l, h)) = law.spacing_policy(vehicle_length) else {
            return bad(
                "control.headways_s",
                "the outputs need one time headway for every vehicle",
            );
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
        if !close(spacing, l) || !close(headway, h) {
            let policy = if h == 0.0 {
                "spacing_policy = \"constant\"".to_string()
            } else {
                format!("spacing_policy = \"time_headway\", time_headway_s = {h}")
            };
            return bad(
                if !close(spacing, l) {
                    "platoon.spacing_m"
                } else if headway > 0.0 && h > 0.0 {
                    "platoon.time_headway_s"
                } else {
                    "platoon.spacing_policy"
                },
                format!(
                    "law = \"{name}\" keeps {l} m + {h} s x v front to front (its distances in \
                     [control] plus platoon.vehicle_length_m), the platoon says {spacing} m + \
                     {headway} s x v: set spacing_m = {l} and {policy} in [platoon], or change \
                     the law's distances in [control]"
                ),
            );
        }
    }
    let cut_in_splits = fallback.cut_in.map(|h| h.split);
    let control = ControllerParams {
        law,
        gain,
        beta1,
        beta2,
        rule,
        resilient,
        h_steps,
        check_steps,
        fallback,
        dt,
        tau_nominal,
        spacing,
        headway,
        leader_broadcast_steps,
        detection: detection(c.detection.as_ref(), dt)?,
        maneuvers: maneuvers(c.maneuvers.as_ref(), n, dt, cut_in_splits)?,
    };
    control
        .validate()
        .and_then(|()| platoon_control::check_topology(&control, &topology))
        .or_else(|e| {
            let section = if matches!(
                e.field,
                "phi"
                    | "rho"
                    | "eta"
                    | "mu"
                    | "period"
                    | "h"
                    | "rule"
                    | "min_interval_s"
                    | "position_m"
                    | "speed_mps"
            ) {
                "trigger".to_string()
            } else if e.field == "preset" {
                "topology".to_string()
            } else if e.field == "maneuvers" {
                return bad("maneuvers", e.message);
            } else {
                "control".to_string()
            };
            bad(&format!("{section}.{}", e.field), e.message)
        })?;

    // [attack]
    let a = &c.attack;
    if let Some(b) = &a.assumption2 {
        b.validate()
            .or_else(|e| bad("attack.assumption2", e.to_string()))?;
    }
    let dos = match &a.kind {
        DosConfig::None {} => DosSchedule::none(),
        DosConfig::Intervals { intervals } => {
            let pairs: Vec<(f64, f64)> = intervals.iter().map(|p| (p[0], p[1])).collect();
            DosSchedule::from_intervals(&pairs)
                .or_else(|e| bad("attack.intervals", e.to_string()))?
        }
        DosConfig::Periodic {
            period_s,
            duration_s,
            offset_s,
        } => DosSchedule::periodic(*period_s, *duration_s, *offset_s, duration)
            .or_else(|e| bad("attack.period_s", e.to_string()))?,
        DosConfig::Random {
            seed,
            min_gap_s,
            max_gap_s,
            min_duration_s,
            max_duration_s,
        } => {
            let Some(bounds) = &a.assumption2 else {
                return bad(
                    "attack.assumption2",
                    "is required with kind = \"random\" (the generator satisfies these bounds)",
                );
            };
            let generator = RandomDos {
                seed: *seed,
                min_gap: *min_gap_s,
                max_gap: *max_gap_s,
                min_duration: *min_duration_s,
                max_duration: *max_duration_s,
            };
            generator
                .generate(bounds, duration)
                .or_else(|e| bad("attack", e.to_string()))?
        }
    };

    let regroups = c
        .maneuvers
        .as_ref()
        .is_some_and(|m| m.merge.is_some() || m.split.is_some());
    let (link_attacks, channel_seed) = channel(&c.channel, dt, n, regroups)?;
    let jammers = jammers(c, n, dt)?;
    let radio = radio(&mut c.channel, dt)?;
    finite("sumo.start_m", c.sumo.start_m)?;
    positive("sumo.tolerance_m", c.sumo.tolerance_m)?;
    let share = finite("sumo.background_truck_share", c.sumo.background_truck_share)?;
    if !(0.0..=1.0).contains(&share) {
        return bad(
            "sumo.background_truck_share",
            format!("must be in [0, 1], got {share}"),
        );
    }
    if let Some(lc) = &c.sumo.background_lane_changes {
        let key = |k: &str| format!("sumo.background_lane_changes.{k}");
        if !(0.0..=1.0).contains(&finite(&key("cooperative"), lc.cooperative)?) {
            return bad(
                &key("cooperative"),
                format!("must be in [0, 1], got {}", lc.cooperative),
            );
        }
        for (k, x) in [("speed_gain", lc.speed_gain), ("keep_right", lc.keep_right)] {
            if finite(&key(k), x)? < 0.0 {
                return bad(&key(k), format!("must be >= 0, got {x}"));
            }
        }
        positive(&key("assertive"), lc.assertive)?;
    }
    if let Some(p) = c.sumo.fcd_period_s {
        if finite("sumo.fcd_period_s", p)? != 0.0 {
            steps_of("sumo.fcd_period_s", p, dt)?;
        }
    }
    traffic_around(c)?;
    let sf = &c.safety;
    positive("safety.none_decel_mps2", sf.none_decel_mps2)?;
    // positive() has ruled out NaN, so < is the negation of >=.
    if positive("safety.negligible_decel_mps2", sf.negligible_decel_mps2)? < sf.none_decel_mps2 {
        return bad("safety.negligible_decel_mps2", "must be >= none_decel_mps2");
    }
    if positive("safety.benign_decel_mps2", sf.benign_decel_mps2)? < sf.negligible_decel_mps2 {
        return bad(
            "safety.benign_decel_mps2",
            "must be >= negligible_decel_mps2",
        );
    }
    let f = &c.fleet;
    let lanes = f.lanes.clone().unwrap_or_else(|| vec![c.sumo.lane]);
    let o = &c.output;
    if o.decimate == 0 {
        return bad("output.decimate", "must be at least 1 (every step)");
    }
    if f.platoons == 0 {
        return bad("fleet.platoons", "needs at least one platoon");
    }
    if f.platoons.saturating_mul(n + 1) > MAX_VEHICLES {
        return bad(
            "fleet.platoons",
            format!(
                "{} platoons of {} vehicles is more than {MAX_VEHICLES} vehicles",
                f.platoons,
                n + 1
            ),
        );
    }
    if lanes.is_empty() {
        return bad("fleet.lanes", "needs at least one lane");
    }
    if f.platoons > lanes.len() {
        let (lo, hi) = initial
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x[0]), hi.max(x[0]))
            });
        let length = hi - lo + longest;
        if finite("fleet.gap_m", f.gap_m)? <= length {
            return bad(
                "fleet.gap_m",
                format!(
                    "{} m is not more than a platoon's length ({length} m): platoons on one lane would overlap",
                    f.gap_m
                ),
            );
        }
    }
    let fleet = platoon_sim::Fleet {
        platoons: f.platoons,
        lanes,
        gap_m: f.gap_m,
    };
    let safety = platoon_sim::SafetyThresholds {
        none: sf.none_decel_mps2,
        negligible: sf.negligible_decel_mps2,
        benign: sf.benign_decel_mps2,
    };
    let discretisation = c.plant.discretisation;
    if discretisation != platoon_model::Discretisation::Exact
        && c.simulation.plant == PlantKind::Sumo
    {
        return bad(
            "plant.discretisation",
            "the SUMO plant moves vehicles its own way; \"plexe\" is for the native plant \
             (simulation.plant = \"native\")",
        );
    }
    let scenario = Scenario {
        steps: steps as u64,
        initial,
        leader,
        taus,
        discretisation,
        topology,
        control,
        dos,
        link_attacks,
        jammers,
        channel_seed,
        radio,
        assumption2: a.assumption2,
        vehicle_length,
        vehicles,
        cut_ins: control::cut_ins(c, vehicle_length, duration)?,
        safety,
        fleet,
        platoon: 0,
    };
    scenario
        .validate()
        .or_else(|e| bad("scenario", e.to_string()))?;
    Ok(scenario)
}

/// The leader in SUMO's traffic (`leader.drive`), the vehicles ahead of it (`[[sumo.ahead]]`),
/// the flows (`[[sumo.flows]]`) and the route through several edges (`sumo.route`).
fn traffic_around(c: &Config) -> Result<(), Invalid> {
    use crate::schema::LeaderDrive;
    let sumo_plant = c.simulation.plant == PlantKind::Sumo;
    if let LeaderDrive::Sumo {
        speed_mps,
        accel_mps2,
        decel_mps2,
        headway_s,
        min_gap_m,
        ..
    } = &c.leader.drive
    {
        if !sumo_plant {
            return bad(
                "leader.drive",
                "kind = \"sumo\" has SUMO's car-following model drive the leader, which needs \
                 SUMO as the plant: set simulation.plant = \"sumo\" (the native plant's leader \
                 follows leader.profile)",
            );
        }
        if c.sumo.states == crate::schema::SumoStates::Model {
            return bad(
                "leader.drive",
                "kind = \"sumo\": SUMO moves the leader, so the controllers must see SUMO's \
                 states (sumo.states = \"sumo\"), not the model's",
            );
        }
        positive("leader.drive.speed_mps", *speed_mps)?;
        positive("leader.drive.accel_mps2", *accel_mps2)?;
        positive("leader.drive.decel_mps2", *decel_mps2)?;
        positive("leader.drive.headway_s", *headway_s)?;
        if finite("leader.drive.min_gap_m", *min_gap_m)? < 0.0 {
            return bad(
                "leader.drive.min_gap_m",
                format!("must be >= 0, got {min_gap_m}"),
            );
        }
    }
    for (i, a) in c.sumo.ahead.iter().enumerate() {
        let key = |k: &str| format!("sumo.ahead[{i}].{k}");
        positive(&key("gap_m"), a.gap_m)?;
        positive(&key("length_m"), a.length_m)?;
        if finite(&key("speed_mps"), a.speed_mps)? < 0.0 {
            return bad(
                &key("speed_mps"),
                format!("must be >= 0, got {}", a.speed_mps),
            );
        }
    }
    for (i, f) in c.sumo.flows.iter().enumerate() {
        let key = |k: &str| format!("sumo.flows[{i}].{k}");
        for (k, edge) in [("from", &f.from), ("to", &f.to)] {
            if edge.is_empty() {
                return bad(&key(k), "must name an edge of the network");
            }
        }
        positive(&key("vehicles_per_hour"), f.vehicles_per_hour)?;
        if finite(&key("begin_s"), f.begin_s)? < 0.0 {
            return bad(&key("begin_s"), format!("must be >= 0, got {}", f.begin_s));
        }
        if f.end_s.is_none() && f.begin_s >= c.simulation.duration_s {
            return bad(
                &key("begin_s"),
                format!(
                    "{} s is not before the run's end (simulation.duration_s = {} s): no vehicle \
                     would enter",
                    f.begin_s, c.simulation.duration_s
                ),
            );
        }
        if let Some(end) = f.end_s {
            if finite(&key("end_s"), end)? <= f.begin_s {
                return bad(
                    &key("end_s"),
                    format!("must be after begin_s = {}", f.begin_s),
                );
            }
        }
        if let Some(v) = f.speed_mps {
            if finite(&key("speed_mps"), v)? < 0.0 {
                return bad(&key("speed_mps"), format!("must be >= 0, got {v}"));
            }
        }
        if !(0.0..=1.0).contains(&finite(&key("truck_share"), f.truck_share)?) {
            return bad(
                &key("truck_share"),
                format!("must be in [0, 1], got {}", f.truck_share),
            );
        }
    }
    let route = &c.sumo.route;
    if let Some(first) = route.first() {
        if *first != c.sumo.edge {
            return bad(
                "sumo.route",
                format!(
                    "starts on {first:?}, but the platoon starts on sumo.edge = {:?}: the route's \
                     first edge is the one the platoon starts on",
                    c.sumo.edge
                ),
            );
        }
        if route.len() > 1 && !c.cut_ins.is_empty() {
            return bad(
                "sumo.route",
                "[[cut_ins]] on a route of several edges is not built: use one edge, or SUMO's \
                 own traffic ([[sumo.flows]], background_vehicles)",
            );
        }
        if route.len() > 1 && c.sumo.fcd == crate::schema::FcdWriter::Recorded {
            let period = c.sumo.fcd_period_s;
            if period != Some(0.0) {
                return bad(
                    "sumo.fcd",
                    "platoon writes fcd.xml on one edge's lanes; on a route of several edges set \
                     sumo.fcd = \"sumo\" (SUMO writes it during the run) or sumo.fcd_period_s = 0",
                );
            }
        }
    }
    Ok(())
}
