//! The core integration tests, one module per file of this directory, built as one test binary
//! (`autotests = false` and the `[[test]]` table in Cargo.toml): each file as its own binary linked
//! the library and instantiated the generic core again, which cost CI minutes. Run one file's tests
//! with a filter on its module: `cargo test -p aerosid-core --test integration mavlink::`.

mod driver_as5600;
mod driver_icm42688;
mod driver_ms4525do;
mod faults_drivers;
mod faults_sequence;
mod faults_stuck;
mod harness;
mod mavlink;
