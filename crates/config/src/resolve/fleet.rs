//! `[fleet]`: identical, independent platoons on one road.
use super::checks::{bad, finite};
use crate::error::KeyError;
use crate::schema::FleetConfig;
use platoon_model::State;
use platoon_sim::Fleet;

/// Vehicles of a whole fleet at most.
pub(crate) const MAX_VEHICLES: usize = 1_000_000;

/// The lanes the platoons drive on: `fleet.lanes`, or the platoon's `sumo.lane`.
pub(crate) fn lanes(f: &FleetConfig, lane: u32) -> Vec<u32> {
    f.lanes.clone().unwrap_or_else(|| vec![lane])
}

/// `[fleet]` of platoons of `n` followers starting at `initial` (vehicles at most `longest`
/// long) on `lanes`: platoons that share a lane must not overlap.
pub(crate) fn fleet(
    f: &FleetConfig,
    lanes: Vec<u32>,
    n: usize,
    initial: &[State],
    longest: f64,
) -> Result<Fleet, KeyError> {
    if f.platoons == 0 {
        return bad("fleet.platoons", "needs at least one platoon");
    }
    if f.platoons.saturating_mul(n + 1) > MAX_VEHICLES {
        return bad(
            "fleet.platoons",
            format!(
                "{} platoons of {} vehicles is more than {MAX_VEHICLES} vehicles",
                f.platoons,
                n + 1
            ),
        );
    }
    if lanes.is_empty() {
        return bad("fleet.lanes", "needs at least one lane");
    }
    if f.platoons > lanes.len() {
        let (lo, hi) = initial
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x[0]), hi.max(x[0]))
            });
        let length = hi - lo + longest;
        if finite("fleet.gap_m", f.gap_m)? <= length {
            return bad(
                "fleet.gap_m",
                format!(
                    "{} m is not more than a platoon's length ({length} m): platoons on one lane would overlap",
                    f.gap_m
                ),
            );
        }
    }
    Ok(Fleet {
        platoons: f.platoons,
        lanes,
        gap_m: f.gap_m,
    })
}
