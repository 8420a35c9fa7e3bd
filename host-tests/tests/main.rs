//! The host integration tests, one module per file of this directory, built as one test binary
//! (`autotests = false` and the `[[test]]` table in Cargo.toml): each file as its own binary linked
//! the library and instantiated the generic core again, which cost CI minutes. Run one file's tests
//! with a filter on its module: `cargo test -p aerosid-host --test integration qemu_replay::`.

mod against_faer;
mod cli;
mod common;
mod consistency;
mod corrected_regressor;
mod coverage;
mod default_aircraft;
mod fem;
mod fem_qemu;
mod flow_angles;
mod forgetting;
mod fuzz_readers;
mod gaps;
mod measured_data;
mod monte_carlo;
mod noise_free;
mod orthonormality;
mod paper;
mod plot;
mod properties;
mod qemu_faults;
mod qemu_replay;
mod real_logs;
mod reliability_faults;
mod reliability_link;
mod reliability_long_run;
mod reliability_numerical;
mod sim;
mod sizes;
mod synthesis;
mod table1;
mod workflow;
