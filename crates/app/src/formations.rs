//! The stability certificate of every formation a run visited (`summary.json`'s
//! `maneuvers.formations[].stability`): its nominal closed loop under the run's law
//! (`platoon_control::formation_loop`) at every corner of the members' lag box, and the LMI
//! of a common quadratic Lyapunov function over them (`platoon_synthesis::cascade_decay`).
//! What it says and does not: docs/maneuvers.md#what-holds-during-a-formation-change.
use platoon_control::formation_loop::{step_matrix, LoopSpec, STATES};
use platoon_model::VehicleId;
use platoon_sim::{FormationStability, Scenario, Summary};

/// The most followers a formation may have for its certificate: the SDP has
/// `n (n + 1) / 2` unknowns for `n = 4 x followers` where the loop is no cascade.
pub const MAX_FOLLOWERS: usize = 10;

/// The most members with a lag range (a corner of their box is a map: `2^m` of them).
pub const MAX_LAG_RANGES: usize = 10;

/// Checks every formation of `summary`'s maneuvers (platoon 0's) under `scenario`, once per
/// formation and speed; nothing for a run that did not complete (stopped, or failed).
pub fn certify(scenario: &Scenario, summary: &mut Summary) {
    if !summary.complete {
        return;
    }
    let Some(maneuvers) = summary.maneuvers.as_mut() else {
        return;
    };
    let formations = &mut maneuvers.formations;
    for i in 0..formations.len() {
        let (before, rest) = formations.split_at_mut(i);
        let f = &mut rest[0];
        let seen = before
            .iter()
            .find(|g| g.platoons == f.platoons && g.speed_mps.to_bits() == f.speed_mps.to_bits())
            .and_then(|g| g.stability.clone());
        f.stability = Some(seen.unwrap_or_else(|| check(scenario, &f.platoons, f.speed_mps)));
    }
}

/// One formation's certificate: its loop's one-step maps at every corner of the members' lag
/// box (each member's lowest and highest lag, the others' independently), then a common
/// quadratic Lyapunov function over them (`cascade_decay`).
pub fn check(scenario: &Scenario, platoons: &[Vec<u16>], speed: f64) -> FormationStability {
    let unchecked = |why: String| FormationStability {
        spectral_radius: None,
        decay_per_s: None,
        unchecked: Some(why),
    };
    let followers = platoons
        .iter()
        .map(Vec::len)
        .sum::<usize>()
        .saturating_sub(1);
    if followers == 0 {
        return unchecked("no follower".into());
    }
    if followers > MAX_FOLLOWERS {
        return unchecked(format!(
            "{followers} followers: certificates are computed for at most {MAX_FOLLOWERS}"
        ));
    }
    let spec = LoopSpec {
        params: &scenario.control,
        topology: &scenario.topology,
        discretisation: scenario.discretisation,
    };
    let platoons: Vec<Vec<VehicleId>> = platoons
        .iter()
        .map(|p| p.iter().map(|&v| VehicleId(v)).collect())
        .collect();
    // Each vehicle's lag range by id (the leader's unused), and the members whose range is
    // more than a point.
    let ranges: Vec<(f64, f64)> =
        std::iter::once((scenario.control.tau_nominal, scenario.control.tau_nominal))
            .chain(scenario.member_tau_ranges())
            .collect();
    let members: Vec<usize> = platoons
        .iter()
        .flatten()
        .map(|v| v.index())
        .filter(|&i| i > 0)
        .collect();
    if members.iter().any(|&i| i >= ranges.len()) {
        return unchecked("a member is no vehicle of the run".into());
    }
    let free: Vec<usize> = members
        .iter()
        .copied()
        .filter(|&i| ranges[i].0 < ranges[i].1)
        .collect();
    if free.len() > MAX_LAG_RANGES {
        return unchecked(format!(
            "{} members with a lag range: certificates take at most {MAX_LAG_RANGES}",
            free.len()
        ));
    }
    let lows: Vec<f64> = ranges.iter().map(|r| r.0).collect();
    let map = |taus: &[f64]| step_matrix(&spec, &platoons, speed, taus);
    let low = match map(&lows) {
        Ok(m) => m,
        Err(e) => return unchecked(e.to_string()),
    };
    // The map is affine in each member's lag term, and only that member's rows depend on it:
    // a corner is the lowest lags' map plus the change each member at its highest makes.
    let mut changes = Vec::with_capacity(free.len());
    for &i in &free {
        let mut taus = lows.clone();
        taus[i] = ranges[i].1;
        match map(&taus) {
            Ok(m) => changes.push(m - &low),
            Err(e) => return unchecked(e.to_string()),
        }
    }
    let corners: Vec<_> = (0..1usize << free.len())
        .map(|mask| {
            changes
                .iter()
                .enumerate()
                .filter(|(j, _)| mask & (1 << j) != 0)
                .fold(low.clone(), |acc, (_, d)| acc + d)
        })
        .collect();
    debug_assert!(corners.iter().all(|m| m.nrows() == STATES * followers));
    match platoon_synthesis::cascade_decay(&corners, scenario.dt(), STATES) {
        Ok(d) => FormationStability {
            spectral_radius: Some(d.spectral_radius),
            decay_per_s: d.decay_per_s,
            unchecked: None,
        },
        Err(e) => unchecked(e.to_string()),
    }
}
