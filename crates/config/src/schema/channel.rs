//! The `[channel]` tables: link attacks, the radio and its load, DCC, jammers.
use crate::serde_util;
use schemars::JsonSchema;
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

/// `[channel]`: a seed and a list of `[[channel.attacks]]`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Channel {
    /// Seed of the random losses (Bernoulli, Gilbert-Elliott).
    #[serde(default)]
    pub seed: u64,
    /// The attacks, applied in this order to each packet on each link.
    #[serde(default)]
    pub attacks: Vec<LinkAttackConfig>,
    /// The radio: `ideal` (every packet the attacks leave arrives) or `80211p` (IEEE 802.11p
    /// delivery against distance and channel load, the analytical model of Sepulcre et al.,
    /// docs/channel-80211p.md, with `[channel.radio]`).
    #[serde(default)]
    pub model: RadioModel,
    /// `model = "80211p"`: the model's parameters (every key optional: the paper's base case,
    /// 0.06 vehicles/m at 10 Hz, 23 dBm, 6 Mbps, 190 bytes). The density and beacon rate are
    /// the traffic the run does not simulate, evenly spread (0 vehicles/m: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radio: Option<platoon_radio::Params80211p>,
    /// `model = "80211p"`: where the channel's load comes from: `scenario` (the default: the
    /// radio's traffic plus every transmitter of the run within its interferer range, the
    /// platoon's and the fleet's vehicles at their measured beacon rate, SUMO's background
    /// vehicles at the radio's beacon rate) or `fixed` (the radio's traffic alone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<LoadConfig>,
    /// `model = "80211p"`: the beacon rate of the traffic the run does not simulate (the
    /// radio's density and SUMO's background vehicles): `fixed` (the default, the radio's
    /// `beacon_hz`) or `platoon` (the platoon's mean rate since the start: every vehicle
    /// beacons as the platoon does, at other times).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub background_beacons: Option<BackgroundBeaconsConfig>,
    /// `model = "80211p"`: the window the vehicles' beacon rates are measured over (s; default
    /// 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_window_s: Option<f64>,
    /// `model = "80211p"`: reactive decentralised congestion control (ETSI TS 102 687) in each
    /// vehicle's access layer; an empty `[channel.dcc]` turns it on with the standard's table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dcc: Option<DccConfig>,
    /// Jammers as transmitters on the road (docs/channel-80211p.md#jammers).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub jammers: Vec<JammerConfig>,
}

/// Declares a table that is active on `[start_s, end_s)` (a jammer, a link attack): its keys
/// before the window's, `start_s` and `end_s`, then its keys after them (the order its
/// resolved config is written in). A macro, not a shared struct: the tables are flat, and
/// `serde(flatten)` goes neither with `deny_unknown_fields` nor with the key-span errors.
macro_rules! with_window {
    (
        $(#[$meta:meta])* pub struct $name:ident { $($before:tt)* } then { $($after:tt)* }
    ) => {
        $(#[$meta])*
        pub struct $name {
            $($before)*
            /// Start of its activity (s).
            #[serde(default)]
            pub start_s: f64,
            /// End of its activity (s, exclusive; `inf`, the default: never, the end of the
            /// run).
            #[serde(default = "forever")]
            #[schemars(default = "forever_in_json")]
            pub end_s: f64,
            $($after)*
        }
    };
}

with_window! {
    /// `[[channel.jammers]]`: a transmitter on the road. While it transmits, a vehicle that
    /// receives it above the radio's sensing threshold (the path loss of `[channel.radio]`, its
    /// defaults without one) senses its channel jammed and can neither send nor receive, as under
    /// the paper's DoS; with `[channel] model = "80211p"` its power also enters every other link's
    /// SINR. It stands at `position_m` (moving at `speed_mps`), rides with platoon vehicle `member`
    /// (at `offset_m`), or rides SUMO background vehicle `background`: exactly one of the three.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
    #[serde(deny_unknown_fields)]
    pub struct JammerConfig {
        /// Its road coordinate at t = 0 (m; the platoon's coordinates): a roadside jammer.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub position_m: Option<f64>,
        /// Rides with this platoon vehicle (0 = the leader), `offset_m` along the road from it.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub member: Option<u16>,
        /// With `member`: its offset along the road from that vehicle (m; negative: behind).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub offset_m: Option<f64>,
        /// Rides SUMO background vehicle `bg<background>` (`simulation.plant = "sumo"` with
        /// `sumo.background_vehicles` above it); silent while that vehicle is off the road.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub background: Option<usize>,
        /// When it transmits within `[start_s, end_s)`: `constant`, `periodic` (`on_s`/`off_s`),
        /// `random` (exponential on/off times of means `mean_on_s`/`mean_off_s`, seeded from
        /// `[channel] seed`) or `reactive` (only while it senses a vehicle's transmission; it then
        /// destroys that packet wherever it is heard). Absent: `periodic` with `on_s`/`off_s`,
        /// `constant` without.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub behaviour: Option<JammerBehaviour>,
        /// Random: mean burst length (s).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub mean_on_s: Option<f64>,
        /// Random: mean pause between bursts (s).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub mean_off_s: Option<f64>,
        /// Its speed along the road (m/s; 0: roadside; with `position_m` only).
        #[serde(default)]
        pub speed_mps: f64,
        /// Its distance from the road (m): it reaches the road over the part of it within its
        /// sensing radius, none when it stands farther away than that.
        #[serde(default)]
        pub lateral_m: f64,
        /// Its transmit power (dBm).
        #[serde(default = "jammer_power")]
        pub power_dbm: f64,
    } then {
        /// Periodic: on for `on_s`, then off for `off_s`, from `start_s` (absent: always on).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub on_s: Option<f64>,
        /// Periodic: off time between two bursts (s).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub off_s: Option<f64>,
    }
}

/// `[[channel.jammers]] behaviour`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum JammerBehaviour {
    /// Transmits all the time.
    Constant,
    /// On for `on_s`, off for `off_s`.
    Periodic,
    /// Exponential on/off times.
    Random,
    /// Transmits only while it senses a transmission.
    Reactive,
}

fn jammer_power() -> f64 {
    23.0
}

/// `[channel] load`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LoadConfig {
    /// The radio's traffic plus the run's transmitters, measured as the run goes.
    Scenario,
    /// The radio's traffic alone.
    Fixed,
}

/// `[channel] background_beacons`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BackgroundBeaconsConfig {
    /// `[channel.radio] beacon_hz`.
    Fixed,
    /// The platoon's mean beacon rate since the start.
    Platoon,
}

/// `[channel.dcc]`: reactive DCC's states (ETSI TS 102 687 V1.2.1, Annex A, packets of at most
/// 0.5 ms on air): a vehicle measuring a CBR below `cbr_thresholds[i]` (and at or above the
/// one before) waits at least `t_off_s[i]` between two transmissions; at or above the last
/// threshold, the last `t_off_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DccConfig {
    /// The CBR limits between the states, increasing in (0, 1) (default: relaxed below 0.30,
    /// active 1 to 3 below 0.40, 0.50 and 0.65, restrictive above).
    #[serde(default = "dcc_thresholds")]
    pub cbr_thresholds: Vec<f64>,
    /// The least time between two transmissions in each state (s), one more than the
    /// thresholds, not decreasing (default: 0.06, 0.10, 0.18, 0.26, 1.0).
    #[serde(default = "dcc_t_off")]
    pub t_off_s: Vec<f64>,
}

fn dcc_thresholds() -> Vec<f64> {
    vec![0.30, 0.40, 0.50, 0.65]
}
fn dcc_t_off() -> Vec<f64> {
    vec![0.06, 0.10, 0.18, 0.26, 1.0]
}

/// `[channel] model`: the radio under the attacks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
pub enum RadioModel {
    /// Every packet the attacks leave is delivered.
    #[default]
    #[serde(rename = "ideal")]
    Ideal,
    /// IEEE 802.11p's delivery ratio at the link's distance (docs/channel-80211p.md).
    #[serde(rename = "80211p")]
    Ieee80211p,
}

impl Channel {
    pub(crate) fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

with_window! {
    /// `[[channel.attacks]]`: one link attack, its `kind` and that kind's keys (the keys of another
    /// kind are errors), active on `[start_s, end_s)` for the links it targets.
    #[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
    pub struct LinkAttackConfig {
        /// What it does to the packets it hits.
        #[serde(flatten)]
        pub kind: LinkKindConfig,
    } then {
        /// Targeted senders (vehicle ids, 0 = leader); absent: all.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub senders: Option<Vec<u16>>,
        /// Targeted receivers; absent: all.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub receivers: Option<Vec<u16>>,
        /// Whom the attacker acts as, by the keys it holds: `outsider` (none: in a
        /// `[security]` run its alterations fail verification), `insider` (a member lying in
        /// its own name and signing the lie with its own key; the same as `insider = true`),
        /// `thief` (a ghost or Sybil signing what it alters with member `key_of`'s stolen key).
        /// Only the kinds that alter what packets say take `insider` or `thief` \[`outsider`,
        /// `insider` with `insider = true`\].
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub acts_as: Option<ActsAsConfig>,
        /// With `acts_as = "thief"`: the member whose key it stole (0 = the leader).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub key_of: Option<u16>,
    }
}

/// `[[channel.attacks]] acts_as`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ActsAsConfig {
    /// No valid key.
    Outsider,
    /// A member, with its own key.
    Insider,
    /// A ghost or Sybil with a member's stolen key (`key_of`).
    Thief,
}

pub(crate) fn forever() -> f64 {
    f64::INFINITY
}

/// JSON has no infinity: the schema gives TOML's spelling.
pub(crate) fn forever_in_json() -> &'static str {
    "inf"
}

/// The selector first, the keys every kind has, then the kind's own (a config's order).
impl Serialize for LinkAttackConfig {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("kind", self.kind.name())?;
        m.serialize_entry("start_s", &self.start_s)?;
        m.serialize_entry("end_s", &self.end_s)?;
        if let Some(v) = &self.senders {
            m.serialize_entry("senders", v)?;
        }
        if let Some(v) = &self.receivers {
            m.serialize_entry("receivers", v)?;
        }
        if let Some(v) = &self.acts_as {
            m.serialize_entry("acts_as", v)?;
        }
        if let Some(v) = &self.key_of {
            m.serialize_entry("key_of", v)?;
        }
        serde_util::entries(&mut m, &self.kind, "kind")?;
        m.end()
    }
}

/// `[[channel.attacks]] kind` and its keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LinkKindConfig {
    /// Each packet on each targeted link is lost with probability `loss`.
    Bernoulli {
        /// Loss probability in `[0, 1]`.
        loss: f64,
    },
    /// Burst loss: a two-state (good/bad) Markov chain per link, advanced once per packet on
    /// that link; a packet is lost with `loss_good` or `loss_bad` depending on the state.
    GilbertElliott {
        /// Probability of going from good to bad, per packet.
        p_good_bad: f64,
        /// Probability of going from bad to good, per packet.
        p_bad_good: f64,
        /// Loss probability in the good state.
        #[serde(default)]
        loss_good: f64,
        /// Loss probability in the bad state.
        #[serde(default = "all_lost")]
        loss_bad: f64,
    },
    /// Every targeted packet arrives `delay_s` late (the receiver propagates it open-loop).
    Delay {
        /// The delay (s), a whole number of steps.
        delay_s: f64,
    },
    /// A jammer (e.g. a drone) at `position_m + speed_mps t` along the road: a vehicle within
    /// `radius_m` of it can neither send nor receive, and senses its channel jammed.
    RangeJamming {
        /// Jammer position at t = 0 (m, road coordinate of the platoon).
        position_m: f64,
        /// Jammer speed (m/s).
        #[serde(default)]
        speed_mps: f64,
        /// Jamming radius (m).
        radius_m: f64,
    },
    /// The targeted senders' packets are replaced by the ones they sent `lag_s` earlier, with
    /// their old sequence numbers.
    Replay {
        /// Age of the replayed packets (s), a whole number of steps.
        lag_s: f64,
    },
    /// False data injection: `offset` is added to the state in the targeted senders' packets.
    FalseData {
        /// Offset added to `[p, v, a]`.
        offset: [f64; 3],
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// Random false data: zero-mean normal noise of standard deviation `std` added to the state,
    /// drawn from the channel's seeded stream per packet and link (per packet for an insider,
    /// whose receivers all get the same draw).
    RandomOffset {
        /// Standard deviation on `[p, v, a]` (m, m/s, m/s^2), each >= 0.
        std: [f64; 3],
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// A slow drift: the offset `rate (t - start_s)` on the state grows linearly from the
    /// attack's start; sized to stay inside sensor noise, it passes plausibility checks for a
    /// while.
    Drift {
        /// Growth of the offset on `[p, v, a]` per second (m/s, m/s^2, m/s^3).
        rate: [f64; 3],
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// Feigned braking: the claimed acceleration is replaced by `accel_mps2`; position and
    /// speed stay true.
    FeignedBraking {
        /// The claimed acceleration (m/s^2), e.g. -6.
        accel_mps2: f64,
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// The claimed acceleration multiplied by `factor`; position and speed stay true.
    AccelScale {
        /// The factor.
        factor: f64,
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// A forged formation update: the senders' packets announce that the sender heads a platoon
    /// split behind a cut-in, so the followers behind it that split (`[fallback.cut_in] split`)
    /// take it as their leader; the state stays true.
    ForgedHead {
        /// An insider (a platoon member lying about itself): the packet is altered once as it
        /// is sent, so every receiver gets the same lie; not with `receivers`. Otherwise an
        /// outsider alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
    /// A jammer that reacts to maneuver messages (`[maneuvers]`): every packet on the targeted
    /// links that carries one of `messages` is lost, the beacon with it (a maneuver jammed
    /// half way: `messages = ["move_in"]`).
    JamManeuvers {
        /// The messages jammed, by name: `join_request`, `join_accept`, `join_refuse`,
        /// `open_gap`, `gap_ready`, `move_in`, `in_position`, `update`, `abort`,
        /// `leave_notice`, `merge_request`, `split_notice` \[every one\].
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        messages: Vec<String>,
    },
    /// A forged maneuver message (`[maneuvers]`): the senders' packets carry `message` from
    /// the sender to the leader, with the highest sequence number (the leader takes the first
    /// and drops that sender's later messages as old); the state stays true.
    ForgeManeuver {
        /// `join_request` (a join nobody asked for, of the slot behind the vehicle numbered
        /// just ahead of the sender: for a joiner numbered after the platoon, its tail; the
        /// leader is busy with it until its deadline), `leave_notice` (a leave nobody asked
        /// for: the leader ejects the member) or
        /// `in_position` (a joiner, or the head of a merging platoon, that is not in its slot
        /// says it is) or `split_notice` (a split nobody asked for: the leader splits the
        /// platoon off at the sender).
        message: String,
        /// An insider (the sender itself lies): the packet is altered once as it is sent, so
        /// every receiver gets the same message; not with `receivers`. Otherwise an outsider
        /// alters each link's copy on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        #[schemars(extend("default" = false))]
        insider: bool,
    },
}

/// The bad state loses every packet.
fn all_lost() -> f64 {
    1.0
}

impl LinkKindConfig {
    /// Its `kind`.
    pub fn name(&self) -> &'static str {
        serde_util::tag_name(self, "kind")
    }

    /// Whether the attacker is an insider (false for the kinds that do not alter states).
    pub fn insider(&self) -> bool {
        match *self {
            Self::FalseData { insider, .. }
            | Self::RandomOffset { insider, .. }
            | Self::Drift { insider, .. }
            | Self::FeignedBraking { insider, .. }
            | Self::AccelScale { insider, .. }
            | Self::ForgedHead { insider }
            | Self::ForgeManeuver { insider, .. } => insider,
            Self::JamManeuvers { .. }
            | Self::Bernoulli { .. }
            | Self::GilbertElliott { .. }
            | Self::Delay { .. }
            | Self::RangeJamming { .. }
            | Self::Replay { .. } => false,
        }
    }
}
