//! `[[channel.attacks]]`: the link-level attacks on the V2V channel.
use super::checks::{bad, finite, positive, steps_of};
use crate::error::KeyError;
use crate::schema::{ActsAsConfig, Channel, LinkAttackConfig, LinkKindConfig};
use platoon_attacks::channel::{ActsAs, LinkAttack, LinkAttackKind};
use platoon_maneuver::MessageKind;
use platoon_model::VehicleId;

/// Three finite numbers, `[p, v, a]`.
fn finite3(key: &str, x: [f64; 3]) -> Result<[f64; 3], KeyError> {
    if x.iter().any(|v| !v.is_finite()) {
        return bad(key, "must be finite");
    }
    Ok(x)
}

/// `[channel]`: the link-level attacks (`[[channel.attacks]]`) on a platoon of `followers`
/// (`regroups`: one that may merge or split), at a step of `dt`, and the channel's seed.
pub(crate) fn channel(
    c: &Channel,
    dt: f64,
    followers: usize,
    regroups: bool,
) -> Result<(Vec<LinkAttack>, u64), KeyError> {
    let attacks = c.attacks.iter().enumerate();
    let attacks = attacks.map(|(i, a)| attack(a, i, dt, followers, regroups));
    Ok((attacks.collect::<Result<_, _>>()?, c.seed))
}

/// `[[channel.attacks]]` entry `i`.
fn attack(
    a: &LinkAttackConfig,
    i: usize,
    dt: f64,
    followers: usize,
    regroups: bool,
) -> Result<LinkAttack, KeyError> {
    let key = |k: &str| format!("channel.attacks[{i}].{k}");
    let ids = |k: &str, v: &Option<Vec<u16>>| -> Result<Vec<VehicleId>, KeyError> {
        let v = v.clone().unwrap_or_default();
        if let Some(bad_id) = v.iter().find(|&&id| usize::from(id) > followers) {
            return bad(
                &key(k),
                format!("vehicle {bad_id} does not exist (ids are 0 = leader to {followers})"),
            );
        }
        Ok(v.into_iter().map(VehicleId).collect())
    };
    let kind = kind(a, i, dt, regroups)?;
    let acts_as = acts_as(a, &kind, &key, followers)?;
    if acts_as == ActsAs::Insider && a.receivers.is_some() {
        let named = if a.acts_as.is_some() {
            "acts_as"
        } else {
            "insider"
        };
        return bad(
            &key(named),
            "an insider's broadcast reaches every receiver alike: drop `receivers`",
        );
    }
    let start_s = finite(&key("start_s"), a.start_s)?;
    let end_s = a.end_s;
    if end_s.is_nan() || end_s <= start_s {
        return bad(&key("end_s"), format!("must be after start_s = {start_s}"));
    }
    Ok(LinkAttack {
        kind,
        start_s,
        end_s,
        senders: ids("senders", &a.senders)?,
        receivers: ids("receivers", &a.receivers)?,
        acts_as,
    })
}

/// Whom attack `a` acts as (`acts_as`, `key_of`, the older `insider = true`) in a platoon of
/// `followers`; `key` names its keys.
fn acts_as(
    a: &LinkAttackConfig,
    kind: &LinkAttackKind,
    key: &dyn Fn(&str) -> String,
    followers: usize,
) -> Result<ActsAs, KeyError> {
    let insider = a.kind.insider();
    let said = match a.acts_as {
        None if insider => ActsAsConfig::Insider,
        None => ActsAsConfig::Outsider,
        Some(ActsAsConfig::Insider) => ActsAsConfig::Insider,
        Some(other) if insider => {
            return bad(
                &key("acts_as"),
                format!(
                    "{:?} contradicts `insider = true`: drop one of them",
                    acts_as_name(other)
                ),
            )
        }
        Some(other) => other,
    };
    if said != ActsAsConfig::Outsider && !kind.alters_state() {
        return bad(
            &key("acts_as"),
            format!(
                "a `{}` attack alters nothing a key could sign: only false_data, \
                 random_offset, drift, feigned_braking, accel_scale, forged_head and \
                 forge_maneuver act as insiders or thieves",
                a.kind.name()
            ),
        );
    }
    match (said, a.key_of) {
        (ActsAsConfig::Thief, None) => bad(
            &key("key_of"),
            "a thief signs with a member's stolen key: say whose (0 = the leader)",
        ),
        (ActsAsConfig::Thief, Some(m)) if usize::from(m) > followers => bad(
            &key("key_of"),
            format!("vehicle {m} does not exist (ids are 0 = leader to {followers})"),
        ),
        (ActsAsConfig::Thief, Some(m)) => Ok(ActsAs::Thief {
            key_of: VehicleId(m),
        }),
        (_, Some(_)) => bad(
            &key("key_of"),
            "only a thief (`acts_as = \"thief\"`) holds another member's key",
        ),
        (ActsAsConfig::Insider, None) => Ok(ActsAs::Insider),
        (ActsAsConfig::Outsider, None) => Ok(ActsAs::Outsider),
    }
}

fn acts_as_name(a: ActsAsConfig) -> &'static str {
    match a {
        ActsAsConfig::Outsider => "outsider",
        ActsAsConfig::Insider => "insider",
        ActsAsConfig::Thief => "thief",
    }
}

/// The attack's `kind` and its keys.
fn kind(
    a: &LinkAttackConfig,
    i: usize,
    dt: f64,
    regroups: bool,
) -> Result<LinkAttackKind, KeyError> {
    let key = |k: &str| format!("channel.attacks[{i}].{k}");
    let probability = |k: &str, v: f64| {
        if (0.0..=1.0).contains(&v) {
            Ok(v)
        } else {
            bad(&key(k), format!("must be a probability in [0, 1], got {v}"))
        }
    };
    let message_kind = |k: &str, name: &str| -> Result<MessageKind, KeyError> {
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
    Ok(match a.kind {
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
    })
}
