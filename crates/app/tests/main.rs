//! platoon-app's integration tests as one binary, `app`: each file of this folder is a module
//! (Cargo.toml sets `autotests = false`; a new file needs its `mod` line here, which the
//! workspace's `layout` test checks). One file's tests: `cargo test -p platoon-app --test app
//! user_attack::`.
mod campaign;
mod design;
mod detection;
mod experiment;
mod run;
mod search_file;
mod user_attack;
