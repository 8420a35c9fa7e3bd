//! Fuzz target `read_mat`: see `aerosid_fuzz::read_mat` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_mat::run(data));
