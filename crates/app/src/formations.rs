//! The stability certificate of every formation a run visited (`summary.json`'s
//! `maneuvers.formations[].stability`): its nominal closed loop under the run's law
//! (`platoon_control::formation_loop`) at the ends of the members' lag range, and the LMI of a
//! common quadratic Lyapunov function over them (`platoon_synthesis::common_decay`). What it
//! says and does not: docs/maneuvers.md#what-holds-during-a-formation-change.
use platoon_control::formation_loop::{step_matrix, LoopSpec, STATES};
use platoon_model::VehicleId;
use platoon_sim::{FormationStability, Scenario, Summary};

/// The most followers a formation may have for its certificate: the SDP has
/// `n (n + 1) / 2` unknowns for `n = 4 x followers`.
pub const MAX_FOLLOWERS: usize = 10;

/// Checks every formation of `summary`'s maneuvers (platoon 0's) under `scenario`.
pub fn certify(scenario: &Scenario, summary: &mut Summary) {
    let Some(maneuvers) = summary.maneuvers.as_mut() else {
        return;
    };
    for f in &mut maneuvers.formations {
        f.stability = Some(check(scenario, &f.platoons, f.speed_mps));
    }
}

/// One formation's certificate.
pub fn check(scenario: &Scenario, platoons: &[Vec<u16>], speed: f64) -> FormationStability {
    let unchecked = |why: String| FormationStability {
        spectral_radius: f64::NAN,
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
    // The ends of the lag range: every member at its lowest, then at its highest.
    let ranges = scenario.member_tau_ranges();
    let mut maps = Vec::with_capacity(2);
    for end in [0, 1] {
        let taus: Vec<f64> = std::iter::once(scenario.control.tau_nominal)
            .chain(
                ranges
                    .iter()
                    .map(|&(lo, hi)| if end == 0 { lo } else { hi }),
            )
            .collect();
        match step_matrix(&spec, &platoons, speed, &taus) {
            Ok(m) => maps.push(m),
            Err(e) => return unchecked(e.to_string()),
        }
    }
    debug_assert!(maps.iter().all(|m| m.nrows() == STATES * followers));
    match platoon_synthesis::cascade_decay(&maps, scenario.dt(), STATES) {
        Ok(d) => FormationStability {
            spectral_radius: d.spectral_radius,
            decay_per_s: d.decay_per_s,
            unchecked: None,
        },
        Err(e) => unchecked(e.to_string()),
    }
}
