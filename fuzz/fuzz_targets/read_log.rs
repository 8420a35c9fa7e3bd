//! Fuzz target `read_log`: see `aerosid_fuzz::read_log` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_log::run(data));
