use crate::schema::*;
use nalgebra::RowVector3;
use platoon_attacks::channel::{
    BackgroundBeacons, Dcc, LinkAttack, LinkAttackKind, LoadSource, RadioSpec,
};
use platoon_attacks::{DosSchedule, RandomDos};
use platoon_control::{ControllerParams, TriggerRule};
use platoon_model::{LeaderProfile, State, TauSchedule, VehicleId};
use platoon_sim::Scenario;
use platoon_topology::Topology;

type Invalid = (String, String);

fn bad<T>(key: &str, message: impl Into<String>) -> Result<T, Invalid> {
    Err((key.to_string(), message.into()))
}

fn finite(key: &str, x: f64) -> Result<f64, Invalid> {
    if x.is_finite() {
        Ok(x)
    } else {
        bad(key, format!("must be a finite number, got {x}"))
    }
}

fn positive(key: &str, x: f64) -> Result<f64, Invalid> {
    if finite(key, x)? > 0.0 {
        Ok(x)
    } else {
        bad(key, format!("must be > 0, got {x}"))
    }
}

/// A period as a whole number of steps of `dt`.
fn steps_of(key: &str, period: f64, dt: f64) -> Result<u32, Invalid> {
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

/// `[control] law` and its table: the params of the law it names (its table filled with the
/// defaults, so the resolved config says them); a table of another law is an error.
fn law(k: &mut crate::Control) -> Result<platoon_control::LawParams, Invalid> {
    use platoon_control::LawParams as P;
    let chosen = k.law;
    let tables = [
        (LawName::Acc, k.acc.is_some()),
        (LawName::PathCacc, k.path_cacc.is_some()),
        (LawName::Ploeg, k.ploeg.is_some()),
        (LawName::Consensus, k.consensus.is_some()),
        (LawName::Flatbed, k.flatbed.is_some()),
    ];
    if let Some((other, _)) = tables.iter().find(|(n, given)| *given && *n != chosen) {
        return bad(
            &format!("control.{}", other.name()),
            format!(
                "is the table of law = \"{}\", but law = \"{}\": remove it or set law",
                other.name(),
                chosen.name()
            ),
        );
    }
    Ok(match chosen {
        LawName::Paper => P::Paper,
        LawName::Acc => P::Acc(*k.acc.get_or_insert_with(Default::default)),
        LawName::PathCacc => P::PathCacc(*k.path_cacc.get_or_insert_with(Default::default)),
        LawName::Ploeg => P::Ploeg(*k.ploeg.get_or_insert_with(Default::default)),
        LawName::Consensus => {
            P::Consensus(k.consensus.get_or_insert_with(Default::default).clone())
        }
        LawName::Flatbed => P::Flatbed(*k.flatbed.get_or_insert_with(Default::default)),
    })
}

/// `[fallback]`, `[radar]` and `[guard]` (and the older `control.attack_input`).
fn fallback(
    c: &Config,
    dt: f64,
    vehicle_length: f64,
) -> Result<platoon_control::FallbackParams, Invalid> {
    let f = &c.fallback;
    let mode = match (c.control.attack_input, f.mode) {
        (Some(old), Some(new)) if old != new => {
            return bad(
                "control.attack_input",
                format!(
                    "is the older name of fallback.mode, which says {:?}: set only fallback.mode",
                    new
                ),
            )
        }
        (_, Some(m)) | (Some(m), None) => m,
        (None, None) => platoon_control::FallbackMode::Zero,
    };
    let steps = |key: &str, s: f64| -> Result<u32, Invalid> {
        if s == 0.0 {
            Ok(0)
        } else {
            steps_of(key, s, dt)
        }
    };
    let r = &c.radar;
    let g = &c.guard;
    let acc = platoon_control::FallbackMode::Acc;
    let uses_radar =
        g.enabled || mode == acc || f.per_vehicle.as_ref().is_some_and(|p| p.contains(&acc));
    let params = platoon_control::FallbackParams {
        mode,
        per_vehicle: f.per_vehicle.clone().unwrap_or_default(),
        dwell_steps: steps("fallback.dwell_s", f.dwell_s)?,
        blend_steps: steps("fallback.blend_s", f.blend_s)?,
        closing_mps: f.closing_mps,
        acc: f.acc,
        radar: platoon_control::fallback::RadarParams {
            range_m: r.range_m,
            // Checked against the step only where something reads the radar, so a config with
            // another dt needs no [radar] it does not use.
            period_steps: if uses_radar {
                steps_of("radar.period_s", r.period_s, dt)?
            } else {
                ((r.period_s / dt).round().max(1.0)).min(f64::from(u32::MAX)) as u32
            },
            noise_m: r.noise_m,
            noise_mps: r.noise_mps,
            dropout: r.dropout,
            seed: r.seed,
        },
        guard: g.enabled.then_some(platoon_control::fallback::GuardParams {
            ttc_s: g.ttc_s,
            decel_mps2: g.decel_mps2,
        }),
        vehicle_length,
    };
    params
        .validate(c.platoon.followers)
        .or_else(|(key, message)| {
            let key = if key.starts_with("radar.") || key.starts_with("guard.") {
                key.to_string()
            } else {
                format!("fallback.{key}")
            };
            bad(&key, message)
        })?;
    Ok(params)
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
                 (the spacing in formation less platoon.vehicle_length_m = {} m)",
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
            formation(f, n, spacing + headway * v0, vehicle_length, v0)?
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
    let taus = match &c.plant.tau_per_vehicle {
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

    // [control] and [trigger]
    let k = &c.control;
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
    let fallback = fallback(c, dt, vehicle_length)?;
    // The resolved config says the mode under its current name.
    c.fallback.mode = Some(fallback.mode);
    c.control.attack_input = None;
    let law = law(&mut c.control)?;
    if law != platoon_control::LawParams::Paper {
        // The outputs measure every law against the platoon's spacing policy: it must be the
        // one the law keeps.
        let name = law.name();
        let Some((l, h)) = law.spacing_policy(vehicle_length) else {
            return bad(
                &format!("control.{name}.headways_s"),
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
                    "law = \"{name}\" keeps {l} m + {h} s x v front to front (its [control.{name}] \
                     distances plus platoon.vehicle_length_m), the platoon says {spacing} m + \
                     {headway} s x v: set spacing_m = {l} and {policy} in [platoon], or change \
                     [control.{name}]"
                ),
            );
        }
    }
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
            } else if c.control.law != LawName::Paper && !matches!(e.field, "dt" | "headway") {
                format!("control.{}", c.control.law.name())
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

    let (link_attacks, channel_seed) = channel(&c.channel, dt, n)?;
    let jammers = jammers(c, n, dt)?;
    let radio = radio(&mut c.channel, dt)?;
    finite("sumo.start_m", c.sumo.start_m)?;
    positive("sumo.tolerance_m", c.sumo.tolerance_m)?;
    if let Some(p) = c.sumo.fcd_period_s {
        if finite("sumo.fcd_period_s", p)? != 0.0 {
            steps_of("sumo.fcd_period_s", p, dt)?;
        }
    }
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
        let length = hi - lo + vehicle_length;
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
        safety,
        fleet,
        platoon: 0,
    };
    scenario
        .validate()
        .or_else(|e| bad("scenario", e.to_string()))?;
    Ok(scenario)
}

/// `[channel] model` and `[channel.radio]`: the 802.11p model (its table filled with the
/// defaults, so the resolved config says them), built once per distinct configuration in this
/// process (a model costs milliseconds to tabulate; a campaign's cells share it).
fn radio(c: &mut Channel, dt: f64) -> Result<Option<RadioSpec>, Invalid> {
    use std::sync::{Arc, Mutex, OnceLock};
    match c.model {
        RadioModel::Ideal => {
            let radio_only = [
                ("channel.radio", c.radio.is_some()),
                ("channel.load", c.load.is_some()),
                ("channel.background_beacons", c.background_beacons.is_some()),
                ("channel.load_window_s", c.load_window_s.is_some()),
                ("channel.dcc", c.dcc.is_some()),
            ];
            if let Some((key, _)) = radio_only.iter().find(|(_, set)| *set) {
                return bad(
                    key,
                    "belongs to the 802.11p radio, but channel.model = \"ideal\": remove it or \
                     set model = \"80211p\"",
                );
            }
            Ok(None)
        }
        RadioModel::Ieee80211p => {
            let params = *c.radio.get_or_insert_with(Default::default);
            let load = match *c.load.get_or_insert(LoadConfig::Scenario) {
                LoadConfig::Scenario => LoadSource::Scenario,
                LoadConfig::Fixed => LoadSource::Fixed,
            };
            // The counted load's keys mean nothing with the fixed one: refused, not ignored
            // (and not filled in, so the resolved config reads back).
            if load == LoadSource::Fixed {
                for (key, set) in [
                    ("channel.background_beacons", c.background_beacons.is_some()),
                    ("channel.load_window_s", c.load_window_s.is_some()),
                ] {
                    if set {
                        return bad(
                            key,
                            "is for the load counted from the run, but channel.load = \"fixed\": \
                             remove it or set load = \"scenario\"",
                        );
                    }
                }
            }
            let background_beacons = match load {
                LoadSource::Fixed => BackgroundBeacons::Fixed,
                LoadSource::Scenario => match *c
                    .background_beacons
                    .get_or_insert(BackgroundBeaconsConfig::Fixed)
                {
                    BackgroundBeaconsConfig::Fixed => BackgroundBeacons::Fixed,
                    BackgroundBeaconsConfig::Platoon => BackgroundBeacons::Platoon,
                },
            };
            let window_s = match load {
                LoadSource::Fixed => 1.0,
                LoadSource::Scenario => positive(
                    "channel.load_window_s",
                    finite("channel.load_window_s", *c.load_window_s.get_or_insert(1.0))?,
                )?,
            };
            let window_steps = steps_of("channel.load_window_s", window_s, dt)?.max(1) as u64;
            let dcc = match &c.dcc {
                None => None,
                Some(d) => Some(dcc(d)?),
            };
            // One family per distinct radio in this process: its models are built as runs
            // reach their loads, and a campaign's cells share them.
            static FAMILIES: OnceLock<Mutex<Vec<Arc<platoon_radio::LoadFamily>>>> = OnceLock::new();
            let families = FAMILIES.get_or_init(Default::default);
            let mut cache = families.lock().unwrap_or_else(|e| e.into_inner());
            let family = match cache.iter().find(|m| *m.params() == params) {
                Some(f) => f.clone(),
                None => {
                    let family = platoon_radio::LoadFamily::new(params).or_else(|e| {
                        let key = match &e {
                            platoon_radio::Error::Parameter { name, .. } => {
                                format!("channel.radio.{name}")
                            }
                            _ => "channel.radio".to_string(),
                        };
                        bad(&key, e.to_string())
                    })?;
                    let family = Arc::new(family);
                    // A handful of configurations at most in one process; keep the latest 16.
                    if cache.len() >= 16 {
                        cache.remove(0);
                    }
                    cache.push(family.clone());
                    family
                }
            };
            Ok(Some(RadioSpec {
                family,
                load,
                background_beacons,
                dcc,
                window_steps,
                dt,
            }))
        }
    }
}

/// `[detection]`: the detectors in their tables' order and the reaction.
fn detection(
    d: Option<&DetectionConfig>,
    dt: f64,
) -> Result<platoon_control::DetectionParams, Invalid> {
    let Some(d) = d else {
        return Ok(Default::default());
    };
    let tables = platoon_detect::Detection {
        plausibility: d.plausibility,
        radar_cross: d.radar_cross,
        residual: d.residual,
    };
    tables.validate().or_else(|e| {
        bad(
            &format!("detection.{}.{}", e.detector, e.field),
            e.to_string(),
        )
    })?;
    let specs = tables.specs();
    if specs.is_empty() && d.plugin.is_empty() {
        return bad(
            "detection",
            "turns no detector on: add [detection.plausibility], [detection.radar_cross] or \
             [detection.residual] (an empty table takes the defaults), name a plug-in's \
             detectors in plugin = [...], or remove [detection]",
        );
    }
    for (i, name) in d.plugin.iter().enumerate() {
        let key = format!("detection.plugin[{i}]");
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return bad(
                &key,
                format!("{name:?} is not a detector name (letters, digits, _ and - only)"),
            );
        }
        if platoon_detect::DetectorSpec::NAMES.contains(&name.as_str()) {
            return bad(
                &key,
                format!("{name:?} is a built-in detector: turn it on with [detection.{name}]"),
            );
        }
        if d.plugin[..i].contains(name) {
            return bad(&key, format!("names {name:?} twice"));
        }
    }
    if specs.len() + d.plugin.len() > platoon_control::screening::MAX_DETECTORS {
        return bad(
            "detection.plugin",
            format!(
                "makes {} detectors; a platoon runs at most {}",
                specs.len() + d.plugin.len(),
                platoon_control::screening::MAX_DETECTORS
            ),
        );
    }
    let quiet = finite("detection.quiet_s", d.quiet_s)?;
    if quiet < 0.0 {
        return bad("detection.quiet_s", format!("must be >= 0 s (got {quiet})"));
    }
    let quiet_steps = (quiet / dt).round();
    if quiet_steps > f64::from(u32::MAX) {
        return bad("detection.quiet_s", "is longer than any run");
    }
    Ok(platoon_control::DetectionParams {
        specs,
        reaction: d.reaction,
        quiet_steps: quiet_steps as u32,
        plugin: d.plugin.clone(),
    })
}

/// `[channel.dcc]`: the reactive states' thresholds and `T_off`s.
fn dcc(d: &DccConfig) -> Result<Dcc, Invalid> {
    let (th, off) = (&d.cbr_thresholds, &d.t_off_s);
    for (i, &x) in th.iter().enumerate() {
        let key = format!("channel.dcc.cbr_thresholds[{i}]");
        if !(x > 0.0 && x < 1.0) {
            return bad(&key, format!("must be in (0, 1) (got {x})"));
        }
        if i > 0 && x <= th[i - 1] {
            return bad(
                &key,
                format!("must be above the one before ({})", th[i - 1]),
            );
        }
    }
    if off.len() != th.len() + 1 {
        return bad(
            "channel.dcc.t_off_s",
            format!(
                "needs one entry per state: {} thresholds make {} states, got {} times",
                th.len(),
                th.len() + 1,
                off.len()
            ),
        );
    }
    for (i, &x) in off.iter().enumerate() {
        let key = format!("channel.dcc.t_off_s[{i}]");
        if !(x.is_finite() && x >= 0.0) {
            return bad(&key, format!("must be a time >= 0 s (got {x})"));
        }
        if i > 0 && x < off[i - 1] {
            return bad(
                &key,
                format!("must not be below the one before ({})", off[i - 1]),
            );
        }
    }
    Ok(Dcc {
        cbr_thresholds: th.clone(),
        t_off_s: off.clone(),
    })
}

/// Three finite numbers, `[p, v, a]`.
fn finite3(key: &str, x: [f64; 3]) -> Result<[f64; 3], Invalid> {
    if x.iter().any(|v| !v.is_finite()) {
        return bad(key, "must be finite");
    }
    Ok(x)
}

/// `[channel]`: the link-level attacks.
fn channel(c: &Channel, dt: f64, followers: usize) -> Result<(Vec<LinkAttack>, u64), Invalid> {
    let mut out = Vec::with_capacity(c.attacks.len());
    for (i, a) in c.attacks.iter().enumerate() {
        let key = |k: &str| format!("channel.attacks[{i}].{k}");
        let probability = |k: &str, v: f64| {
            if (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                bad(&key(k), format!("must be a probability in [0, 1], got {v}"))
            }
        };
        let ids = |k: &str, v: &Option<Vec<u16>>| -> Result<Vec<VehicleId>, Invalid> {
            let v = v.clone().unwrap_or_default();
            if let Some(bad_id) = v.iter().find(|&&id| usize::from(id) > followers) {
                return bad(
                    &key(k),
                    format!("vehicle {bad_id} does not exist (ids are 0 = leader to {followers})"),
                );
            }
            Ok(v.into_iter().map(VehicleId).collect())
        };
        let kind = match a.kind {
            LinkKindConfig::Bernoulli { loss } => LinkAttackKind::Bernoulli {
                loss: probability("loss", finite(&key("loss"), loss)?)?,
            },
            LinkKindConfig::GilbertElliott {
                p_good_bad,
                p_bad_good,
                loss_good,
                loss_bad,
            } => LinkAttackKind::GilbertElliott {
                p_good_bad: probability("p_good_bad", finite(&key("p_good_bad"), p_good_bad)?)?,
                p_bad_good: probability("p_bad_good", finite(&key("p_bad_good"), p_bad_good)?)?,
                loss_good: probability("loss_good", loss_good)?,
                loss_bad: probability("loss_bad", loss_bad)?,
            },
            LinkKindConfig::Delay { delay_s } => LinkAttackKind::Delay {
                steps: steps_of(&key("delay_s"), finite(&key("delay_s"), delay_s)?, dt)?,
            },
            LinkKindConfig::RangeJamming {
                position_m,
                speed_mps,
                radius_m,
            } => LinkAttackKind::RangeJamming {
                position_m: finite(&key("position_m"), position_m)?,
                speed_mps: finite(&key("speed_mps"), speed_mps)?,
                radius_m: positive(&key("radius_m"), finite(&key("radius_m"), radius_m)?)?,
            },
            LinkKindConfig::Replay { lag_s } => LinkAttackKind::Replay {
                lag_steps: u64::from(steps_of(&key("lag_s"), finite(&key("lag_s"), lag_s)?, dt)?),
            },
            LinkKindConfig::FalseData { offset, .. } => LinkAttackKind::FalseData {
                offset: finite3(&key("offset"), offset)?,
            },
            LinkKindConfig::RandomOffset { std, .. } => {
                if std.iter().any(|&x| x < 0.0) {
                    return bad(&key("std"), format!("must be >= 0 (got {std:?})"));
                }
                LinkAttackKind::RandomOffset {
                    std: finite3(&key("std"), std)?,
                }
            }
            LinkKindConfig::Drift { rate, .. } => LinkAttackKind::Drift {
                rate: finite3(&key("rate"), rate)?,
            },
            LinkKindConfig::FeignedBraking { accel_mps2, .. } => LinkAttackKind::FeignedBraking {
                accel: finite(&key("accel_mps2"), accel_mps2)?,
            },
            LinkKindConfig::AccelScale { factor, .. } => LinkAttackKind::AccelScale {
                factor: finite(&key("factor"), factor)?,
            },
        };
        let insider = a.kind.insider();
        if insider && a.receivers.is_some() {
            return bad(
                &key("insider"),
                "an insider's broadcast reaches every receiver alike: drop `receivers`",
            );
        }
        let start_s = finite(&key("start_s"), a.start_s)?;
        let end_s = a.end_s;
        if end_s.is_nan() || end_s <= start_s {
            return bad(&key("end_s"), format!("must be after start_s = {start_s}"));
        }
        out.push(LinkAttack {
            kind,
            start_s,
            end_s,
            senders: ids("senders", &a.senders)?,
            receivers: ids("receivers", &a.receivers)?,
            insider,
        });
    }
    Ok((out, c.seed))
}

/// `[[channel.jammers]]`: jammers as transmitters. Each is heard above the sensing threshold out
/// to the radio's sensing radius for its power (`[channel.radio]`, its defaults without one),
/// and senses the vehicles out to theirs.
fn jammers(
    c: &Config,
    followers: usize,
    dt: f64,
) -> Result<Vec<platoon_attacks::jammer::Jammer>, Invalid> {
    use crate::schema::JammerBehaviour as B;
    use platoon_attacks::jammer::{Behaviour, Jammer, Placement};
    let radio = c.channel.radio.unwrap_or_default();
    let mut out = Vec::with_capacity(c.channel.jammers.len());
    for (i, j) in c.channel.jammers.iter().enumerate() {
        let key = |k: &str| format!("channel.jammers[{i}].{k}");
        let lateral_m = finite(&key("lateral_m"), j.lateral_m)?;
        if lateral_m < 0.0 {
            return bad(&key("lateral_m"), format!("must be >= 0 (got {lateral_m})"));
        }
        let speed_mps = finite(&key("speed_mps"), j.speed_mps)?;
        let placement = match (j.position_m, j.member, j.background) {
            (Some(x), None, None) => Placement::Roadside {
                position_m: finite(&key("position_m"), x)?,
                speed_mps,
                lateral_m,
            },
            (None, Some(v), None) => {
                if usize::from(v) > followers {
                    return bad(
                        &key("member"),
                        format!("vehicle {v} does not exist (ids are 0 = leader to {followers})"),
                    );
                }
                Placement::Member {
                    vehicle: VehicleId(v),
                    offset_m: finite(&key("offset_m"), j.offset_m.unwrap_or(0.0))?,
                    lateral_m,
                }
            }
            (None, None, Some(index)) => {
                let bg = c.sumo.background_vehicles;
                if c.simulation.plant != PlantKind::Sumo || index >= bg {
                    return bad(
                        &key("background"),
                        format!(
                            "rides SUMO background vehicle bg{index}: needs simulation.plant = \"sumo\" \
                             and sumo.background_vehicles > {index} (it is {bg})"
                        ),
                    );
                }
                Placement::Background { index, lateral_m }
            }
            (None, None, None) => {
                return bad(
                    &key("position_m"),
                    "missing: give position_m (roadside), member (a platoon vehicle) or \
                     background (a SUMO background vehicle)",
                )
            }
            _ => {
                return bad(
                    &key("position_m"),
                    "give only one of position_m, member and background",
                )
            }
        };
        if j.offset_m.is_some() && j.member.is_none() {
            return bad(
                &key("offset_m"),
                "is the offset from a member; give member too",
            );
        }
        if speed_mps != 0.0 && j.position_m.is_none() {
            return bad(
                &key("speed_mps"),
                "only a roadside jammer (position_m) has its own speed",
            );
        }
        let power_dbm = finite(&key("power_dbm"), j.power_dbm)?;
        if !(-30.0..=60.0).contains(&power_dbm) {
            return bad(
                &key("power_dbm"),
                format!("must be in [-30, 60] dBm (1 µW to 1 kW), got {power_dbm}"),
            );
        }
        let heard_m = radio.sensing_radius_m(power_dbm);
        if heard_m <= 0.0 {
            return bad(
                &key("power_dbm"),
                format!(
                    "{power_dbm} dBm is below the sensing threshold ({} dBm) even at 1 m",
                    radio.sensing_threshold_dbm
                ),
            );
        }
        let start_s = finite(&key("start_s"), j.start_s)?;
        if start_s < 0.0 {
            return bad(&key("start_s"), format!("must be >= 0 s (got {start_s})"));
        }
        if j.end_s.is_nan() || j.end_s <= start_s {
            return bad(&key("end_s"), format!("must be after start_s = {start_s}"));
        }
        let periodic = j.on_s.is_some() || j.off_s.is_some();
        let random = j.mean_on_s.is_some() || j.mean_off_s.is_some();
        let kind = j
            .behaviour
            .unwrap_or(if periodic { B::Periodic } else { B::Constant });
        if periodic && kind != B::Periodic {
            return bad(
                &key("on_s"),
                "on_s and off_s are for behaviour = \"periodic\"",
            );
        }
        if random && kind != B::Random {
            return bad(
                &key("mean_on_s"),
                "mean_on_s and mean_off_s are for behaviour = \"random\"",
            );
        }
        // On and off times of at least a step: the channel changes only from step to step.
        let time = |k: &str, v: Option<f64>, what: &str| match v {
            Some(v) if finite(&key(k), v)? >= dt => Ok(v),
            Some(v) => bad(
                &key(k),
                format!("must be at least one step ({dt} s), got {v}"),
            ),
            None => bad(&key(k), format!("a {what} jammer needs it")),
        };
        let behaviour = match kind {
            B::Constant => Behaviour::Constant,
            B::Reactive => Behaviour::Reactive,
            B::Periodic => {
                if j.on_s.is_none() {
                    return bad(&key("on_s"), "a periodic jammer needs both on_s and off_s");
                }
                if j.off_s.is_none() {
                    return bad(&key("off_s"), "a periodic jammer needs both on_s and off_s");
                }
                Behaviour::Periodic {
                    on_s: time("on_s", j.on_s, "periodic")?,
                    off_s: time("off_s", j.off_s, "periodic")?,
                }
            }
            B::Random => Behaviour::Random {
                mean_on_s: time("mean_on_s", j.mean_on_s, "random")?,
                mean_off_s: time("mean_off_s", j.mean_off_s, "random")?,
            },
        };
        out.push(Jammer {
            placement,
            power_dbm,
            start_s,
            end_s: j.end_s,
            behaviour,
            heard_m,
            senses_m: radio.sensing_radius_m(radio.tx_power_dbm),
        });
    }
    Ok(out)
}
