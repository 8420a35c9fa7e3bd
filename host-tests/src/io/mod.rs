//! Flight-log input and output.
//!
//! * [`log`] — the project's CSV flight-log layout: one row per
//!   [`aerosid_core::aero::SensorSample`], named columns, SI units, radians.

pub mod log;
