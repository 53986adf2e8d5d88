//! The files of a run, for every front-end: run directories written atomically ([`RunDir`]:
//! staged in `<DIR>.partial`, renamed when complete), the per-step tables as CSV or Parquet,
//! streamed ([`tables`]), and the PNG figures ([`plots`]).
pub mod plots;
pub mod rundir;
pub mod tables;

pub use rundir::RunDir;
