//! # aerosid-fem
//!
//! Fitting a user's model file to flight data: output error and the filter error method of
//! `aerosid-core` (`aerosid_core::fem`), on the host side — the model file ([`usermodel`]: states,
//! inputs, outputs and parameters in TOML, equations as expressions), its data read into segments,
//! identification pooled over files or segments with parameters fixed, validation and prediction
//! of another flight ([`workflow`]), the batch Gauss–Newton filter error method on a stored record
//! ([`fem_batch`]) and the HFB-320 report against the published values ([`fem_report`]).
//!
//! The filter itself is the core's (`no_std`, the one that runs on board); this crate gives it a
//! model read at run time and the flights read by `aerosid-read`.
#![forbid(unsafe_code)]
// Index loops mirror the matrix formulas of the estimators.
#![allow(clippy::needless_range_loop)]

pub mod fem_batch;
pub mod fem_report;
pub mod usermodel;
pub mod workflow;

// The reading layer and the figures under the names the modules use for them (`crate::io::…`,
// `crate::plot::…`), as in the `aerosid` crate.
use aerosid_read as io;
use aerosid_report::plot;
