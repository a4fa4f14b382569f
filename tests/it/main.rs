//! The integration tests: one test crate (one binary to build and link), with a module per
//! module of the library it tests (`tests/it/fit/` for `src/fit/`, ...) and `cli` for the
//! contracts of the `trimorph` command line (subcommands, bad inputs, exit codes, atomic
//! output). Fixtures are shared with every other test: `tests/common/` (helpers),
//! `tests/data/`, `tests/golden/`.
//!
//! Run one group with a filter on the module path, e.g. `cargo test --test it fit::`, or
//! `cargo test --test it cli::warp_cmd::`.
//!
//! `tests/fuzz_regressions.rs` stays a binary of its own: the fuzz targets it replays set
//! the process-wide memory budget (`trimorph::memory::set_limit`, 256 MiB), which would
//! apply to every test running beside them in one process.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod edit;
mod exact;
mod fit;
mod io;
mod jobs;
mod memory;
mod mesh;
mod morph;
mod register;
mod render;
mod server;
mod warp;
