//! The errors-in-variables model of the analysis: `W_T` (seed 000 eq. 9) of every regressor column
//! and of every synthesised coefficient, by Monte Carlo propagation of the sensors' white noise
//! (and of an estimated flow angle's slow error) through the whole chain (seed 000 §V, eq. 34–41 build `σ_ε` the same way: by sampling the
//! errors of the measured inputs of a compound quantity).
//!
//! ## Why it matters here
//! The regressors are measured or reconstructed, not known: the reconstructed angle of attack
//! carries an error of ~0.0007 rad on the simulated flights (an initial-state error per 5 s
//! segment plus the random walk of the integrated accelerometer, gyro and attitude noise). Under
//! the stabiliser and the phugoid, α is almost a linear function of `q`, `δe` and `V`
//! (`α ≈ α₀(V₀/V)²`; the part of α the other regressors do not explain has a standard deviation of
//! only ~0.0036 rad), so ordinary least squares attenuates `C_Lα` by several per cent and loads the
//! lost part onto the correlated regressors — measured on the clean flights, a spurious `ΔV/V` in
//! `C_L` of about −0.045 (`t²` ≈ 10 on average, above the Bonferroni threshold on 2 of 20 flights)
//! and a spurious `C_Lq`. With the vane's own 0.5° noise instead of the reconstruction the
//! attenuation is ~40 %. This is the errors-in-variables problem PCA-GTLS exists for; it needs
//! the error covariance of the columns, which this module estimates.
//!
//! ## Method
//! 1. The white-noise level of every measured channel, from its third differences
//!    ([`super::signal::white_noise_sd`]); for a channel logged slower than the grid and
//!    interpolated by the reader, from its values at its own sample instants, where the replicas
//!    draw its noise and interpolate it as the reader did ([`super::held_noise`]).
//! 2. `R` replicas of the flight with independent white noise of those levels added to every
//!    channel (seeded ChaCha8, so the result is reproducible). For each replica the flight-path
//!    reconstruction is repeated with the sensor errors found held fixed
//!    ([`super::compat::reconstruct_air_data`]: only the segments' initial states are refitted, so
//!    the replica's reconstructed air data carry the reconstruction's own error structure), and
//!    the coefficients and every candidate column are synthesised again.
//! 3. The difference of each replica's columns and coefficients from the nominal ones is a draw
//!    of their errors; their second moments over the replicas and the identification samples are
//!    `W_T` — the full covariance, including the correlation of the airspeed's error in `q̄` (the
//!    coefficient) with the same error in a speed regressor.
//!
//! 4. An estimated flow angle (an autopilot's α/β, the α-free mode's) errs by more than white
//!    noise: by the gust the estimator takes as zero and the wind it has not caught up with,
//!    correlated over seconds. Its standard deviation and correlation time
//!    ([`super::origin::estimate_errors`]) drive a second set of replicas that draw that error
//!    alone, as a first-order Gauss–Markov process per manoeuvre ([`estimate_error_moments`]);
//!    the two errors are independent, so their moments add, coefficient by coefficient, where
//!    the data bear the correction ([`super::origin::with_estimate_errors`]).
//!
//! The added noise has the level of the measured noise, so a replica's difference has the
//! distribution of the data's own error to first order (the data are noisy already: the
//! linearisation point carries one noise realisation, a second-order effect).
//!
//! A column whose error variance is below `1e-12` of its mean square (the intercept; a commanded
//! throttle) is exact.

use super::compat::{reconstruct_air_data, Compatibility};
use super::held_noise;
use super::model::{synthesise, Corrections, Table, Term, TermRefs};
use super::origin::{gauss_markov, EstimateError};
use super::regress::EivModel;
use super::signal::white_noise_sd;
use crate::io::measured::{MeasuredFlight, Quantity};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::BTreeMap;

/// The white-noise standard deviation of every channel (SI units), on the grid's samples.
pub fn channel_noise(flight: &MeasuredFlight) -> BTreeMap<Quantity, f64> {
    flight.channels.iter().map(|(q, v)| (*q, white_noise_sd(v))).collect()
}

/// The white noise of every channel as the Monte Carlo draws it: its standard deviation and, for a
/// channel logged slower than the grid (`h_s`) and interpolated by the reader, its sample
/// instants, where the noise is estimated and drawn ([`super::held_noise`]); `None` for a channel
/// at the grid's rate, whose noise is white on the grid.
pub fn channel_noise_model(flight: &MeasuredFlight, h_s: f64) -> BTreeMap<Quantity, (f64, Option<Vec<usize>>)> {
    flight
        .channels
        .iter()
        .map(|(q, v)| {
            let instants = flight
                .log
                .logged_rate_hz
                .get(q)
                .and_then(|r| held_noise::sample_instants(v, *r, h_s));
            let sd = match &instants {
                Some(k) => held_noise::white_noise_sd_at(v, k),
                None => white_noise_sd(v),
            };
            (*q, (sd, instants))
        })
        .collect()
}

/// The error second moments of one coefficient's columns.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnErrors {
    /// The terms, in the order of `cov`.
    pub terms: Vec<Term>,
    /// `(T + 1)²` row-major: the terms' errors, then the coefficient's.
    pub cov: Vec<f64>,
    /// Mean square of each term's column on the identification segment.
    pub mean_square: Vec<f64>,
    /// Terms not identifiable from an estimated flow angle on this flight
    /// ([`super::origin::with_estimate_errors`]): the fit's value for them is no estimate, and
    /// the report gives them no standard error.
    pub not_identifiable: Vec<Term>,
}

impl ColumnErrors {
    fn index(&self, t: &Term) -> Option<usize> {
        self.terms.iter().position(|x| x == t)
    }

    /// The error variance of a term's column (0 if unknown).
    pub fn variance(&self, t: &Term) -> f64 {
        let k = self.terms.len() + 1;
        self.index(t).map_or(0.0, |i| self.cov[i * k + i])
    }

    /// The error variance of the coefficient.
    pub fn output_variance(&self) -> f64 {
        let k = self.terms.len() + 1;
        self.cov[k * k - 1]
    }

    /// These moments plus `other`'s (errors independent of these), over the same terms.
    pub fn plus(&self, other: &ColumnErrors) -> ColumnErrors {
        ColumnErrors {
            cov: self.cov.iter().zip(&other.cov).map(|(a, b)| a + b).collect(),
            ..self.clone()
        }
    }

    /// Whether a term's column is exact (error variance below `1e-12` of its mean square, or no
    /// error estimate for it).
    pub fn is_exact(&self, t: &Term) -> bool {
        match self.index(t) {
            None => true,
            Some(i) => self.variance(t) <= 1e-12 * self.mean_square[i],
        }
    }

    /// The errors-in-variables model of a regression on `terms`.
    pub fn eiv(&self, terms: &[Term]) -> EivModel {
        let k = self.terms.len() + 1;
        let exact: Vec<bool> = terms.iter().map(|t| self.is_exact(t)).collect();
        let noisy: Vec<usize> = terms
            .iter()
            .zip(&exact)
            .filter(|(_, e)| !**e)
            .filter_map(|(t, _)| self.index(t))
            .collect();
        let nx = noisy.len();
        let mut w_xx = vec![0.0; nx * nx];
        let mut w_xz = vec![0.0; nx];
        for (r, &a) in noisy.iter().enumerate() {
            for (c, &b) in noisy.iter().enumerate() {
                w_xx[r * nx + c] = self.cov[a * k + b];
            }
            w_xz[r] = self.cov[a * k + (k - 1)];
        }
        EivModel { exact, w_xx, w_xz }
    }
}

/// Settings of the Monte Carlo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonteCarlo {
    /// Replicas with reconstructed air data, and the most with measured ones ([`replicas`]).
    /// Default 8: the reconstruction error is nearly constant over a 5 s segment, so its variance
    /// is estimated from about `8 × 11` segment draws on a 90 s flight (±15 %).
    pub replicas: usize,
    /// Seed of the added noise.
    pub seed: u64,
}

impl Default for MonteCarlo {
    fn default() -> Self {
        Self {
            replicas: 8,
            seed: 0x006e_6f69_7365,
        }
    }
}

/// Independent draws of a measured-air-data error that [`replicas`] asks for: a variance from
/// `D` independent draws has a relative standard error of `√(2/D)`, 4.5 % at 1 000.
pub const WINDOW_DRAWS: usize = 1000;

/// The fewest replicas with measured air data.
pub const MIN_MEASURED_REPLICAS: usize = 4;

/// The replicas [`column_errors`] runs: `mc.replicas` with reconstructed air data; with measured
/// ones the fewest, between [`MIN_MEASURED_REPLICAS`] and `mc.replicas`, whose identification
/// samples hold [`WINDOW_DRAWS`] smoothing windows.
///
/// Why fewer with measured air data: there a column's error is the sensors' white noise through
/// the Savitzky–Golay smoother and the derivatives, correlated over one window of `2M+1`
/// samples, so each replica gives about `n_id/(2M+1)` independent draws (270 on 60 s at 50 Hz,
/// `M = 5`) — not one per 5 s segment as a reconstruction's error does. Four replicas of a 60 s
/// segment then estimate the moments better (±4.3 %) than eight do with a reconstruction (±15 %).
pub fn replicas(mc: &MonteCarlo, reconstructed: bool, n_id: usize, sg_half: usize) -> usize {
    if reconstructed {
        return mc.replicas;
    }
    let per_replica = (n_id / (2 * sg_half + 1)).max(1);
    WINDOW_DRAWS
        .div_ceil(per_replica)
        .clamp(MIN_MEASURED_REPLICAS.min(mc.replicas), mc.replicas)
}

/// The inputs of [`column_errors`] that describe how the nominal table was made.
pub struct Synthesis<'a> {
    /// The flight.
    pub flight: &'a MeasuredFlight,
    /// Time step, s.
    pub h_s: f64,
    /// Sensor corrections applied.
    pub corrections: &'a Corrections,
    /// Savitzky–Golay half-width, samples.
    pub sg_half: usize,
    /// The compatibility check whose reconstructed air data the table used (`None`: measured air
    /// data).
    pub compat: Option<&'a Compatibility>,
    /// The fusion's crossovers when the air data are fused ([`super::airdata`]).
    pub fuse_cutoffs: Option<&'a BTreeMap<crate::io::measured::Quantity, f64>>,
    /// Term references.
    pub refs: &'a TermRefs,
    /// Identification samples (the moments are taken over `0..n_id`).
    pub n_id: usize,
    /// The slow error of each estimated flow angle ([`super::origin::estimate_errors`]), drawn
    /// in every replica beside the white noise (empty: none).
    pub estimate_errors: &'a BTreeMap<Quantity, EstimateError>,
}

impl Synthesis<'_> {
    /// The replicas [`column_errors`] runs on this table ([`replicas`]).
    pub fn replicas(&self, table: &Table, mc: &MonteCarlo) -> usize {
        replicas(mc, self.compat.is_some(), self.n_id.min(table.t_s.len()), self.sg_half)
    }
}

/// The coefficients (indices into [`super::model::COEFFICIENTS`]) whose error moments share one
/// Gram matrix: the longitudinal ones and the lateral ones.
const GROUPS: [[usize; 3]; 2] = [[0, 1, 4], [2, 3, 5]];

/// Samples synthesised beyond the identification segment in a replica: 2 s, and at least four
/// smoothing half-widths.
fn replica_margin(h_s: f64, sg_half: usize) -> usize {
    ((2.0 / h_s).ceil() as usize).max(4 * sg_half)
}

/// The error moments of every coefficient's `terms` (`None` where the coefficient is absent)
/// under the sensors' white noise.
pub fn column_errors(
    s: &Synthesis,
    table: &Table,
    terms: &[Vec<Term>; 6],
    mc: &MonteCarlo,
) -> [Option<ColumnErrors>; 6] {
    moments(s, table, terms, mc, Draw::White)
}

/// The error moments of every coefficient's `terms` under the estimated flow angles' slow errors
/// alone ([`Synthesis::estimate_errors`]; independent of the white noise, so the two moments
/// add). Kept apart so that a coefficient in whose baseline an estimated angle is not
/// identifiable can keep the white-noise model ([`super::origin::with_estimate_errors`]).
pub fn estimate_error_moments(
    s: &Synthesis,
    table: &Table,
    terms: &[Vec<Term>; 6],
    mc: &MonteCarlo,
) -> [Option<ColumnErrors>; 6] {
    moments(s, table, terms, mc, Draw::Estimates)
}

/// What a replica draws.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Draw {
    /// Every channel's white noise.
    White,
    /// The estimated flow angles' slow errors.
    Estimates,
}

/// Seed offset of the estimate errors' replicas (independent of the white-noise ones).
const ESTIMATE_SEED: u64 = 0x0065_7374_696d;

fn moments(
    s: &Synthesis,
    table: &Table,
    terms: &[Vec<Term>; 6],
    mc: &MonteCarlo,
    draw: Draw,
) -> [Option<ColumnErrors>; 6] {
    let n_id = s.n_id.min(table.t_s.len());
    let noise = match draw {
        Draw::White => channel_noise_model(s.flight, s.h_s),
        Draw::Estimates => BTreeMap::new(),
    };
    let groups = GramGroups::new(table, terms);
    // Nominal columns, once per distinct term.
    let mut nominal: BTreeMap<Term, Option<Vec<f64>>> = BTreeMap::new();
    for t in groups.union.iter().flatten() {
        nominal.entry(*t).or_insert_with(|| t.column(table, s.refs));
    }
    let mut sums: Vec<Option<Vec<f64>>> = (0..6)
        .map(|i| table.z[i].is_some().then(|| vec![0.0; (terms[i].len() + 1).pow(2)]))
        .collect();
    let mut count = 0usize;
    let n_keep = replica_length(s, n_id);
    let seed = match draw {
        Draw::White => mc.seed,
        Draw::Estimates => mc.seed ^ ESTIMATE_SEED,
    };
    for r in 0..s.replicas(table, mc) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(r as u64));
        let mut pert = perturbed_flight(s.flight, &noise, n_keep, &mut rng);
        if draw == Draw::Estimates {
            add_estimate_errors(&mut pert, s.estimate_errors, s.h_s, &mut rng);
        }
        let tk = replica_table(s, &pert);
        count += n_id;
        groups.accumulate(&mut sums, &nominal, table, &tk, s.refs, n_id);
    }
    moments_per_coefficient(&sums, terms, &nominal, n_id, count)
}

/// The coefficients present, in groups that share most of their terms (the longitudinal and the
/// lateral ones): one Gram matrix per group instead of one per coefficient.
struct GramGroups {
    /// Each group's coefficients present in the table.
    members: Vec<Vec<usize>>,
    /// Each group's distinct terms.
    union: Vec<Vec<Term>>,
    /// Each coefficient's columns in its group's matrix (its terms, then its output) as indices
    /// into the group's distinct terms followed by the group's outputs.
    index: Vec<Vec<Vec<usize>>>,
}

impl GramGroups {
    fn new(table: &Table, terms: &[Vec<Term>; 6]) -> Self {
        let present = |i: usize| table.z[i].is_some();
        let members: Vec<Vec<usize>> = GROUPS
            .iter()
            .map(|g| g.iter().copied().filter(|&i| present(i)).collect::<Vec<_>>())
            .filter(|g| !g.is_empty())
            .collect();
        let union: Vec<Vec<Term>> = members
            .iter()
            .map(|g| {
                let mut u: Vec<Term> = Vec::new();
                for t in g.iter().flat_map(|&i| &terms[i]) {
                    if !u.contains(t) {
                        u.push(*t);
                    }
                }
                u
            })
            .collect();
        let index: Vec<Vec<Vec<usize>>> = members
            .iter()
            .zip(&union)
            .map(|(g, u)| {
                g.iter()
                    .enumerate()
                    .map(|(m, &i)| {
                        terms[i]
                            .iter()
                            .map(|t| u.iter().position(|v| v == t).unwrap_or(0))
                            .chain([u.len() + m])
                            .collect()
                    })
                    .collect()
            })
            .collect();
        Self { members, union, index }
    }

    /// Adds one replica's second moments of its differences from the nominal columns and
    /// coefficients (`tk` against `table`, over `0..n_id`) to each coefficient's sum.
    fn accumulate(
        &self,
        sums: &mut [Option<Vec<f64>>],
        nominal: &BTreeMap<Term, Option<Vec<f64>>>,
        table: &Table,
        tk: &Table,
        refs: &TermRefs,
        n_id: usize,
    ) {
        for ((g, u), index) in self.members.iter().zip(&self.union).zip(&self.index) {
            // The group's differences as the columns of an `n_id × k` matrix `D` (its distinct
            // terms, then each coefficient's output); `DᵀD` by one cache-blocked, vectorised
            // matrix product.
            let k = u.len() + g.len();
            let mut d = Vec::with_capacity(k * n_id);
            for t in u {
                match (&nominal[t], t.column(tk, refs)) {
                    (Some(c0), Some(ck)) => d.extend((0..n_id).map(|j| ck[j] - c0[j])),
                    _ => d.extend(core::iter::repeat_n(0.0, n_id)),
                }
            }
            for &i in g {
                match (&table.z[i], &tk.z[i]) {
                    (Some(z0), Some(zk)) => d.extend((0..n_id).map(|j| zk[j] - z0[j])),
                    _ => d.extend(core::iter::repeat_n(0.0, n_id)),
                }
            }
            let d = nalgebra::DMatrix::from_vec(n_id, k, d);
            let gram = d.transpose() * &d;
            for (&i, idx) in g.iter().zip(index) {
                let (Some(sum), Some(_)) = (&mut sums[i], &tk.z[i]) else {
                    continue;
                };
                let ki = idx.len();
                // The upper triangle, mirrored: the product's two triangles may round
                // differently.
                for (a, &ia) in idx.iter().enumerate() {
                    for (b, &ib) in idx.iter().enumerate() {
                        sum[a * ki + b] += gram[(ia.min(ib), ia.max(ib))];
                    }
                }
            }
        }
    }
}

/// The samples a replica keeps. With measured air data a replica is synthesised over the
/// identification segment and a margin: the moments are taken over `0..n_id`, and the synthesis
/// is local within a few smoothing half-widths (the Savitzky–Golay filters, the derivatives). A
/// reconstruction is not: its segments and their initial states span the whole flight, which is
/// kept. A pooled flight is cut at the end of a manoeuvre, never inside one.
fn replica_length(s: &Synthesis, n_id: usize) -> usize {
    let n_keep = match s.compat {
        None => (n_id + replica_margin(s.h_s, s.sg_half)).min(s.flight.len()),
        Some(_) => s.flight.len(),
    };
    s.flight
        .log
        .pieces
        .iter()
        .find(|p| p.start < n_keep && n_keep <= p.end)
        .map_or(n_keep, |p| p.end)
}

/// One replica of the flight: its first `n_keep` samples with white noise of each channel's
/// level added (drawn at a slow channel's own instants and interpolated as the reader did).
fn perturbed_flight(
    flight: &MeasuredFlight,
    noise: &BTreeMap<Quantity, (f64, Option<Vec<usize>>)>,
    n_keep: usize,
    rng: &mut ChaCha8Rng,
) -> MeasuredFlight {
    let mut pert = flight.clone();
    pert.t_s.truncate(n_keep);
    pert.log.pieces.retain(|p| p.end <= n_keep);
    for (q, v) in pert.channels.iter_mut() {
        let (sd, instants) = noise.get(q).map_or((0.0, None), |(sd, k)| (*sd, k.as_deref()));
        // The whole flight's draws, so that a replica's noise does not depend on the margin.
        let draws = if sd > 0.0 { v.len() } else { 0 };
        let slow = (sd > 0.0)
            .then_some(instants)
            .flatten()
            .map(|k| held_noise::interpolated_noise(v.len(), k, sd, &mut *rng));
        v.truncate(n_keep);
        if let Some(e) = slow {
            v.iter_mut().zip(e).for_each(|(x, e)| *x += e);
            continue;
        }
        for j in 0..draws {
            let e: f64 = StandardNormal.sample(&mut *rng);
            if let Some(x) = v.get_mut(j) {
                *x += sd * e;
            }
        }
    }
    pert
}

/// Adds to every estimated flow angle of a replica a draw of its slow error
/// ([`super::origin::EstimateError`]), independent in each manoeuvre (a record's wind estimate
/// and gusts are its own).
fn add_estimate_errors(
    pert: &mut MeasuredFlight,
    errors: &BTreeMap<Quantity, EstimateError>,
    h_s: f64,
    rng: &mut ChaCha8Rng,
) {
    let pieces: Vec<(usize, usize)> = pert.pieces().iter().map(|p| (p.start, p.end)).collect();
    for (q, e) in errors {
        let Some(v) = pert.channels.get_mut(q) else {
            continue;
        };
        for &(a, b) in &pieces {
            let b = b.min(v.len());
            if a >= b {
                continue;
            }
            let d = gauss_markov(b - a, e.sd_rad, e.correlation_time_s, h_s, &mut *rng);
            v[a..b].iter_mut().zip(d).for_each(|(x, d)| *x += d);
        }
    }
}

/// A replica's table: its air data reconstructed again with the sensor errors held (and fused
/// as the nominal ones were) when the table used a reconstruction, then the synthesis.
fn replica_table(s: &Synthesis, pert: &MeasuredFlight) -> Table {
    let air = s.compat.map(|c| reconstruct_air_data(pert, s.h_s, c));
    let air = air.filter(|a| !a.is_empty()).map(|a| match s.fuse_cutoffs {
        Some(fc) => super::airdata::fuse_all(pert, &a, s.h_s, Some(fc)).0,
        None => a,
    });
    synthesise(pert, s.h_s, s.corrections, s.sg_half, air.as_ref())
}

/// Each present coefficient's error moments: the replicas' sums over the samples counted, and
/// its terms' mean squares on the identification segment.
fn moments_per_coefficient(
    sums: &[Option<Vec<f64>>],
    terms: &[Vec<Term>; 6],
    nominal: &BTreeMap<Term, Option<Vec<f64>>>,
    n_id: usize,
    count: usize,
) -> [Option<ColumnErrors>; 6] {
    let mut out: [Option<ColumnErrors>; 6] = Default::default();
    for i in 0..6 {
        let Some(sum) = &sums[i] else {
            continue;
        };
        let mean_square = terms[i]
            .iter()
            .map(|t| {
                nominal[t].as_ref().map_or(0.0, |c| {
                    c[..n_id].iter().map(|v| v * v).sum::<f64>() / n_id.max(1) as f64
                })
            })
            .collect();
        out[i] = Some(ColumnErrors {
            terms: terms[i].clone(),
            cov: sum.iter().map(|v| v / count.max(1) as f64).collect(),
            mean_square,
            not_identifiable: Vec::new(),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measured_air_data_take_the_replicas_that_hold_a_thousand_smoothing_windows() {
        let mc = MonteCarlo::default();
        // A reconstruction: always the setting.
        assert_eq!(replicas(&mc, true, 3000, 5), 8);
        // 60 s at 50 Hz, 11-sample windows: 272 windows per replica, 4 replicas hold 1 000.
        assert_eq!(replicas(&mc, false, 3000, 5), 4);
        // 181 per replica: 6.
        assert_eq!(replicas(&mc, false, 2000, 5), 6);
        // A short flight: capped at the setting.
        assert_eq!(replicas(&mc, false, 400, 5), 8);
        // A long one: never below the floor.
        assert_eq!(replicas(&mc, false, 100_000, 5), MIN_MEASURED_REPLICAS);
        // Never more than the setting, even below the floor.
        let two = MonteCarlo { replicas: 2, ..mc };
        assert_eq!(replicas(&two, false, 3000, 5), 2);
        assert_eq!(replicas(&two, false, 400, 5), 2);
    }

    /// The premise of the replicas' margin: the synthesis of a flight cut `replica_margin` samples
    /// after the identification segment equals the whole flight's on that segment, to the bit.
    #[test]
    fn a_flight_cut_after_the_margin_synthesises_the_same_identification_segment() {
        let flight = super::super::hidden::flight(None, 30.0, 11, true).expect("simulated flight");
        let h_s = flight.t_s[1] - flight.t_s[0];
        let sg_half = (super::super::GapSettings::default().smoothing_half_width_s / h_s).round() as usize;
        let n_id = flight.len() * 6 / 10;
        let keep = n_id + replica_margin(h_s, sg_half);
        assert!(keep < flight.len(), "the test needs a cut inside the flight");
        let mut cut = flight.clone();
        cut.t_s.truncate(keep);
        for v in cut.channels.values_mut() {
            v.truncate(keep);
        }
        let corr = Corrections::default();
        let (whole, part) = (
            synthesise(&flight, h_s, &corr, sg_half, None),
            synthesise(&cut, h_s, &corr, sg_half, None),
        );
        for i in 0..6 {
            let (a, b) = (
                whole.z[i].as_ref().expect("coefficient"),
                part.z[i].as_ref().expect("coefficient"),
            );
            assert_eq!(a[..n_id], b[..n_id], "coefficient {i}");
        }
        assert_eq!(whole.signals.len(), part.signals.len());
        for (s, a) in &whole.signals {
            assert_eq!(a[..n_id], part.signals[s][..n_id], "{s:?}");
        }
    }
}
