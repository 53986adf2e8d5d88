//! `--out` and `--force`, of every command that writes a directory of outputs.
use crate::Result;
use platoon_output::rundir::RunDir;
use std::path::PathBuf;

/// Where a command writes its outputs. Each command names its default directory in the help
/// of `--out` (`#[command(mut_arg("out", ...))]` on its arguments).
#[derive(Debug, clap::Args)]
pub struct OutDir {
    /// Output directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the output directory if it exists.
    #[arg(long)]
    pub force: bool,
}

impl OutDir {
    /// `--out`, else `default`.
    pub fn path_or(&self, default: &str) -> PathBuf {
        self.out.clone().unwrap_or_else(|| PathBuf::from(default))
    }

    /// Creates the output directory (`--out`, else `default`; replaced with `--force`), runs
    /// `write` into it and commits it, then prints the text `write` returns and where the
    /// outputs are.
    pub fn write(
        &self,
        default: &str,
        write: impl FnOnce(&RunDir) -> Result<String>,
    ) -> Result<()> {
        let dir = RunDir::create(&self.path_or(default), self.force)?;
        let text = write(&dir)?;
        let path = dir.commit()?;
        print!("{text}");
        println!("outputs: {}", path.display());
        Ok(())
    }
}
