//! The orchestrator's measure of the controllers' misbehaviour detectors (`[detection]`): what
//! the controller process said of each packet (the `inspections` service, built-in or plug-in
//! controller alike) joined with what truly happened to it, from the step's states, tx and rx
//! batches, by the in-process runner's own code
//! ([`platoon_sim::detection::DetectionRecorder`], one per platoon).
use crate::session::{inspections_from_wire, link_from_wire, Numbering};
use platoon_control::{Delivery, Packet};
use platoon_model::{State, VehicleId};
use platoon_sim::detection::{DetectionRecorder, DetectionSummary, Scored};
use platoon_sim::Scenario;
use platoon_wire::{Inspection, LinkPacket};

/// Every platoon's recorder and the step's inputs sorted per platoon.
pub(crate) struct Measure {
    num: Numbering,
    detectors: usize,
    recorders: Vec<DetectionRecorder>,
    links: Vec<Vec<(VehicleId, Packet)>>,
    inspections: Vec<Vec<platoon_control::Inspection>>,
    scored: Vec<Scored>,
}

impl Measure {
    /// For a run that measures detectors; `None` otherwise.
    pub(crate) fn new(scenario: &Scenario) -> Option<Self> {
        let d = &scenario.control.detection;
        if !d.is_measured() {
            return None;
        }
        let num = Numbering::of(scenario);
        let names = d.names();
        Some(Self {
            num,
            detectors: names.len(),
            recorders: scenario
                .replicas()
                .iter()
                .map(|r| {
                    DetectionRecorder::new(r.platoon, &names, d.reaction, r.dt())
                        .signed(r.control.security.as_ref(), num.per_platoon)
                })
                .collect(),
            links: vec![Vec::new(); num.platoons],
            inspections: vec![Vec::new(); num.platoons],
            scored: Vec::new(),
        })
    }

    /// Step `k`: every vehicle's true state, the tx batch, each platoon's deliveries (as the
    /// orchestrator sorted the rx batch) and the controller's inspections.
    pub(crate) fn record(
        &mut self,
        k: u64,
        states: &[State],
        tx: &[LinkPacket],
        deliveries: &[Vec<Delivery>],
        inspections: &[Inspection],
    ) {
        let num = self.num;
        for l in &mut self.links {
            l.clear();
        }
        for (j, receiver, packet) in tx.iter().filter_map(|it| link_from_wire(it, num)) {
            self.links[j].push((receiver, packet));
        }
        inspections_from_wire(k, inspections, num, self.detectors, &mut self.inspections);
        self.scored.clear();
        let n1 = num.per_platoon;
        for (j, r) in self.recorders.iter_mut().enumerate() {
            r.record(
                k,
                &states[j * n1..(j + 1) * n1],
                self.links[j].iter().copied(),
                &deliveries[j],
                &self.inspections[j],
            );
            self.scored.extend_from_slice(r.scored());
        }
    }

    /// The packets scored at the last step, platoon by platoon.
    pub(crate) fn scored(&self) -> &[Scored] {
        &self.scored
    }

    /// Platoon 0's figures (`summary.json`'s `detection`).
    pub(crate) fn summary(&self) -> Option<DetectionSummary> {
        self.recorders.first().map(DetectionRecorder::summary)
    }
}
