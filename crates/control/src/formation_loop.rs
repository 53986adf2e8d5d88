//! The closed loop of a formation, linearised: what a stability certificate of a formation
//! (`platoon_synthesis::common_decay`) is checked on.
//!
//! A formation is the vehicles of the lane's platoons in road order, each platoon headed by the
//! leader or by a member that heads a part of its own on its ACC (a split's, or a merging
//! platoon's before the merge). In it every member runs the config's law ([`crate::Law`], the
//! very code a run calls; the paper's on the preset's pattern over its platoon) on what it
//! would know in the nominal case: the radar's exact gap and closing speed to the vehicle ahead
//! in the formation, and a packet from every vehicle it hears at every step (its state and the
//! command of the step before, as a packet carries it; the paper's law's estimates are those
//! states);
//! a head runs its ACC (the fallback's, opened to its headway) behind the member ahead of it.
//! The plant moves each with its lag under the run's discretisation.
//!
//! One step of that loop maps the followers' deviations from the equilibrium (every vehicle at
//! the leader's constant speed, at the distances its law keeps) `z = [p, v, a, u_last]` per
//! follower, in road order, to the next: [`step_matrix`] returns that map's Jacobian, by central
//! differences of the loop around the equilibrium (exact for the laws, which are affine there,
//! up to rounding). Left out: the beaconing's sample and hold, losses, attacks, the fallback,
//! the guard and the saturations (none is active at the equilibrium).
use crate::checks::Heard;
use crate::composed::View;
use crate::fallback::{acc_command, Reading};
use crate::radar::{radar_truth, RadarTruth};
use crate::ControllerParams;
use nalgebra::DMatrix;
use platoon_model::{Discretisation, State, VehicleId};
use platoon_topology::Topology;

/// States per follower in [`step_matrix`]: `p`, `v`, `a` and the command of the step before.
pub const STATES: usize = 4;

/// What the loop of a formation is built from: the run's controller parameters (its law,
/// spacing policy, fallback ACC and lengths, step), its graph (whom each vehicle hears, by id)
/// and its plant's discretisation.
#[derive(Debug, Clone, Copy)]
pub struct LoopSpec<'a> {
    /// The controllers' parameters.
    pub params: &'a ControllerParams,
    /// The communication graph, by vehicle id.
    pub topology: &'a Topology,
    /// How the plant moves the followers.
    pub discretisation: Discretisation,
}

/// Why a formation's loop cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LoopError {
    /// The law has no [`crate::Law`].
    #[error("law = \"{0}\" has no formation loop")]
    NoLaw(&'static str),
    /// The formation does not start with the leader, names a vehicle twice or beyond the run.
    #[error("not a formation of this run: {0}")]
    Formation(String),
}

/// The Jacobian of one step of the formation's loop (`STATES * followers` square, followers
/// in road order) at the leader's constant `speed` (m/s), each vehicle `j` with lag `taus[j]`
/// (s; index 0, the leader's, unused). `platoons` lists the lane's platoons in road order, each
/// head first; the first is headed by the leader.
pub fn step_matrix(
    spec: &LoopSpec<'_>,
    platoons: &[Vec<VehicleId>],
    speed: f64,
    taus: &[f64],
) -> Result<DMatrix<f64>, LoopError> {
    let p = spec.params;
    // The paper's law reads its estimates: in the nominal case, every vehicle's state at
    // every step.
    let estimating = p.law.is_paper();
    let law: Box<dyn crate::Law> = match p.law.law(p.fallback.vehicle_length) {
        Some(law) => law,
        None if estimating => Box::new(crate::PaperLaw::new(p)),
        None => return Err(LoopError::NoLaw(p.law.name())),
    };
    let vehicles = spec.topology.followers() + 1;
    let road = road_order(platoons, vehicles.min(taus.len()))?;
    // The equilibrium: each behind the one ahead at the distance it keeps at `speed`.
    let heads_headway = crate::maneuvers::split_headway(&p.fallback.acc, p.headway, f64::INFINITY);
    let mut z0 = vec![0.0; STATES * (road.len() - 1)];
    let mut ahead_p = 0.0;
    for (i, &(v, head)) in road.iter().enumerate().skip(1) {
        let h = if v == head { heads_headway } else { p.headway };
        let at = ahead_p - (p.spacing + h * speed);
        z0[STATES * (i - 1)..STATES * i].copy_from_slice(&[at, speed, 0.0, 0.0]);
        ahead_p = at;
    }
    // Each follower hears every vehicle (its slots: every id but its own).
    let slots = |v: VehicleId| -> Vec<VehicleId> {
        (0..vehicles as u16)
            .map(VehicleId)
            .filter(|&j| j != v)
            .collect()
    };
    let rest = vec![State::new(0.0, speed, 0.0); vehicles];
    let mut laws: Vec<_> = road[1..]
        .iter()
        .map(|&(v, _)| {
            let mut law = dyn_clone::clone_box(&*law);
            law.start(v, spec.topology, &slots(v), &rest);
            law
        })
        .collect();
    // Each vehicle's platoon, head first (the part the paper's law steers in).
    let part_of = |v: VehicleId| {
        platoons
            .iter()
            .find(|pl| pl.contains(&v))
            .map(Vec::as_slice)
    };
    let step = |z: &[f64]| -> Vec<f64> {
        // Every vehicle's state and last command: the leader's, then the followers' from `z`;
        // a vehicle out of the formation keeps the leader's (it is no part of the loop).
        let mut state = vec![(State::new(0.0, speed, 0.0), 0.0); vehicles];
        for (i, &(v, _)) in road.iter().enumerate().skip(1) {
            let s = &z[STATES * (i - 1)..STATES * i];
            state[v.index()] = (State::new(s[0], s[1], s[2]), s[3]);
        }
        let packet = |j: VehicleId| Heard {
            step: Some(0),
            seq: 1,
            state: state[j.index()].0,
            u: state[j.index()].1,
            head: VehicleId::LEADER,
        };
        // What each radar sees: the vehicle ahead in road order.
        let in_road: Vec<State> = road.iter().map(|(v, _)| state[v.index()].0).collect();
        let mut truths: Vec<Option<RadarTruth>> = Vec::with_capacity(road.len());
        radar_truth(
            &in_road,
            |j| p.fallback.length(road[j].0.index()),
            &mut truths,
        );
        let mut next = vec![0.0; z.len()];
        for (i, &(v, head)) in road.iter().enumerate().skip(1) {
            let (own, last_u) = state[v.index()];
            let ahead = road[i - 1].0;
            let length = p.fallback.length(ahead.index());
            let radar = truths[i];
            let u = if v == head {
                let reading = radar.map(|r| Reading {
                    gap: r.gap,
                    closing: r.closing,
                    intruder: false,
                });
                acc_command(
                    &p.fallback.acc,
                    reading,
                    heads_headway,
                    own[1],
                    p.spacing,
                    length,
                )
            } else {
                let neighbours = spec.topology.in_neighbours(v);
                let heard: Vec<Heard> = neighbours.iter().map(|&j| packet(j)).collect();
                let ahead_heard = packet(ahead);
                let head_heard = packet(head);
                let law = &mut laws[i - 1];
                if estimating {
                    exact_estimates(&mut **law, v, &state);
                }
                law.command(&View {
                    k: 0,
                    dt: p.dt,
                    id: v,
                    vehicles,
                    own,
                    last_u,
                    radar,
                    ahead,
                    ahead_heard: Some(&ahead_heard),
                    neighbours,
                    heard: &heard,
                    head: (!head.is_leader()).then_some((head, &head_heard)),
                    part: part_of(v),
                    room: State::zeros(),
                })
            };
            let x = spec.discretisation.step(&own, u, taus[v.index()], p.dt);
            next[STATES * (i - 1)..STATES * i].copy_from_slice(&[x[0], x[1], x[2], u]);
        }
        next
    };
    Ok(central_jacobian(&z0, step))
}

/// The formation's vehicles in road order, each with the head of its platoon (`platoons` in
/// road order, each head first), checked: the leader first, every vehicle one of the run's
/// `vehicles` ids, none twice.
fn road_order(
    platoons: &[Vec<VehicleId>],
    vehicles: usize,
) -> Result<Vec<(VehicleId, VehicleId)>, LoopError> {
    let road: Vec<(VehicleId, VehicleId)> = platoons
        .iter()
        .flat_map(|pl| pl.iter().map(move |&v| (v, pl[0])))
        .collect();
    let bad = |why: String| Err(LoopError::Formation(why));
    if road.first().is_none_or(|(v, _)| !v.is_leader()) {
        return bad("the first platoon is not headed by the leader".into());
    }
    for (i, (v, _)) in road.iter().enumerate() {
        if v.index() >= vehicles {
            return bad(format!("vehicle {} is not one of the run's", v.0));
        }
        if road[..i].iter().any(|(w, _)| w == v) {
            return bad(format!("vehicle {} is named twice", v.0));
        }
    }
    Ok(road)
}

/// The Jacobian of `f` at `z0` by central differences, each step relative to the
/// coordinate's size (`1e-6 max(|z|, 1)`).
fn central_jacobian(z0: &[f64], mut f: impl FnMut(&[f64]) -> Vec<f64>) -> DMatrix<f64> {
    let n = z0.len();
    let mut jacobian = DMatrix::zeros(n, n);
    for c in 0..n {
        let h = 1e-6 * z0[c].abs().max(1.0);
        let mut up = z0.to_vec();
        up[c] += h;
        let mut down = z0.to_vec();
        down[c] -= h;
        let (fu, fd) = (f(&up), f(&down));
        for r in 0..n {
            jacobian[(r, c)] = (fu[r] - fd[r]) / (2.0 * h);
        }
    }
    jacobian
}

/// What the paper's law of vehicle `v` knows in the nominal case: every vehicle's state
/// (`states[j].0`, its slots every id but `v`'s, as `step_matrix` started it) and its own.
fn exact_estimates(law: &mut dyn crate::Law, v: VehicleId, states: &[(State, f64)]) {
    let others = (0..states.len() as u16).map(VehicleId).filter(|&j| j != v);
    for (slot, j) in others.enumerate() {
        law.heard(
            0,
            slot,
            &crate::Packet::beacon(j, 1, 0, states[j.index()].0),
        );
    }
    if let Some(t) = law.triggering() {
        t.sent(0, &states[v.index()].0);
    }
}
