//! platoon-control's integration tests as one binary, `control`: each file of this folder is a module
//! (Cargo.toml sets `autotests = false`; a new file needs its `mod` line here, which the
//! workspace's `layout` test checks). One file's tests: `cargo test -p platoon-control --test control
//! user_detector::`.
mod plexe_agreement;
mod screening;
mod user_detector;
