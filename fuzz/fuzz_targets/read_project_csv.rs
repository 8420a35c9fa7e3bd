//! Fuzz target `read_project_csv`: see `aerosid_fuzz::read_project_csv` for the input format and the invariants checked.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| aerosid_fuzz::read_project_csv::run(data));
