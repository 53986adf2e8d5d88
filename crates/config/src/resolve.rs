//! Resolving a parsed config into the pure core's [`Scenario`]: one resolver per table (a
//! module each), each checking the values it lowers, so that every error names the key whose
//! value it read ([`KeyError`]). [`scenario_of`] runs them in order and reads the config only;
//! [`write_resolved_defaults`] is the separate step that writes the defaults that depend on
//! other keys into the config (what a run directory's `config.toml` says). The schema with its
//! own defaults is `crate::schema`.
use crate::error::KeyError;
use crate::schema::Config;
use platoon_control::ControllerParams;
use platoon_sim::Scenario;

mod attack;
mod channel;
mod checks;
mod control;
mod cut_ins;
mod defaults;
mod detection;
mod fallback;
mod fleet;
mod geometry;
mod jammers;
mod leader;
mod maneuvers;
mod output;
mod plant;
mod platoon;
mod radio;
mod safety;
mod security;
mod simulation;
mod sumo;
mod topology;
mod trigger;
mod vehicles;

pub use defaults::write_resolved_defaults;

/// Resolves a parsed config into its scenario, checking every value; the config is only read
/// (see [`write_resolved_defaults`] for the defaults that depend on other keys). The tables
/// are resolved in a fixed order, so a config with several errors always names the same one.
pub fn scenario_of(c: &Config) -> Result<Scenario, KeyError> {
    let grid = simulation::grid(&c.simulation)?;
    let dt = grid.dt;
    let shape = platoon::shape(&c.platoon)?;
    let n = shape.n;
    let members = vehicles::members(c, n)?;
    // The longest vehicle: what the checks on whole-platoon room count, and its key.
    let (longest, longest_key) = members.iter().map(|m| (m.length(), m.length_key())).fold(
        (
            if members.is_empty() {
                shape.vehicle_length
            } else {
                0.0
            },
            "platoon.vehicle_length_m".to_string(),
        ),
        |a, b| if b.0 > a.0 { b } else { a },
    );
    let leader = leader::profile(&c.leader.profile)?;
    let initial = platoon::initial_states(&c.platoon, &shape, (longest, &longest_key), &leader)?;
    leader::check_start(&leader, &initial)?;
    let leader_broadcast_steps = leader::broadcast_steps(&c.leader, dt)?;
    let topology = topology::topology(&c.topology, n)?;
    let tau_nominal = plant::tau_nominal(&c.plant)?;
    let mut taus = plant::taus(&c.plant, n)?;
    let vehicles = vehicles::vehicles(c, &members, &mut taus, tau_nominal, &leader, &initial)?;
    drop(members);
    let layout = geometry::Layout {
        initial: &initial,
        lengths: if vehicles.is_empty() {
            vec![shape.vehicle_length; n + 1]
        } else {
            vehicles.iter().map(|v| v.length_m).collect()
        },
        spacing: shape.spacing,
        headway: shape.headway,
        leader: &leader,
    };
    geometry::initial_states(c, &layout)?;

    let (gain, beta1, beta2) = control::paper_gains(&c.control)?;
    let triggering = trigger::triggering(&c.trigger, dt)?;
    let mut fallback = fallback::fallback(c, dt, shape.vehicle_length)?;
    fallback.lengths = vehicles.iter().map(|v| v.length_m).collect();
    let law = control::law(&c.control);
    if let (Some(h), Some(split)) = (
        &mut fallback.cut_in,
        control::cut_in_split(c, &law, &topology),
    ) {
        h.split = split;
    }
    control::check_law(&law, &fallback, &vehicles, &shape)?;
    let cut_in_splits = fallback.cut_in.map(|h| h.split);
    let control = ControllerParams {
        law,
        gain,
        beta1,
        beta2,
        rule: triggering.rule,
        resilient: triggering.resilient,
        h_steps: triggering.h_steps,
        check_steps: triggering.check_steps,
        fallback,
        dt,
        tau_nominal,
        spacing: shape.spacing,
        headway: shape.headway,
        leader_broadcast_steps,
        detection: detection::detection(c.detection.as_ref(), dt)?,
        maneuvers: maneuvers::maneuvers(c.maneuvers.as_ref(), n, grid, cut_in_splits)?,
        security: security::security(
            c.security.as_ref(),
            (
                c.detection.as_ref().is_some_and(|d| {
                    d.plausibility.is_some() || d.radar_cross.is_some() || d.residual.is_some()
                }),
                c.maneuvers.is_some(),
                c.maneuvers
                    .as_ref()
                    .is_some_and(|m| m.merge.is_some() || m.split.is_some()),
            ),
            n,
        )?,
    };
    control::check_controller(&control, &topology)?;

    let dos = attack::dos(&c.attack, grid.duration)?;
    let regroups = c
        .maneuvers
        .as_ref()
        .is_some_and(|m| m.merge.is_some() || m.split.is_some());
    let (link_attacks, channel_seed) = channel::channel(&c.channel, dt, n, regroups)?;
    let jammers = jammers::jammers(c, n, dt)?;
    let radio = radio::radio(&c.channel, dt, control.security.as_ref())?;
    sumo::check(&c.sumo, dt)?;
    sumo::traffic_around(c)?;
    geometry::ahead(c, &layout, grid.duration)?;
    let safety = safety::thresholds(&c.safety)?;
    let lanes = fleet::lanes(&c.fleet, c.sumo.lane);
    output::check(&c.output)?;
    let fleet = fleet::fleet(&c.fleet, lanes, n, &initial, longest)?;
    let discretisation = plant::discretisation(&c.plant, c.simulation.plant)?;
    let cut_ins = cut_ins::cut_ins(c, &layout, shape.vehicle_length, grid.duration)?;
    drop(layout);
    let scenario = Scenario {
        steps: grid.steps,
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
        assumption2: c.attack.assumption2,
        vehicle_length: shape.vehicle_length,
        vehicles,
        cut_ins,
        safety,
        fleet,
        platoon: 0,
    };
    scenario
        .validate()
        .or_else(|e| checks::bad("scenario", e.to_string()))?;
    Ok(scenario)
}

/// The keys of a config that only SUMO's plant runs (its traffic: `[[sumo.flows]]`,
/// `[[sumo.ahead]]`, `sumo.background_vehicles`, a `sumo.route` of several edges), refused on
/// the native plant. Not part of [`scenario_of`]: a config whose `simulation.plant` is native
/// may be run on SUMO (`--plant sumo`); the front-end checks it once the plant is chosen.
pub fn native_plant_check(c: &Config) -> Result<(), KeyError> {
    sumo::native_plant(c)
}

/// [`scenario_of`], then [`write_resolved_defaults`] into the config: what [`crate::parse`]
/// does to a file, for a config built or changed in code.
pub fn to_scenario(c: &mut Config) -> Result<Scenario, KeyError> {
    let scenario = scenario_of(c)?;
    write_resolved_defaults(c);
    Ok(scenario)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Reason;
    use crate::{Embedded, KeyLines, LawName};
    use platoon_control::SpacingPolicy;
    use platoon_topology::Preset;

    /// configs/leave.toml with `law` (its defaults, the platoon spaced as it keeps it) on
    /// `preset`.
    fn leave_with(law: LawName, preset: Preset) -> Config {
        let mut c = Embedded::Leave.parse().unwrap().0;
        c.control.law = law.defaults();
        let (l, h) = c
            .control
            .law
            .spacing_policy(c.platoon.vehicle_length_m)
            .unwrap();
        c.platoon.spacing_m = l;
        c.platoon.spacing = if h == 0.0 {
            SpacingPolicy::Constant
        } else {
            SpacingPolicy::TimeHeadway(h)
        }
        .into();
        c.topology = preset.into();
        c
    }

    /// What callers used to tell by the key's name, they tell by the reason.
    #[test]
    fn the_reason_says_what_the_key_named() {
        // PATH CACC reads the leader, whom predecessor following does not carry.
        let e = scenario_of(&leave_with(LawName::PathCacc, Preset::Pf)).unwrap_err();
        assert_eq!(e.key, "topology.preset", "{e}");
        assert!(matches!(e.reason, Reason::Unheard(_)), "{e}");
        // The consensus law keeps its neighbours for the whole run: no leave.
        let e = scenario_of(&leave_with(LawName::Consensus, Preset::Plf)).unwrap_err();
        assert_eq!(e.key, "maneuvers", "{e}");
        assert!(matches!(e.reason, Reason::LawWithoutManeuvers(_)), "{e}");
        // The shared checks keep their numbers.
        let mut c = Embedded::Paper.parse().unwrap().0;
        c.simulation.dt_s = -0.5;
        let e = scenario_of(&c).unwrap_err();
        assert_eq!(
            e,
            KeyError::new("simulation.dt_s", Reason::NotPositive(-0.5))
        );
        assert_eq!(
            e.to_string(),
            "key `simulation.dt_s`: must be > 0, got -0.5"
        );
        c.simulation.dt_s = 0.01;
        c.trigger.h_s = 0.015;
        let e = scenario_of(&c).unwrap_err();
        assert_eq!(
            e.reason,
            Reason::NotWholeSteps {
                period_s: 0.015,
                dt_s: 0.01
            }
        );
    }

    /// A key error in a file names the file and the key's line.
    #[test]
    fn a_key_error_is_placed_at_its_line() {
        let text = Embedded::Paper.text();
        let e = KeyError::new("trigger.h_s", Reason::NotPositive(0.0))
            .in_file("paper.toml", &KeyLines::new(text));
        let line = text.lines().position(|l| l.starts_with("h_s")).unwrap() + 1;
        assert_eq!(e.line, Some(line));
        assert_eq!(
            e.to_string(),
            format!("paper.toml:{line}: key `trigger.h_s`: must be > 0, got 0")
        );
    }

    /// Resolving reads the config; writing the defaults is a step of its own, after which the
    /// config resolves to the same scenario and writing them again changes nothing.
    #[test]
    fn resolving_reads_and_the_defaults_are_written_apart() {
        let mut c = Embedded::Paper.parse().unwrap().0;
        c.trigger.check_period_s = None;
        c.fallback.mode = None;
        c.control.attack_input = Some(platoon_control::FallbackMode::Hold);
        c.channel.model = crate::RadioModel::Ieee80211p;
        let before = c.clone();
        let scenario = scenario_of(&c).unwrap();
        assert_eq!(c, before, "scenario_of changed the config");
        write_resolved_defaults(&mut c);
        assert_eq!(c.trigger.check_period_s, Some(c.simulation.dt_s));
        assert_eq!(c.fallback.mode, Some(platoon_control::FallbackMode::Hold));
        assert_eq!(c.control.attack_input, None);
        assert!(c.channel.radio.is_some() && c.channel.load.is_some());
        let again = scenario_of(&c).unwrap();
        assert_eq!(format!("{again:?}"), format!("{scenario:?}"));
        let written = c.clone();
        write_resolved_defaults(&mut c);
        assert_eq!(c, written);
    }
}
