//! The misbehaviour detectors measured against ground truth: every packet a follower's
//! detectors inspected (`Controller::inspections`) joined with what truly happened to it
//! ([`crate::truth`]), per detector and per label: true and false positives and negatives,
//! precision, recall, F1, the false-alarm rate on genuine traffic and the time to detect.
//! Whoever holds the controllers records (the in-process runner, the iceoryx2 controller
//! node), with this same code, so both give the same figures.
use crate::truth::{Label, Labelled, TruthLabeler};
use platoon_control::{Delivery, Inspection, Packet};
use platoon_model::{State, VehicleId};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A confusion matrix: a flag on a packet that is not genuine is a true positive.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Confusion {
    /// Misbehaving packets flagged.
    pub tp: u64,
    /// Genuine packets flagged.
    pub fp: u64,
    /// Genuine packets not flagged.
    pub tn: u64,
    /// Misbehaving packets not flagged.
    #[serde(rename = "fn")]
    pub fn_: u64,
}

impl Confusion {
    fn add(&mut self, misbehaving: bool, flagged: bool) {
        match (misbehaving, flagged) {
            (true, true) => self.tp += 1,
            (true, false) => self.fn_ += 1,
            (false, true) => self.fp += 1,
            (false, false) => self.tn += 1,
        }
    }

    /// `tp / (tp + fp)`; `None` without a flag.
    pub fn precision(&self) -> Option<f64> {
        ratio(self.tp, self.tp + self.fp)
    }

    /// `tp / (tp + fn)`; `None` without a misbehaving packet.
    pub fn recall(&self) -> Option<f64> {
        ratio(self.tp, self.tp + self.fn_)
    }

    /// The harmonic mean of precision and recall, `2 tp / (2 tp + fp + fn)`: defined whenever
    /// there was a misbehaving packet (0 when none was flagged); `None` without one.
    pub fn f1(&self) -> Option<f64> {
        (self.tp + self.fn_ > 0)
            .then(|| 2.0 * self.tp as f64 / (2 * self.tp + self.fp + self.fn_) as f64)
    }

    /// `fp / (fp + tn)`: flags on genuine packets; `None` without one.
    pub fn false_alarm_rate(&self) -> Option<f64> {
        ratio(self.fp, self.fp + self.tn)
    }
}

fn ratio(a: u64, b: u64) -> Option<f64> {
    (b > 0).then(|| a as f64 / b as f64)
}

/// One detector over a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectorScore {
    /// Its name (`residual`, ...).
    pub name: String,
    /// Over every inspected packet.
    pub totals: Confusion,
    /// Per ground-truth label of the inspected packets (`genuine`, `altered`, ...).
    pub by_label: BTreeMap<String, Confusion>,
    /// Precision, recall, F1 and false-alarm rate of `totals` (absent when undefined).
    pub precision: Option<f64>,
    /// See `precision`.
    pub recall: Option<f64>,
    /// See `precision`.
    pub f1: Option<f64>,
    /// See `precision`.
    pub false_alarm_rate: Option<f64>,
    /// From the first misbehaving packet inspected to this detector's first flag on one (s);
    /// absent when there was none or it never flagged one.
    pub time_to_detect_s: Option<f64>,
}

/// `summary.json`'s `detection` (runs with `[detection]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectionSummary {
    /// The reaction to a flag (`log`, `drop`, `fallback`).
    pub reaction: String,
    /// Packets the detectors inspected, flagged (any detector) and the reaction refused.
    pub inspected: u64,
    /// See `inspected`.
    pub flagged: u64,
    /// See `inspected`.
    pub refused: u64,
    /// Inspected packets by ground-truth label.
    pub labels: BTreeMap<String, u64>,
    /// Each detector, in the order of `[detection]`.
    pub detectors: Vec<DetectorScore>,
    /// Any detector (what the reaction acts on).
    pub any: DetectorScore,
    /// The leader's checks of maneuver messages (`[maneuvers] check_reports`: requests from
    /// vehicles it never heard, in-position reports its beacons contradict), over the messages
    /// they tested; not among `inspected` and `any`, which are the followers' detectors'.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maneuver_checks: Option<DetectorScore>,
    /// Signed runs: every vehicle whose key signed a lie that was delivered (altered, forged
    /// or false content whose signature holds under its key: an insider's own, or a thief's
    /// with its stolen key), with the first step one was; ground truth for the misbehaviour
    /// authority's revocations. Empty (and absent) otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub signed_lies: Vec<SignedLie>,
}

/// A vehicle whose key signed a delivered lie ([`DetectionSummary::signed_lies`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignedLie {
    /// The vehicle (0 = the leader).
    pub vehicle: u16,
    /// The first step a lie its key signed was delivered.
    pub first_step: u64,
}

/// One delivery with its ground truth and what became of it: a row of the per-message dataset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// The platoon.
    pub platoon: u16,
    /// The step it was delivered at.
    pub step: u64,
    /// The delivery: its receiver and the packet as delivered.
    pub delivery: Delivery,
    /// What the detectors (or, receiver 0, the leader's check of maneuver messages) said of it
    /// and what became of it; `None` when none of them tested it (refused by the packet
    /// checks before them, a beacon to the leader, or a controller that did not say).
    pub inspection: Option<Inspection>,
    /// What refused it (`None`: accepted, or the controller did not say).
    pub refused_by: Option<platoon_control::RefusedBy>,
    /// What truly happened to it.
    pub label: Label,
    /// The claimed sender's true state at the packet's sampling step (if known).
    pub truth: Option<State>,
    /// In a signed run (`[security]`), whose key made its signature, told from its seal
    /// ([`KeyUse::of`]); `None` in an unsigned run.
    pub key: Option<KeyUse>,
}

/// Whose key signed a delivery and whom its attacker acted as, told from the seal it
/// carries: the ground truth of issue 52's attacker model, measured on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyUse {
    /// The vehicle of the platoon whose pseudonym made the packet's signature, if the
    /// signature holds under one (`None`: no seal, a key of another PKI, or a packet altered
    /// after signing).
    pub signed_by: Option<VehicleId>,
    /// For a misbehaving delivery, whom its attacker acted as: `outsider` (the signature holds
    /// under no key of the platoon, or it does under the sender's own and the content is as
    /// the sender signed it: a replay, a delay), `insider` (altered, forged or false, and
    /// signed with the claimed sender's own key), `thief` (signed with another member's key);
    /// `None` for a genuine delivery.
    pub acts_as: Option<&'static str>,
}

impl KeyUse {
    /// Whose key signed `packet`, delivered at step `k`, by `keys`.
    pub fn signer(
        keys: &mut platoon_security::Keyring,
        k: u64,
        packet: &Packet,
    ) -> Option<VehicleId> {
        let header = platoon_security::SecurityHeader::decode(packet.seal?.as_bytes()).ok()?;
        // At most one pseudonym change a step: its epoch is among the first k + 1.
        let slot = keys.signed_by(&packet.signed_bytes(), &header, k as usize + 1)?;
        Some(VehicleId(slot.vehicle as u16))
    }

    /// The key use of `d`, signed by `signed_by` ([`KeyUse::signer`]), with ground truth
    /// `label`.
    pub fn of(signed_by: Option<VehicleId>, d: &Delivery, label: Label) -> Self {
        let changed = matches!(
            label,
            Label::Altered { .. } | Label::Forged | Label::Lied { .. }
        );
        let acts_as = match signed_by {
            _ if !label.is_misbehaviour() => None,
            Some(v) if v != d.packet.sender => Some("thief"),
            Some(_) if changed => Some("insider"),
            _ => Some("outsider"),
        };
        Self { signed_by, acts_as }
    }
}

/// Whether inspection `i` is of delivery `r`: its link, sequence number, step and claimed state.
fn of(r: &Scored, i: &Inspection) -> bool {
    let p = &r.delivery.packet;
    r.delivery.receiver == i.receiver
        && p.sender == i.sender
        && p.seq == i.seq
        && p.step == i.step
        && p.state
            .iter()
            .zip(i.state.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

/// One detector's (or check's) figures so far: its confusion, per label, and the step of its
/// first flag on a misbehaving packet.
#[derive(Debug, Clone, Default)]
struct Tally(Confusion, BTreeMap<&'static str, Confusion>, Option<u64>);

impl Tally {
    fn add(&mut self, k: u64, label: &'static str, bad: bool, flagged: bool) {
        self.0.add(bad, flagged);
        self.1.entry(label).or_default().add(bad, flagged);
        if bad && flagged && self.2.is_none() {
            self.2 = Some(k);
        }
    }
}

/// Records one platoon's detection, step by step.
#[derive(Debug, Clone)]
pub struct DetectionRecorder {
    platoon: u16,
    dt: f64,
    labeler: TruthLabeler,
    labelled: Vec<Labelled>,
    names: Vec<String>,
    reaction: &'static str,
    counts: platoon_control::screening::ScreenCounts,
    per: Vec<Tally>,
    any: Tally,
    first_bad: Option<u64>,
    /// The leader's checks, and their first misbehaving message (`None` before one).
    leader: Option<Tally>,
    leader_first_bad: Option<u64>,
    labels: BTreeMap<&'static str, u64>,
    scored: Vec<Scored>,
    /// A signed run's keys, to tell whose key signed each delivery.
    keys: Option<platoon_security::Keyring>,
    /// Per vehicle whose key signed a delivered lie: the first step one was.
    signed_lies: BTreeMap<u16, u64>,
}

impl DetectionRecorder {
    /// For platoon `platoon` whose controller runs the detectors `names` (in process its
    /// `detector_names()`; in a co-simulation the config's, `DetectionParams::names`) with
    /// `reaction`; `dt` the step.
    pub fn new(
        platoon: u16,
        names: &[impl AsRef<str>],
        reaction: platoon_control::Reaction,
        dt: f64,
    ) -> Self {
        Self {
            platoon,
            dt,
            labeler: TruthLabeler::for_seconds(10.0, dt),
            labelled: Vec::new(),
            names: names.iter().map(|n| n.as_ref().to_string()).collect(),
            reaction: reaction.name(),
            counts: Default::default(),
            per: vec![Default::default(); names.len()],
            any: Default::default(),
            first_bad: None,
            leader: None,
            leader_first_bad: None,
            labels: BTreeMap::new(),
            scored: Vec::new(),
            keys: None,
            signed_lies: BTreeMap::new(),
        }
    }

    /// In a signed run (`security`: its `[security]`, for this platoon), every scored
    /// delivery says whose key signed it ([`Scored::key`]); `vehicles` the platoon's.
    pub fn signed(
        mut self,
        security: Option<&platoon_control::security::SecurityParams>,
        vehicles: usize,
    ) -> Self {
        self.keys = security.map(|s| s.keyring(vehicles));
        self
    }

    /// Step `k`: the true `states`, the step's `links` (broadcasts as (receiver, packet)), what
    /// was delivered and what the controller's detectors said of it (its
    /// `Controller::inspections`, or what a controller process reported on the wire). The
    /// scored packets of the step are then [`DetectionRecorder::scored`].
    pub fn record(
        &mut self,
        k: u64,
        states: &[State],
        links: impl Iterator<Item = (VehicleId, Packet)>,
        deliveries: &[Delivery],
        inspections: &[Inspection],
    ) {
        self.labelled.clear();
        self.labeler
            .label(k, states, links, deliveries, &mut self.labelled);
        self.scored.clear();
        self.scored.extend(self.labelled.iter().map(|l| Scored {
            platoon: self.platoon,
            step: l.step,
            delivery: l.delivery,
            inspection: None,
            refused_by: None,
            label: l.label,
            truth: l.truth,
            key: None,
        }));
        if let Some(keys) = &mut self.keys {
            // The receivers of one broadcast share its signature check.
            let mut checked: Vec<(Packet, Option<VehicleId>)> = Vec::new();
            for r in &mut self.scored {
                let p = &r.delivery.packet;
                let signed_by = match checked.iter().find(|(q, _)| q == p) {
                    Some(&(_, by)) => by,
                    None => {
                        let by = KeyUse::signer(keys, k, p);
                        checked.push((*p, by));
                        by
                    }
                };
                let key = KeyUse::of(signed_by, &r.delivery, r.label);
                if let (Some(v), Some("insider" | "thief")) = (key.signed_by, key.acts_as) {
                    self.signed_lies.entry(v.0).or_insert(r.step);
                }
                r.key = Some(key);
            }
        }
        // Inspections come in delivery order (the controllers admit deliveries in order): each
        // is the next delivery of its link, sequence number, step and claimed state.
        let mut next = 0;
        for i in inspections {
            if i.dropped_message() {
                // A message a machine dropped as old, recorded after the step's others: the
                // last taken delivery that carried it (an identical earlier copy was taken).
                let row = self.scored.iter_mut().rev().find(|r| {
                    r.refused_by.is_none() && r.delivery.packet.maneuver.is_some() && of(r, i)
                });
                if let Some(row) = row {
                    row.refused_by = i.refused_by;
                }
                continue;
            }
            let found = self.scored[next..].iter().position(|r| of(r, i));
            // One that matches no delivery (a plug-in's, out of order or made up) is not
            // counted: the figures are of packets that were delivered.
            let Some(j) = found.map(|j| next + j) else {
                continue;
            };
            next = j + 1;
            let row = &mut self.scored[j];
            row.refused_by = i.refused_by;
            if i.refused_by_checks() {
                // Refused before any detector: no inspection to score.
                continue;
            }
            row.inspection = Some(*i);
            let label = row.label;
            self.score(k, i, label);
        }
    }

    /// Scores one inspection of a delivery labelled `label` at step `k`.
    fn score(&mut self, k: u64, i: &Inspection, label: Label) {
        let (bad, label) = (label.is_misbehaviour(), label.name());
        if i.receiver.is_leader() {
            // The leader's checks of maneuver messages: scored apart.
            if bad && self.leader_first_bad.is_none() {
                self.leader_first_bad = Some(k);
            }
            let leader = self.leader.get_or_insert_with(Default::default);
            leader.add(k, label, bad, i.flagged);
        } else {
            self.counts.inspected += 1;
            self.counts.flagged += u64::from(i.flagged);
            self.counts.refused += u64::from(i.refused);
            if bad && self.first_bad.is_none() {
                self.first_bad = Some(k);
            }
            *self.labels.entry(label).or_default() += 1;
            for (t, v) in self.per.iter_mut().zip(i.verdicts()) {
                t.add(k, label, bad, v.flagged);
            }
            self.any.add(k, label, bad, i.flagged);
        }
    }

    /// Every delivery of the last [`DetectionRecorder::record`], in delivery order, with what
    /// the controller said of it.
    pub fn scored(&self) -> &[Scored] {
        &self.scored
    }

    /// The figures so far.
    pub fn summary(&self) -> DetectionSummary {
        let screened = self.counts;
        let score =
            |name: &str, first_bad: Option<u64>, Tally(c, by, first): &Tally| DetectorScore {
                name: name.to_string(),
                totals: *c,
                by_label: by.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
                precision: c.precision(),
                recall: c.recall(),
                f1: c.f1(),
                false_alarm_rate: c.false_alarm_rate(),
                time_to_detect_s: first
                    .zip(first_bad)
                    .map(|(f, b)| f.saturating_sub(b) as f64 * self.dt),
            };
        DetectionSummary {
            reaction: self.reaction.to_string(),
            inspected: screened.inspected,
            flagged: screened.flagged,
            refused: screened.refused,
            labels: self
                .labels
                .iter()
                .map(|(k, v)| (k.to_string(), *v))
                .collect(),
            detectors: self
                .names
                .iter()
                .zip(&self.per)
                .map(|(n, p)| score(n, self.first_bad, p))
                .collect(),
            any: score("any", self.first_bad, &self.any),
            maneuver_checks: self
                .leader
                .as_ref()
                .map(|p| score("maneuver_checks", self.leader_first_bad, p)),
            signed_lies: self
                .signed_lies
                .iter()
                .map(|(&vehicle, &first_step)| SignedLie {
                    vehicle,
                    first_step,
                })
                .collect(),
        }
    }
}
