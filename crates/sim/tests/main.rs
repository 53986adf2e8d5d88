//! platoon-sim's integration tests as one binary, `sim`: each file of this folder is a module
//! (Cargo.toml sets `autotests = false`; a new file needs its `mod` line here, which the
//! workspace's `layout` test checks). One file's tests: `cargo test -p platoon-sim --test sim
//! truth::`.
mod scenario;
mod summary;
mod truth;
