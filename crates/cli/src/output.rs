//! Run directories written atomically: everything goes into `<DIR>.partial` and the directory is
//! renamed to `<DIR>` only when every file is written, so a killed run never leaves a directory
//! that looks complete.
use anyhow::{bail, Context, Result};
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A run directory being written.
pub struct RunDir {
    final_path: PathBuf,
    staging: PathBuf,
    force: bool,
}

impl RunDir {
    /// Starts writing `out`. Fails if `out` exists and `force` is not set. A `<out>.partial` left by
    /// a killed run is removed.
    pub fn create(out: &Path, force: bool) -> Result<Self> {
        if out.exists() && !force {
            bail!(
                "output directory {} exists; choose another --out or pass --force to replace it",
                out.display()
            );
        }
        let staging = sibling(out, ".partial");
        if staging.exists() {
            fs::remove_dir_all(&staging).with_context(|| {
                format!(
                    "removing the unfinished run directory {}",
                    staging.display()
                )
            })?;
        }
        fs::create_dir_all(&staging).with_context(|| format!("creating {}", staging.display()))?;
        Ok(Self {
            final_path: out.to_path_buf(),
            staging,
            force,
        })
    }

    /// Opens `out` for work that can resume (a campaign): an existing `<out>.partial` is kept
    /// and reused (the bool says so) unless `force`, which starts over; a finished `out` is
    /// an error without `force`, and with it is replaced only when the new one is committed.
    pub fn resumable(out: &Path, force: bool) -> Result<(Self, bool)> {
        let staging = sibling(out, ".partial");
        if force {
            if staging.exists() {
                eprintln!(
                    "--force: removing the unfinished {} and starting over",
                    staging.display()
                );
                fs::remove_dir_all(&staging)
                    .with_context(|| format!("removing {}", staging.display()))?;
            }
            if out.exists() {
                eprintln!(
                    "--force: {} will be replaced when this run finishes",
                    out.display()
                );
            }
        } else if out.exists() {
            bail!(
                "{} exists and is finished; choose another --out or pass --force to start over",
                out.display()
            );
        }
        let resumed = staging.is_dir();
        fs::create_dir_all(&staging).with_context(|| format!("creating {}", staging.display()))?;
        Ok((
            Self {
                final_path: out.to_path_buf(),
                staging,
                force,
            },
            resumed,
        ))
    }

    /// The staging directory (`<out>.partial`).
    pub fn staging(&self) -> &Path {
        &self.staging
    }

    /// Path of a file inside the (staging) directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.staging.join(name)
    }

    /// A buffered writer for a new file in the directory.
    pub fn writer(&self, name: &str) -> Result<BufWriter<fs::File>> {
        let p = self.path(name);
        let f = fs::File::create(&p).with_context(|| format!("creating {}", p.display()))?;
        Ok(BufWriter::new(f))
    }

    /// Writes a whole file.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<()> {
        let mut w = self.writer(name)?;
        w.write_all(bytes)
            .and_then(|_| w.flush())
            .with_context(|| format!("writing {name}"))
    }

    /// Moves the finished directory into place.
    pub fn commit(self) -> Result<PathBuf> {
        let old = sibling(&self.final_path, ".old");
        if self.final_path.exists() {
            debug_assert!(self.force);
            fs::rename(&self.final_path, &old).with_context(|| {
                format!("moving the previous {} aside", self.final_path.display())
            })?;
        }
        fs::rename(&self.staging, &self.final_path).with_context(|| {
            format!(
                "renaming {} to {}",
                self.staging.display(),
                self.final_path.display()
            )
        })?;
        if old.exists() {
            fs::remove_dir_all(&old).with_context(|| format!("removing {}", old.display()))?;
        }
        Ok(self.final_path)
    }
}

fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "run".into());
    name.push(suffix);
    path.with_file_name(name)
}
