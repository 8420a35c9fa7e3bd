//! Fuzz target `drivers`: see `aerosid_fuzz::drivers` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::drivers::run(data));
