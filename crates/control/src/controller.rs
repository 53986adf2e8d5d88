use crate::checks::PacketChecks;
use crate::fallback::{FallbackMachine, Radar, RadarTruth, Return, Situation, Truths};
use crate::screening::{read_radars, sensed, Detector};
use crate::{ControllerParams, Delivery, Mode, Packet, ParamsError, TriggerRule};
use platoon_model::{FreeFlow, State, VehicleId};
use platoon_topology::Topology;

/// What one follower did in a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FollowerStep {
    /// It broadcast its state in this step.
    pub triggered: bool,
    /// It was affected by an attack (`A*`): its fallback applies, theta frozen.
    pub affected: bool,
    /// The command `u_i[k]`.
    pub u: f64,
    /// `theta_i` at the start of the step (0 for rules without one).
    pub theta: f64,
    /// What it did: cooperative law, a fallback, or blending back.
    pub mode: Mode,
    /// The emergency-braking guard overrode the command.
    pub guard: bool,
    /// Whom it took as its leader: the platoon's (the default), or the member heading its part
    /// of a platoon split behind a car that cut in (`[fallback.cut_in] split`).
    pub head: VehicleId,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Sampling {
    /// The event rule decides.
    Event,
    /// Resilient sampling (11): the last broadcast fell in an attack; sample again at `next`.
    Attacked { next: u64 },
}

#[derive(Debug, Clone)]
struct Follower {
    id: VehicleId,
    own: State,
    neighbours: Vec<VehicleId>,
    estimates: Vec<State>,
    theta: f64,
    sampling: Sampling,
    seq: u32,
    /// The step and state of its last broadcast (for the CAM rule).
    last_sent: (u64, State),
    step: FollowerStep,
    fallback: FallbackMachine,
    radar: Radar,
}

/// The controllers of all followers of one platoon. Pure and deterministic: the same calls give
/// the same results bit for bit, whoever makes them.
#[derive(Debug, Clone)]
pub struct PlatoonController {
    params: ControllerParams,
    flow: FreeFlow,
    theta_decay: f64,
    theta_gain: f64,
    followers: Vec<Follower>,
    leader: crate::seam::LeaderBeacon,
    checks: PacketChecks,
    commands: Vec<f64>,
    /// What the radars see this step ([`PlatoonController::set_radar_truth`] or the states).
    truths: Truths,
    /// Each follower's radar reading of this step, read once for the detectors and the
    /// fallback.
    readings: Vec<Option<(crate::fallback::Reading, u64)>>,
}

impl PlatoonController {
    /// Controllers for the followers of `topology`, with the estimators started from the initial
    /// states (`initial[0]` is the leader): the sample at `t = 0` is assumed delivered.
    pub fn new(
        params: ControllerParams,
        topology: &Topology,
        initial: &[State],
    ) -> Result<Self, ParamsError> {
        Self::with_detectors(params, topology, initial, Vec::new())
    }

    /// [`PlatoonController::new`] with misbehaviour detectors of the caller's after those of
    /// `params.detection`, under its reaction ([`crate::screening`]).
    pub fn with_detectors(
        params: ControllerParams,
        topology: &Topology,
        initial: &[State],
        detectors: Vec<Box<dyn Detector>>,
    ) -> Result<Self, ParamsError> {
        params.validate()?;
        let n = topology.followers();
        params
            .fallback
            .validate(n)
            .map_err(|(field, message)| ParamsError { field, message })?;
        if initial.len() != n + 1 {
            return Err(ParamsError {
                field: "initial_states",
                message: format!(
                    "need {} states (leader + {n} followers), got {}",
                    n + 1,
                    initial.len()
                ),
            });
        }
        let theta0 = match params.rule {
            TriggerRule::Dynamic { theta0, .. } => theta0,
            _ => 0.0,
        };
        let followers = (1..=n)
            .map(|i| {
                let id = VehicleId::follower(i);
                let neighbours = topology.in_neighbours(id).to_vec();
                let estimates: Vec<State> = neighbours.iter().map(|j| initial[j.index()]).collect();
                Follower {
                    id,
                    own: initial[i],
                    neighbours,
                    estimates,
                    theta: theta0,
                    sampling: Sampling::Event,
                    seq: 0,
                    last_sent: (0, initial[i]),
                    step: FollowerStep::default(),
                    fallback: FallbackMachine::new(params.fallback.of(i), Return::SpacingOffset),
                    radar: Radar::new(params.fallback.radar.seed, i as u16),
                }
            })
            .collect();
        let (theta_decay, theta_gain) = match params.rule {
            // Exact integration of theta' = -rho theta - eta s over dt with s held.
            TriggerRule::Dynamic { rho, eta, .. } => {
                let decay = (-rho * params.dt).exp();
                let integral = if rho > 0.0 {
                    (1.0 - decay) / rho
                } else {
                    params.dt
                };
                (decay, eta * integral)
            }
            _ => (1.0, 0.0),
        };
        Ok(Self {
            flow: FreeFlow::new(params.tau_nominal, params.dt),
            theta_decay,
            theta_gain,
            followers,
            leader: Default::default(),
            checks: crate::screening::checks(
                &params.detection,
                detectors,
                topology,
                initial,
                params.dt,
                crate::screening::Hearing::Graph,
            )?,
            commands: vec![0.0; n],
            truths: Truths::default(),
            readings: Vec::with_capacity(n),
            params,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &ControllerParams {
        &self.params
    }

    fn accept(&mut self, k: u64, d: &Delivery, states: &[State]) {
        let p = &self.params;
        let sensed = sensed(k, p.dt, d, states, &self.readings, |j| p.fallback.length(j));
        let Some((fi, s)) = self.checks.admit_sensed(k, d, sensed) else {
            return;
        };
        // An old (delayed) sample is propagated open-loop to the current step.
        let pk = &d.packet;
        let mut x = pk.state;
        for _ in pk.step..k {
            x = self.flow.advance(&x);
        }
        self.followers[fi].estimates[s] = x;
    }
}

impl crate::Controller for PlatoonController {
    /// The commands `u_i` of the last [`receive`](crate::Controller::receive), followers 1..=N at index i-1.
    fn commands(&self) -> &[f64] {
        &self.commands
    }

    /// What each vehicle's radar would see in the coming [`receive`](crate::Controller::receive) (leader
    /// first), as the plant measured it: with SUMO its leader on the lane, whoever that is.
    /// Without it the radar sees the platoon's predecessor in the states (the native plant,
    /// which gives the same numbers).
    fn set_radar_truth(&mut self, truth: &[Option<RadarTruth>]) {
        self.truths.give(truth, self.followers.len() + 1);
    }

    /// What follower `i` (1-based) did in the last step.
    fn follower_step(&self, i: VehicleId) -> FollowerStep {
        self.followers[i.index() - 1].step
    }

    /// Phase 1 of step `k`: `states[v]` is vehicle v's true state (leader at 0). Appends the
    /// packets broadcast at this step to `out` (the leader's first, then followers in order).
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>) {
        let p = &self.params;
        self.leader
            .transmit(k, p.leader_broadcast_steps, states, out);
        let t = k as f64 * p.dt;
        for f in &mut self.followers {
            let x = states[f.id.index()];
            f.step = FollowerStep {
                theta: f.theta,
                ..FollowerStep::default()
            };
            let fire = if k == 0 {
                true // t_0 = 0 is a sampling instant of every rule
            } else {
                match f.sampling {
                    Sampling::Attacked { next } => k >= next,
                    Sampling::Event => {
                        // beta1 |eps|^2 - beta2 |q|^2, evaluated only when a rule needs it.
                        let s = || {
                            let eps2 = (f.own - x).norm_squared();
                            // On the way back the law regulates q shifted by the spacing
                            // offset; so does the trigger (else a large unshifted q would
                            // let the estimation error grow until a jump in u).
                            let q2 = (neighbourhood_error(f, p.spacing, p.headway)
                                + f.fallback.offset(k))
                            .norm_squared();
                            p.beta1 * eps2 - p.beta2 * q2
                        };
                        match p.rule {
                            TriggerRule::Periodic { period_steps } => {
                                k.is_multiple_of(u64::from(period_steps))
                            }
                            TriggerRule::Cam(cam) => {
                                let (step, last) = f.last_sent;
                                cam.fires(k - step, &x, &last)
                            }
                            _ if !k.is_multiple_of(u64::from(p.check_steps)) => false,
                            TriggerRule::Static => s() > 0.0,
                            TriggerRule::Dynamic { phi, .. } => s() - phi * f.theta > 0.0,
                            TriggerRule::Mixed { mu, alpha } => {
                                s() > p.beta1 * mu * (-alpha * t).exp()
                            }
                        }
                    }
                }
            };
            if fire {
                f.own = x;
                f.last_sent = (k, x);
                f.seq += 1;
                f.step.triggered = true;
                out.push(Packet {
                    sender: f.id,
                    seq: f.seq,
                    step: k,
                    state: x,
                    u: f.fallback.last_u(),
                    // The paper's law has no leader to re-point: it never splits.
                    head: VehicleId::LEADER,
                    maneuver: None,
                });
            }
        }
    }

    /// Phase 2 of step `k`: applies the packets the network delivered and computes the commands.
    ///
    /// `jammed[v]` tells whether vehicle v sensed its channel jammed during this step (the
    /// resilient mechanism needs to know whether its broadcast got through). Returns `u_i[k]` for
    /// followers 1..=N (index i-1). Every estimator then advances to step `k + 1`.
    fn receive(&mut self, k: u64, states: &[State], rx: &[Delivery], jammed: &[bool]) -> &[f64] {
        let radar_on = self.params.fallback.uses_radar();
        {
            // The radars first: the detectors read them too.
            let fb = &self.params.fallback;
            let radar_any = radar_on || self.checks.reads_radar();
            let truths = self.truths.take(states, |j| fb.length(j), radar_any);
            let radars = self.followers.iter_mut().map(|f| &mut f.radar);
            read_radars(k, &fb.radar, radar_any, radars, truths, &mut self.readings);
        }
        self.checks.begin_step();
        for d in rx {
            self.accept(k, d, states);
        }
        let p = &self.params;
        for ((f, u_out), reading) in self
            .followers
            .iter_mut()
            .zip(self.commands.iter_mut())
            .zip(&self.readings)
        {
            let jam = jammed[f.id.index()];
            if f.step.triggered && p.resilient {
                f.sampling = if jam {
                    Sampling::Attacked {
                        next: k + u64::from(p.h_steps),
                    }
                } else {
                    Sampling::Event
                };
            }
            let affected = jam
                || matches!(f.sampling, Sampling::Attacked { .. })
                || self.checks.distrusts(f.id, k);
            let q = neighbourhood_error(f, p.spacing, p.headway);
            let coop = -(p.gain * q)[0];
            let reading = reading.filter(|_| radar_on).map(|(r, _)| r);
            let own = states[f.id.index()];
            let situation = Situation {
                k,
                dt: p.dt,
                params: &p.fallback,
                affected,
                cut_in: reading.is_some_and(|r| r.intruder),
                law: coop,
                q,
                reading,
                speed: own[1],
                spacing: p.spacing,
                headway: p.headway,
                length_ahead: p.fallback.length(f.id.index() - 1),
                rebased: false,
            };
            // On the way back the law regulates q shifted by the spacing offset.
            let (mode, u, guard) = f
                .fallback
                .step(&situation, |offset| -(p.gain * (q + offset))[0]);
            if !affected {
                if let TriggerRule::Dynamic { .. } = p.rule {
                    let eps2 = (f.own - own).norm_squared();
                    let s = p.beta1 * eps2 - p.beta2 * (q + f.fallback.offset(k)).norm_squared();
                    f.theta = (self.theta_decay * f.theta - self.theta_gain * s).max(0.0);
                }
            }
            f.step.u = u;
            f.step.affected = affected;
            f.step.mode = mode;
            f.step.guard = guard;
            *u_out = u;
            f.own = self.flow.advance(&f.own);
            for e in &mut f.estimates {
                *e = self.flow.advance(e);
            }
        }
        &self.commands
    }

    fn checks(&self) -> Option<&PacketChecks> {
        Some(&self.checks)
    }
}

/// `q_i` from follower i's current estimates.
fn neighbourhood_error(f: &Follower, spacing: f64, headway: f64) -> State {
    let i = f.id.0 as f64;
    let mut q = State::zeros();
    for (j, e) in f.neighbours.iter().zip(&f.estimates) {
        // x^_i - x^_j - l_ij with l_ij = [(j - i) g, 0, 0], the gap g = l + h_t v of the rear
        // vehicle of the two (g = l for constant spacing: h_t = 0 adds exactly nothing).
        let rear = if j.0 < f.id.0 { f.own[1] } else { e[1] };
        q += f.own - e;
        q[0] -= (j.0 as f64 - i) * (spacing + headway * rear);
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Controller;
    use nalgebra::RowVector3;
    use platoon_topology::Preset;

    fn params(rule: TriggerRule) -> ControllerParams {
        ControllerParams {
            law: crate::LawParams::Paper,
            gain: RowVector3::new(4.81, 9.12, 2.97),
            beta1: 319.38,
            beta2: 5.62,
            rule,
            resilient: true,
            h_steps: 2,
            check_steps: 1,
            fallback: crate::FallbackParams::default(),
            dt: 0.01,
            tau_nominal: 0.5,
            spacing: 10.0,
            headway: 0.0,
            leader_broadcast_steps: 1,
            detection: Default::default(),
            maneuvers: None,
        }
    }

    fn formation(n: usize, v: f64) -> Vec<State> {
        (0..=n)
            .map(|i| State::new(-(i as f64) * 10.0, v, 0.0))
            .collect()
    }

    fn everyone(topology: &Topology, packets: &[Packet]) -> Vec<Delivery> {
        packets
            .iter()
            .flat_map(|p| {
                topology.out_neighbours(p.sender).iter().map(|&r| Delivery {
                    receiver: r,
                    packet: *p,
                })
            })
            .collect()
    }

    #[test]
    fn in_formation_there_is_no_error_no_input_and_no_event() {
        let topo = Topology::preset(Preset::Tpsf, 4).unwrap();
        let states = formation(4, 15.0);
        for rule in [
            TriggerRule::Static,
            TriggerRule::Dynamic {
                phi: 0.33,
                rho: 0.5,
                eta: 0.5,
                theta0: 200.0,
            },
        ] {
            let mut c = PlatoonController::new(params(rule), &topo, &states).unwrap();
            let mut tx = Vec::new();
            c.transmit(0, &states, &mut tx);
            assert_eq!(tx.len(), 5, "everyone samples at t = 0");
            let u = c
                .receive(0, &states, &everyone(&topo, &tx), &[false; 5])
                .to_vec();
            assert_eq!(u, vec![0.0; 4]);
            // One step later in exact formation at constant speed the estimators are exact.
            let next: Vec<State> = states
                .iter()
                .map(|x| State::new(x[0] + 0.15, 15.0, 0.0))
                .collect();
            tx.clear();
            c.transmit(1, &next, &mut tx);
            assert_eq!(tx.len(), 1, "only the leader broadcasts: {tx:?}");
        }
    }

    #[test]
    fn control_law_sign_and_spacing_convention() {
        // Follower 1 of a PF platoon 2 m too close to the leader must brake: q_p = +2, u < 0.
        let topo = Topology::preset(Preset::Pf, 1).unwrap();
        let states = vec![State::new(0.0, 15.0, 0.0), State::new(-8.0, 15.0, 0.0)];
        let mut c = PlatoonController::new(params(TriggerRule::Static), &topo, &states).unwrap();
        let mut tx = Vec::new();
        c.transmit(0, &states, &mut tx);
        let u = c.receive(0, &states, &everyone(&topo, &tx), &[false; 2]);
        assert!((u[0] - (-4.81 * 2.0)).abs() < 1e-12, "u = {}", u[0]);
    }

    #[test]
    fn time_headway_regulates_each_gap_to_l_plus_h_v_of_its_rear_vehicle() {
        // At 20 m/s with h_t = 0.5 s the desired gap is 10 + 10 = 20 m. A BPF platoon (links
        // both ways) at those gaps is at rest for the law; the same platoon at 10 m gaps is
        // 10 m too close.
        let topo = Topology::preset(Preset::Bpf, 3).unwrap();
        let mut p = params(TriggerRule::Static);
        p.headway = 0.5;
        let v = [20.0, 20.0, 20.0, 20.0];
        let gap = |v: f64| 10.0 + 0.5 * v;
        let mut at_rest = vec![State::new(0.0, v[0], 0.0)];
        for (i, &vi) in v.iter().enumerate().skip(1) {
            at_rest.push(State::new(at_rest[i - 1][0] - gap(vi), vi, 0.0));
        }
        let run = |states: &[State], p: &ControllerParams| {
            let mut c = PlatoonController::new(p.clone(), &topo, states).unwrap();
            let mut tx = Vec::new();
            c.transmit(0, states, &mut tx);
            c.receive(0, states, &everyone(&topo, &tx), &[false; 4])
                .to_vec()
        };
        for u in run(&at_rest, &p) {
            assert!(u.abs() < 1e-12, "u = {u}");
        }
        // Constant spacing sees every gap 10 m too long: the last follower (no one behind it)
        // accelerates.
        let mut constant = p.clone();
        constant.headway = 0.0;
        assert!((run(&at_rest, &constant)[2] - 4.81 * 10.0).abs() < 1e-9);
        let close = formation(3, 20.0);
        let u = run(&close, &p);
        // Follower 3 (one gap ahead, none behind): q_p = +10, u = -K_p 10.
        assert!((u[2] - (-4.81 * 10.0)).abs() < 1e-9, "u = {u:?}");
        // Bad headways are refused by name.
        p.headway = -1.0;
        let e = PlatoonController::new(p, &topo, &close).unwrap_err();
        assert_eq!(e.field, "headway");
    }

    #[test]
    fn static_rule_fires_when_estimation_error_outweighs_tracking_error() {
        let topo = Topology::preset(Preset::Pf, 1).unwrap();
        let mut states = formation(1, 15.0);
        let mut c = PlatoonController::new(params(TriggerRule::Static), &topo, &states).unwrap();
        let mut tx = Vec::new();
        c.transmit(0, &states, &mut tx);
        c.receive(0, &states, &everyone(&topo, &tx), &[false; 2]);
        // The follower's true state leaves its estimate by 0.1 m while q stays ~0:
        // beta1 * 0.01 > beta2 * |q|^2 -> fires.
        states[0][0] += 0.15;
        states[1][0] += 0.15 + 0.1;
        tx.clear();
        c.transmit(1, &states, &mut tx);
        assert!(tx.iter().any(|p| p.sender == VehicleId(1)));
        assert!(c.follower_step(VehicleId(1)).triggered);
    }

    #[test]
    fn dynamic_rule_waits_for_theta_to_be_outweighed() {
        let topo = Topology::preset(Preset::Pf, 1).unwrap();
        let dynamic = TriggerRule::Dynamic {
            phi: 0.33,
            rho: 0.5,
            eta: 0.5,
            theta0: 200.0,
        };
        let mut states = formation(1, 15.0);
        let mut c = PlatoonController::new(params(dynamic), &topo, &states).unwrap();
        let mut tx = Vec::new();
        c.transmit(0, &states, &mut tx);
        c.receive(0, &states, &everyone(&topo, &tx), &[false; 2]);
        // Same 0.1 m estimation error: beta1 * 0.01 = 3.19 < phi * theta ~ 66: no event.
        states[0][0] += 0.15;
        states[1][0] += 0.25;
        tx.clear();
        c.transmit(1, &states, &mut tx);
        assert!(!c.follower_step(VehicleId(1)).triggered);
        // A 0.5 m error (79.8 > 66) fires.
        states[1][0] += 0.4;
        tx.clear();
        c.transmit(1, &states, &mut tx);
        assert!(c.follower_step(VehicleId(1)).triggered);
    }

    #[test]
    fn resilient_sampling_during_attack_and_recovery() {
        let topo = Topology::preset(Preset::Pf, 1).unwrap();
        let mut states = formation(1, 15.0);
        let mut c = PlatoonController::new(params(TriggerRule::Static), &topo, &states).unwrap();
        let mut tx = Vec::new();
        // Step 0 is a broadcast under attack: the follower goes to resilient sampling every 2 steps.
        c.transmit(0, &states, &mut tx);
        let u = c.receive(0, &states, &[], &[true, true])[0];
        assert_eq!(u, 0.0);
        assert!(c.follower_step(VehicleId(1)).affected);
        let mut fired = Vec::new();
        for k in 1..=6 {
            for x in &mut states {
                x[0] += 0.15; // cruise at 15 m/s: the estimators stay exact
            }
            tx.clear();
            c.transmit(k, &states, &mut tx);
            let jam = k < 4; // the attack ends at step 4
            c.receive(k, &states, &[], &[jam, jam]);
            let s = c.follower_step(VehicleId(1));
            fired.push(s.triggered);
            assert_eq!(s.affected, k < 4, "step {k}");
        }
        // Samples at 2 (jammed) and 4 (gets through), then the event rule again.
        assert_eq!(fired, vec![false, true, false, true, false, false]);
    }

    #[test]
    fn hostile_packets_are_rejected_and_counted() {
        let topo = Topology::preset(Preset::Pf, 2).unwrap();
        let states = formation(2, 15.0);
        let mut c = PlatoonController::new(params(TriggerRule::Static), &topo, &states).unwrap();
        let mut tx = Vec::new();
        c.transmit(0, &states, &mut tx);
        c.receive(0, &states, &everyone(&topo, &tx), &[false; 3]);
        let to = |receiver, sender, seq, step, p: f64| Delivery {
            receiver: VehicleId(receiver),
            packet: Packet::beacon(VehicleId(sender), seq, step, State::new(p, 15.0, 0.0)),
        };
        let bad = [
            to(2, 1, 5, 1, f64::NAN),
            to(2, 0, 5, 1, 0.0), // 2 does not hear the leader
            to(9, 1, 5, 1, 0.0),
            to(2, 1, 5, 7, 0.0),
            to(2, 1, 1, 0, -10.0), // replays the packet of step 0
        ];
        tx.clear();
        c.transmit(1, &states, &mut tx);
        c.receive(1, &states, &bad, &[false; 3]);
        let r = c.rejected();
        assert_eq!(
            (r.non_finite, r.unknown_sender, r.future_step, r.stale_seq),
            (1, 2, 1, 1)
        );
        assert_eq!(r.total(), 5);
    }

    /// One forged packet with a near-maximum sequence number is refused (it would
    /// lock its sender out for the rest of the run), and a forged packet that passes every
    /// check holds off genuine ones of its own step only.
    #[test]
    fn a_forged_packet_never_locks_a_sender_out() {
        let topo = Topology::preset(Preset::Pf, 2).unwrap();
        let mut states = formation(2, 15.0);
        let periodic = TriggerRule::Periodic { period_steps: 2 };
        let mut c = PlatoonController::new(params(periodic), &topo, &states).unwrap();
        let flow = FreeFlow::new(0.5, 0.01);
        let to_2 = |packet| Delivery {
            receiver: VehicleId(2),
            packet,
        };
        let mut genuine_accepted = 0;
        for k in 0..40u64 {
            let mut tx = Vec::new();
            c.transmit(k, &states, &mut tx);
            let mut rx = everyone(&topo, &tx);
            if k == 5 {
                let mut forged = *tx
                    .iter()
                    .find(|p| p.sender == VehicleId(1))
                    .unwrap_or(&Packet::beacon(VehicleId(1), 1, k, states[1]));
                forged.seq = u32::MAX - 1;
                forged.step = k;
                forged.state = states[1];
                rx.insert(0, to_2(forged));
            }
            if k == 10 {
                // Plausible in every way (the sender's true state, the next sequence number):
                // accepted, and it can only shadow step 10.
                rx.insert(0, to_2(Packet::beacon(VehicleId(1), 11, k, states[1])));
            }
            if k == 20 {
                let mut teleported = states[1];
                teleported[0] += 30.0;
                rx.insert(0, to_2(Packet::beacon(VehicleId(1), 21, k, teleported)));
            }
            let before = c.rejected();
            c.receive(k, &states, &rx, &[false; 3]);
            let after = c.rejected();
            let genuine_from_1 = tx.iter().filter(|p| p.sender == VehicleId(1)).count() as u64;
            let refused = after.total() - before.total();
            if k > 10 && k != 20 {
                assert_eq!(refused, 0, "step {k}: genuine packets refused");
                genuine_accepted += genuine_from_1;
            }
            for x in states.iter_mut() {
                *x = flow.advance(x);
            }
        }
        let r = c.rejected();
        assert_eq!(r.implausible_seq, 1, "{r:?}");
        assert_eq!(r.implausible_state, 1, "{r:?}");
        assert!(genuine_accepted > 0, "follower 1 kept being heard");
    }

    #[test]
    fn delayed_packet_is_propagated_to_now() {
        let topo = Topology::preset(Preset::Pf, 1).unwrap();
        let states = formation(1, 15.0);
        let mut a = PlatoonController::new(params(TriggerRule::Static), &topo, &states).unwrap();
        let mut b = a.clone();
        let leader = Packet::beacon(VehicleId(0), 9, 3, State::new(1.0, 16.0, 1.0));
        let flow = FreeFlow::new(0.5, 0.01);
        let now = Packet {
            step: 5,
            state: flow.advance(&flow.advance(&leader.state)),
            ..leader
        };
        let ua = a.receive(
            5,
            &states,
            &[Delivery {
                receiver: VehicleId(1),
                packet: leader,
            }],
            &[false; 2],
        )[0];
        let ub = b.receive(
            5,
            &states,
            &[Delivery {
                receiver: VehicleId(1),
                packet: now,
            }],
            &[false; 2],
        )[0];
        assert_eq!(ua, ub);
    }
}
