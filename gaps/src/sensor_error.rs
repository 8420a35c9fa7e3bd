//! The sensor errors of the air data and attitude: the parameters the compatibility check
//! ([`super::compat`]) and the instrumental-variable test ([`super::instrumental`]) score, and
//! their scores and findings. Both report in these terms; the output-error check calls the
//! instrumental one on turbulent vanes, so the shared vocabulary sits below both.

use crate::io::measured::Quantity;

/// A sensor-error parameter of the compatibility model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum SensorParam {
    /// Additive bias of a channel (its unit).
    Bias(Quantity),
    /// Relative scale factor error `k` (`measured = (1+k) true`).
    Scale(Quantity),
    /// Time delay of a channel, s.
    Delay(Quantity),
    /// Unknown extra x position of a vane, m (`Alpha` or `Beta`).
    VaneX(Quantity),
}

impl SensorParam {
    /// The channel.
    pub fn channel(&self) -> Quantity {
        match *self {
            Self::Bias(q) | Self::Scale(q) | Self::Delay(q) | Self::VaneX(q) => q,
        }
    }
    /// Short name for reports, e.g. `bias(Alpha)`.
    pub fn name(&self) -> String {
        match self {
            Self::Bias(q) => format!("bias({q:?})"),
            Self::Scale(q) => format!("scale({q:?})"),
            Self::Delay(q) => format!("delay({q:?})"),
            Self::VaneX(q) => format!("vane_x({q:?})"),
        }
    }
    /// Unit of the estimate.
    pub fn unit(&self) -> &'static str {
        match self {
            Self::Bias(q) => unit_of(*q),
            Self::Scale(_) => "-",
            Self::Delay(_) => "s",
            Self::VaneX(_) => "m",
        }
    }
    /// Whether `value` is within the physical range of this kind of sensor error: a scale factor
    /// within ±50 % (vane upwash and calibration errors are tens of per cent), a delay within
    /// ±0.5 s (sensor lags and sampling skews; longer is a clock error, not a sensor); biases and
    /// vane offsets are not bounded. A candidate outside its range is not a sensor error of its
    /// kind — the reconstruction fails for that channel (on the longitudinal Twin Otter record,
    /// `scale(β) = −1.05`: the vane shows none of the reconstructed β's drift) — and is not entered.
    pub fn plausible(&self, value: f64) -> bool {
        match self {
            Self::Scale(_) => value.abs() <= 0.5,
            Self::Delay(_) => value.abs() <= 0.5,
            Self::Bias(_) | Self::VaneX(_) => value.is_finite(),
        }
    }

    /// Finite-difference step of the compatibility fit's Jacobian, in the parameter's unit.
    pub(super) fn fd_step(&self) -> f64 {
        match self {
            Self::Bias(q) => match q {
                Quantity::Airspeed => 1e-2,
                Quantity::AccelX | Quantity::AccelY | Quantity::AccelZ => 1e-3,
                _ => 1e-5,
            },
            Self::Scale(_) => 1e-4,
            Self::Delay(_) => 2e-3,
            Self::VaneX(_) => 1e-2,
        }
    }
}

/// The unit of a channel's bias.
pub(super) fn unit_of(q: Quantity) -> &'static str {
    match q {
        Quantity::Airspeed => "m/s",
        Quantity::AccelX | Quantity::AccelY | Quantity::AccelZ => "m/s²",
        Quantity::RollRate | Quantity::PitchRate | Quantity::YawRate => "rad/s",
        _ => "rad",
    }
}

/// A candidate's score in one round.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamScore {
    /// The parameter.
    pub param: SensorParam,
    /// Linearised estimate.
    pub value: f64,
    /// Its standard error (coloured residuals).
    pub sigma: f64,
    /// Partial test statistic `t²`.
    pub t2: f64,
    /// Which part scored it (`"attitude"`, `"velocity"` or `"instrumental"`).
    pub part: &'static str,
    /// The least |error| this flight names with about 80 % probability, in the parameter's unit:
    /// `(max(√t²_threshold, 2·T_crit) + t₀.₂)·σ`, as for the aerodynamic candidates
    /// (docs/model-gaps.md, "What the flight could detect"); NaN when not computed.
    pub min_detectable: f64,
    /// The oracle's standard error (docs/model-gaps.md, "The oracle"): the model-based σ of the
    /// candidate alone beside the baseline — for the compatibility check the first round's
    /// `sigma` itself, for the instrumental variables the coloured-residual σ of its regression.
    pub oracle_se: f64,
    /// `(max(z_entry, 2·z_gain) + z₀.₂)·oracle_se`, normal quantiles at the tests' levels; NaN
    /// when not computed.
    pub oracle_min_detectable: f64,
}

/// A sensor error found, with its final estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// The parameter.
    pub param: SensorParam,
    /// Estimate after the refit.
    pub value: f64,
    /// Standard error after the refit.
    pub sigma: f64,
    /// `t²` when it entered.
    pub t2: f64,
    /// Which part found it (`"attitude"`, `"velocity"` or `"instrumental"`).
    pub part: &'static str,
    /// Held-out gain of the kinematic reconstruction with this error over the same model without
    /// it (each segment predicted by a fit that left its fold out), against the noise of the
    /// held-out residuals: `T` of [`super::select::noise_referenced_gain`] (for the
    /// `"instrumental"` part, of its regression's blocks); NaN when the gains lean negative. For a
    /// bias of a turbulent air-data channel, the sign-flip `z` of [`super::select::gain`] instead.
    pub cv_gain_z: f64,
    /// The same gain relative to the held-out squared error without it.
    pub cv_gain: f64,
    /// Why it is not named (empty for a named error).
    pub why: String,
}
