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
mod jammers;
mod leader;
mod maneuvers;
mod output;
mod plant;
mod platoon;
mod radio;
mod safety;
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
    // The longest vehicle: what the checks on whole-platoon room count.
    let longest = members.iter().map(|m| m.length()).fold(
        if members.is_empty() {
            shape.vehicle_length
        } else {
            0.0
        },
        f64::max,
    );
    let leader = leader::profile(&c.leader.profile)?;
    let initial = platoon::initial_states(&c.platoon, &shape, longest, &leader)?;
    leader::check_start(&leader, &initial)?;
    let leader_broadcast_steps = leader::broadcast_steps(&c.leader, dt)?;
    let topology = topology::topology(&c.topology, n)?;
    let tau_nominal = plant::tau_nominal(&c.plant)?;
    let mut taus = plant::taus(&c.plant, n)?;
    let vehicles = vehicles::vehicles(c, &members, &mut taus, tau_nominal, &leader, &initial)?;
    drop(members);

    let (gain, beta1, beta2) = control::paper_gains(&c.control)?;
    let triggering = trigger::triggering(&c.trigger, dt)?;
    let mut fallback = fallback::fallback(c, dt, shape.vehicle_length)?;
    fallback.lengths = vehicles.iter().map(|v| v.length_m).collect();
    let law = control::law(&c.control);
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
        maneuvers: maneuvers::maneuvers(c.maneuvers.as_ref(), n, dt, cut_in_splits)?,
    };
    control::check_controller(&control, &topology)?;

    let dos = attack::dos(&c.attack, grid.duration)?;
    let regroups = c
        .maneuvers
        .as_ref()
        .is_some_and(|m| m.merge.is_some() || m.split.is_some());
    let (link_attacks, channel_seed) = channel::channel(&c.channel, dt, n, regroups)?;
    let jammers = jammers::jammers(c, n, dt)?;
    let radio = radio::radio(&c.channel, dt)?;
    sumo::check(&c.sumo, dt)?;
    sumo::traffic_around(c)?;
    let safety = safety::thresholds(&c.safety)?;
    let lanes = fleet::lanes(&c.fleet, c.sumo.lane);
    output::check(&c.output)?;
    let fleet = fleet::fleet(&c.fleet, lanes, n, &initial, longest)?;
    let discretisation = plant::discretisation(&c.plant, c.simulation.plant)?;
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
        cut_ins: cut_ins::cut_ins(c, shape.vehicle_length, grid.duration)?,
        safety,
        fleet,
        platoon: 0,
    };
    scenario
        .validate()
        .or_else(|e| checks::bad("scenario", e.to_string()))?;
    Ok(scenario)
}

/// [`scenario_of`], then [`write_resolved_defaults`] into the config: what [`crate::parse`]
/// does to a file, for a config built or changed in code.
pub fn to_scenario(c: &mut Config) -> Result<Scenario, KeyError> {
    let scenario = scenario_of(c)?;
    write_resolved_defaults(c);
    Ok(scenario)
}
