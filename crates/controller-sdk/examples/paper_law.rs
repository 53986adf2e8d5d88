//! The paper's controller (Han et al. 2024), re-implemented on the SDK from its equations: the
//! open-loop estimators (2), the neighbourhood error q_i and the law u_i = -K q_i (1), the
//! triggering rules (periodic, static (21), dynamic (4) + (12)), the resilient sampling (11)
//! and u_i = 0 while a follower is affected by an attack. The packet checks are the shared
//! [`PacketChecks`]. With a config that uses nothing else (no fallback but `zero` with no dwell
//! or blend, no guard: `configs/paper.toml`, `configs/table1.toml`), a run with it equals the
//! built-in run byte for byte (tested); any other config is refused, naming the key.
//!
//! ```sh
//! cargo build --example paper_law
//! platoon run configs/paper.toml --controller target/debug/examples/paper_law
//! ```
use platoon_controller_sdk::{
    run, Controller, Delivery, FallbackMode, FollowerStep, FreeFlow, Mode, Packet, PacketChecks,
    RejectCounts, Scenario, State, TriggerRule, VehicleId,
};

/// One follower's view: its own estimate, its neighbours' estimates and its trigger state.
#[derive(Debug, Clone)]
struct Follower {
    id: VehicleId,
    /// Whom it hears, in the order of [`PacketChecks::neighbours`].
    hears: Vec<VehicleId>,
    estimates: Vec<State>,
    /// x^_i: its own state as its neighbours estimate it (reset when it broadcasts).
    own: State,
    /// The dynamic rule's internal variable theta_i.
    theta: f64,
    /// (11): its last broadcast was jammed; it samples again at this step.
    resample_at: Option<u64>,
    seq: u32,
    last_u: f64,
    step: FollowerStep,
}

#[derive(Debug, Clone)]
struct PaperLaw {
    k_gain: [f64; 3],
    beta1: f64,
    beta2: f64,
    rule: TriggerRule,
    resilient: bool,
    h_steps: u64,
    check_steps: u64,
    spacing: f64,
    headway: f64,
    leader_every: u64,
    flow: FreeFlow,
    /// theta' = -rho theta - eta s, integrated exactly over a step with s held.
    theta_decay: f64,
    theta_gain: f64,
    followers: Vec<Follower>,
    leader_seq: u32,
    leader_last_u: f64,
    checks: PacketChecks,
    u: Vec<f64>,
}

impl PaperLaw {
    fn new(s: &Scenario) -> Result<Self, String> {
        let p = &s.control;
        let fb = &p.fallback;
        let unsupported = if p.law.name() != "paper" {
            Some("control.law (only \"paper\")")
        } else if fb.mode != FallbackMode::Zero || !fb.per_vehicle.is_empty() {
            Some("fallback.mode (only \"zero\")")
        } else if fb.dwell_steps != 0 || fb.blend_steps != 0 {
            Some("fallback.dwell_s and fallback.blend_s (only 0)")
        } else if fb.guard.is_some() {
            Some("guard.enabled (only false)")
        } else if fb.cut_in.is_some() {
            Some("fallback.cut_in (only absent)")
        } else if matches!(p.rule, TriggerRule::Mixed { .. } | TriggerRule::Cam(_)) {
            Some("trigger.rule (not \"mixed\" nor \"cam\")")
        } else {
            None
        };
        if let Some(key) = unsupported {
            return Err(format!("paper_law does not implement this config's {key}"));
        }
        let theta0 = match p.rule {
            TriggerRule::Dynamic { theta0, .. } => theta0,
            _ => 0.0,
        };
        let (theta_decay, theta_gain) = match p.rule {
            TriggerRule::Dynamic { rho, eta, .. } => {
                let decay = (-rho * p.dt).exp();
                let integral = if rho > 0.0 { (1.0 - decay) / rho } else { p.dt };
                (decay, eta * integral)
            }
            _ => (1.0, 0.0),
        };
        let checks = PacketChecks::new(&s.topology, &s.initial, p.dt);
        let followers = (1..=s.topology.followers())
            .map(|i| {
                let id = VehicleId::follower(i);
                let hears = checks.neighbours(id).to_vec();
                Follower {
                    id,
                    estimates: hears.iter().map(|j| s.initial[j.index()]).collect(),
                    hears,
                    own: s.initial[i],
                    theta: theta0,
                    resample_at: None,
                    seq: 0,
                    last_u: 0.0,
                    step: FollowerStep::default(),
                }
            })
            .collect::<Vec<_>>();
        Ok(Self {
            k_gain: [p.gain[0], p.gain[1], p.gain[2]],
            beta1: p.beta1,
            beta2: p.beta2,
            rule: p.rule,
            resilient: p.resilient,
            h_steps: u64::from(p.h_steps),
            check_steps: u64::from(p.check_steps),
            spacing: p.spacing,
            headway: p.headway,
            leader_every: u64::from(p.leader_broadcast_steps),
            flow: FreeFlow::new(p.tau_nominal, p.dt),
            theta_decay,
            theta_gain,
            u: vec![0.0; followers.len()],
            followers,
            leader_seq: 0,
            leader_last_u: 0.0,
            checks,
        })
    }

    /// q_i = sum over its neighbours j of (x^_i - x^_j - l_ij), l_ij = [(j - i) g, 0, 0] with
    /// the gap g = l + h_t v of the rear vehicle of the two.
    fn q(&self, f: &Follower) -> State {
        let mut q = State::zeros();
        for (j, e) in f.hears.iter().zip(&f.estimates) {
            let rear = if j.0 < f.id.0 { f.own[1] } else { e[1] };
            q += f.own - e;
            q[0] -= (f64::from(j.0) - f64::from(f.id.0)) * (self.spacing + self.headway * rear);
        }
        q
    }

    /// beta1 |x^_i - x_i|^2 - beta2 |q_i|^2.
    fn s(&self, f: &Follower, x: &State, q: &State) -> f64 {
        self.beta1 * (f.own - x).norm_squared() - self.beta2 * q.norm_squared()
    }
}

impl Controller for PaperLaw {
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>) {
        if k.is_multiple_of(self.leader_every) {
            self.leader_seq += 1;
            out.push(Packet {
                sender: VehicleId::LEADER,
                seq: self.leader_seq,
                step: k,
                state: states[0],
                u: self.leader_last_u,
                head: VehicleId::LEADER,
                maneuver: None,
                seal: None,
                group: None,
            });
        }
        // Packets carry the sender's command of the step before (for the leader, the
        // acceleration it applied then).
        self.leader_last_u = states[0][2];
        for n in 0..self.followers.len() {
            let f = &self.followers[n];
            let x = states[f.id.index()];
            let fire = match f.resample_at {
                _ if k == 0 => true, // t = 0 samples under every rule
                Some(at) => k >= at,
                None => match self.rule {
                    TriggerRule::Periodic { period_steps } => {
                        k.is_multiple_of(u64::from(period_steps))
                    }
                    _ if !k.is_multiple_of(self.check_steps) => false,
                    TriggerRule::Static => self.s(f, &x, &self.q(f)) > 0.0,
                    TriggerRule::Dynamic { phi, .. } => {
                        self.s(f, &x, &self.q(f)) - phi * f.theta > 0.0
                    }
                    // Refused in `new`.
                    TriggerRule::Mixed { .. } | TriggerRule::Cam(_) => false,
                },
            };
            let f = &mut self.followers[n];
            f.step = FollowerStep {
                theta: f.theta,
                triggered: fire,
                ..FollowerStep::default()
            };
            if fire {
                f.own = x;
                f.seq += 1;
                out.push(Packet {
                    sender: f.id,
                    seq: f.seq,
                    step: k,
                    state: x,
                    u: f.last_u,
                    head: VehicleId::LEADER,
                    maneuver: None,
                    seal: None,
                    group: None,
                });
            }
        }
    }

    fn receive(
        &mut self,
        k: u64,
        states: &[State],
        deliveries: &[Delivery],
        jammed: &[bool],
    ) -> &[f64] {
        for d in deliveries {
            if let Some((i, s)) = self.checks.admit(k, d) {
                // A delayed sample is propagated open-loop to now.
                let mut x = d.packet.state;
                for _ in d.packet.step..k {
                    x = self.flow.advance(&x);
                }
                self.followers[i].estimates[s] = x;
            }
        }
        for n in 0..self.followers.len() {
            let f = &self.followers[n];
            let jam = jammed[f.id.index()];
            let mut resample_at = f.resample_at;
            if f.step.triggered && self.resilient {
                resample_at = jam.then_some(k + self.h_steps);
            }
            let affected = jam || resample_at.is_some();
            let q = self.q(f);
            let [k0, k1, k2] = self.k_gain;
            let u = if affected {
                0.0
            } else {
                -(k0 * q[0] + k1 * q[1] + k2 * q[2])
            };
            let mut theta = f.theta;
            if !affected {
                if let TriggerRule::Dynamic { .. } = self.rule {
                    let s = self.s(f, &states[f.id.index()], &q);
                    theta = (self.theta_decay * theta - self.theta_gain * s).max(0.0);
                }
            }
            let flow = self.flow;
            let f = &mut self.followers[n];
            f.resample_at = resample_at;
            f.theta = theta;
            f.last_u = u;
            f.step.u = u;
            f.step.affected = affected;
            f.step.mode = if affected { Mode::Zero } else { Mode::Coop };
            self.u[n] = u;
            // Every estimate advances to step k + 1.
            f.own = flow.advance(&f.own);
            for e in &mut f.estimates {
                *e = flow.advance(e);
            }
        }
        &self.u
    }

    fn commands(&self) -> &[f64] {
        &self.u
    }

    fn follower_step(&self, i: VehicleId) -> FollowerStep {
        self.followers[i.index() - 1].step
    }

    fn rejected(&self) -> RejectCounts {
        self.checks.rejected()
    }
}

fn main() -> Result<(), platoon_controller_sdk::Error> {
    run(|platoon| PaperLaw::new(platoon).map(|c| Box::new(c) as Box<dyn Controller>))
}
