//! Maneuver runs in process through an injector that records what it saw: the messages as
//! they crossed the channel, each delivery's ground-truth label.
use platoon_attacks::inject::{InjectError, Injector, Reception, Step};
use platoon_control::{Delivery, Packet};
use platoon_maneuver::{Body, Message};
use platoon_model::{State, VehicleId};
use platoon_sim::truth::{Fields, Label, TruthLabeler};
use platoon_sim::{InjectorFactory, Plugins, Scenario, Simulation, StepRow};
use std::sync::{Arc, Mutex};

/// The built-in channel, recording every maneuver message broadcast (step, message), dropping
/// every delivery of the messages `drop` picks, letting `forge` invent or alter deliveries, and
/// labelling every delivery that carries a message against what was broadcast (the ground
/// truth).
#[derive(Debug, Clone)]
pub struct Recording {
    inner: Box<dyn Injector>,
    log: Arc<Mutex<Log>>,
    drop: fn(u64, &Message) -> bool,
    forge: fn(&Step<'_>, &mut Vec<Delivery>),
    truth: TruthLabeler,
}

/// What a [`Recording`] saw.
#[derive(Debug, Default)]
pub struct Log {
    pub sent: Vec<(u64, Message)>,
    pub labelled: Vec<(Message, Label)>,
    /// How many deliveries of any kind (beacons too) the truth labelled `altered`.
    pub altered: usize,
    /// What the controllers refused over the run (`summary.json`'s `rejected_packets`).
    pub rejected: platoon_control::RejectCounts,
    /// What the seals did (`[security]` runs; `summary.json`'s `security`).
    pub seals: Option<platoon_control::SealCounts>,
}

impl Injector for Recording {
    fn step(&mut self, step: &Step<'_>, out: &mut Reception<'_>) -> Result<(), InjectError> {
        self.inner.step(step, out)?;
        let drop = self.drop;
        out.deliveries
            .retain(|d| !d.packet.maneuver.is_some_and(|m| drop(step.k, &m)));
        (self.forge)(step, out.deliveries);
        let links = step.tx.iter().flat_map(|p| {
            step.topology
                .out_neighbours(p.sender)
                .iter()
                .map(move |&r| (r, *p))
        });
        let mut labelled = Vec::new();
        self.truth
            .label(step.k, step.states, links, out.deliveries, &mut labelled);
        let mut log = self.log.lock().unwrap();
        log.sent.extend(
            step.tx
                .iter()
                .filter_map(|p| p.maneuver.map(|m| (step.k, m))),
        );
        log.labelled.extend(
            labelled
                .iter()
                .filter_map(|l| l.delivery.packet.maneuver.map(|m| (m, l.label))),
        );
        log.altered += labelled
            .iter()
            .filter(|l| matches!(l.label, Label::Altered { .. }))
            .count();
        Ok(())
    }
}

pub fn nothing(_: &Step<'_>, _: &mut Vec<Delivery>) {}

/// Runs `s` in process through [`Recording`]: every row, and what it saw.
pub fn run_with(
    s: Scenario,
    drop: fn(u64, &Message) -> bool,
    forge: fn(&Step<'_>, &mut Vec<Delivery>),
) -> (Vec<StepRow>, Log) {
    let log = Arc::new(Mutex::new(Log::default()));
    let shared = log.clone();
    let plugins = Plugins {
        injector: InjectorFactory::new(move |s| {
            Ok(Box::new(Recording {
                inner: InjectorFactory::builtin().make(s)?,
                log: shared.clone(),
                drop,
                forge,
                truth: TruthLabeler::new(1000),
            }))
        }),
        ..Plugins::default()
    };
    let mut sim = Simulation::with_plugins(s, &plugins).unwrap();
    let mut rows = Vec::new();
    while !sim.is_done() {
        rows.extend_from_slice(sim.step());
    }
    let mut log = std::mem::take(&mut *log.lock().unwrap());
    log.rejected = sim.controller().rejected();
    log.seals = sim.controller().seals();
    (rows, log)
}

/// [`run_with`] forging nothing: every row and every message sent.
pub fn run(s: Scenario, drop: fn(u64, &Message) -> bool) -> (Vec<StepRow>, Vec<(u64, Message)>) {
    let (rows, log) = run_with(s, drop, nothing);
    assert!(
        log.labelled.iter().all(|(_, l)| *l == Label::Genuine),
        "nothing altered or forged"
    );
    (rows, log.sent)
}

pub fn of(rows: &[StepRow], v: u16) -> Vec<&StepRow> {
    rows.iter().filter(|r| r.vehicle == v).collect()
}

/// The catalogue's fake join request: the joiner's packets to the leader rewritten at 3 s,
/// before it asks, into a request for the slot behind the tail.
pub const FAKE_JOIN_REQUEST: &str = "\n[[channel.attacks]]\nkind = \"forge_maneuver\"\n\
    message = \"join_request\"\nsenders = [4]\nreceivers = [0]\nstart_s = 3.0\nend_s = 3.2\n";

/// A delivery to the leader at step `k` of a message `body` in `sender`'s name that it never
/// sent (message sequence number `seq`), on a packet numbered `packet_seq` carrying `state`.
pub fn forged_to_leader(
    k: u64,
    sender: u16,
    state: State,
    (packet_seq, seq): (u32, u16),
    body: Body,
) -> Delivery {
    let sender = VehicleId(sender);
    Delivery {
        receiver: VehicleId::LEADER,
        packet: Packet {
            maneuver: Some(Message {
                sender,
                to: VehicleId::LEADER,
                seq,
                body,
            }),
            ..Packet::beacon(sender, packet_seq, k, state)
        },
    }
}

/// Asserts that the ground truth labels every delivery it did not find genuine `altered` in
/// its maneuver field, a `body` in `sender`'s name, and that there are some.
pub fn altered_only(log: &Log, sender: u16, body: Body) {
    let altered: Vec<_> = log
        .labelled
        .iter()
        .filter(|(_, l)| *l != Label::Genuine)
        .collect();
    assert!(!altered.is_empty());
    for (m, l) in altered {
        assert_eq!((m.sender, m.body), (VehicleId(sender), body));
        assert!(
            matches!(l, Label::Altered { fields } if fields.contains(Fields::MANEUVER)),
            "{l:?}"
        );
    }
}
