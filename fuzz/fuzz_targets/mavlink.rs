//! Fuzz target `mavlink`: see `aerosid_fuzz::mavlink` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::mavlink::run(data));
