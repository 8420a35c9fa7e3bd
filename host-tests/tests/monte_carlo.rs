//! Monte Carlo uncertainty of synthetic coefficients (seed paper 000, Section V, eq. 34–41).
//!
//! 1. GIVEN a linear measurand `f(ξ) = gᵀξ` with correlated inputs and correlated errors, WHEN the
//!    MC runs `M = 10⁶` draws, THEN `σ̂_ε` (eq. 41) equals the exact `(gᵀ Σ_ΔΞ g)^{1/2}` — here a
//!    first-order propagation is exact and `ε ~ N(0, σ²)` whatever the inputs.
//!    Tolerance: the 97.5 % order statistic of `M` normal draws has standard error
//!    `√(p(1−p)/M)/φ(1.96) · σ = 2.67e-3 σ`, so `U₊/1.96` has relative standard error
//!    `1.36e-3`; taking the larger of `|U₋|`, `|U₊|` (nearly independent) adds a bias of
//!    `+1.36e-3/√π = +0.77e-3`. We allow `0.77e-3 ± 5 · 1.36e-3`, i.e. `[−6.0e-3, +7.6e-3]` relative.
//! 2. GIVEN a Gaussian copula with target correlations, WHEN 2·10⁵ points are drawn, THEN every
//!    marginal is uniform (Kolmogorov–Smirnov `D` below the 1 % critical value `1.628/√N`) and each
//!    pair's Spearman correlation is `6/π · asin(ρ/2)` within `4.5/√N = 0.010` (the Spearman
//!    estimate's standard error is at most `1/√(N−1) = 0.0022`). Also Φ against reference values.
//! 3. GIVEN the same seed, WHEN run in a 1-thread and a 2-thread rayon pool, THEN the raw errors and
//!    the statistics are bit-identical.
//! 4. GIVEN the nonlinear `C_L` synthesis over the default ranges, WHEN the MC runs 10⁶ draws, THEN
//!    (a) it exceeds the first-order value at the centre of the ranges by > 30 %: the sensitivity
//!    (dominated by airspeed, `∂C_L/∂V = −2 C_L/V`, with `C_L ∝ |a_z|/V²`) varies strongly over the
//!    ranges, so the errors are a scale mixture with heavier tails than the centre's Gaussian;
//!    (b) with all errors 10× smaller it equals the *mixture* of local first-order Gaussians over the
//!    same copula within 2 % (the local-linear limit); (c) at full size it exceeds that mixture by
//!    2–9 %: curvature within one error draw (`1/V²`) lengthens the lower tail by ≈ `3·1.96 σ_V/(2V)`
//!    ≈ 7 % at `V = 12` m/s, and eq. 41 takes the longer tail. All six coefficients are printed.

use crate::common;

use aerosid::mc::synth::{self, idx, Airframe, Coefficient, Sensors};
use aerosid::mc::{self, coverage_bounds, phi, psd_cholesky, ErrorKind, Input, McError, McSettings, Problem, Sampler};
use common::pearson;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

fn settings(draws: usize, seed: u64) -> McSettings {
    McSettings {
        draws,
        seed,
        progress: false,
        ..McSettings::default()
    }
}

fn linear_problem() -> (Problem, Vec<f64>) {
    let abs = |name, lo, hi| Input {
        name,
        range: [lo, hi],
        error_kind: ErrorKind::Absolute,
    };
    let inputs = vec![
        abs("a", -1.0, 2.0),
        abs("b", 10.0, 30.0),
        abs("c", -5.0, -4.0),
        abs("d", 0.0, 0.1),
    ];
    let mut p = Problem::independent(inputs, &[0.1, 0.5, 0.02, 0.0]);
    p.set_corr(0, 1, 0.6);
    p.set_corr(1, 2, -0.3);
    // Correlated errors of inputs 0 and 2 (a shared sensor); input 3 exact.
    let n = 4;
    p.error_cov[2] = 0.5 * 0.1 * 0.02;
    p.error_cov[2 * n] = 0.5 * 0.1 * 0.02;
    (p, vec![1.5, -2.0, 40.0, 7.0])
}

#[test]
fn linear_measurand_matches_exact_gaussian_propagation() {
    let (p, g) = linear_problem();
    let n = p.len();
    let exact = {
        let mut v = 0.0;
        for i in 0..n {
            for j in 0..n {
                v += g[i] * p.error_cov[i * n + j] * g[j];
            }
        }
        v.sqrt()
    };
    let f = |x: &[f64]| g.iter().zip(x).map(|(a, b)| a * b).sum::<f64>();
    let m = 1_000_000;
    let t = Instant::now();
    let r = mc::run(&p, &settings(m, 1), f).expect("valid problem");
    let elapsed = t.elapsed();
    let rel = r.sigma_eps / exact - 1.0;
    println!(
        "linear: exact σ = {exact:.6}, MC σ_ε = {:.6} (rel {rel:+.2e}), U = [{:.6}, {:.6}], mean {:.2e}, std {:.6}, \
         M = {m} in {elapsed:?}",
        r.sigma_eps, r.u_lower, r.u_upper, r.mean, r.std
    );
    let se = (0.975_f64 * 0.025 / m as f64).sqrt() / 0.058_440_944 / 1.96; // relative SE of U₊/1.96
    let bias = se / std::f64::consts::PI.sqrt();
    assert!(
        (rel - bias).abs() < 5.0 * se,
        "σ_ε off by {rel:.2e} (allowed {bias:.2e} ± {:.2e})",
        5.0 * se
    );
    // The first-order propagation agrees with the exact value (finite differences are exact here).
    let taylor = mc::taylor_sigma(&p, &p.centre(), &f);
    assert!((taylor / exact - 1.0).abs() < 1e-9, "taylor {taylor} exact {exact}");
    // Moments: mean within 5 standard errors of 0, sample std within 5 standard errors of σ.
    assert!(r.mean.abs() < 5.0 * exact / (m as f64).sqrt());
    assert!((r.std / exact - 1.0).abs() < 5.0 / (2.0 * m as f64).sqrt());
    assert_eq!((r.used, r.non_finite), (m, 0));
}

#[test]
fn phi_matches_reference_values() {
    // Reference values of the standard normal CDF (mpmath, 20 digits).
    let cases = [
        (0.0, 0.5),
        (1.0, 0.841_344_746_068_542_9),
        (-1.0, 0.158_655_253_931_457_05),
        (1.96, 0.975_002_104_851_780_1),
        (-1.96, 0.024_997_895_148_220_435),
        (-5.0, 2.866_515_718_791_939e-7),
        (-8.0, 6.220_960_574_271_785e-16),
    ];
    for (x, want) in cases {
        let got = phi(x);
        assert!(((got - want) / want).abs() < 1e-14, "Φ({x}) = {got:e}, want {want:e}");
    }
}

fn ranks(x: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    for (k, &i) in order.iter().enumerate() {
        r[i] = k as f64;
    }
    r
}

#[test]
fn copula_has_uniform_marginals_and_target_rank_correlation() {
    let abs = |name| Input {
        name,
        range: [0.0, 1.0],
        error_kind: ErrorKind::Absolute,
    };
    let mut p = Problem::independent(vec![abs("u0"), abs("u1"), abs("u2")], &[0.0; 3]);
    let target = [(0, 1, 0.7), (0, 2, -0.4), (1, 2, 0.2)];
    for (i, j, rho) in target {
        p.set_corr(i, j, rho);
    }
    let s = Sampler::new(&p).expect("positive definite");
    let n_draws = 200_000;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let (mut z, mut u) = (vec![0.0; 3], vec![0.0; 3]);
    let mut cols: Vec<Vec<f64>> = (0..3).map(|_| Vec::with_capacity(n_draws)).collect();
    for _ in 0..n_draws {
        s.draw_uniform(&mut rng, &mut z, &mut u);
        for j in 0..3 {
            cols[j].push(u[j]);
        }
    }
    let nf = n_draws as f64;
    let ks_crit = 1.628 / nf.sqrt();
    for (j, col) in cols.iter().enumerate() {
        let mut sorted = col.clone();
        sorted.sort_by(f64::total_cmp);
        let d = sorted
            .iter()
            .enumerate()
            .map(|(i, &x)| ((i + 1) as f64 / nf - x).max(x - i as f64 / nf))
            .fold(0.0_f64, f64::max);
        println!("marginal {j}: KS D = {d:.2e} (1 % critical {ks_crit:.2e})");
        assert!(d < ks_crit, "marginal {j} not uniform: D = {d}");
    }
    let rk: Vec<Vec<f64>> = cols.iter().map(|c| ranks(c)).collect();
    for (i, j, rho) in target {
        let want = 6.0 / std::f64::consts::PI * (rho / 2.0_f64).asin();
        let got = pearson(&rk[i], &rk[j]);
        println!("Spearman ({i},{j}): {got:+.4}, target 6/π·asin(ρ/2) = {want:+.4} (ρ = {rho})");
        assert!(
            (got - want).abs() < 4.5 / nf.sqrt(),
            "Spearman ({i},{j}) {got} vs {want}"
        );
    }
}

#[test]
fn refuses_bad_problems_and_factors_singular_error_covariances() {
    let (mut p, _) = linear_problem();
    p.set_corr(0, 1, 1.5);
    assert_eq!(Sampler::new(&p).err(), Some(McError::NotCorrelation));
    let (mut p, _) = linear_problem();
    p.set_corr(0, 1, 0.9);
    p.set_corr(1, 2, 0.9);
    p.set_corr(0, 2, -0.9);
    assert_eq!(Sampler::new(&p).err(), Some(McError::CorrNotPositiveDefinite));
    let (mut p, _) = linear_problem();
    p.inputs[1].range = [3.0, 2.0];
    assert_eq!(Sampler::new(&p).err(), Some(McError::BadRange(1)));
    // A rank-one error covariance (two inputs from one sensor) and an exact input.
    let a = [4.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    let l = psd_cholesky(&a, 3).expect("semidefinite");
    for i in 0..3 {
        for j in 0..3 {
            let v: f64 = (0..3).map(|k| l[i * 3 + k] * l[j * 3 + k]).sum();
            assert!((v - a[i * 3 + j]).abs() < 1e-12);
        }
    }
    assert!(psd_cholesky(&[1.0, 0.0, 0.0, -1e-3], 2).is_none());
    // Order statistics: k = ⌈pM⌉ (1-based).
    let mut x: Vec<f64> = (1..=200).rev().map(f64::from).collect();
    assert_eq!(coverage_bounds(&mut x, 0.025, 0.975), (5.0, 195.0));
}

#[test]
fn bit_identical_for_one_and_two_threads() {
    let af = Airframe::skywalker_2013_mod();
    let p = synth::default_problem(&Sensors::default());
    let s = McSettings {
        draws: 100_000,
        seed: 3,
        chunk_size: 4096,
        progress: false,
    };
    let f = |x: &[f64]| synth::synthesise(&af, Coefficient::Cm, x);
    let sampler = Sampler::new(&p).expect("valid");
    let run_in = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            (
                mc::errors(&sampler, &s, &f).expect("ok"),
                mc::run(&p, &s, f).expect("ok"),
            )
        })
    };
    let (e1, r1) = run_in(1);
    let (e2, r2) = run_in(2);
    assert!(e1.iter().zip(&e2).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(r1, r2);
    assert_eq!(r1.sigma_eps.to_bits(), r2.sigma_eps.to_bits());
    let other = mc::run(&p, &McSettings { seed: 4, ..s.clone() }, f).expect("ok");
    assert_ne!(other.sigma_eps, r1.sigma_eps);
}

#[test]
fn nonlinear_lift_synthesis_differs_from_first_order_at_the_centre() {
    let af = Airframe::skywalker_2013_mod();
    let p = synth::default_problem(&Sensors::default());
    let x0 = p.centre();
    let f = |x: &[f64]| synth::synthesise(&af, Coefficient::CL, x);
    // Sanity of the synthesis: level flight at the centre speed, lift = weight.
    let mut level = x0.clone();
    level[idx::AZ] = -9.80665;
    level[idx::AX] = 0.0;
    level[idx::RPM] = 0.0; // no thrust
    level[idx::ALPHA] = 0.0;
    let cl_level = f(&level);
    let want = 2.0 * 9.80665 / (0.5 * x0[idx::RHO] * x0[idx::V] * x0[idx::V] * 0.45);
    assert!((cl_level / want - 1.0).abs() < 1e-12);

    let m = 1_000_000;
    let t = Instant::now();
    let r = mc::run(&p, &settings(m, 5), f).expect("valid");
    let elapsed = t.elapsed();
    let taylor = mc::taylor_sigma(&p, &x0, &f);
    let mixture = mc::taylor_mixture_sigma(&p, 200_000, 6, &f).expect("valid");
    // The same with every error 10× smaller (results scaled back by 10): the local-linear limit.
    let k = 0.1;
    let mut p_small = p.clone();
    p_small.error_cov.iter_mut().for_each(|v| *v *= k * k);
    let r_small = mc::run(&p_small, &settings(m, 5), f).expect("valid");
    let mixture_small = mc::taylor_mixture_sigma(&p_small, 200_000, 6, &f).expect("valid");
    println!(
        "C_L: MC σ_ε = {:.5} (U = [{:+.5}, {:+.5}], mean {:+.2e}, std {:.5}; M = {m}, {elapsed:?} on {} threads)\n\
         \x20    first-order at the centre = {taylor:.5} (MC/Taylor = {:.3})\n\
         \x20    mixture of local first-order Gaussians = {mixture:.5} (MC/mixture = {:.3})\n\
         \x20    errors ×0.1, rescaled: MC {:.5} (U = [{:+.5}, {:+.5}]), mixture {:.5} (MC/mixture = {:.4})",
        r.sigma_eps,
        r.u_lower,
        r.u_upper,
        r.mean,
        r.std,
        rayon::current_num_threads(),
        r.sigma_eps / taylor,
        r.sigma_eps / mixture,
        r_small.sigma_eps / k,
        r_small.u_lower / k,
        r_small.u_upper / k,
        mixture_small / k,
        r_small.sigma_eps / mixture_small,
    );
    // (a) The range effect: the centre's Taylor value understates σ_ε by far more than sampling error.
    assert!(
        r.sigma_eps / taylor > 1.3,
        "the range-centre Taylor value should understate σ_ε"
    );
    // (b) In the local-linear limit the MC is the mixture of local Taylor Gaussians (2 % covers the
    //     MC's ~0.3 % and the 2·10⁵-point mixture's ~0.5 % sampling error and the residual curvature).
    assert!(
        (r_small.sigma_eps / mixture_small - 1.0).abs() < 0.02,
        "local-linear limit"
    );
    // (c) At full size, curvature within one error draw: C_L ∝ 1/V², so ε ≈ −(a δ_V + b δ_V²) with
    //     b/a = 3/(2V); at the 1.96σ point the quadratic term shifts the lower tail outward by
    //     3·1.96·σ_V/(2V) ≈ 7 % at V = 12 m/s (where the tail comes from) and the upper tail inward.
    //     Eq. 41 takes the longer tail, so σ_ε exceeds the mixture by a few per cent.
    assert!(r.u_lower.abs() > r.u_upper.abs(), "the lower tail is the longer one");
    let excess = r.sigma_eps / mixture - 1.0;
    assert!(
        (0.02..0.09).contains(&excess),
        "curvature excess {excess:.3} outside [0.02, 0.09]"
    );

    let s = settings(m, 7);
    let t = Instant::now();
    let rows = synth::coefficient_sigmas(&af, &p, &s).expect("valid");
    let elapsed = t.elapsed();
    println!("all six, M = {m} each, {elapsed:?} total:");
    for row in &rows {
        println!(
            "  {}: σ_ε = {:.5}  U = [{:+.5}, {:+.5}]  std {:.5}  first-order(centre) {:.5}  ratio {:.3}",
            row.coefficient.name(),
            row.mc.sigma_eps,
            row.mc.u_lower,
            row.mc.u_upper,
            row.mc.std,
            row.taylor_centre,
            row.mc.sigma_eps / row.taylor_centre
        );
        assert!(row.mc.sigma_eps.is_finite() && row.mc.sigma_eps > 0.0);
        assert_eq!(row.mc.non_finite, 0);
        assert_eq!(row.mc.w_t_entry(), row.mc.sigma_eps * row.mc.sigma_eps);
    }
}
