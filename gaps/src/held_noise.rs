//! The white noise of a channel logged slower than the analysis's time base, as the errors-in-
//! variables model must see it.
//!
//! The readers replace a channel held between samples (a 10 Hz pitot on a 50 Hz grid) by the
//! straight lines between its sample instants ([`crate::io::held`]); the ULog and DataFlash
//! readers interpolate a slow topic the same way. The error of such a channel is the logger's
//! white noise **at its sample instants**, linearly interpolated in between:
//!
//! * its level cannot be read from the third differences on the grid
//!   ([`super::signal::white_noise_sd`]): between two sample instants the series is a straight
//!   line, so most third differences are zero and their median is zero for a channel at a fifth of
//!   the grid's rate and a quarter of the truth at half of it — the Monte Carlo of
//!   [`super::noise`] then treats a noisy pitot, propeller speed or estimated flow angle as exact;
//! * its spectrum is not white on the grid: a draw per grid sample would be smoothed away by the
//!   Savitzky–Golay filter, while the real error is constant in sign over a whole sample interval
//!   and passes it.
//!
//! So the sample instants are found again (the grid samples where the interpolated series bends),
//! the level is the third-difference estimate over the values there, and the Monte Carlo draws its
//! noise there and interpolates it the way the reader interpolated the data.
//!
//! Measured on simulated test cards (10 Hz pitot of 0.3 m/s noise, propeller speed of 1 %): the grid
//! estimate gives 0 for both, the sample-instant estimate 0.24–0.29 m/s and 0.6–1.3 %; with the
//! pitot treated as exact, its error in `q̄` (in every coefficient) and in `ΔV/V` (a candidate) is
//! one error in two columns, and `ΔV/V` in `C_D` passed every test on 8 of 20 clean cards
//! (BENCHMARKS.md, "Pooled manoeuvres (test card)").

use rand::Rng;
use rand_distr::StandardNormal;

/// Relative size of a second difference below which the series is taken as straight there (the
/// rounding of a linear interpolation in `f64`, far below any logged channel's noise).
const STRAIGHT: f64 = 1e-9;

/// The sample instants (grid indices) of a channel logged at `rate_hz` on a grid of step `h_s`
/// and linearly interpolated in between: index 0 and every sample where the series bends
/// (`|x[j+1] − 2x[j] + x[j−1]|` beyond rounding). When the count found is not within a factor
/// 1.5 of the rate's (a topic interpolated at instants between the grid's, where a bend shows on
/// two samples; a channel flat for long stretches), the grid samples nearest the rate's instants
/// instead. `None` when the channel is not slower than the grid (fewer than 1.5 grid samples per
/// sample) or too short.
pub fn sample_instants(x: &[f64], rate_hz: f64, h_s: f64) -> Option<Vec<usize>> {
    let n = x.len();
    let per = 1.0 / (rate_hz * h_s);
    if !(per >= 1.5 && per.is_finite()) || n < 8 {
        return None;
    }
    let mut k = vec![0];
    for j in 1..n - 1 {
        let d2 = x[j + 1] - 2.0 * x[j] + x[j - 1];
        let scale = x[j - 1].abs().max(x[j].abs()).max(x[j + 1].abs());
        if d2.abs() > STRAIGHT * scale.max(f64::MIN_POSITIVE) {
            k.push(j);
        }
    }
    let expected = n as f64 / per;
    if (k.len() as f64) < expected / 1.5 || (k.len() as f64) > expected * 1.5 {
        k = (0..)
            .map(|i| (i as f64 * per).round() as usize)
            .take_while(|&j| j < n)
            .collect();
        k.dedup();
    }
    Some(k)
}

/// The white-noise standard deviation of a channel from its values at its sample instants.
pub fn white_noise_sd_at(x: &[f64], instants: &[usize]) -> f64 {
    let v: Vec<f64> = instants.iter().filter_map(|&j| x.get(j).copied()).collect();
    super::signal::white_noise_sd(&v)
}

/// `n` grid samples of white noise of standard deviation `sd` drawn at `instants` (sorted, the
/// first 0) and linearly interpolated between them, held after the last: the error of a channel
/// logged at those instants as the reader interpolated it.
pub fn interpolated_noise(n: usize, instants: &[usize], sd: f64, rng: &mut impl Rng) -> Vec<f64> {
    let draws: Vec<f64> = instants
        .iter()
        .map(|_| sd * rng.sample::<f64, _>(StandardNormal))
        .collect();
    let mut out = vec![0.0; n];
    let mut k = 0usize;
    for (i, o) in out.iter_mut().enumerate() {
        while k + 1 < instants.len() && instants[k + 1] <= i {
            k += 1;
        }
        let a = instants[k];
        *o = match instants.get(k + 1) {
            Some(&b) if b > a => draws[k] + (i as f64 - a as f64) / (b - a) as f64 * (draws[k + 1] - draws[k]),
            _ => draws[k],
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A 10 Hz channel (a slow sine and white noise of σ 0.3) held on a 50 Hz grid with a
    /// drifting phase, interpolated by the reader's own function.
    fn held_channel(seed: u64, n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let h = 0.02;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * h).collect();
        let mut held = Vec::with_capacity(n);
        let mut v = 0.0;
        let mut next = 0.0;
        for &ti in &t {
            if ti >= next - 1e-9 {
                v = 15.0 + 0.5 * (0.7 * ti).sin() + 0.3 * rng.sample::<f64, _>(StandardNormal);
                // 10 Hz with a small clock drift against the grid.
                next += 0.1003;
            }
            held.push(v);
        }
        let interp = crate::io::held::interpolate(&t, &held);
        (held, interp)
    }

    #[test]
    fn the_noise_of_an_interpolated_slow_channel_is_read_at_its_sample_instants() {
        // GIVEN a 10 Hz channel of white noise σ 0.3 interpolated onto a 50 Hz grid
        let (_, x) = held_channel(3, 6000);
        // WHEN its noise is estimated on the grid and at its sample instants
        let on_grid = super::super::signal::white_noise_sd(&x);
        let k = sample_instants(&x, 10.0, 0.02).expect("slower than the grid");
        let at = white_noise_sd_at(&x, &k);
        // THEN the grid's estimate is zero (most third differences of a straight line are), the
        // sample instants are one per 0.1 s (within 2 %), and their estimate is σ within 10 %
        // (a robust scale from 1 200 values: relative standard error ≈ 3 %)
        assert!(on_grid < 0.01, "grid estimate {on_grid}");
        let expected = 6000.0 * 0.02 / 0.1003;
        assert!(
            (k.len() as f64 - expected).abs() < 0.02 * expected,
            "{} instants",
            k.len()
        );
        assert!((at - 0.3).abs() < 0.03, "estimate at the instants {at}");
    }

    #[test]
    fn interpolated_draws_have_the_level_at_the_instants_and_the_interpolations_in_between() {
        // GIVEN instants every 5 samples
        let instants: Vec<usize> = (0..2000).step_by(5).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        // WHEN noise of σ 2 is drawn there and interpolated
        let e = interpolated_noise(2000, &instants, 2.0, &mut rng);
        // THEN at the instants the variance is σ² (400 draws: within 20 %, 2.8 standard errors)
        // and half-way between two it is σ²/2 ((1/2)² + (1/2)² of it), within 25 %
        let at: f64 = instants.iter().map(|&j| e[j] * e[j]).sum::<f64>() / instants.len() as f64;
        assert!((at / 4.0 - 1.0).abs() < 0.2, "variance at the instants {at}");
        let mid: Vec<f64> = instants
            .iter()
            .filter(|&&j| j + 5 < 2000)
            .map(|&j| 0.5 * (e[j + 2] + e[j + 3]))
            .collect();
        let v_mid = mid.iter().map(|x| x * x).sum::<f64>() / mid.len() as f64;
        assert!(
            (v_mid / 4.0 - 0.5).abs() < 0.125,
            "variance between the instants {v_mid}"
        );
        // and the series is straight between the instants
        for w in instants.windows(2) {
            let (a, b) = (w[0], w[1]);
            for j in a + 1..b {
                let d2 = e[j + 1] - 2.0 * e[j] + e[j - 1];
                assert!(d2.abs() < 1e-12, "bend at {j}");
            }
        }
    }

    #[test]
    fn a_channel_at_the_grid_rate_has_no_instants_of_its_own() {
        let x: Vec<f64> = (0..100).map(|i| (i as f64 * 0.3).sin()).collect();
        assert!(sample_instants(&x, 50.0, 0.02).is_none());
        // A slow channel flat for most of the record (a held throttle): the rate's instants.
        let flat = vec![0.5; 500];
        let k = sample_instants(&flat, 10.0, 0.02).expect("slower than the grid");
        assert_eq!(k.len(), 100);
        assert_eq!(k[1], 5);
    }
}
