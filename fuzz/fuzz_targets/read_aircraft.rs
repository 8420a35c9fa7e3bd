//! Fuzz target `read_aircraft`: see `aerosid_fuzz::read_aircraft` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_aircraft::run(data));
