//! The config's own controllers ([`platoon_controller_sdk::build`]: the paper's, or one of the
//! field's laws) as a plug-in controller service: what the built-in controller service runs,
//! started by `platoon run --controller` instead. A run with it equals the built-in run byte for
//! byte (tested):
//!
//! ```sh
//! cargo build --example configured
//! platoon run configs/paper.toml --controller target/debug/examples/configured
//! ```
use platoon_controller_sdk::{build, run};

fn main() -> Result<(), platoon_controller_sdk::Error> {
    run(|platoon| build(&platoon.control, &platoon.topology, &platoon.initial))
}
