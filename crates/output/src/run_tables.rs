//! The per-step tables of a run ([`RunFiles`]): trajectories, events, wire, the channel log and
//! the detections, written step by step into a run directory or kept in memory as Arrow record
//! batches, and read back from a finished run directory ([`read_tables`]).
use crate::error::Result;
use crate::rundir::RunDir;
use crate::tables::{Format, Table};
use arrow_array::RecordBatch;
use arrow_schema::SchemaRef;
use platoon_attacks::channel::ChannelEvent;
use platoon_config::OutputFile;
use platoon_sim::detection::Scored;
use platoon_sim::truth::Label;
use platoon_sim::{Scenario, StepRow, StepWire};
use std::path::Path;

/// The files of a run directory's per-step data: trajectories (every `decimate`-th step),
/// events (broadcasts and mode switches), wire (vehicles whose links were not all delivered as
/// sent), the channel log (in process) and the detections, as CSV or Parquet; keeps platoon 0's
/// rows for the plots (memory stays bounded for large fleets).
pub struct RunFiles {
    trajectories: Table<StepRow>,
    events: Table<EventRow>,
    wire: Table<WireRow>,
    channel: Option<Table<ChannelEvent>>,
    detections: Table<DetectionRow>,
    decimate: u64,
    last: Vec<Option<u64>>,
    modes: Vec<platoon_control::Status>,
    per_platoon: usize,
    dt: f64,
    rows: Vec<StepRow>,
    /// Keep platoon 0's rows for the plots (not when the tables are kept in memory).
    keep_rows: bool,
    /// The detection events of the step, written after its rows' own: (vehicle's index in the
    /// fleet, event).
    pending: Vec<(usize, Event)>,
    /// The (vehicle, sender) pairs whose packets the reaction refuses (as last seen).
    refusing: std::collections::BTreeSet<(usize, u16)>,
    /// Platoon 0's detector flags (follower, t), for modes.png.
    flags: Vec<(u16, f64)>,
    /// Per vehicle: the intrusion its radar sees, if any.
    intrusions: Vec<Option<Intrusion>>,
    /// Per vehicle: an intrusion began since it last ran its law (for `rejoined`).
    intruded: Vec<bool>,
    /// Per vehicle: the authority revoked it (`revoked` once).
    revoked: Vec<bool>,
    /// Per vehicle: its gap to the vehicle ahead in the platoon at the step before (m).
    gaps: Vec<f64>,
    /// Per vehicle: whom it took as its leader at the step before (runs that split).
    heads: Vec<u16>,
    /// Each vehicle's length (m), leader first.
    lengths: Vec<f64>,
    /// The run has traffic that can touch the platoon: the trajectories and the detections
    /// have the radar's columns ([`StepRow::RADAR_COLUMNS`]).
    radar: bool,
    /// With `radar`, the step's detections, written once its rows say what each receiver's
    /// radar saw.
    waiting: Vec<DetectionRow>,
}

/// A vehicle in front of a follower that is not its predecessor, as the plant's radar sees it.
#[derive(Debug, Clone, Copy)]
struct Intrusion {
    /// The follower's gap to its predecessor at the step before it appeared (m).
    before: f64,
    /// The gap to it has been at least `before` since.
    opened: bool,
}

/// Where [`RunFiles`] keeps its tables.
enum Place<'a> {
    Dir(&'a RunDir, Format),
    Memory,
}

impl Place<'_> {
    fn table<T: serde::Serialize + serde::de::DeserializeOwned>(
        &self,
        stem: &str,
        enabled: bool,
    ) -> Result<Table<T>> {
        self.table_without(stem, enabled, &[])
    }

    /// A table without the columns `absent` (see [`Table::create_without`]).
    fn table_without<T: serde::Serialize + serde::de::DeserializeOwned>(
        &self,
        stem: &str,
        enabled: bool,
        absent: &[&str],
    ) -> Result<Table<T>> {
        match self {
            Place::Dir(dir, format) => Table::create_without(dir, stem, *format, enabled, absent),
            Place::Memory => Table::memory_without(stem, enabled, absent),
        }
    }
}

/// A run's per-step tables as Arrow record batches, each by name (`trajectories`, `events`,
/// `wire`, `channel`, `detections`: the files' stems) with its schema, the Parquet files'.
pub type Tables = Vec<(&'static str, SchemaRef, Vec<RecordBatch>)>;

/// The per-step tables of a finished run directory (CSV or Parquet, whichever it wrote), as
/// `platoon_app::run::simulate_in_memory` returns them.
pub fn read_tables(dir: &Path) -> Result<Tables> {
    fn read<T: serde::Serialize + serde::de::DeserializeOwned>(
        dir: &Path,
        stem: &'static str,
        tables: &mut Tables,
    ) -> Result<()> {
        for ext in ["csv", "parquet"] {
            let path = dir.join(format!("{stem}.{ext}"));
            if path.exists() {
                // The radar's columns are there in runs with traffic only, the head's in runs
                // that split, the key columns of the detections in signed runs.
                let mut optional = StepRow::OPTIONAL_COLUMNS.to_vec();
                optional.extend(DetectionRow::KEY_COLUMNS);
                let (schema, batches) = crate::tables::read_batches::<T>(&path, &optional)?;
                tables.push((stem, schema, batches));
                break;
            }
        }
        Ok(())
    }
    let mut tables = Tables::new();
    read::<StepRow>(dir, "trajectories", &mut tables)?;
    read::<EventRow>(dir, "events", &mut tables)?;
    read::<WireRow>(dir, "wire", &mut tables)?;
    read::<ChannelEvent>(dir, "channel", &mut tables)?;
    read::<DetectionRow>(dir, "detections", &mut tables)?;
    Ok(tables)
}

/// One row of wire.csv: a vehicle's link packets in a step where not everything sent to it was
/// delivered as sent.
#[derive(serde::Serialize, serde::Deserialize)]
struct WireRow {
    step: u64,
    t: f64,
    platoon: u16,
    vehicle: u16,
    sent: u64,
    delivered_as_sent: u64,
    altered: u64,
    dropped: u64,
    injected: u64,
    jammed: u64,
}

/// One row of detections.csv: a delivery the injector made (to any receiver, the leader
/// included, accepted or refused), what it claimed, the truth, what refused it, and each
/// built-in detector's verdict (empty when that detector is off or did not see the packet, and
/// on the leader's rows).
#[derive(serde::Serialize, serde::Deserialize)]
struct DetectionRow {
    /// The step it was received (and inspected) at.
    step: u64,
    t: f64,
    platoon: u16,
    receiver: u16,
    /// The claimed sender.
    sender: u16,
    seq: u32,
    /// The step it claims to have been sampled at.
    sampled_step: u64,
    claimed_p: f64,
    claimed_v: f64,
    claimed_a: f64,
    /// The claimed sender's true state at `sampled_step` (empty if unknown).
    true_p: Option<f64>,
    true_v: Option<f64>,
    true_a: Option<f64>,
    /// `platoon_sim::truth::Label`'s name: genuine, altered, lied, delayed, replayed, forged.
    label: String,
    /// `altered`: the fields changed from the broadcast; `lied`: those false; `+`-separated
    /// (`p`, `v`, `a`, `u`, `step`, `head`, `maneuver`), empty for the other labels.
    fields: String,
    /// The kind of the maneuver message it carries (`leave_notice`, ...), empty for none.
    maneuver: String,
    /// A detector (or, receiver 0, the leader's check of maneuver messages) tested it.
    inspected: bool,
    /// What refused it: a packet check (`stale_seq`, ... as in `rejected_packets`), the
    /// detectors' `reaction` or the leader's `check_reports`; empty when accepted.
    refused_by: Option<String>,
    /// Signed runs (`[security]`) only: the vehicle whose key made its signature, empty if
    /// none of the platoon's did (no seal, another PKI's key, altered after signing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    signed_by: Option<String>,
    /// Signed runs only: whom the attacker of a misbehaving delivery acted as (`outsider`,
    /// `insider`, `thief`; `platoon_sim::detection::KeyUse`), empty for a genuine one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    acts_as: Option<String>,
    /// Any detector flagged it.
    flagged: bool,
    /// The reaction refused it.
    refused: bool,
    plausibility_flagged: Option<bool>,
    plausibility_score: Option<f64>,
    radar_cross_flagged: Option<bool>,
    radar_cross_score: Option<f64>,
    residual_flagged: Option<bool>,
    residual_score: Option<f64>,
    /// Runs with traffic that can touch the platoon: who the receiver's radar had in front of
    /// it at the step (as in the trajectories, [`StepRow::radar_target`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radar_target: Option<platoon_sim::traffic::RadarTarget>,
    /// The gap to it (m; NaN: nothing seen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radar_gap_m: Option<f64>,
    /// Its relative speed `v - v_ahead` (m/s; NaN: nothing seen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radar_closing_mps: Option<f64>,
}

/// One row per broadcast of a follower, one per change of its mode, with traffic one per step
/// of an intrusion's course, and with `[detection]` one per packet its detectors flagged and one
/// when its reaction begins or ends refusing a sender.
#[derive(serde::Serialize, serde::Deserialize)]
struct EventRow {
    platoon: u16,
    vehicle: u16,
    step: u64,
    t: f64,
    /// `broadcast`, `switch` (the vehicle's mode changed at this step), `intruder_in`,
    /// `gap_opened`, `intruder_out`, `rejoined`, `split`, `merged`, `flagged`, `distrust`,
    /// `trust`, `joined`, `left` or `revoked` (the misbehaviour authority revoked its
    /// certificates).
    event: Event,
    /// The mode it is in (after the switch).
    mode: platoon_control::Status,
    /// Broadcasts: the time since its previous broadcast.
    inter_event_s: Option<f64>,
    under_attack: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
enum Event {
    Broadcast,
    Switch,
    /// The radar's nearest vehicle ahead became one that is not the predecessor (a cut-in), as
    /// the plant sees it.
    IntruderIn,
    /// The gap to that vehicle reached the gap the follower had to its predecessor at the step
    /// before it appeared.
    GapOpened,
    /// The radar's nearest vehicle ahead is the predecessor again.
    IntruderOut,
    /// Back on its law (mode `coop`) after an intrusion.
    Rejoined,
    /// It took a member ahead as its leader: the platoon split ahead of it, behind a car that
    /// cut in (the trajectories' `head` says which member).
    Split,
    /// It took the platoon's leader as its leader again.
    Merged,
    /// A detector flagged a packet the vehicle received (`[detection]`).
    Flagged,
    /// Its reaction began refusing a sender's packets (the first refused after an accepted
    /// one).
    Distrust,
    /// It accepted a packet of a sender it had been refusing.
    Trust,
    /// A joiner took the platoon's law: the leader admitted it (`[maneuvers]`; its mode left
    /// `outside`).
    Joined,
    /// A member left the platoon and its lane (`[maneuvers]`; mode `left`).
    Left,
    /// The misbehaviour authority revoked the vehicle's certificates (`[security.reports]`):
    /// every receiver refuses its packets from then on.
    Revoked,
}

impl From<Vec<StepRow>> for Plotted {
    fn from(rows: Vec<StepRow>) -> Self {
        Self {
            rows,
            flags: Vec::new(),
        }
    }
}

impl RunFiles {
    /// Opens the tables `output` asks for in `dir`; `channel` (in process) also opens the
    /// channel log (a co-simulation's injector writes its own). With `[detection]`, the
    /// detections (the per-message dataset) too. `radar`: the run has traffic that can touch
    /// the platoon (scripted cut-ins, SUMO's background traffic on its lanes), and the
    /// trajectories and the detections say what each radar saw (three columns more,
    /// [`StepRow::RADAR_COLUMNS`]); without, the tables are as they were before those columns.
    pub fn create(
        scenario: &Scenario,
        output: &platoon_config::OutputConfig,
        dir: &RunDir,
        channel: bool,
        radar: bool,
    ) -> Result<Self> {
        Self::open(
            scenario,
            output,
            Place::Dir(dir, Format::of(output, scenario)),
            channel,
            radar,
        )
    }

    /// The same tables kept in memory as Arrow record batches ([`RunFiles::into_tables`]),
    /// the channel log included; no file is written. In process the traffic is the scripted
    /// cut-ins: with any, the radar's columns are there.
    pub fn in_memory(scenario: &Scenario, output: &platoon_config::OutputConfig) -> Result<Self> {
        Self::open(
            scenario,
            output,
            Place::Memory,
            true,
            !scenario.cut_ins.is_empty(),
        )
    }

    fn open(
        scenario: &Scenario,
        output: &platoon_config::OutputConfig,
        place: Place<'_>,
        channel: bool,
        radar: bool,
    ) -> Result<Self> {
        let steps = scenario.steps + 1;
        let on = |f: OutputFile| output.writes(f);
        let absent: &[&str] = if radar { &[] } else { &StepRow::RADAR_COLUMNS };
        // Whom each vehicle took as its leader: in runs that split only.
        let mut absent_rows = absent.to_vec();
        if !scenario.splits() {
            absent_rows.push(StepRow::HEAD_COLUMN);
        }
        // Each vehicle's lane: in runs where vehicles change lanes only.
        if !scenario.changes_lanes() {
            absent_rows.push(StepRow::LANE_COLUMN);
        }
        Ok(Self {
            trajectories: place.table_without(
                "trajectories",
                on(OutputFile::Trajectories),
                &absent_rows,
            )?,
            events: place.table("events", on(OutputFile::Events))?,
            wire: place.table("wire", on(OutputFile::Wire))?,
            channel: channel
                .then(|| place.table("channel", on(OutputFile::Channel)))
                .transpose()?,
            detections: place.table_without(
                "detections",
                scenario.control.detection.is_measured() && on(OutputFile::Detections),
                &DetectionRow::absent(absent, scenario.control.security.is_some()),
            )?,
            decimate: output.decimate,
            last: vec![None; scenario.vehicles()],
            modes: vec![platoon_control::Status::default(); scenario.vehicles()],
            per_platoon: scenario.vehicles_per_platoon(),
            dt: scenario.dt(),
            // Platoon 0's rows for the plots; grown as needed past a million steps.
            rows: match place {
                Place::Dir(..) => Vec::with_capacity(
                    steps.min(1 << 20) as usize * scenario.vehicles_per_platoon(),
                ),
                Place::Memory => Vec::new(),
            },
            keep_rows: matches!(place, Place::Dir(..)),
            pending: Vec::new(),
            refusing: Default::default(),
            flags: Vec::new(),
            intrusions: vec![None; scenario.vehicles()],
            intruded: vec![false; scenario.vehicles()],
            revoked: vec![false; scenario.vehicles()],
            heads: vec![0; scenario.vehicles()],
            gaps: vec![f64::NAN; scenario.vehicles()],
            lengths: scenario.lengths(),
            radar,
            waiting: Vec::new(),
        })
    }

    /// The tables of [`RunFiles::in_memory`] after the run (its sink's `finish`), by name; a
    /// table `[output] files` leaves out is not there.
    pub fn into_tables(mut self) -> Result<Tables> {
        let mut tables = Tables::new();
        let mut take = |name: &'static str, got: Option<(SchemaRef, Vec<RecordBatch>)>| {
            if let Some((schema, batches)) = got {
                tables.push((name, schema, batches));
            }
        };
        take("trajectories", self.trajectories.take_batches()?);
        take("events", self.events.take_batches()?);
        take("wire", self.wire.take_batches()?);
        if let Some(channel) = &mut self.channel {
            take("channel", channel.take_batches()?);
        }
        take("detections", self.detections.take_batches()?);
        Ok(tables)
    }

    /// Platoon 0's rows so far.
    pub fn into_rows(self) -> Vec<StepRow> {
        self.rows
    }

    /// Platoon 0's rows and detector flags (follower, t) so far, for the plots.
    pub fn into_plotted(self) -> Plotted {
        Plotted {
            rows: self.rows,
            flags: self.flags,
        }
    }
}

impl RunFiles {
    /// One step: every platoon's rows (platoon by platoon, leader first) and what happened on
    /// the wire.
    pub fn step(&mut self, step: &[StepRow], wire: StepWire<'_>) -> Result<()> {
        if self.keep_rows {
            self.rows.extend(step.iter().take_while(|r| r.platoon == 0));
        }
        let k = step[0].step;
        for (i, counts) in wire.per_vehicle.iter().enumerate() {
            if counts.is_eventful() {
                self.wire.write(WireRow {
                    step: k,
                    t: step[0].t,
                    platoon: (i / self.per_platoon) as u16,
                    vehicle: (i % self.per_platoon) as u16,
                    sent: counts.sent,
                    delivered_as_sent: counts.delivered_as_sent,
                    altered: counts.altered,
                    dropped: counts.dropped,
                    injected: counts.injected,
                    jammed: counts.jammed,
                })?;
            }
        }
        // The step's detections, with what each receiver's radar saw.
        for mut d in self.waiting.drain(..) {
            let seen = step
                .get(usize::from(d.platoon) * self.per_platoon + usize::from(d.receiver))
                .filter(|r| (r.platoon, r.vehicle) == (d.platoon, d.receiver) && r.step == d.step)
                .map(|r| r.with_radar_columns(true));
            d.radar_target = Some(seen.and_then(|r| r.radar_target).unwrap_or_default());
            d.radar_gap_m = Some(seen.and_then(|r| r.radar_gap_m).unwrap_or(f64::NAN));
            d.radar_closing_mps = Some(seen.and_then(|r| r.radar_closing_mps).unwrap_or(f64::NAN));
            self.detections.write(d)?;
        }
        let keep = k.is_multiple_of(self.decimate);
        // Each vehicle's in the order they happened (a stable sort).
        self.pending.sort_by_key(|(v, _)| *v);
        let mut next = 0;
        let mut ahead_p = f64::NAN;
        for r in step {
            if keep {
                self.trajectories.write(r.with_radar_columns(self.radar))?;
            }
            let p_ahead = std::mem::replace(&mut ahead_p, r.p);
            if r.vehicle == 0 {
                continue;
            }
            let v = usize::from(r.platoon) * self.per_platoon + usize::from(r.vehicle);
            let row = |event, inter_event_s| EventRow {
                platoon: r.platoon,
                vehicle: r.vehicle,
                step: r.step,
                t: r.t,
                event,
                mode: r.mode,
                inter_event_s,
                under_attack: r.under_attack,
            };
            // Only traffic that can touch the platoon brings intruders.
            let intrusion = if self.radar {
                self.intrusion(v, r, p_ahead)
            } else {
                None
            };
            if intrusion == Some(Event::IntruderIn) {
                self.events.write(row(Event::IntruderIn, None))?;
            }
            if r.revoked && !std::mem::replace(&mut self.revoked[v], true) {
                self.events.write(row(Event::Revoked, None))?;
            }
            if r.mode != self.modes[v] {
                let was = std::mem::replace(&mut self.modes[v], r.mode);
                self.events.write(row(Event::Switch, None))?;
                let outside = |s: platoon_control::Status| {
                    matches!(
                        s.role(),
                        platoon_control::Role::Outside | platoon_control::Role::Beside
                    )
                };
                if outside(was) && !outside(r.mode) {
                    self.events.write(row(Event::Joined, None))?;
                }
                if r.mode == platoon_control::Role::Left {
                    self.events.write(row(Event::Left, None))?;
                }
                if r.mode == platoon_control::Mode::Coop && std::mem::take(&mut self.intruded[v]) {
                    self.events.write(row(Event::Rejoined, None))?;
                }
            }
            if let Some(head) = r.head {
                if std::mem::replace(&mut self.heads[v], head) != head {
                    let e = if head == 0 {
                        Event::Merged
                    } else {
                        Event::Split
                    };
                    self.events.write(row(e, None))?;
                }
            }
            if let Some(e @ (Event::GapOpened | Event::IntruderOut)) = intrusion {
                self.events.write(row(e, None))?;
            }
            if r.triggered {
                let prev = &mut self.last[v];
                let inter = prev.map(|p| (r.step - p) as f64 * self.dt);
                self.events.write(row(Event::Broadcast, inter))?;
                *prev = Some(r.step);
            }
            // The step's detection events come sorted by vehicle (below), as the rows do.
            while let Some(&(_, e)) = self.pending.get(next).filter(|(x, _)| *x == v) {
                self.events.write(row(e, None))?;
                next += 1;
            }
        }
        self.pending.clear();
        Ok(())
    }

    /// Follows vehicle `v`'s intrusion through its row `r` (`p_ahead`: the position of the
    /// platoon member ahead of it, whose length its gap counts): the event of this step, if any.
    fn intrusion(&mut self, v: usize, r: &StepRow, p_ahead: f64) -> Option<Event> {
        let gap = p_ahead - r.p - self.lengths[usize::from(r.vehicle) - 1];
        // A car there from the first step: the gap to the predecessor at that step.
        let before = match std::mem::replace(&mut self.gaps[v], gap) {
            b if b.is_nan() => gap,
            b => b,
        };
        match (&mut self.intrusions[v], r.intruder) {
            (None, Some(_)) => {
                self.intrusions[v] = Some(Intrusion {
                    before,
                    opened: false,
                });
                self.intruded[v] = true;
                Some(Event::IntruderIn)
            }
            (Some(i), Some(t)) if !i.opened && t.gap >= i.before => {
                i.opened = true;
                Some(Event::GapOpened)
            }
            (Some(_), None) => {
                self.intrusions[v] = None;
                // It rejoins only if it left its law for the car (or an attack meanwhile).
                if r.mode == platoon_control::Mode::Coop && self.modes[v] == r.mode {
                    self.intruded[v] = false;
                }
                Some(Event::IntruderOut)
            }
            _ => None,
        }
    }

    /// What the built-in channel did not deliver as sent, as it happened.
    pub fn channel(&mut self, event: &ChannelEvent) -> Result<()> {
        match &mut self.channel {
            Some(t) => t.write(*event),
            None => Ok(()),
        }
    }

    /// The packets the detectors inspected in the step, with their ground truth (before the
    /// step's rows); `names` are the detectors, in the order of each packet's verdicts.
    pub fn detections(&mut self, names: &[&str], scored: &[Scored]) -> Result<()> {
        for s in scored {
            if let Some(i) = &s.inspection {
                self.events_of(s.platoon, i);
            }
            let row = detection_row(names, s, self.dt);
            if self.radar {
                // Written with the step's rows, which say what the radars saw.
                self.waiting.push(row);
            } else {
                self.detections.write(row)?;
            }
        }
        Ok(())
    }

    /// The events of a follower's inspection (a packet to the leader or to no vehicle has
    /// none): a flag, and a reaction that begins or ends refusing a sender.
    fn events_of(&mut self, platoon: u16, i: &platoon_control::Inspection) {
        if !(1..self.per_platoon).contains(&usize::from(i.receiver.0)) {
            return;
        }
        let v = usize::from(platoon) * self.per_platoon + usize::from(i.receiver.0);
        if i.flagged {
            self.pending.push((v, Event::Flagged));
            if platoon == 0 {
                self.flags.push((i.receiver.0, i.k as f64 * self.dt));
            }
        }
        let key = (v, i.sender.0);
        if i.refused && self.refusing.insert(key) {
            self.pending.push((v, Event::Distrust));
        } else if !i.refused && self.refusing.remove(&key) {
            self.pending.push((v, Event::Trust));
        }
    }

    /// After the last step.
    pub fn finish(&mut self) -> Result<()> {
        // Detections of a step whose rows never came (a run that ended in between).
        for mut d in self.waiting.drain(..) {
            d.radar_target = Some(Default::default());
            d.radar_gap_m = Some(f64::NAN);
            d.radar_closing_mps = Some(f64::NAN);
            self.detections.write(d)?;
        }
        self.trajectories.finish()?;
        self.events.finish()?;
        self.wire.finish()?;
        self.detections.finish()?;
        if let Some(t) = &mut self.channel {
            t.finish()?;
        }
        Ok(())
    }
}

/// The dataset's row of one delivery (`names`: the detectors, in the order of each
/// inspection's verdicts; `dt` the step).
fn detection_row(names: &[&str], s: &Scored, dt: f64) -> DetectionRow {
    let i = s.inspection.as_ref();
    // The leader's checks of maneuver messages are no detector's: their columns empty.
    let verdict = |name: &str| {
        let i = i.filter(|i| !i.receiver.is_leader())?;
        let d = names.iter().position(|n| *n == name)?;
        i.verdicts().get(d).copied()
    };
    let flagged = |name: &str| verdict(name).map(|v| v.flagged);
    // NaN: the detector had nothing to test (no radar reading, no earlier packet).
    let score = |name: &str| verdict(name).map(|v| v.score).filter(|x| !x.is_nan());
    let p = &s.delivery.packet;
    let fields = match s.label {
        Label::Altered { fields } | Label::Lied { fields } => fields.names().join("+"),
        _ => String::new(),
    };
    DetectionRow {
        step: s.step,
        t: s.step as f64 * dt,
        platoon: s.platoon,
        receiver: s.delivery.receiver.0,
        sender: p.sender.0,
        seq: p.seq,
        sampled_step: p.step,
        claimed_p: p.state[0],
        claimed_v: p.state[1],
        claimed_a: p.state[2],
        true_p: s.truth.map(|x| x[0]),
        true_v: s.truth.map(|x| x[1]),
        true_a: s.truth.map(|x| x[2]),
        label: s.label.name().to_string(),
        fields,
        maneuver: p
            .maneuver
            .map_or_else(String::new, |m| m.body.kind().name().to_string()),
        inspected: i.is_some(),
        refused_by: s.refused_by.map(|r| r.name().to_string()),
        signed_by: s
            .key
            .map(|k| k.signed_by.map_or_else(String::new, |v| v.0.to_string())),
        acts_as: s.key.map(|k| k.acts_as.unwrap_or_default().to_string()),
        flagged: i.is_some_and(|i| i.flagged),
        refused: i.is_some_and(|i| i.refused),
        plausibility_flagged: flagged("plausibility"),
        plausibility_score: score("plausibility"),
        radar_cross_flagged: flagged("radar_cross"),
        radar_cross_score: score("radar_cross"),
        residual_flagged: flagged("residual"),
        residual_score: score("residual"),
        radar_target: None,
        radar_gap_m: None,
        radar_closing_mps: None,
    }
}

impl DetectionRow {
    /// The key columns, in signed runs only.
    const KEY_COLUMNS: [&'static str; 2] = ["signed_by", "acts_as"];

    /// The columns a run's detections leave out: `absent` (the radar's, without traffic) and,
    /// unless `signed`, the key columns.
    fn absent<'a>(absent: &[&'a str], signed: bool) -> Vec<&'a str> {
        let mut all = absent.to_vec();
        if !signed {
            all.extend(Self::KEY_COLUMNS);
        }
        all
    }
}

/// Platoon 0's rows and detector flags, as the plots draw them.
#[derive(Debug, Clone, Default)]
pub struct Plotted {
    /// Platoon 0's rows.
    pub rows: Vec<StepRow>,
    /// Platoon 0's detector flags: (follower, t), one per flagged packet.
    pub flags: Vec<(u16, f64)>,
}
