//! # aerosid
//!
//! The `aerosid` command and the analyses it runs for a user: the model-gap analysis
//! (`aerosid-gaps`, re-exported as [`gaps`]), user models and the filter error method
//! (`aerosid-fem`, re-exported as [`usermodel`], [`workflow`], [`fem_batch`], [`fem_report`]),
//! figures and HTML reports (`aerosid-report`, as [`plot`] and [`html`]), Monte Carlo, batches of
//! logs and the main job's report.
//!
//! It sits on top of the other crates: the reading layer (`aerosid-read`, re-exported below as
//! [`io`]: every log format to one measured flight), the simulator (`aerosid-sim`, re-exported as
//! [`sim`] and [`flights`], because the gap analysis and the main job use its types), the
//! QEMU harness (`aerosid-qemu`, for `aerosid replay --qemu`) and the ELF checks
//! (`aerosid-elf-check`, for `aerosid panic-audit` and `aerosid stack-bound`). Nothing here depends
//! on the test crate, so `cargo install --path tool` builds neither faer nor the test suites.
//!
//! The entry point a program shares with `aerosid batch`: one log read and analysed into its
//! folder ([`batch::run_one`]), never failing (a bad log is an `error` row with the message).
//!
//! ```
//! use aerosid::batch::{run_one, BatchSettings, Status};
//! use std::path::Path;
//! let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
//! let out = std::env::temp_dir().join(format!("aerosid-doc-{}", std::process::id()));
//! let mut settings = BatchSettings::new(&out);
//! settings.with = Some(data.join("maps/hfb320.map"));
//! settings.progress = false;
//! let row = run_one(&data.join("flight/hfb320_1_10.asc"), &settings);
//! assert_eq!(row.status, Status::Verdict, "{}", row.reason);
//! assert!(out.join(&row.folder).join("report.json").is_file());
//! # std::fs::remove_dir_all(&out).ok();
//! ```
#![forbid(unsafe_code)]
// Index loops mirror the matrix formulas of the estimators.
#![allow(clippy::needless_range_loop)]

pub mod batch;
pub mod card;
pub mod demo;
pub mod experiment;
pub mod longrun;
pub mod mc;
pub mod progress;
pub mod replay;
pub mod report;
pub mod table1;

/// The model-gap analysis (`aerosid-gaps`), with the benchmark campaign that drives it over
/// simulated flights, test cards and the vendored real flights (`aerosid gaps-bench`).
pub mod gaps {
    pub use aerosid_gaps::*;
    pub mod bench;
}

/// The user-model fitting (`aerosid-fem`): model files, the identify/validate/predict workflow,
/// the batch filter error method and the HFB-320 report.
pub use aerosid_fem::{fem_batch, fem_report, usermodel, workflow};
/// The reading layer (`aerosid-read`): every log format to one measured flight, under the name
/// the analyses use for it.
pub use aerosid_read as io;
/// SVG figures and report.html (`aerosid-report`).
pub use aerosid_report::{html, plot};
/// The simulator, under the name the analyses use for it.
pub use aerosid_sim as sim;
/// The main job's and the seed's flights.
pub use aerosid_sim::flights;
