//! Seeded synthetic data for the estimator tests and benchmarks.
//!
//! A sample is `x = [x_e, x_n]` (exact regressors first, then the noisy ones, as the core expects)
//! and `z`. The noise-free regressors are sums of sinusoids with incommensurate frequencies (well
//! excited) or with a chosen column nearly or exactly degenerate; the measured regressors and the
//! output carry independent Gaussian noise of stated standard deviation.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// How the noise-free regressors are excited.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Excitation {
    /// Every noisy regressor has its own sinusoids (full rank, well conditioned).
    Well,
    /// The last noisy regressor moves with amplitude `level` times the others' (badly excited).
    Weak {
        /// Relative amplitude of the weakly excited column.
        level: f64,
    },
    /// The last noisy regressor is exactly the sum of the first two, in the measured data too.
    Collinear,
}

/// A regression data set definition.
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// Number of exact regressors (each is the constant 1; at most 1 is meaningful).
    pub n_exact: usize,
    /// True parameters `[θ_e, θ_n]`.
    pub theta: Vec<f64>,
    /// Standard deviation of the noise on each noisy regressor.
    pub sigma_x: Vec<f64>,
    /// Standard deviation of the noise on `z`.
    pub sigma_z: f64,
    /// Excitation pattern.
    pub excitation: Excitation,
    /// RNG seed.
    pub seed: u64,
}

/// One generated sample: measured regressors, measured output, and the noise-free regressors.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Measured regressors `[x_e, x_n]`.
    pub x: Vec<f64>,
    /// Measured output.
    pub z: f64,
    /// Noise-free regressors.
    pub x0: Vec<f64>,
}

/// Generates `n` samples of `spec`.
pub fn generate(spec: &Spec, n: usize) -> Vec<Sample> {
    let nt = spec.theta.len();
    let nx = nt - spec.n_exact;
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let std = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
    // Frequencies (rad/sample) and phases per noisy column, three sinusoids each.
    let freqs: Vec<[f64; 3]> = (0..nx)
        .map(|j| {
            let b = 0.011 + 0.0173 * j as f64;
            [b, 2.71 * b + 0.003, 6.13 * b + 0.007]
        })
        .collect();
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        let tf = t as f64;
        let mut x0 = vec![1.0; nt];
        for j in 0..nx {
            let f = freqs[j];
            x0[spec.n_exact + j] =
                (f[0] * tf + j as f64).sin() + 0.6 * (f[1] * tf + 0.3 * j as f64).sin() + 0.3 * (f[2] * tf).cos();
        }
        match spec.excitation {
            Excitation::Well => {}
            Excitation::Weak { level } => {
                let j = nt - 1;
                x0[j] *= level;
            }
            Excitation::Collinear => {
                if nx >= 3 {
                    x0[nt - 1] = x0[spec.n_exact] + x0[spec.n_exact + 1];
                }
            }
        }
        let y: f64 = x0.iter().zip(&spec.theta).map(|(a, b)| a * b).sum();
        let mut x = x0.clone();
        for j in 0..nx {
            x[spec.n_exact + j] += spec.sigma_x[j] * std.sample(&mut rng);
        }
        if spec.excitation == Excitation::Collinear && nx >= 3 {
            x[nt - 1] = x[spec.n_exact] + x[spec.n_exact + 1];
        }
        let z = y + spec.sigma_z * std.sample(&mut rng);
        out.push(Sample { x, z, x0 });
    }
    out
}
