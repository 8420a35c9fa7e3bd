//! # aerosid-host-tests
//!
//! The cross-crate tests and benchmarks of aerosid, with the `f64` desktop references (faer) the
//! no_std core is checked against and seeded data generators.
//!
//! It depends on every other host crate (dev-dependencies: the tool, the simulator, the QEMU harness,
//! the ELF checks) and nothing depends on it, so its tests may combine them freely. The tests that
//! run the `aerosid` binary live in `tool/tests/` (only the binary's own package is given its path).
//!
//! * [`reference`](mod@reference) — batch and compressed PCA-GTLS references built on faer's SVD/QR.
//! * [`data`] — seeded synthetic regression data (well/badly excited, collinear, noisy regressors).
#![forbid(unsafe_code)]
// Index loops mirror the matrix formulas of the references.
#![allow(clippy::needless_range_loop)]

pub mod data;
pub mod reference;
