//! ISA density and Dryden turbulence (MIL-F-8785C low altitude, data/aircraft README §4).
//!
//! Math note (discretisation): each Dryden forming filter is written in state space, its stationary
//! state covariance `P` is solved in closed form, and the output row is scaled so the stationary
//! output variance is exactly `σ²`. The discrete step uses `Φ = e^{AΔt}` (closed form) and the exact
//! process-noise covariance `Q_d = P − Φ P Φᵀ`, so the sampled sequence has exactly the continuous
//! process's statistics at the sample instants (no Euler/Tustin error). The filters are built for a
//! fixed nominal airspeed (the trim airspeed), as is usual.

use nalgebra::{Matrix2, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Feet to metres.
pub const FT_M: f64 = 0.3048;
/// Knots to metres per second.
pub const KT_MPS: f64 = 1852.0 / 3600.0;

/// ISA troposphere density at geometric altitude `alt_m` (≤ 11 km), kg/m³.
pub fn isa_density(alt_m: f64) -> f64 {
    let t = 288.15 - 0.0065 * alt_m;
    let p = 101_325.0 * (t / 288.15).powf(5.255_88);
    p / (287.053 * t)
}

/// Turbulence scale lengths and intensities along body x, y, z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Turbulence {
    /// `L_u, L_v, L_w`, m.
    pub lengths_m: [f64; 3],
    /// `σ_u, σ_v, σ_w`, m/s.
    pub sigma_mps: [f64; 3],
}

impl Turbulence {
    /// Light: wind at 20 ft of 15 kt.
    pub const W20_LIGHT_MPS: f64 = 15.0 * KT_MPS;
    /// Moderate: 30 kt.
    pub const W20_MODERATE_MPS: f64 = 30.0 * KT_MPS;
    /// Severe: 45 kt.
    pub const W20_SEVERE_MPS: f64 = 45.0 * KT_MPS;

    /// MIL-F-8785C low altitude: `L_w = h`, `L_u = L_v = h/(0.177 + 0.000823h)^1.2`, `σ_w = 0.1 W20`,
    /// `σ_u = σ_v = σ_w/(0.177 + 0.000823h)^0.4`, h in ft above ground, clamped to 10…1000 ft
    /// (the low-altitude band; the medium-altitude interpolation is not modelled).
    pub fn mil_f_8785c_low_altitude(height_agl_m: f64, w20_mps: f64) -> Self {
        let h = (height_agl_m / FT_M).clamp(10.0, 1000.0);
        let k = 0.177 + 0.000823 * h;
        let lw = h * FT_M;
        let luv = h / k.powf(1.2) * FT_M;
        let sw = 0.1 * w20_mps;
        let suv = sw / k.powf(0.4);
        Self {
            lengths_m: [luv, luv, lw],
            sigma_mps: [suv, suv, sw],
        }
    }
}

/// One second-order Dryden channel `σ √(L/(πV)) (1 + √3 (L/V)s)/(1 + (L/V)s)²` (v and w).
#[derive(Debug, Clone, Copy)]
struct Second {
    phi: Matrix2<f64>,
    chol: Matrix2<f64>,
    c: Vector2<f64>,
    x: Vector2<f64>,
}

/// Dryden gusts in body axes, seeded.
#[derive(Debug, Clone)]
pub struct Dryden {
    a_u: f64,
    b_u: f64,
    sigma: [f64; 3],
    u: f64,
    lat: [Second; 2],
    rng: ChaCha8Rng,
}

impl Dryden {
    /// Filters for nominal airspeed `airspeed_mps`, sample time `dt_s`, seeded; the initial state is
    /// drawn from the stationary distribution.
    pub fn new(t: &Turbulence, airspeed_mps: f64, dt_s: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let v = airspeed_mps.max(1.0);
        let mut n = || -> f64 { rng.sample(StandardNormal) };
        // u: first order, a Gauss–Markov process with time constant L_u/V.
        let a_u = (-v * dt_s / t.lengths_m[0].max(1e-3)).exp();
        let b_u = t.sigma_mps[0] * (1.0 - a_u * a_u).max(0.0).sqrt();
        let u = t.sigma_mps[0] * n();
        let mut lat = [Second {
            phi: Matrix2::zeros(),
            chol: Matrix2::zeros(),
            c: Vector2::zeros(),
            x: Vector2::zeros(),
        }; 2];
        for (k, ch) in lat.iter_mut().enumerate() {
            let l = t.lengths_m[k + 1].max(1e-3);
            let sigma = t.sigma_mps[k + 1];
            let tau = v / l; // double pole at −τ
                             // Controllable form: A = [[0, 1], [−τ², −2τ]], B = [0, 1]ᵀ, C₀ = [1, √3 L/V].
            let a = Matrix2::new(0.0, 1.0, -tau * tau, -2.0 * tau);
            let p = Matrix2::new(1.0 / (4.0 * tau * tau * tau), 0.0, 0.0, 1.0 / (4.0 * tau));
            let c0 = Vector2::new(1.0, 3f64.sqrt() / tau);
            let var = (c0.transpose() * p * c0)[(0, 0)];
            let c = c0 * (sigma / var.sqrt());
            // e^{AΔt} = e^{−τΔt}(I + Δt(A + τI)) since (A + τI)² = 0.
            let phi = (Matrix2::identity() + (a + Matrix2::identity() * tau) * dt_s) * (-tau * dt_s).exp();
            let qd = p - phi * p * phi.transpose();
            let qd = (qd + qd.transpose()) * 0.5;
            // 2×2 Cholesky by hand (qd is PSD; guard round-off).
            let l11 = qd[(0, 0)].max(0.0).sqrt();
            let l21 = if l11 > 0.0 { qd[(1, 0)] / l11 } else { 0.0 };
            let l22 = (qd[(1, 1)] - l21 * l21).max(0.0).sqrt();
            let chol = Matrix2::new(l11, 0.0, l21, l22);
            let p_chol = Matrix2::new(p[(0, 0)].sqrt(), 0.0, 0.0, p[(1, 1)].sqrt());
            let x = p_chol * Vector2::new(n(), n());
            *ch = Second { phi, chol, c, x };
        }
        Self {
            a_u,
            b_u,
            sigma: t.sigma_mps,
            u,
            lat,
            rng,
        }
    }

    /// The current gust velocity in body axes (u, v, w), m/s.
    pub fn gust_body_mps(&self) -> Vector3<f64> {
        Vector3::new(
            self.u,
            self.lat[0].c.dot(&self.lat[0].x),
            self.lat[1].c.dot(&self.lat[1].x),
        )
    }

    /// Advances the filters by one sample time and returns the new gust.
    pub fn step(&mut self) -> Vector3<f64> {
        let rng = &mut self.rng;
        let e: f64 = rng.sample(StandardNormal);
        self.u = self.a_u * self.u + self.b_u * e;
        for ch in self.lat.iter_mut() {
            let w = Vector2::new(rng.sample(StandardNormal), rng.sample(StandardNormal));
            ch.x = ch.phi * ch.x + ch.chol * w;
        }
        self.gust_body_mps()
    }

    /// The stationary standard deviations `σ_u, σ_v, σ_w` the filters produce (exactly the
    /// [`Turbulence`] intensities), m/s.
    pub fn sigma_mps(&self) -> [f64; 3] {
        self.sigma
    }
}
