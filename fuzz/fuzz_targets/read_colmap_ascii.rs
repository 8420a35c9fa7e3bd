//! Fuzz target `read_colmap_ascii`: see `aerosid_fuzz::read_colmap_ascii` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_colmap_ascii::run(data));
