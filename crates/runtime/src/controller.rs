//! The controller SDK: run any [`platoon_control::Controller`] as the controller service of an
//! iceoryx2 run.
//!
//! [`run`] drives one controller per platoon (each built by the caller from its platoon's
//! replica of the scenario) through the whole contract of `docs/controller-contract.md`: it
//! opens the ports, reports READY, waits for START, blocks on its wake-up listener (no busy
//! polling), and at every step k reads the plant's `states[k]`, calls [`Controller::transmit`]
//! and publishes the broadcasts as `tx[k]` (one item per link, to every out-neighbour of the
//! sender), reads the injector's `rx[k]`, sorts it into each platoon's deliveries and jammed
//! notices, calls [`Controller::receive`] and publishes every follower's command and what it did
//! ([`Controller::follower_step`]) as `commands[k]`; after the last step it reports DONE with
//! the packets the controllers refused, and it exits on STOP, ABORT or when `platoon run` is
//! gone. When the controllers run misbehaviour detectors (`[detection]`: their
//! [`Controller::detector_names`]) and the run names a detection log ([`DETECTION_LOG_ENV`]),
//! it measures them against ground truth as the in-process runner does
//! ([`platoon_sim::detection::DetectionRecorder`], one per platoon, fed the same states, links,
//! deliveries and controller) and writes platoon 0's figures there before DONE. An error (a
//! controller that cannot be built, a command that is not finite) names the controller and the
//! step in the run's summary.
//!
//! The built-in controller node ([`crate::nodes::controller`]) is [`run`] with
//! [`platoon_control::build`]; the `platoon-controller` crate wraps it for users.
use crate::ipc::{Inlet, Outlet};
use crate::session::{
    contract, deliveries_from_wire, packet_to_wire, reporting, states_from_wire, Numbering,
};
use crate::{monotonic_ns, RunError};
use platoon_control::fallback::RadarTruth;
use platoon_control::{Controller, Packet};
use platoon_model::{State, VehicleId};
use platoon_sim::detection::{DetectionRecorder, DetectionSummary};
use platoon_sim::Scenario;
use platoon_wire::{Command, ControlMsg, LinkPacket, Node, Service, VehicleState};
use std::path::{Path, PathBuf};

/// The variable of the controller service's environment naming the file where [`run`] writes
/// platoon 0's [`DetectionSummary`] (JSON) after the last step, when its controllers run
/// detectors; `platoon run` sets it for runs with `[detection]`. Unset: nothing is written.
pub const DETECTION_LOG_ENV: &str = "PLATOON_DETECTION_LOG";

/// The detection log this process was given ([`DETECTION_LOG_ENV`]), if any.
pub fn detection_log_from_env() -> Option<PathBuf> {
    std::env::var_os(DETECTION_LOG_ENV)
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
}

/// Writes `summary` to `path` as JSON, atomically (a sibling file renamed over it), so a reader
/// finds the whole file or none.
pub fn write_detection(path: &Path, summary: &DetectionSummary) -> std::io::Result<()> {
    let json = serde_json::to_string_pretty(summary).map_err(std::io::Error::other)? + "\n";
    let mut partial = path.as_os_str().to_owned();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    std::fs::write(&partial, json)?;
    std::fs::rename(&partial, path)
}

/// Runs the controllers `make` builds, one per platoon from its replica of `scenario`
/// ([`Scenario::replicas`], in order), as the controller service of run `run_id` until the run
/// ends. An error of `make` stops the run and names the controller. With `detection_log` (see
/// [`DETECTION_LOG_ENV`]) and controllers that run detectors, platoon 0's detection figures are
/// written there before DONE.
pub fn run(
    run_id: &str,
    scenario: &Scenario,
    detection_log: Option<&Path>,
    mut make: impl FnMut(&Scenario) -> Result<Box<dyn Controller>, String>,
) -> Result<(), RunError> {
    reporting(run_id, Node::Controller, |ctx, k| {
        let e = &ctx.endpoint;
        let num = Numbering::of(scenario);
        let n1 = num.per_platoon;
        let mut states_in: Inlet<VehicleState> =
            Inlet::new(&e.open_step_service(Service::States)?, Node::Plant)?;
        let mut rx_in: Inlet<LinkPacket> =
            Inlet::new(&e.open_step_service(Service::Rx)?, Node::Injector)?;
        let links: usize = (0..n1)
            .map(|v| scenario.topology.out_neighbours(VehicleId(v as u16)).len())
            .sum();
        let tx_out: Outlet<LinkPacket> = e.outlet(
            &e.open_step_service(Service::Tx)?,
            Service::Tx,
            links * num.platoons,
        )?;
        let cmd_out: Outlet<Command> = e.outlet(
            &e.open_step_service(Service::Commands)?,
            Service::Commands,
            num.followers(),
        )?;
        let fail = |m: String| contract(Node::Controller, m);
        let replicas = scenario.replicas();
        let mut controllers = replicas
            .iter()
            .map(&mut make)
            .collect::<Result<Vec<_>, _>>()
            .map_err(fail)?;
        // The detectors measured against ground truth, as in process: one recorder per platoon
        // whose controller runs detectors, only when someone reads the figures.
        let mut recorders: Vec<Option<DetectionRecorder>> = controllers
            .iter()
            .zip(&replicas)
            .map(|(c, r)| {
                (detection_log.is_some() && !c.detector_names().is_empty()).then(|| {
                    DetectionRecorder::new(
                        r.platoon,
                        c.detector_names(),
                        r.control.detection.reaction,
                        r.dt(),
                    )
                })
            })
            .collect();
        let mut states: Option<Vec<State>> = None;
        // The radar reads the plant's view of the vehicle ahead (SUMO: its lane leader), for
        // the fallback, the guard or a detector.
        let radar_from_plant =
            scenario.control.fallback.uses_radar() || scenario.control.detection.reads_radar();
        let mut truths: Vec<Option<RadarTruth>> = Vec::with_capacity(num.vehicles());
        // Each platoon's broadcasts of the step (the links its recorder labels).
        let mut tx: Vec<Vec<Packet>> = vec![Vec::new(); num.platoons];
        let (mut wire_tx, mut deliveries, mut jammed, mut cmds) = (
            Vec::new(),
            vec![Vec::new(); num.platoons],
            vec![false; num.vehicles()],
            Vec::with_capacity(num.followers()),
        );
        if !ctx.ready()? {
            return Ok(());
        }
        loop {
            if states.is_none() {
                if let Some(s) = states_in.take(*k)? {
                    truths.clear();
                    truths.extend(s.iter().map(|x| {
                        (x.flags & VehicleState::AHEAD != 0).then_some(RadarTruth {
                            gap: x.gap,
                            closing: x.closing,
                        })
                    }));
                    let s = states_from_wire(&s, num.vehicles())?;
                    wire_tx.clear();
                    let stamp = monotonic_ns();
                    for ((j, c), tx) in controllers.iter_mut().enumerate().zip(&mut tx) {
                        tx.clear();
                        c.transmit(*k, &s[j * n1..(j + 1) * n1], tx);
                        for p in tx.iter() {
                            let Some(to) = (p.sender.index() < n1)
                                .then(|| scenario.topology.out_neighbours(p.sender))
                            else {
                                return Err(fail(format!(
                                    "step {k}: platoon {j} broadcast as vehicle {}, which it \
                                     does not have",
                                    p.sender.0
                                )));
                            };
                            let mut packet = packet_to_wire(p, stamp);
                            packet.sender = num.global(j, p.sender);
                            wire_tx.extend(to.iter().map(|&r| LinkPacket {
                                receiver: num.global(j, r),
                                kind: LinkPacket::DELIVERY,
                                packet,
                            }));
                        }
                    }
                    tx_out.send(*k, scenario.dt(), &wire_tx)?;
                    states = Some(s);
                }
            }
            if let Some(s) = &states {
                if let Some(items) = rx_in.take(*k)? {
                    deliveries_from_wire(&items, num, &mut deliveries, &mut jammed);
                    cmds.clear();
                    for (j, c) in controllers.iter_mut().enumerate() {
                        let range = j * n1..(j + 1) * n1;
                        if radar_from_plant {
                            c.set_radar_truth(&truths[range.clone()]);
                        }
                        // The commands are `commands()`, what the in-process runner hands the
                        // plant; `follower_step` adds the flags.
                        c.receive(
                            *k,
                            &s[range.clone()],
                            &deliveries[j],
                            &jammed[range.clone()],
                        );
                        if let Some(d) = &mut recorders[j] {
                            // The in-process runner's inputs: a broadcast nobody listens to has
                            // no link either way.
                            d.record(
                                *k,
                                &s[range],
                                platoon_sim::wire::links(&replicas[j].topology, &tx[j]),
                                &deliveries[j],
                                &**c,
                            );
                        }
                        let u = c.commands();
                        for i in 1..n1 {
                            let f = c.follower_step(VehicleId(i as u16));
                            let u = u.get(i - 1).copied().unwrap_or(f64::NAN);
                            if !u.is_finite() {
                                return Err(fail(format!(
                                    "step {k}: the command of follower {i} of platoon {j} is {u}"
                                )));
                            }
                            cmds.push(Command {
                                vehicle: num.global(j, VehicleId(i as u16)),
                                flags: Command::flags_of(
                                    f.triggered,
                                    f.affected,
                                    f.guard,
                                    f.mode.code(),
                                ),
                                u,
                                theta: f.theta,
                            });
                        }
                    }
                    cmd_out.send(*k, scenario.dt(), &cmds)?;
                    states = None;
                    if *k == scenario.steps {
                        if let (Some(path), Some(Some(d))) = (detection_log, recorders.first()) {
                            let summary = d.summary(controllers[0].screened());
                            write_detection(path, &summary).map_err(|e| {
                                fail(format!(
                                    "writing the detection figures to {}: {e}",
                                    path.display()
                                ))
                            })?;
                        }
                        let mut done = ControlMsg::new(ControlMsg::DONE, Node::Controller, *k);
                        for c in &controllers {
                            let r = c.rejected();
                            for (sum, x) in done.counts.iter_mut().zip(r.as_array()) {
                                *sum += x;
                            }
                        }
                        return ctx.done(done);
                    }
                    *k += 1;
                    continue; // the next states may already be here
                }
            }
            if !ctx.wait()? {
                return Ok(());
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_detection_figures_are_written_whole_and_read_back_the_same() {
        let recorder = DetectionRecorder::new(
            0,
            &["residual", "radar_cross"],
            platoon_control::Reaction::Fallback,
            0.01,
        );
        let summary = recorder.summary(Default::default());
        let dir = std::env::temp_dir().join(format!("platoon-detection-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("detection.json");
        write_detection(&path, &summary).unwrap();
        let back: DetectionSummary =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(back, summary);
        assert_eq!(back.detectors.len(), 2);
        assert_eq!(names, ["detection.json"], "a partial file was left behind");
    }
}
