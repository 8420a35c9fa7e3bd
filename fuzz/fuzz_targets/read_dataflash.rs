//! Fuzz target `read_dataflash`: see `aerosid_fuzz::read_dataflash` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_dataflash::run(data));
