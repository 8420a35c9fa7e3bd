//! `aerosid demo`: identifies a pitching-moment model `C_m = C_m0 + C_mα α + C_mq q_n + C_mδe δe`
//! (seed 000, eq. 3e; values of the `skywalker_2013_mod` airframe) from generated 100 Hz data with
//! realistic sensor noise on *every* regressor, running the on-board `f32` recursive PCA-GTLS
//! exactly as the firmware does, and reports the estimates with their σ (eq. 17) beside the truth
//! and the RLS baseline. The first 20 s are a calm cruise (no excitation: the PCA threshold must
//! refuse to invent parameters), then elevator doublets and sweeps excite the short period.

use aerosid_core::{Estimator, Forgetting, Gtls, GtlsSettings, Rls, RlsSettings, Solution, VffSettings};
use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::fmt::Write as _;

/// The shortest and longest demo flight the command accepts, s: at least 10 s of excitation after
/// the 20 s calm cruise, at most ten hours.
pub const SECONDS_RANGE: (f64, f64) = (30.0, 36_000.0);

const NAMES: [&str; 4] = ["Cm0", "Cmα", "Cmq", "Cmδe"];
const TRUTH: [f64; 4] = [0.01, -1.3, -20.0, 1.0];
/// Sensor noise (1σ) on α [rad] (vane), q_n [-] (gyro 0.01 rad/s at V = 15 m/s, c̄ = 0.24 m),
/// δe [rad] (servo feedback), and the synthesised C_m [-].
const SIGMA: [f64; 4] = [0.0087, 0.01 * 0.24 / (2.0 * 15.0), 0.005, 0.004];
const RATE_HZ: f64 = 100.0;

/// True short-period-like signals: α, q_n, δe at time `t` (s) (zero excitation in cruise).
pub fn manoeuvre(t: f64) -> [f64; 3] {
    let trim_alpha = 0.06;
    if t < 20.0 {
        return [trim_alpha, 0.0, -0.02];
    }
    let tau = t - 20.0;
    // Repeating 3-2-1-1 elevator (0.4 s unit) followed by a 0.2–2 Hz sweep, every 12 s.
    let cycle = tau % 12.0;
    let de = if cycle < 4.0 {
        let u = cycle / 0.4;
        let amp = 0.08;
        if u < 3.0 {
            amp
        } else if u < 5.0 {
            -amp
        } else if u < 6.0 {
            amp
        } else if u < 7.0 {
            -amp
        } else {
            0.0
        }
    } else {
        let s = cycle - 4.0;
        let f = 0.2 + (2.0 - 0.2) * s / 8.0;
        0.06 * (2.0 * std::f64::consts::PI * f * s).sin()
    };
    // A second-order pitch response to the elevator: α and q lag δe (not identical, so the regressors
    // are not collinear).
    let alpha = trim_alpha - 0.5 * de + 0.02 * (1.7 * tau).sin() + 0.01 * (0.37 * tau).cos();
    let qn = (0.004 * (2.3 * tau).cos() - 0.006 * de + 0.002 * (5.1 * tau).sin()) * 0.5;
    [alpha, qn, -0.02 + de]
}

/// The demo of `seconds` of generated data from `seed`: the estimates every 10 s, then the final
/// table and the estimator's health, as text.
pub fn demo(seed: u64, seconds: f64) -> Result<String, String> {
    let mut out = String::new();
    let n = (seconds * RATE_HZ) as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let unit = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
    let (mut gtls, mut rls) = estimators()?;
    write_header(&mut out, n, seed);
    let mut refused = 0usize;
    for i in 0..n {
        let t = i as f64 / RATE_HZ;
        let (x, z) = noisy_sample(t, &unit, &mut rng);
        let step = match gtls.update(&x, z) {
            Ok(s) => s,
            Err(e) => {
                refused += 1;
                let _ = writeln!(out, "t = {t:.2} s: sample refused: {e}");
                continue;
            }
        };
        if rls.update(&x, z).is_err() {
            refused += 1;
        }
        if i % (10 * RATE_HZ as usize) == 0 || i + 1 == n {
            let th = gtls.theta();
            let sol = solution_name(step.solution);
            let _ = writeln!(
                out,
                "{t:7.1} {:>4} {:8.5} {:10.4} {:10.3}   {sol}",
                step.k, step.lambda_next, th[1], th[2]
            );
        }
    }
    out.push('\n');
    write_estimates(&mut out, &gtls, &rls);
    write_health(&mut out, &gtls, refused);
    Ok(out)
}

/// The on-board estimator (f32 PCA-GTLS with the variable forgetting factor, `W_T` from the
/// noise levels) and the RLS baseline.
fn estimators() -> Result<(Gtls<f32, 4, 1, 4>, Rls<f32, 4>), String> {
    let w_t = SMatrix::<f32, 4, 4>::from_fn(|i, j| if i == j { (SIGMA[i] * SIGMA[i]) as f32 } else { 0.0 });
    let settings = GtlsSettings {
        forgetting: Forgetting::Variable(VffSettings::for_dimension(4)),
        ..GtlsSettings::default()
    };
    let weights = SVector::<f32, 4>::repeat(1.0);
    let gtls = Gtls::<f32, 4, 1, 4>::new(&w_t, &weights, settings)
        .map_err(|e| format!("invalid estimator settings: {e:?}"))?;
    let rls = Rls::<f32, 4>::new(RlsSettings::default()).map_err(|e| format!("invalid RLS settings: {e:?}"))?;
    Ok((gtls, rls))
}

/// The title, the noise levels and the progress table's header.
fn write_header(out: &mut String, n: usize, seed: u64) {
    let _ = writeln!(
        out,
        "aerosid demo — C_m of the skywalker_2013_mod airframe, {n} samples at 100 Hz, seed {}",
        seed
    );
    let _ = writeln!(
        out,
        "noise 1σ: α {:.2}°, q_n {:.1e}, δe {:.2}°, C_m {:.3}",
        SIGMA[0].to_degrees(),
        SIGMA[1],
        SIGMA[2].to_degrees(),
        SIGMA[3]
    );
    out.push('\n');
    let _ = writeln!(
        out,
        "{:>7} {:>4} {:>8} {:>10} {:>10}   solution",
        "t [s]", "k", "λ_F", "Cmα", "Cmq"
    );
}

/// The regressors `[1, α, q_n, δe]` and `C_m` at time `t`, the noise drawn from `rng` in that
/// order.
fn noisy_sample(t: f64, unit: &Normal<f64>, rng: &mut ChaCha8Rng) -> (SVector<f32, 4>, f32) {
    let x0 = manoeuvre(t);
    let cm = TRUTH[0] + TRUTH[1] * x0[0] + TRUTH[2] * x0[1] + TRUTH[3] * x0[2];
    let x = SVector::<f32, 4>::from([
        1.0,
        (x0[0] + SIGMA[0] * unit.sample(rng)) as f32,
        (x0[1] + SIGMA[1] * unit.sample(rng)) as f32,
        (x0[2] + SIGMA[2] * unit.sample(rng)) as f32,
    ]);
    let z = (cm + SIGMA[3] * unit.sample(rng)) as f32;
    (x, z)
}

/// Which solution the estimator gave, in words.
fn solution_name(s: Solution) -> &'static str {
    match s {
        Solution::Tls => "GTLS (eq. 16)",
        Solution::MinimumNorm => "minimum norm (eq. 22–23): not all parameters excited",
        Solution::NotEnoughData => "not enough data",
        Solution::Nongeneric => "non-generic, minimum norm",
        Solution::LeastSquares => "LS",
    }
}

/// The final estimates ± σ beside the truth and RLS, and each error in σ.
fn write_estimates(out: &mut String, gtls: &Gtls<f32, 4, 1, 4>, rls: &Rls<f32, 4>) {
    let cov = gtls.covariance().ok();
    let _ = writeln!(
        out,
        "{:<6} {:>10} {:>22} {:>10} {:>12}",
        "param", "truth", "GTLS f32 ± σ (eq. 17)", "RLS f32", "GTLS err/σ"
    );
    for i in 0..4 {
        let est = gtls.theta()[i] as f64;
        let sigma = cov.map(|c| (c[(i, i)] as f64).sqrt());
        let (pm, zs) = match sigma {
            Some(s) => (
                format!("{est:10.4} ± {s:<9.4}"),
                format!("{:+.2}", (est - TRUTH[i]) / s),
            ),
            None => (format!("{est:10.4} ± (n/a)    "), "n/a".into()),
        };
        let _ = writeln!(
            out,
            "{:<6} {:>10.4} {:>22} {:>10.4} {:>12}",
            NAMES[i],
            TRUTH[i],
            pm,
            rls.theta()[i],
            zs
        );
    }
}

/// The estimator's singular values, threshold, re-orthonormalisations, the refused samples and
/// its state's size.
fn write_health(out: &mut String, gtls: &Gtls<f32, 4, 1, 4>, refused: usize) {
    let h = gtls.health();
    out.push('\n');
    let _ = writeln!(
        out,
        "singular values {:?}, threshold {:.1}, re-orthonormalisations {}, refused samples {refused}",
        gtls.singular_values().as_slice(),
        gtls.threshold().unwrap_or(f32::NAN),
        h.reorthonormalisations
    );
    let _ = writeln!(
        out,
        "estimator state: {} bytes (f32, n_θ = 4)",
        core::mem::size_of::<Gtls<f32, 4, 1, 4>>()
    );
}
