//! The spacing policy: which distance the law keeps between neighbours.

use std::fmt;

/// What distance the law keeps between a vehicle and the one `m` places ahead of it:
/// `m l` with [`SpacingPolicy::Constant`] (the paper), `m (l + h_t v_rear)` with
/// [`SpacingPolicy::TimeHeadway`], `v_rear` the rear vehicle's speed. The one place the policy
/// is named: its config spelling ([`SpacingPolicy::name`]), its words in reports (`Display`) and
/// its headway ([`SpacingPolicy::headway`], 0 for constant spacing, so that `l + 0 v` is `l`
/// to the last bit).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum SpacingPolicy {
    /// The paper's constant spacing `l`.
    #[default]
    Constant,
    /// A time headway `h_t` (s, > 0) on top of the standstill spacing `l`.
    TimeHeadway(f64),
}

impl SpacingPolicy {
    /// The policy of time headway `h` (s): constant spacing for `h <= 0`.
    pub fn from_headway(h: f64) -> Self {
        if h > 0.0 {
            Self::TimeHeadway(h)
        } else {
            Self::Constant
        }
    }

    /// The time headway `h_t` (s); 0 for constant spacing.
    pub fn headway(self) -> f64 {
        match self {
            Self::Constant => 0.0,
            Self::TimeHeadway(h) => h,
        }
    }

    /// The name configs and summaries use: `constant` or `time_headway`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Constant => "constant",
            Self::TimeHeadway(_) => "time_headway",
        }
    }

    /// The policy a config names (`constant` or `time_headway`) with its headway (s), or
    /// `None` for an unknown name.
    pub fn parse(name: &str, headway: f64) -> Option<Self> {
        match name {
            "constant" => Some(Self::Constant),
            "time_headway" => Some(Self::TimeHeadway(headway)),
            _ => None,
        }
    }
}

/// `constant spacing` or `time headway 0.5 s`.
impl fmt::Display for SpacingPolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Constant => f.write_str("constant spacing"),
            Self::TimeHeadway(h) => write!(f, "time headway {h} s"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_words_and_headways_agree() {
        assert_eq!(SpacingPolicy::from_headway(0.0), SpacingPolicy::Constant);
        assert_eq!(SpacingPolicy::from_headway(1.5).headway(), 1.5);
        assert_eq!(SpacingPolicy::Constant.headway(), 0.0);
        assert_eq!(SpacingPolicy::Constant.to_string(), "constant spacing");
        assert_eq!(
            SpacingPolicy::TimeHeadway(0.5).to_string(),
            "time headway 0.5 s"
        );
        for p in [SpacingPolicy::Constant, SpacingPolicy::TimeHeadway(2.0)] {
            assert_eq!(SpacingPolicy::parse(p.name(), p.headway()), Some(p));
        }
        assert_eq!(SpacingPolicy::parse("headway", 1.0), None);
    }
}
