//! Time per estimator update: the recursive PCA-GTLS (seed 000, Algorithm 1, step 4 by the secular
//! equation) against (i) the dense reference — accumulate the information matrix
//! `λ·G + d* d*ᵀ` of the scaled row (eq. 10–12) and take a faer self-adjoint eigendecomposition per
//! sample, `θ` from the eigenvector of the smallest eigenvalue (eq. 16) — and (ii) the RLS baseline.
//!
//! Every estimator sees the same pre-generated, seeded stream: `WARM_UP` samples bring it to its
//! steady state outside the timing, then each criterion iteration runs the next `STREAM` samples
//! and reports the elapsed time divided by `STREAM`, so the `time:` criterion prints is the time
//! per update. `secular_only` times `rank_one_update` alone on the same scaled rows, to split the
//! GTLS cost into the secular step and the rest. Before the measurements, the mean secular
//! iterations and deflations per update (`Step::secular`) are printed once, together with a check
//! that the recursive `θ` agrees with the faer reference.
//!
//! Run: `cargo bench -p aerosid-host-tests --bench update -- --warm-up-time 1 --measurement-time 3`.
//!
//! Data (seed `SEED`, `dt = 10 ms`, forgetting `λ = LAMBDA` for every estimator): each noisy
//! regressor is a three-tone multisine with its own frequencies and random phases (so the
//! regressors are not collinear) plus white Gaussian noise of a realistic standard deviation
//! (`SLOTS`); the output is `z = xᵀθ_true` (with `THETA_INTERCEPT` when the first regressor is the
//! exact `1`) plus noise of `SIGMA_Z`. `W_T` is the diagonal of those variances (eq. 9).

use aerosid_core::linalg::secular::{rank_one_update, Outcome};
use aerosid_core::{Estimator, Forgetting, Gtls, GtlsSettings, Real, Rls, RlsSettings, Solution};
use criterion::{criterion_group, criterion_main, Criterion};
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
use faer::{Mat, Par, Side};
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::hint::black_box;
use std::time::Instant;

/// Seed of the sample stream.
const SEED: u64 = 0xAE20_5EED_0000_0001;
/// Samples processed before timing starts (steady state).
const WARM_UP: usize = 1000;
/// Samples per criterion iteration (12 KiB of `f64` samples for `n_θ = 5`: stays in L1).
const STREAM: usize = 256;
/// Constant forgetting factor `λ_F` of every estimator (time constant 2 s at 100 Hz).
const LAMBDA: f64 = 0.995;
/// Sample interval, s.
const DT_S: f64 = 0.01;
/// Standard deviation of the output noise (a force coefficient, dimensionless).
const SIGMA_Z: f64 = 0.01;
/// The true intercept (e.g. `C_L0`), used when the first regressor is the exact `1`.
const THETA_INTERCEPT: f64 = 0.2;

/// One noisy regressor of the synthetic stream.
struct Slot {
    /// Amplitude of the multisine (regressor units, rad or normalised rate).
    amp: f64,
    /// Noise standard deviation (same units).
    sigma: f64,
    /// Frequencies of the three tones, Hz.
    freqs_hz: [f64; 3],
    /// True parameter (coefficient per regressor unit).
    theta: f64,
}

/// Noisy regressors in order: α (rad), q̂ (normalised), δ_e (rad), β (rad), p̂ (normalised).
const SLOTS: [Slot; 5] = [
    Slot {
        amp: 0.08,
        sigma: 0.005,
        freqs_hz: [0.31, 1.13, 2.37],
        theta: 5.0,
    },
    Slot {
        amp: 0.02,
        sigma: 0.001,
        freqs_hz: [0.47, 1.61, 2.93],
        theta: 7.0,
    },
    Slot {
        amp: 0.06,
        sigma: 0.002,
        freqs_hz: [0.53, 1.37, 3.17],
        theta: 0.4,
    },
    Slot {
        amp: 0.05,
        sigma: 0.005,
        freqs_hz: [0.37, 1.91, 2.71],
        theta: -0.3,
    },
    Slot {
        amp: 0.02,
        sigma: 0.001,
        freqs_hz: [0.61, 1.49, 3.41],
        theta: 0.2,
    },
];

/// One sample `(x, z)`.
#[derive(Clone, Copy)]
struct Sample<T: Real, const NT: usize> {
    x: SVector<T, NT>,
    z: T,
}

/// `WARM_UP + STREAM` samples with `NT` regressors; the first `NE ∈ {0, 1}` of them is the exact
/// intercept `1`, the others are noisy `SLOTS`.
fn stream<T: Real, const NT: usize>(ne: usize) -> Vec<Sample<T, NT>> {
    let nx = NT - ne;
    assert!(ne <= 1 && nx <= SLOTS.len());
    let mut rng = ChaCha8Rng::seed_from_u64(SEED ^ ((NT as u64) << 8) ^ ne as u64);
    let unit = Normal::new(0.0, 1.0).expect("unit normal");
    let phases: Vec<[f64; 3]> = (0..nx)
        .map(|_| [0; 3].map(|_| rng.random_range(0.0..std::f64::consts::TAU)))
        .collect();
    (0..WARM_UP + STREAM)
        .map(|i| {
            let t_s = i as f64 * DT_S;
            let mut x = SVector::<T, NT>::zeros();
            let mut z = 0.0;
            if ne == 1 {
                x[0] = T::one();
                z += THETA_INTERCEPT;
            }
            for (j, slot) in SLOTS.iter().take(nx).enumerate() {
                let truth: f64 = slot
                    .freqs_hz
                    .iter()
                    .zip(&phases[j])
                    .map(|(f, p)| (std::f64::consts::TAU * f * t_s + p).sin())
                    .sum::<f64>()
                    * (slot.amp / 3.0_f64.sqrt());
                z += slot.theta * truth;
                x[ne + j] = T::lit(truth + slot.sigma * unit.sample(&mut rng));
            }
            z += SIGMA_Z * unit.sample(&mut rng);
            Sample { x, z: T::lit(z) }
        })
        .collect()
}

/// `W_T` (eq. 9) of the TLS block `[noisy regressors, z]`: the diagonal of the noise variances.
fn w_t<T: Real, const NA: usize>() -> SMatrix<T, NA, NA> {
    SMatrix::from_fn(|r, c| {
        if r != c {
            T::zero()
        } else if r + 1 == NA {
            T::lit(SIGMA_Z * SIGMA_Z)
        } else {
            T::lit(SLOTS[r].sigma * SLOTS[r].sigma)
        }
    })
}

fn gtls<T: Real, const NT: usize, const NE: usize, const NA: usize>() -> Gtls<T, NT, NE, NA> {
    let settings = GtlsSettings {
        forgetting: Forgetting::Constant(T::lit(LAMBDA)),
        ..GtlsSettings::default()
    };
    Gtls::new(&w_t::<T, NA>(), &SVector::repeat(T::one()), settings).expect("valid GTLS settings")
}

fn rls<T: Real, const NT: usize>() -> Rls<T, NT> {
    Rls::new(RlsSettings {
        forgetting: Forgetting::Constant(T::lit(LAMBDA)),
        ..RlsSettings::default()
    })
    .expect("valid RLS settings")
}

/// How the faer reference computes its eigendecomposition.
#[derive(Clone, Copy, PartialEq, Eq)]
enum FaerApi {
    /// `Mat::self_adjoint_eigen(Side::Lower)`: faer's convenience API (allocates the
    /// result and its workspace on every call).
    Convenience,
    /// `linalg::evd::self_adjoint_evd` into preallocated `U`, `S` and workspace (no allocation).
    Preallocated,
}

/// Reference (i): the information matrix of the scaled rows, eigendecomposed by faer per sample.
/// All regressors noisy (`NA = NT + 1`).
struct FaerEigen<T: Real + faer::traits::RealField, const NT: usize, const NA: usize> {
    api: FaerApi,
    lambda: T,
    c_inv: SMatrix<T, NA, NA>,
    /// `G = Σ λ^{t−i} d*_i d*_iᵀ`, both triangles kept.
    g: Mat<T>,
    u: Mat<T>,
    s: Diag<T>,
    mem: MemBuffer,
    /// `[θ; −1]`.
    a: SVector<T, NA>,
}

impl<T: Real + faer::traits::RealField, const NT: usize, const NA: usize> FaerEigen<T, NT, NA> {
    fn new(api: FaerApi) -> Self {
        assert_eq!(NA, NT + 1);
        let w = w_t::<T, NA>();
        // Diagonal W_T: C = diag(σ), C⁻¹ = diag(1/σ) (kept as a full matrix, as in `Gtls`).
        let c_inv = SMatrix::from_fn(|r, c| if r == c { T::one() / w[(r, r)].sqrt() } else { T::zero() });
        let scratch = self_adjoint_evd_scratch::<T>(NA, ComputeEigenvectors::Yes, Par::Seq, Default::default());
        Self {
            api,
            lambda: T::lit(LAMBDA),
            c_inv,
            g: Mat::zeros(NA, NA),
            u: Mat::zeros(NA, NA),
            s: Diag::zeros(NA),
            mem: MemBuffer::new(scratch),
            a: SVector::zeros(),
        }
    }

    /// One sample; `false` if the decomposition failed or `θ` is undefined.
    fn update(&mut self, x: &SVector<T, NT>, z: T) -> bool {
        let mut d = SVector::<T, NA>::zeros();
        for i in 0..NT {
            d[i] = x[i];
        }
        d[NT] = z;
        let d_star = self.c_inv.transpose() * d; // eq. 10
        for j in 0..NA {
            for i in 0..NA {
                self.g[(i, j)] = self.lambda * self.g[(i, j)] + d_star[i] * d_star[j];
            }
        }
        // Eigenvalues come out non-decreasing: column 0 is v_NA, the smallest direction.
        let mut v = SVector::<T, NA>::zeros();
        match self.api {
            FaerApi::Convenience => {
                let Ok(evd) = self.g.self_adjoint_eigen(Side::Lower) else {
                    return false;
                };
                for (i, vi) in v.iter_mut().enumerate() {
                    *vi = evd.U()[(i, 0)];
                }
            }
            FaerApi::Preallocated => {
                let ok = self_adjoint_evd(
                    self.g.as_ref(),
                    self.s.as_mut(),
                    Some(self.u.as_mut()),
                    Par::Seq,
                    MemStack::new(&mut self.mem),
                    Default::default(),
                );
                if ok.is_err() {
                    return false;
                }
                for (i, vi) in v.iter_mut().enumerate() {
                    *vi = self.u[(i, 0)];
                }
            }
        }
        // Eq. 16: [θ; −1] = h C⁻¹ v_NA.
        let a = self.c_inv * v;
        let last = a[NT];
        if last == T::zero() {
            return false;
        }
        self.a = a * (-T::one() / last);
        true
    }

    fn theta(&self) -> SVector<T, NT> {
        SVector::from_fn(|i, _| self.a[i])
    }
}

/// Warms `step` up on the first `WARM_UP` samples, then times it over the next `STREAM` samples;
/// the time criterion records is per sample (per update).
fn run<T: Real, const NT: usize>(
    c: &mut Criterion,
    group: &str,
    id: &str,
    samples: &[Sample<T, NT>],
    mut step: impl FnMut(&SVector<T, NT>, T) -> bool,
) {
    let (warm, measured) = samples.split_at(WARM_UP);
    let warm_ok = warm.iter().filter(|s| step(&s.x, s.z)).count();
    assert_eq!(warm_ok, WARM_UP, "{group}/{id}: a warm-up sample was refused");
    let per_pass = u32::try_from(measured.len()).expect("stream length fits u32");
    let mut g = c.benchmark_group(group);
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                for s in measured {
                    black_box(step(black_box(&s.x), black_box(s.z)));
                }
            }
            start.elapsed() / per_pass
        })
    });
    g.finish();
}

fn bench_gtls<T: Real, const NT: usize, const NE: usize, const NA: usize>(c: &mut Criterion, group: &str, id: &str) {
    let samples = stream::<T, NT>(NE);
    let mut est = gtls::<T, NT, NE, NA>();
    run(c, group, id, &samples, |x, z| black_box(est.update(x, z)).is_ok());
}

fn bench_faer<T: Real + faer::traits::RealField, const NT: usize, const NA: usize>(
    c: &mut Criterion,
    group: &str,
    id: &str,
    api: FaerApi,
) {
    let samples = stream::<T, NT>(0);
    let mut est = FaerEigen::<T, NT, NA>::new(api);
    run(c, group, id, &samples, |x, z| {
        let ok = est.update(x, z);
        black_box(&est.a);
        ok
    });
}

/// The secular step alone: `rank_one_update` of `V, S` with the scaled rows `d* = C⁻ᵀ d` of the
/// all-noisy stream (what `Gtls<T, NT, 0, NA>` feeds it).
fn bench_secular<T: Real, const NT: usize, const NA: usize>(c: &mut Criterion, id: &str) {
    let samples = stream::<T, NT>(0);
    let w = w_t::<T, NA>();
    let c_inv = SMatrix::<T, NA, NA>::from_fn(|r, c| if r == c { T::one() / w[(r, r)].sqrt() } else { T::zero() });
    let rows: Vec<Sample<T, NA>> = samples
        .iter()
        .map(|s| Sample {
            x: c_inv.transpose() * SVector::from_fn(|i, _| if i < NT { s.x[i] } else { s.z }),
            z: T::zero(),
        })
        .collect();
    let lambda = T::lit(LAMBDA);
    let mut v = SMatrix::<T, NA, NA>::identity();
    let mut sv = SVector::<T, NA>::zeros(); // squared singular values
    run(c, "secular_only", id, &rows, |w, _| {
        match rank_one_update(&v, &sv, lambda, w) {
            Some((v2, s2, outcome)) => {
                v = v2;
                sv = s2;
                black_box(outcome);
                true
            }
            None => false,
        }
    });
}

fn bench_rls<T: Real, const NT: usize>(c: &mut Criterion, id: &str) {
    let samples = stream::<T, NT>(1);
    let mut est = rls::<T, NT>();
    run(c, "rls", id, &samples, |x, z| black_box(est.update(x, z)).is_ok());
}

/// The orthonormality guard's repair: one modified Gram–Schmidt of a 6×6 `V` that has drifted by
/// ~1e-6 (what `tests/orthonormality.rs` counts once per ~3000 updates in `f32`).
fn bench_reorthonormalise<T: Real>(c: &mut Criterion, id: &str) {
    let mut v0 = SMatrix::<T, 6, 6>::identity();
    for i in 0..6 {
        for j in 0..6 {
            v0[(i, j)] += T::lit(1e-6 * (((3 * i + 5 * j) % 7) as f64 - 3.0));
        }
    }
    let mut g = c.benchmark_group("reorthonormalise");
    g.bench_function(id, |b| {
        b.iter(|| {
            let mut v = black_box(v0);
            black_box(aerosid_core::linalg::reorthonormalise(&mut v));
            v
        })
    });
    g.finish();
}

fn updates(c: &mut Criterion) {
    faer::set_global_parallelism(Par::Seq);
    bench_reorthonormalise::<f64>(c, "f64/na6");
    bench_reorthonormalise::<f32>(c, "f32/na6");
    bench_gtls::<f64, 4, 0, 5>(c, "gtls", "f64/n4");
    bench_gtls::<f64, 5, 0, 6>(c, "gtls", "f64/n5");
    bench_gtls::<f32, 4, 0, 5>(c, "gtls", "f32/n4");
    bench_gtls::<f32, 5, 0, 6>(c, "gtls", "f32/n5");
    bench_gtls::<f64, 4, 1, 4>(c, "gtls_intercept", "f64/n4");
    bench_gtls::<f64, 5, 1, 5>(c, "gtls_intercept", "f64/n5");
    bench_gtls::<f32, 4, 1, 4>(c, "gtls_intercept", "f32/n4");
    bench_gtls::<f32, 5, 1, 5>(c, "gtls_intercept", "f32/n5");
    bench_faer::<f64, 4, 5>(c, "faer_eigen", "f64/n4", FaerApi::Convenience);
    bench_faer::<f64, 5, 6>(c, "faer_eigen", "f64/n5", FaerApi::Convenience);
    bench_faer::<f32, 4, 5>(c, "faer_eigen", "f32/n4", FaerApi::Convenience);
    bench_faer::<f32, 5, 6>(c, "faer_eigen", "f32/n5", FaerApi::Convenience);
    bench_faer::<f64, 4, 5>(c, "faer_evd_noalloc", "f64/n4", FaerApi::Preallocated);
    bench_faer::<f64, 5, 6>(c, "faer_evd_noalloc", "f64/n5", FaerApi::Preallocated);
    bench_faer::<f32, 4, 5>(c, "faer_evd_noalloc", "f32/n4", FaerApi::Preallocated);
    bench_faer::<f32, 5, 6>(c, "faer_evd_noalloc", "f32/n5", FaerApi::Preallocated);
    bench_secular::<f64, 4, 5>(c, "f64/n4");
    bench_secular::<f64, 5, 6>(c, "f64/n5");
    bench_secular::<f32, 4, 5>(c, "f32/n4");
    bench_secular::<f32, 5, 6>(c, "f32/n5");
    bench_rls::<f64, 4>(c, "f64/n4");
    bench_rls::<f64, 5>(c, "f64/n5");
    bench_rls::<f32, 4>(c, "f32/n4");
    bench_rls::<f32, 5>(c, "f32/n5");
}

/// Prints, once and untimed, what the secular step did per update over the warm-up and over one
/// pass of the timed stream, which solution produced `θ`, and (all-noisy case) the largest
/// difference between the recursive `θ` and the faer reference at the end of the stream.
fn secular_stats<T: Real + faer::traits::RealField, const NT: usize, const NE: usize, const NA: usize>(label: &str) {
    let samples = stream::<T, NT>(NE);
    let mut est = gtls::<T, NT, NE, NA>();
    let mut reference = (NE == 0).then(|| FaerEigen::<T, NT, NA>::new(FaerApi::Preallocated));
    let (warm, measured) = samples.split_at(WARM_UP);
    let mut tally = |part: &[Sample<T, NT>], est: &mut Gtls<T, NT, NE, NA>| {
        let (mut iterations, mut deflated, mut not_converged, mut tls, mut refused, mut general) =
            (0u64, 0u64, 0u64, 0usize, 0usize, 0usize);
        for s in part {
            if let Some(r) = reference.as_mut() {
                // Same samples as the estimator: θ is compared at the end.
                r.update(&s.x, s.z);
            }
            match est.update(&s.x, s.z) {
                Ok(step) => {
                    let Outcome {
                        deflated: d,
                        iterations: it,
                        not_converged: nc,
                        general: g,
                    } = step.secular;
                    general += usize::from(g);
                    iterations += u64::from(it);
                    deflated += u64::from(d);
                    not_converged += u64::from(nc);
                    tls += usize::from(step.solution == Solution::Tls);
                }
                Err(_) => refused += 1,
            }
        }
        let n = part.len() as f64;
        format!(
            "iterations/update {:.2}, per root {:.2}, deflations/update {:.3}, not converged {}, general path {}, TLS solutions {}/{}, refused {}",
            iterations as f64 / n,
            iterations as f64 / (n * NA as f64 - deflated as f64).max(1.0),
            deflated as f64 / n,
            not_converged,
            general,
            tls,
            part.len(),
            refused
        )
    };
    let warm_line = tally(warm, &mut est);
    let timed_line = tally(measured, &mut est);
    eprintln!("secular {label} (NA = {NA}): warm-up {WARM_UP}: {warm_line}");
    eprintln!("secular {label} (NA = {NA}): timed stream {STREAM}: {timed_line}");
    if let Some(r) = reference {
        let theta = est.theta();
        let ref_theta = r.theta();
        let diff = (0..NT)
            .map(|i| (theta[i] - ref_theta[i]).to_f64().abs())
            .fold(0.0, f64::max);
        let scale = (0..NT).map(|i| ref_theta[i].to_f64().abs()).fold(0.0, f64::max);
        let estimate = (0..NT)
            .map(|i| format!("{:+.3}", theta[i].to_f64()))
            .collect::<Vec<_>>()
            .join(", ");
        let truth = SLOTS
            .iter()
            .take(NT)
            .map(|s| format!("{:+.3}", s.theta))
            .collect::<Vec<_>>()
            .join(", ");
        eprintln!(
            "secular {label}: θ = [{estimate}] (true [{truth}]); max |θ − θ_faer| / max |θ_faer| = {:.1e}",
            diff / scale
        );
    }
}

fn statistics(_: &mut Criterion) {
    faer::set_global_parallelism(Par::Seq);
    secular_stats::<f64, 4, 0, 5>("gtls/f64/n4");
    secular_stats::<f64, 5, 0, 6>("gtls/f64/n5");
    secular_stats::<f32, 4, 0, 5>("gtls/f32/n4");
    secular_stats::<f32, 5, 0, 6>("gtls/f32/n5");
    secular_stats::<f64, 4, 1, 4>("gtls_intercept/f64/n4");
    secular_stats::<f64, 5, 1, 5>("gtls_intercept/f64/n5");
    secular_stats::<f32, 4, 1, 4>("gtls_intercept/f32/n4");
    secular_stats::<f32, 5, 1, 5>("gtls_intercept/f32/n5");
}

criterion_group!(benches, statistics, updates);
criterion_main!(benches);
