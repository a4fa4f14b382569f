#![no_main]
//! Fuzz target `ngff_metadata`; the body is in `fuzz/targets.rs`, shared with
//! `tests/fuzz_regressions.rs`.

use libfuzzer_sys::fuzz_target;

#[path = "../targets.rs"]
mod targets;

fuzz_target!(|data: &[u8]| targets::ngff_metadata(data));
