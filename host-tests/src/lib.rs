//! # aerosid-host-tests
//!
//! The host (std) side of aerosid: the `f64` desktop references (faer) the no_std core is checked
//! against, seeded data generators for tests and benchmarks, and the `aerosid` command-line tool.
//!
//! * [`reference`] — batch and compressed PCA-GTLS references built on faer's SVD/QR.
//! * [`data`] — seeded synthetic regression data (well/badly excited, collinear, noisy regressors).
#![forbid(unsafe_code)]
// Index loops mirror the matrix formulas of the references.
#![allow(clippy::needless_range_loop)]

pub mod data;
pub mod reference;
