//! Fuzz target `gtls`: see `aerosid_fuzz::gtls` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::gtls::run(data));
