//! The on-board identification pipeline: sample checks → coefficient synthesis (eq. 1–2) → the six
//! recursive PCA-GTLS estimators (eq. 3a–3f, Algorithm 1 of seed 000).
//!
//! ## Flow of one [`SensorSample`]
//! 1. Every channel is checked (finite, inside [`Limits`], `dt_s` within
//!    `dt_tolerance·nominal_dt_s` of nominal); failures are counted per channel in [`Health`] and the
//!    channel's value is replaced by 0 in the stored copy so it cannot leak into other outputs.
//! 2. The gyro enters the [`RateDifferentiator`] (a bad gyro or `dt_s` restarts its window); the
//!    sample enters a 5-slot delay line, so that the sample synthesised is the centre of the
//!    differentiator's window: the output lags the input by
//!    [`RateDifferentiator::DELAY_SAMPLES`] samples (20 ms at 100 Hz).
//! 3. The centre sample is synthesised ([`synthesise`]). With `α` or `β` missing the propeller's
//!    axial speed `V cos β cos(α + θ_p)` uses 0 for the missing angle (relative error in `J` about
//!    `α·tan(α + θ_p)` or `β²/2`, below 2 % for `|α|, |β| < 10°`); this is counted in
//!    [`Health::axial_speed_fallbacks`].
//! 4. Each coefficient is updated only if every channel it needs is valid (its output's channels and
//!    its regressors' channels, [`Pipeline::needed_channels`]) and, for the moments, the
//!    differentiator has a full window. Otherwise its estimator is not touched and the refusal is
//!    counted in its [`CoefficientHealth`]; the other coefficients still update.
//!
//! ## The moment prefilter
//! The moment coefficients' `ω̇` comes from the 5-point Savitzky–Golay slope of the gyro, which is
//! exactly the window average of the true `ω̇` with the kernel `[2, 3, 3, 2]/10` over the four
//! sample intervals (sum the slope's coefficients `[−2, −1, 0, 1, 2]/10h` to the right of each
//! interval). The synthetic `C_l, C_m, C_n` are therefore *smoothed* versions of the true ones, while
//! the regressors at the centre sample are not: wherever `ω̇` is not smooth on a 40 ms scale
//! (surface steps, servo rate limits, the start of a doublet) the two disagree, and the
//! disagreement is correlated with the surfaces. Measured on noise-free simulated data with servos
//! (τ 40 ms, 6 rad/s) and elevator 3-2-1-1s: batch OLS gave `C_mα −1.51, C_mq −17.8` for a truth
//! of `−1.3, −20`. With [`PipelineSettings::moment_prefilter`] (default on) every moment regressor
//! is passed through the same kernel, integrated over the samples by the trapezoidal rule:
//! [`MOMENT_PREFILTER`] `= [0.1, 0.25, 0.3, 0.25, 0.1]` over the window centred on the synthesised
//! sample (the equation `C = θᵀx` is linear, so filtering both sides keeps it); the same check
//! then gives `−1.276, −20.25`.
//!
//! The trapezoidal rule is a choice of variance over bias (measured below). Its frequency
//! response `0.3 + 0.5 cos ωh + 0.2 cos 2ωh = 1 − 0.65·(ωh)² + …` smooths the regressors a little
//! more than the differentiator smooths `ω̇` (`(sin ωh + 2 sin 2ωh)/(5ωh) = 1 − 17/30·(ωh)² + …`),
//! which leaves a small model mismatch: batch OLS on a noise-free flight is off the linearised truth
//! by 0.15 % on average over the ten moment derivatives with `|θ| ≥ 0.1` (`C_lr` 0.51 %, `C_lp`
//! 0.29 %, `C_lδa` 0.19 %, `C_nr` 0.14 %; `host-tests/tests/coverage.rs`,
//! `noise_free_moment_derivatives_match_the_truth`). Integrating the kernel by the four-point cubic
//! rule instead, `[15, 76, 58, 76, 15]/240`, matches the differentiator to fourth order and halves
//! that (0.07 %; `C_nr` 0.001 %, `C_mq` 0.001 %), and the in-class coverage of eq. 17's ±2σ went from
//! 0.895 to 0.914; `[19, 60, 82, 60, 19]/240` (second order, with the trapezoid's zero at Nyquist)
//! did about as well on bias (0.07 %, coverage 0.917). But both let more regressor noise through (`Σw²` 0.267 and 0.254
//! against 0.235, and no zero at Nyquist for the first), and over 24 seeded Fig. 2 flights (VFF,
//! the `C_m` jump, truth in the model class) the tracking got worse: `C_mα`'s error 5 s after the
//! jump 12.9 % → 14.6 % and 13.5 %, the time until it stays within 5 % 13.5 → 15.8 and 14.5 s. The
//! on-board default is the VFF, whose short memory makes variance the larger error, so the
//! trapezoid stays; a matched kernel with the trapezoid's noise needs a longer window (more delay).
//! The intercept is left exactly 1. White regressor noise shrinks by
//! `Σw² = 0.235` in variance, which scales the regressor block of the moments' `W_T`; the noise
//! becomes correlated over ±4 samples (eq. 17's `σ` then understates the spread of the moment
//! parameters somewhat; the host coverage test measures by how much). Cost: `5·(n_θ − 1)` multiply-
//! adds per moment coefficient. A moment coefficient needs its regressors' channels valid in all
//! five samples of the window.
//!
//! Channels each output needs (besides its regressors): forces `accel, airspeed, density, prop`,
//! plus `α` for `C_L`, `C_D` (and `α, β` for all three in [`ForceAxes::Wind`]); moments
//! `gyro, airspeed, density, prop` and a full differentiator window.

use super::model::{channel, idx, AeroModels, ChannelMask, CoefficientModel, Regressor, SensorNoise, RAW_COUNT};
use super::synthesis::{synthesise, ForceAxes, RateDifferentiator, Synthesis, SynthesisSettings};
use super::{Airframe, SensorSample};
use crate::estimator::{Estimator, Step};
use crate::gtls::{Gtls, GtlsSettings};
use crate::{Error, Real};
use nalgebra::Vector3;

/// Plausibility limits of the channels (a value outside is refused as out of range).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits<T> {
    /// Largest specific-force component, m/s². Default 160 (16 g).
    pub max_accel_mps2: T,
    /// Largest rate component, rad/s. Default 10.
    pub max_rate_rad_s: T,
    /// Smallest airspeed, m/s (the coefficients divide by `V²`). Default 5.
    pub min_airspeed_mps: T,
    /// Largest airspeed, m/s. Default 60.
    pub max_airspeed_mps: T,
    /// Largest `|α|`, rad. Default 0.5.
    pub max_alpha_rad: T,
    /// Largest `|β|`, rad. Default 0.5.
    pub max_beta_rad: T,
    /// Largest propeller speed, rad/s (negative is refused). Default 3000.
    pub max_prop_speed_rad_s: T,
    /// Largest `|δ|` of a surface, rad. Default 0.6.
    pub max_surface_rad: T,
    /// Air density range, kg/m³. Default 0.5…1.5.
    pub density_range_kgpm3: (T, T),
    /// Nominal sampling interval, s. Default 0.01 (100 Hz).
    pub nominal_dt_s: T,
    /// Accepted `|dt_s − nominal_dt_s|` as a fraction of `nominal_dt_s`. Default 0.5.
    pub dt_tolerance: T,
}

impl<T: Real> Limits<T> {
    /// Every limit 0: a placeholder for `const` initialisers.
    pub const ZERO: Self = Self {
        max_accel_mps2: T::ZERO,
        max_rate_rad_s: T::ZERO,
        min_airspeed_mps: T::ZERO,
        max_airspeed_mps: T::ZERO,
        max_alpha_rad: T::ZERO,
        max_beta_rad: T::ZERO,
        max_prop_speed_rad_s: T::ZERO,
        max_surface_rad: T::ZERO,
        density_range_kgpm3: (T::ZERO, T::ZERO),
        nominal_dt_s: T::ZERO,
        dt_tolerance: T::ZERO,
    };
}

impl<T: Real> Default for Limits<T> {
    fn default() -> Self {
        let l = T::lit;
        Self {
            max_accel_mps2: l(160.0),
            max_rate_rad_s: l(10.0),
            min_airspeed_mps: l(5.0),
            max_airspeed_mps: l(60.0),
            max_alpha_rad: l(0.5),
            max_beta_rad: l(0.5),
            max_prop_speed_rad_s: l(3000.0),
            max_surface_rad: l(0.6),
            density_range_kgpm3: (l(0.5), l(1.5)),
            nominal_dt_s: l(0.01),
            dt_tolerance: l(0.5),
        }
    }
}

impl<T: Real> Limits<T> {
    /// The valid channels of a sample ([`channel`] bits).
    pub fn valid_channels(&self, s: &SensorSample<T>) -> ChannelMask {
        let in_abs = |x: T, max: T| x.finite() && x.abs() <= max;
        let vec_in = |v: &Vector3<T>, max: T| v.iter().all(|x| in_abs(*x, max));
        let mut m = 0;
        let mut set = |ok: bool, bit: u16| {
            if ok {
                m |= bit;
            }
        };
        set(vec_in(&s.accel_mps2, self.max_accel_mps2), channel::ACCEL);
        set(vec_in(&s.gyro_rad_s, self.max_rate_rad_s), channel::GYRO);
        set(
            s.airspeed_mps >= self.min_airspeed_mps && s.airspeed_mps <= self.max_airspeed_mps,
            channel::AIRSPEED,
        );
        set(in_abs(s.alpha_rad, self.max_alpha_rad), channel::ALPHA);
        set(in_abs(s.beta_rad, self.max_beta_rad), channel::BETA);
        set(
            s.prop_speed_rad_s >= T::zero() && s.prop_speed_rad_s <= self.max_prop_speed_rad_s,
            channel::PROP,
        );
        set(in_abs(s.elevator_rad, self.max_surface_rad), channel::ELEVATOR);
        set(in_abs(s.aileron_rad, self.max_surface_rad), channel::AILERON);
        set(in_abs(s.rudder_rad, self.max_surface_rad), channel::RUDDER);
        let (rho_min, rho_max) = self.density_range_kgpm3;
        set(
            s.air_density_kgpm3 >= rho_min && s.air_density_kgpm3 <= rho_max,
            channel::DENSITY,
        );
        set(
            s.t_s.finite() && (s.dt_s - self.nominal_dt_s).abs() <= self.dt_tolerance * self.nominal_dt_s,
            channel::DT,
        );
        m
    }
}

/// The moment prefilter's FIR, oldest to newest (symmetric; module doc). Sums to 1.
pub const MOMENT_PREFILTER: [f64; 5] = [0.1, 0.25, 0.3, 0.25, 0.1];

/// The largest `n_θ` of the default models (the width of [`PipelineStep::regressors`]).
pub const MAX_PARAMETERS: usize = 6;

/// Settings of the pipeline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PipelineSettings<T> {
    /// Synthesis conventions.
    pub synthesis: SynthesisSettings<T>,
    /// Channel limits and the nominal `dt`.
    pub limits: Limits<T>,
    /// Sensor specifications for `W_T`.
    pub noise: SensorNoise<T>,
    /// Settings shared by the six estimators.
    pub gtls: GtlsSettings<T>,
    /// Pass the moment coefficients' regressors through [`MOMENT_PREFILTER`] (module doc). Default
    /// on.
    pub moment_prefilter: bool,
}

impl<T: Real> PipelineSettings<T> {
    /// A placeholder for `const` initialisers, replaced before use.
    pub const PLACEHOLDER: Self = Self {
        synthesis: SynthesisSettings::ZERO,
        limits: Limits::ZERO,
        noise: SensorNoise::ZERO,
        gtls: GtlsSettings::PLACEHOLDER,
        moment_prefilter: false,
    };
}

impl<T: Real> Default for PipelineSettings<T> {
    fn default() -> Self {
        Self {
            synthesis: SynthesisSettings::default(),
            limits: Limits::default(),
            noise: SensorNoise::default(),
            gtls: GtlsSettings::default(),
            moment_prefilter: true,
        }
    }
}

/// Why a coefficient did not update on a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// The delay line or the differentiator window is not yet full (start-up, or after a gyro or
    /// `dt_s` fault).
    Warmup,
    /// These needed channels ([`channel`] bits) were missing or out of range.
    Channels(ChannelMask),
    /// The estimator refused the sample (its state is unchanged).
    Estimator(Error),
    /// The pipeline is the unconfigured [`Pipeline::PLACEHOLDER`] (or a
    /// [`configure`](Pipeline::configure) failed): every sample is refused and nothing changes,
    /// the health counters included.
    NotConfigured,
}

/// What one coefficient's estimator did with a sample.
pub type CoefficientStatus<T> = Result<Step<T>, Refusal>;

/// Counters of one coefficient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CoefficientHealth {
    /// Accepted updates.
    pub updates: u32,
    /// Refused for a missing or out-of-range channel.
    pub refused_channels: u32,
    /// Refused during warm-up of the delay line / differentiator.
    pub refused_warmup: u32,
    /// Refused by the estimator itself.
    pub refused_estimator: u32,
}

/// The pipeline's health report (for telemetry).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Samples processed.
    pub samples: u32,
    /// Samples with each channel invalid, indexed by the bit position of [`channel`].
    pub invalid_channel: [u32; channel::COUNT],
    /// Synthesised samples whose propeller axial speed used the α/β fallback (module doc).
    pub axial_speed_fallbacks: u32,
    /// Per coefficient, indexed by [`idx`].
    pub coefficients: [CoefficientHealth; idx::COUNT],
}

impl Health {
    /// Every counter 0 (a `const`; equal to `default()`).
    pub const ZERO: Self = Self {
        samples: 0,
        invalid_channel: [0; channel::COUNT],
        axial_speed_fallbacks: 0,
        coefficients: [CoefficientHealth {
            updates: 0,
            refused_channels: 0,
            refused_warmup: 0,
            refused_estimator: 0,
        }; idx::COUNT],
    };
}

/// A point in [`Pipeline::process_probed`] where the probe is called.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stage {
    /// Channel checks, delay line, differentiator and synthesis done.
    Synthesis,
    /// The coefficient of this [`idx`] done (updated or refused).
    Coefficient(usize),
}

/// The result of one [`Pipeline::process`] call.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PipelineStep<T: Real> {
    /// The synthesis of the centre sample, once the delay line is full and `V`, `ρ` are valid.
    pub synthesis: Option<Synthesis<T>>,
    /// Per coefficient, indexed by [`idx`].
    pub status: [CoefficientStatus<T>; idx::COUNT],
    /// Per coefficient, the regressor vector `x` given to its estimator (first `n_θ` entries, the
    /// rest 0); all 0 where no update was attempted. With the output in
    /// [`Synthesis::coefficients`] this is the exact row the estimator saw (for baselines and logs).
    pub regressors: [[T; MAX_PARAMETERS]; idx::COUNT],
}

impl<T: Real> PipelineStep<T> {
    /// Nothing synthesised, every coefficient in warm-up (a `const`, for the firmware's static).
    pub const WARMUP: Self = Self {
        synthesis: None,
        status: [Err(Refusal::Warmup); idx::COUNT],
        regressors: [[T::ZERO; MAX_PARAMETERS]; idx::COUNT],
    };
}

impl<T: Real> Default for PipelineStep<T> {
    /// [`Self::WARMUP`].
    fn default() -> Self {
        Self::WARMUP
    }
}

/// Synthesis state and the six estimators (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pipeline<T: Real> {
    airframe: Airframe<T>,
    models: AeroModels<T>,
    settings: PipelineSettings<T>,
    differentiator: RateDifferentiator<T>,
    /// Sanitised samples in a ring: the newest is `delay[head]`, the one of age `a` (samples)
    /// `delay[(head + a) % DELAY_LEN]`; the centre has age `DELAY_SAMPLES`. Also the moment
    /// prefilter's window (the FIR is symmetric, so newest-first order is its order too).
    delay: [SensorSample<T>; DELAY_LEN],
    /// The valid channels of each sample in `delay`.
    delay_masks: [ChannelMask; DELAY_LEN],
    /// Slot of the newest sample in `delay`.
    head: u8,
    /// [`Regressor::raw_row`] of each sample in `delay` (same slots): the moment prefilter's inputs.
    raw: [[T; RAW_COUNT]; DELAY_LEN],
    filled: u8,
    lift: Gtls<T, 4, 1, 4>,
    drag: Gtls<T, 5, 1, 5>,
    side: Gtls<T, 6, 1, 6>,
    roll: Gtls<T, 6, 1, 6>,
    pitch: Gtls<T, 4, 1, 4>,
    yaw: Gtls<T, 6, 1, 6>,
    health: Health,
    /// [`Pipeline::needed_channels`] and the regressors' own channels of each coefficient, fixed
    /// by the configuration: formed once there, not from the models on every sample.
    needs: [(ChannelMask, ChannelMask); idx::COUNT],
    /// Set by a successful [`Pipeline::configure`]; until then every sample is refused
    /// ([`Refusal::NotConfigured`]).
    configured: bool,
}

/// Length of the delay line: the differentiator's window.
const DELAY_LEN: usize = RateDifferentiator::<f32>::LEN;

/// `Σ w²` of [`MOMENT_PREFILTER`].
fn prefilter_gain<T: Real>() -> T {
    MOMENT_PREFILTER
        .iter()
        .fold(T::zero(), |a, w| a + T::lit(*w) * T::lit(*w))
}

/// Builds one coefficient's estimator into `est`. Not inlined: its temporaries (`W_T`, its factor
/// and inverse, the new estimator) live in its own frame, which the six calls reuse one after the
/// other, not all at once in the caller's (the firmware builds the pipeline at boot).
#[inline(never)]
fn build_estimator<T: Real, const N: usize>(
    est: &mut Gtls<T, N, 1, N>,
    m: &CoefficientModel<T, N>,
    s: &PipelineSettings<T>,
    af: &Airframe<T>,
    prefiltered: bool,
) -> Result<(), Error> {
    m.validate()?;
    let gain = if prefiltered { prefilter_gain() } else { T::one() };
    let w_t = m.error_covariance_filtered(&s.noise, af.span_m, af.chord_m, gain);
    *est = Gtls::new(&w_t, &m.weight_vector(), s.gtls)?;
    Ok(())
}

/// The regressor row of one coefficient for the centre sample: from the centre alone, or (moment
/// prefilter) from the whole window.
struct Row<'a, T: Real> {
    centre: &'a SensorSample<T>,
    syn: &'a Synthesis<T>,
    /// The window's [`Regressor::raw_row`]s (the ring) and [`MOMENT_PREFILTER`] in `T` in ring
    /// order, when the regressors are prefiltered.
    window: Option<(&'a [[T; RAW_COUNT]; DELAY_LEN], &'a [T; DELAY_LEN])>,
}

fn update_one<T: Real, const N: usize>(
    est: &mut Gtls<T, N, 1, N>,
    model: &CoefficientModel<T, N>,
    row: &Row<'_, T>,
    z: T,
    out: &mut [T; MAX_PARAMETERS],
) -> CoefficientStatus<T> {
    let x = match row.window {
        Some((raw, weights)) => model.filtered_from_raw(raw, weights),
        None => model.regressor_vector(row.centre, row.syn),
    };
    for (o, v) in out.iter_mut().zip(x.iter()) {
        *o = *v;
    }
    est.update(&x, z).map_err(Refusal::Estimator)
}

impl<T: Real> Pipeline<T> {
    /// A placeholder pipeline (placeholder airframe, models and settings, estimator storage, no
    /// data) for `const` initialisers: the firmware's static starts as this and is
    /// [`configure`](Self::configure)d in place at boot, so that the stack never holds the whole
    /// pipeline (≈ 5 KB). Until then it refuses every sample ([`Refusal::NotConfigured`]) and
    /// stays unchanged.
    ///
    /// Every number and flag in it is zero: a static holding it lies in `.bss` (zeroed at reset)
    /// instead of `.data`, whose initial image takes flash (≈ 5.7 KB of the firmware's), and the
    /// reset at the start of [`configure`](Self::configure) is a `memset`, not a copy of a ≈ 5 KB
    /// constant (another ≈ 5 KB of `.rodata`). The host test
    /// `qemu_replay::pipeline_static_has_no_flash_image` checks the firmware's static.
    pub const PLACEHOLDER: Self = Self {
        airframe: Airframe::ZERO,
        models: AeroModels::PLACEHOLDER,
        settings: PipelineSettings::PLACEHOLDER,
        differentiator: RateDifferentiator::new(),
        delay: [SensorSample::ZERO; DELAY_LEN],
        delay_masks: [0; DELAY_LEN],
        head: 0,
        raw: [[T::ZERO; RAW_COUNT]; DELAY_LEN],
        filled: 0,
        lift: Gtls::PLACEHOLDER,
        drag: Gtls::PLACEHOLDER,
        side: Gtls::PLACEHOLDER,
        roll: Gtls::PLACEHOLDER,
        pitch: Gtls::PLACEHOLDER,
        yaw: Gtls::PLACEHOLDER,
        health: Health::ZERO,
        needs: [(0, 0); idx::COUNT],
        configured: false,
    };

    /// A new pipeline. Errors: an invalid model ([`CoefficientModel::validate`]) or setting →
    /// [`Error::InvalidSetting`]; a `W_T` that is not positive definite →
    /// [`Error::NotPositiveDefinite`].
    pub fn new(airframe: Airframe<T>, models: AeroModels<T>, settings: PipelineSettings<T>) -> Result<Self, Error> {
        let mut p = Self::PLACEHOLDER;
        p.configure(airframe, models, settings)?;
        Ok(p)
    }

    /// Configures the pipeline in place and starts it afresh (no data, empty delay line, zero
    /// health counters): each estimator is built and stored in turn, so the stack holds at most one
    /// estimator under construction (the firmware configures its static at boot this way). Errors
    /// as [`Self::new`]; on `Err` the pipeline is the [`Self::PLACEHOLDER`] again (never half
    /// configured).
    pub fn configure(
        &mut self,
        airframe: Airframe<T>,
        models: AeroModels<T>,
        settings: PipelineSettings<T>,
    ) -> Result<(), Error> {
        let lim = &settings.limits;
        let valid = lim.nominal_dt_s > T::zero()
            && lim.dt_tolerance > T::zero()
            && lim.min_airspeed_mps > T::zero()
            && settings.noise.nominal_airspeed_mps > T::zero();
        *self = Self::PLACEHOLDER;
        if !valid {
            return Err(Error::InvalidSetting);
        }
        self.airframe = airframe;
        self.models = models;
        self.settings = settings;
        if let Err(e) = self.build_estimators() {
            *self = Self::PLACEHOLDER;
            return Err(e);
        }
        self.needs = core::array::from_fn(|i| (self.needed_channels(i), self.regressor_channels(i)));
        self.configured = true;
        Ok(())
    }

    /// Builds the six estimators from the models, settings and airframe, one at a time in place.
    #[inline(never)]
    fn build_estimators(&mut self) -> Result<(), Error> {
        let (m, s, af) = (self.models, self.settings, self.airframe);
        let (m, s, af) = (&m, &s, &af);
        let pre = s.moment_prefilter;
        build_estimator(&mut self.lift, &m.lift, s, af, false)?;
        build_estimator(&mut self.drag, &m.drag, s, af, false)?;
        build_estimator(&mut self.side, &m.side, s, af, false)?;
        build_estimator(&mut self.roll, &m.roll, s, af, pre)?;
        build_estimator(&mut self.pitch, &m.pitch, s, af, pre)?;
        build_estimator(&mut self.yaw, &m.yaw, s, af, pre)
    }

    /// The channels coefficient `i` ([`idx`]) needs: its output's and its regressors'.
    pub fn needed_channels(&self, i: usize) -> ChannelMask {
        use channel::*;
        let force = ACCEL | AIRSPEED | DENSITY | PROP;
        let moment = GYRO | AIRSPEED | DENSITY | PROP;
        let angles = match self.settings.synthesis.force_axes {
            ForceAxes::Stability => 0,
            ForceAxes::Wind => ALPHA | BETA,
        };
        let own = match i {
            idx::LIFT | idx::DRAG => force | ALPHA | angles,
            idx::SIDE => force | angles,
            idx::ROLL | idx::PITCH | idx::YAW => moment,
            _ => return ALL,
        };
        own | self.regressor_channels(i)
    }

    /// The channels coefficient `i`'s regressors need.
    fn regressor_channels(&self, i: usize) -> ChannelMask {
        let m = &self.models;
        match i {
            idx::LIFT => m.lift.channels(),
            idx::DRAG => m.drag.channels(),
            idx::SIDE => m.side.channels(),
            idx::ROLL => m.roll.channels(),
            idx::PITCH => m.pitch.channels(),
            _ => m.yaw.channels(),
        }
    }

    /// Processes one sample (module doc). Never fails as a whole: each coefficient's outcome is in
    /// [`PipelineStep::status`], and a refused coefficient's estimator is untouched.
    pub fn process(&mut self, sample: &SensorSample<T>) -> PipelineStep<T> {
        self.process_probed(sample, &mut |_| {})
    }

    /// [`Self::process`] calling `probe` at the end of each stage: [`Stage::Synthesis`] once the
    /// sample is checked, delayed and synthesised, then [`Stage::Coefficient`] after each
    /// coefficient (updated or refused), in [`idx`] order. The core has no clock: the firmware's
    /// probe reads a counter there (instruction counts under QEMU, DWT cycles on hardware). The
    /// probe is not called during warm-up.
    pub fn process_probed(&mut self, sample: &SensorSample<T>, probe: &mut impl FnMut(Stage)) -> PipelineStep<T> {
        let mut step = PipelineStep::default();
        self.process_into(sample, &mut step, probe);
        step
    }

    /// [`Self::process_probed`] writing the result into `step` (every field is overwritten), so that
    /// the caller's buffer is filled in place: the on-board task keeps one and no result is copied.
    pub fn process_into(
        &mut self,
        sample: &SensorSample<T>,
        step: &mut PipelineStep<T>,
        probe: &mut impl FnMut(Stage),
    ) {
        if !self.configured {
            step.synthesis = None;
            step.status = [Err(Refusal::NotConfigured); idx::COUNT];
            step.regressors = [[T::zero(); MAX_PARAMETERS]; idx::COUNT];
            return;
        }
        let mask = self.settings.limits.valid_channels(sample);
        self.health.samples = self.health.samples.saturating_add(1);
        // Every channel valid (the common case): nothing to count.
        if mask != channel::ALL {
            for bit in 0..channel::COUNT {
                if mask & (1 << bit) == 0 {
                    self.health.invalid_channel[bit] = self.health.invalid_channel[bit].saturating_add(1);
                }
            }
        }
        self.differentiator.push(
            &sample.gyro_rad_s,
            sample.dt_s,
            mask & channel::GYRO != 0,
            mask & channel::DT != 0,
        );
        // The ring moves back one slot (no sample is copied): the new head holds the newest.
        let head = (usize::from(self.head) + DELAY_LEN - 1) % DELAY_LEN;
        self.head = head as u8;
        self.delay[head] = sanitise(sample, mask);
        self.delay_masks[head] = mask;
        self.raw[head] = Regressor::raw_row(&self.delay[head], self.airframe.span_m, self.airframe.chord_m);
        self.filled = (self.filled + 1).min(DELAY_LEN as u8);

        step.synthesis = None;
        step.status = [Err(Refusal::Warmup); idx::COUNT];
        let delay = RateDifferentiator::<T>::DELAY_SAMPLES;
        if (self.filled as usize) <= delay {
            step.regressors = [[T::zero(); MAX_PARAMETERS]; idx::COUNT];
            self.count(&step.status);
            return;
        }
        let centre = (head + delay) % DELAY_LEN;
        let cmask = self.delay_masks[centre];
        // The prefilter's window is the whole delay line; the channels valid in all of it.
        let window_full = self.filled as usize == DELAY_LEN;
        let wmask = self.delay_masks.iter().fold(channel::ALL, |m, k| m & *k);
        // The prefilter's weights in ring order: slot (head + a) % L carries the weight of age a.
        // (Converted to `T` at constant indices first: a run-time index into the `f64` table
        // would convert in software `f64` on the M4F every sample.)
        let by_age: [T; DELAY_LEN] = core::array::from_fn(|age| T::lit(MOMENT_PREFILTER[age]));
        let weights: [T; DELAY_LEN] = core::array::from_fn(|slot| by_age[(slot + DELAY_LEN - head) % DELAY_LEN]);
        let omega_dot = self.differentiator.derivative();
        let syn = if cmask & (channel::AIRSPEED | channel::DENSITY) == (channel::AIRSPEED | channel::DENSITY) {
            synthesise(
                &self.delay[centre],
                &self.airframe,
                &omega_dot.unwrap_or_else(Vector3::zeros),
                &self.settings.synthesis,
            )
            .ok()
        } else {
            None
        };
        if syn.is_some() && cmask & (channel::ALPHA | channel::BETA) != (channel::ALPHA | channel::BETA) {
            self.health.axial_speed_fallbacks = self.health.axial_speed_fallbacks.saturating_add(1);
        }
        step.synthesis = syn;
        probe(Stage::Synthesis);
        let prefilter = self.settings.moment_prefilter;
        for i in 0..idx::COUNT {
            let is_moment = matches!(i, idx::ROLL | idx::PITCH | idx::YAW);
            let filtered = is_moment && prefilter;
            let (needed, own) = self.needs[i];
            let mut missing = needed & !cmask;
            if filtered && window_full {
                // The regressors' channels in every sample of the window.
                missing |= own & !wmask;
            }
            let x_out = &mut step.regressors[i];
            *x_out = [T::zero(); MAX_PARAMETERS];
            step.status[i] = match syn {
                _ if missing != 0 => Err(Refusal::Channels(missing)),
                None => Err(Refusal::Channels(channel::AIRSPEED | channel::DENSITY)),
                Some(_) if is_moment && (omega_dot.is_none() || !window_full) => Err(Refusal::Warmup),
                Some(ref y) => {
                    let c = &y.coefficients;
                    let row = Row {
                        centre: &self.delay[centre],
                        syn: y,
                        window: filtered.then_some((&self.raw, &weights)),
                    };
                    match i {
                        idx::LIFT => update_one(&mut self.lift, &self.models.lift, &row, c.lift, x_out),
                        idx::DRAG => update_one(&mut self.drag, &self.models.drag, &row, c.drag, x_out),
                        idx::SIDE => update_one(&mut self.side, &self.models.side, &row, c.side, x_out),
                        idx::ROLL => update_one(&mut self.roll, &self.models.roll, &row, c.roll, x_out),
                        idx::PITCH => update_one(&mut self.pitch, &self.models.pitch, &row, c.pitch, x_out),
                        _ => update_one(&mut self.yaw, &self.models.yaw, &row, c.yaw, x_out),
                    }
                }
            };
            probe(Stage::Coefficient(i));
        }
        self.count(&step.status);
    }

    fn count(&mut self, status: &[CoefficientStatus<T>; idx::COUNT]) {
        for (h, s) in self.health.coefficients.iter_mut().zip(status.iter()) {
            let c = match s {
                Ok(_) => &mut h.updates,
                Err(Refusal::Warmup) => &mut h.refused_warmup,
                Err(Refusal::Channels(_)) => &mut h.refused_channels,
                Err(Refusal::Estimator(_)) => &mut h.refused_estimator,
                // Not counted: an unconfigured pipeline changes nothing (`process_into`).
                Err(Refusal::NotConfigured) => continue,
            };
            *c = c.saturating_add(1);
        }
    }

    /// The health counters.
    pub fn health(&self) -> &Health {
        &self.health
    }
    /// The settings in force.
    pub fn settings(&self) -> &PipelineSettings<T> {
        &self.settings
    }
    /// The regressor sets.
    pub fn models(&self) -> &AeroModels<T> {
        &self.models
    }
    /// The airframe constants.
    pub fn airframe(&self) -> &Airframe<T> {
        &self.airframe
    }
    /// The `C_L` estimator (eq. 3a).
    pub fn lift(&self) -> &Gtls<T, 4, 1, 4> {
        &self.lift
    }
    /// The `C_D` estimator (eq. 3b).
    pub fn drag(&self) -> &Gtls<T, 5, 1, 5> {
        &self.drag
    }
    /// The `C_Y` estimator (eq. 3c).
    pub fn side(&self) -> &Gtls<T, 6, 1, 6> {
        &self.side
    }
    /// The `C_l` estimator (eq. 3d).
    pub fn roll(&self) -> &Gtls<T, 6, 1, 6> {
        &self.roll
    }
    /// The `C_m` estimator (eq. 3e).
    pub fn pitch(&self) -> &Gtls<T, 4, 1, 4> {
        &self.pitch
    }
    /// The `C_n` estimator (eq. 3f).
    pub fn yaw(&self) -> &Gtls<T, 6, 1, 6> {
        &self.yaw
    }
}

/// A copy of the sample with every invalid channel set to 0.
fn sanitise<T: Real>(s: &SensorSample<T>, mask: ChannelMask) -> SensorSample<T> {
    let mut c = *s;
    // Every channel valid (the common case): no channel to zero. The attitude and the throttle
    // are checked whatever the mask (they have no channel bit).
    if mask != channel::ALL {
        let ok = |bit: u16| mask & bit != 0;
        let z = T::zero();
        if !ok(channel::ACCEL) {
            c.accel_mps2 = Vector3::zeros();
        }
        if !ok(channel::GYRO) {
            c.gyro_rad_s = Vector3::zeros();
        }
        if !ok(channel::AIRSPEED) {
            c.airspeed_mps = z;
        }
        if !ok(channel::ALPHA) {
            c.alpha_rad = z;
        }
        if !ok(channel::BETA) {
            c.beta_rad = z;
        }
        if !ok(channel::PROP) {
            c.prop_speed_rad_s = z;
        }
        if !ok(channel::ELEVATOR) {
            c.elevator_rad = z;
        }
        if !ok(channel::AILERON) {
            c.aileron_rad = z;
        }
        if !ok(channel::RUDDER) {
            c.rudder_rad = z;
        }
        if !ok(channel::DENSITY) {
            c.air_density_kgpm3 = z;
        }
        if !ok(channel::DT) {
            c.dt_s = z;
            if !c.t_s.finite() {
                c.t_s = z;
            }
        }
    }
    if !c.throttle.finite() {
        c.throttle = T::zero();
    }
    if !c.euler_rad.iter().all(|x| x.finite()) {
        c.euler_rad = Vector3::zeros();
    }
    c
}
