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
        Self::create_saying(out, force, true)
    }

    /// [`RunDir::create`] with `force`, silently: for directories the program owns (a
    /// campaign's cell records), which it replaces as a matter of course.
    pub fn replace(out: &Path) -> Result<Self> {
        Self::create_saying(out, true, false)
    }

    fn create_saying(out: &Path, force: bool, say: bool) -> Result<Self> {
        check_destination(out, force)?;
        if say && force && out.exists() {
            eprintln!(
                "--force: {} will be replaced when this run finishes",
                out.display()
            );
        }
        let staging = sibling(out, ".partial");
        if staging.exists() {
            if say {
                eprintln!(
                    "removing {}, left by a run that did not finish",
                    staging.display()
                );
            }
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
        check_destination(out, force)?;
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

    /// Moves the finished directory into place (a previous one, with `force`, is moved aside
    /// first and removed after). If the move fails, the previous directory is put back and the
    /// staged summary.json is marked incomplete: no summary that says `complete: true` is ever
    /// left outside a finished directory.
    pub fn commit(self) -> Result<PathBuf> {
        let old = sibling(&self.final_path, ".old");
        let replacing = self.final_path.exists();
        if replacing {
            debug_assert!(self.force);
            if let Err(e) = fs::rename(&self.final_path, &old) {
                self.mark_incomplete(&format!("could not move the previous run aside: {e}"));
                return Err(e).with_context(|| {
                    format!(
                        "moving the previous {} aside (this run stays in {})",
                        self.final_path.display(),
                        self.staging.display()
                    )
                });
            }
        }
        if let Err(e) = fs::rename(&self.staging, &self.final_path) {
            if replacing {
                let _ = fs::rename(&old, &self.final_path);
            }
            self.mark_incomplete(&format!("could not move into place: {e}"));
            return Err(e).with_context(|| {
                format!(
                    "renaming {} to {} (this run stays in {})",
                    self.staging.display(),
                    self.final_path.display(),
                    self.staging.display()
                )
            });
        }
        if replacing {
            fs::remove_dir_all(&old).with_context(|| format!("removing {}", old.display()))?;
        }
        Ok(self.final_path)
    }

    /// Rewrites a staged summary.json with `complete: false` and `why`.
    fn mark_incomplete(&self, why: &str) {
        let path = self.staging.join("summary.json");
        let Ok(text) = fs::read_to_string(&path) else {
            return;
        };
        if let Ok(mut v) = serde_json::from_str::<serde_json::Value>(&text) {
            v["complete"] = serde_json::Value::Bool(false);
            v["error"] = serde_json::Value::String(why.to_string());
            if let Ok(t) = serde_json::to_string_pretty(&v) {
                let _ = fs::write(&path, t + "\n");
            }
        }
    }
}

/// Checks before any work that `out` can become a run directory: it is a directory (or does not
/// exist), exists only with `force`, is not a mount point (a run directory is replaced by
/// renaming, which a mount point does not allow), and no `<out>.old` from a replacement that
/// stopped half-way is in the way.
fn check_destination(out: &Path, force: bool) -> Result<()> {
    match fs::symlink_metadata(out) {
        Ok(m) if !m.is_dir() => bail!(
            "{} exists and is not a directory; --force replaces run directories only: remove it or choose another --out",
            out.display()
        ),
        Ok(_) if !force => bail!(
            "output directory {} exists; choose another --out or pass --force to replace it",
            out.display()
        ),
        Ok(m) => {
            use std::os::unix::fs::MetadataExt;
            let abs = fs::canonicalize(out).with_context(|| format!("resolving {}", out.display()))?;
            let parent_dev = abs
                .parent()
                .and_then(|p| fs::metadata(p).ok())
                .map(|p| p.dev());
            if parent_dev != Some(m.dev()) {
                bail!(
                    "{} is a mount point, which --force cannot replace (run directories are replaced by renaming): use a directory inside it, e.g. --out {}",
                    out.display(),
                    out.join("run").display()
                );
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e).with_context(|| format!("inspecting {}", out.display())),
    }
    let old = sibling(out, ".old");
    if old.exists() {
        bail!(
            "{} is left by an earlier run whose replacement of {} stopped half-way and may hold that run's outputs: move it back or remove it, then run again",
            old.display(),
            out.display()
        );
    }
    Ok(())
}

fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "run".into());
    name.push(suffix);
    path.with_file_name(name)
}
