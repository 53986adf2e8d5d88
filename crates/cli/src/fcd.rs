//! `platoon fcd`: SUMO's FCD output from a SUMO run directory's trajectories; the conversion is
//! [`platoon_app::sumo::write_fcd`].
use crate::Result;
use platoon_app::sumo::{write_fcd, FcdOptions};
use std::path::PathBuf;

/// Arguments of `platoon fcd` (the help text is on the command in main.rs).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The run directory (of a `--plant sumo` run: it has plant.json and the trajectories).
    pub run: PathBuf,
    /// Seconds between timesteps, a whole multiple of the time between the trajectories' rows
    /// (the step times the run's `output.decimate`) [default: the period of the run's own
    /// fcd.xml, whichever writer wrote it; every step the trajectories hold if it wrote none;
    /// 0: every step the trajectories hold].
    #[arg(long, value_name = "SECONDS")]
    pub period: Option<f64>,
    /// The network [default: the one the run drove on, named in its plant.json].
    #[arg(long, value_name = "FILE")]
    pub net: Option<PathBuf>,
    /// Where to write [default: fcd.xml in the run directory, replaced].
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let written = write_fcd(
        &args.run,
        &FcdOptions {
            period_s: args.period,
            net: args.net,
            out: args.out,
        },
    )?;
    println!(
        "{}: {} timesteps, {} vehicle positions",
        written.path.display(),
        written.timesteps,
        written.vehicles
    );
    Ok(())
}
