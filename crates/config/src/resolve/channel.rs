//! `[channel]`: the link attacks, the jammers and the 802.11p radio.
use super::{bad, finite, positive, steps_of, Invalid};
use crate::schema::*;
use platoon_attacks::channel::{
    BackgroundBeacons, Dcc, LinkAttack, LinkAttackKind, LoadSource, RadioSpec,
};
use platoon_maneuver::MessageKind;
use platoon_model::VehicleId;

/// `[channel] model` and `[channel.radio]`: the 802.11p model (its table filled with the
/// defaults, so the resolved config says them), built once per distinct configuration in this
/// process (a model costs milliseconds to tabulate; a campaign's cells share it).
pub(super) fn radio(c: &mut Channel, dt: f64) -> Result<Option<RadioSpec>, Invalid> {
    use std::sync::{Arc, Mutex, OnceLock};
    match c.model {
        RadioModel::Ideal => {
            let radio_only = [
                ("channel.radio", c.radio.is_some()),
                ("channel.load", c.load.is_some()),
                ("channel.background_beacons", c.background_beacons.is_some()),
                ("channel.load_window_s", c.load_window_s.is_some()),
                ("channel.dcc", c.dcc.is_some()),
            ];
            if let Some((key, _)) = radio_only.iter().find(|(_, set)| *set) {
                return bad(
                    key,
                    "belongs to the 802.11p radio, but channel.model = \"ideal\": remove it or \
                     set model = \"80211p\"",
                );
            }
            Ok(None)
        }
        RadioModel::Ieee80211p => {
            let params = *c.radio.get_or_insert_with(Default::default);
            let load = match *c.load.get_or_insert(LoadConfig::Scenario) {
                LoadConfig::Scenario => LoadSource::Scenario,
                LoadConfig::Fixed => LoadSource::Fixed,
            };
            // The counted load's keys mean nothing with the fixed one: refused, not ignored
            // (and not filled in, so the resolved config reads back).
            if load == LoadSource::Fixed {
                for (key, set) in [
                    ("channel.background_beacons", c.background_beacons.is_some()),
                    ("channel.load_window_s", c.load_window_s.is_some()),
                ] {
                    if set {
                        return bad(
                            key,
                            "is for the load counted from the run, but channel.load = \"fixed\": \
                             remove it or set load = \"scenario\"",
                        );
                    }
                }
            }
            let background_beacons = match load {
                LoadSource::Fixed => BackgroundBeacons::Fixed,
                LoadSource::Scenario => match *c
                    .background_beacons
                    .get_or_insert(BackgroundBeaconsConfig::Fixed)
                {
                    BackgroundBeaconsConfig::Fixed => BackgroundBeacons::Fixed,
                    BackgroundBeaconsConfig::Platoon => BackgroundBeacons::Platoon,
                },
            };
            let window_s = match load {
                LoadSource::Fixed => 1.0,
                LoadSource::Scenario => positive(
                    "channel.load_window_s",
                    finite("channel.load_window_s", *c.load_window_s.get_or_insert(1.0))?,
                )?,
            };
            let window_steps = steps_of("channel.load_window_s", window_s, dt)?.max(1) as u64;
            let dcc = match &c.dcc {
                None => None,
                Some(d) => Some(dcc(d)?),
            };
            // One family per distinct radio in this process: its models are built as runs
            // reach their loads, and a campaign's cells share them.
            static FAMILIES: OnceLock<Mutex<Vec<Arc<platoon_radio::LoadFamily>>>> = OnceLock::new();
            let families = FAMILIES.get_or_init(Default::default);
            let mut cache = families.lock().unwrap_or_else(|e| e.into_inner());
            let family = match cache.iter().find(|m| *m.params() == params) {
                Some(f) => f.clone(),
                None => {
                    let family = platoon_radio::LoadFamily::new(params).or_else(|e| {
                        let key = match &e {
                            platoon_radio::Error::Parameter { name, .. } => {
                                format!("channel.radio.{name}")
                            }
                            _ => "channel.radio".to_string(),
                        };
                        bad(&key, e.to_string())
                    })?;
                    let family = Arc::new(family);
                    // A handful of configurations at most in one process; keep the latest 16.
                    if cache.len() >= 16 {
                        cache.remove(0);
                    }
                    cache.push(family.clone());
                    family
                }
            };
            Ok(Some(RadioSpec {
                family,
                load,
                background_beacons,
                dcc,
                window_steps,
                dt,
            }))
        }
    }
}

/// `[channel.dcc]`: the reactive states' thresholds and `T_off`s.
fn dcc(d: &DccConfig) -> Result<Dcc, Invalid> {
    let (th, off) = (&d.cbr_thresholds, &d.t_off_s);
    for (i, &x) in th.iter().enumerate() {
        let key = format!("channel.dcc.cbr_thresholds[{i}]");
        if !(x > 0.0 && x < 1.0) {
            return bad(&key, format!("must be in (0, 1) (got {x})"));
        }
        if i > 0 && x <= th[i - 1] {
            return bad(
                &key,
                format!("must be above the one before ({})", th[i - 1]),
            );
        }
    }
    if off.len() != th.len() + 1 {
        return bad(
            "channel.dcc.t_off_s",
            format!(
                "needs one entry per state: {} thresholds make {} states, got {} times",
                th.len(),
                th.len() + 1,
                off.len()
            ),
        );
    }
    for (i, &x) in off.iter().enumerate() {
        let key = format!("channel.dcc.t_off_s[{i}]");
        if !(x.is_finite() && x >= 0.0) {
            return bad(&key, format!("must be a time >= 0 s (got {x})"));
        }
        if i > 0 && x < off[i - 1] {
            return bad(
                &key,
                format!("must not be below the one before ({})", off[i - 1]),
            );
        }
    }
    Ok(Dcc {
        cbr_thresholds: th.clone(),
        t_off_s: off.clone(),
    })
}

/// Three finite numbers, `[p, v, a]`.
fn finite3(key: &str, x: [f64; 3]) -> Result<[f64; 3], Invalid> {
    if x.iter().any(|v| !v.is_finite()) {
        return bad(key, "must be finite");
    }
    Ok(x)
}

/// `[channel]`: the link-level attacks.
pub(super) fn channel(
    c: &Channel,
    dt: f64,
    followers: usize,
    regroups: bool,
) -> Result<(Vec<LinkAttack>, u64), Invalid> {
    let mut out = Vec::with_capacity(c.attacks.len());
    for (i, a) in c.attacks.iter().enumerate() {
        let key = |k: &str| format!("channel.attacks[{i}].{k}");
        let probability = |k: &str, v: f64| {
            if (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                bad(&key(k), format!("must be a probability in [0, 1], got {v}"))
            }
        };
        let ids = |k: &str, v: &Option<Vec<u16>>| -> Result<Vec<VehicleId>, Invalid> {
            let v = v.clone().unwrap_or_default();
            if let Some(bad_id) = v.iter().find(|&&id| usize::from(id) > followers) {
                return bad(
                    &key(k),
                    format!("vehicle {bad_id} does not exist (ids are 0 = leader to {followers})"),
                );
            }
            Ok(v.into_iter().map(VehicleId).collect())
        };
        let message_kind = |k: &str, name: &str| -> Result<MessageKind, Invalid> {
            match MessageKind::from_name(name) {
                Some(m) => Ok(m),
                None => bad(
                    k,
                    format!(
                        "unknown maneuver message {name:?}; use {}",
                        MessageKind::ALL.map(MessageKind::name).join(", ")
                    ),
                ),
            }
        };
        let kind = match a.kind {
            LinkKindConfig::Bernoulli { loss } => LinkAttackKind::Bernoulli {
                loss: probability("loss", finite(&key("loss"), loss)?)?,
            },
            LinkKindConfig::GilbertElliott {
                p_good_bad,
                p_bad_good,
                loss_good,
                loss_bad,
            } => LinkAttackKind::GilbertElliott {
                p_good_bad: probability("p_good_bad", finite(&key("p_good_bad"), p_good_bad)?)?,
                p_bad_good: probability("p_bad_good", finite(&key("p_bad_good"), p_bad_good)?)?,
                loss_good: probability("loss_good", loss_good)?,
                loss_bad: probability("loss_bad", loss_bad)?,
            },
            LinkKindConfig::Delay { delay_s } => LinkAttackKind::Delay {
                steps: steps_of(&key("delay_s"), finite(&key("delay_s"), delay_s)?, dt)?,
            },
            LinkKindConfig::RangeJamming {
                position_m,
                speed_mps,
                radius_m,
            } => LinkAttackKind::RangeJamming {
                position_m: finite(&key("position_m"), position_m)?,
                speed_mps: finite(&key("speed_mps"), speed_mps)?,
                radius_m: positive(&key("radius_m"), finite(&key("radius_m"), radius_m)?)?,
            },
            LinkKindConfig::Replay { lag_s } => LinkAttackKind::Replay {
                lag_steps: u64::from(steps_of(&key("lag_s"), finite(&key("lag_s"), lag_s)?, dt)?),
            },
            LinkKindConfig::FalseData { offset, .. } => LinkAttackKind::FalseData {
                offset: finite3(&key("offset"), offset)?,
            },
            LinkKindConfig::RandomOffset { std, .. } => {
                if std.iter().any(|&x| x < 0.0) {
                    return bad(&key("std"), format!("must be >= 0 (got {std:?})"));
                }
                LinkAttackKind::RandomOffset {
                    std: finite3(&key("std"), std)?,
                }
            }
            LinkKindConfig::Drift { rate, .. } => LinkAttackKind::Drift {
                rate: finite3(&key("rate"), rate)?,
            },
            LinkKindConfig::FeignedBraking { accel_mps2, .. } => LinkAttackKind::FeignedBraking {
                accel: finite(&key("accel_mps2"), accel_mps2)?,
            },
            LinkKindConfig::AccelScale { factor, .. } => LinkAttackKind::AccelScale {
                factor: finite(&key("factor"), factor)?,
            },
            LinkKindConfig::ForgedHead { .. } => LinkAttackKind::ForgedHead,
            LinkKindConfig::JamManeuvers { ref messages } => {
                let mut kinds = 0;
                for m in messages {
                    kinds |= message_kind(&key("messages"), m)?.bit();
                }
                LinkAttackKind::JamManeuvers {
                    kinds: if messages.is_empty() { u16::MAX } else { kinds },
                }
            }
            LinkKindConfig::ForgeManeuver { ref message, .. } => {
                let message = message_kind(&key("message"), message)?;
                if !matches!(
                    message,
                    MessageKind::JoinRequest
                        | MessageKind::LeaveNotice
                        | MessageKind::InPosition
                        | MessageKind::SplitNotice
                ) {
                    return bad(
                        &key("message"),
                        format!(
                            "{:?} cannot be forged; use \"join_request\", \"leave_notice\", \
                             \"in_position\" or \"split_notice\"",
                            message.name()
                        ),
                    );
                }
                if message == MessageKind::SplitNotice && !regroups {
                    // Who heads whom is followed only in runs that merge or split.
                    return bad(
                        &key("message"),
                        "a forged split notice needs a run whose platoon may split: give \
                         [maneuvers.split] (or [maneuvers.merge])"
                            .to_string(),
                    );
                }
                LinkAttackKind::ForgeManeuver { message }
            }
        };
        let insider = a.kind.insider();
        if insider && a.receivers.is_some() {
            return bad(
                &key("insider"),
                "an insider's broadcast reaches every receiver alike: drop `receivers`",
            );
        }
        let start_s = finite(&key("start_s"), a.start_s)?;
        let end_s = a.end_s;
        if end_s.is_nan() || end_s <= start_s {
            return bad(&key("end_s"), format!("must be after start_s = {start_s}"));
        }
        out.push(LinkAttack {
            kind,
            start_s,
            end_s,
            senders: ids("senders", &a.senders)?,
            receivers: ids("receivers", &a.receivers)?,
            insider,
        });
    }
    Ok((out, c.seed))
}

/// `[[channel.jammers]]`: jammers as transmitters. Each is heard above the sensing threshold out
/// to the radio's sensing radius for its power (`[channel.radio]`, its defaults without one),
/// and senses the vehicles out to theirs.
pub(super) fn jammers(
    c: &Config,
    followers: usize,
    dt: f64,
) -> Result<Vec<platoon_attacks::jammer::Jammer>, Invalid> {
    use crate::schema::JammerBehaviour as B;
    use platoon_attacks::jammer::{Behaviour, Jammer, Placement};
    let radio = c.channel.radio.unwrap_or_default();
    let mut out = Vec::with_capacity(c.channel.jammers.len());
    for (i, j) in c.channel.jammers.iter().enumerate() {
        let key = |k: &str| format!("channel.jammers[{i}].{k}");
        let lateral_m = finite(&key("lateral_m"), j.lateral_m)?;
        if lateral_m < 0.0 {
            return bad(&key("lateral_m"), format!("must be >= 0 (got {lateral_m})"));
        }
        let speed_mps = finite(&key("speed_mps"), j.speed_mps)?;
        let placement = match (j.position_m, j.member, j.background) {
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
        };
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
        let behaviour = match kind {
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
        };
        out.push(Jammer {
            placement,
            power_dbm,
            start_s,
            end_s: j.end_s,
            behaviour,
            heard_m,
            senses_m: radio.sensing_radius_m(radio.tx_power_dbm),
        });
    }
    Ok(out)
}
