//! The variable forgetting factor (eq. 24–33) on an abrupt parameter change, our reading of the
//! damaged eq. 28, the floor on `λ_F`, and the start of eq. 28's statistics.
//!
//! GIVEN a well-excited seeded flight segment whose slope parameter jumps by −1/3 at sample 5000
//! (simulated damage), identified by GTLS (intercept exact, three noisy regressors),
//! WHEN `λ_F` is constant (0.999), variable with our (Paleologu) reading of eq. 28, variable with the
//! literal reading, and variable without a floor,
//! THEN our reading detects the jump at once and re-converges (θ₁ within 5 % for good) in 168
//! samples where constant forgetting needs 2685; the literal reading detects it only after 1479
//! samples and needs 3973, more than constant forgetting; and without a floor `λ_F` collapses to
//! ~3e-4, the effective count to 1 and the estimator loses its excitation (k = 0) for a while,
//! which the floor of 0.9 prevents (k stays 3, N_eff ≥ 10).
//!
//! The sweep (`startup_sweep_*`): GIVEN `Gtls<T, 3, 0, 4>` (errors of σ = 0.05 in x and z), one
//! parameter jumping by −1/3 at sample 300, 1 500, 5 000 or 20 000, 10 seeds each, `f32` and `f64`,
//! WHEN the VFF runs with `for_dimension(3)` or `for_aero_coefficients(100)`, and beside it an
//! independent implementation of eq. 24 and 28–33 in this file (`sweep::RefVff`, `f64`, sharing
//! no code with the core's `Vff`: the powers are unnormalised weighted sums, `σ_ε²` formed two
//! ways and compared), THEN the core agrees with it at every sample (tolerances at `F32_TOL`), the statistics
//! (re)start at the same TLS solution, and every target holds: the estimate is within 5 % of the
//! new value for good after a median of 63 / 50 / 83 / 110 samples (`for_dimension(3)`) and
//! 112 / 120 / 112 / 328 (`for_aero_coefficients(100)`) at the four jump times (`λ = 0.999`:
//! 1 365 / 2 403 / 2 606 / 2 656; target ≤ 500), never later than `λ = 0.999` on any seed, and
//! `λ_F < λ_max` on none of the 268 000 stationary samples before the jumps (`f32` and `f64` alike).
//!
//! The early-jump sweep (`early_jump_*`): GIVEN its own generator (per seed random parameters of
//! magnitude 0.5–5 and regressors that are sums of three sinusoids of random frequency, phase and
//! amplitude; errors of σ = 0.05 in every noisy regressor and in `z`; the first noisy parameter
//! jumping by −1/3 at sample 150, 300, 600, 1 500 or 5 000), 100 seeds, `Gtls` of dimension 3, 5
//! and 6 with every regressor noisy and of dimension 6 with an exact intercept, WHEN the VFF runs
//! with `for_dimension(n)` and beside it `λ = 0.999`, THEN the VFF settles later on no seed
//! (target: at most 1 in 100, by at most 20 %), `λ_F < λ_max` on no stationary sample, the median
//! is below `λ = 0.999`'s and at most 500 samples in every dimension at every jump time (with the
//! hold after a detection, `vff` module doc, "The hold"; the always-on tests: dimension 3,
//! `f64`, and the jump at 150 in dimension 5, where the clip of `σ_ε²`'s input must cut the median
//! by at least 10 %; the rest in the ignored `early_jump_sweep_full`, the seed-by-seed reading of the
//! jump at 150 in the ignored `early_jump_at_150_arming_diagnosis`). `early_jump_diagnosis` (ignored) shows why the
//! seed's ceiling `λ_max = 1` fails this (`vff` module doc, "The ceiling");
//! `for_dimension_threshold_follows_the_short_window` checks eq. 32's threshold per dimension,
//! `early_test_false_drops_on_white_residuals` the early test's false drops (`vff` module doc,
//! "Eq. 32 before the noise power has its weight"), `early_f_test_flags_a_jump_right_after_the_start`
//! the early F test on the case it was made for (same doc, "The early F test").

use crate::common;

use aerosid_core::{Eq28Reading, Estimator, Forgetting, Gtls, GtlsSettings, VffSettings};
use aerosid_host_tests::data::{generate, Excitation, Sample, Spec};
use common::*;

const JUMP: usize = 5000;
const N: usize = 9000;
const BEFORE: [f64; 4] = [0.3, 4.5, -0.8, 1.2];
const AFTER: [f64; 4] = [0.3, 3.0, -0.8, 1.2];

fn data() -> Vec<Sample> {
    let mk = |theta: &[f64]| Spec {
        n_exact: 1,
        theta: theta.to_vec(),
        sigma_x: vec![0.02, 0.03, 0.01],
        sigma_z: 0.02,
        excitation: Excitation::Well,
        seed: 77,
    };
    let a = generate(&mk(&BEFORE), N);
    let b = generate(&mk(&AFTER), N);
    a[..JUMP].iter().chain(b[JUMP..].iter()).cloned().collect()
}

struct Trace {
    /// First sample after the jump at which θ₁ stays within 5 % of its new value (to the end).
    settle: Option<usize>,
    /// First sample after the jump with λ_F < 0.99.
    detect: Option<usize>,
    min_lambda: f64,
    min_k_after: usize,
    false_alarms_before: usize,
    low_samples: usize,
    min_n_eff: f64,
}

fn run(forgetting: Forgetting<f64>) -> Trace {
    let settings = GtlsSettings {
        forgetting,
        ..GtlsSettings::default()
    };
    let mut g = Gtls::<f64, 4, 1, 4>::new(&diag_wt(&[0.02, 0.03, 0.01, 0.02]), &sv(&[1.0; 4]), settings).unwrap();
    let mut tr = Trace {
        settle: None,
        detect: None,
        min_lambda: 1.0,
        min_k_after: 3,
        false_alarms_before: 0,
        low_samples: 0,
        min_n_eff: f64::MAX,
    };
    for (t, s) in data().iter().enumerate() {
        let step = g.update(&sv(&s.x), s.z).unwrap();
        if (2000..JUMP).contains(&t) && step.lambda_next < 0.99 {
            tr.false_alarms_before += 1;
        }
        if t >= JUMP {
            tr.min_lambda = tr.min_lambda.min(step.lambda_next);
            tr.min_k_after = tr.min_k_after.min(step.k as usize);
            tr.min_n_eff = tr.min_n_eff.min(g.effective_samples());
            if step.lambda_next < 0.99 {
                tr.low_samples += 1;
            }
            if tr.detect.is_none() && step.lambda_next < 0.99 {
                tr.detect = Some(t - JUMP);
            }
            let ok = ((g.theta()[1] - AFTER[1]) / AFTER[1]).abs() < 0.05;
            match (ok, tr.settle) {
                (true, None) => tr.settle = Some(t - JUMP),
                (false, Some(_)) => tr.settle = None,
                _ => {}
            }
        }
    }
    println!(
        "detect {:?}, settle {:?}, min λ {:.2e}, min k after {}, false alarms before {}, λ<0.99 for {} samples, min N_eff {:.1}",
        tr.detect, tr.settle, tr.min_lambda, tr.min_k_after, tr.false_alarms_before, tr.low_samples, tr.min_n_eff
    );
    tr
}

/// `for_dimension(4)` with the seed's ceiling `λ_max = 1` (the readings of eq. 28 and the floor
/// compared without the background forgetting of `for_dimension`'s `λ_max = 0.999`).
fn vff(reading: Eq28Reading, lambda_min: f64) -> Forgetting<f64> {
    Forgetting::Variable(VffSettings {
        reading,
        lambda_min,
        lambda_max: 1.0,
        ..VffSettings::for_dimension(4)
    })
}

#[test]
fn paleologu_reading_tracks_a_jump_faster_than_constant_forgetting() {
    let constant = run(Forgetting::Constant(0.999));
    let vff = run(vff(Eq28Reading::Paleologu, 0.9));
    let detect = vff.detect.expect("the VFF must detect the jump");
    let settle = vff.settle.expect("the VFF must re-converge");
    let settle_const = constant.settle.expect("constant forgetting re-converges eventually");
    assert!(detect <= 5, "detected after {detect} samples");
    assert!(settle <= 200, "re-converged after {settle} samples");
    assert!(
        settle * 5 <= settle_const,
        "VFF {settle} vs constant {settle_const} samples"
    );
    assert_eq!(vff.false_alarms_before, 0, "no λ drop on a steady model");
    assert_eq!(vff.min_k_after, 3, "the floor keeps the estimator excited");
}

#[test]
fn literal_reading_of_eq28_finds_the_jump_late() {
    let constant = run(Forgetting::Constant(0.999));
    let ours = run(vff(Eq28Reading::Paleologu, 0.9));
    let lit = run(vff(Eq28Reading::Literal, 0.9));
    // As printed, the noise power follows the residual faster than the error power: right after the
    // jump eq. 32 holds (λ = 1), and λ drops only when the short window decays below the long one.
    assert!(
        lit.detect.is_none_or(|d| d > 100),
        "literal reading detected at {:?}",
        lit.detect
    );
    let (s_lit, s_ours) = (lit.settle.unwrap_or(N), ours.settle.unwrap_or(N));
    assert!(s_lit > 10 * s_ours, "literal {s_lit} vs ours {s_ours} samples");
    // It forgets the new model along with the old one while λ sits low after the late detection:
    // slower than not detecting at all with a constant λ = 0.999.
    let s_const = constant.settle.unwrap_or(N);
    assert!(s_lit > s_const, "literal {s_lit} vs λ = 0.999 {s_const} samples");
}

#[test]
fn without_a_floor_lambda_collapses_and_excitation_is_lost() {
    let no_floor = run(vff(Eq28Reading::Paleologu, 1e-9));
    assert!(no_floor.min_lambda < 0.05, "min λ {:.3e}", no_floor.min_lambda);
    assert!(
        no_floor.min_k_after < 3,
        "without a floor the estimator should fall into insufficient excitation"
    );
}

// ---------------------------------------------------------------------------------------------------
// A change early in the flight: the sweep over the jump time, and an independent VFF
// ---------------------------------------------------------------------------------------------------

/// The sweep's model: three noisy regressors, no exact one (`Gtls<_, 3, 0, 4>`), errors of σ = 0.05
/// in every regressor and in `z`; `θ₀` jumps by −1/3 (4.5 → 3.0).
mod sweep {
    use super::*;
    use aerosid_core::{Real, Solution};

    pub const SIGMA: f64 = 0.05;
    pub const BEFORE: [f64; 3] = [4.5, -0.8, 1.2];
    pub const AFTER: [f64; 3] = [3.0, -0.8, 1.2];
    /// Samples run after the jump; "not settled" if θ₀ is not within 5 % for good by then.
    pub const AFTER_JUMP: usize = 6000;
    pub const JUMPS: [usize; 4] = [300, 1500, 5000, 20000];
    pub const SEEDS: std::ops::Range<u64> = 1..11;

    /// Samples `0..jump` of the model before the jump and `jump..` after, the same regressors and
    /// noise throughout (one seed).
    pub fn data(jump: usize, seed: u64) -> Vec<Sample> {
        let mk = |theta: &[f64]| Spec {
            n_exact: 0,
            theta: theta.to_vec(),
            sigma_x: vec![SIGMA; 3],
            sigma_z: SIGMA,
            excitation: Excitation::Well,
            seed,
        };
        let n = jump + AFTER_JUMP;
        let a = generate(&mk(&BEFORE), n);
        let b = generate(&mk(&AFTER), n);
        a[..jump].iter().chain(b[jump..].iter()).cloned().collect()
    }

    /// The settings under test.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub enum Settings {
        ForDimension,
        ForAero,
    }

    impl Settings {
        pub fn vff<T: Real>(self) -> VffSettings<T> {
            match self {
                Settings::ForDimension => VffSettings::for_dimension(3),
                Settings::ForAero => VffSettings::for_aero_coefficients(T::lit(100.0)),
            }
        }
    }

    /// An independent implementation of eq. 24 and 28–33 in our reading (`vff` module doc), in
    /// `f64` on plain arrays; it shares no code with the core's `Vff`. The powers are weighted sums
    /// over the residuals since the statistics started, kept unnormalised (`Σₖ γᵏ x(t−k)`, each
    /// advanced as `γ·S + x`) and divided by their sums of weights only when read (the core keeps
    /// normalised means with the gain `1/W`): `σ_q²`, `σ_ν²` with weights `γ₂ᵏ`; `σ_ε²` over what
    /// it took in: at each sample after the first, `σ_ν²` of the sample before (clipped at `κσ_ε²`
    /// of the sample before while eq. 32 is tested and holds) with the weight
    /// `(γ₁ − γ₂)·Σⱼ γ₂ʲ` (`j` over the samples before), each weight decaying as `γ₁ᵏ` (`k`
    /// samples ago); unclipped this is the mean of `ν²` with weights `γ₁ᵏ − γ₂ᵏ`, whose sum is
    /// the noise weight (both forms are formed and compared at every sample). Before eq. 32 is
    /// tested against `σ_ε²`, the early test compares `σ_ν²` with the smallest `σ_ν²` of the
    /// samples since the start whose window is filled (`1 − γ₂ⁿ ≥` the fill after `n` samples).
    /// Fed the samples, the core's `θ(t−1)` and whether that was a TLS solution, and the `λ_F` the
    /// core applied to the sample.
    pub struct RefVff {
        s: VffSettings<f64>,
        p: [[f64; 3]; 3],
        p_trace0: f64,
        /// Samples since the start, and the unnormalised sums `Σ γ₂ᵏ`, `Σ γ₂ᵏ q²`, `Σ γ₂ᵏ ν²`,
        /// `Σ γ₁ᵏ ν²` over them (`k = 0` the newest).
        n: usize,
        w2: f64,
        s2q: f64,
        s2nu: f64,
        s1nu: f64,
        /// What `σ_ε²` took in, as the sums `Σ γ₁ᵏ w` and `Σ γ₁ᵏ w·v` (`k = 0` the newest intake).
        w_in: f64,
        s_in: f64,
        /// `σ_ε²`'s weight after the previous sample of the statistics (0 before the start).
        weight_old: f64,
        /// The smallest `σ_ν²` of a filled window since the start (the early test), if any.
        min_filled: Option<f64>,
        /// `σ_ν²` and `σ_ε²` after the previous sample of the statistics.
        last: Option<(f64, f64)>,
        /// Whether a clip has changed what `σ_ε²` took in since the start.
        clipped: bool,
        pub started_at: Option<usize>,
        /// Samples left of the hold after a detection (`vff` module doc, "The hold"), and the
        /// margin of the sample that started it (a hold follows that sample's decision).
        hold: usize,
        hold_margin: f64,
    }

    /// One reference step's values.
    pub struct RefStep {
        pub nu: f64,
        pub q: f64,
        pub pq: f64,
        pub pnu: f64,
        pub peps: f64,
        pub lambda: f64,
        /// How far from a switch of eq. 32: the smallest of `|σ_ν² / (γ₀² r) − 1|` (`r` the power
        /// eq. 32 compares with), the relative distance of `σ_ε²`'s weight from
        /// `min_noise_weight_samples` and of the window's fill from the early test's (∞ before the
        /// start).
        pub margin: f64,
    }

    impl RefVff {
        pub fn new(s: VffSettings<f64>) -> Self {
            let d = 1.0 / s.pi0;
            Self {
                s,
                p: [[d, 0.0, 0.0], [0.0, d, 0.0], [0.0, 0.0, d]],
                p_trace0: 3.0 * d,
                n: 0,
                w2: 0.0,
                s2q: 0.0,
                s2nu: 0.0,
                s1nu: 0.0,
                w_in: 0.0,
                s_in: 0.0,
                weight_old: 0.0,
                min_filled: None,
                last: None,
                clipped: false,
                started_at: None,
                hold: 0,
                hold_margin: f64::INFINITY,
            }
        }

        /// Sample `t`: `x`, `z` measured, `theta` = θ(t−1), `tls` whether it was a TLS solution,
        /// `lam` the λ_F applied to this sample.
        pub fn step(&mut self, t: usize, x: &[f64], z: f64, theta: &[f64], tls: bool, lam: f64) -> RefStep {
            // Eq. 24 with the TLS-corrected regressor: the W_T-orthogonal projection of d = [x, z]
            // onto dᵀa = 0, a = [θ; −1], W_T = σ²I.
            let a = [theta[0], theta[1], theta[2], -1.0];
            let d = [x[0], x[1], x[2], z];
            let rho: f64 = (0..4).map(|i| d[i] * a[i]).sum();
            let awa: f64 = a.iter().map(|v| SIGMA * SIGMA * v * v).sum();
            let x0: Vec<f64> = (0..3).map(|i| x[i] - rho * SIGMA * SIGMA * a[i] / awa).collect();
            let nu = z - (0..3).map(|i| x0[i] * theta[i]).sum::<f64>();
            // Eq. 29.
            let px: Vec<f64> = (0..3).map(|i| (0..3).map(|j| self.p[i][j] * x0[j]).sum()).collect();
            let q: f64 = (0..3).map(|i| x0[i] * px[i]).sum();
            // Eq. 30 by the matrix inversion lemma, P ← (P − P x xᵀ P/(λ + q))/λ, without the
            // division while it would raise trace P above its start.
            let mut pn = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    pn[i][j] = self.p[i][j] - px[i] * px[j] / (lam + q);
                }
            }
            let tr = pn[0][0] + pn[1][1] + pn[2][2];
            let scale = if tr / lam <= self.p_trace0 { 1.0 / lam } else { 1.0 };
            for row in pn.iter_mut() {
                for v in row.iter_mut() {
                    *v *= scale;
                }
            }
            self.p = pn;
            let (g1, g2) = (self.s.gamma1, self.s.gamma2);
            let (g0, wmin) = (self.s.gamma0, self.s.min_noise_weight_samples);
            if !tls && self.weight_old < wmin {
                // Not a solution before eq. 32 is tested: the statistics restart.
                *self = Self {
                    p: self.p,
                    ..Self::new(self.s)
                };
            } else if tls && self.started_at.is_none() {
                self.started_at = Some(t);
            }
            let mut out = RefStep {
                nu,
                q,
                pq: 0.0,
                pnu: 0.0,
                peps: 0.0,
                lambda: self.s.lambda_max,
                margin: f64::INFINITY,
            };
            if self.started_at.is_none() {
                return out;
            }
            // σ_ε²'s weight before this sample (Σ (γ₁ᵏ − γ₂ᵏ) over the samples before), the
            // sums over the samples before without the newest's term (so it cannot cancel).
            let tested_before = self.weight_old >= wmin;
            let old_sum = g1 * self.s1nu - g2 * self.s2nu;
            if let Some((pnu, peps)) = self.last {
                let clip = self.s.noise_clip;
                // Tested: against σ_ε², or by the early test (a filled window's minimum `m`)
                // once σ_ε² is not below `m`.
                let tested = tested_before || self.min_filled.is_some_and(|m| peps >= m);
                let calm = clip > 0.0 && tested && lam >= self.s.lambda_max;
                let value = if calm { pnu.min(clip * peps) } else { pnu };
                self.clipped |= value < pnu;
                let w = (g1 - g2) * self.w2;
                self.w_in = g1 * self.w_in + w;
                self.s_in = g1 * self.s_in + w * value;
            }
            self.n += 1;
            self.w2 = g2 * self.w2 + 1.0;
            self.s2q = g2 * self.s2q + q * q;
            self.s2nu = g2 * self.s2nu + nu * nu;
            self.s1nu = g1 * self.s1nu + nu * nu;
            out.pq = self.s2q / self.w2;
            out.pnu = self.s2nu / self.w2;
            // The noise weight in closed form: Σₖ₌₀ⁿ⁻¹ γ₁ᵏ − γ₂ᵏ.
            let n = self.n as i32;
            let wold = (1.0 - g1.powi(n)) / (1.0 - g1) - (1.0 - g2.powi(n)) / (1.0 - g2);
            // The two forms of σ_ε²'s weight agree, and of σ_ε² while nothing was clipped.
            assert!(
                (self.w_in - wold).abs() <= 1e-9 * wold.max(1.0),
                "noise weight {} vs {wold}",
                self.w_in
            );
            assert!(
                self.clipped || (self.s_in - old_sum).abs() <= 1e-9 * old_sum,
                "σ_ε² {} vs {old_sum}",
                self.s_in
            );
            out.peps = if self.w_in > 0.0 { self.s_in / self.w_in } else { 0.0 };
            self.weight_old = wold;
            self.last = Some((out.pnu, out.peps));
            // What eq. 32 compares σ_ν² with: σ_ε² once it has its weight, else (the early test)
            // the smallest σ_ν² of a filled window so far, once this window is filled.
            let fill = aerosid_core::vff::EARLY_WINDOW_FILL;
            let filled = 1.0 - g2.powi(n);
            let reference = if wold >= wmin {
                Some((out.peps, 1.0))
            } else if self.s.early_test && filled >= fill {
                let m = self.min_filled.map_or(out.pnu, |m| m.min(out.pnu));
                self.min_filled = Some(m);
                Some((m, aerosid_core::vff::EARLY_THRESHOLD))
            } else {
                None
            };
            out.margin = ((wold - wmin) / wmin.max(1.0)).abs();
            if self.s.early_test {
                out.margin = out.margin.min((filled / fill - 1.0).abs());
            }
            if let Some((r, c)) = reference {
                out.margin = out.margin.min((out.pnu / (c * g0 * g0 * r) - 1.0).abs());
                // Eq. 32, else eq. 33 clamped to [λ_min, λ_max].
                if out.pnu.sqrt() > g0 * (c * r).sqrt() {
                    let (sq, snu, seps) = (out.pq.sqrt(), out.pnu.sqrt(), r.sqrt());
                    let l = sq * seps / (self.s.varsigma + (snu - seps).abs());
                    out.lambda = l.min(self.s.lambda_max).max(self.s.lambda_min);
                }
            }
            // The hold: once eq. 32 is tested against σ_ε², a failing sample starts HOLD_SAMPLES
            // samples at the floor wherever eq. 32 holds again.
            if self.s.early_test && wold >= wmin {
                let left = if tested_before { self.hold } else { 0 };
                if left > 0 {
                    out.margin = out.margin.min(self.hold_margin);
                }
                self.hold = if out.lambda < self.s.lambda_max {
                    if left == 0 {
                        self.hold_margin = out.margin;
                    }
                    left.checked_sub(1).unwrap_or(aerosid_core::vff::HOLD_SAMPLES as usize)
                } else if left > 0 {
                    out.lambda = self.s.lambda_min;
                    left - 1
                } else {
                    0
                };
            }
            out
        }
    }

    /// What one run measured.
    #[derive(Debug, Clone, Default)]
    pub struct Run {
        /// Samples after the jump until θ₀ is within 5 % of its new value for good.
        pub settle: Option<usize>,
        /// Samples before the jump (after the VFF started) with λ_F < λ_max.
        pub false_drops: usize,
        /// The sample at which the core's VFF statistics started (their last start), and how
        /// often they restarted (a lost TLS solution before eq. 32 was tested).
        pub started_at: Option<usize>,
        pub restarts: usize,
        /// Largest relative deviation of the core's VFF powers and λ_F from the reference, and the
        /// samples where eq. 32 switched differently although the reference's margin exceeded
        /// `flip_margin`.
        pub max_dev_power: f64,
        pub max_dev_lambda: f64,
        pub flips: usize,
        pub flips_outside_margin: usize,
    }

    /// Runs the core on `data` with `forgetting`; beside a VFF, the reference.
    pub fn run<T: Real>(data: &[Sample], jump: usize, forgetting: Forgetting<T>, flip_margin: f64) -> Run {
        let settings = GtlsSettings {
            forgetting,
            ..GtlsSettings::default()
        };
        let mut g = Gtls::<T, 3, 0, 4>::new(&diag_wt(&[SIGMA; 4]), &sv(&[1.0; 3]), settings).unwrap();
        let mut reference = match forgetting {
            Forgetting::Variable(v) => Some(RefVff::new(VffSettings {
                gamma1: v.gamma1.to_f64(),
                gamma2: v.gamma2.to_f64(),
                gamma0: v.gamma0.to_f64(),
                varsigma: v.varsigma.to_f64(),
                lambda_min: v.lambda_min.to_f64(),
                lambda_max: v.lambda_max.to_f64(),
                pi0: v.pi0.to_f64(),
                min_noise_weight_samples: v.min_noise_weight_samples.to_f64(),
                noise_clip: v.noise_clip.to_f64(),
                reading: v.reading,
                early_test: v.early_test,
            })),
            Forgetting::Constant(_) => None,
        };
        let lambda_max = match forgetting {
            Forgetting::Variable(v) => v.lambda_max,
            Forgetting::Constant(l) => l,
        };
        let mut out = Run::default();
        let mut tls = false;
        let mut was_started = false;
        for (t, s) in data.iter().enumerate() {
            let theta_prev: Vec<f64> = g.theta().iter().map(|v| v.to_f64()).collect();
            // The sample as the core sees it (rounded to T), for the reference too.
            let xr: Vec<f64> = s.x.iter().map(|v| T::lit(*v).to_f64()).collect();
            let zr = T::lit(s.z).to_f64();
            let step = g.update(&sv(&s.x), T::lit(s.z)).unwrap();
            if let Some(r) = reference.as_mut() {
                let rs = r.step(t, &xr, zr, &theta_prev, tls, step.lambda.to_f64());
                let v = &step.vff;
                let rel = |a: T, b: f64, scale: f64| (a.to_f64() - b).abs() / scale.max(f64::MIN_POSITIVE);
                // ν is compared against the residual's scale, σ·(1 + ‖θ‖) (it cancels from ~5).
                // The powers of ν, weighted means p of ν², against themselves or, where that is
                // larger, against 2·scale·√p: by Cauchy–Schwarz ν's deviation δν carries at most
                // 2·δν·√p into p, so this measure is at most ν's (it matters on the first samples
                // of the statistics, where p is one or two ν² that may be small).
                let scale = SIGMA * 6.0;
                let nu_dev = rel(step.prior_residual, rs.nu, scale);
                let pow_dev = |a: T, p: f64| rel(a, p, p.max(2.0 * scale * p.sqrt()));
                let dev = [
                    nu_dev,
                    rel(v.q, rs.q, rs.q.abs()),
                    rel(v.power_q, rs.pq, rs.pq),
                    pow_dev(v.power_nu, rs.pnu),
                    pow_dev(v.power_eps, rs.peps),
                ]
                .into_iter()
                .filter(|d| d.is_finite())
                .fold(0.0, f64::max);
                out.max_dev_power = out.max_dev_power.max(dev);
                let core_max = step.lambda_next == lambda_max;
                let ref_max = rs.lambda == lambda_max.to_f64();
                if core_max != ref_max {
                    out.flips += 1;
                    if rs.margin.abs() > flip_margin {
                        out.flips_outside_margin += 1;
                    }
                } else {
                    out.max_dev_lambda = out.max_dev_lambda.max((step.lambda_next.to_f64() - rs.lambda).abs());
                }
                // The start of the statistics' last run (the core's powers are 0 before it).
                if v.power_nu == T::zero() {
                    out.started_at = None;
                } else if out.started_at.is_none() {
                    out.started_at = Some(t);
                }
                if v.power_nu == T::zero() && was_started {
                    out.restarts += 1;
                }
                was_started = v.power_nu > T::zero();
                if out.started_at.is_some() && t < jump && step.lambda_next < lambda_max {
                    out.false_drops += 1;
                }
            }
            tls = step.solution == Solution::Tls;
            if t >= jump {
                let ok = ((g.theta()[0].to_f64() - AFTER[0]) / AFTER[0]).abs() < 0.05;
                match (ok, out.settle) {
                    (true, None) => out.settle = Some(t - jump),
                    (false, Some(_)) => out.settle = None,
                    _ => {}
                }
            }
        }
        if let (Some(r), Some(c)) = (reference.as_ref(), out.started_at) {
            assert_eq!(r.started_at, Some(c), "the statistics start at a TLS solution");
        }
        out
    }

    pub fn median(v: &mut [usize]) -> usize {
        v.sort_unstable();
        v[v.len() / 2]
    }
}

/// One jump time of the sweep: medians over the seeds (`None`: not settled within
/// [`sweep::AFTER_JUMP`] samples on at least half of them).
struct Row {
    jump: usize,
    median_vff: Option<usize>,
    median_constant: Option<usize>,
    /// Seeds on which the VFF settled later than `λ = 0.999` (or not at all where it did).
    vff_slower: usize,
    /// Samples with `λ_F < λ_max` before the jump (stationary data), over the seeds.
    false_drops: usize,
}

/// The sweep for one scalar type and one setting: prints its table and checks the core's VFF
/// against the reference at every sample of every VFF run (`tol_power`: relative deviation of `ν`,
/// `q` and the three powers; `tol_lambda`: absolute deviation of `λ_F` where both are on the same
/// side of eq. 32; `flip_margin`: eq. 32 may decide differently only where the reference's
/// `σ_ν²/(γ₀²σ_ε²)` is within this relative distance of 1).
fn startup_sweep<T: aerosid_core::Real>(
    name: &str,
    settings: sweep::Settings,
    tol_power: f64,
    tol_lambda: f64,
    flip_margin: f64,
) -> Vec<Row> {
    use rayon::prelude::*;
    use sweep::*;
    let fmt = |m: Option<usize>| m.map_or("not settled".to_string(), |v| v.to_string());
    let mut rows = Vec::new();
    for jump in JUMPS {
        let runs: Vec<(Run, Run)> = SEEDS
            .into_par_iter()
            .map(|seed| {
                let d = data(jump, seed);
                let v = run::<T>(&d, jump, Forgetting::Variable(settings.vff()), flip_margin);
                let c = run::<T>(&d, jump, Forgetting::Constant(T::lit(0.999)), flip_margin);
                (v, c)
            })
            .collect();
        let not = |s: Option<usize>| s.unwrap_or(usize::MAX);
        let med = |f: &dyn Fn(&(Run, Run)) -> Option<usize>| {
            let m = median(&mut runs.iter().map(|r| not(f(r))).collect::<Vec<_>>());
            (m != usize::MAX).then_some(m)
        };
        let row = Row {
            jump,
            median_vff: med(&|r| r.0.settle),
            median_constant: med(&|r| r.1.settle),
            vff_slower: runs.iter().filter(|(v, c)| not(v.settle) > not(c.settle)).count(),
            false_drops: runs.iter().map(|(v, _)| v.false_drops).sum(),
        };
        let start: Vec<usize> = runs.iter().filter_map(|(v, _)| v.started_at).collect();
        let dev_p = runs.iter().map(|(v, _)| v.max_dev_power).fold(0.0, f64::max);
        let dev_l = runs.iter().map(|(v, _)| v.max_dev_lambda).fold(0.0, f64::max);
        let flips: usize = runs.iter().map(|(v, _)| v.flips).sum();
        let flips_out: usize = runs.iter().map(|(v, _)| v.flips_outside_margin).sum();
        println!(
            "{name} {settings:?} jump at {jump:>5}: settled after (median) VFF {:>11}, λ = 0.999 {:>11}; \
             VFF slower on {}/10 seeds; false λ drops before the jump {}; VFF per seed {:?}; \
             statistics (re)started at sample {:?}..{:?} after {} restarts; vs reference: powers {dev_p:.1e}, λ {dev_l:.1e}, \
             eq. 32 decided differently {flips} times ({flips_out} outside ±{flip_margin:e})",
            fmt(row.median_vff),
            fmt(row.median_constant),
            row.vff_slower,
            row.false_drops,
            runs.iter().map(|(v, _)| v.settle).collect::<Vec<_>>(),
            start.iter().min(),
            start.iter().max(),
            runs.iter().map(|(v, _)| v.restarts).sum::<usize>(),
        );
        assert_eq!(
            start.len(),
            runs.len(),
            "{name} {settings:?}: the statistics never started"
        );
        assert!(
            dev_p <= tol_power,
            "{name} {settings:?}: the core's VFF deviates from the reference by {dev_p:e}"
        );
        assert!(
            dev_l <= tol_lambda,
            "{name} {settings:?}: λ_F deviates from the reference by {dev_l:e}"
        );
        assert_eq!(
            flips_out, 0,
            "{name} {settings:?}: eq. 32 decided differently away from its threshold"
        );
        rows.push(row);
    }
    let stationary: usize = JUMPS.iter().sum::<usize>() * SEEDS.count();
    let drops: usize = rows.iter().map(|r| r.false_drops).sum();
    println!("{name} {settings:?}: false λ drops on {stationary} stationary samples: {drops}");
    rows
}

/// Reference tolerances. `f64`: the two implementations differ in the order of operations only;
/// measured 1.5e-13 (powers) and 1e-14 (λ_F), so 1e-10 leaves a thousandfold margin. `f32`: `ν` is
/// a difference of terms of ≈ 5 that leaves ≈ 0.05 (cancellation ×100: ≈ 100·ε ≈ 6e-6 relative),
/// and `q` comes from `P` after up to 26 000 rank-one updates in `f32` (≈ √N·ε ≈ 1e-5); measured
/// 9.4e-5, so 5e-4. `λ_F` of eq. 33 carries the powers' error times `σ_ν/(σ_ν − σ_ε) ≤ 1/(1 − 1/γ₀)`
/// (≤ 3): 2e-3. Eq. 32 may switch differently only where the powers' ratio is within twice their
/// error of the threshold.
const F64_TOL: (f64, f64, f64) = (1e-10, 1e-10, 1e-9);
const F32_TOL: (f64, f64, f64) = (5e-4, 2e-3, 1e-3);

/// The targets, for both settings and every jump time: the estimate within 5 % of the new value for
/// good after a median of at most 500 samples; on no seed later than with `λ = 0.999`; no sample
/// of the stationary data before the jump with `λ_F < λ_max`.
fn check_targets(rows: &[Row]) {
    for r in rows {
        assert!(
            r.median_vff.is_some_and(|m| m <= 500),
            "jump at {}: median {:?} > 500",
            r.jump,
            r.median_vff
        );
        assert_eq!(r.vff_slower, 0, "jump at {}: VFF slower than λ = 0.999", r.jump);
        assert_eq!(r.false_drops, 0, "jump at {}: false λ drops", r.jump);
    }
}

/// Settings that break eq. 31 (`γ₂ < γ₁`), ask for no noise weight or for more than `σ_ε²` can gather
/// (`1/(1 − γ₁) − 1/(1 − γ₂)`: 585 samples for `for_dimension(3)`) are refused.
#[test]
fn vff_settings_against_eq31_or_the_noise_weight_are_refused() {
    use aerosid_core::{Error, Rls, RlsSettings};
    let base = VffSettings::<f64>::for_dimension(3);
    type Edit = (&'static str, fn(&mut VffSettings<f64>));
    let cases: [Edit; 6] = [
        ("γ₂ = γ₁", |v| v.gamma2 = v.gamma1),
        ("γ₂ > γ₁", |v| (v.gamma1, v.gamma2) = (v.gamma2, v.gamma1)),
        ("negative noise weight", |v| v.min_noise_weight_samples = -1.0),
        ("no noise weight", |v| v.min_noise_weight_samples = 0.0),
        ("noise weight never reached", |v| v.min_noise_weight_samples = 585.5),
        ("NaN noise weight", |v| v.min_noise_weight_samples = f64::NAN),
    ];
    for (what, edit) in cases {
        let mut vs = base;
        edit(&mut vs);
        let settings = GtlsSettings {
            forgetting: Forgetting::Variable(vs),
            ..GtlsSettings::default()
        };
        let got = Gtls::<f64, 3, 0, 4>::new(&diag_wt(&[0.05; 4]), &sv(&[1.0; 3]), settings).err();
        assert_eq!(got, Some(Error::InvalidSetting), "{what}");
        let rls = RlsSettings {
            forgetting: Forgetting::Variable(vs),
            ..RlsSettings::default()
        };
        assert_eq!(Rls::<f64, 3>::new(rls).err(), Some(Error::InvalidSetting), "{what}");
    }
    // Just below the weight it tends to is valid.
    let mut vs = base;
    vs.min_noise_weight_samples = 584.0;
    let settings = GtlsSettings {
        forgetting: Forgetting::Variable(vs),
        ..GtlsSettings::default()
    };
    assert!(Gtls::<f64, 3, 0, 4>::new(&diag_wt(&[0.05; 4]), &sv(&[1.0; 3]), settings).is_ok());
}

#[test]
fn startup_sweep_f64_for_dimension() {
    let (p, l, f) = F64_TOL;
    check_targets(&startup_sweep::<f64>("f64", sweep::Settings::ForDimension, p, l, f));
}

#[test]
fn startup_sweep_f32_for_dimension() {
    let (p, l, f) = F32_TOL;
    check_targets(&startup_sweep::<f32>("f32", sweep::Settings::ForDimension, p, l, f));
}

#[test]
fn startup_sweep_f64_for_aero() {
    let (p, l, f) = F64_TOL;
    check_targets(&startup_sweep::<f64>("f64", sweep::Settings::ForAero, p, l, f));
}

#[test]
fn startup_sweep_f32_for_aero() {
    let (p, l, f) = F32_TOL;
    check_targets(&startup_sweep::<f32>("f32", sweep::Settings::ForAero, p, l, f));
}

// ---------------------------------------------------------------------------------------------------
// An early jump over many seeds: randomised regressors and parameters, dimensions 3, 5 and 6
// ---------------------------------------------------------------------------------------------------

/// A second sweep with its own generator: per seed, random parameters and regressors (every noisy
/// column a sum of three sinusoids of random frequency, phase and amplitude), the intercept as an
/// exact column or none, errors of σ = 0.05 in every noisy regressor and in `z`; the first noisy
/// parameter jumps by −1/3 of its value.
mod early {
    use super::*;
    use aerosid_core::{Real, Solution};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    pub const SIGMA: f64 = 0.05;
    pub const AFTER_JUMP: usize = 6000;

    /// One data set: rows `x = [x_e, x_n]`, `z`, and the jumping parameter's index and new value.
    pub struct Data {
        pub rows: Vec<(Vec<f64>, f64)>,
        pub jump: usize,
        pub index: usize,
        pub after: f64,
        /// The a priori residual's power right after the jump over its stationary power (the old
        /// estimate applied to the new model): `1 + Δθ²·mean(x₀ⱼ²)/(σ²(1 + ‖θ‖²))` over the first
        /// 200 samples after the jump.
        pub power_ratio: f64,
    }

    /// `nt` parameters of which `ne` (0 or 1) are the exact intercept; the jump at sample `jump`.
    pub fn data(nt: usize, ne: usize, jump: usize, seed: u64) -> Data {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ ((nt * 10 + ne) as u64));
        let std = Normal::new(0.0, 1.0).unwrap();
        let nx = nt - ne;
        // Frequencies 0.005–0.15 rad/sample (periods of 40–1 200 samples), amplitudes 0.3–1.
        let waves: Vec<[(f64, f64, f64); 3]> = (0..nx)
            .map(|_| {
                core::array::from_fn(|_| {
                    (
                        rng.random_range(0.005..0.15),
                        rng.random_range(0.0..std::f64::consts::TAU),
                        rng.random_range(0.3..1.0),
                    )
                })
            })
            .collect();
        // Parameters of magnitude 0.5–5, random signs; the intercept 0.3.
        let mut theta: Vec<f64> = (0..nt)
            .map(|j| {
                if j < ne {
                    0.3
                } else {
                    let m: f64 = rng.random_range(0.5..5.0);
                    if rng.random::<bool>() {
                        m
                    } else {
                        -m
                    }
                }
            })
            .collect();
        let index = ne;
        let after = theta[index] * (2.0 / 3.0);
        let n = jump + AFTER_JUMP;
        let mut rows = Vec::with_capacity(n);
        let norm2: f64 = theta[ne..].iter().map(|v| v * v).sum::<f64>() + 1.0;
        let delta = theta[index] - after;
        let mut excess = 0.0;
        for t in 0..n {
            if t == jump {
                theta[index] = after;
            }
            let tf = t as f64;
            let mut x0 = vec![1.0; nt];
            for (j, w) in waves.iter().enumerate() {
                x0[ne + j] = w.iter().map(|(f, p, a)| a * (f * tf + p).sin()).sum();
            }
            let y: f64 = x0.iter().zip(&theta).map(|(a, b)| a * b).sum();
            if (jump..jump + 200).contains(&t) {
                excess += (delta * x0[index]).powi(2) / 200.0;
            }
            let mut x = x0;
            for v in x.iter_mut().skip(ne) {
                *v += SIGMA * std.sample(&mut rng);
            }
            rows.push((x, y + SIGMA * std.sample(&mut rng)));
        }
        Data {
            rows,
            jump,
            index,
            after,
            power_ratio: 1.0 + excess / (SIGMA * SIGMA * norm2),
        }
    }

    /// What one run measured.
    #[derive(Debug, Clone, Default)]
    pub struct Run {
        /// Samples after the jump until the jumping parameter is within 5 % of its new value for good.
        pub settle: Option<usize>,
        /// Samples before the jump with `λ_F < λ_max` (after the first TLS solution).
        pub false_drops: usize,
        /// The sample at which eq. 28's statistics (last) started, the one at which eq. 32 was
        /// first tested (`σ_ε²`'s weight `D` reached `min_noise_weight_samples`), and the first
        /// sample at or after the jump with `λ_F < λ_max` (VFF only).
        pub started: Option<usize>,
        pub armed: Option<usize>,
        pub detected: Option<usize>,
    }

    /// Runs `Gtls<T, NT, NE, NA>` on `d`.
    pub fn run<T: Real, const NT: usize, const NE: usize, const NA: usize>(d: &Data, forgetting: Forgetting<T>) -> Run {
        let settings = GtlsSettings {
            forgetting,
            ..GtlsSettings::default()
        };
        let mut g = Gtls::<T, NT, NE, NA>::new(&diag_wt(&[SIGMA; NA]), &sv(&[1.0; NT]), settings).unwrap();
        let lambda_max = match forgetting {
            Forgetting::Variable(v) => v.lambda_max,
            Forgetting::Constant(l) => l,
        };
        let mut out = Run::default();
        let mut solved = false;
        // W₂ and D of the `vff` module doc, followed from the samples with statistics (those
        // with σ_ν² > 0; σ_ν² = 0 before the start and on a restart).
        let (mut w2, mut w_eps) = (0.0, 0.0);
        for (t, (x, z)) in d.rows.iter().enumerate() {
            let step = g.update(&sv(x), T::lit(*z)).unwrap();
            solved |= step.solution == Solution::Tls;
            if solved && t < d.jump && step.lambda_next < lambda_max {
                out.false_drops += 1;
            }
            if let Forgetting::Variable(v) = forgetting {
                let (g1, g2) = (v.gamma1.to_f64(), v.gamma2.to_f64());
                if step.vff.power_nu == T::zero() {
                    (w2, w_eps, out.started, out.armed) = (0.0, 0.0, None, None);
                } else {
                    out.started.get_or_insert(t);
                    w_eps = g1 * w_eps + (g1 - g2) * w2;
                    w2 = g2 * w2 + 1.0;
                    if out.armed.is_none() && w_eps >= v.min_noise_weight_samples.to_f64() {
                        out.armed = Some(t);
                    }
                }
                if t >= d.jump && out.detected.is_none() && step.lambda_next < lambda_max {
                    out.detected = Some(t);
                }
            }
            if t >= d.jump {
                let ok = ((g.theta()[d.index].to_f64() - d.after) / d.after).abs() < 0.05;
                match (ok, out.settle) {
                    (true, None) => out.settle = Some(t - d.jump),
                    (false, Some(_)) => out.settle = None,
                    _ => {}
                }
            }
        }
        out
    }
}

/// One jump time of the early-jump sweep, over the seeds.
#[derive(Debug)]
struct EarlyRow {
    jump: usize,
    median_vff: usize,
    median_constant: usize,
    /// Seeds on which the VFF settled later than `λ = 0.999`, and the largest ratio of the two.
    slower: usize,
    worst_ratio: f64,
    /// Samples with `λ_F < λ_max` before the jump, over the seeds.
    false_drops: usize,
    /// Seeds whose residual power right after the jump is below `γ₀²` (eq. 32 cannot fire on it),
    /// and the VFF's median over the other seeds.
    below_eq32: usize,
    median_vff_above: usize,
}

const EARLY_JUMPS: [usize; 5] = [150, 300, 600, 1500, 5000];
const EARLY_SEEDS: std::ops::RangeInclusive<u64> = 1..=100;

/// The early-jump runs at one jump time for `Gtls<T, NT, NE, NA>`, one per seed in seed order: the
/// VFF with the settings `vs`, `λ = 0.999`, and the residual power ratio of the jump.
fn early_runs<T: aerosid_core::Real, const NT: usize, const NE: usize, const NA: usize>(
    jump: usize,
    vs: VffSettings<T>,
) -> Vec<(early::Run, early::Run, f64)> {
    use rayon::prelude::*;
    EARLY_SEEDS
        .into_par_iter()
        .map(|seed| {
            let d = early::data(NT, NE, jump, seed);
            let v = early::run::<T, NT, NE, NA>(&d, Forgetting::Variable(vs));
            let c = early::run::<T, NT, NE, NA>(&d, Forgetting::Constant(T::lit(0.999)));
            (v, c, d.power_ratio)
        })
        .collect()
}

/// The early-jump sweep for `Gtls<T, NT, NE, NA>` with the VFF settings `vs` against
/// `λ = 0.999`; prints and returns one row per jump time ("not settled" counts as the
/// [`early::AFTER_JUMP`] samples run after the jump).
fn early_sweep<T: aerosid_core::Real, const NT: usize, const NE: usize, const NA: usize>(
    name: &str,
    vs: VffSettings<T>,
    jumps: &[usize],
) -> Vec<EarlyRow> {
    let g0 = vs.gamma0.to_f64();
    jumps
        .iter()
        .map(|&jump| {
            let not = early::AFTER_JUMP;
            let runs: Vec<(usize, usize, usize, f64)> = early_runs::<T, NT, NE, NA>(jump, vs)
                .iter()
                .map(|(v, c, ratio)| (v.settle.unwrap_or(not), c.settle.unwrap_or(not), v.false_drops, *ratio))
                .collect();
            let mut v: Vec<usize> = runs.iter().map(|r| r.0).collect();
            let mut c: Vec<usize> = runs.iter().map(|r| r.1).collect();
            let slow: Vec<f64> = runs.iter().filter(|r| r.0 > r.1).map(|r| r.0 as f64 / r.1.max(1) as f64).collect();
            let row = EarlyRow {
                jump,
                median_vff: sweep::median(&mut v),
                median_constant: sweep::median(&mut c),
                slower: slow.len(),
                worst_ratio: slow.iter().copied().fold(0.0, f64::max),
                false_drops: runs.iter().map(|r| r.2).sum(),
                below_eq32: runs.iter().filter(|r| r.3 < g0 * g0).count(),
                median_vff_above: sweep::median(
                    &mut runs.iter().filter(|r| r.3 >= g0 * g0).map(|r| r.0).collect::<Vec<_>>(),
                ),
            };
            println!(
                "{name} jump at {jump:>4}: settled after (median) VFF {:>4}, λ = 0.999 {:>4}; VFF slower on {}/{} seeds \
                 (worst ×{:.2}); false λ drops before the jump {}; jump below eq. 32's limit on {} seeds \
                 (median VFF over the others {})",
                row.median_vff,
                row.median_constant,
                row.slower,
                runs.len(),
                row.worst_ratio,
                row.false_drops,
                row.below_eq32,
                row.median_vff_above
            );
            row
        })
        .collect()
}

/// The targets: the VFF slower than `λ = 0.999` on at most 1 seed in 100 and then by at most 20 %;
/// no `λ_F < λ_max` on the stationary data before the jump; a median below `λ = 0.999`'s at every
/// jump time, and of at most 500 samples to settle.
fn check_early(name: &str, rows: &[EarlyRow]) {
    for r in rows {
        assert!(
            r.median_vff <= 500,
            "{name} jump at {}: median {} > 500",
            r.jump,
            r.median_vff
        );
        assert!(
            r.median_vff < r.median_constant,
            "{name} jump at {}: median {} not below λ = 0.999's {}",
            r.jump,
            r.median_vff,
            r.median_constant
        );
        assert!(
            r.slower <= 1 && r.worst_ratio <= 1.2,
            "{name} jump at {}: VFF slower than λ = 0.999 on {} seeds (worst ×{:.2})",
            r.jump,
            r.slower,
            r.worst_ratio
        );
        assert_eq!(r.false_drops, 0, "{name} jump at {}: false λ drops", r.jump);
    }
}

/// The case of an independent harness, always run: `Gtls<f64, 3, 0, 4>`, 100 seeds, five jump times.
#[test]
fn early_jump_sweep_f64_dimension_3() {
    check_early(
        "f64 3/0",
        &early_sweep::<f64, 3, 0, 4>("f64 3/0", VffSettings::for_dimension(3), &EARLY_JUMPS),
    );
}

/// The jump at sample 150 in dimension 5, always run (`Gtls<f64, 5, 0, 6>`, 100 seeds): the clip of
/// what `σ_ε²` takes in while eq. 32 holds (`vff` module doc, "28c while eq. 32 holds" and "The
/// clip while the early test holds") settles it at least 10 % sooner on the median than the same
/// settings without it (measured 362 against 541 samples; `λ = 0.999`: 915), with the targets of
/// `check_early` (the median ≤ 500 included).
#[test]
fn early_jump_at_150_dimension_5_clip() {
    let jump = &EARLY_JUMPS[..1];
    let with = VffSettings::<f64>::for_dimension(5);
    let without = VffSettings {
        noise_clip: 0.0,
        ..with
    };
    let clip = early_sweep::<f64, 5, 0, 6>("f64 5/0", with, jump);
    let none = early_sweep::<f64, 5, 0, 6>("f64 5/0 without the clip", without, jump);
    check_early("f64 5/0", &clip);
    let (a, b) = (clip[0].median_vff, none[0].median_vff);
    assert!(a * 10 <= b * 9, "median {a} with the clip, {b} without");
}

/// The early F test (`vff` module doc, "The early F test"): `Gtls<f64, 6, 0, 7>`, seed 98 of the
/// early-jump generator, the jump at sample 150 (`R = 22`) 27 samples after the statistics start
/// (the first TLS solution at sample 123), before any short window is filled and long before
/// `σ_ε²` has its weight. `σ_ν²/σ_ε²` reaches 7.1 at the jump; the F test flags it there and the
/// noise power before it is held as the early test's reference, so the estimate settles within
/// 250 samples (measured 167) where `λ = 0.999` (and the VFF without the F test: the change then
/// enters the young `σ_ε²`, never detected) needs more than 1 000 (1 086). Asserted: `λ_F < λ_max`
/// within 2 samples of the jump, settled within 250 samples, and `λ = 0.999` after more than 1 000
/// (the case is the one described).
#[test]
fn early_f_test_flags_a_jump_right_after_the_start() {
    let d = early::data(6, 0, 150, 98);
    let v = early::run::<f64, 6, 0, 7>(&d, Forgetting::Variable(VffSettings::for_dimension(6)));
    let c = early::run::<f64, 6, 0, 7>(&d, Forgetting::Constant(0.999));
    let settle = v.settle.expect("VFF settled");
    println!("detected {:?}, settled {settle}, λ = 0.999: {:?}", v.detected, c.settle);
    assert!(v.detected.is_some_and(|t| t <= d.jump + 2), "detected {:?}", v.detected);
    assert!(settle <= 250, "settled after {settle}");
    assert!(
        c.settle.is_none_or(|s| s > 1000),
        "λ = 0.999 settled after {:?}",
        c.settle
    );
}

/// Why a jump at sample 150 settles late in dimensions 5 and 6 (`vff` module doc, "What is
/// left"), seed by seed: when eq. 28's statistics start (the first TLS solution) and when eq. 32
/// is first tested (`σ_ε²`'s weight reaches 50 samples), and for the jumps above eq. 32's limit
/// (`R ≥ γ₀²`) how many come before that test and how they settle, with and without the clip.
/// Asserted: the reading, i.e. at least two thirds of the jumps above the limit that settle
/// later than 500 samples with the clip came before eq. 32 was tested.
#[test]
#[ignore = "diagnosis of the jump at sample 150 in dimensions 5 and 6, seed by seed"]
fn early_jump_at_150_arming_diagnosis() {
    fn diagnose<const NT: usize, const NA: usize>(name: &str) {
        let jump = EARLY_JUMPS[0];
        let with = VffSettings::<f64>::for_dimension(NT);
        let g02 = with.gamma0 * with.gamma0;
        let not = early::AFTER_JUMP;
        let mut late_before = (0, 0);
        for (what, vs) in [
            ("with the clip", with),
            (
                "without",
                VffSettings {
                    noise_clip: 0.0,
                    ..with
                },
            ),
        ] {
            let runs = early_runs::<f64, NT, 0, NA>(jump, vs);
            let mut start: Vec<usize> = runs.iter().filter_map(|r| r.0.started).collect();
            let mut armed: Vec<usize> = runs.iter().filter_map(|r| r.0.armed).collect();
            println!(
                "{name} {what}: statistics started at sample {} (median; range {:?}–{:?}), eq. 32 tested from {} (median)",
                sweep::median(&mut start),
                start.first(),
                start.last(),
                sweep::median(&mut armed)
            );
            let above: Vec<_> = runs.iter().enumerate().filter(|(_, r)| r.2 >= g02).collect();
            for before in [true, false] {
                let group: Vec<_> = above
                    .iter()
                    .filter(|(_, r)| r.0.armed.is_none_or(|a| a > jump) == before)
                    .collect();
                let mut settle: Vec<usize> = group.iter().map(|(_, r)| r.0.settle.unwrap_or(not)).collect();
                println!(
                    "  {} jumps above the limit {} eq. 32 was tested: {} detected, median to settle {}",
                    group.len(),
                    if before { "before" } else { "after" },
                    group.iter().filter(|(_, r)| r.0.detected.is_some()).count(),
                    if settle.is_empty() {
                        0
                    } else {
                        sweep::median(&mut settle)
                    }
                );
            }
            for (i, (v, c, ratio)) in above.iter().filter(|(_, r)| r.0.settle.unwrap_or(not) > 500) {
                println!(
                    "    seed {:3}: R {ratio:5.2}, started {:?}, tested from {:?}, detected {:?}, settled {} (λ = 0.999: {})",
                    *i as u64 + EARLY_SEEDS.start(),
                    v.started,
                    v.armed,
                    v.detected,
                    v.settle.unwrap_or(not),
                    c.settle.unwrap_or(not)
                );
            }
            if vs.noise_clip > 0.0 {
                let late: Vec<_> = above.iter().filter(|(_, r)| r.0.settle.unwrap_or(not) > 500).collect();
                late_before = (
                    late.iter().filter(|(_, r)| r.0.armed.is_none_or(|a| a > jump)).count(),
                    late.len(),
                );
            }
        }
        let (b, n) = late_before;
        assert!(
            3 * b >= 2 * n,
            "{name}: {b} of {n} late jumps above the limit came before eq. 32 was tested"
        );
    }
    diagnose::<5, 6>("f64 5/0");
    diagnose::<6, 7>("f64 6/0");
}

/// The full sweep: dimensions 3, 5 and 6 with every regressor noisy, 6 with the intercept exact,
/// `f32` and `f64` (≈ 8 times the always-on case), with every target of `check_early` at every
/// jump time. The tightest is the median at sample 150 in dimension 6, where a jump comes before
/// eq. 32 is tested on almost all seeds (the first TLS solution plus the noise weight of 50
/// samples; `early_jump_at_150_arming_diagnosis`): 465 / 441 samples (every regressor noisy / an
/// exact intercept; 565 / 565 without the hold after a detection, `vff` module doc, "The hold"),
/// 53 of 100 seeds within 500 in both.
#[test]
#[ignore = "the full sweep, about 5 min: dimensions 3, 5, 6 and an exact column, f32 and f64"]
fn early_jump_sweep_full() {
    let sweeps = [
        (
            "f32 3/0",
            early_sweep::<f32, 3, 0, 4>("f32 3/0", VffSettings::for_dimension(3), &EARLY_JUMPS),
        ),
        (
            "f64 5/0",
            early_sweep::<f64, 5, 0, 6>("f64 5/0", VffSettings::for_dimension(5), &EARLY_JUMPS),
        ),
        (
            "f32 5/0",
            early_sweep::<f32, 5, 0, 6>("f32 5/0", VffSettings::for_dimension(5), &EARLY_JUMPS),
        ),
        (
            "f64 6/0",
            early_sweep::<f64, 6, 0, 7>("f64 6/0", VffSettings::for_dimension(6), &EARLY_JUMPS),
        ),
        (
            "f32 6/0",
            early_sweep::<f32, 6, 0, 7>("f32 6/0", VffSettings::for_dimension(6), &EARLY_JUMPS),
        ),
        (
            "f64 6/1",
            early_sweep::<f64, 6, 1, 6>("f64 6/1", VffSettings::for_dimension(6), &EARLY_JUMPS),
        ),
        (
            "f32 6/1",
            early_sweep::<f32, 6, 1, 6>("f32 6/1", VffSettings::for_dimension(6), &EARLY_JUMPS),
        ),
    ];
    for (name, rows) in &sweeps {
        check_early(name, rows);
    }
}

/// Why `for_dimension` has the ceiling `λ_max = 0.999`: with the seed's `λ_max = 1` the issue's
/// case (`Gtls<f64, 3, 0, 4>`, the early-jump generator) settles later than `λ = 0.999` on many
/// seeds at every jump time (measured 30 / 18 / 15 / 13 / 12 of 100), most of them jumps below
/// eq. 32's limit (29–31): `vff` module doc, "The ceiling". Asserted: at least 10 seeds, ten times
/// the target's one in 100.
#[test]
#[ignore = "diagnosis with the paper's ceiling λ = 1: asserts the slow seeds the ceiling 0.999 removes"]
fn early_jump_diagnosis() {
    let vs = VffSettings {
        lambda_max: 1.0,
        ..VffSettings::for_dimension(3)
    };
    for r in early_sweep::<f64, 3, 0, 4>("f64 3/0, λ_max = 1", vs, &EARLY_JUMPS) {
        assert!(r.slower >= 10, "jump at {}: slower on {} seeds only", r.jump, r.slower);
        assert!(
            r.below_eq32 >= 20,
            "jump at {}: {} seeds below eq. 32's limit",
            r.jump,
            r.below_eq32
        );
    }
}

/// `for_dimension`'s eq. 32 threshold per dimension (`vff` module doc, "Eq. 32: the threshold per
/// dimension"): 2 up to `n = 3` (short window of 15 samples, `d₁ = 29`), and for larger `n` the
/// Wilson–Hilferty quantile of `χ²_d₁/d₁` at the tail probability of `γ₀ = 2`, `d₁ = 29`. The
/// references are the exact quantiles (regularised incomplete beta, `P(χ²_d₁/d₁ > γ₀²) =
/// P(χ²₂₉/29 > 4) = 2.3·10⁻¹²`): `γ₀` = 1.854 / 1.757 / 1.686 for `d₁` = 39 / 49 / 59; the
/// approximation is within 0.01 of them (it errs low by 0.003–0.006, i.e. a slightly higher
/// false-drop probability, which the sweeps measure: no drop).
#[test]
fn for_dimension_threshold_follows_the_short_window() {
    for n in 1..=3 {
        assert_eq!(VffSettings::<f64>::for_dimension(n).gamma0, 2.0, "n = {n}");
        assert_eq!(VffSettings::<f32>::for_dimension(n).gamma0, 2.0, "n = {n}");
    }
    for (n, exact) in [(4, 1.854), (5, 1.757), (6, 1.686)] {
        let g64 = VffSettings::<f64>::for_dimension(n).gamma0;
        let g32 = VffSettings::<f32>::for_dimension(n).gamma0 as f64;
        assert!((g64 - exact).abs() < 0.01, "n = {n}: γ₀ {g64} vs {exact}");
        assert!((g32 - g64).abs() < 1e-5, "n = {n}: f32 {g32} vs f64 {g64}");
    }
    let g: Vec<f64> = (3..=40).map(|n| VffSettings::<f64>::for_dimension(n).gamma0).collect();
    assert!(g.windows(2).all(|w| w[1] < w[0] && w[1] > 1.0), "{g:?}");
}

/// The early test's false drops on white residuals (`vff` module doc, "Eq. 32 before the noise
/// power has its weight"): the core's `Vff` fed `ν ~ N(0, 1)` from the start of the statistics
/// until `σ_ε²`'s weight reaches 50 samples, 10⁵ runs per dimension. The statistics start after
/// 100 samples without a solution, as in an estimator (whose first TLS solution comes after at
/// least `n_θ + 1` samples): started at once, `q = x̂₀ᵀPx̂₀` of the first sample is `1/π₀` and
/// keeps `σ_q` and eq. 33's `λ_F` at `λ_max` for tens of samples. The module doc's Monte Carlo
/// gives the probability that a run drops `λ_F` by the minimum of the filled windows as
/// 1.4·10⁻³ / 9·10⁻⁵ / 5·10⁻⁶ in dimensions 3 / 5 / 6, i.e. 140 / 9 / 0.5 runs expected here
/// (measured 140 / 11 / 2 with the minimum alone); the early F test (`vff` module doc, "The early
/// F test", 10⁻⁵ per sample over the 30–60 samples it runs) adds at most a few 10⁻⁴ (measured
/// with both: 163 / 13 / 2). Asserted at most 200 / 25 / 5 (four Poisson standard deviations
/// above the minimum's expected count, or 5 for the last), and at least one in dimension 3 (the
/// test can fail both ways: it sees the early test act at all).
#[test]
fn early_test_false_drops_on_white_residuals() {
    use aerosid_core::Vff;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};
    use rayon::prelude::*;
    const RUNS: u64 = 100_000;
    for (n, most, least) in [(3, 200, 1), (5, 25, 0), (6, 5, 0)] {
        let vs = VffSettings::<f64>::for_dimension(n);
        let (g1, g2) = (vs.gamma1, vs.gamma2);
        let dropped = (0..RUNS)
            .into_par_iter()
            .filter(|&seed| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ ((n as u64) << 40));
                let std = Normal::new(0.0, 1.0).unwrap();
                let mut vff = Vff::<f64, 1>::new(vs).unwrap();
                for _ in 0..100 {
                    vff.update(&sv(&[1.0]), std.sample(&mut rng), false).unwrap();
                }
                let (mut w2, mut d) = (0.0, 0.0);
                let mut drop = false;
                while d < vs.min_noise_weight_samples {
                    let step = vff.update(&sv(&[1.0]), std.sample(&mut rng), true).unwrap();
                    (d, w2) = (g1 * d + (g1 - g2) * w2, g2 * w2 + 1.0);
                    drop |= d < vs.min_noise_weight_samples && step.lambda < vs.lambda_max;
                }
                drop
            })
            .count();
        println!("dimension {n}: λ_F dropped before σ_ε² had its weight on {dropped} of {RUNS} runs");
        assert!(
            (least..=most).contains(&dropped),
            "dimension {n}: {dropped} runs dropped λ_F (expected {least}..={most})"
        );
    }
}
