//! Fuzz target `pipeline`: see `aerosid_fuzz::pipeline` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::pipeline::run(data));
