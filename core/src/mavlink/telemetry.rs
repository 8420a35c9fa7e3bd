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
