//! The orchestrator: creates the run's services, starts the plant, controller and injector
//! processes, waits until all are ready, records every step, and shuts everything down, on
//! success or failure, leaving no process behind.
use crate::detection::Measure;
use crate::ipc::{wait, ControlInlet, Endpoint, Inlet};
use crate::session::{
    check_traffic, deliveries_from_wire, link_from_wire, states_from_wire, Numbering,
};
use crate::timing::{StageClock, Timing};
use crate::RunError;
use platoon_control::{FollowerStep, RejectCounts};
use platoon_sim::detection::Scored;
use platoon_sim::{step_rows, Scenario, StepRow, StepWire, WireCounts};
use platoon_wire::{
    Command, ControlMsg, Inspection, LinkPacket, Node, Observed, Service, TrafficVehicle,
    VehicleState,
};
use std::path::PathBuf;
use std::process::{Child, Command as Process, Stdio};
use std::time::{Duration, Instant};

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
    /// the run ends with [`RunError::Interrupted`] within one wait tick (100 ms).
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

/// One process of the run.
struct Proc {
    node: Node,
    child: Child,
    /// Where its stdout and stderr go.
    log: Option<PathBuf>,
    /// Not built in: a program of the user's (`--injector`) or the SUMO bridge.
    plugin: bool,
}

struct Children {
    procs: Vec<Proc>,
}

impl Children {
    /// A child that has exited (its index), with its status.
    fn exited(&mut self) -> Option<(usize, String)> {
        self.procs
            .iter_mut()
            .enumerate()
            .find_map(|(i, p)| Some((i, p.child.try_wait().ok()??.to_string())))
    }

    /// The process that plays `node`.
    fn of(&self, node: &str) -> Option<&Proc> {
        self.procs.iter().find(|p| p.node.name() == node)
    }

    /// Each child's peak resident memory so far, in KiB.
    fn peak_rss_kib(&self) -> Vec<(&'static str, u64)> {
        self.procs
            .iter()
            .filter_map(|p| Some((p.node.name(), crate::peak_rss_kib(Some(p.child.id()))?)))
            .collect()
    }

    /// Waits up to `grace` for every child to exit, then kills what is left.
    fn shut_down(&mut self, grace: Duration) {
        let until = Instant::now() + grace;
        for Proc { child: c, .. } in &mut self.procs {
            while Instant::now() < until {
                if let Ok(Some(_)) = c.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
        self.procs.clear();
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        self.shut_down(Duration::ZERO);
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

/// Runs `scenario` across processes and calls `on_step` with the rows of every step, in order,
/// what happened on the wire in it (measured between the tx and rx batches) and, in runs that
/// measure detectors, the packets they inspected with their ground truth (the per-message
/// dataset; empty otherwise).
/// On failure every process is stopped and the error names the node and the step.
pub fn orchestrate(
    opts: &Options,
    scenario: &Scenario,
    mut on_step: impl FnMut(&[StepRow], StepWire<'_>, &[Scored]),
) -> Result<Outcome, RunError> {
    let e = Endpoint::new(&opts.run_id, Node::Orchestrator)?;
    // Create everything before any node starts, so nodes only ever open.
    let wake = Node::ALL
        .iter()
        .map(|&n| e.wake_service(n, true))
        .collect::<Result<Vec<_>, _>>()?;
    let services = Services {
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
    };
    let control_service = e.control_service(Service::Control, true)?;
    let status_service = e.control_service(Service::Status, true)?;
    let listener = e.listener()?;
    let status = ControlInlet::new(&status_service)?;
    let control = e.control_outlet(&control_service, Service::Control)?;
    let mut states: Inlet<VehicleState> = Inlet::new(&services._states, Node::Plant)?;
    let mut tx: Inlet<LinkPacket> = Inlet::new(&services._tx, Node::Controller)?;
    let mut rx: Inlet<LinkPacket> = Inlet::new(&services._rx, Node::Injector)?;
    let mut commands: Inlet<Command> = Inlet::new(&services._commands, Node::Controller)?;
    let mut traffic: Option<Inlet<TrafficVehicle>> = services
        ._traffic
        .as_ref()
        .map(|s| Inlet::new(s, Node::Plant))
        .transpose()?;
    let mut inspections: Option<Inlet<Inspection>> = services
        ._inspections
        .as_ref()
        .map(|s| Inlet::new(s, Node::Controller))
        .transpose()?;
    let observe = Observe::create(&e, opts.observers, scenario)?;

    let mut children = Children { procs: Vec::new() };
    let result = (|| {
        spawn_all(opts, &mut children)?;
        let mut run = Recorder::new(scenario);
        // Startup: wait until every node is READY.
        let mut ready = [false; Node::ALL.len()];
        ready[Node::Orchestrator as usize] = true;
        ready[Node::Channel as usize] = !opts.channel_first;
        let started = Instant::now();
        let stopped = || {
            opts.stop
                .as_ref()
                .is_some_and(|s| s.load(std::sync::atomic::Ordering::SeqCst))
        };
        while ready.iter().any(|r| !r) {
            if stopped() {
                return Err(RunError::Interrupted { step: 0 });
            }
            watch(&mut children, 0, &status)?;
            while let Some(m) = status.next()? {
                check_failed(&m, &children)?;
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
                return Err(RunError::Stalled {
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
            wait(&listener, Duration::from_millis(100))?;
        }
        // A controller that does not publish inspections (a raw-protocol one, say) inspects
        // nothing: its steps are recorded without waiting for them. Every node opened its
        // ports before READY.
        if services._inspections.as_ref().is_some_and(|s| {
            use iceoryx2::service::port_factory::PortFactory as _;
            s.dynamic_config().number_of_publishers() == 0
        }) {
            inspections = None;
        }
        states.connect()?;
        traffic.as_ref().map_or(Ok(()), Inlet::connect)?;
        tx.connect()?;
        rx.connect()?;
        inspections.as_ref().map_or(Ok(()), Inlet::connect)?;
        commands.connect()?;
        control.send(ControlMsg::new(ControlMsg::START, Node::Orchestrator, 0))?;
        run.last_progress = Instant::now();

        // The run: record each step once its four samples are in.
        let mut rejected = None;
        let mut clock = StageClock::default();
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
        let mut radio = None;
        // The inlets as one `Streams`, borrowed anew wherever the loop records.
        macro_rules! streams {
            () => {
                Streams {
                    states: &mut states,
                    traffic: traffic.as_mut().map(|t| (t, opts.traffic)),
                    tx: &mut tx,
                    rx: &mut rx,
                    inspections: inspections.as_mut(),
                    commands: &mut commands,
                }
            };
        }
        loop {
            if stopped() {
                return Err(RunError::Interrupted { step: run.step });
            }
            // Progress is a step recorded or a node reporting: samples that arrive without
            // completing a step (an injector repeating rx[k]) do not reset the timeout.
            let mut progressed = false;
            // A malformed sample stops the run, but only after every step that was complete
            // before it is recorded.
            // Each inlet is drained even when another's sample was malformed; traffic after
            // states, so the traffic of every step whose states are in is in too (the plant
            // publishes it first).
            let drained = [
                states.drain(),
                traffic.as_mut().map_or(Ok(0), Inlet::drain),
                tx.drain(),
                rx.drain(),
                inspections.as_mut().map_or(Ok(0), Inlet::drain),
                commands.drain(),
            ]
            .into_iter()
            .find(Result::is_err)
            .unwrap_or(Ok(0));
            let mut streams = streams!();
            progressed |= streams.record(scenario, &mut run, &mut clock, &observe, &mut on_step)?;
            while let Some(m) = status.next()? {
                progressed = true;
                if let Err(failed) = check_failed(&m, &children) {
                    // What it failed on may be a malformed sample of another node (a plant
                    // refusing a controller's commands) that arrived with the steps complete
                    // before it: record those, and name the sender if its sample is the cause.
                    let mut streams = streams!();
                    streams.drain_all();
                    streams.record(scenario, &mut run, &mut clock, &observe, &mut on_step)?;
                    return Err(failed);
                }
                if m.kind == ControlMsg::DONE {
                    if let Some(n) = Node::from_u32(m.node) {
                        done[n as usize] = true;
                    }
                    if m.node == Node::Controller as u32 {
                        rejected = Some(RejectCounts::from_array(m.counts));
                    }
                    if scenario.radio.is_some() && channel_node.is_some_and(|n| m.node == n as u32)
                    {
                        // Every vehicle of every platoon measures at every step.
                        let samples = scenario.vehicles() as u64 * (scenario.steps + 1);
                        radio = Some(platoon_attacks::channel::RadioStats::from_counts(
                            m.counts, samples,
                        ));
                    }
                }
            }
            drained?;
            if run.step > scenario.steps && done.iter().all(|d| *d) {
                break;
            }
            if let Err(e) = watch(&mut children, run.step, &status) {
                // A process that died may have published steps we have not read yet: record
                // every step that is complete before saying so. Looked at before the step
                // timeout: a process that died is why nothing came. A report read here is
                // treated as one read above: a malformed sample it failed on names its sender.
                let mut streams = streams!();
                streams.drain_all();
                let recorded =
                    streams.record(scenario, &mut run, &mut clock, &observe, &mut on_step);
                if matches!(e, RunError::Failed { .. }) {
                    recorded?;
                }
                return Err(e);
            }
            if progressed {
                run.last_progress = Instant::now();
            } else if run.last_progress.elapsed() > opts.step_timeout {
                let k = run.step;
                let (node, what) = if k > scenario.steps {
                    let late = Node::ALL.iter().find(|n| !done[**n as usize]).expect("one");
                    (late.name(), "it never reported DONE")
                } else if !states.has(k) {
                    ("plant", "states")
                } else if traffic.as_ref().is_some_and(|t| !t.has(k)) {
                    ("plant", "the traffic sample")
                } else if !tx.has(k) {
                    ("controller", "the tx batch")
                } else if !rx.has(k) {
                    ("injector", "the rx batch")
                } else if inspections.as_ref().is_some_and(|i| !i.has(k)) {
                    ("controller", "the inspections")
                } else {
                    ("controller", "commands")
                };
                return Err(RunError::Stalled {
                    node,
                    step: k,
                    waited_s: opts.step_timeout.as_secs_f64(),
                    what,
                    duplicates: states.duplicates()
                        + traffic.as_ref().map_or(0, Inlet::duplicates)
                        + tx.duplicates()
                        + rx.duplicates()
                        + inspections.as_ref().map_or(0, Inlet::duplicates)
                        + commands.duplicates(),
                    detail: children.of(node).map_or_else(String::new, |p| {
                        log_detail(p, true)
                            + "\n  --step-timeout sets how long a run waits for a step"
                    }),
                });
            }
            wait(&listener, Duration::from_millis(100))?;
        }
        Ok(Outcome {
            radio,
            detection: run.measure.as_ref().and_then(Measure::summary),
            rejected: rejected.unwrap_or_default(),
            timing: clock.report(),
            duplicates: DuplicateSamples {
                states: states.duplicates(),
                tx: tx.duplicates(),
                rx: rx.duplicates(),
                commands: commands.duplicates(),
                inspections: inspections.as_ref().map_or(0, Inlet::duplicates),
            },
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
                    .with_reason(&err.to_string()),
            );
            children.shut_down(Duration::from_millis(300));
        }
    }
    drop(children);
    e.cleanup_dead_nodes();
    result
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
    ) -> Result<bool, RunError> {
        let mut progressed = false;
        while run.step <= scenario.steps && self.states.has(run.step) {
            let k = run.step;
            // The traffic of step k is published before its states, and drained after them:
            // missing or malformed, it is the plant's fault, whoever else failed on it since
            // (the injector reads it too).
            if let Some((inlet, count)) = &self.traffic {
                let items = inlet.peek(k).ok_or_else(|| RunError::Contract {
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
                },
                run.measure.as_ref().map_or(&[], Measure::scored),
            );
            run.step += 1;
            progressed = true;
        }
        Ok(progressed)
    }
}

/// The observer copies of the four step streams (`observe/<leaf>`), published only while
/// someone subscribes.
struct Observe {
    states: (
        crate::ipc::StepService<VehicleState>,
        crate::ipc::Outlet<VehicleState>,
    ),
    tx: (
        crate::ipc::StepService<LinkPacket>,
        crate::ipc::Outlet<LinkPacket>,
    ),
    rx: (
        crate::ipc::StepService<LinkPacket>,
        crate::ipc::Outlet<LinkPacket>,
    ),
    commands: (
        crate::ipc::StepService<Command>,
        crate::ipc::Outlet<Command>,
    ),
}

impl Observe {
    fn create(e: &Endpoint, observers: usize, scenario: &Scenario) -> Result<Self, RunError> {
        let vehicles = Numbering::of(scenario).vehicles();
        macro_rules! stream {
            ($o:expr, $len:expr) => {{
                let service = e.create_observe_service($o, observers)?;
                let outlet = e.outlet(&service, Service::Observe($o), $len)?;
                (service, outlet)
            }};
        }
        Ok(Self {
            states: stream!(Observed::States, vehicles),
            tx: stream!(Observed::Tx, vehicles * 4),
            rx: stream!(Observed::Rx, vehicles * 4),
            commands: stream!(Observed::Commands, vehicles),
        })
    }

    fn publish(
        &self,
        k: u64,
        dt: f64,
        s: &[VehicleState],
        t: &[LinkPacket],
        r: &[LinkPacket],
        c: &[Command],
    ) -> Result<(), RunError> {
        use iceoryx2::service::port_factory::PortFactory as _;
        fn one<T: std::fmt::Debug + Copy + iceoryx2::prelude::ZeroCopySend + 'static>(
            (service, outlet): &(crate::ipc::StepService<T>, crate::ipc::Outlet<T>),
            k: u64,
            dt: f64,
            items: &[T],
        ) -> Result<(), RunError> {
            if service.dynamic_config().number_of_subscribers() > 0 {
                outlet.send(k, dt, items)?;
            }
            Ok(())
        }
        one(&self.states, k, dt, s)?;
        one(&self.tx, k, dt, t)?;
        one(&self.rx, k, dt, r)?;
        one(&self.commands, k, dt, c)
    }
}

/// A node's FAILED report as the run's error, naming the log that holds the whole of it.
fn check_failed(m: &ControlMsg, children: &Children) -> Result<(), RunError> {
    if m.kind == ControlMsg::FAILED {
        let node = Node::from_u32(m.node).map_or("unknown", |n| n.name());
        return Err(RunError::Failed {
            node,
            step: m.step,
            reason: printable(&m.reason()),
            detail: children
                .of(node)
                .map_or_else(String::new, |p| log_detail(p, false)),
        });
    }
    Ok(())
}

/// The error of a process that exited, or the report it sent first: a node that reported
/// FAILED and waits for ABORT (both SDKs, the built-in nodes and the SUMO plant do) keeps its
/// report readable until it is read, so its report, never its exit, is the run's error on any
/// machine load. A process that exits right after reporting may take its report with it.
fn watch(children: &mut Children, step: u64, status: &ControlInlet) -> Result<(), RunError> {
    let Some((i, exit)) = children.exited() else {
        return Ok(());
    };
    while let Some(m) = status.next()? {
        check_failed(&m, children)?;
    }
    let p = &children.procs[i];
    Err(RunError::Died {
        node: p.node.name(),
        pid: p.child.id(),
        step,
        status: exit,
        detail: died_detail(p, step),
    })
}

/// How many of a dead process's last log lines its error quotes.
const TAIL_LINES: usize = 10;

/// What the error of a process that died adds, one line each: the last lines of its log (its
/// stderr and stdout) and where that log is, and for a plug-in that died before the run got
/// past step 0 (starting, or at its first step: where a plug-in of another contract version
/// fails) the contract version the run speaks.
fn died_detail(p: &Proc, step: u64) -> String {
    let mut s = log_detail(p, true);
    if p.plugin && step == 0 {
        use platoon_wire::{CONTRACT_DOC, CONTRACT_VERSION, CONTRACT_VERSION_ENV};
        s += &format!(
            "\n  this run speaks platoon contract v{CONTRACT_VERSION} (type names \
             platoon::v{CONTRACT_VERSION}::*, {CONTRACT_VERSION_ENV}={CONTRACT_VERSION} in the \
             {}'s environment); a plug-in written for another version fails as it starts: \
             see \"Contract versions\" in {CONTRACT_DOC}",
            p.node.name()
        );
    }
    s
}

/// A line naming `p`'s log (`logs/<node>.log`, in the run directory) and, with `tail`, quoting
/// its last lines; empty when its output is not logged.
fn log_detail(p: &Proc, tail: bool) -> String {
    let Some(log) = &p.log else {
        return String::new();
    };
    // The log directory is `logs/` in the run directory, which is renamed when the run ends:
    // name it from there.
    let shown = match log.parent().and_then(|d| d.file_name()) {
        Some(dir) => format!("{}/{}.log", dir.to_string_lossy(), p.node.name()),
        None => format!("{}.log", p.node.name()),
    };
    if !tail {
        return format!("\n  its whole report is in {shown} (in the run directory)");
    }
    let lines = last_lines(log, TAIL_LINES);
    if lines.is_empty() {
        return format!("\n  it wrote nothing to {shown} (in the run directory)");
    }
    let mut s = format!("\n  the last lines of {shown} (in the run directory):");
    for line in lines {
        s += &format!("\n  | {line}");
    }
    s
}

/// `text` safe for a terminal and a JSON file: control characters (an escape sequence, a
/// carriage return, a NUL) are written as escapes (`\u{1b}`); invalid UTF-8 was already
/// replaced when the bytes were read.
fn printable(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// The last `n` non-empty lines of a log file (of its last 64 KiB), each cut to 300
/// characters and made [`printable`]; none if it cannot be read.
fn last_lines(path: &std::path::Path, n: usize) -> Vec<String> {
    use std::io::{Read, Seek, SeekFrom};
    const WINDOW: u64 = 64 * 1024;
    let Ok(mut file) = std::fs::File::open(path) else {
        return Vec::new();
    };
    let len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut bytes = Vec::new();
    if file
        .seek(SeekFrom::Start(len.saturating_sub(WINDOW)))
        .is_err()
        || file.read_to_end(&mut bytes).is_err()
    {
        return Vec::new();
    }
    let text = String::from_utf8_lossy(&bytes);
    let mut lines: Vec<String> = text
        .lines()
        .map(str::trim_end)
        .filter(|l| !l.is_empty())
        .rev()
        .take(n)
        .map(|l| match l.char_indices().nth(300) {
            Some((i, _)) => format!("{}...", printable(&l[..i])),
            None => printable(l),
        })
        .collect();
    lines.reverse();
    lines
}

fn spawn_all(opts: &Options, children: &mut Children) -> Result<(), RunError> {
    let channel = opts.channel_first.then_some(Node::Channel);
    for node in [Node::Plant, Node::Controller, Node::Injector]
        .into_iter()
        .chain(channel)
    {
        let program = match node {
            Node::Plant => &opts.plant,
            Node::Controller => &opts.controller,
            Node::Injector => &opts.injector,
            _ => &Program::Builtin,
        };
        let (mut cmd, shown) = match program {
            Program::Shell(line) => {
                let mut cmd = Process::new("sh");
                cmd.arg("-c").arg(format!("exec {line}"));
                (cmd, line.clone())
            }
            Program::Exec { program, args } => {
                let mut cmd = Process::new(program);
                cmd.args(args);
                (cmd, format!("{} {}", program.display(), args.join(" ")))
            }
            Program::Builtin => {
                let mut cmd = node_command(opts, node);
                // The channel log belongs to whichever node runs the built-in channel.
                if matches!(node, Node::Injector | Node::Channel) {
                    if let Some(log) = &opts.channel_log {
                        cmd.arg("--log").arg(log);
                    }
                }
                (cmd, format!("{} node {}", opts.exe.display(), node.name()))
            }
        };
        // Their own process group: a Ctrl-C at the terminal reaches the orchestrator only,
        // which stops them with ABORT after recording what is complete.
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        pin(&mut cmd, &opts.cpus);
        if node == Node::Injector && opts.channel_first {
            cmd.env("PLATOON_INJECTOR_INPUT", "gated");
        }
        cmd.env("PLATOON_RUN_ID", &opts.run_id)
            .env("PLATOON_CONFIG", &opts.config)
            .env(
                platoon_wire::CONTRACT_VERSION_ENV,
                platoon_wire::CONTRACT_VERSION.to_string(),
            )
            .envs(opts.env.iter().map(|(k, v)| (k, v)))
            .stdin(Stdio::null());
        // Our nodes compute one step at a time between wake-ups: a BLAS thread pool (this
        // binary's OpenBLAS, numpy's in the SUMO bridge) buys them nothing, and its threads
        // spin at start (some 50 ms of CPU each, beside SUMO starting). A user's command
        // (`--injector`, `--controller`) gets the environment as it is; so does any node when
        // the user set the variable.
        let blas = "OPENBLAS_NUM_THREADS";
        let ours = !matches!(program, Program::Shell(_));
        if ours && std::env::var_os(blas).is_none() && !opts.env.iter().any(|(k, _)| k == blas) {
            cmd.env(blas, "1");
        }
        let plugin = *program != Program::Builtin;
        if let (true, Some(dir)) = (plugin, &opts.python_path) {
            cmd.env("PYTHONPATH", python_path(dir, &opts.env));
        }
        let spawn_err = |source| RunError::Spawn {
            node: node.name(),
            command: shown.clone(),
            source,
        };
        let log = opts
            .log_dir
            .as_ref()
            .map(|dir| dir.join(format!("{}.log", node.name())));
        if let Some(log) = &log {
            let file = std::fs::File::create(log).map_err(spawn_err)?;
            let out = file.try_clone().map_err(spawn_err)?;
            cmd.stdout(out).stderr(file);
        }
        let child = cmd.spawn().map_err(spawn_err)?;
        children.procs.push(Proc {
            node,
            child,
            log,
            plugin,
        });
    }
    Ok(())
}

/// `dir` before the `PYTHONPATH` a plug-in would otherwise get (from `env`, the run's
/// [`Options::env`], else this process's), which it keeps.
fn python_path(dir: &std::path::Path, env: &[(String, String)]) -> std::ffi::OsString {
    let theirs = match env.iter().rev().find(|(k, _)| k == "PYTHONPATH") {
        Some((_, v)) => Some(std::ffi::OsString::from(v)),
        None => std::env::var_os("PYTHONPATH"),
    };
    let mut path = dir.as_os_str().to_owned();
    if let Some(theirs) = theirs.filter(|t| !t.is_empty()) {
        path.push(":");
        path.push(theirs);
    }
    path
}

/// Restricts the child to `cpus` (before it runs anything, so its threads inherit it).
fn pin(cmd: &mut Process, cpus: &[usize]) {
    if cpus.is_empty() {
        return;
    }
    // SAFETY: cpu_set_t is plain data; CPU_ZERO/CPU_SET only write into it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &cpu in cpus {
        unsafe { libc::CPU_SET(cpu, &mut set) };
    }
    // SAFETY: sched_setaffinity is async-signal-safe and touches only this (forked) process.
    unsafe {
        std::os::unix::process::CommandExt::pre_exec(cmd, move || {
            if libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

fn node_command(opts: &Options, node: Node) -> Process {
    let mut cmd = Process::new(&opts.exe);
    cmd.arg("node")
        .arg(node.name())
        .arg("--run-id")
        .arg(&opts.run_id)
        .arg("--config")
        .arg(&opts.config);
    cmd
}

/// Turns the four samples of a step into rows, the way the in-process runner does.
struct Recorder<'a> {
    scenario: &'a Scenario,
    replicas: Vec<Scenario>,
    num: Numbering,
    step: u64,
    last_progress: Instant,
    rows: Vec<StepRow>,
    jammed: Vec<bool>,
    leader_sent: Vec<bool>,
    deliveries: Vec<Vec<platoon_control::Delivery>>,
    wire: Vec<WireCounts>,
    outside: WireCounts,
    wire_counter: platoon_sim::tally::WireCounter,
    /// The detectors measured against ground truth (`[detection]` runs).
    measure: Option<Measure>,
}

impl<'a> Recorder<'a> {
    fn new(scenario: &'a Scenario) -> Self {
        let num = Numbering::of(scenario);
        Self {
            scenario,
            replicas: scenario.replicas(),
            num,
            step: 0,
            last_progress: Instant::now(),
            rows: Vec::with_capacity(num.vehicles()),
            jammed: vec![false; num.vehicles()],
            leader_sent: vec![false; num.platoons],
            deliveries: vec![Vec::new(); num.platoons],
            wire: vec![WireCounts::default(); num.vehicles()],
            outside: WireCounts::default(),
            wire_counter: Default::default(),
            measure: Measure::new(scenario),
        }
    }

    /// Step `self.step`'s samples, and what the controller's detectors said of its packets
    /// (empty: nothing, or the run measures none).
    fn record(
        &mut self,
        s: &[VehicleState],
        t: &[LinkPacket],
        r: &[LinkPacket],
        c: &[Command],
        inspections: &[Inspection],
    ) -> Result<(), RunError> {
        let num = self.num;
        let n1 = num.per_platoon;
        let states = states_from_wire(s, num.vehicles())?;
        // The rx batch, sorted as the controllers sort it: deliveries per platoon and who was
        // told its channel was jammed (for the rows and for the wire tally below).
        deliveries_from_wire(r, num, &mut self.deliveries, &mut self.jammed);
        if c.len() != num.followers() {
            return Err(RunError::Contract {
                node: "controller",
                message: format!("{} commands for {} followers", c.len(), num.followers()),
            });
        }
        // Follower i of platoon j at j * N + i - 1 with a finite command: anything else would be
        // recorded against the wrong vehicle (a plug-in controller's mistake, named; the step
        // is not recorded).
        for (x, cmd) in c.iter().enumerate() {
            let i = platoon_model::VehicleId((x % (n1 - 1) + 1) as u16);
            let want = num.global(x / (n1 - 1), i);
            if cmd.vehicle != want || !cmd.u.is_finite() {
                return Err(RunError::Contract {
                    node: "controller",
                    message: format!(
                        "step {}: command {x} is for vehicle {} with u = {}; a step's commands \
                         list every follower in order (vehicle {want} here), each with a \
                         finite u",
                        self.step, cmd.vehicle, cmd.u
                    ),
                });
            }
        }
        // Which leaders broadcast: one pass over the tx batch, not one per platoon.
        self.leader_sent.fill(false);
        for p in t {
            if let Some((j, i)) = num.split(p.packet.sender) {
                self.leader_sent[j] |= i.is_leader();
            }
        }
        self.rows.clear();
        for (j, replica) in self.replicas.iter().enumerate() {
            let leader_triggered = self.leader_sent[j];
            let cmds = &c[j * (n1 - 1)..(j + 1) * (n1 - 1)];
            step_rows(
                self.step,
                replica,
                &states[j * n1..(j + 1) * n1],
                leader_triggered,
                &self.jammed[j * n1..(j + 1) * n1],
                |i| {
                    let cmd = cmds[i - 1];
                    FollowerStep {
                        triggered: cmd.flags & Command::TRIGGERED != 0,
                        affected: cmd.flags & Command::AFFECTED != 0,
                        u: cmd.u,
                        theta: cmd.theta,
                        mode: platoon_control::Mode::from_code(cmd.mode_code()),
                        guard: cmd.flags & Command::GUARD != 0,
                    }
                },
                &mut self.rows,
            );
        }
        // The wire, measured as the in-process runner measures it.
        self.outside = WireCounts::default();
        for j in 0..num.platoons {
            let links = t.iter().filter_map(|it| {
                link_from_wire(it, num)
                    .filter(|l| l.0 == j)
                    .map(|(_, receiver, p)| (receiver, p))
            });
            self.wire_counter.count(
                links,
                &self.deliveries[j],
                &self.jammed[j * n1..(j + 1) * n1],
                &mut self.wire[j * n1..(j + 1) * n1],
                &mut self.outside,
            );
        }
        if let Some(m) = &mut self.measure {
            m.record(self.step, &states, t, &self.deliveries, inspections);
        }
        let _ = self.scenario;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dead(node: Node, log: Option<PathBuf>, plugin: bool) -> Proc {
        let mut child = Process::new("true").spawn().unwrap();
        child.wait().unwrap();
        Proc {
            node,
            child,
            log,
            plugin,
        }
    }

    #[test]
    fn a_dead_plugin_is_quoted_from_its_log_and_told_the_contract() {
        let dir = std::env::temp_dir().join(format!("platoon-died-{}", std::process::id()));
        let logs = dir.join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        let log = logs.join("injector.log");
        let mut text: String = (1..=15).map(|i| format!("line {i}\n\n")).collect();
        text += &"x".repeat(1000);
        std::fs::write(&log, text).unwrap();
        let d = died_detail(&dead(Node::Injector, Some(log.clone()), true), 0);
        assert!(d.contains("logs/injector.log"), "{d}");
        assert!(d.contains("| line 15\n") && d.contains("| line 7\n"), "{d}");
        assert!(!d.contains("line 6\n"), "10 lines only: {d}");
        assert!(d.contains(&format!("| {}...", "x".repeat(300))), "{d}");
        assert!(!d.contains(&"x".repeat(301)), "{d}");
        assert!(
            d.contains(&format!("contract v{}", platoon_wire::CONTRACT_VERSION)),
            "{d}"
        );
        // A built-in node, or a plug-in past step 0: no contract note.
        let later = died_detail(&dead(Node::Injector, Some(log.clone()), true), 5);
        assert!(!later.contains("contract") && later.contains("| line 15"));
        let builtin = died_detail(&dead(Node::Plant, Some(logs.join("plant.log")), false), 0);
        assert!(
            builtin.contains("it wrote nothing to logs/plant.log"),
            "{builtin}"
        );
        assert!(!builtin.contains("contract"), "{builtin}");
        assert_eq!(died_detail(&dead(Node::Plant, None, false), 3), "");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn plugins_get_the_bridge_first_on_their_python_path() {
        let bridge = std::path::Path::new("/b/bridge");
        let mut env = vec![("PYTHONPATH".to_string(), "/mine:/also".to_string())];
        assert_eq!(python_path(bridge, &env), "/b/bridge:/mine:/also");
        env[0].1 = String::new();
        assert_eq!(python_path(bridge, &env), "/b/bridge");
    }
}
