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

fn main() {
    println!("cargo:rustc-check-cfg=cfg(sdp_solver)");
    println!("cargo:rerun-if-env-changed=PLATOON_NO_OPENBLAS");
    for c in CANDIDATES {
        // A path that does not exist makes cargo rerun this script, so installing OpenBLAS
        // later is picked up by the next build.
        println!("cargo:rerun-if-changed={c}");
    }
    let found = std::env::var_os("PLATOON_NO_OPENBLAS").is_none()
        && CANDIDATES.iter().any(|c| Path::new(c).exists());
    if found {
        println!("cargo:rustc-link-lib=dylib=openblas");
        println!("cargo:rustc-cfg=sdp_solver");
    } else {
        println!(
            "cargo:warning=OpenBLAS not found: `platoon design` and the LMI experiments are built without their SDP solver (install libopenblas-dev and rebuild; .ci/run does)"
        );
    }
}
