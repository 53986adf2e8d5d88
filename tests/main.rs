//! The workspace's end-to-end tests as one binary, `e2e` (registered by crates/cli): each file
//! of this folder is a module, so that the whole workspace is linked once, not once per file.
//! A new file needs its `mod` line here (the `layout` module checks it). One file's tests:
//! `cargo test -p platoon-cli --test e2e cosim::`.
//!
//! A scenario's checks may read top to bottom in one function longer than the crates' sources
//! allow (the workspace's `too_many_lines`, for `crates/*/src`).
#![allow(clippy::too_many_lines)]
mod common;

mod campaign;
mod cli;
mod controller;
mod cosim;
mod degradation;
mod docs;
mod figures;
mod formations;
mod ground_truth;
mod group_key;
mod join_middle;
mod lanes;
mod layout;
mod leaves;
mod maneuvers;
mod merges;
mod mixed;
mod plexe_join;
mod search;
mod security;
mod sumo;
mod traffic;
