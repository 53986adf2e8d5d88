//! `[vehicle_classes]` and `[platoon] members`: each vehicle's class (docs/traffic.md#mixed-vehicles).
use super::checks::{bad, finite, positive};
use super::plant::tau_schedule;
use crate::error::KeyError;
use crate::schema::*;
use platoon_model::{LeaderProfile, State, TauSchedule};
use platoon_sim::Vehicle;

/// One member's class, checked: its name, the class and its true lag (if the class gives one).
pub(crate) struct Member<'a> {
    name: &'a str,
    class: &'a VehicleClass,
    tau: Option<TauSchedule>,
}

impl Member<'_> {
    /// Its length (m).
    pub(crate) fn length(&self) -> f64 {
        self.class.length_m
    }

    /// The key that gives its length.
    pub(crate) fn length_key(&self) -> String {
        format!("vehicle_classes.{}.length_m", self.name)
    }
}

/// The members of the platoon (leader first) with their classes, each class checked; empty
/// without `platoon.members`.
pub(crate) fn members(c: &Config, n: usize) -> Result<Vec<Member<'_>>, KeyError> {
    let classes = &c.vehicle_classes;
    let Some(members) = &c.platoon.members else {
        if let Some(name) = classes.keys().next() {
            return bad(
                &format!("vehicle_classes.{name}"),
                "defines a class, but platoon.members assigns none: list each vehicle's class \
                 there (the leader first)",
            );
        }
        return Ok(Vec::new());
    };
    // Each name with the key that gave it.
    let names: Vec<(&String, String)> = match members {
        Members::Every(name) => vec![(name, "platoon.members".to_string()); n + 1],
        Members::Each(names) if names.len() == n + 1 => names
            .iter()
            .enumerate()
            .map(|(i, name)| (name, format!("platoon.members[{i}]")))
            .collect(),
        Members::Each(names) => {
            return bad(
                "platoon.members",
                format!(
                    "lists {} vehicles but platoon.followers = {n} needs {} (the leader first; \
                     or name one class for every vehicle, members = \"car\")",
                    names.len(),
                    n + 1
                ),
            )
        }
    };
    let mut checked = std::collections::BTreeMap::new();
    for (name, class) in classes {
        let key = |k: &str| format!("vehicle_classes.{name}.{k}");
        if finite(&key("length_m"), class.length_m)? < 0.0 {
            return bad(
                &key("length_m"),
                format!("must be >= 0, got {}", class.length_m),
            );
        }
        if let Some(a) = class.accel_max_mps2 {
            positive(&key("accel_max_mps2"), a)?;
        }
        if let Some(d) = class.decel_max_mps2 {
            positive(&key("decel_max_mps2"), d)?;
        }
        if let Some(e) = class.emergency_decel_mps2 {
            positive(&key("emergency_decel_mps2"), e)?;
            match class.decel_max_mps2 {
                Some(d) if e >= d => {}
                Some(d) => {
                    return bad(
                        &key("emergency_decel_mps2"),
                        format!(
                            "{e} m/s^2 is below decel_max_mps2 = {d}: the guard's braking is the \
                             harder one"
                        ),
                    )
                }
                None => {
                    return bad(
                        &key("emergency_decel_mps2"),
                        "needs decel_max_mps2, the braking it goes beyond",
                    )
                }
            }
        }
        let tau = match (class.tau_s, &class.tau) {
            (Some(_), Some(_)) => {
                return bad(
                    &key("tau"),
                    "give either tau_s (a constant) or tau, not both",
                )
            }
            (Some(t), None) => Some(
                TauSchedule::constant(positive(&key("tau_s"), t)?)
                    .or_else(|e| bad(&key("tau_s"), e.to_string()))?,
            ),
            (None, Some(t)) => Some(tau_schedule(&key("tau"), t)?),
            (None, None) => None,
        };
        if let Some([lo, hi]) = class.tau_range_s {
            if !(finite(&key("tau_range_s"), lo)? > 0.0 && finite(&key("tau_range_s"), hi)? >= lo) {
                return bad(
                    &key("tau_range_s"),
                    format!("[{lo}, {hi}] must be [lo, hi] with 0 < lo <= hi"),
                );
            }
        }
        checked.insert(name.as_str(), (class, tau));
    }
    names
        .into_iter()
        .map(|(name, key)| match checked.get(name.as_str()) {
            Some((class, tau)) => Ok(Member {
                name,
                class,
                tau: tau.clone(),
            }),
            None => bad(
                &key,
                format!(
                    "unknown vehicle class \"{name}\": [vehicle_classes] defines {}",
                    if classes.is_empty() {
                        "none".to_string()
                    } else {
                        classes
                            .keys()
                            .map(|k| format!("\"{k}\""))
                            .collect::<Vec<_>>()
                            .join(", ")
                    }
                ),
            ),
        })
        .collect()
}

/// The members' vehicles for the scenario, and each follower's true lag with the classes'
/// (`taus` as `[plant]` gave them). Checks that every range contains its member's lag, that
/// no follower's lag is given twice, and that the initial accelerations and the leader's
/// profile keep within the limits.
pub(crate) fn vehicles(
    c: &Config,
    members: &[Member<'_>],
    taus: &mut [TauSchedule],
    tau_nominal: f64,
    leader: &LeaderProfile,
    initial: &[State],
) -> Result<Vec<Vehicle>, KeyError> {
    let mut out = Vec::with_capacity(members.len());
    for (i, m) in members.iter().enumerate() {
        let key = |k: &str| format!("vehicle_classes.{}.{k}", m.name);
        let class = m.class;
        if i > 0 {
            if let Some(t) = &m.tau {
                if c.plant.tau_per_vehicle.is_some() {
                    return bad(
                        "plant.tau_per_vehicle",
                        format!(
                            "gives follower {i} a lag that its class \"{}\" gives too: give it \
                             in one place",
                            m.name
                        ),
                    );
                }
                taus[i - 1] = t.clone();
            }
        }
        let own = if i > 0 {
            taus[i - 1].range()
        } else {
            (tau_nominal, tau_nominal)
        };
        let range = match class.tau_range_s {
            Some([lo, hi]) => {
                if i > 0 && (own.0 < lo || own.1 > hi) {
                    return bad(
                        &key("tau_range_s"),
                        format!(
                            "[{lo}, {hi}] does not contain the lag of follower {i} (of class \
                             \"{}\"), which runs from {} to {} s",
                            m.name, own.0, own.1
                        ),
                    );
                }
                (lo, hi)
            }
            None => own,
        };
        let limits = |a: f64, what: &str| -> Result<(), KeyError> {
            if let Some(max) = class.accel_max_mps2.filter(|&max| a > max) {
                return bad(
                    what,
                    format!(
                        "accelerates at {a} m/s^2, more than its class \"{}\" allows \
                         (accel_max_mps2 = {max})",
                        m.name
                    ),
                );
            }
            if let Some(max) = class.decel_max_mps2.filter(|&max| -a > max) {
                return bad(
                    what,
                    format!(
                        "brakes at {} m/s^2, more than its class \"{}\" allows \
                         (decel_max_mps2 = {max})",
                        -a, m.name
                    ),
                );
            }
            Ok(())
        };
        if i == 0 {
            // The leader drives its profile: the class's limits must hold for it.
            for w in leader.waypoints().windows(2) {
                limits((w[1].1 - w[0].1) / (w[1].0 - w[0].0), "leader.profile")?;
            }
        } else {
            limits(initial[i][2], &format!("platoon.initial_states[{i}]"))?;
        }
        out.push(Vehicle {
            class: m.name.to_string(),
            length_m: class.length_m,
            accel_max_mps2: class.accel_max_mps2,
            decel_max_mps2: class.decel_max_mps2,
            emergency_decel_mps2: class.emergency_decel_mps2,
            tau_range_s: range,
        });
    }
    Ok(out)
}
