//! # aerosid-core
//!
//! On-line aerodynamic model identification for small fixed-wing UAVs, for a Cortex-M4F flight
//! computer: `no_std`, no heap, no `unsafe`, fixed-size const-generic matrices, generic over the
//! scalar (`f32` on the MCU, `f64` on the host).
//!
//! ## Conventions
//! * SI units and radians everywhere; names carry units (`airspeed_mps`, `rate_rad_s`, `dt_s`).
//! * Body frame FRD (x forward, y right, z down). Rates are normalised as `p_n = p b/(2V)`,
//!   `q_n = q c̄/(2V)`, `r_n = r b/(2V)` (seed 000, eq. 3).
//! * Regressor vectors put the exactly known regressors (the intercept `1`) first, then the noisy
//!   ones; the output `z` is separate (see [`gtls`]).
//! * Every step returns `Result<_, Error>`; a refused sample leaves the estimator untouched.
//!
//! ## Modules
//! * [`aero`] — what the flight computer measures ([`aero::SensorSample`]) and knows
//!   ([`aero::Airframe`]); the synthesis of the six coefficients from eq. 1–2
//!   ([`aero::synthesis`], with a causal 5-point differentiator for `ω̇`), the regressor sets and
//!   `W_T` of eq. 3 ([`aero::model`]) and the six-estimator [`aero::pipeline::Pipeline`] that refuses
//!   a sample only for the coefficients whose channels are bad.
//! * [`drivers`] — sensor drivers over embedded-hal 1.0 buses (IMU, airspeed, vanes) and the
//!   control-surface/RPM source, each returning errors and health flags, never bad samples.
//! * [`mavlink`] — MAVLink 2 over the UART, hand-encoded: heartbeat and per-coefficient
//!   `DEBUG_FLOAT_ARRAY` telemetry out, a byte-at-a-time parser for `SERVO_OUTPUT_RAW` and RPM in, and
//!   the [`mavlink::SurfaceSource`] that turns them into deflections, throttle and propeller speed.
//! * [`fem`] — the filter error method (seed 001): separate state and parameter filters for models
//!   with process noise; the HFB-320 and the seed's longitudinal model.
//! * [`gtls`] — recursive PCA-GTLS (seed 000, Algorithm 1, eq. 8–23) with mixed LS–TLS for exact
//!   regressors.
//! * [`linalg::secular`] — the rank-one SVD/eigen update by the secular equation (ref. \[17\]).
//! * [`vff`] — the variable forgetting factor (eq. 24–33) and our reading of the damaged eq. 28.
//! * [`rls`] — the recursive least-squares baseline.
//! * [`estimator`] — the common [`Estimator`] trait and step report.
//! * [`harness`] — the constants the firmware and the host's QEMU harness share.
//!
//! The estimator of one eq. 3 coefficient is [`GtlsWithIntercept`] (`Gtls<T, N, 1, N>`), named
//! per model as [`GtlsLongitudinal`], [`GtlsDrag`] and [`GtlsLateral`].
//!
//! ## Example
//! One coefficient `z = θ₀ + θ₁ x₁ + θ₂ x₂` identified sample by sample, the intercept exact and
//! `x₁, x₂, z` taken as noisy: the on-board estimator's use, in `f64` here. The data below carry
//! no noise, so the estimate is the true `θ` to rounding.
//!
//! ```
//! use aerosid_core::{Estimator, GtlsSettings, GtlsWithIntercept};
//! use nalgebra::{SMatrix, SVector};
//! // W_T: the error covariance of the noisy block [x₁, x₂, z] (eq. 9); W: the parameters' weights.
//! let w_t = SMatrix::<f64, 3, 3>::from_diagonal_element(1e-4);
//! let weights = SVector::<f64, 3>::repeat(1.0);
//! let mut gtls = GtlsWithIntercept::<f64, 3>::new(&w_t, &weights, GtlsSettings::default())?;
//! for k in 0..200 {
//!     let (x1, x2) = ((0.1 * k as f64).sin(), (0.37 * k as f64).cos());
//!     let z = 0.5 + 2.0 * x1 - 1.0 * x2;
//!     gtls.update(&SVector::from([1.0, x1, x2]), z)?;
//! }
//! let theta = gtls.theta();
//! assert!((theta[0] - 0.5).abs() < 1e-6 && (theta[1] - 2.0).abs() < 1e-6 && (theta[2] + 1.0).abs() < 1e-6);
//! # Ok::<(), aerosid_core::Error>(())
//! ```
//!
//! ## References
//! * Seed 000: Vaiopoulos, Zogopoulos-Papaliakos, Kyriakopoulos, *On-line Aerodynamic Model
//!   Identification on Small Fixed-Wing UAVs with Uncertain Flight Data* (NTUA).
//! * Gu & Eisenstat, *A stable and fast algorithm for updating the singular value decomposition*, 1994.
//! * Bunch, Nielsen & Sorensen, *Rank-one modification of the symmetric eigenproblem*, 1978.
//! * Paleologu, Benesty & Ciochină, *A robust variable forgetting factor RLS algorithm*, IEEE SPL 2008.
//! * Van Huffel & Vandewalle, *The Total Least Squares Problem*, SIAM 1991.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]
// `!(x > 0)` is deliberate throughout: it is true for NaN, which is how non-finite values are refused.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops over const dimensions mirror the equations (and several arrays are indexed together).
#![allow(clippy::needless_range_loop)]

pub mod aero;
pub mod drivers;
pub mod error;
pub mod estimator;
pub mod fem;
pub mod gtls;
pub mod harness;
pub mod linalg;
pub mod mavlink;
pub mod rls;
pub mod scalar;
pub mod vff;

pub use error::Error;
pub use estimator::{Estimator, Solution, Step};
pub use gtls::{Forgetting, Gtls, GtlsHealth, GtlsSettings};
pub use rls::{Rls, RlsSettings};
pub use scalar::Real;
pub use vff::{Eq28Reading, Vff, VffSettings};

/// Recursive PCA-GTLS over `N` parameters whose first regressor, the intercept `1`, is exact and
/// the others noisy — the form of every coefficient model of seed 000 eq. 3 (`NE = 1`, so the TLS
/// block has `NA = N − 1 + 1 = N` columns).
pub type GtlsWithIntercept<T, const N: usize> = Gtls<T, N, 1, N>;
/// Eq. 3a and 3e (`C_L`, `C_m`): regressors `[1, α, q_n, δe]`.
pub type GtlsLongitudinal<T> = GtlsWithIntercept<T, 4>;
/// Eq. 3b (`C_D`): regressors `[1, α, α², q_n, δe]`.
pub type GtlsDrag<T> = GtlsWithIntercept<T, 5>;
/// Eq. 3c, 3d and 3f (`C_Y`, `C_l`, `C_n`): regressors `[1, β, p_n, r_n, δa, δr]`.
pub type GtlsLateral<T> = GtlsWithIntercept<T, 6>;

/// Crate version, for telemetry and the firmware banner.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
