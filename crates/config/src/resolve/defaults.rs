//! The defaults that depend on other keys, written into a config once it resolved, so that
//! the config a run directory keeps (`config.toml`) says what ran.
use crate::schema::{BackgroundBeaconsConfig, Config, LoadConfig, RadioModel};

/// Writes out the defaults of a config that resolved ([`super::scenario_of`]) which depend on
/// other keys: `trigger.check_period_s` (the step), `fallback.mode` (from the older
/// `control.attack_input`, which goes) and, with the 802.11p radio, `[channel.radio]`,
/// `channel.load` and, for the load counted from the run, `channel.background_beacons` and
/// `channel.load_window_s`. What resolves is the same before and after.
pub fn write_resolved_defaults(c: &mut Config) {
    let dt = c.simulation.dt_s;
    c.trigger.check_period_s.get_or_insert(dt);
    if let Ok(mode) = super::fallback::mode(c) {
        c.fallback.mode = Some(mode);
        c.control.attack_input = None;
    }
    let ch = &mut c.channel;
    if ch.model == RadioModel::Ieee80211p {
        ch.radio.get_or_insert_with(Default::default);
        if *ch.load.get_or_insert(LoadConfig::Scenario) == LoadConfig::Scenario {
            ch.background_beacons
                .get_or_insert(BackgroundBeaconsConfig::Fixed);
            ch.load_window_s.get_or_insert(1.0);
        }
    }
}
