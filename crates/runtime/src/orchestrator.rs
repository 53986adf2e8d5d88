//! The orchestrator: creates the run's services, starts the plant, controller and injector
//! processes, waits until all are ready, records every step, and shuts everything down, on
//! success or failure, leaving no process behind.
use crate::detection::Measure;
use crate::ipc::{wait, ControlInlet, Endpoint, Inlet};
use crate::session::{
    check_traffic, deliveries_from_wire, link_from_wire, states_from_wire, Numbering,
};
use crate::timing::{StageClock, Stats, Timing};
use crate::CosimError;
use platoon_control::{FollowerStep, RejectCounts};
use platoon_sim::detection::Scored;
use platoon_sim::{step_rows, RowSources, Scenario, StepRow, StepWire, WireCounts};
use platoon_wire::{
    Command, ControlMsg, Inspection, LinkPacket, Node, Observed, Service, TrafficVehicle,
    VehicleState,
};
use std::path::PathBuf;
use std::process::{Child, Command as Process, Stdio};
use std::time::{Duration, Instant};

mod observe;
mod record;
mod supervise;

use observe::Observe;
use record::Recorder;
use supervise::{check_failed, log_detail, spawn_all, watch, Children};

/// Which program plays a role (plant, controller or injector).
#[derive(Debug, Clone, PartialEq)]
pub enum Program {
    /// `platoon node <role>`: the native plant, the controllers of `platoon-control`, or the
    /// channel of `platoon-attacks`.
    Builtin,
    /// A command line given by the user, run with `sh -c "exec <command>"`.
    Shell(String),
    /// A program with its arguments (e.g. the SUMO bridge in the bridge's Python).
    Exec {
        /// The executable.
        program: PathBuf,
        /// Its arguments.
        args: Vec<String>,
    },
}

/// How to run one co-simulation.
#[derive(Debug, Clone)]
pub struct Options {
    /// Names the run's services (see [`crate::new_run_id`]).
    pub run_id: String,
    /// The `platoon` binary, which runs the nodes (`platoon node <role>`).
    pub exe: PathBuf,
    /// The resolved scenario config every node loads.
    pub config: PathBuf,
    /// The run's `facts.json` ([`crate::plugin::RunFacts`]), named to every process by
    /// `PLATOON_RUN_FACTS`; `None`: the variable is not set.
    pub facts: Option<PathBuf>,
    /// The injector.
    pub injector: Program,
    /// The controller service (`docs/controller-contract.md`): a plug-in is treated as a
    /// plug-in injector is (named when it dies, stalls or sends something malformed).
    pub controller: Program,
    /// The plant.
    pub plant: Program,
    /// The background vehicles the plant publishes every step on `traffic` (SUMO's
    /// `[sumo] background_vehicles`); 0: the run has no `traffic` service.
    pub traffic: usize,
    /// The run has traffic that can touch the platoons (scripted cut-ins, SUMO vehicles that
    /// reach their lanes): its rows say what each radar saw, as the in-process runner's do.
    pub radar: bool,
    /// More environment for every process (e.g. `PLATOON_PLANT_SPEC`).
    pub env: Vec<(String, String)>,
    /// Where the built-in injector writes its channel log (CSV).
    pub channel_log: Option<PathBuf>,
    /// Where each node's stderr goes (`<dir>/<node>.log`); inherited if `None`. The error of a
    /// process that dies quotes the last lines of its log.
    pub log_dir: Option<PathBuf>,
    /// Prepended to `PYTHONPATH` of every plug-in process (a program that is not
    /// [`Program::Builtin`]): the bridge directory, so a Python plug-in imports the SDK
    /// (`platoon_injector`, `platoon_wire`) from wherever it is.
    pub python_path: Option<PathBuf>,
    /// How long the run waits for one step before naming the node that holds it up.
    pub step_timeout: Duration,
    /// How long the nodes may take to start.
    pub ready_timeout: Duration,
    /// Run the built-in channel (the config's attacks) before the injector, which then reads
    /// `gated` instead of `tx` (`--injector-mode after`).
    pub channel_first: bool,
    /// Read-only observers each `observe/<leaf>` service has room for.
    pub observers: usize,
    /// Set from outside (a signal handler) to stop the run cleanly: the nodes get ABORT and
    /// the run ends with [`CosimError::Interrupted`] within one wait tick (100 ms).
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// The CPUs the nodes (plant, controller, injector, channel) may run on; empty: any. The
    /// orchestrator itself is not pinned. A step is a chain of wake-ups in which one process
    /// runs at a time, so on machines where waking a process on another core is slow (a VM
    /// that halts idle cores) one shared core is faster: see BENCHMARKS.md.
    pub cpus: Vec<usize>,
}

/// What a finished run reports besides its rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Packets the controllers refused.
    pub rejected: RejectCounts,
    /// What the controllers' seals did (`[security]` runs; 0 otherwise).
    pub seals: platoon_control::SealCounts,
    /// Where the time of a step went.
    pub timing: Timing,
    /// Samples that repeated a step, per service.
    pub duplicates: DuplicateSamples,
    /// Each node's peak resident memory in KiB (`VmHWM`), read as the run ends.
    pub peak_rss_kib: Vec<(&'static str, u64)>,
    /// What the built-in channel's 802.11p radio measured (`summary.json`'s `channel`), as it
    /// reported with DONE; `None` without the radio or when a third-party injector replaced the
    /// channel.
    pub radio: Option<platoon_attacks::channel::RadioStats>,
    /// Platoon 0's detectors measured against ground truth (`summary.json`'s `detection`), in
    /// runs that measure them (`[detection]`).
    pub detection: Option<platoon_sim::detection::DetectionSummary>,
}

/// Samples the orchestrator received for a step it already had, per service (a publisher
/// repeating itself: harmless to the results, costly to the run).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct DuplicateSamples {
    /// From the plant.
    pub states: u64,
    /// From the controller.
    pub tx: u64,
    /// From the injector.
    pub rx: u64,
    /// From the controller.
    pub commands: u64,
    /// From the controller (runs with `[detection]`).
    pub inspections: u64,
}

impl DuplicateSamples {
    /// All of them.
    pub fn total(&self) -> u64 {
        self.states + self.tx + self.rx + self.commands + self.inspections
    }
}

/// The services the orchestrator creates and keeps open for the run.
struct Services {
    _states: crate::ipc::StepService<VehicleState>,
    _tx: crate::ipc::StepService<LinkPacket>,
    _rx: crate::ipc::StepService<LinkPacket>,
    _commands: crate::ipc::StepService<Command>,
    _gated: crate::ipc::StepService<LinkPacket>,
    _traffic: Option<crate::ipc::StepService<TrafficVehicle>>,
    _inspections: Option<crate::ipc::StepService<Inspection>>,
    _wake: Vec<crate::ipc::WakeService>,
}

impl Services {
    /// Every step service of the run (traffic and inspections when it has them) beside the
    /// wake-up services `wake`: created before any node starts, so nodes only ever open.
    fn create(
        e: &Endpoint,
        opts: &Options,
        scenario: &Scenario,
        wake: Vec<crate::ipc::WakeService>,
    ) -> Result<Self, CosimError> {
        Ok(Services {
            _states: e.create_step_service(Service::States)?,
            _tx: e.create_step_service(Service::Tx)?,
            _rx: e.create_step_service(Service::Rx)?,
            _commands: e.create_step_service(Service::Commands)?,
            _gated: e.create_step_service(Service::Gated)?,
            _traffic: (opts.traffic > 0)
                .then(|| e.create_step_service(Service::Traffic))
                .transpose()?,
            _inspections: scenario
                .control
                .detection
                .is_measured()
                .then(|| e.create_step_service(Service::Inspections))
                .transpose()?,
            _wake: wake,
        })
    }
}

/// Runs `scenario` across processes and calls `on_step` with the rows of every step, in order,
/// what happened on the wire in it (measured between the tx and rx batches) and, in runs that
/// measure detectors, the packets they inspected with their ground truth (the per-message
/// dataset; empty otherwise).
/// On failure every process is stopped and the error names the node and the step.
pub fn orchestrate(
    opts: &Options,
    scenario: &Scenario,
    mut on_step: impl FnMut(&[StepRow], StepWire<'_>, &[Scored]),
) -> Result<Outcome, CosimError> {
    let e = Endpoint::new(&opts.run_id, Node::Orchestrator)?;
    // Create everything before any node starts, so nodes only ever open.
    let wake = Node::ALL
        .iter()
        .map(|&n| e.wake_service(n, true))
        .collect::<Result<Vec<_>, _>>()?;
    let services = Services::create(&e, opts, scenario, wake)?;
    let control_service = e.control_service(Service::Control, true)?;
    let status_service = e.control_service(Service::Status, true)?;
    let listener = e.listener()?;
    let status = ControlInlet::new(&status_service)?;
    let control = e.control_outlet(&control_service, Service::Control)?;
    let mut inlets = Inlets::open(&services)?;
    let observe = Observe::create(&e, opts.observers, scenario)?;

    let mut children = Children { procs: Vec::new() };
    let result = (|| {
        spawn_all(opts, &mut children)?;
        let mut run = Recorder::new(scenario, opts.radar);
        // Startup: wait until every node is READY.
        await_ready(opts, &mut children, &status, &listener)?;
        inlets.connect(&services)?;
        control.send(ControlMsg::new(ControlMsg::START, Node::Orchestrator, 0))?;
        run.last_progress = Instant::now();

        // The run: record each step once its four samples are in.
        let mut clock = StageClock::default();
        let mut done = Done::awaited(opts, scenario);
        loop {
            if stopped(opts) {
                return Err(CosimError::Interrupted { step: run.step });
            }
            // Progress is a step recorded or a node reporting: samples that arrive without
            // completing a step (an injector repeating rx[k]) do not reset the timeout.
            let mut progressed = false;
            // A malformed sample stops the run, but only after every step that was complete
            // before it is recorded.
            let drained = inlets.drain();
            let mut streams = inlets.streams(opts.traffic);
            progressed |= streams.record(scenario, &mut run, &mut clock, &observe, &mut on_step)?;
            while let Some(m) = status.next()? {
                progressed = true;
                if let Err(failed) = check_failed(&m, &children) {
                    // What it failed on may be a malformed sample of another node (a plant
                    // refusing a controller's commands) that arrived with the steps complete
                    // before it: record those, and name the sender if its sample is the cause.
                    let mut streams = inlets.streams(opts.traffic);
                    streams.drain_all();
                    streams.record(scenario, &mut run, &mut clock, &observe, &mut on_step)?;
                    return Err(failed);
                }
                if m.kind == ControlMsg::DONE {
                    done.report(&m, scenario);
                } else if m.kind == ControlMsg::TIMING && m.node == Node::Controller as u32 {
                    done.crypto = Some((Stats::from_ns(&m.counts), Stats::from_ns(&m.seals)));
                }
            }
            drained?;
            if run.step > scenario.steps && done.all() {
                break;
            }
            if let Err(e) = watch(&mut children, run.step, &status) {
                // A process that died may have published steps we have not read yet: record
                // every step that is complete before saying so. Looked at before the step
                // timeout: a process that died is why nothing came. A report read here is
                // treated as one read above: a malformed sample it failed on names its sender.
                let mut streams = inlets.streams(opts.traffic);
                streams.drain_all();
                let recorded =
                    streams.record(scenario, &mut run, &mut clock, &observe, &mut on_step);
                if matches!(e, CosimError::Failed { .. }) {
                    recorded?;
                }
                return Err(e);
            }
            if progressed {
                run.last_progress = Instant::now();
            } else if run.last_progress.elapsed() > opts.step_timeout {
                let streams = inlets.streams(opts.traffic);
                return Err(stalled_at(
                    run.step, scenario, opts, &done.done, &streams, &children,
                ));
            }
            wait(&listener, Duration::from_millis(100))?;
        }
        Ok(Outcome {
            radio: done.radio,
            detection: run.measure.as_ref().and_then(Measure::summary),
            rejected: done.rejected.unwrap_or_default(),
            seals: done.seals,
            timing: {
                let mut t = clock.report();
                if let Some((sign, verify)) = done.crypto {
                    (t.sign, t.verify) = (sign, verify);
                }
                t
            },
            duplicates: inlets.duplicates(),
            peak_rss_kib: Vec::new(),
        })
    })();
    let mut result = result;
    match &mut result {
        Ok(outcome) => {
            outcome.peak_rss_kib = children.peak_rss_kib();
            let _ = control.send(ControlMsg::new(ControlMsg::STOP, Node::Orchestrator, 0));
            children.shut_down(Duration::from_secs(2));
        }
        Err(err) => {
            let _ = control.send(
                ControlMsg::new(ControlMsg::ABORT, Node::Orchestrator, 0)
                    .with_reason(&crate::Causes(err).to_string()),
            );
            children.shut_down(Duration::from_millis(300));
        }
    }
    drop(children);
    e.cleanup_dead_nodes();
    result
}

/// The orchestrator's subscribers: the four samples of a step, the plant's traffic and the
/// controller's inspections when the run has them.
struct Inlets {
    states: Inlet<VehicleState>,
    traffic: Option<Inlet<TrafficVehicle>>,
    tx: Inlet<LinkPacket>,
    rx: Inlet<LinkPacket>,
    inspections: Option<Inlet<Inspection>>,
    commands: Inlet<Command>,
}

impl Inlets {
    /// Subscribes to the run's services (before any node starts).
    fn open(services: &Services) -> Result<Self, CosimError> {
        Ok(Self {
            states: Inlet::new(&services._states, Node::Plant)?,
            traffic: services
                ._traffic
                .as_ref()
                .map(|s| Inlet::new(s, Node::Plant))
                .transpose()?,
            tx: Inlet::new(&services._tx, Node::Controller)?,
            rx: Inlet::new(&services._rx, Node::Injector)?,
            inspections: services
                ._inspections
                .as_ref()
                .map(|s| Inlet::new(s, Node::Controller))
                .transpose()?,
            commands: Inlet::new(&services._commands, Node::Controller)?,
        })
    }

    /// Connects to the nodes' publishers, once every node is READY (every node opened its
    /// ports before). A controller that does not publish inspections (a raw-protocol one,
    /// say) inspects nothing: its steps are recorded without waiting for them.
    fn connect(&mut self, services: &Services) -> Result<(), CosimError> {
        if services._inspections.as_ref().is_some_and(|s| {
            use iceoryx2::service::port_factory::PortFactory as _;
            s.dynamic_config().number_of_publishers() == 0
        }) {
            self.inspections = None;
        }
        self.states.connect()?;
        self.traffic.as_ref().map_or(Ok(()), Inlet::connect)?;
        self.tx.connect()?;
        self.rx.connect()?;
        self.inspections.as_ref().map_or(Ok(()), Inlet::connect)?;
        self.commands.connect()
    }

    /// Takes every sample that arrived. Each inlet is drained even when another's sample was
    /// malformed (the first such error is returned); traffic after states, so the traffic of
    /// every step whose states are in is in too (the plant publishes it first).
    fn drain(&mut self) -> Result<(), CosimError> {
        [
            self.states.drain(),
            self.traffic.as_mut().map_or(Ok(0), Inlet::drain),
            self.tx.drain(),
            self.rx.drain(),
            self.inspections.as_mut().map_or(Ok(0), Inlet::drain),
            self.commands.drain(),
        ]
        .into_iter()
        .find(Result::is_err)
        .unwrap_or(Ok(0))
        .map(|_| ())
    }

    /// The inlets as one [`Streams`] (the run's traffic with `traffic` vehicles), borrowed anew
    /// wherever the loop records.
    fn streams(&mut self, traffic: usize) -> Streams<'_> {
        Streams {
            states: &mut self.states,
            traffic: self.traffic.as_mut().map(|t| (t, traffic)),
            tx: &mut self.tx,
            rx: &mut self.rx,
            inspections: self.inspections.as_mut(),
            commands: &mut self.commands,
        }
    }

    /// How many samples each inlet got twice.
    fn duplicates(&self) -> DuplicateSamples {
        DuplicateSamples {
            states: self.states.duplicates(),
            tx: self.tx.duplicates(),
            rx: self.rx.duplicates(),
            commands: self.commands.duplicates(),
            inspections: self.inspections.as_ref().map_or(0, Inlet::duplicates),
        }
    }
}

/// The orchestrator's four inlets, and the plant's traffic with its count if the run has it.
struct Streams<'a> {
    states: &'a mut Inlet<VehicleState>,
    traffic: Option<(&'a mut Inlet<TrafficVehicle>, usize)>,
    tx: &'a mut Inlet<LinkPacket>,
    rx: &'a mut Inlet<LinkPacket>,
    inspections: Option<&'a mut Inlet<Inspection>>,
    commands: &'a mut Inlet<Command>,
}

impl Streams<'_> {
    /// Reads what arrived on every inlet, ignoring malformed samples (the run is stopping).
    fn drain_all(&mut self) {
        let _ = self.states.drain();
        if let Some((t, _)) = &mut self.traffic {
            let _ = t.drain();
        }
        let _ = self.tx.drain();
        let _ = self.rx.drain();
        if let Some(i) = &mut self.inspections {
            let _ = i.drain();
        }
        let _ = self.commands.drain();
    }

    /// Records every step whose four samples are in; true if any was.
    fn record(
        &mut self,
        scenario: &Scenario,
        run: &mut Recorder<'_>,
        clock: &mut StageClock,
        observe: &Observe,
        on_step: &mut impl FnMut(&[StepRow], StepWire<'_>, &[Scored]),
    ) -> Result<bool, CosimError> {
        let mut progressed = false;
        while run.step <= scenario.steps && self.states.has(run.step) {
            let k = run.step;
            // The traffic of step k is published before its states, and drained after them:
            // missing or malformed, it is the plant's fault, whoever else failed on it since
            // (the injector reads it too).
            if let Some((inlet, count)) = &self.traffic {
                let items = inlet.peek(k).ok_or_else(|| CosimError::Contract {
                    node: "plant",
                    message: format!(
                        "no traffic sample for step {k} (the plant publishes it before the \
                         states of the step)"
                    ),
                })?;
                check_traffic(items, Some(*count), k)?;
            }
            if !(self.tx.has(k)
                && self.rx.has(k)
                && self.commands.has(k)
                && self.inspections.as_ref().is_none_or(|i| i.has(k)))
            {
                break;
            }
            if let Some((inlet, _)) = &mut self.traffic {
                inlet.take_buffered(k);
            }
            let (hs, s) = self.states.take_buffered(k).expect("has");
            let (ht, t) = self.tx.take_buffered(k).expect("has");
            let (hr, r) = self.rx.take_buffered(k).expect("has");
            let (hc, c) = self.commands.take_buffered(k).expect("has");
            clock.push(hs.stamp_ns, ht.stamp_ns, hr.stamp_ns, hc.stamp_ns);
            let inspected = self
                .inspections
                .as_mut()
                .map(|inlet| inlet.take_buffered(k).expect("has").1);
            run.record(&s, &t, &r, &c, inspected.as_deref().unwrap_or(&[]))?;
            observe.publish(k, scenario.dt(), &s, &t, &r, &c)?;
            on_step(
                &run.rows,
                StepWire {
                    per_vehicle: &run.wire,
                    outside: run.outside,
                    maneuvers: &run.maneuvers,
                },
                run.measure.as_ref().map_or(&[], Measure::scored),
            );
            run.step += 1;
            progressed = true;
        }
        Ok(progressed)
    }
}

/// Whether the run was asked to stop.
fn stopped(opts: &Options) -> bool {
    opts.stop
        .as_ref()
        .is_some_and(|s| s.load(std::sync::atomic::Ordering::SeqCst))
}

/// Waits until every node reports READY (the channel too when it runs first), watching the
/// children and the status reports; a node not READY within the ready timeout is named,
/// a plug-in before a built-in node.
fn await_ready(
    opts: &Options,
    children: &mut Children,
    status: &ControlInlet,
    listener: &iceoryx2::port::listener::Listener<iceoryx2::service::ipc::Service>,
) -> Result<(), CosimError> {
    let mut ready = [false; Node::ALL.len()];
    ready[Node::Orchestrator as usize] = true;
    ready[Node::Channel as usize] = !opts.channel_first;
    let started = Instant::now();
    while ready.iter().any(|r| !r) {
        if stopped(opts) {
            return Err(CosimError::Interrupted { step: 0 });
        }
        watch(children, 0, status)?;
        while let Some(m) = status.next()? {
            check_failed(&m, children)?;
            if m.kind == ControlMsg::READY {
                if let Some(n) = Node::from_u32(m.node) {
                    ready[n as usize] = true;
                }
            }
        }
        if ready.iter().all(|r| *r) {
            break;
        }
        if started.elapsed() > opts.ready_timeout {
            // A plug-in first (the user's program, or the SUMO bridge): a built-in node is
            // late only when the machine is, and then so is every other.
            let late = Node::ALL
                .iter()
                .filter(|n| !ready[**n as usize])
                .min_by_key(|n| !children.of(n.name()).is_some_and(|p| p.plugin))
                .expect("one is not ready");
            return Err(CosimError::Stalled {
                node: late.name(),
                step: 0,
                waited_s: opts.ready_timeout.as_secs_f64(),
                what: "it never reported READY",
                duplicates: 0,
                detail: children.of(late.name()).map_or_else(String::new, |p| {
                    log_detail(p, true)
                        + "\n  --ready-timeout sets how long the processes may take to start"
                }),
            });
        }
        wait(listener, Duration::from_millis(100))?;
    }
    Ok(())
}

/// The nodes' DONE reports: who the run waits for (false until it reports; true for whom it
/// does not wait), the node that reports the channel's radio with its DONE (if one does), and
/// what the reports carried.
struct Done {
    done: [bool; Node::ALL.len()],
    channel_node: Option<Node>,
    /// The controller's reject counts.
    rejected: Option<RejectCounts>,
    /// What its seals did.
    seals: platoon_control::SealCounts,
    /// The channel's radio measurements.
    radio: Option<platoon_attacks::channel::RadioStats>,
    /// The controller's TIMING (`[security]` runs): signing and verifying per step.
    crypto: Option<(Option<Stats>, Option<Stats>)>,
}

impl Done {
    /// Whom `opts`' run of `scenario` waits for.
    fn awaited(opts: &Options, scenario: &Scenario) -> Self {
        // Plant and controller report DONE (the controller with its reject counts); an injector
        // only has to publish every step, so a third-party one need not know about DONE.
        let mut done = [false; Node::ALL.len()];
        done[Node::Orchestrator as usize] = true;
        done[Node::Injector as usize] = true;
        done[Node::Channel as usize] = !opts.channel_first;
        // The built-in channel reports its radio's measurements with DONE, and flushes the
        // channel log the run reads back for jammers' per-link outages before it: wait for it.
        let waits = scenario.radio.is_some() || !scenario.jammers.is_empty();
        let channel_node = if !waits {
            None
        } else if opts.channel_first {
            Some(Node::Channel)
        } else {
            matches!(opts.injector, Program::Builtin).then_some(Node::Injector)
        };
        if let Some(n) = channel_node {
            done[n as usize] = false;
        }
        Self {
            done,
            channel_node,
            rejected: None,
            seals: Default::default(),
            radio: None,
            crypto: None,
        }
    }

    /// Takes the DONE report `m`.
    fn report(&mut self, m: &ControlMsg, scenario: &Scenario) {
        if let Some(n) = Node::from_u32(m.node) {
            self.done[n as usize] = true;
        }
        if m.node == Node::Controller as u32 {
            self.rejected = Some(RejectCounts::from_array(m.counts));
            self.seals = platoon_control::SealCounts::from_array(
                m.seals,
                platoon_control::security::ReportCounts::from_array(m.reports),
            );
        }
        if scenario.radio.is_some() && self.channel_node.is_some_and(|n| m.node == n as u32) {
            // Every vehicle of every platoon measures at every step.
            let samples = scenario.vehicles() as u64 * (scenario.steps + 1);
            self.radio = Some(platoon_attacks::channel::RadioStats::from_counts(
                m.counts, samples,
            ));
        }
    }

    /// Whether every node awaited has reported.
    fn all(&self) -> bool {
        self.done.iter().all(|d| *d)
    }
}

/// Why the run stalled at step `k`: the node that did not publish (or, past the last step,
/// report DONE) within the step timeout, what it owed, and the duplicates that arrived.
fn stalled_at(
    k: u64,
    scenario: &Scenario,
    opts: &Options,
    done: &[bool],
    streams: &Streams<'_>,
    children: &Children,
) -> CosimError {
    let (node, what) = if k > scenario.steps {
        let late = Node::ALL.iter().find(|n| !done[**n as usize]).expect("one");
        (late.name(), "it never reported DONE")
    } else if !streams.states.has(k) {
        ("plant", "states")
    } else if streams.traffic.as_ref().is_some_and(|(t, _)| !t.has(k)) {
        ("plant", "the traffic sample")
    } else if !streams.tx.has(k) {
        ("controller", "the tx batch")
    } else if !streams.rx.has(k) {
        ("injector", "the rx batch")
    } else if streams.inspections.as_ref().is_some_and(|i| !i.has(k)) {
        ("controller", "the inspections")
    } else {
        ("controller", "commands")
    };
    CosimError::Stalled {
        node,
        step: k,
        waited_s: opts.step_timeout.as_secs_f64(),
        what,
        duplicates: streams.states.duplicates()
            + streams.traffic.as_ref().map_or(0, |(t, _)| t.duplicates())
            + streams.tx.duplicates()
            + streams.rx.duplicates()
            + streams.inspections.as_ref().map_or(0, |i| i.duplicates())
            + streams.commands.duplicates(),
        detail: children.of(node).map_or_else(String::new, |p| {
            log_detail(p, true) + "\n  --step-timeout sets how long a run waits for a step"
        }),
    }
}
