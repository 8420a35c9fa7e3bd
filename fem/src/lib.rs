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
//!
//! ```
//! use aerosid_fem::workflow::{run_fem, FemArgs};
//! use std::path::Path;
//! // The HFB-320 longitudinal model shipped with the tool; its `[data]` names the vendored flight.
//! let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/models/hfb320.toml");
//! let out = std::env::temp_dir().join(format!("aerosid-fem-doc-{}", std::process::id()));
//! let run = run_fem(&FemArgs {
//!     model,
//!     data: Vec::new(),
//!     with: None,
//!     segments: Vec::new(),
//!     validate: Vec::new(),
//!     validate_segments: Vec::new(),
//!     fix: Vec::new(),
//!     out: out.clone(),
//! })?;
//! assert!(run.saved.converged);
//! println!("{}", run.text);
//! # std::fs::remove_dir_all(&out).ok();
//! # Ok::<(), String>(())
//! ```
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
