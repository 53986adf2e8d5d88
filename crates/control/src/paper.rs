//! The paper's law as a stage of the one follower pipeline ([`crate::composed`]): the open-loop
//! estimators (2) of the follower itself and of every vehicle it hears, the law `u = -K q`
//! (reading R1) on the neighbourhood error
//!
//! ```text
//! q_i = sum_j a_ij (x^_i - x^_j - l_ij) + h_i (x^_i - x^_0 - l_i0),   l_ij = [(j - i) g, 0, 0]
//! ```
//!
//! (`g = l + h_t v` of the rear vehicle of the two, reading R3's sign), and the triggering rules
//! on those estimates ([`TriggerRule`]: periodic, CAM, static, dynamic, mixed) with the
//! resilient mechanism (11). It comes back from a fallback by offsetting its spacing reference
//! ([`Return::SpacingOffset`]).
//!
//! In a platoon whose formation changes (`[maneuvers]`) or that splits behind a car that cut in
//! (`[fallback.cut_in] split`), the graph is the preset's pattern on the follower's part of
//! the formation: it hears the members at the same places relative to its own as in the graph
//! it started with, and the leader's term goes to the head of its part; `l_ij` counts places in
//! that part. A platoon that keeps its formation and its leader runs the paper's graph exactly.
use crate::composed::{Law, Triggering, View};
use crate::fallback::Return;
use crate::{ControllerParams, Packet, TriggerRule};
use nalgebra::RowVector3;
use platoon_model::{FreeFlow, State, VehicleId};
use platoon_topology::Topology;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Sampling {
    /// The event rule decides.
    Event,
    /// Resilient sampling (11): the last broadcast fell in an attack; sample again at `next`.
    Attacked { next: u64 },
}

/// Where a neighbour of the graph sits relative to a follower.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    /// The head of its part (the platoon's leader, or the member heading a split part).
    Head,
    /// This many places ahead of it (negative: behind).
    Ahead(i32),
}

/// One follower's copy of the paper's law (module docs).
#[derive(Debug, Clone)]
pub struct PaperLaw {
    gain: RowVector3<f64>,
    beta1: f64,
    beta2: f64,
    rule: TriggerRule,
    resilient: bool,
    h_steps: u32,
    check_steps: u32,
    dt: f64,
    spacing: f64,
    headway: f64,
    flow: FreeFlow,
    theta_decay: f64,
    theta_gain: f64,
    /// The follower whose copy this is, set by [`Law::start`].
    id: VehicleId,
    /// Its graph's in-neighbours, each with its slot among the vehicles it hears.
    graph: Vec<(usize, VehicleId)>,
    /// Each graph neighbour's place relative to it, in the order of `graph`.
    places: Vec<Place>,
    /// The vehicles it hears (its packet checks' neighbours), in slot order.
    heard: Vec<VehicleId>,
    /// Its estimate of its own state.
    own: State,
    /// Its estimate of every vehicle it hears, by slot.
    estimates: Vec<State>,
    theta: f64,
    sampling: Sampling,
    /// The step and state of its last broadcast (for the CAM rule).
    last_sent: (u64, State),
    /// `q_i` of the last command.
    q: State,
    /// The room of the last command ([`View::room`]).
    room: State,
}

impl PaperLaw {
    /// The law `params` describes (gain, triggering, estimators' nominal lag, spacing policy),
    /// not yet started for a follower.
    pub fn new(params: &ControllerParams) -> Self {
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
        let theta = match params.rule {
            TriggerRule::Dynamic { theta0, .. } => theta0,
            _ => 0.0,
        };
        Self {
            gain: params.gain,
            beta1: params.beta1,
            beta2: params.beta2,
            rule: params.rule,
            resilient: params.resilient,
            h_steps: params.h_steps,
            check_steps: params.check_steps,
            dt: params.dt,
            spacing: params.spacing,
            headway: params.headway,
            flow: FreeFlow::new(params.tau_nominal, params.dt),
            theta_decay,
            theta_gain,
            id: VehicleId::LEADER,
            graph: Vec::new(),
            places: Vec::new(),
            heard: Vec::new(),
            own: State::zeros(),
            estimates: Vec::new(),
            theta,
            sampling: Sampling::Event,
            last_sent: (0, State::zeros()),
            q: State::zeros(),
            room: State::zeros(),
        }
    }

    /// `q_i` on the paper's graph: every in-neighbour, at its place in the initial formation.
    fn graph_error(&self) -> State {
        let i = self.id.0 as f64;
        let mut q = State::zeros();
        for &(slot, j) in &self.graph {
            let e = &self.estimates[slot];
            // x^_i - x^_j - l_ij with l_ij = [(j - i) g, 0, 0], the gap g = l + h_t v of the
            // rear vehicle of the two (g = l for constant spacing: h_t = 0 adds exactly nothing).
            let rear = if j.0 < self.id.0 { self.own[1] } else { e[1] };
            q += self.own - e;
            q[0] -= (j.0 as f64 - i) * (self.spacing + self.headway * rear);
        }
        q
    }

    /// `q_i` on the graph's pattern over `part` (members in road order, its head first): each
    /// neighbour of the graph at its place relative to the follower, the leader's term on the
    /// head; neighbours that are not in the part, or not heard, add nothing. Each vehicle
    /// ahead is taken `room` further ahead ([`View::room`]).
    fn part_error(&self, part: &[VehicleId], room: &State) -> State {
        let Some(me) = part.iter().position(|&v| v == self.id) else {
            return State::zeros();
        };
        // The place in `part` a neighbour of the graph is at, if it is in the part.
        let place_of = |place: &Place| match *place {
            Place::Head => Some(0),
            Place::Ahead(d) => usize::try_from(me as i64 - i64::from(d))
                .ok()
                .filter(|&at| at < part.len()),
        };
        let mut q = State::zeros();
        for (n, place) in self.places.iter().enumerate() {
            let Some(at) = place_of(place) else { continue };
            // A place the graph names twice (the head is also the vehicle ahead) counts once.
            if at == me || self.places[..n].iter().any(|p| place_of(p) == Some(at)) {
                continue;
            }
            let j = part[at];
            let Some(slot) = self.heard.iter().position(|&h| h == j) else {
                continue;
            };
            let e = &self.estimates[slot];
            let rear = if at < me { self.own[1] } else { e[1] };
            q += self.own - e;
            q[0] -= (at as f64 - me as f64) * (self.spacing + self.headway * rear);
            if at < me {
                // It keeps `room` more to every vehicle ahead.
                q += room;
            }
        }
        q
    }

    fn law_of(&self, q: &State) -> f64 {
        -(self.gain * q)[0]
    }

    /// `beta1 |eps|^2 - beta2 |q + offset|^2` at the follower's true state `x`.
    fn condition(&self, x: &State, q: &State, offset: &State) -> f64 {
        let eps2 = (self.own - x).norm_squared();
        self.beta1 * eps2 - self.beta2 * (q + offset).norm_squared()
    }
}

impl Law for PaperLaw {
    fn start(
        &mut self,
        id: VehicleId,
        topology: &Topology,
        heard: &[VehicleId],
        initial: &[State],
    ) {
        self.id = id;
        self.heard = heard.to_vec();
        self.graph = topology
            .in_neighbours(id)
            .iter()
            .filter_map(|&j| Some((heard.iter().position(|&h| h == j)?, j)))
            .collect();
        self.places = self
            .graph
            .iter()
            .map(|&(_, j)| match j.is_leader() {
                true => Place::Head,
                false => Place::Ahead(i32::from(id.0) - i32::from(j.0)),
            })
            .collect();
        self.estimates = heard.iter().map(|j| initial[j.index()]).collect();
        self.own = initial[id.index()];
        self.last_sent = (0, self.own);
    }

    fn command(&mut self, view: &View<'_>) -> f64 {
        self.room = view.room;
        self.q = match view.part {
            Some(part) => self.part_error(part, &view.room),
            None => self.graph_error(),
        };
        self.law_of(&self.q)
    }

    fn way_back(&self) -> Return {
        Return::SpacingOffset
    }

    fn tracking_error(&self) -> State {
        self.q
    }

    fn command_offset(&mut self, offset: State) -> f64 {
        self.law_of(&(self.q + offset))
    }

    fn heard(&mut self, k: u64, slot: usize, packet: &Packet) {
        // An old (delayed) sample is propagated open-loop to the current step.
        let mut x = packet.state;
        for _ in packet.step..k {
            x = self.flow.advance(&x);
        }
        if let Some(e) = self.estimates.get_mut(slot) {
            *e = x;
        }
    }

    fn end_step(&mut self) {
        self.own = self.flow.advance(&self.own);
        for e in &mut self.estimates {
            *e = self.flow.advance(e);
        }
    }

    fn triggering(&mut self) -> Option<&mut dyn Triggering> {
        Some(self)
    }
}

impl Triggering for PaperLaw {
    fn theta(&self) -> f64 {
        self.theta
    }

    fn fires(&mut self, k: u64, x: &State, offset: State, part: Option<&[VehicleId]>) -> bool {
        if k == 0 {
            return true; // t_0 = 0 is a sampling instant of every rule
        }
        if let Sampling::Attacked { next } = self.sampling {
            return k >= next;
        }
        // On the way back the law regulates q shifted by the spacing offset; so does the
        // trigger (else a large unshifted q would let the estimation error grow until a jump
        // in u). Evaluated only when a rule needs it.
        let s = || {
            let q = match part {
                Some(part) => self.part_error(part, &self.room),
                None => self.graph_error(),
            };
            self.condition(x, &q, &offset)
        };
        match self.rule {
            TriggerRule::Periodic { period_steps } => k.is_multiple_of(u64::from(period_steps)),
            TriggerRule::Cam(cam) => {
                let (step, last) = self.last_sent;
                cam.fires(k - step, x, &last)
            }
            _ if !k.is_multiple_of(u64::from(self.check_steps)) => false,
            TriggerRule::Static => s() > 0.0,
            TriggerRule::Dynamic { phi, .. } => s() - phi * self.theta > 0.0,
            TriggerRule::Mixed { mu, alpha } => {
                let t = k as f64 * self.dt;
                s() > self.beta1 * mu * (-alpha * t).exp()
            }
        }
    }

    fn sent(&mut self, k: u64, x: &State) {
        self.own = *x;
        self.last_sent = (k, *x);
    }

    fn attacked(&mut self, k: u64, triggered: bool, jammed: bool) -> bool {
        if triggered && self.resilient {
            self.sampling = if jammed {
                Sampling::Attacked {
                    next: k + u64::from(self.h_steps),
                }
            } else {
                Sampling::Event
            };
        }
        matches!(self.sampling, Sampling::Attacked { .. })
    }

    fn settle(&mut self, x: &State, affected: bool, offset: State) {
        if !affected {
            if let TriggerRule::Dynamic { .. } = self.rule {
                let s = self.condition(x, &self.q, &offset);
                self.theta = (self.theta_decay * self.theta - self.theta_gain * s).max(0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests;
