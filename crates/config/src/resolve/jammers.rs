//! `[[channel.jammers]]`: jammers as transmitters.
use super::checks::{bad, finite};
use crate::error::KeyError;
use crate::schema::{Config, JammerBehaviour as B, JammerConfig, PlantKind};
use platoon_attacks::jammer::{Behaviour, Jammer, Placement};
use platoon_model::VehicleId;
use platoon_radio::Params80211p;

/// `[[channel.jammers]]`: jammers as transmitters. Each is heard above the sensing threshold out
/// to the radio's sensing radius for its power (`[channel.radio]`, its defaults without one),
/// and senses the vehicles out to theirs.
pub(crate) fn jammers(c: &Config, followers: usize, dt: f64) -> Result<Vec<Jammer>, KeyError> {
    let radio = c.channel.radio.unwrap_or_default();
    c.channel
        .jammers
        .iter()
        .enumerate()
        .map(|(i, j)| jammer(c, j, &Key(i), followers, dt, &radio))
        .collect()
}

/// The keys of `[[channel.jammers]]` entry `.0`.
struct Key(usize);

impl Key {
    fn of(&self, k: &str) -> String {
        format!("channel.jammers[{}].{k}", self.0)
    }
}

/// One jammer of a platoon of `followers`, at a step of `dt`, with the platoon's `radio`.
fn jammer(
    c: &Config,
    j: &JammerConfig,
    at: &Key,
    followers: usize,
    dt: f64,
    radio: &Params80211p,
) -> Result<Jammer, KeyError> {
    let key = |k: &str| at.of(k);
    let lateral_m = finite(&key("lateral_m"), j.lateral_m)?;
    if lateral_m < 0.0 {
        return bad(&key("lateral_m"), format!("must be >= 0 (got {lateral_m})"));
    }
    let speed_mps = finite(&key("speed_mps"), j.speed_mps)?;
    let placement = placement(c, j, at, followers, lateral_m, speed_mps)?;
    if j.offset_m.is_some() && j.member.is_none() {
        return bad(
            &key("offset_m"),
            "is the offset from a member; give member too",
        );
    }
    if speed_mps != 0.0 && j.position_m.is_none() {
        return bad(
            &key("speed_mps"),
            "only a roadside jammer (position_m) has its own speed",
        );
    }
    let power_dbm = finite(&key("power_dbm"), j.power_dbm)?;
    if !(-30.0..=60.0).contains(&power_dbm) {
        return bad(
            &key("power_dbm"),
            format!("must be in [-30, 60] dBm (1 µW to 1 kW), got {power_dbm}"),
        );
    }
    let heard_m = radio.sensing_radius_m(power_dbm);
    if heard_m <= 0.0 {
        return bad(
            &key("power_dbm"),
            format!(
                "{power_dbm} dBm is below the sensing threshold ({} dBm) even at 1 m",
                radio.sensing_threshold_dbm
            ),
        );
    }
    let start_s = finite(&key("start_s"), j.start_s)?;
    if start_s < 0.0 {
        return bad(&key("start_s"), format!("must be >= 0 s (got {start_s})"));
    }
    if j.end_s.is_nan() || j.end_s <= start_s {
        return bad(&key("end_s"), format!("must be after start_s = {start_s}"));
    }
    Ok(Jammer {
        placement,
        power_dbm,
        start_s,
        end_s: j.end_s,
        behaviour: behaviour(j, at, dt)?,
        heard_m,
        senses_m: radio.sensing_radius_m(radio.tx_power_dbm),
    })
}

/// Where the jammer is: roadside (`position_m`), on a member (`member`) or on a SUMO background
/// vehicle (`background`), exactly one of them.
fn placement(
    c: &Config,
    j: &JammerConfig,
    at: &Key,
    followers: usize,
    lateral_m: f64,
    speed_mps: f64,
) -> Result<Placement, KeyError> {
    let key = |k: &str| at.of(k);
    Ok(match (j.position_m, j.member, j.background) {
        (Some(x), None, None) => Placement::Roadside {
            position_m: finite(&key("position_m"), x)?,
            speed_mps,
            lateral_m,
        },
        (None, Some(v), None) => {
            if usize::from(v) > followers {
                return bad(
                    &key("member"),
                    format!("vehicle {v} does not exist (ids are 0 = leader to {followers})"),
                );
            }
            Placement::Member {
                vehicle: VehicleId(v),
                offset_m: finite(&key("offset_m"), j.offset_m.unwrap_or(0.0))?,
                lateral_m,
            }
        }
        (None, None, Some(index)) => {
            let bg = c.sumo.background_vehicles;
            if c.simulation.plant != PlantKind::Sumo || index >= bg {
                return bad(
                    &key("background"),
                    format!(
                        "rides SUMO background vehicle bg{index}: needs simulation.plant = \"sumo\" \
                         and sumo.background_vehicles > {index} (it is {bg})"
                    ),
                );
            }
            Placement::Background { index, lateral_m }
        }
        (None, None, None) => {
            return bad(
                &key("position_m"),
                "missing: give position_m (roadside), member (a platoon vehicle) or \
                 background (a SUMO background vehicle)",
            )
        }
        _ => {
            return bad(
                &key("position_m"),
                "give only one of position_m, member and background",
            )
        }
    })
}

/// When it jams: constantly, reactively, on and off periodically or at random, on and off
/// times of at least a step of `dt` (the channel changes only from step to step).
fn behaviour(j: &JammerConfig, at: &Key, dt: f64) -> Result<Behaviour, KeyError> {
    let key = |k: &str| at.of(k);
    let periodic = j.on_s.is_some() || j.off_s.is_some();
    let random = j.mean_on_s.is_some() || j.mean_off_s.is_some();
    let kind = j
        .behaviour
        .unwrap_or(if periodic { B::Periodic } else { B::Constant });
    if periodic && kind != B::Periodic {
        return bad(
            &key("on_s"),
            "on_s and off_s are for behaviour = \"periodic\"",
        );
    }
    if random && kind != B::Random {
        return bad(
            &key("mean_on_s"),
            "mean_on_s and mean_off_s are for behaviour = \"random\"",
        );
    }
    // On and off times of at least a step: the channel changes only from step to step.
    let time = |k: &str, v: Option<f64>, what: &str| match v {
        Some(v) if finite(&key(k), v)? >= dt => Ok(v),
        Some(v) => bad(
            &key(k),
            format!("must be at least one step ({dt} s), got {v}"),
        ),
        None => bad(&key(k), format!("a {what} jammer needs it")),
    };
    Ok(match kind {
        B::Constant => Behaviour::Constant,
        B::Reactive => Behaviour::Reactive,
        B::Periodic => {
            if j.on_s.is_none() {
                return bad(&key("on_s"), "a periodic jammer needs both on_s and off_s");
            }
            if j.off_s.is_none() {
                return bad(&key("off_s"), "a periodic jammer needs both on_s and off_s");
            }
            Behaviour::Periodic {
                on_s: time("on_s", j.on_s, "periodic")?,
                off_s: time("off_s", j.off_s, "periodic")?,
            }
        }
        B::Random => Behaviour::Random {
            mean_on_s: time("mean_on_s", j.mean_on_s, "random")?,
            mean_off_s: time("mean_off_s", j.mean_off_s, "random")?,
        },
    })
}
