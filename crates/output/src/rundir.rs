//! Run directories written atomically: everything goes into `<DIR>.partial` and the directory is
//! renamed to `<DIR>` only when every file is written, so a killed run never leaves a directory
//! that looks complete.
use crate::error::{OutputError, Result};
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
            fs::remove_dir_all(&staging).map_err(|e| {
                let what = format!(
                    "removing the unfinished run directory {}",
                    staging.display()
                );
                OutputError::io(&staging, what, e)
            })?;
        }
        fs::create_dir_all(&staging)
            .map_err(|e| OutputError::io(&staging, format!("creating {}", staging.display()), e))?;
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
                fs::remove_dir_all(&staging).map_err(|e| {
                    OutputError::io(&staging, format!("removing {}", staging.display()), e)
                })?;
            }
            if out.exists() {
                eprintln!(
                    "--force: {} will be replaced when this run finishes",
                    out.display()
                );
            }
        }
        let resumed = staging.is_dir();
        fs::create_dir_all(&staging)
            .map_err(|e| OutputError::io(&staging, format!("creating {}", staging.display()), e))?;
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
        let f = fs::File::create(&p)
            .map_err(|e| OutputError::io(&p, format!("creating {}", p.display()), e))?;
        Ok(BufWriter::new(f))
    }

    /// Writes a whole file.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<()> {
        let mut w = self.writer(name)?;
        w.write_all(bytes)
            .and_then(|_| w.flush())
            .map_err(|e| OutputError::io(&self.path(name), format!("writing {name}"), e))
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
                let what = format!(
                    "moving the previous {} aside (this run stays in {})",
                    self.final_path.display(),
                    self.staging.display()
                );
                return Err(OutputError::io(&self.final_path, what, e));
            }
        }
        if let Err(e) = fs::rename(&self.staging, &self.final_path) {
            if replacing {
                let _ = fs::rename(&old, &self.final_path);
            }
            self.mark_incomplete(&format!("could not move into place: {e}"));
            let what = format!(
                "renaming {} to {} (this run stays in {})",
                self.staging.display(),
                self.final_path.display(),
                self.staging.display()
            );
            return Err(OutputError::io(&self.final_path, what, e));
        }
        if replacing {
            fs::remove_dir_all(&old)
                .map_err(|e| OutputError::io(&old, format!("removing {}", old.display()), e))?;
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
        Ok(m) if !m.is_dir() => return Err(refused(out, format!(
            "{} exists and is not a directory; --force replaces run directories only: remove it or choose another --out",
            out.display()
        ))),
        Ok(_) if !force => return Err(refused(out, format!(
            "output directory {} exists; choose another --out or pass --force to replace it",
            out.display()
        ))),
        Ok(m) => {
            use std::os::unix::fs::MetadataExt;
            let abs = fs::canonicalize(out)
                .map_err(|e| OutputError::io(out, format!("resolving {}", out.display()), e))?;
            let parent_dev = abs
                .parent()
                .and_then(|p| fs::metadata(p).ok())
                .map(|p| p.dev());
            if parent_dev != Some(m.dev()) {
                return Err(refused(out, format!(
                    "{} is a mount point, which --force cannot replace (run directories are replaced by renaming): use a directory inside it, e.g. --out {}",
                    out.display(),
                    out.join("run").display()
                )));
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(OutputError::io(out, format!("inspecting {}", out.display()), e)),
    }
    let old = sibling(out, ".old");
    if old.exists() {
        return Err(refused(out, format!(
            "{} is left by an earlier run whose replacement of {} stopped half-way and may hold that run's outputs: move it back or remove it, then run again",
            old.display(),
            out.display()
        )));
    }
    Ok(())
}

fn refused(out: &Path, reason: String) -> OutputError {
    OutputError::Refused {
        path: out.to_path_buf(),
        reason,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_existing_directory_is_refused_by_path_with_the_message_the_cli_prints() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("run");
        fs::create_dir(&out).unwrap();
        let Err(e) = RunDir::create(&out, false) else {
            panic!("an existing directory was accepted");
        };
        assert!(
            matches!(&e, OutputError::Refused { path, .. } if path == &out),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            format!(
                "output directory {} exists; choose another --out or pass --force to replace it",
                out.display()
            )
        );
    }

    #[test]
    fn an_io_failure_names_the_path_and_keeps_the_cause() {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("file");
        fs::write(&file, "").unwrap();
        let out = file.join("run");
        let Err(e) = RunDir::create(&out, false) else {
            panic!("a run directory inside a file was created");
        };
        assert!(
            matches!(&e, OutputError::Io { path, .. } if path == &out),
            "{e:?}"
        );
        assert_eq!(e.to_string(), format!("inspecting {}", out.display()));
        assert!(std::error::Error::source(&e).is_some());
    }
}
