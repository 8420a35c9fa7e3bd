//! # aerosid
//!
//! The `aerosid` command and the analyses it runs for a user: reading flight logs, the model-gap
//! analysis, user models, Monte Carlo and the main job's report.
#![forbid(unsafe_code)]
// Index loops mirror the matrix formulas of the estimators.
#![allow(clippy::needless_range_loop)]

pub mod demo;
pub mod experiment;
pub mod fem_batch;
pub mod fem_report;
pub mod gaps;
pub mod io;
pub mod longrun;
pub mod mc;
pub mod plot;
pub mod replay;
pub mod report;
pub mod table1;
pub mod usermodel;
pub mod workflow;

pub use aerosid_sim as sim;
pub use aerosid_sim::flights;
