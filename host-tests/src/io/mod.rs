//! Flight-log input and output.
//!
//! * [`log`] — the project's CSV flight-log layout: one row per
//!   [`aerosid_core::aero::SensorSample`], named columns, SI units, radians.
//! * [`measured`] — measured flight data as the model-gap analysis reads it (named SI channels and
//!   the aircraft's constants), whatever file it came from.

pub mod log;
pub mod measured;
