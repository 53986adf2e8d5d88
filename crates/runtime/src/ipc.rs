//! The iceoryx2 ports of one node: step outlets that publish and wake their readers, step inlets
//! that buffer by step, the control channel and the node's own wake-up listener.
use crate::{monotonic_ns, CosimError};
use iceoryx2::node::NodeBuilder;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use platoon_wire::{
    service_name, wakes, ControlMsg, Node as Role, Service, StepHeader, ORCHESTRATOR_WAKE_EVERY,
};
use std::collections::VecDeque;
use std::fmt::Debug;
use std::sync::OnceLock;
use std::time::Duration;

/// Samples a subscriber can hold before its publisher waits: many steps, so a reader that falls
/// behind (the orchestrator writing CSV) slows the run down instead of losing data.
pub const BUFFER: usize = 64;

type Ipc = ipc::Service;

fn ipc_err(
    what: impl std::fmt::Display,
    e: impl std::error::Error + Send + Sync + 'static,
) -> CosimError {
    CosimError::Ipc {
        what: what.to_string(),
        source: Box::new(e),
    }
}

/// The iceoryx2 node of one process in run `run_id`, with the cleanup of dead nodes done first
/// (a killed run leaves shared memory behind; this removes it).
pub struct Endpoint {
    run_id: String,
    role: Role,
    node: iceoryx2::node::Node<Ipc>,
}

impl Endpoint {
    /// Creates the node.
    pub fn new(run_id: &str, role: Role) -> Result<Self, CosimError> {
        set_log_level_from_env_or(LogLevel::Error);
        let name = NodeName::new(&format!("platoon-{}-{run_id}", role.name()))
            .map_err(|e| ipc_err("node name", e))?;
        let node = NodeBuilder::new()
            .name(&name)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<Ipc>()
            .map_err(|e| ipc_err("creating the iceoryx2 node", e))?;
        node.try_cleanup_dead_nodes();
        crate::handoff::init();
        Ok(Self {
            run_id: run_id.to_string(),
            role,
            node,
        })
    }

    /// Removes what dead nodes left behind.
    pub fn cleanup_dead_nodes(&self) {
        self.node.try_cleanup_dead_nodes();
    }

    fn name(&self, s: Service) -> Result<ServiceName, CosimError> {
        let n = service_name(&self.run_id, s);
        ServiceName::new(&n).map_err(|e| ipc_err(format!("service name {n}"), e))
    }

    /// Creates a step service (the orchestrator creates them all before starting the others).
    pub fn create_step_service<T: Debug + ZeroCopySend + 'static>(
        &self,
        s: Service,
    ) -> Result<StepService<T>, CosimError> {
        self.create_service(s, 2, 4, 8, false)
    }

    /// Creates the observer copy of a step stream: room for `observers` read-only subscribers,
    /// and safe overflow, so an observer that stalls loses its oldest samples instead of
    /// holding the publisher (the orchestrator) up.
    pub fn create_observe_service<T: Debug + ZeroCopySend + 'static>(
        &self,
        o: platoon_wire::Observed,
        observers: usize,
    ) -> Result<StepService<T>, CosimError> {
        let observers = observers.max(1);
        self.create_service(Service::Observe(o), 1, observers, observers + 2, true)
    }

    /// Creates a step stream's service with room for these publishers, subscribers and nodes.
    fn create_service<T: Debug + ZeroCopySend + 'static>(
        &self,
        s: Service,
        publishers: usize,
        subscribers: usize,
        nodes: usize,
        safe_overflow: bool,
    ) -> Result<StepService<T>, CosimError> {
        let name = self.name(s)?;
        self.step_builder::<T>(&name)
            .max_publishers(publishers)
            .max_subscribers(subscribers)
            .max_nodes(nodes)
            .history_size(0)
            .subscriber_max_buffer_size(BUFFER)
            .enable_safe_overflow(safe_overflow)
            .create()
            .map_err(|e| ipc_err(format!("creating service {name}"), e))
    }

    /// The builder of a step stream's service: a slice of `T` per sample under a [`StepHeader`].
    fn step_builder<T: Debug + ZeroCopySend + 'static>(
        &self,
        name: &ServiceName,
    ) -> iceoryx2::service::builder::publish_subscribe::Builder<[T], StepHeader, Ipc> {
        self.node
            .service_builder(name)
            .publish_subscribe::<[T]>()
            .user_header::<StepHeader>()
    }

    /// Opens a step service.
    pub fn open_step_service<T: Debug + ZeroCopySend + 'static>(
        &self,
        s: Service,
    ) -> Result<StepService<T>, CosimError> {
        let name = self.name(s)?;
        self.step_builder::<T>(&name)
            .open()
            .map_err(|e| ipc_err(format!("opening service {name}"), e))
    }

    /// Opens an optional step service ([`Service::Traffic`]): `None` if the orchestrator did
    /// not create it for this run.
    pub fn open_optional_step_service<T: Debug + ZeroCopySend + 'static>(
        &self,
        s: Service,
    ) -> Result<Option<StepService<T>>, CosimError> {
        let name = self.name(s)?;
        match self
            .node
            .service_builder(&name)
            .publish_subscribe::<[T]>()
            .user_header::<StepHeader>()
            .open()
        {
            Ok(service) => Ok(Some(service)),
            Err(iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError::DoesNotExist) => {
                Ok(None)
            }
            Err(e) => Err(ipc_err(format!("opening service {name}"), e)),
        }
    }

    /// Creates (orchestrator) or opens the control or status service.
    pub fn control_service(&self, s: Service, create: bool) -> Result<ControlService, CosimError> {
        let name = self.name(s)?;
        let b = self
            .node
            .service_builder(&name)
            .publish_subscribe::<ControlMsg>();
        if create {
            b.max_publishers(4)
                .max_subscribers(4)
                .max_nodes(8)
                .history_size(0)
                .subscriber_max_buffer_size(BUFFER)
                .enable_safe_overflow(false)
                .create()
                .map_err(|e| ipc_err(format!("creating service {name}"), e))
        } else {
            b.open()
                .map_err(|e| ipc_err(format!("opening service {name}"), e))
        }
    }

    /// Creates (orchestrator) or opens the wake-up event service of `node`.
    pub fn wake_service(&self, node: Role, create: bool) -> Result<WakeService, CosimError> {
        let name = self.name(Service::Wake(node))?;
        let b = self.node.service_builder(&name).event();
        if create {
            b.max_notifiers(8)
                .max_listeners(2)
                .max_nodes(8)
                .create()
                .map_err(|e| ipc_err(format!("creating service {name}"), e))
        } else {
            b.open()
                .map_err(|e| ipc_err(format!("opening service {name}"), e))
        }
    }

    /// This node's listener.
    pub fn listener(&self) -> Result<Listener<Ipc>, CosimError> {
        self.wake_service(platoon_wire::wake_listener_of(self.role), false)?
            .listener_builder()
            .create()
            .map_err(|e| ipc_err("creating the wake-up listener", e))
    }

    /// Notifiers that wake the readers of `s` (all but this node).
    pub fn wakers(&self, s: Service) -> Result<Vec<Waker>, CosimError> {
        wakes(s)
            .iter()
            .filter(|&&r| r != self.role)
            .map(|&r| {
                let service = self.wake_service(r, false)?;
                let notifier = service
                    .notifier_builder()
                    .create()
                    .map_err(|e| ipc_err(format!("notifier for {}", r.name()), e))?;
                Ok(Waker {
                    role: r,
                    notifier,
                    service,
                    pids: OnceLock::new(),
                })
            })
            .collect()
    }

    /// A publisher of step samples on `s` that wakes the readers; its shared memory grows
    /// with the batches. A reader maps grown memory only when it first reads from it, so what
    /// this process published and nobody read yet is lost if it exits: use
    /// [`Endpoint::fixed_outlet`] where the batch size is bounded.
    pub fn outlet<T: Debug + Copy + ZeroCopySend + 'static>(
        &self,
        service: &StepService<T>,
        s: Service,
        max_len: usize,
    ) -> Result<Outlet<T>, CosimError> {
        self.outlet_with(service, s, max_len, AllocationStrategy::PowerOfTwo)
    }

    /// A publisher of step samples of at most `max_len` items on `s`: its shared memory never
    /// moves, and the orchestrator maps it before the first step ([`Inlet::connect`]), so its
    /// samples stay readable after this process exits or panics.
    pub fn fixed_outlet<T: Debug + Copy + ZeroCopySend + 'static>(
        &self,
        service: &StepService<T>,
        s: Service,
        max_len: usize,
    ) -> Result<Outlet<T>, CosimError> {
        self.outlet_with(service, s, max_len, AllocationStrategy::Static)
    }

    fn outlet_with<T: Debug + Copy + ZeroCopySend + 'static>(
        &self,
        service: &StepService<T>,
        s: Service,
        max_len: usize,
        strategy: AllocationStrategy,
    ) -> Result<Outlet<T>, CosimError> {
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(max_len.max(1))
            .allocation_strategy(strategy)
            .create()
            .map_err(|e| ipc_err(format!("publisher on {s:?}"), e))?;
        Ok(Outlet {
            publisher,
            wake: self.wakers(s)?,
        })
    }

    /// The control (orchestrator -> nodes) or status (nodes -> orchestrator) outlet.
    pub fn control_outlet(
        &self,
        service: &ControlService,
        s: Service,
    ) -> Result<ControlOutlet, CosimError> {
        let publisher = service
            .publisher_builder()
            .create()
            .map_err(|e| ipc_err(format!("publisher on {s:?}"), e))?;
        Ok(ControlOutlet {
            publisher,
            wake: self.wakers(s)?,
        })
    }
}

/// A step service's port factory.
pub type StepService<T> =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, [T], StepHeader>;
/// The control or status service's port factory.
pub type ControlService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, ControlMsg, ()>;
/// A wake-up event service's port factory.
pub type WakeService = iceoryx2::service::port_factory::event::PortFactory<Ipc>;

/// Wakes one node: its notifier, and the processes listening (for the wake-up hand-off, see
/// `handoff`), looked up once some are there.
pub struct Waker {
    role: Role,
    notifier: Notifier<Ipc>,
    service: WakeService,
    pids: OnceLock<Vec<libc::pid_t>>,
}

impl Waker {
    /// Notifies the node, first handing it this process's CPU, except the orchestrator's (it
    /// records and writes the outputs, off the chain of a step).
    fn wake(&self) -> Result<(), CosimError> {
        if self.role != Role::Orchestrator && crate::handoff::enabled() {
            crate::handoff::hand_to(self.listener_pids());
        }
        self.notifier
            .notify()
            .map(|_| ())
            .map_err(|e| ipc_err("waking a reader", e))
    }

    fn listener_pids(&self) -> &[libc::pid_t] {
        if let Some(pids) = self.pids.get() {
            return pids;
        }
        let mut pids = Vec::new();
        self.service.dynamic_config().list_listeners(|d| {
            if let Ok(pid) = d.node_id.pid::<Ipc>() {
                pids.push(pid.value() as libc::pid_t);
            }
            CallbackProgression::Continue
        });
        if pids.is_empty() {
            // Not listening yet: look again at the next wake-up.
            return &[];
        }
        self.pids.get_or_init(|| pids)
    }
}

/// Publishes one sample per step and wakes its readers.
pub struct Outlet<T: Debug + ZeroCopySend + 'static> {
    publisher: Publisher<Ipc, [T], StepHeader>,
    wake: Vec<Waker>,
}

impl<T: Debug + Copy + ZeroCopySend + 'static> Outlet<T> {
    /// Sends `items` as the sample of step `step` (time `step dt`); returns its publish stamp.
    pub fn send(&self, step: u64, dt: f64, items: &[T]) -> Result<u64, CosimError> {
        let mut sample = self
            .publisher
            .loan_slice_uninit(items.len())
            .map_err(|e| ipc_err("loaning a sample", e))?;
        let stamp = monotonic_ns();
        *sample.user_header_mut() = StepHeader::new(step, dt, items.len(), stamp);
        let sample = sample.write_from_slice(items);
        sample.send().map_err(|e| ipc_err("sending a sample", e))?;
        for w in &self.wake {
            if w.role != Role::Orchestrator || step.is_multiple_of(ORCHESTRATOR_WAKE_EVERY) {
                w.wake()?;
            }
        }
        Ok(stamp)
    }
}

fn wake(wakers: &[Waker]) -> Result<(), CosimError> {
    wakers.iter().try_for_each(Waker::wake)
}

/// Publishes control or status messages and wakes their readers.
pub struct ControlOutlet {
    publisher: Publisher<Ipc, ControlMsg, ()>,
    wake: Vec<Waker>,
}

impl ControlOutlet {
    /// Sends one message.
    pub fn send(&self, msg: ControlMsg) -> Result<(), CosimError> {
        self.publisher
            .send_copy(msg)
            .map_err(|e| ipc_err("sending a control message", e))?;
        wake(&self.wake)
    }
}

/// A received step sample, copied out of shared memory: its header and items.
pub type Sample<T> = (StepHeader, Vec<T>);

/// Receives step samples and keeps them by step until asked for.
pub struct Inlet<T: Debug + ZeroCopySend + 'static> {
    subscriber: Subscriber<Ipc, [T], StepHeader>,
    pending: VecDeque<Sample<T>>,
    from: Role,
    /// Steps below this were taken: samples of them are duplicates.
    floor: u64,
    duplicates: u64,
}

impl<T: Debug + Copy + ZeroCopySend + 'static> Inlet<T> {
    /// A subscriber on `service`, whose samples come from `from`.
    pub fn new(service: &StepService<T>, from: Role) -> Result<Self, CosimError> {
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(|e| ipc_err("creating a subscriber", e))?;
        Ok(Self {
            subscriber,
            pending: VecDeque::new(),
            from,
            floor: 0,
            duplicates: 0,
        })
    }

    /// Connects to every publisher the service has now. A publisher that goes away (its
    /// process exits) takes the samples this subscriber never connected to with it; those of
    /// a connection already made stay readable. So a run connects once every node has opened
    /// its ports, before the first step, and what a crashing node published is not lost.
    pub fn connect(&self) -> Result<(), CosimError> {
        use iceoryx2::port::update_connections::UpdateConnections as _;
        self.subscriber
            .update_connections()
            .map_err(|e| ipc_err("connecting a subscriber", e))
    }

    /// Samples dropped because their step was already taken or already buffered: a publisher
    /// that repeats itself, counted so a run can say so.
    pub fn duplicates(&self) -> u64 {
        self.duplicates
    }

    /// Moves every new received sample into the buffer (a repeated step is dropped and
    /// counted, see [`Inlet::duplicates`]); returns how many were new.
    pub fn drain(&mut self) -> Result<usize, CosimError> {
        let mut n = 0;
        while let Some(s) = self
            .subscriber
            .receive()
            .map_err(|e| ipc_err("receiving", e))?
        {
            let h = s.user_header();
            let items = usize::try_from(h.count)
                .ok()
                .and_then(|n| s.payload().get(..n))
                .ok_or_else(|| CosimError::Contract {
                    node: self.from.name(),
                    message: format!(
                        "the sample of step {} says it holds {} items but carries {}",
                        h.step,
                        h.count,
                        s.payload().len()
                    ),
                })?;
            if h.step < self.floor || self.pending.iter().any(|(p, _)| p.step == h.step) {
                self.duplicates += 1;
                continue;
            }
            self.pending.push_back((*h, items.to_vec()));
            n += 1;
        }
        Ok(n)
    }

    /// The oldest buffered sample, whatever its step.
    pub fn pop(&mut self) -> Option<Sample<T>> {
        self.pending.pop_front()
    }

    /// Whether the sample of step `k` is buffered.
    pub fn has(&self, k: u64) -> bool {
        self.pending.iter().any(|(h, _)| h.step == k)
    }

    /// The items of step `k` if they are buffered, left there.
    pub fn peek(&self, k: u64) -> Option<&[T]> {
        self.pending
            .iter()
            .find(|(h, _)| h.step == k)
            .map(|(_, v)| v.as_slice())
    }

    /// The sample of step `k`, if it arrived; samples of earlier steps are dropped.
    pub fn take(&mut self, k: u64) -> Result<Option<Vec<T>>, CosimError> {
        Ok(self.take_sample(k)?.map(|(_, v)| v))
    }

    /// Like [`Inlet::take`], with the sample's header.
    pub fn take_sample(&mut self, k: u64) -> Result<Option<Sample<T>>, CosimError> {
        self.drain()?;
        Ok(self.take_buffered(k))
    }

    /// The sample of step `k` if it is already buffered, without reading anything new (so a
    /// malformed sample that arrives meanwhile cannot interrupt recording what is complete).
    pub fn take_buffered(&mut self, k: u64) -> Option<Sample<T>> {
        while self.pending.front().is_some_and(|(h, _)| h.step < k) {
            self.pending.pop_front();
        }
        match self.pending.front() {
            Some((h, _)) if h.step == k => {
                self.floor = k + 1;
                self.pending.pop_front()
            }
            _ => None,
        }
    }
}

/// Receives control or status messages.
pub struct ControlInlet {
    subscriber: Subscriber<Ipc, ControlMsg, ()>,
}

impl ControlInlet {
    /// A subscriber on `service`.
    pub fn new(service: &ControlService) -> Result<Self, CosimError> {
        Ok(Self {
            subscriber: service
                .subscriber_builder()
                .create()
                .map_err(|e| ipc_err("creating a control subscriber", e))?,
        })
    }

    /// The next message, if any.
    pub fn next(&self) -> Result<Option<ControlMsg>, CosimError> {
        Ok(self
            .subscriber
            .receive()
            .map_err(|e| ipc_err("receiving a control message", e))?
            .map(|s| *s.payload()))
    }
}

/// Waits until this node is notified, or `timeout` passes.
pub fn wait(listener: &Listener<Ipc>, timeout: Duration) -> Result<(), CosimError> {
    listener
        .timed_wait(|_| {}, timeout)
        .map_err(|e| ipc_err("waiting for a wake-up", e))?;
    crate::handoff::woken();
    Ok(())
}
