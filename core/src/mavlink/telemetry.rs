//! Telemetry out: the heartbeat and one `DEBUG_FLOAT_ARRAY` per aerodynamic coefficient (layout in
//! the [module doc](super)).

use super::frame::{EncodeError, Encoder};
use super::messages::{name10, DebugFloatArray, Heartbeat, NamedValueFloat};
use crate::aero::model::idx;
use crate::aero::pipeline::MAX_PARAMETERS;

/// `DEBUG_FLOAT_ARRAY.name` of each coefficient, indexed by [`idx`] (also its `array_id`).
pub const COEFFICIENT_NAMES: [&str; idx::COUNT] = ["CL", "CD", "CY", "Cl", "Cm", "Cn"];

/// Positions in `DEBUG_FLOAT_ARRAY.data` of a coefficient report.
pub mod slot {
    /// `θ_0…θ_5` at `THETA..THETA + 6` (unused parameters 0).
    pub const THETA: usize = 0;
    /// `σ_0…σ_5` at `SIGMA..SIGMA + 6` (unused 0; NaN where undefined, e.g. `k < n_θ`).
    pub const SIGMA: usize = 6;
    /// Retained rank `k`.
    pub const RANK_K: usize = 12;
    /// Forgetting factor `λ_F`.
    pub const LAMBDA_F: usize = 13;
    /// Health flags (an integer below 2²⁴, exact in an `f32`).
    pub const HEALTH_FLAGS: usize = 14;
    /// Refused samples (saturates at 2²⁴ = 16 777 216, 46 h at 100 Hz).
    pub const REFUSED: usize = 15;
    /// Number of parameters `n_θ`.
    pub const N_PARAMS: usize = 16;
    /// Number of slots used.
    pub const COUNT: usize = 17;
}

/// Largest integer an `f32` holds exactly.
const F32_EXACT_MAX: u32 = 1 << 24;

/// A plain-data snapshot of one coefficient's estimate, as sent.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CoefficientReport {
    /// Which coefficient, by [`idx`] (`C_L` = 0 … `C_n` = 5); names in [`COEFFICIENT_NAMES`].
    pub coefficient: u8,
    /// Parameters `θ` (the first `n_params` used).
    pub theta: [f32; MAX_PARAMETERS],
    /// Their standard deviations `σ` (NaN where not defined).
    pub sigma: [f32; MAX_PARAMETERS],
    /// Number of parameters `n_θ` (1…6).
    pub n_params: u8,
    /// Retained rank `k` (eq. 21).
    pub rank_k: u8,
    /// Forgetting factor `λ_F`.
    pub lambda_f: f32,
    /// Health flags; bits 24…31 are not representable and are sent cleared (keep flags in 0…23).
    pub health_flags: u32,
    /// Refused samples (saturating at 2²⁴ on the wire).
    pub refused: u32,
}

impl CoefficientReport {
    /// The report as a `DEBUG_FLOAT_ARRAY` stamped `time_us`.
    pub fn to_debug_float_array(&self, time_us: u64) -> Result<DebugFloatArray, EncodeError> {
        let name = COEFFICIENT_NAMES
            .get(usize::from(self.coefficient))
            .ok_or(EncodeError::UnknownCoefficient)?;
        let mut m = DebugFloatArray {
            time_us,
            array_id: u16::from(self.coefficient),
            name: name10(name).ok_or(EncodeError::NameTooLong)?,
            ..DebugFloatArray::default()
        };
        let n = usize::from(self.n_params).min(MAX_PARAMETERS);
        for i in 0..n {
            m.data[slot::THETA + i] = self.theta[i];
            m.data[slot::SIGMA + i] = self.sigma[i];
        }
        m.data[slot::RANK_K] = f32::from(self.rank_k);
        m.data[slot::LAMBDA_F] = self.lambda_f;
        m.data[slot::HEALTH_FLAGS] = (self.health_flags & (F32_EXACT_MAX - 1)) as f32;
        m.data[slot::REFUSED] = self.refused.min(F32_EXACT_MAX) as f32;
        m.data[slot::N_PARAMS] = f32::from(self.n_params);
        Ok(m)
    }
}

impl CoefficientReport {
    /// The report a `DEBUG_FLOAT_ARRAY` of [`CoefficientReport::to_debug_float_array`] carries (the
    /// ground side's decoding; health flags and refused counts as sent, i.e. below 2²⁴).
    pub fn from_debug_float_array(m: &DebugFloatArray) -> Self {
        let mut r = Self {
            coefficient: m.array_id as u8,
            theta: [0.0; MAX_PARAMETERS],
            sigma: [0.0; MAX_PARAMETERS],
            n_params: m.data[slot::N_PARAMS] as u8,
            rank_k: m.data[slot::RANK_K] as u8,
            lambda_f: m.data[slot::LAMBDA_F],
            health_flags: m.data[slot::HEALTH_FLAGS] as u32,
            refused: m.data[slot::REFUSED] as u32,
        };
        r.theta
            .copy_from_slice(&m.data[slot::THETA..slot::THETA + MAX_PARAMETERS]);
        r.sigma
            .copy_from_slice(&m.data[slot::SIGMA..slot::SIGMA + MAX_PARAMETERS]);
        r
    }

    /// `true` if `θ`, `σ` (NaN equal to NaN), `k`, `λ_F` and `n_θ` are the same bit for bit.
    pub fn same_estimate_bits(&self, other: &Self) -> bool {
        let n = usize::from(self.n_params).min(MAX_PARAMETERS);
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        self.n_params == other.n_params
            && self.rank_k == other.rank_k
            && self.lambda_f.to_bits() == other.lambda_f.to_bits()
            && (0..n).all(|j| same(self.theta[j], other.theta[j]) && same(self.sigma[j], other.sigma[j]))
    }
}

/// The co-processor's telemetry writer: one [`Encoder`] (ids and sequence) for every frame it sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Telemetry {
    /// The frame encoder.
    pub encoder: Encoder,
}

impl Telemetry {
    /// Telemetry sent as `system_id`/`component_id` (e.g. the autopilot's system id and
    /// [`super::frame::MAV_COMP_ID_ONBOARD_COMPUTER`]).
    pub const fn new(system_id: u8, component_id: u8) -> Self {
        Self {
            encoder: Encoder::new(system_id, component_id),
        }
    }

    /// Writes the 1 Hz heartbeat (21 bytes) into `out`; returns its length.
    pub fn heartbeat(&mut self, system_status: u8, out: &mut [u8]) -> Result<usize, EncodeError> {
        self.encoder.encode(&Heartbeat::onboard_controller(system_status), out)
    }

    /// Writes one coefficient report (at most 100 bytes) into `out`; returns its length.
    pub fn coefficient(
        &mut self,
        report: &CoefficientReport,
        time_us: u64,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        self.encoder.encode(&report.to_debug_float_array(time_us)?, out)
    }

    /// Writes the reports one after another (at most 600 bytes for six) into `out`; returns the
    /// total length. On error nothing after the last whole frame is meaningful.
    pub fn coefficients(
        &mut self,
        reports: &[CoefficientReport],
        time_us: u64,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let mut at = 0;
        for r in reports {
            let rest = out.get_mut(at..).ok_or(EncodeError::BufferTooSmall)?;
            at += self.coefficient(r, time_us, rest)?;
        }
        Ok(at)
    }

    /// Writes the health report (168 bytes at most) into `out`; returns its length.
    pub fn health(&mut self, report: &HealthReport, time_us: u64, out: &mut [u8]) -> Result<usize, EncodeError> {
        self.encoder.encode(&report.to_debug_float_array(time_us), out)
    }

    /// Writes one `NAMED_VALUE_FLOAT` (30 bytes at most) into `out`; returns its length.
    pub fn named_value(
        &mut self,
        name: &str,
        value: f32,
        time_boot_ms: u32,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let m = NamedValueFloat {
            time_boot_ms,
            name: name10(name).ok_or(EncodeError::NameTooLong)?,
            value,
        };
        self.encoder.encode(&m, out)
    }
}

/// `DEBUG_FLOAT_ARRAY.name` of the co-processor's health report ([`HealthReport`]).
pub const HEALTH_NAME: &str = "health";
/// `DEBUG_FLOAT_ARRAY.array_id` of the health report (clear of the coefficients' 0…5).
pub const HEALTH_ARRAY_ID: u16 = 100;

/// Positions in `DEBUG_FLOAT_ARRAY.data` of the [`HealthReport`]: counters since boot (integers,
/// saturating at 2²⁴ on the wire) and masks of [`crate::aero::model::channel`] bits.
pub mod health_slot {
    /// Samples taken by the sampling task.
    pub const SAMPLED: usize = 0;
    /// Samples dropped because the estimator's queue was full.
    pub const DROPPED: usize = 1;
    /// Gaps in the sample sequence the estimator saw ([`crate::aero::SequenceHealth::gaps`]).
    pub const GAPS: usize = 2;
    /// Samples missing in those gaps.
    pub const MISSED: usize = 3;
    /// Samples refused as not newer than the last one.
    pub const STALE: usize = 4;
    /// Failed reads of the IMU (bus error, not ready, invalid data, saturated).
    pub const IMU_FAULTS: usize = 5;
    /// Failed reads of the airspeed sensor.
    pub const AIRSPEED_FAULTS: usize = 6;
    /// Failed reads of the α vane.
    pub const ALPHA_FAULTS: usize = 7;
    /// Failed reads of the β vane.
    pub const BETA_FAULTS: usize = 8;
    /// Samples with a surface, the throttle, the RPM or the attitude missing or stale on the
    /// autopilot link.
    pub const AUTOPILOT_FAULTS: usize = 9;
    /// Re-initialisations of the IMU (after a run of failed reads).
    pub const IMU_REINITS: usize = 10;
    /// Re-initialisations of the airspeed sensor's bus.
    pub const AIRSPEED_REINITS: usize = 11;
    /// Re-initialisations of the α vane's bus.
    pub const ALPHA_REINITS: usize = 12;
    /// Re-initialisations of the β vane's bus.
    pub const BETA_REINITS: usize = 13;
    /// Channels stuck at the last sample (a mask of channel bits).
    pub const STUCK_NOW: usize = 14;
    /// Times a channel became stuck, all channels.
    pub const STUCK_EPISODES: usize = 15;
    /// Samples with a channel reported stuck, summed over the channels.
    pub const STUCK_SAMPLES: usize = 16;
    /// Frames received on the autopilot link.
    pub const LINK_FRAMES: usize = 17;
    /// Frames rejected on the autopilot link (bad checksum, bad length, unknown incompatibility
    /// flags).
    pub const LINK_REJECTED: usize = 18;
    /// Bytes discarded by the link's parser while looking for a frame.
    pub const LINK_DISCARDED: usize = 19;
    /// Received bytes lost on the autopilot link (receiver overrun or full ring).
    pub const LINK_LOST: usize = 20;
    /// Channels the pipeline found invalid (missing, NaN, out of range) at the last sample (a
    /// mask of channel bits).
    pub const INVALID_NOW: usize = 21;
    /// Samples with each channel invalid, at `INVALID + bit` for the 11 channel bits
    /// ([`crate::aero::Health::invalid_channel`]).
    pub const INVALID: usize = 22;
    /// Frames on the autopilot link not kept because their stamp was not newer than the kept
    /// frame's — repeats and replays ([`crate::mavlink::MavlinkSurfaces::not_newer_frames`]).
    /// After the `INVALID` block so that the slots before it keep their places.
    pub const LINK_NOT_NEWER: usize = INVALID + crate::aero::model::channel::COUNT;
    /// Number of slots used.
    pub const COUNT: usize = LINK_NOT_NEWER + 1;
}

/// The co-processor's health report (counters and masks by [`health_slot`]), sent as one
/// `DEBUG_FLOAT_ARRAY` named [`HEALTH_NAME`] with `array_id` [`HEALTH_ARRAY_ID`]: 20 + 34·4 =
/// 156 payload bytes, a 168-byte frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthReport {
    /// The values by [`health_slot`].
    pub values: [u32; health_slot::COUNT],
}

impl Default for HealthReport {
    fn default() -> Self {
        Self {
            values: [0; health_slot::COUNT],
        }
    }
}

impl HealthReport {
    /// The report as a `DEBUG_FLOAT_ARRAY` stamped `time_us` (each value saturated at 2²⁴).
    pub fn to_debug_float_array(&self, time_us: u64) -> DebugFloatArray {
        let mut m = DebugFloatArray {
            time_us,
            array_id: HEALTH_ARRAY_ID,
            name: name10(HEALTH_NAME).unwrap_or([0; 10]),
            ..DebugFloatArray::default()
        };
        for (d, v) in m.data.iter_mut().zip(self.values.iter()) {
            *d = (*v).min(F32_EXACT_MAX) as f32;
        }
        m
    }

    /// The report a `DEBUG_FLOAT_ARRAY` carries, if it is one (`array_id` [`HEALTH_ARRAY_ID`]).
    pub fn from_debug_float_array(m: &DebugFloatArray) -> Option<Self> {
        if m.array_id != HEALTH_ARRAY_ID {
            return None;
        }
        let mut r = Self::default();
        for (v, d) in r.values.iter_mut().zip(m.data.iter()) {
            *v = *d as u32;
        }
        Some(r)
    }
}

/// Bits of [`CoefficientReport::health_flags`] as [`reports`] sets them.
pub mod health_bit {
    /// Not every noisy direction is excited (`k < n_θ − 1`, eq. 21): the minimum-norm solution is
    /// in use and `σ` is not defined.
    pub const UNDER_EXCITED: u32 = 1 << 0;
    /// No accepted update yet.
    pub const NO_UPDATES: u32 = 1 << 1;
    /// Samples were refused for a missing or out-of-range channel.
    pub const CHANNEL_REFUSALS: u32 = 1 << 2;
    /// The estimator itself refused samples (numerical gate).
    pub const ESTIMATOR_REFUSALS: u32 = 1 << 3;
    /// The parameter covariance (eq. 17) could not be formed.
    pub const NO_COVARIANCE: u32 = 1 << 4;
}

fn report_one<const N: usize>(
    i: usize,
    g: &crate::Gtls<f32, N, 1, N>,
    h: &crate::aero::pipeline::CoefficientHealth,
) -> CoefficientReport {
    use crate::Estimator;
    let mut r = CoefficientReport {
        coefficient: i as u8,
        theta: [0.0; MAX_PARAMETERS],
        sigma: [0.0; MAX_PARAMETERS],
        n_params: N as u8,
        rank_k: g.excited() as u8,
        lambda_f: g.lambda(),
        health_flags: 0,
        refused: h
            .refused_channels
            .saturating_add(h.refused_warmup)
            .saturating_add(h.refused_estimator),
    };
    for (o, v) in r.theta.iter_mut().zip(g.theta().iter()) {
        *o = *v;
    }
    match g.covariance() {
        Ok(c) => {
            for (j, o) in r.sigma.iter_mut().take(N).enumerate() {
                *o = libm::sqrtf(c[(j, j)].max(0.0));
            }
        }
        Err(_) => {
            r.sigma.iter_mut().take(N).for_each(|o| *o = f32::NAN);
            r.health_flags |= health_bit::NO_COVARIANCE;
        }
    }
    if g.excited() + 1 < N {
        r.health_flags |= health_bit::UNDER_EXCITED;
    }
    if h.updates == 0 {
        r.health_flags |= health_bit::NO_UPDATES;
    }
    if h.refused_channels > 0 {
        r.health_flags |= health_bit::CHANNEL_REFUSALS;
    }
    if h.refused_estimator > 0 {
        r.health_flags |= health_bit::ESTIMATOR_REFUSALS;
    }
    r
}

/// The six coefficient reports of an on-board pipeline, indexed by [`idx`]: `θ`, `σ` from the
/// eq. 17 covariance (one small matrix inversion per coefficient: call it at the telemetry rate,
/// not per sample), `k`, `λ_F`, the [`health_bit`] flags and the refused-sample count.
pub fn reports(p: &crate::aero::Pipeline<f32>) -> [CoefficientReport; idx::COUNT] {
    let h = &p.health().coefficients;
    [
        report_one(idx::LIFT, p.lift(), &h[idx::LIFT]),
        report_one(idx::DRAG, p.drag(), &h[idx::DRAG]),
        report_one(idx::SIDE, p.side(), &h[idx::SIDE]),
        report_one(idx::ROLL, p.roll(), &h[idx::ROLL]),
        report_one(idx::PITCH, p.pitch(), &h[idx::PITCH]),
        report_one(idx::YAW, p.yaw(), &h[idx::YAW]),
    ]
}

/// The report of coefficient `coefficient` (an [`idx`]; `None` past `C_n`) of an on-board pipeline,
/// equal to `reports(p)[coefficient]`: one at a time, for a caller that encodes and sends the
/// reports one by one (the firmware: a small frame buffer, the estimator locked for one report).
pub fn report(p: &crate::aero::Pipeline<f32>, coefficient: usize) -> Option<CoefficientReport> {
    let h = p.health().coefficients.get(coefficient)?;
    Some(match coefficient {
        idx::LIFT => report_one(idx::LIFT, p.lift(), h),
        idx::DRAG => report_one(idx::DRAG, p.drag(), h),
        idx::SIDE => report_one(idx::SIDE, p.side(), h),
        idx::ROLL => report_one(idx::ROLL, p.roll(), h),
        idx::PITCH => report_one(idx::PITCH, p.pitch(), h),
        _ => report_one(idx::YAW, p.yaw(), h),
    })
}
