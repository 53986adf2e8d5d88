//! clarabel's SDP support needs BLAS and LAPACK. When the system OpenBLAS is installed (Debian's
//! libopenblas-dev, which .ci/run installs) it is linked and the solver is built in (cfg
//! `sdp_solver`). Without it the build still succeeds, nothing references clarabel, and every
//! design call says what to install: `platoon run` never needs a system library.
use std::path::Path;

const CANDIDATES: [&str; 5] = [
    "/usr/lib/x86_64-linux-gnu/libopenblas.so",
    "/usr/lib/aarch64-linux-gnu/libopenblas.so",
    "/usr/lib64/libopenblas.so",
    "/usr/lib/libopenblas.so",
    "/usr/local/lib/libopenblas.so",
];

/// Debian's package database: changes when a package (libopenblas-dev) is installed.
const DPKG_STATUS: &str = "/var/lib/dpkg/status";

fn main() {
    println!("cargo:rustc-check-cfg=cfg(sdp_solver)");
    println!("cargo:rerun-if-env-changed=PLATOON_NO_OPENBLAS");
    // Watch only paths that exist: cargo reruns a build script on every build when a watched
    // path is missing, which would recompile this crate and the CLI each time.
    let present: Vec<&str> = CANDIDATES
        .into_iter()
        .filter(|c| Path::new(c).exists())
        .collect();
    for c in &present {
        println!("cargo:rerun-if-changed={c}");
    }
    if present.is_empty() && Path::new(DPKG_STATUS).exists() {
        // Installing libopenblas-dev later changes dpkg's status file: the next build links it.
        println!("cargo:rerun-if-changed={DPKG_STATUS}");
    }
    let found = std::env::var_os("PLATOON_NO_OPENBLAS").is_none() && !present.is_empty();
    if found {
        println!("cargo:rustc-link-lib=dylib=openblas");
        println!("cargo:rustc-cfg=sdp_solver");
    } else {
        println!(
            "cargo:warning=OpenBLAS not found: `platoon design` and the LMI experiments are built without their SDP solver (install libopenblas-dev and rebuild, which picks it up by itself on Debian; elsewhere `touch crates/synthesis/build.rs` first; .ci/run installs it)"
        );
    }
}
