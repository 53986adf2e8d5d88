//! Every figure the README and the docs state as a result, computed again and compared at the
//! digits they print (`common::published`): the runs are deterministic, so a figure that drifts,
//! in the code or in the text, fails here. Each study has its own module; each test runs the
//! study's own settings or a reduced grid of it that still gives the published digits.
#[path = "figures/design.rs"]
mod design;
#[path = "figures/detection.rs"]
mod detection;
#[path = "figures/search.rs"]
mod search;
#[path = "figures/studies.rs"]
mod studies;
