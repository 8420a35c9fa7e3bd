//! The factor from a standard error to the least size a test detects, the standard error known
//! (normal quantiles): what the oracle of the detection limits ([`super::oracle`]) states for the
//! aerodynamic candidates and the compatibility check and the instrumental-variable test state
//! for the sensor candidates. The selection's own factor, with the standard error estimated from
//! `G` block scores (Student-t quantiles), is [`super::select::detection_factor`].

use super::signal::normal_upper_quantile;

/// The detection probability the limits are stated for.
pub const POWER: f64 = 0.8;

/// `oracle_min_detectable / se` for an entry test of one-sided level `p_entry` and a held-out test
/// of level `gain_alpha`, the standard error known (normal quantiles).
pub fn detection_factor(p_entry: f64, gain_alpha: f64) -> f64 {
    normal_upper_quantile(p_entry).max(2.0 * normal_upper_quantile(gain_alpha)) + normal_upper_quantile(1.0 - POWER)
}

/// The one-sided level of a normal test whose two-sided threshold on `t²` is `threshold_t2`.
pub fn level_of_normal_threshold(threshold_t2: f64) -> f64 {
    0.5 * libm::erfc(threshold_t2.max(0.0).sqrt() / core::f64::consts::SQRT_2)
}
