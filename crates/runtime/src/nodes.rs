//! The plant, controller and (Rust) injector processes, written on [`crate::session`]. Each
//! composes the pure core and blocks on its wake-up listener between samples; none of them
//! busy-polls. The built-in channel is an injector of the pure seam adapted to the wire
//! ([`crate::injector`]), the
//! built-in controller a controller on the SDK ([`crate::controller`]).
use crate::injector::Platoons;
use crate::ipc::{Inlet, Outlet};
use crate::session::{contract, reporting, Numbering};
use crate::CosimError;
use platoon_control::fallback::RadarTruth;
use platoon_sim::traffic::RadarTarget;
use platoon_sim::{InjectorFactory, Plant, Scenario};
use platoon_wire::{Command, ControlMsg, Node, Service, VehicleState};
use std::path::Path;

/// The native plant process: integrates every vehicle with the model of `platoon-sim`.
pub fn plant(run_id: &str, scenario: &Scenario) -> Result<(), CosimError> {
    reporting(run_id, Node::Plant, |ctx, k| {
        let e = &ctx.endpoint;
        let num = Numbering::of(scenario);
        let states_out: Outlet<VehicleState> = e.fixed_outlet(
            &e.open_step_service(Service::States)?,
            Service::States,
            num.vehicles(),
        )?;
        let mut commands: Inlet<Command> =
            Inlet::new(&e.open_step_service(Service::Commands)?, Node::Controller)?;
        let mut plants: Vec<Plant> = scenario.replicas().iter().map(Plant::new).collect();
        let mut buf = Vec::with_capacity(num.vehicles());
        let mut u = vec![0.0; num.followers()];
        let mut guard = vec![false; num.followers()];
        // Which lane each follower's command asks for (`true`: beside), by slot.
        let mut want = vec![false; num.followers()];
        if !ctx.ready()? {
            return Ok(());
        }
        let mut truth = Vec::new();
        let mut targets = Vec::new();
        let publish = |k: u64,
                       plants: &[Plant],
                       buf: &mut Vec<VehicleState>,
                       truth: &mut Vec<Option<RadarTruth>>,
                       targets: &mut Vec<RadarTarget>| {
            buf.clear();
            for p in plants {
                // What a radar sees natively: the predecessor, or a vehicle that cut in.
                p.radar_view(truth, targets);
                let view = p.states().iter().zip(truth.iter()).zip(targets.iter());
                buf.extend(view.enumerate().map(|(i, ((x, t), who))| {
                    let lane = match p.beside(i) {
                        true => VehicleState::BESIDE,
                        false => 0,
                    };
                    let (flags, gap, closing) = t.map_or((0, 0.0, 0.0), |t| {
                        let intruder = match (t.intruder, who) {
                            (false, _) => 0,
                            (true, RadarTarget::CutIn(c)) => {
                                VehicleState::INTRUDER
                                    | VehicleState::target_flags(1 + u32::from(*c))
                            }
                            (true, _) => VehicleState::INTRUDER,
                        };
                        (VehicleState::AHEAD | intruder, t.gap, t.closing)
                    });
                    VehicleState {
                        vehicle: 0, // numbered below
                        flags: flags | lane,
                        p: x[0],
                        v: x[1],
                        a: x[2],
                        gap,
                        closing,
                    }
                }));
            }
            for (g, s) in buf.iter_mut().enumerate() {
                s.vehicle = g as u32;
            }
            states_out.send(k, scenario.dt(), buf)
        };
        publish(0, &plants, &mut buf, &mut truth, &mut targets)?;
        let n = num.per_platoon - 1;
        loop {
            let got = commands.take(*k)?;
            let Some(cmds) = got else {
                if !ctx.wait()? {
                    return Ok(());
                }
                continue;
            };
            commands_into(&cmds, num, &mut u, &mut guard)?;
            if scenario.changes_lanes() {
                // Each vehicle into the lane its mode asks for (`left`, `beside`: the one
                // beside) where the gap there is safe, as the in-process run.
                for c in cmds.iter() {
                    // Checked in `commands_into`.
                    if let Some((j, i)) = num.split(c.vehicle) {
                        want[j * n + i.index() - 1] =
                            platoon_control::Status::from_code(c.mode_code())
                                .is_ok_and(|s| s.is_beside_the_lane());
                    }
                }
                for (plant, want) in plants.iter_mut().zip(want.chunks(n)) {
                    plant.change_lanes(|i| want[i - 1]);
                }
            }
            for ((plant, u), guard) in plants.iter_mut().zip(u.chunks(n)).zip(guard.chunks(n)) {
                plant.advance(*k, u, |i| guard[i - 1]);
            }
            if *k == scenario.steps {
                return ctx.done(ControlMsg::new(ControlMsg::DONE, Node::Plant, *k));
            }
            *k += 1;
            publish(*k, &plants, &mut buf, &mut truth, &mut targets)?;
        }
    })
}

/// Checks a command batch (one finite command per follower) and copies it into `u`.
fn commands_into(
    cmds: &[Command],
    num: Numbering,
    u: &mut [f64],
    guard: &mut [bool],
) -> Result<(), CosimError> {
    if cmds.len() != u.len() {
        return Err(contract(
            Node::Controller,
            format!("{} commands for {} followers", cmds.len(), u.len()),
        ));
    }
    for c in cmds {
        if let Err(e) = platoon_control::Status::from_code(c.mode_code()) {
            return Err(contract(
                Node::Controller,
                format!("bad command for vehicle {}: {e}", c.vehicle),
            ));
        }
        match num.split(c.vehicle) {
            Some((j, i)) if !i.is_leader() && c.u.is_finite() => {
                let slot = j * (num.per_platoon - 1) + i.index() - 1;
                u[slot] = c.u;
                guard[slot] = c.flags & Command::GUARD != 0;
            }
            _ => {
                return Err(contract(
                    Node::Controller,
                    format!("bad command for vehicle {}: {}", c.vehicle, c.u),
                ))
            }
        }
    }
    Ok(())
}

/// The controller service: every follower's triggering rule, estimators and control law, for
/// every platoon: the controllers [`platoon_control::build`] makes from the config, on the
/// controller SDK ([`crate::controller`]) like any third-party one.
pub fn controller(run_id: &str, scenario: &Scenario) -> Result<(), CosimError> {
    crate::controller::run(run_id, scenario, |s| {
        platoon_control::build(&s.control, &s.topology, &s.initial).map_err(|e| e.to_string())
    })
}

/// The built-in attack injector: the channel of `platoon-attacks` between the controllers, one
/// per platoon, adapted to the wire ([`crate::injector::Platoons`]) like any injector of the
/// pure seam. Writes its log (every packet not delivered as sent) to `log` as CSV.
pub fn injector(run_id: &str, scenario: &Scenario, log: Option<&Path>) -> Result<(), CosimError> {
    let mut channel = Platoons::new(scenario, &InjectorFactory::builtin(), log)?;
    crate::injector::run(run_id, scenario, &mut channel)
}

/// The same channel in front of a third-party injector (`--injector-mode after`): reads `tx`,
/// publishes `gated`.
pub fn channel(run_id: &str, scenario: &Scenario, log: Option<&Path>) -> Result<(), CosimError> {
    let mut channel = Platoons::new(scenario, &InjectorFactory::builtin(), log)?;
    crate::injector::run_on(
        crate::injector::Ports::CHANNEL,
        run_id,
        scenario,
        &mut channel,
    )
}
