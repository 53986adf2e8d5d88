//! The recorder: the four samples of a step turned into rows, as the in-process runner does.
use super::*;
use platoon_sim::traffic::RadarTarget;

/// Turns the four samples of a step into rows, the way the in-process runner does.
pub(super) struct Recorder<'a> {
    pub(super) scenario: &'a Scenario,
    pub(super) replicas: Vec<Scenario>,
    pub(super) num: Numbering,
    pub(super) step: u64,
    pub(super) last_progress: Instant,
    pub(super) rows: Vec<StepRow>,
    pub(super) jammed: Vec<bool>,
    /// What the plant's radars saw of intruders at this step (empty: none anywhere); with
    /// `targets_on`, what they saw at all.
    pub(super) ahead: Vec<Option<platoon_control::fallback::RadarTruth>>,
    /// Who they saw (with `targets_on`, else empty).
    pub(super) targets: Vec<RadarTarget>,
    /// The run has traffic that may come between its vehicles (scripted cut-ins or the plant's
    /// background traffic): the rows say what the radars saw, as the in-process runner's do.
    pub(super) targets_on: bool,
    pub(super) leader_sent: Vec<bool>,
    pub(super) deliveries: Vec<Vec<platoon_control::Delivery>>,
    pub(super) wire: Vec<WireCounts>,
    pub(super) outside: WireCounts,
    /// The maneuver messages broadcast at this step, (platoon, message), once a broadcast.
    pub(super) maneuvers: Vec<(u16, platoon_control::maneuvers::Message)>,
    /// Scratch: who broadcast them, (platoon, sender).
    pub(super) broadcasters: Vec<(u16, platoon_model::VehicleId)>,
    pub(super) wire_counter: platoon_sim::tally::WireCounter,
    /// The detectors measured against ground truth (`[detection]` runs).
    pub(super) measure: Option<Measure>,
    /// Each vehicle's lane as the plant reported it (`true`: beside the platoon's), by
    /// vehicle; empty in runs where nobody changes lanes.
    pub(super) beside: Vec<bool>,
}

impl<'a> Recorder<'a> {
    /// `radar`: the run has traffic that can touch the platoons ([`super::Options::radar`]).
    pub(super) fn new(scenario: &'a Scenario, radar: bool) -> Self {
        let num = Numbering::of(scenario);
        Self {
            scenario,
            replicas: scenario.replicas(),
            num,
            step: 0,
            last_progress: Instant::now(),
            rows: Vec::with_capacity(num.vehicles()),
            jammed: vec![false; num.vehicles()],
            ahead: Vec::new(),
            targets: Vec::new(),
            targets_on: radar,
            leader_sent: vec![false; num.platoons],
            deliveries: vec![Vec::new(); num.platoons],
            wire: vec![WireCounts::default(); num.vehicles()],
            outside: WireCounts::default(),
            maneuvers: Vec::new(),
            broadcasters: Vec::new(),
            wire_counter: Default::default(),
            measure: Measure::new(scenario),
            beside: Vec::new(),
        }
    }

    /// Step `self.step`'s samples, and what the controller's detectors said of its packets
    /// (empty: nothing, or the run measures none).
    pub(super) fn record(
        &mut self,
        s: &[VehicleState],
        t: &[LinkPacket],
        r: &[LinkPacket],
        c: &[Command],
        inspections: &[Inspection],
    ) -> Result<(), CosimError> {
        let num = self.num;
        let n1 = num.per_platoon;
        let states = states_from_wire(s, num.vehicles())?;
        // The rx batch, sorted as the controllers sort it: deliveries per platoon and who was
        // told its channel was jammed (for the rows and for the wire tally below).
        deliveries_from_wire(r, num, &mut self.deliveries, &mut self.jammed);
        check_commands(self.step, num, c)?;
        // Which leaders broadcast: one pass over the tx batch, not one per platoon.
        self.leader_sent.fill(false);
        for p in t {
            if let Some((j, i)) = num.split(p.packet.sender) {
                self.leader_sent[j] |= i.is_leader();
            }
        }
        if self.scenario.changes_lanes() {
            self.beside.clear();
            self.beside.resize(num.vehicles(), false);
            for x in s {
                if let Some(b) = self.beside.get_mut(x.vehicle as usize) {
                    *b = x.flags & VehicleState::BESIDE != 0;
                }
            }
        }
        // The intruders the plant's radars saw (none without traffic on the lane); in runs
        // with traffic, whatever they saw, and who.
        self.ahead.clear();
        self.targets.clear();
        if self.targets_on {
            let cut_ins = self.scenario.cut_ins.len() as u32;
            self.ahead.extend(s.iter().map(|x| {
                (x.flags & VehicleState::AHEAD != 0).then_some(
                    platoon_control::fallback::RadarTruth {
                        gap: x.gap,
                        closing: x.closing,
                        intruder: x.flags & VehicleState::INTRUDER != 0,
                    },
                )
            }));
            self.targets.extend(s.iter().map(|x| {
                let i = num.split(x.vehicle).map_or(0, |(_, i)| i.index());
                match (x.flags & VehicleState::AHEAD != 0, x.target_code()) {
                    (false, _) => RadarTarget::Nothing,
                    _ if x.flags & VehicleState::INTRUDER == 0 => {
                        RadarTarget::Member(i.saturating_sub(1) as u16)
                    }
                    (true, 0) => RadarTarget::Unknown,
                    (true, c) if c <= cut_ins => RadarTarget::CutIn((c - 1) as u16),
                    (true, c) => RadarTarget::Background(c - 1 - cut_ins),
                }
            }));
        } else if s.iter().any(|x| x.flags & VehicleState::INTRUDER != 0) {
            self.ahead.extend(s.iter().map(|x| {
                (x.flags & VehicleState::INTRUDER != 0).then_some(
                    platoon_control::fallback::RadarTruth {
                        gap: x.gap,
                        closing: x.closing,
                        intruder: true,
                    },
                )
            }));
        }
        self.rows.clear();
        for (j, replica) in self.replicas.iter().enumerate() {
            let leader_triggered = self.leader_sent[j];
            let cmds = &c[j * (n1 - 1)..(j + 1) * (n1 - 1)];
            step_rows(
                replica,
                &RowSources {
                    k: self.step,
                    states: &states[j * n1..(j + 1) * n1],
                    leader_triggered,
                    jammed: &self.jammed[j * n1..(j + 1) * n1],
                    ahead: self.ahead.get(j * n1..(j + 1) * n1).unwrap_or(&[]),
                    targets: self.targets.get(j * n1..(j + 1) * n1).unwrap_or(&[]),
                    beside: self.beside.get(j * n1..(j + 1) * n1).unwrap_or(&[]),
                },
                |i| {
                    let cmd = cmds[i - 1];
                    let status =
                        platoon_control::Status::from_code(cmd.mode_code()).unwrap_or_default();
                    FollowerStep {
                        triggered: cmd.flags & Command::TRIGGERED != 0,
                        affected: cmd.flags & Command::AFFECTED != 0,
                        u: cmd.u,
                        theta: cmd.theta,
                        // Checked above.
                        mode: status.mode().unwrap_or_default(),
                        role: status.role(),
                        guard: cmd.flags & Command::GUARD != 0,
                        head: platoon_model::VehicleId(cmd.head()),
                        revoked: cmd.flags & Command::REVOKED != 0,
                        leader_revoked: cmd.flags & Command::LEADER_REVOKED != 0,
                    }
                },
                &mut self.rows,
            );
        }
        // The wire, measured as the in-process runner measures it.
        self.outside = WireCounts::default();
        // A broadcast's message once, on its first link (the in-process runner reads each
        // broadcast once): a sender broadcasts one packet a step.
        self.maneuvers.clear();
        self.broadcasters.clear();
        for (j, _, p) in t.iter().filter_map(|it| link_from_wire(it, num)) {
            if let Some(m) = p.maneuver {
                let key = (j as u16, p.sender);
                if !self.broadcasters.contains(&key) {
                    self.broadcasters.push(key);
                    self.maneuvers.push((key.0, m));
                }
            }
        }
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

/// Step `step`'s commands, checked before anything is recorded: one per follower, follower i of
/// platoon j at j * N + i - 1, each with a finite command and a known mode code; anything else
/// would be recorded against the wrong vehicle (a plug-in controller's mistake, named; the step
/// is not recorded).
fn check_commands(step: u64, num: Numbering, c: &[Command]) -> Result<(), CosimError> {
    let n1 = num.per_platoon;
    if c.len() != num.followers() {
        return Err(CosimError::Contract {
            node: "controller",
            message: format!("{} commands for {} followers", c.len(), num.followers()),
        });
    }
    for (x, cmd) in c.iter().enumerate() {
        let i = platoon_model::VehicleId((x % (n1 - 1) + 1) as u16);
        let want = num.global(x / (n1 - 1), i);
        if let Err(e) = platoon_control::Status::from_code(cmd.mode_code()) {
            return Err(CosimError::Contract {
                node: "controller",
                message: format!("step {}: command {x} (vehicle {want}): {e}", step),
            });
        }
        if cmd.vehicle != want || !cmd.u.is_finite() {
            return Err(CosimError::Contract {
                node: "controller",
                message: format!(
                    "step {}: command {x} is for vehicle {} with u = {}; a step's commands \
                     list every follower in order (vehicle {want} here), each with a \
                     finite u",
                    step, cmd.vehicle, cmd.u
                ),
            });
        }
    }
    Ok(())
}
