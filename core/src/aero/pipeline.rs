//! The on-board identification pipeline: sample checks → coefficient synthesis (eq. 1–2) → the six
//! recursive PCA-GTLS estimators (eq. 3a–3f, Algorithm 1 of seed 000).
//!
//! ## Flow of one [`SensorSample`]
//! 1. Every channel is checked (finite, inside [`Limits`], `dt_s` within
//!    `dt_tolerance·nominal_dt_s` of nominal); failures are counted per channel in [`Health`] and the
//!    channel's value is replaced by 0 in the stored copy so it cannot leak into other outputs.
//! 2. The gyro enters the [`RateDifferentiator`] (a bad gyro or `dt_s` restarts its window); the
//!    sample enters a 3-slot delay line, so that the sample synthesised is the centre of the
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
//! Channels each output needs (besides its regressors): forces `accel, airspeed, density, prop`,
//! plus `α` for `C_L`, `C_D` (and `α, β` for all three in [`ForceAxes::Wind`]); moments
//! `gyro, airspeed, density, prop` and a full differentiator window.

use super::model::{channel, idx, AeroModels, ChannelMask, CoefficientModel, SensorNoise};
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
}

impl<T: Real> Default for PipelineSettings<T> {
    fn default() -> Self {
        Self {
            synthesis: SynthesisSettings::default(),
            limits: Limits::default(),
            noise: SensorNoise::default(),
            gtls: GtlsSettings::default(),
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

/// The result of one [`Pipeline::process`] call.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PipelineStep<T: Real> {
    /// The synthesis of the centre sample, once the delay line is full and `V`, `ρ` are valid.
    pub synthesis: Option<Synthesis<T>>,
    /// Per coefficient, indexed by [`idx`].
    pub status: [CoefficientStatus<T>; idx::COUNT],
}

/// Synthesis state and the six estimators (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pipeline<T: Real> {
    airframe: Airframe<T>,
    models: AeroModels<T>,
    settings: PipelineSettings<T>,
    differentiator: RateDifferentiator<T>,
    /// Sanitised samples and their valid channels, newest first.
    delay: [(SensorSample<T>, ChannelMask); 3],
    filled: u8,
    lift: Gtls<T, 4, 1, 4>,
    drag: Gtls<T, 5, 1, 5>,
    side: Gtls<T, 6, 1, 6>,
    roll: Gtls<T, 6, 1, 6>,
    pitch: Gtls<T, 4, 1, 4>,
    yaw: Gtls<T, 6, 1, 6>,
    health: Health,
}

fn estimator<T: Real, const N: usize>(
    m: &CoefficientModel<T, N>,
    s: &PipelineSettings<T>,
    af: &Airframe<T>,
) -> Result<Gtls<T, N, 1, N>, Error> {
    m.validate()?;
    let w_t = m.error_covariance(&s.noise, af.span_m, af.chord_m);
    Gtls::new(&w_t, &m.weight_vector(), s.gtls)
}

fn update_one<T: Real, const N: usize>(
    est: &mut Gtls<T, N, 1, N>,
    model: &CoefficientModel<T, N>,
    sample: &SensorSample<T>,
    syn: &Synthesis<T>,
    z: T,
) -> CoefficientStatus<T> {
    let x = model.regressor_vector(sample, syn);
    est.update(&x, z).map_err(Refusal::Estimator)
}

impl<T: Real> Pipeline<T> {
    /// A new pipeline. Errors: an invalid model ([`CoefficientModel::validate`]) or setting →
    /// [`Error::InvalidSetting`]; a `W_T` that is not positive definite →
    /// [`Error::NotPositiveDefinite`].
    pub fn new(airframe: Airframe<T>, models: AeroModels<T>, settings: PipelineSettings<T>) -> Result<Self, Error> {
        let lim = &settings.limits;
        if !(lim.nominal_dt_s > T::zero() && lim.dt_tolerance > T::zero() && lim.min_airspeed_mps > T::zero()) {
            return Err(Error::InvalidSetting);
        }
        if !(settings.noise.nominal_airspeed_mps > T::zero()) {
            return Err(Error::InvalidSetting);
        }
        let af = &airframe;
        Ok(Self {
            lift: estimator(&models.lift, &settings, af)?,
            drag: estimator(&models.drag, &settings, af)?,
            side: estimator(&models.side, &settings, af)?,
            roll: estimator(&models.roll, &settings, af)?,
            pitch: estimator(&models.pitch, &settings, af)?,
            yaw: estimator(&models.yaw, &settings, af)?,
            airframe,
            models,
            settings,
            differentiator: RateDifferentiator::new(),
            delay: [(SensorSample::default(), 0); 3],
            filled: 0,
            health: Health::default(),
        })
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
        let m = &self.models;
        match i {
            idx::LIFT => force | ALPHA | angles | m.lift.channels(),
            idx::DRAG => force | ALPHA | angles | m.drag.channels(),
            idx::SIDE => force | angles | m.side.channels(),
            idx::ROLL => moment | m.roll.channels(),
            idx::PITCH => moment | m.pitch.channels(),
            idx::YAW => moment | m.yaw.channels(),
            _ => ALL,
        }
    }

    /// Processes one sample (module doc). Never fails as a whole: each coefficient's outcome is in
    /// [`PipelineStep::status`], and a refused coefficient's estimator is untouched.
    pub fn process(&mut self, sample: &SensorSample<T>) -> PipelineStep<T> {
        let mask = self.settings.limits.valid_channels(sample);
        self.health.samples = self.health.samples.saturating_add(1);
        for bit in 0..channel::COUNT {
            if mask & (1 << bit) == 0 {
                self.health.invalid_channel[bit] = self.health.invalid_channel[bit].saturating_add(1);
            }
        }
        self.differentiator.push(
            &sample.gyro_rad_s,
            sample.dt_s,
            mask & channel::GYRO != 0,
            mask & channel::DT != 0,
        );
        self.delay[2] = self.delay[1];
        self.delay[1] = self.delay[0];
        self.delay[0] = (sanitise(sample, mask), mask);
        self.filled = (self.filled + 1).min(3);

        let mut step = PipelineStep {
            synthesis: None,
            status: [Err(Refusal::Warmup); idx::COUNT],
        };
        if (self.filled as usize) < 3 {
            self.count(&step.status);
            return step;
        }
        let (centre, cmask) = self.delay[RateDifferentiator::<T>::DELAY_SAMPLES];
        let omega_dot = self.differentiator.derivative();
        let syn = if cmask & (channel::AIRSPEED | channel::DENSITY) == (channel::AIRSPEED | channel::DENSITY) {
            synthesise(
                &centre,
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
        for i in 0..idx::COUNT {
            let missing = self.needed_channels(i) & !cmask;
            let is_moment = matches!(i, idx::ROLL | idx::PITCH | idx::YAW);
            step.status[i] = match syn {
                _ if missing != 0 => Err(Refusal::Channels(missing)),
                None => Err(Refusal::Channels(channel::AIRSPEED | channel::DENSITY)),
                Some(_) if is_moment && omega_dot.is_none() => Err(Refusal::Warmup),
                Some(ref y) => {
                    let c = &y.coefficients;
                    match i {
                        idx::LIFT => update_one(&mut self.lift, &self.models.lift, &centre, y, c.lift),
                        idx::DRAG => update_one(&mut self.drag, &self.models.drag, &centre, y, c.drag),
                        idx::SIDE => update_one(&mut self.side, &self.models.side, &centre, y, c.side),
                        idx::ROLL => update_one(&mut self.roll, &self.models.roll, &centre, y, c.roll),
                        idx::PITCH => update_one(&mut self.pitch, &self.models.pitch, &centre, y, c.pitch),
                        _ => update_one(&mut self.yaw, &self.models.yaw, &centre, y, c.yaw),
                    }
                }
            };
        }
        self.count(&step.status);
        step
    }

    fn count(&mut self, status: &[CoefficientStatus<T>; idx::COUNT]) {
        for (h, s) in self.health.coefficients.iter_mut().zip(status.iter()) {
            let c = match s {
                Ok(_) => &mut h.updates,
                Err(Refusal::Warmup) => &mut h.refused_warmup,
                Err(Refusal::Channels(_)) => &mut h.refused_channels,
                Err(Refusal::Estimator(_)) => &mut h.refused_estimator,
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
    let ok = |bit: u16| mask & bit != 0;
    let z = T::zero();
    let mut c = *s;
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
    if !c.throttle.finite() {
        c.throttle = z;
    }
    if !c.euler_rad.iter().all(|x| x.finite()) {
        c.euler_rad = Vector3::zeros();
    }
    c
}
