//! Misbehaviour detection in the receive path (`[detection]`): every packet that passes the
//! packet checks ([`crate::checks`]) is shown to the platoon's detectors (`platoon-detect`:
//! plausibility, radar cross-check, model residual, or the caller's own), with what the
//! receiver knows (its own state, its radar on the vehicle ahead, the sender's last accepted
//! packet). What a follower then does is the reaction the user chose:
//!
//! - [`Reaction::Log`]: nothing; the verdicts are recorded ([`Inspection`]) and measured;
//! - [`Reaction::Drop`]: a flagged packet is refused, and so is every packet of that sender to
//!   that follower until `quiet_steps` pass without a flag;
//! - [`Reaction::Fallback`]: as `Drop`, and the follower is affected meanwhile: it runs its
//!   fallback (`[fallback] mode`, ACC on its radar for instance) until the quiet period ends,
//!   then returns as after a DoS (dwell, blend).
//!
//! Pure and deterministic like the rest of the controller: the same deliveries give the same
//! verdicts bit for bit, in process and in the iceoryx2 controller node.

use platoon_detect::{Last, Observation, RadarReading};
use platoon_model::{State, VehicleId};

pub use platoon_detect::{
    Detection as DetectorTables, Detector, DetectorSpec, Detectors, ParamError, Verdict,
};

/// What a follower does about a flagged sender (`[detection] reaction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "snake_case")]
pub enum Reaction {
    /// Record the verdicts only.
    #[default]
    Log,
    /// Refuse the sender's packets until a quiet period passes without a flag.
    Drop,
    /// Refuse them and run the fallback meanwhile.
    Fallback,
}

impl Reaction {
    /// Every reaction.
    pub const ALL: [Reaction; 3] = [Self::Log, Self::Drop, Self::Fallback];

    /// Its config name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Log => "log",
            Self::Drop => "drop",
            Self::Fallback => "fallback",
        }
    }
}

/// The detectors of a platoon and what a flag makes a follower do.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DetectionParams {
    /// The detectors, in the order of every [`Inspection`]'s verdicts (empty: detection off).
    pub specs: Vec<DetectorSpec>,
    /// The reaction to a flag.
    pub reaction: Reaction,
    /// Steps without a flag after which a distrusted sender is trusted again (`Drop`,
    /// `Fallback`).
    pub quiet_steps: u32,
    /// The detectors a controller plug-in runs itself (`[detection] plugin`): the built-in
    /// controllers do not; a co-simulation records the plug-in's verdicts under these names,
    /// after those of `specs`.
    pub plugin: Vec<String>,
}

impl DetectionParams {
    /// Whether a built-in detector is on (the built-in controllers run them).
    pub fn is_on(&self) -> bool {
        !self.specs.is_empty()
    }

    /// Whether the run measures detectors: built-in ones, or a plug-in's.
    pub fn is_measured(&self) -> bool {
        self.is_on() || !self.plugin.is_empty()
    }

    /// The names of every detector the run measures, in the order of each inspection's
    /// verdicts: the built-in ones, then the plug-in's.
    pub fn names(&self) -> Vec<String> {
        self.specs
            .iter()
            .map(|s| s.name().to_string())
            .chain(self.plugin.iter().cloned())
            .collect()
    }

    /// Whether a detector reads the radar (the controller then reads it every step even when
    /// its fallback does not).
    pub fn reads_radar(&self) -> bool {
        self.specs
            .iter()
            .any(|s| matches!(s, DetectorSpec::RadarCross(_)))
    }
}

/// The most detectors one platoon runs.
pub const MAX_DETECTORS: usize = 8;

/// What the detectors said of one packet a follower received, and what became of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inspection {
    /// The step it was received.
    pub k: u64,
    /// The receiving follower.
    pub receiver: VehicleId,
    /// The claimed sender.
    pub sender: VehicleId,
    /// Its sequence number.
    pub seq: u32,
    /// The step it claims to have been sampled at.
    pub step: u64,
    /// The state it claims.
    pub state: State,
    /// Whether any detector flagged it.
    pub flagged: bool,
    /// Whether the reaction refused it (flagged, or its sender distrusted).
    pub refused: bool,
    /// What refused it: the reaction, the leader's check, or (a record of a packet no detector
    /// saw, [`Inspection::refused_by_checks`]) one of the packet checks; `None` if accepted.
    pub refused_by: Option<crate::RefusedBy>,
    verdicts: [Verdict; MAX_DETECTORS],
    detectors: u8,
}

impl Inspection {
    /// The inspection of a packet `(sender, seq, step, state)` that `receiver` got at step `k`,
    /// with each detector's verdict (at most [`MAX_DETECTORS`]; more are ignored): how the
    /// co-simulation rebuilds what a controller process reported on the wire. `flagged` is
    /// whether any verdict flagged it (a reaction may act on fewer detectors than it
    /// reports), `refused` whether the reaction refused it.
    pub fn new(
        k: u64,
        receiver: VehicleId,
        (sender, seq, step, state): (VehicleId, u32, u64, State),
        flagged: bool,
        refused: bool,
        verdicts: &[Verdict],
    ) -> Self {
        let mut all = [Verdict::NOT_TESTED; MAX_DETECTORS];
        let n = verdicts.len().min(MAX_DETECTORS);
        all[..n].copy_from_slice(&verdicts[..n]);
        Self {
            k,
            receiver,
            sender,
            seq,
            step,
            state,
            flagged,
            refused,
            refused_by: refused.then_some(crate::RefusedBy::Reaction),
            verdicts: all,
            detectors: n as u8,
        }
    }

    /// This inspection refused by `by` instead (`None`: accepted, `refused` false).
    pub fn with_refusal(mut self, by: Option<crate::RefusedBy>) -> Self {
        use crate::RefusedBy as R;
        self.refused = matches!(by, Some(R::Reaction | R::CheckReports));
        self.refused_by = by;
        self
    }

    /// A record of a packet the packet checks refused before any detector saw it: not an
    /// inspection, no verdict, `refused` false (the reaction did not refuse it).
    pub fn refused_by_checks(&self) -> bool {
        self.refused_by.is_some_and(|b| b.by_checks())
    }

    /// A record that the maneuver message of a packet was dropped as old by its receiver's
    /// protocol machine ([`crate::RefusedBy::ManeuverSeq`]): recorded after the step's other
    /// inspections, not an inspection.
    pub fn dropped_message(&self) -> bool {
        self.refused_by == Some(crate::RefusedBy::ManeuverSeq)
    }

    /// Each detector's verdict, in the order of [`DetectionParams::specs`].
    pub fn verdicts(&self) -> &[Verdict] {
        &self.verdicts[..usize::from(self.detectors)]
    }
}

/// Counts over a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct ScreenCounts {
    /// Packets shown to the detectors.
    pub inspected: u64,
    /// Packets some detector flagged.
    pub flagged: u64,
    /// Packets the reaction refused.
    pub refused: u64,
}

/// What the receiver knows besides the packet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensed {
    /// Its own state.
    pub own: State,
    /// Its radar on the vehicle ahead, if it reads one.
    pub radar: Option<RadarReading>,
}

/// Each follower's radar reading of step `k` with the step it was measured at, into `out`
/// (followers in order, `truths` leader first): read once a step, for the detectors and the
/// fallback alike, when `on`; on each radar's own stream, so who reads first does not move the
/// draws.
pub(crate) fn read_radars<'a>(
    k: u64,
    params: &crate::fallback::RadarParams,
    on: bool,
    radars: impl Iterator<Item = &'a mut crate::fallback::Radar>,
    truths: &[Option<crate::fallback::RadarTruth>],
    out: &mut Vec<Option<(crate::fallback::Reading, u64)>>,
) {
    out.clear();
    out.extend(radars.enumerate().map(|(fi, radar)| {
        if on {
            let truth = truths.get(fi + 1).copied().flatten();
            radar.read(k, params, truth).map(|r| (r, radar.taken()))
        } else {
            None
        }
    }));
}

/// What the receiver of `d` senses at step `k`: its own state and, for a follower, its radar
/// reading of this step ([`read_radars`]) brought to the detectors' terms.
pub(crate) fn sensed(
    k: u64,
    dt: f64,
    d: &crate::Delivery,
    states: &[State],
    readings: &[Option<(crate::fallback::Reading, u64)>],
    length: impl Fn(usize) -> f64,
) -> Sensed {
    let r = d.receiver.index();
    Sensed {
        own: states.get(r).copied().unwrap_or_else(State::zeros),
        radar: r
            .checked_sub(1)
            .and_then(|fi| readings.get(fi).copied().flatten())
            // A vehicle that cut in is not the predecessor: the radar does not see the sender.
            .filter(|(reading, _)| !reading.intruder)
            .map(|(reading, taken)| RadarReading {
                gap_m: reading.gap,
                closing_mps: reading.closing,
                // The sender ahead is the predecessor, vehicle r - 1.
                vehicle_length_m: length(r - 1),
                age_s: k.saturating_sub(taken) as f64 * dt,
            }),
    }
}

/// The packet checks of a built-in controller: `detection`'s detectors, then the caller's
/// `extra` ones (at most [`MAX_DETECTORS`] in all).
/// Whom a follower's checks accept packets from besides its graph's neighbours.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Hearing {
    /// Nobody.
    Graph,
    /// Every member ahead (a platoon that may split).
    AllAhead,
    /// Every vehicle (a platoon that negotiates maneuvers).
    Everyone,
}

impl Hearing {
    /// The hearing of a platoon that may split (`split`) and negotiates maneuvers.
    pub(crate) fn of(split: bool, maneuvers: bool) -> Self {
        match (split, maneuvers) {
            (_, true) => Hearing::Everyone,
            (true, false) => Hearing::AllAhead,
            (false, false) => Hearing::Graph,
        }
    }
}

pub(crate) fn checks(
    detection: &DetectionParams,
    extra: Vec<Box<dyn Detector>>,
    topology: &platoon_topology::Topology,
    initial: &[State],
    dt: f64,
    hearing: Hearing,
) -> Result<crate::PacketChecks, crate::ParamsError> {
    let err = |message| crate::ParamsError {
        field: "detection",
        message,
    };
    let all = detection.specs.len() + extra.len();
    if all > MAX_DETECTORS {
        return Err(err(format!(
            "{all} detectors: a platoon runs at most {MAX_DETECTORS}"
        )));
    }
    let checks = crate::PacketChecks::new(topology, initial, dt);
    let checks = match hearing {
        Hearing::Graph => checks,
        Hearing::AllAhead => checks.hearing_all_ahead(initial),
        Hearing::Everyone => checks.hearing_everyone(initial),
    };
    checks
        .with_detection_and(detection, extra)
        .map_err(|e| err(e.to_string()))
}

/// The detection state of one platoon's followers.
#[derive(Debug, Clone)]
pub(crate) struct Screening {
    detectors: Detectors,
    names: Vec<&'static str>,
    reaction: Reaction,
    quiet_steps: u64,
    dt: f64,
    /// Whether a detector may read the radar (a built-in one that does, or any of the
    /// caller's): the controller then reads it every step.
    reads_radar: bool,
    /// Per follower and neighbour slot: distrusted up to (excluding) this step.
    distrust_until: Vec<Vec<u64>>,
    scratch: Vec<Verdict>,
    log: Vec<Inspection>,
    counts: ScreenCounts,
}

impl Screening {
    /// The detectors `params` names, then the caller's `extra` ones, under its reaction.
    pub(crate) fn new(
        params: &DetectionParams,
        extra: Vec<Box<dyn Detector>>,
        neighbours: &[Vec<VehicleId>],
        dt: f64,
    ) -> Result<Screening, ParamError> {
        let mut detectors = Detectors::from_specs(&params.specs)?;
        let reads_radar = params.reads_radar() || !extra.is_empty();
        for d in extra {
            detectors.push(d);
        }
        let mut screening = Self::with(
            detectors,
            params.reaction,
            params.quiet_steps,
            neighbours,
            dt,
        );
        screening.reads_radar = reads_radar;
        Ok(screening)
    }

    pub(crate) fn with(
        detectors: Detectors,
        reaction: Reaction,
        quiet_steps: u32,
        neighbours: &[Vec<VehicleId>],
        dt: f64,
    ) -> Screening {
        Screening {
            names: detectors.names().collect(),
            detectors,
            reaction,
            quiet_steps: u64::from(quiet_steps),
            dt,
            reads_radar: true,
            distrust_until: neighbours.iter().map(|n| vec![0; n.len()]).collect(),
            scratch: Vec::with_capacity(MAX_DETECTORS),
            log: Vec::new(),
            counts: ScreenCounts::default(),
        }
    }

    pub(crate) fn begin_step(&mut self) {
        self.log.clear();
    }

    /// Shows an admitted packet to the detectors; whether the reaction refuses it.
    pub(crate) fn screen(
        &mut self,
        k: u64,
        (fi, s): (usize, usize),
        receiver: VehicleId,
        packet: &crate::Packet,
        last: Option<Last>,
        sensed: Sensed,
    ) -> bool {
        let obs = Observation {
            k,
            dt: self.dt,
            receiver,
            own: sensed.own,
            packet,
            last,
            radar: sensed
                .radar
                .filter(|_| packet.sender.index() + 1 == receiver.index()),
        };
        let flagged = self.detectors.inspect_all(&obs, &mut self.scratch);
        if flagged {
            self.distrust_until[fi][s] = k + 1 + self.quiet_steps;
        }
        let refused = self.reaction != Reaction::Log && k < self.distrust_until[fi][s];
        self.log.push(Inspection::new(
            k,
            receiver,
            (packet.sender, packet.seq, packet.step, packet.state),
            flagged,
            refused,
            &self.scratch,
        ));
        self.counts.inspected += 1;
        self.counts.flagged += u64::from(flagged);
        self.counts.refused += u64::from(refused);
        refused
    }

    /// Records what a check outside the detectors said of a packet `receiver` got at step `k`
    /// (the leader's checks of maneuver messages): no detector's verdict, flagged and refused
    /// as the check decided. Not counted in [`Screening::counts`]: the recorder scores such
    /// checks apart from the detectors.
    pub(crate) fn note(
        &mut self,
        k: u64,
        receiver: VehicleId,
        packet: &crate::Packet,
        refused: bool,
    ) {
        let untested = [Verdict::NOT_TESTED; MAX_DETECTORS];
        self.log.push(
            Inspection::new(
                k,
                receiver,
                (packet.sender, packet.seq, packet.step, packet.state),
                refused,
                refused,
                &untested[..self.names.len().min(MAX_DETECTORS)],
            )
            .with_refusal(refused.then_some(crate::RefusedBy::CheckReports)),
        );
    }

    /// Records that the packet checks refused a packet `receiver` got at step `k` (`why`),
    /// before any detector saw it: in the log, in delivery order, so the recorder can say
    /// what refused each delivery; not counted in [`Screening::counts`].
    pub(crate) fn refusal(
        &mut self,
        k: u64,
        receiver: VehicleId,
        packet: &crate::Packet,
        why: crate::RefusedBy,
    ) {
        self.log.push(
            Inspection::new(
                k,
                receiver,
                (packet.sender, packet.seq, packet.step, packet.state),
                false,
                false,
                &[],
            )
            .with_refusal(Some(why)),
        );
    }

    /// Whether follower `fi` (0-based) runs its fallback at step `k` because it distrusts a
    /// neighbour (`Reaction::Fallback` only).
    pub(crate) fn affects(&self, fi: usize, k: u64) -> bool {
        self.reaction == Reaction::Fallback && self.distrust_until[fi].iter().any(|&u| k < u)
    }

    pub(crate) fn log(&self) -> &[Inspection] {
        &self.log
    }

    pub(crate) fn reads_radar(&self) -> bool {
        self.reads_radar
    }

    pub(crate) fn names(&self) -> &[&'static str] {
        &self.names
    }

    pub(crate) fn counts(&self) -> ScreenCounts {
        self.counts
    }
}
