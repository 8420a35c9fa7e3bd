//! The six coefficient models of eq. 3a–3f (seed 000): which regressors each uses, how the regressor
//! vector is built from a synthesised sample, and the error covariance `W_T` (eq. 9) of each from
//! sensor specifications.
//!
//! ## Regressor sets (the defaults, fixed dimensions)
//! | coefficient | regressors | estimator |
//! |---|---|---|
//! | `C_L` (3a) | `[1, α, q_n, δe]` | `Gtls<T, 4, 1, 4>` |
//! | `C_D` (3b) | `[1, α, α², q_n, δe]` | `Gtls<T, 5, 1, 5>` |
//! | `C_Y` (3c) | `[1, β, p_n, r_n, δa, δr]` | `Gtls<T, 6, 1, 6>` |
//! | `C_l` (3d) | `[1, β, p_n, r_n, δa, δr]` | `Gtls<T, 6, 1, 6>` |
//! | `C_m` (3e) | `[1, α, q_n, δe]` | `Gtls<T, 4, 1, 4>` |
//! | `C_n` (3f) | `[1, β, p_n, r_n, δa, δr]` | `Gtls<T, 6, 1, 6>` |
//!
//! Every model has the intercept `1` first as the one exact regressor (mixed LS–TLS, see
//! [`gtls`](crate::gtls)); the seed prints no intercept in 3c, 3d, 3f but an intercept there absorbs
//! trims and the residual of the propeller torque model. `δa` is in `C_l` and `C_n` (the seeds README:
//! eq. 3d/3f omit it, which is wrong for a real aircraft). The regressor list of each model is
//! configuration ([`CoefficientModel::regressors`]); its length is the estimator's dimension.
//!
//! ## `W_T` from sensor specifications (eq. 9, Section V)
//! Diagonal in the sensor errors, in the order of the noisy regressors then the output:
//! `σ_α²`, `σ_β²`, `σ_δ²` for vanes and surfaces; rates through the normalisation at the nominal
//! airspeed `V₀`: `σ_{p_n} = σ_gyro b/(2V₀)`, `σ_{q_n} = σ_gyro c̄/(2V₀)`, `σ_{r_n} = σ_gyro b/(2V₀)`;
//! `α²` at the nominal `α₀` to second order: `var α² = 4α₀²σ_α² + 2σ_α⁴`, `cov(α, α²) = 2α₀σ_α²`
//! (the `2σ_α⁴` keeps `W_T` definite at `α₀ = 0`). The last diagonal entry `σ_ε²` is the synthetic
//! coefficient's own error (eq. 41), a parameter from the host-side Monte Carlo of Section V.
//!
//! *Math note*: the error of `V` in the rate normalisation, and the correlation between the rate
//! regressors and the moment coefficients (both contain the gyro error through `ω̇` and `ω × Jω`),
//! are neglected here; the Monte Carlo `σ_ε` is where such compound errors belong.

use super::synthesis::Synthesis;
use super::SensorSample;
use crate::{Error, Real};
use nalgebra::{SMatrix, SVector};

/// Indices of the six coefficients, in the order used by every per-coefficient array.
pub mod idx {
    /// `C_L`.
    pub const LIFT: usize = 0;
    /// `C_D`.
    pub const DRAG: usize = 1;
    /// `C_Y`.
    pub const SIDE: usize = 2;
    /// `C_l`.
    pub const ROLL: usize = 3;
    /// `C_m`.
    pub const PITCH: usize = 4;
    /// `C_n`.
    pub const YAW: usize = 5;
    /// Number of coefficients.
    pub const COUNT: usize = 6;
}

/// Sensor channels of a [`SensorSample`], as bits of a [`ChannelMask`].
pub mod channel {
    /// `accel_mps2`.
    pub const ACCEL: u16 = 1 << 0;
    /// `gyro_rad_s`.
    pub const GYRO: u16 = 1 << 1;
    /// `airspeed_mps`.
    pub const AIRSPEED: u16 = 1 << 2;
    /// `alpha_rad`.
    pub const ALPHA: u16 = 1 << 3;
    /// `beta_rad`.
    pub const BETA: u16 = 1 << 4;
    /// `prop_speed_rad_s`.
    pub const PROP: u16 = 1 << 5;
    /// `elevator_rad`.
    pub const ELEVATOR: u16 = 1 << 6;
    /// `aileron_rad`.
    pub const AILERON: u16 = 1 << 7;
    /// `rudder_rad`.
    pub const RUDDER: u16 = 1 << 8;
    /// `air_density_kgpm3`.
    pub const DENSITY: u16 = 1 << 9;
    /// `dt_s` (near nominal) and `t_s` (finite).
    pub const DT: u16 = 1 << 10;
    /// Number of channels.
    pub const COUNT: usize = 11;
    /// Every channel.
    pub const ALL: u16 = (1 << COUNT) - 1;
}

/// A set of [`channel`] bits.
pub type ChannelMask = u16;

/// Number of noisy regressors ([`Regressor::NOISY`], the slots of [`Regressor::raw_row`]).
pub const RAW_COUNT: usize = 9;

/// One regressor of eq. 3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Regressor {
    /// The intercept `1` (exact).
    One,
    /// `α`, rad.
    Alpha,
    /// `α²`, rad².
    Alpha2,
    /// `β`, rad.
    Beta,
    /// `p_n = p b/(2V)`.
    RollRateN,
    /// `q_n = q c̄/(2V)`.
    PitchRateN,
    /// `r_n = r b/(2V)`.
    YawRateN,
    /// `δe`, rad.
    Elevator,
    /// `δa`, rad.
    Aileron,
    /// `δr`, rad.
    Rudder,
}

impl Regressor {
    /// The regressor's value for a sample and its synthesis.
    pub fn value<T: Real>(self, s: &SensorSample<T>, syn: &Synthesis<T>) -> T {
        match self {
            Regressor::One => T::one(),
            Regressor::Alpha => s.alpha_rad,
            Regressor::Alpha2 => s.alpha_rad * s.alpha_rad,
            Regressor::Beta => s.beta_rad,
            Regressor::RollRateN => syn.rates_n.x,
            Regressor::PitchRateN => syn.rates_n.y,
            Regressor::YawRateN => syn.rates_n.z,
            Regressor::Elevator => s.elevator_rad,
            Regressor::Aileron => s.aileron_rad,
            Regressor::Rudder => s.rudder_rad,
        }
    }

    /// The regressor's value from a sample alone, with the normalised rates formed from the sample's
    /// own gyro and airspeed exactly as [`synthesise`](super::synthesis::synthesise) forms them
    /// (bit-identical to [`Self::value`] with that sample's synthesis). Used for the samples of the
    /// moment prefilter's window ([`super::pipeline`]).
    pub fn value_raw<T: Real>(self, s: &SensorSample<T>, span_m: T, chord_m: T) -> T {
        let two = T::lit(2.0);
        let v = s.airspeed_mps;
        match self {
            Regressor::RollRateN => s.gyro_rad_s.x * span_m / (two * v),
            Regressor::PitchRateN => s.gyro_rad_s.y * chord_m / (two * v),
            Regressor::YawRateN => s.gyro_rad_s.z * span_m / (two * v),
            Regressor::One => T::one(),
            Regressor::Alpha => s.alpha_rad,
            Regressor::Alpha2 => s.alpha_rad * s.alpha_rad,
            Regressor::Beta => s.beta_rad,
            Regressor::Elevator => s.elevator_rad,
            Regressor::Aileron => s.aileron_rad,
            Regressor::Rudder => s.rudder_rad,
        }
    }

    /// Every regressor but the intercept, in the order of [`Regressor::raw_row`]'s slots.
    pub const NOISY: [Regressor; RAW_COUNT] = [
        Regressor::Alpha,
        Regressor::Alpha2,
        Regressor::Beta,
        Regressor::RollRateN,
        Regressor::PitchRateN,
        Regressor::YawRateN,
        Regressor::Elevator,
        Regressor::Aileron,
        Regressor::Rudder,
    ];

    /// The regressor's slot in [`Regressor::raw_row`] (`None` for the intercept).
    pub fn raw_slot(self) -> Option<usize> {
        Self::NOISY.iter().position(|r| *r == self)
    }

    /// Every noisy regressor's [`Self::value_raw`] of one sample, computed once when the sample
    /// enters the pipeline's window (the moment prefilter then only weights and sums them). The
    /// normalised rates are 0 where the airspeed is not positive (a sanitised sample with an
    /// invalid airspeed; they are not used then, since their channel is invalid).
    pub fn raw_row<T: Real>(s: &SensorSample<T>, span_m: T, chord_m: T) -> [T; RAW_COUNT] {
        let v_ok = s.airspeed_mps > T::zero();
        Self::NOISY.map(|r| match r {
            Regressor::RollRateN | Regressor::PitchRateN | Regressor::YawRateN if !v_ok => T::zero(),
            r => r.value_raw(s, span_m, chord_m),
        })
    }

    /// The channels the regressor needs.
    pub fn channels(self) -> ChannelMask {
        match self {
            Regressor::One => 0,
            Regressor::Alpha | Regressor::Alpha2 => channel::ALPHA,
            Regressor::Beta => channel::BETA,
            Regressor::RollRateN | Regressor::PitchRateN | Regressor::YawRateN => channel::GYRO | channel::AIRSPEED,
            Regressor::Elevator => channel::ELEVATOR,
            Regressor::Aileron => channel::AILERON,
            Regressor::Rudder => channel::RUDDER,
        }
    }
}

/// Sensor error specifications (1σ) and the nominal flight condition at which `W_T` is formed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorNoise<T> {
    /// α vane, rad. Default 0.0087 (0.5°).
    pub alpha_rad: T,
    /// β vane, rad. Default 0.0087 (0.5°).
    pub beta_rad: T,
    /// Gyroscope, rad/s. Default 0.005.
    pub gyro_rad_s: T,
    /// Surface deflections, rad. Default 0.0035 (0.2°).
    pub surface_rad: T,
    /// Nominal airspeed `V₀` of the rate normalisation, m/s. Default 15.
    pub nominal_airspeed_mps: T,
    /// Nominal angle of attack `α₀` for the `α²` error, rad. Default 0.05.
    pub nominal_alpha_rad: T,
}

impl<T: Real> SensorNoise<T> {
    /// Every specification 0: a placeholder for `const` initialisers.
    pub const ZERO: Self = Self {
        alpha_rad: T::ZERO,
        beta_rad: T::ZERO,
        gyro_rad_s: T::ZERO,
        surface_rad: T::ZERO,
        nominal_airspeed_mps: T::ZERO,
        nominal_alpha_rad: T::ZERO,
    };
}

impl<T: Real> Default for SensorNoise<T> {
    fn default() -> Self {
        let l = T::lit;
        Self {
            alpha_rad: l(0.0087),
            beta_rad: l(0.0087),
            gyro_rad_s: l(0.005),
            surface_rad: l(0.0035),
            nominal_airspeed_mps: l(15.0),
            nominal_alpha_rad: l(0.05),
        }
    }
}

/// The model of one coefficient: its regressors (the exact intercept first) and the error `σ_ε` of
/// the synthetic coefficient itself (eq. 41). `NT` is the number of parameters `n_θ`; the estimator
/// is `Gtls<T, NT, 1, NT>`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoefficientModel<T, const NT: usize> {
    /// Regressors in order; `regressors[0]` must be [`Regressor::One`] and no other may be.
    pub regressors: [Regressor; NT],
    /// `σ_ε` of the synthetic coefficient (dimensionless), the last diagonal entry of `W_T` is its
    /// square (eq. 41).
    pub sigma_eps: T,
    /// Diagonal of `W` in eq. 23 (minimum weighted-norm solution), one per parameter. Default 1.
    pub weights: [T; NT],
}

impl<T: Real, const NT: usize> CoefficientModel<T, NT> {
    /// A placeholder for `const` initialisers (every regressor the intercept, `σ_ε` and the
    /// weights 0: it does not [`validate`](Self::validate)). All its numbers are zero, so that a
    /// static holding it needs no initial image in flash (see [`super::Pipeline::PLACEHOLDER`]).
    pub const fn placeholder() -> Self {
        Self {
            regressors: [Regressor::One; NT],
            sigma_eps: T::ZERO,
            weights: [T::ZERO; NT],
        }
    }

    /// A model with unit weights.
    pub fn new(regressors: [Regressor; NT], sigma_eps: T) -> Self {
        Self {
            regressors,
            sigma_eps,
            weights: [T::one(); NT],
        }
    }

    /// The same model with the minimum-norm weights `W_j = 1/s_j` (eq. 23) for typical parameter
    /// magnitudes `s_j > 0` (the intercept's entry is unused by the estimator and kept at 1).
    pub fn with_typical_magnitudes(mut self, magnitudes: [f64; NT]) -> Self {
        for j in 1..NT {
            self.weights[j] = T::one() / T::lit(magnitudes[j]);
        }
        self
    }

    /// Checks the documented constraints: the intercept first and only there, no repeated regressor,
    /// `σ_ε > 0`, positive weights.
    pub fn validate(&self) -> Result<(), Error> {
        if NT < 2 || self.regressors[0] != Regressor::One {
            return Err(Error::InvalidSetting);
        }
        for i in 1..NT {
            for j in 0..i {
                if self.regressors[i] == self.regressors[j] {
                    return Err(Error::InvalidSetting);
                }
            }
        }
        if !(self.sigma_eps > T::zero() && self.sigma_eps.finite()) {
            return Err(Error::InvalidSetting);
        }
        if !self.weights.iter().all(|w| *w > T::zero() && w.finite()) {
            return Err(Error::InvalidSetting);
        }
        Ok(())
    }

    /// The channels the regressors need.
    pub fn channels(&self) -> ChannelMask {
        self.regressors.iter().fold(0, |m, r| m | r.channels())
    }

    /// The regressor vector `x` of eq. 4 for a sample.
    pub fn regressor_vector(&self, s: &SensorSample<T>, syn: &Synthesis<T>) -> SVector<T, NT> {
        SVector::<T, NT>::from_fn(|i, _| self.regressors[i].value(s, syn))
    }

    /// [`Self::filtered_regressor_vector`] from the window's [`Regressor::raw_row`]s (bit-identical
    /// to it where the rates are defined): what the pipeline calls.
    pub fn filtered_from_raw<const L: usize>(&self, raw: &[[T; RAW_COUNT]; L], weights: &[T; L]) -> SVector<T, NT> {
        SVector::<T, NT>::from_fn(|i, _| match self.regressors[i].raw_slot() {
            None => T::one(),
            Some(slot) => {
                let mut acc = T::zero();
                for (row, w) in raw.iter().zip(weights.iter()) {
                    acc += *w * row[slot.min(RAW_COUNT - 1)];
                }
                acc
            }
        })
    }

    /// The regressor vector of the centre of a window of `L` samples passed through the FIR
    /// `weights` (the moment prefilter, [`super::pipeline`]): each regressor is computed per sample
    /// ([`Regressor::value_raw`]) and filtered; the intercept stays exactly 1.
    pub fn filtered_regressor_vector<const L: usize>(
        &self,
        window: &[SensorSample<T>; L],
        weights: &[T; L],
        span_m: T,
        chord_m: T,
    ) -> SVector<T, NT> {
        SVector::<T, NT>::from_fn(|i, _| match self.regressors[i] {
            Regressor::One => T::one(),
            r => {
                let mut acc = T::zero();
                for (s, w) in window.iter().zip(weights.iter()) {
                    acc += *w * r.value_raw(s, span_m, chord_m);
                }
                acc
            }
        })
    }

    /// `W` of eq. 23 as a vector.
    pub fn weight_vector(&self) -> SVector<T, NT> {
        SVector::<T, NT>::from_fn(|i, _| self.weights[i])
    }

    /// `W_T` (eq. 9) of the noisy block `[x_n, z]` (dimension `NT`: `NT − 1` noisy regressors and the
    /// output) from the sensor specifications (module doc), for an airframe of span `span_m` and
    /// chord `chord_m`.
    pub fn error_covariance(&self, noise: &SensorNoise<T>, span_m: T, chord_m: T) -> SMatrix<T, NT, NT> {
        self.error_covariance_filtered(noise, span_m, chord_m, T::one())
    }

    /// [`Self::error_covariance`] with the regressor block scaled by `regressor_gain` (`Σ w²` of an FIR
    /// applied to the regressors: the variance of white sensor noise after the filter); the output's
    /// `σ_ε²` is not scaled.
    pub fn error_covariance_filtered(
        &self,
        noise: &SensorNoise<T>,
        span_m: T,
        chord_m: T,
        regressor_gain: T,
    ) -> SMatrix<T, NT, NT> {
        let two = T::lit(2.0);
        let v0 = noise.nominal_airspeed_mps;
        let a0 = noise.nominal_alpha_rad;
        let sa2 = noise.alpha_rad * noise.alpha_rad;
        let cov = |a: Regressor, b: Regressor| -> T {
            use Regressor::*;
            match (a, b) {
                (Alpha, Alpha) => sa2,
                (Alpha, Alpha2) | (Alpha2, Alpha) => two * a0 * sa2,
                (Alpha2, Alpha2) => T::lit(4.0) * a0 * a0 * sa2 + two * sa2 * sa2,
                (Beta, Beta) => noise.beta_rad * noise.beta_rad,
                (RollRateN, RollRateN) | (YawRateN, YawRateN) => {
                    let s = noise.gyro_rad_s * span_m / (two * v0);
                    s * s
                }
                (PitchRateN, PitchRateN) => {
                    let s = noise.gyro_rad_s * chord_m / (two * v0);
                    s * s
                }
                (Elevator, Elevator) | (Aileron, Aileron) | (Rudder, Rudder) => noise.surface_rad * noise.surface_rad,
                _ => T::zero(),
            }
        };
        let mut w = SMatrix::<T, NT, NT>::zeros();
        for i in 0..NT - 1 {
            for j in 0..NT - 1 {
                w[(i, j)] = cov(self.regressors[i + 1], self.regressors[j + 1]) * regressor_gain;
            }
        }
        w[(NT - 1, NT - 1)] = self.sigma_eps * self.sigma_eps;
        w
    }
}

/// The regressor sets of all six coefficients (module doc), with the default dimensions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AeroModels<T> {
    /// `C_L` (eq. 3a).
    pub lift: CoefficientModel<T, 4>,
    /// `C_D` (eq. 3b).
    pub drag: CoefficientModel<T, 5>,
    /// `C_Y` (eq. 3c).
    pub side: CoefficientModel<T, 6>,
    /// `C_l` (eq. 3d, with `δa`).
    pub roll: CoefficientModel<T, 6>,
    /// `C_m` (eq. 3e).
    pub pitch: CoefficientModel<T, 4>,
    /// `C_n` (eq. 3f, with `δa`).
    pub yaw: CoefficientModel<T, 6>,
}

/// Typical magnitudes `s_j` of the default models' parameters (in regressor order, the intercept's
/// entry unused), the scales of the minimum weighted-norm solution (eq. 22–23, `W_j = 1/s_j`).
///
/// Rounded over the published small-UAV sets of `data/aircraft` (skywalker_2013_mod, Rascal 110)
/// and Beard & McLain's Aerosonde; a derivative that every set has as 0 (`C_Dq`, `C_Yp`, `C_Yr`) gets
/// 0.1, a tenth of the coefficient's leading derivative. `C_Dα²` is the induced drag's
/// `C_Lα²/(π e A)` (1.0–1.9).
pub mod typical {
    /// `C_L`: `[1, α, q_n, δe]`.
    pub const LIFT: [f64; 4] = [1.0, 5.0, 5.0, 0.2];
    /// `C_D`: `[1, α, α², q_n, δe]`.
    pub const DRAG: [f64; 5] = [1.0, 0.3, 2.0, 0.1, 0.1];
    /// `C_Y`: `[1, β, p_n, r_n, δa, δr]`.
    pub const SIDE: [f64; 6] = [1.0, 1.0, 0.1, 0.1, 0.1, 0.2];
    /// `C_l`: `[1, β, p_n, r_n, δa, δr]`.
    pub const ROLL: [f64; 6] = [1.0, 0.1, 0.5, 0.15, 0.2, 0.03];
    /// `C_m`: `[1, α, q_n, δe]`.
    pub const PITCH: [f64; 4] = [1.0, 1.0, 10.0, 0.5];
    /// `C_n`: `[1, β, p_n, r_n, δa, δr]`.
    pub const YAW: [f64; 6] = [1.0, 0.15, 0.05, 0.3, 0.03, 0.1];
}

impl<T: Real> AeroModels<T> {
    /// Placeholder models (intercept-only rows, `σ_ε = 1`) for `const` initialisers, replaced before
    /// use ([`Pipeline::configure`](crate::aero::Pipeline::configure)).
    pub const PLACEHOLDER: Self = Self {
        lift: CoefficientModel::placeholder(),
        drag: CoefficientModel::placeholder(),
        side: CoefficientModel::placeholder(),
        roll: CoefficientModel::placeholder(),
        pitch: CoefficientModel::placeholder(),
        yaw: CoefficientModel::placeholder(),
    };

    /// The default regressor sets with the given `σ_ε` per coefficient, indexed by [`idx`], and the
    /// minimum-norm weights `W_j = 1/s_j` of [`typical`].
    ///
    /// Our reading of eq. 23 (the seed leaves `W` open): when `k < n_θ`, the parameters of the
    /// unexcited directions are chosen as small as possible *relative to their typical size*. With unit
    /// weights a derivative whose regressor is small in value (`q_n ≈ 10⁻²`) is cheap in the norm, and
    /// the unexcited direction is filled with it: in the seed's Fig. 1 flight unit weights gave
    /// `C_Dq ≈ 1` and `C_Dα²` 61 % low; these weights give `C_Dq ≈ 0` and `C_Dα²` within 5 %.
    pub fn with_sigma_eps(sigma_eps: [T; idx::COUNT]) -> Self {
        use Regressor::*;
        let lat = [One, Beta, RollRateN, YawRateN, Aileron, Rudder];
        Self {
            lift: CoefficientModel::new([One, Alpha, PitchRateN, Elevator], sigma_eps[idx::LIFT])
                .with_typical_magnitudes(typical::LIFT),
            drag: CoefficientModel::new([One, Alpha, Alpha2, PitchRateN, Elevator], sigma_eps[idx::DRAG])
                .with_typical_magnitudes(typical::DRAG),
            side: CoefficientModel::new(lat, sigma_eps[idx::SIDE]).with_typical_magnitudes(typical::SIDE),
            roll: CoefficientModel::new(lat, sigma_eps[idx::ROLL]).with_typical_magnitudes(typical::ROLL),
            pitch: CoefficientModel::new([One, Alpha, PitchRateN, Elevator], sigma_eps[idx::PITCH])
                .with_typical_magnitudes(typical::PITCH),
            yaw: CoefficientModel::new(lat, sigma_eps[idx::YAW]).with_typical_magnitudes(typical::YAW),
        }
    }
}
