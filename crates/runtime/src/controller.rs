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
//! gone. In runs that measure misbehaviour detectors (`[detection]`) it publishes what every
//! controller's detectors said of the step's packets ([`Controller::inspections`]) on the
//! `inspections` service before the commands; the orchestrator measures them against ground
//! truth as the in-process runner does. An error (a controller that cannot be built, a command
//! that is not finite) names the controller and the step in the run's summary.
//!
//! The built-in controller node ([`crate::nodes::controller`]) is [`run`] with
//! [`platoon_control::build`]; the `platoon-controller-sdk` crate wraps it for users.
use crate::ipc::{Inlet, Outlet};
use crate::session::{
    contract, deliveries_from_wire, inspection_to_wire, packet_to_wire, reporting,
    states_from_wire, Numbering,
};
use crate::{monotonic_ns, CosimError};
use platoon_control::fallback::RadarTruth;
use platoon_control::{Controller, Packet};
use platoon_model::{State, VehicleId};
use platoon_sim::Scenario;
use platoon_wire::{Command, ControlMsg, Inspection, LinkPacket, Node, Service, VehicleState};

/// Runs the controllers `make` builds, one per platoon from its replica of `scenario`
/// ([`Scenario::replicas`], in order), as the controller service of run `run_id` until the run
/// ends. An error of `make` stops the run and names the controller.
pub fn run(
    run_id: &str,
    scenario: &Scenario,
    mut make: impl FnMut(&Scenario) -> Result<Box<dyn Controller>, String>,
) -> Result<(), CosimError> {
    reporting(run_id, Node::Controller, |ctx, k| {
        let e = &ctx.endpoint;
        let num = Numbering::of(scenario);
        let n1 = num.per_platoon;
        let mut states_in: Inlet<VehicleState> =
            Inlet::new(&e.open_step_service(Service::States)?, Node::Plant)?;
        let mut rx_in: Inlet<LinkPacket> =
            Inlet::new(&e.open_step_service(Service::Rx)?, Node::Injector)?;
        let hearing = scenario.hearing();
        let links: usize = (0..n1)
            .map(|v| hearing.out_neighbours(VehicleId(v as u16)).len())
            .sum();
        let tx_out: Outlet<LinkPacket> = e.fixed_outlet(
            &e.open_step_service(Service::Tx)?,
            Service::Tx,
            links * num.platoons,
        )?;
        let cmd_out: Outlet<Command> = e.fixed_outlet(
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
        // `[security]`: the seals' signing and verifying timed by the machine's clock, per
        // step, for timing.json (ControlMsg::TIMING before DONE).
        for c in &mut controllers {
            c.time_crypto(monotonic_ns);
        }
        let mut crypto = crate::timing::CryptoStages::default();
        // What the detectors said, for the orchestrator to measure (`[detection]` runs only):
        // at most every delivery of a step is inspected.
        let inspections_out: Option<Outlet<Inspection>> = scenario
            .control
            .detection
            .is_measured()
            .then(|| {
                e.outlet(
                    &e.open_step_service(Service::Inspections)?,
                    Service::Inspections,
                    links * num.platoons,
                )
            })
            .transpose()?;
        let mut inspections: Vec<Inspection> = Vec::new();
        if inspections_out.is_some() {
            same_detectors(&controllers, &scenario.control.detection.names()).map_err(fail)?;
        }
        let mut states: Option<Vec<State>> = None;
        // The radar reads the plant's view of the vehicle ahead (SUMO: its lane leader), for
        // the fallback, the guard or a detector.
        let radar_from_plant = scenario.control.fallback.uses_radar()
            || scenario.control.detection.reads_radar()
            || scenario.changes_lanes();
        let mut truths: Vec<Option<RadarTruth>> = Vec::with_capacity(num.vehicles());
        let mut scratch = Broadcasts::default();
        let (mut deliveries, mut jammed, mut cmds) = (
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
                    radar_truths(&s, &mut truths);
                    let s = states_from_wire(&s, num.vehicles())?;
                    let wire_tx = scratch.broadcasts(&mut controllers, *k, &s, &hearing, num)?;
                    tx_out.send(*k, scenario.dt(), wire_tx)?;
                    states = Some(s);
                }
            }
            if let Some(s) = &states {
                if let Some(items) = rx_in.take(*k)? {
                    deliveries_from_wire(&items, num, &mut deliveries, &mut jammed);
                    cmds.clear();
                    inspections.clear();
                    for (j, c) in controllers.iter_mut().enumerate() {
                        let range = j * n1..(j + 1) * n1;
                        if radar_from_plant {
                            c.set_radar_truth(&truths[range.clone()]);
                        }
                        c.receive(
                            *k,
                            &s[range.clone()],
                            &deliveries[j],
                            &jammed[range.clone()],
                        );
                        if inspections_out.is_some() {
                            inspections.extend(
                                c.inspections()
                                    .iter()
                                    .map(|i| inspection_to_wire(i, j, num)),
                            );
                        }
                        commands_of(&**c, j, num, &mut cmds)
                            .map_err(|why| fail(format!("step {k}: {why}")))?;
                    }
                    if let Some(out) = &inspections_out {
                        out.send(*k, scenario.dt(), &inspections)?;
                    }
                    cmd_out.send(*k, scenario.dt(), &cmds)?;
                    states = None;
                    let timed = controllers.iter().filter_map(|c| c.crypto_time());
                    if let Some(total) = timed.reduce(|a, b| a.plus(&b)) {
                        crypto.push(total);
                    }
                    if *k == scenario.steps {
                        if let Some(timing) = timing_message(&crypto, *k) {
                            ctx.report_status(timing)?;
                        }
                        return ctx.done(done_message(&controllers, *k));
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

/// Verdicts are recorded under the config's detector names `names`, in order: a controller
/// whose detectors are others would have its figures filed under the wrong names.
fn same_detectors(controllers: &[Box<dyn Controller>], names: &[String]) -> Result<(), String> {
    for c in controllers {
        let own = c.detector_names();
        if !own.is_empty() && own != names {
            return Err(format!(
                "its detectors are {own:?}, but the config's [detection] measures {names:?} \
                 (built-in tables first, then plugin = [...]): name them there, in order"
            ));
        }
    }
    Ok(())
}

/// The commands of controller `c` (platoon `j`) for its followers, with their flags, onto
/// `cmds`: what the in-process runner hands the plant (`commands()`), `follower_step` adding
/// the flags. A command that is not finite is an error naming the follower.
fn commands_of(
    c: &dyn Controller,
    j: usize,
    num: Numbering,
    cmds: &mut Vec<Command>,
) -> Result<(), String> {
    let u = c.commands();
    for i in 1..num.per_platoon {
        let f = c.follower_step(VehicleId(i as u16));
        let u = u.get(i - 1).copied().unwrap_or(f64::NAN);
        if !u.is_finite() {
            return Err(format!("the command of follower {i} of platoon {j} is {u}"));
        }
        cmds.push(Command {
            vehicle: num.global(j, VehicleId(i as u16)),
            flags: Command::flags_of(
                f.triggered,
                f.affected,
                f.guard,
                (f.revoked, f.leader_revoked),
                f.status().code(),
                f.head.0,
            ),
            u,
            theta: f.theta,
        });
    }
    Ok(())
}

/// The controller's TIMING at step `k`: what its seals' cryptography took per step
/// (`[security]` runs; none otherwise).
fn timing_message(crypto: &crate::timing::CryptoStages, k: u64) -> Option<ControlMsg> {
    if crypto.per_step().0.is_empty() {
        return None;
    }
    let mut m = ControlMsg::new(ControlMsg::TIMING, Node::Controller, k);
    let (sign, verify) = crypto.to_ns();
    m.counts = sign;
    m.seals[..6].copy_from_slice(&verify);
    Some(m)
}

/// The controller's DONE at step `k`, with the packets every controller rejected, by reason.
fn done_message(controllers: &[Box<dyn Controller>], k: u64) -> ControlMsg {
    let mut done = ControlMsg::new(ControlMsg::DONE, Node::Controller, k);
    for c in controllers {
        let r = c.rejected();
        for (sum, x) in done.counts.iter_mut().zip(r.as_array()) {
            *sum += x;
        }
        if let Some(s) = c.seals() {
            for (sum, x) in done.seals.iter_mut().zip(s.as_array()) {
                *sum += x;
            }
            for (sum, x) in done.reports.iter_mut().zip(s.reports.as_array()) {
                *sum += x;
            }
        }
    }
    done
}

/// The transmit half's buffers, kept from step to step.
#[derive(Default)]
struct Broadcasts {
    tx: Vec<Packet>,
    sent: Vec<bool>,
    wire: Vec<LinkPacket>,
}

impl Broadcasts {
    /// What each platoon's controller broadcasts at step `k` on `s` (every platoon's states,
    /// in order), one item per link of `hearing`; a broadcast as a vehicle the platoon does
    /// not have, naming a head it does not have, or a second one in the step breaks the
    /// contract.
    fn broadcasts(
        &mut self,
        controllers: &mut [Box<dyn Controller>],
        k: u64,
        s: &[State],
        hearing: &platoon_topology::Topology,
        num: Numbering,
    ) -> Result<&[LinkPacket], CosimError> {
        let n1 = num.per_platoon;
        self.wire.clear();
        let stamp = monotonic_ns();
        for (j, c) in controllers.iter_mut().enumerate() {
            self.tx.clear();
            c.transmit(k, &s[j * n1..(j + 1) * n1], &mut self.tx);
            self.sent.clear();
            self.sent.resize(n1, false);
            for p in self.tx.iter() {
                let Some(to) = (p.sender.index() < n1).then(|| hearing.out_neighbours(p.sender))
                else {
                    return Err(contract(
                        Node::Controller,
                        format!(
                            "step {k}: platoon {j} broadcast as vehicle {}, which it \
                             does not have",
                            p.sender.0
                        ),
                    ));
                };
                if p.head.index() >= n1 {
                    return Err(contract(
                        Node::Controller,
                        format!(
                            "step {k}: platoon {j}: vehicle {} names vehicle {} as its \
                             head, which the platoon does not have",
                            p.sender.0, p.head.0
                        ),
                    ));
                }
                // At most one broadcast per vehicle and step: the tx outlet holds
                // one item per link.
                if std::mem::replace(&mut self.sent[p.sender.index()], true) {
                    return Err(contract(
                        Node::Controller,
                        format!(
                            "step {k}: platoon {j}: vehicle {} broadcast twice in one \
                             step (at most once per step)",
                            p.sender.0
                        ),
                    ));
                }
                let packet = packet_to_wire(p, stamp, j, num);
                self.wire.extend(to.iter().map(|&r| LinkPacket {
                    receiver: num.global(j, r),
                    kind: LinkPacket::DELIVERY,
                    packet,
                }));
            }
        }
        Ok(&self.wire)
    }
}

/// What each vehicle's radar sees of the vehicle ahead, as the plant reported it in `states`
/// (None: nothing ahead), into `truths`.
fn radar_truths(states: &[VehicleState], truths: &mut Vec<Option<RadarTruth>>) {
    truths.clear();
    truths.extend(states.iter().map(|x| {
        (x.flags & VehicleState::AHEAD != 0).then_some(RadarTruth {
            gap: x.gap,
            closing: x.closing,
            intruder: x.flags & VehicleState::INTRUDER != 0,
        })
    }));
}
