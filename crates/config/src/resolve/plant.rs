//! `[plant]`: the vehicles' lags and how the native plant integrates them.
use super::checks::{bad, positive};
use crate::error::KeyError;
use crate::schema::{Plant, PlantKind, TauConfig};
use platoon_model::{Discretisation, TauSchedule};

/// A `tau` table (`plant.tau`, a class's `tau`) at `key`.
pub(crate) fn tau_schedule(key: &str, t: &TauConfig) -> Result<TauSchedule, KeyError> {
    let r = match t {
        TauConfig::Paper {} => Ok(TauSchedule::paper()),
        TauConfig::Constant { value_s } => TauSchedule::constant(*value_s),
        TauConfig::Knots {
            knots,
            interpolation,
        } => TauSchedule::new(knots.iter().map(|k| (k[0], k[1])).collect(), *interpolation),
    };
    r.or_else(|e| bad(key, e.to_string()))
}

/// `plant.tau_nominal_s`: the lag the estimators assume.
pub(crate) fn tau_nominal(p: &Plant) -> Result<f64, KeyError> {
    positive("plant.tau_nominal_s", p.tau_nominal_s)
}

/// Each of the `n` followers' true lag as `[plant]` gives it (`tau`, or `tau_per_vehicle`);
/// vehicle classes may replace them.
pub(crate) fn taus(p: &Plant, n: usize) -> Result<Vec<TauSchedule>, KeyError> {
    match &p.tau_per_vehicle {
        None => {
            let s = tau_schedule("plant.tau", &p.tau)?;
            Ok(vec![s; n])
        }
        Some(list) => {
            if list.len() != n {
                return bad(
                    "plant.tau_per_vehicle",
                    format!("has {} entries, platoon.followers = {n}", list.len()),
                );
            }
            list.iter()
                .enumerate()
                .map(|(i, t)| tau_schedule(&format!("plant.tau_per_vehicle[{i}]"), t))
                .collect()
        }
    }
}

/// `plant.discretisation`, which only the native plant (`simulation.plant`) takes.
pub(crate) fn discretisation(p: &Plant, plant: PlantKind) -> Result<Discretisation, KeyError> {
    if p.discretisation != Discretisation::Exact && plant == PlantKind::Sumo {
        return bad(
            "plant.discretisation",
            "the SUMO plant moves vehicles its own way; \"plexe\" is for the native plant \
             (simulation.plant = \"native\")",
        );
    }
    Ok(p.discretisation)
}
