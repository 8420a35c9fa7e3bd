//! # aerosid-host
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
pub mod demo;
pub mod experiment;
pub mod fem_batch;
pub mod fem_report;
pub mod flights;
pub mod gaps;
pub mod io;
pub mod longrun;
pub mod mc;
pub mod panic_audit;
pub mod plot;
pub mod qemu;
pub mod reference;
pub mod replay;
pub mod report;
pub mod sim;
pub mod stack_bound;
pub mod table1;
