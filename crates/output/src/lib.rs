//! The files of a run, for every front-end: run directories written atomically ([`RunDir`]:
//! staged in `<DIR>.partial`, renamed when complete), the per-step tables as CSV or Parquet,
//! streamed ([`tables`]), the PNG figures ([`plots`]), SUMO's FCD output from the recorded
//! trajectories ([`fcd`]), and the reports' Markdown tables ([`markdown`]). Their errors are
//! [`OutputError`].
pub mod error;
pub mod fcd;
pub mod markdown;
pub mod plots;
pub mod run_tables;
pub mod rundir;
pub mod tables;

pub use error::OutputError;
pub use rundir::RunDir;
