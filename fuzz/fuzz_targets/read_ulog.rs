//! Fuzz target `read_ulog`: see `aerosid_fuzz::read_ulog` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_ulog::run(data));
