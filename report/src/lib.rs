//! # aerosid-report
//!
//! What the analyses show a reader: SVG figures ([`plot`]), the model-gap report as one HTML page
//! ([`html`]), and the fit of a prediction to a measurement ([`fit`]: RMS, R², Theil's U), the same
//! definitions for the user model's simulation (`aerosid-fem`) and the gap analysis's prediction
//! of another flight (`aerosid-gaps`).
//!
//! It knows nothing of flights or models: a figure is built from arrays, the page from a JSON
//! value, a fit from two series, so both analyses sit above it and neither depends on the other.
//!
//! ```
//! use aerosid_report::fit::output_fit;
//! let measured = [1.0, 2.0, 3.0, 4.0];
//! let predicted = [1.1, 1.9, 3.2, 3.9];
//! let fit = output_fit("q", "rad/s", &measured, &predicted);
//! assert_eq!(fit.samples, 4);
//! assert!(fit.r2 > 0.95 && fit.theil_u < 0.05);
//! ```
#![forbid(unsafe_code)]

pub mod fit;
pub mod html;
pub mod plot;
