//! Stage 1: the flight checked and brought to the analysis rate, α and β chosen, and the pass's
//! plan — step sizes, the identification split, the candidate count and the thresholds.

use crate::io::flow_angles::WindFitSettings;
use crate::io::measured::MeasuredFlight;
use crate::model::{self, Corrections, Table, Term, TermRefs};
use crate::{at_analysis_rate, check_input, compat, select, signal, GapError, GapSettings};

/// The flight the analysis runs on, and its plan.
pub struct Prepared {
    /// At the analysis rate, with α and β from the vanes or the α-free estimate, as
    /// [`GapSettings::flow_angles`] asks (the data-quality assessment reads what was done from the
    /// flight's metadata).
    pub flight: MeasuredFlight,
    /// Its time step, s.
    pub h: f64,
    /// What the averaging to the analysis rate did, when it averaged.
    pub rate_note: Option<String>,
    /// Each coefficient's baseline terms ([`GapSettings::baseline`], else eq. 3).
    pub baselines: [Vec<Term>; 6],
    /// Step sizes, split and thresholds.
    pub plan: Plan,
}

/// Step sizes, the identification split, the candidate count and the thresholds of a flight.
pub struct Plan {
    /// Largest residual-autocorrelation lag, samples.
    pub max_lag: usize,
    /// Savitzky–Golay half-width, samples.
    pub sg_half: usize,
    /// Samples of the identification segment.
    pub n_id: usize,
    /// Candidates tested (the Bonferroni divisor).
    pub m: usize,
    /// The coefficients' `t²` threshold (Student's t, `threshold_blocks − 1` degrees of freedom).
    pub threshold_t2: f64,
    /// The blocks it assumes.
    pub threshold_blocks: usize,
    /// The compatibility check's `t²` threshold (normal: many segments).
    pub compat_threshold_t2: f64,
    /// The table synthesised from the data as logged (no corrections, the sensors' own air data):
    /// it counts the candidates, and it is the aerodynamics' table when the compatibility check
    /// corrects nothing and the air data are the sensors' ([`super::synthesis::table`]).
    pub as_logged: Table,
}

/// [`Prepared`] of a flight; its input errors name its own samples (checked before the rate
/// changes).
pub fn prepare(flight: &MeasuredFlight, settings: &GapSettings) -> Result<Prepared, GapError> {
    check_input(flight)?;
    let (decimated, rate_note) = at_analysis_rate(flight, settings.max_rate_hz).unzip();
    let at_rate = decimated.as_ref().unwrap_or(flight);
    let flight = crate::io::flow_angles::prepare(at_rate, settings.flow_angles, &WindFitSettings::default());
    let h = check_input(&flight)?;
    let baselines: [Vec<Term>; 6] = core::array::from_fn(|i| match &settings.baseline {
        Some(b) => b[i].clone(),
        None => Term::eq3(i),
    });
    let plan = plan(&flight, h, settings, &baselines);
    Ok(Prepared {
        flight,
        h,
        rate_note,
        baselines,
        plan,
    })
}

/// The [`Plan`] of a checked flight with time step `h`.
pub fn plan(flight: &MeasuredFlight, h: f64, settings: &GapSettings, baselines: &[Vec<Term>; 6]) -> Plan {
    let n = flight.len();
    let max_lag = ((settings.max_lag_s / h).round() as usize).max(1);
    let sg_half = (settings.smoothing_half_width_s / h).round() as usize;
    let n_id = identification_end(flight, settings.identification_fraction);
    // The candidate count (Bonferroni divisor) needs the table; synthesised uncorrected to learn
    // which signals exist (the corrected table has the same signals).
    let as_logged = model::synthesise(flight, h, &Corrections::default(), sg_half, None);
    let n_aero = aero_candidate_count(&as_logged, baselines);
    let n_compat_est = if settings.compatibility {
        compat_candidate_count(flight)
    } else {
        0
    };
    let m = (n_aero + n_compat_est).max(1);
    let z = signal::normal_upper_quantile(settings.alpha / (2.0 * m as f64));
    // The compatibility check's statistic is normal (many segments); the coefficients' block
    // sandwich has G − 1 degrees of freedom (G blocks of `cv.block_s`).
    let blocks = (n / ((settings.cv.block_s / h).round() as usize).max(10)).max(2);
    let threshold_t2 = select::student_t_upper_quantile(settings.alpha / (2.0 * m as f64), blocks as f64 - 1.0).powi(2);
    Plan {
        max_lag,
        sg_half,
        n_id,
        m,
        threshold_t2,
        threshold_blocks: blocks,
        compat_threshold_t2: z * z,
        as_logged,
    }
}

/// How many library terms the coefficients of `table` will be offered beyond their baselines.
fn aero_candidate_count(table: &Table, baselines: &[Vec<Term>; 6]) -> usize {
    let refs_probe = TermRefs {
        alpha_break_rad: 0.0,
        airspeed_mps: 1.0,
        mach: 0.0,
    };
    let mut n_aero = 0usize;
    for i in 0..6 {
        if table.z[i].is_none() {
            continue;
        }
        let base = &baselines[i];
        n_aero += Term::offered(i, table)
            .iter()
            .filter(|t| !base.contains(t) && t.column(table, &refs_probe).is_some())
            .count();
    }
    n_aero
}

/// How many sensor-error candidates the compatibility check will test on this flight.
fn compat_candidate_count(flight: &MeasuredFlight) -> usize {
    compat::attitude_candidates(flight).len() + compat::velocity_candidates(flight).len()
}

/// The end of the identification segment: the first `fraction` of the samples, clamped to leave
/// 100 and 50; on a flight of [`select::MIN_PIECES_FOR_FOLDS`] manoeuvres or more, the join
/// nearest to it (whole manoeuvres held out; at least one on each side).
fn identification_end(flight: &MeasuredFlight, fraction: f64) -> usize {
    let n = flight.len();
    let at = ((n as f64 * fraction).round() as usize).clamp(100, n - 50);
    let pieces = flight.pieces();
    if pieces.len() < select::MIN_PIECES_FOR_FOLDS {
        return at;
    }
    pieces[1..]
        .iter()
        .map(|p| p.start)
        .min_by_key(|s| s.abs_diff(at))
        .unwrap_or(at)
}
