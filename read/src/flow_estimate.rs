//! What the α-free mode ([`crate::flow_angles`]) did to a flight: the wind / pitot-scale fit and
//! the estimated α and β with their uncertainty. A flight's log ([`crate::measured::LogMeta`])
//! carries this record and the data-quality assessment reads it; the estimator that makes it
//! depends on the flight, never the other way round.

use serde::Serialize;

/// The wind of one block.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WindBlock {
    /// Block start and end, s.
    pub t_s: [f64; 2],
    /// Wind north, east (velocity of the air), m/s.
    pub wind_ne_mps: [f64; 2],
    /// Their 1-σ, m/s.
    pub sigma_ne_mps: [f64; 2],
    /// The heading span flown in the block, degrees.
    pub heading_span_deg: f64,
}

/// The result of the wind / pitot-scale fit ([`crate::flow_angles::fit_wind`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WindFit {
    /// Per block.
    pub blocks: Vec<WindBlock>,
    /// Pitot scale `k` (true airspeed = `k` × logged).
    pub pitot_scale: f64,
    /// Its 1-σ.
    pub pitot_scale_sigma: f64,
    /// RMS of the airspeed residual `k·V_m − |v_g − w|`, m/s (gusts and pitot noise).
    pub residual_rms_mps: f64,
    /// Samples used.
    pub samples: usize,
    /// Independent samples (residual autocorrelation).
    pub effective_samples: f64,
    /// Condition number of the scaled Jacobian.
    pub condition: f64,
    /// The covariance of `[k, w_N1, w_E1, …]`, row-major (the blocks in order).
    #[serde(skip)]
    pub covariance: Vec<f64>,
    /// Why the fit cannot be trusted (empty: it can); a non-empty list means α/β are not
    /// estimated from it.
    pub refused: Vec<String>,
}

/// What the α-free mode did, for the data-quality assessment and the report
/// ([`crate::measured::LogMeta::flow_angles`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlowAngles {
    /// `vanes`, `estimated`, `not estimated` or `off`.
    pub status: String,
    /// Where the wind came from: `wind-triangle fit`, `autopilot wind estimate` or empty.
    pub wind_source: String,
    /// The fit (when one was made, refused or not).
    pub fit: Option<WindFit>,
    /// The autopilot's logged wind, mean north and east, m/s (for comparison).
    pub autopilot_wind_ne_mps: Option<[f64; 2]>,
    /// 1-σ of the estimated α, rad (NaN: unknown).
    pub alpha_sigma_rad: f64,
    /// 1-σ of the estimated β, rad (NaN: unknown).
    pub beta_sigma_rad: f64,
    /// 1-σ of α as the gap analysis sees it, after its ±0.1-s smoothing (which passes
    /// [`crate::flow_angles::SMOOTHED_WHITE_SHARE`] of the attitude's white noise; the wind's and the gusts' slow
    /// errors pass whole), rad: what the α terms' excitation is judged against.
    pub alpha_sigma_smoothed_rad: f64,
    /// The same for β, rad.
    pub beta_sigma_smoothed_rad: f64,
    /// Standard deviation of the estimated α over the flight, rad (the α excitation).
    pub alpha_excitation_rad: f64,
    /// Standard deviation of the estimated β, rad (the sideslip excitation).
    pub beta_excitation_rad: f64,
    /// The assumptions, each a sentence.
    pub assumptions: Vec<String>,
    /// Why α/β were not estimated (empty when they were).
    pub why_not: Vec<String>,
    /// One sentence for the data-quality table.
    pub summary: String,
}

impl Default for FlowAngles {
    /// Nothing estimated: the σ's and excitations unknown (NaN), the texts empty.
    fn default() -> Self {
        Self {
            status: String::new(),
            wind_source: String::new(),
            fit: None,
            autopilot_wind_ne_mps: None,
            alpha_sigma_rad: f64::NAN,
            beta_sigma_rad: f64::NAN,
            alpha_sigma_smoothed_rad: f64::NAN,
            beta_sigma_smoothed_rad: f64::NAN,
            alpha_excitation_rad: f64::NAN,
            beta_excitation_rad: f64::NAN,
            assumptions: Vec::new(),
            why_not: Vec::new(),
            summary: String::new(),
        }
    }
}
