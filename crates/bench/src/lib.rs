//! The benchmark harness behind `platoon bench`: what the co-simulation costs on this machine,
//! measured side by side in one run (medians, percentiles and ratios; the machines are shared
//! and noisy, so no absolute thresholds anywhere). `platoon bench all` runs every benchmark and
//! writes BENCHMARKS.md. The co-simulations it starts run the processes of the `platoon` binary
//! it is called from (`platoon node ...`), so it runs from that binary, not on its own.

mod campaign;
mod design;
mod latency;
mod machine;
mod report;
mod search;
mod security;
mod step;

pub use campaign::{campaign, Campaign};
pub use design::{design, Design};
pub use latency::{latency, Latency};
pub use report::{all, All};
pub use search::{search, Search};
pub use security::{security, Security, SecurityRatio, SecurityReport, SecurityRow};
pub use step::{step, Step};

use platoon_output::rundir::RunDir;
use std::path::PathBuf;

/// A bench's output directory, `out` or `runs/<default>`, created (replaced with `force`).
fn create_out(out: Option<PathBuf>, default: &str, force: bool) -> anyhow::Result<RunDir> {
    let out = out.unwrap_or_else(|| PathBuf::from("runs").join(default));
    Ok(RunDir::create(&out, force)?)
}
