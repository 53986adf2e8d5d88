//! The bridge (Python) and the SUMO networks, embedded in the binary, so a `platoon` that was
//! moved out of its checkout or installed with `cargo install` still runs SUMO and Python
//! injectors: the first time it needs them it unpacks them (atomically) into a directory of its
//! own version and contents, `$XDG_DATA_HOME/platoon/bundle-<version>-<hash>/` (default
//! `~/.local/share`), laid out like the repository (`bridge/`, `sumo/`).
use crate::error::{Context, OtherError};

type Result<T, E = OtherError> = std::result::Result<T, E>;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

macro_rules! files {
    ($($path:literal),* $(,)?) => {
        &[$(($path, include_bytes!(concat!("../../../", $path)) as &[u8])),*]
    };
}

/// Every file of the bundle, by its path in the repository.
pub const FILES: &[(&str, &[u8])] = files!(
    "bridge/README.md",
    "bridge/bench_peers.py",
    "bridge/bench_sumo.py",
    "bridge/dask_cells.py",
    "bridge/examples/dos_jammer.py",
    "bridge/examples/drop_sender.py",
    "bridge/examples/falsify.py",
    "bridge/examples/ghost.py",
    "bridge/examples/hostile.py",
    "bridge/examples/maneuver_attacks.py",
    "bridge/examples/maneuver_truth.py",
    "bridge/examples/notebooks/platoon.ipynb",
    "bridge/examples/observer.py",
    "bridge/examples/paper_law.py",
    "bridge/examples/radar_controller.py",
    "bridge/examples/sliding_mode.py",
    "bridge/examples/speed_check.py",
    "bridge/parquet_equals_csv.py",
    "bridge/platoon/__init__.py",
    "bridge/platoon/__main__.py",
    "bridge/platoon/_cli.py",
    "bridge/platoon/_core.pyi",
    "bridge/platoon/_moved.py",
    "bridge/platoon/config_layout.json",
    "bridge/platoon/controller.py",
    "bridge/platoon/dask/__init__.py",
    "bridge/platoon/dask/__main__.py",
    "bridge/platoon/dask/cells.py",
    "bridge/platoon/design.py",
    "bridge/platoon/injector.py",
    "bridge/platoon/plugin.py",
    "bridge/platoon/py.typed",
    "bridge/platoon/sumo/__init__.py",
    "bridge/platoon/sumo/__main__.py",
    "bridge/platoon/sumo/cpp/libsumo_api.h",
    "bridge/platoon/sumo/cpp/sumo_step.cpp",
    "bridge/platoon/sumo/model.py",
    "bridge/platoon/sumo/native.py",
    "bridge/platoon/sumo/plant.py",
    "bridge/platoon/wire.py",
    "bridge/platoon_controller.py",
    "bridge/platoon_injector.py",
    "bridge/platoon_plant.py",
    "bridge/platoon_plugin.py",
    "bridge/platoon_wire.py",
    "bridge/plexe_reference.py",
    "bridge/pyproject.toml",
    "bridge/requirements-package.txt",
    "bridge/requirements-tools.txt",
    "bridge/requirements.txt",
    "bridge/setup-venv.sh",
    "bridge/sumo_native.py",
    "bridge/sumo_plant.py",
    "bridge/tools/bench_peers.py",
    "bridge/tools/bench_sumo.py",
    "bridge/tools/parquet_equals_csv.py",
    "bridge/tools/plexe_join.py",
    "bridge/tools/plexe_reference.py",
    "bridge/wire_layout.json",
    "sumo/README.md",
    "sumo/build-networks.sh",
    "sumo/highway-long/highway-long.edg.xml",
    "sumo/highway-long/highway-long.net.xml",
    "sumo/highway-long/highway-long.nod.xml",
    "sumo/highway/highway.edg.xml",
    "sumo/highway/highway.net.xml",
    "sumo/highway/highway.nod.xml",
    "sumo/onramp/onramp.edg.xml",
    "sumo/onramp/onramp.net.xml",
    "sumo/onramp/onramp.nod.xml",
);

/// Where the bundle goes: `$XDG_DATA_HOME/platoon` or `~/.local/share/platoon`.
fn data_dir() -> Result<PathBuf> {
    if let Some(d) = std::env::var_os("XDG_DATA_HOME").filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(d).join("platoon"));
    }
    let home = std::env::var_os("HOME")
        .filter(|h| !h.is_empty())
        .context("neither XDG_DATA_HOME nor HOME is set, so there is nowhere to unpack the bridge (set PLATOON_BRIDGE_DIR to a checkout's bridge/)")?;
    Ok(PathBuf::from(home).join(".local/share/platoon"))
}

/// The unpacked bundle's root (holding `bridge/` and `sumo/`), unpacking it if it is not there.
pub fn unpacked() -> Result<PathBuf> {
    let mut hash = Sha256::new();
    for (path, bytes) in FILES {
        hash.update(path.as_bytes());
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(bytes);
    }
    let hex: String = hash.finalize()[..6]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    let parent = data_dir()?;
    let root = parent.join(format!("bundle-{}-{hex}", env!("CARGO_PKG_VERSION")));
    if root.join("bridge/setup-venv.sh").is_file() {
        return Ok(root);
    }
    let staging = parent.join(format!(".bundle-{hex}.partial-{}", std::process::id()));
    let write = || -> Result<()> {
        for (path, bytes) in FILES {
            let file = staging.join(path);
            std::fs::create_dir_all(file.parent().unwrap_or(&staging))?;
            std::fs::write(&file, bytes)?;
            if path.ends_with(".sh") {
                use std::os::unix::fs::PermissionsExt;
                std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o755))?;
            }
        }
        Ok(())
    };
    write().with_context(|| format!("unpacking the bridge into {}", staging.display()))?;
    // Another process may have unpacked the same bundle meanwhile: theirs is as good.
    if let Err(e) = std::fs::rename(&staging, &root) {
        let _ = std::fs::remove_dir_all(&staging);
        if !root.join("bridge/setup-venv.sh").is_file() {
            return Err(e).with_context(|| format!("moving the bridge into {}", root.display()));
        }
    } else {
        eprintln!(
            "unpacked the SUMO bridge and networks this binary carries into {}",
            root.display()
        );
    }
    Ok(root)
}

/// Whether `dir` is a bridge directory.
pub fn is_bridge(dir: &Path) -> bool {
    dir.join("setup-venv.sh").is_file()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every file of the repository's bridge/ (but its tests and venv) and sumo/ is in the
    /// bundle, as it is on disk: a new bridge file cannot be forgotten.
    #[test]
    fn the_bundle_holds_every_bridge_and_network_file() {
        let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut on_disk = Vec::new();
        let mut stack = vec![repo.join("bridge"), repo.join("sumo")];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                let name = path.file_name().unwrap().to_string_lossy().into_owned();
                if name.starts_with('.') || name == "__pycache__" || name == "tests" {
                    continue;
                }
                if path.is_dir() {
                    stack.push(path);
                } else if !name.ends_with(".pyc") && !name.ends_with(".so") {
                    // (.so: the package's compiled core, where an editable install put it)
                    let rel = path
                        .strip_prefix(&repo)
                        .unwrap()
                        .to_string_lossy()
                        .into_owned();
                    on_disk.push(rel);
                }
            }
        }
        on_disk.sort();
        let mut bundled: Vec<String> = FILES.iter().map(|(p, _)| p.to_string()).collect();
        bundled.sort();
        assert_eq!(bundled, on_disk, "update bundle::FILES");
        for (path, bytes) in FILES {
            assert_eq!(std::fs::read(repo.join(path)).unwrap(), *bytes, "{path}");
        }
    }
}
