#![no_main]
//! Fuzz target `image_decode_warp`; the body is in `fuzz/targets.rs`, shared with
//! `tests/fuzz_regressions.rs`.

use libfuzzer_sys::fuzz_target;

#[path = "../targets.rs"]
mod targets;

fuzz_target!(|data: &[u8]| targets::image_decode_warp(data));
