//! `[channel] model`, `[channel.radio]` and `[channel.dcc]`: the 802.11p radio.
use super::checks::{bad, finite, positive, steps_of};
use crate::error::KeyError;
use crate::schema::{BackgroundBeaconsConfig, Channel, DccConfig, LoadConfig, RadioModel};
use platoon_attacks::channel::{BackgroundBeacons, Dcc, LoadSource, RadioSpec};

/// `[channel] model` and `[channel.radio]`: the 802.11p model (absent tables take their
/// defaults, which `write_resolved_defaults` writes out), built once per distinct configuration
/// in this process (a model costs milliseconds to tabulate; a campaign's cells share it).
/// With `security` (`[security]`), the model's packets are larger by what signing adds on the
/// air ([`platoon_control::SecurityParams::mean_overhead_bytes`]: the standards' overhead).
pub(crate) fn radio(
    c: &Channel,
    dt: f64,
    security: Option<&platoon_control::SecurityParams>,
) -> Result<Option<RadioSpec>, KeyError> {
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
            let mut params = c.radio.unwrap_or_default();
            if let Some(s) = security {
                let signed = params.packet_bytes + s.mean_overhead_bytes(params.beacon_hz);
                if signed > 2304 && params.packet_bytes <= 2304 {
                    return bad(
                        "channel.radio.packet_bytes",
                        format!(
                            "is {} bytes, {signed} with [security]'s signature and certificate \
                             on the air, above 802.11's 2304",
                            params.packet_bytes
                        ),
                    );
                }
                params.packet_bytes = signed;
            }
            let load = match c.load.unwrap_or(LoadConfig::Scenario) {
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
                LoadSource::Scenario => match c
                    .background_beacons
                    .unwrap_or(BackgroundBeaconsConfig::Fixed)
                {
                    BackgroundBeaconsConfig::Fixed => BackgroundBeacons::Fixed,
                    BackgroundBeaconsConfig::Platoon => BackgroundBeacons::Platoon,
                },
            };
            let window_s = match load {
                LoadSource::Fixed => 1.0,
                LoadSource::Scenario => positive(
                    "channel.load_window_s",
                    finite("channel.load_window_s", c.load_window_s.unwrap_or(1.0))?,
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
fn dcc(d: &DccConfig) -> Result<Dcc, KeyError> {
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
