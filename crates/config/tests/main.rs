//! platoon-config's integration tests as one binary, `config`: each file of this folder is a module
//! (Cargo.toml sets `autotests = false`; a new file needs its `mod` line here, which the
//! workspace's `layout` test checks). One file's tests: `cargo test -p platoon-config --test config
//! typed::`.
mod configs;
mod link_attacks;
mod reaction;
mod reference;
mod scenarios;
mod typed;
