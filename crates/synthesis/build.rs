//! clarabel's SDP support needs BLAS and LAPACK: link the system OpenBLAS (Debian's
//! libopenblas-dev, which .ci/run installs), which carries both.
fn main() {
    println!("cargo:rustc-link-lib=dylib=openblas");
}
