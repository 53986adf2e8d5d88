//! What the tests of signed runs share (tests/security.rs, tests/group_key.rs): a shipped
//! config's text, a scenario of a config's text, the seals' refusals by name, and whether two
//! runs' rows are the same bit for bit.
use super::repo;
use platoon_control::SealCounts;
use platoon_sim::{Scenario, StepRow};

/// `configs/<name>.toml`'s text.
pub fn config(name: &str) -> String {
    std::fs::read_to_string(repo().join(format!("configs/{name}.toml"))).unwrap()
}

/// The scenario of a config's `text`.
pub fn scenario(text: &str) -> Scenario {
    platoon_config::parse(text, std::path::Path::new("signed.toml"))
        .unwrap()
        .1
}

/// The refusals of `seals` by name.
pub fn refused(seals: &SealCounts, name: &str) -> u64 {
    seals.by_reason().find(|(n, _)| *n == name).unwrap().1
}

/// Whether two runs' rows are the same bit for bit (NaN included: a radar without a target).
pub fn same(a: &[StepRow], b: &[StepRow]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| format!("{x:?}") == format!("{y:?}"))
}
