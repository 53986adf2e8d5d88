//! The orchestrator's measure of the controllers' misbehaviour detectors (`[detection]`): what
//! the controller process said of each packet (the `inspections` service, built-in or plug-in
//! controller alike) joined with what truly happened to it, from the step's states, tx and rx
//! batches, by the in-process runner's own code
//! ([`platoon_sim::detection::DetectionRecorder`], one per platoon).
use crate::session::{
    deliveries_from_wire, inspections_from_wire, packet_from_wire, states_from_wire, Numbering,
};
use crate::RunError;
use platoon_control::{Delivery, Packet};
use platoon_model::{State, VehicleId};
use platoon_sim::detection::{DetectionRecorder, DetectionSummary, Scored};
use platoon_sim::Scenario;
use platoon_wire::{Inspection, LinkPacket, VehicleState};

/// Every platoon's recorder and the step's inputs sorted per platoon.
pub(crate) struct Measure {
    num: Numbering,
    detectors: usize,
    recorders: Vec<DetectionRecorder>,
    links: Vec<Vec<(VehicleId, Packet)>>,
    deliveries: Vec<Vec<Delivery>>,
    jammed: Vec<bool>,
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
                .map(|r| DetectionRecorder::new(r.platoon, &names, d.reaction, r.dt()))
                .collect(),
            links: vec![Vec::new(); num.platoons],
            deliveries: vec![Vec::new(); num.platoons],
            jammed: vec![false; num.vehicles()],
            inspections: vec![Vec::new(); num.platoons],
            scored: Vec::new(),
        })
    }

    /// Step `k`: the true states, the tx and rx batches and the controller's inspections.
    pub(crate) fn record(
        &mut self,
        k: u64,
        states: &[VehicleState],
        tx: &[LinkPacket],
        rx: &[LinkPacket],
        inspections: &[Inspection],
    ) -> Result<(), RunError> {
        let num = self.num;
        let states: Vec<State> = states_from_wire(states, num.vehicles())?;
        for l in &mut self.links {
            l.clear();
        }
        for it in tx {
            // A link of platoon j; anything else in the controller's batch links nobody (the
            // wire tally skips it too).
            if let (Some((j, receiver)), Some((js, sender))) =
                (num.split(it.receiver), num.split(it.packet.sender))
            {
                if j != js {
                    continue;
                }
                let mut packet = packet_from_wire(&it.packet);
                packet.sender = sender;
                self.links[j].push((receiver, packet));
            }
        }
        deliveries_from_wire(rx, num, &mut self.deliveries, &mut self.jammed);
        inspections_from_wire(k, inspections, num, self.detectors, &mut self.inspections);
        self.scored.clear();
        let n1 = num.per_platoon;
        for (j, r) in self.recorders.iter_mut().enumerate() {
            r.record(
                k,
                &states[j * n1..(j + 1) * n1],
                self.links[j].iter().copied(),
                &self.deliveries[j],
                &self.inspections[j],
            );
            self.scored.extend_from_slice(r.scored());
        }
        Ok(())
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
