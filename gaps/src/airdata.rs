//! Which air data the coefficients are fitted to: measured vanes and pitot, the inertial
//! reconstruction of the compatibility check, or the two fused.
//!
//! * **Measured**: the vanes and the pitot see the air the wing sees — gusts included — so an
//!   equation-error fit on them stays unbiased in turbulence, but their white noise (a vane's
//!   0.5° is `C_Lα·0.009` in `C_L`) limits what can be detected.
//! * **Reconstructed**: `V, α, β` integrated from the accelerometers and gyros (the compatibility
//!   check's flight-path reconstruction). Far less noisy, but it assumes steady air: every gust
//!   becomes an error that the coefficients' fits turn into α̇, ΔV/V or control terms.
//! * **Fused** (the default when both exist): a complementary filter, the reconstruction's high
//!   frequencies and the vanes' low frequencies, `x = x_rec + LP_fc(x_meas − x_rec)`. The low-passed
//!   difference is the estimated wind (gusts below `fc`, as an angle or a speed) plus the
//!   reconstruction's slowly varying error; above `fc` the reconstruction's error is small and the
//!   vanes' noise is removed. `LP_fc` is a first-order low-pass run forward and backward (zero
//!   phase, `|H|² = 1/(1+(f/fc)²)²`).
//!
//! **The crossover is chosen from the data**, per channel, as the `fc` that minimises the
//! predicted error of the fused signal: `E(fc) = var(HP_fc(d)) − g_HP(fc)·N + g_LP(fc)·N`, with `d`
//! the measured-minus-reconstructed difference, `N` the measured channel's white-noise variance
//! (from third differences, [`super::signal::white_noise_sd`]) and `g` the noise gains of the
//! filters: the first two terms estimate the wind (and reconstruction error) the fused signal
//! loses above `fc`, the third the sensor noise it keeps below. In calm air this picks a low `fc`
//! (the reconstruction is better: on the campaign's calm flight the α error is 0.55 mrad fused
//! against 2.77 mrad for the smoothed vane), in turbulence a high one (gusts carry power at every
//! frequency: 2.3 mrad fused against 17.5 mrad for the reconstruction at σ = 0.3 m/s).
//! A sensor error of the vane (bias, scale, delay) passes into the fused signal at low frequency;
//! finding it is the compatibility check's job, and the report names the air data used.

use super::signal::white_noise_sd;
use crate::io::measured::{MeasuredFlight, Quantity};
use std::collections::BTreeMap;

/// The air data the analysis uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AirDataChoice {
    /// Fused when both the sensors and the reconstruction exist, else whichever exists.
    #[default]
    Auto,
    /// The vanes and the pitot.
    Measured,
    /// The inertial reconstruction (steady air assumed).
    Reconstructed,
    /// The complementary fusion of both.
    Fused,
}

impl AirDataChoice {
    /// Command-line name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Measured => "measured",
            Self::Reconstructed => "reconstructed",
            Self::Fused => "fused",
        }
    }

    /// From a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        [Self::Auto, Self::Measured, Self::Reconstructed, Self::Fused]
            .into_iter()
            .find(|c| c.name() == s)
    }
}

/// Candidate crossovers, Hz.
const CROSSOVERS_HZ: [f64; 9] = [0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0];

/// Zero-phase first-order low-pass (forward and backward), cutoff `fc` Hz.
pub fn low_pass(x: &[f64], fc_hz: f64, h_s: f64) -> Vec<f64> {
    let a = (-2.0 * core::f64::consts::PI * fc_hz * h_s).exp();
    let mut y = x.to_vec();
    for i in 1..y.len() {
        y[i] = a * y[i - 1] + (1.0 - a) * y[i];
    }
    for i in (0..y.len().saturating_sub(1)).rev() {
        y[i] = a * y[i + 1] + (1.0 - a) * y[i];
    }
    y
}

/// [`low_pass`] of every channel of `xs` (each its own length), the same operations in the same
/// order per channel. Four channels advance together: each channel's recursion is a chain of
/// dependent multiply-adds, so one at a time waits on the latency of every step; four
/// independent chains fill those waits.
pub fn low_pass_all(xs: &[Vec<f64>], fc_hz: f64, h_s: f64) -> Vec<Vec<f64>> {
    let a = (-2.0 * core::f64::consts::PI * fc_hz * h_s).exp();
    let mut ys: Vec<Vec<f64>> = xs.to_vec();
    for group in ys.chunks_mut(4) {
        let n = group.first().map_or(0, Vec::len);
        let same_length = group.iter().all(|y| y.len() == n);
        if let ([y0, y1, y2, y3], true) = (&mut *group, same_length) {
            let mut lanes = [y0, y1, y2, y3];
            for i in 1..n {
                for y in lanes.iter_mut() {
                    y[i] = a * y[i - 1] + (1.0 - a) * y[i];
                }
            }
            for i in (0..n.saturating_sub(1)).rev() {
                for y in lanes.iter_mut() {
                    y[i] = a * y[i + 1] + (1.0 - a) * y[i];
                }
            }
        } else {
            for y in group.iter_mut() {
                *y = low_pass(y, fc_hz, h_s);
            }
        }
    }
    ys
}

/// White-noise variance gain of [`low_pass`] (`Σh²` of its impulse response, away from the ends).
fn lp_noise_gain(fc_hz: f64, h_s: f64) -> f64 {
    let n = 4096;
    let mut imp = vec![0.0; n];
    imp[n / 2] = 1.0;
    low_pass(&imp, fc_hz, h_s).iter().map(|v| v * v).sum()
}

fn variance(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n
}

/// The fused channel and its crossover, Hz.
pub fn fuse(measured: &[f64], reconstructed: &[f64], h_s: f64, fc_hz: Option<f64>) -> (Vec<f64>, f64) {
    let d: Vec<f64> = measured.iter().zip(reconstructed).map(|(m, r)| m - r).collect();
    let fc = fc_hz.unwrap_or_else(|| {
        let noise = white_noise_sd(measured).powi(2);
        let nyquist = 0.5 / h_s;
        CROSSOVERS_HZ
            .into_iter()
            .filter(|f| *f < 0.5 * nyquist)
            .map(|fc| {
                let lp = low_pass(&d, fc, h_s);
                let hp: Vec<f64> = d.iter().zip(&lp).map(|(a, b)| a - b).collect();
                let g_lp = lp_noise_gain(fc, h_s);
                // HP = 1 − LP: its white-noise gain is 1 − 2·h_lp(0) + Σh_lp², h_lp(0) ≈ g_lp's
                // peak; bounded below by 0.
                let g_hp = (1.0 - 2.0 * lp_peak(fc, h_s) + g_lp).max(0.0);
                let lost = (variance(&hp) - g_hp * noise).max(0.0);
                (fc, lost + g_lp * noise)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(1.0, |x| x.0)
    });
    let lp = low_pass(&d, fc, h_s);
    (reconstructed.iter().zip(&lp).map(|(r, w)| r + w).collect(), fc)
}

/// The centre tap of [`low_pass`]'s impulse response.
fn lp_peak(fc_hz: f64, h_s: f64) -> f64 {
    let n = 4096;
    let mut imp = vec![0.0; n];
    imp[n / 2] = 1.0;
    low_pass(&imp, fc_hz, h_s)[n / 2]
}

/// The fused air data of every channel both sources have; `cutoffs` fixes the crossovers (the
/// Monte Carlo replicas use the nominal flight's), else they are chosen from the data.
pub fn fuse_all(
    flight: &MeasuredFlight,
    reconstructed: &BTreeMap<Quantity, Vec<f64>>,
    h_s: f64,
    cutoffs: Option<&BTreeMap<Quantity, f64>>,
) -> (BTreeMap<Quantity, Vec<f64>>, BTreeMap<Quantity, f64>) {
    let mut out = BTreeMap::new();
    let mut fcs = BTreeMap::new();
    for (q, rec) in reconstructed {
        match flight.get(*q) {
            Some(m) if m.len() == rec.len() => {
                let (mut x, fc) = fuse(m, rec, h_s, cutoffs.and_then(|c| c.get(q).copied()));
                if flight.log.pieces.len() > 1 {
                    // The crossover is chosen on the whole flight; the filter runs per manoeuvre,
                    // never across a join.
                    x.clear();
                    for p in &flight.log.pieces {
                        x.extend(fuse(&m[p.start..p.end], &rec[p.start..p.end], h_s, Some(fc)).0);
                    }
                }
                out.insert(*q, x);
                fcs.insert(*q, fc);
            }
            _ => {
                out.insert(*q, rec.clone());
            }
        }
    }
    (out, fcs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn rms(a: &[f64], b: &[f64]) -> f64 {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    }

    #[test]
    fn filtering_channels_together_gives_each_channel_alone_to_the_bit() {
        // GIVEN nine noise channels: two groups of four of equal length, and one left over; and
        // a group with one channel shorter than the rest
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let mut draw = |n: usize| -> Vec<f64> { (0..n).map(|_| nd.sample(&mut rng)).collect() };
        let even: Vec<Vec<f64>> = (0..9).map(|_| draw(1000)).collect();
        let uneven = vec![draw(500), draw(499), draw(500), draw(500)];
        for xs in [even, uneven] {
            // WHEN they are low-passed together
            let together = low_pass_all(&xs, 0.6, 0.02);
            // THEN each equals its channel filtered alone, bit for bit
            assert_eq!(together.len(), xs.len());
            for (y, x) in together.iter().zip(&xs) {
                assert_eq!(*y, low_pass(x, 0.6, 0.02));
            }
        }
    }

    #[test]
    fn the_crossover_follows_the_wind() {
        // GIVEN a true signal, a noisy "vane" of it, and a "reconstruction" that misses a wind
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let nrm = Normal::new(0.0, 1.0).unwrap();
        let n = 9000;
        let h = 0.01;
        let truth: Vec<f64> = (0..n).map(|i| 0.05 * (i as f64 * h * 2.0).sin()).collect();
        let vane: Vec<f64> = truth.iter().map(|t| t + 0.0087 * nrm.sample(&mut rng)).collect();
        for (wind_amp, low) in [(0.0, true), (0.02, false)] {
            // a wind with power up to a few hertz (a random walk low-passed at 3 Hz)
            let mut w = 0.0;
            let raw: Vec<f64> = (0..n)
                .map(|_| {
                    w = 0.99 * w + nrm.sample(&mut rng);
                    w
                })
                .collect();
            let wind = low_pass(&raw, 3.0, h);
            let sd = variance(&wind).sqrt().max(1e-12);
            // the reconstruction: the truth less the wind, with its own slow error (the integrated
            // inertial noise: a drift below 0.05 Hz, 2 mrad RMS)
            let white: Vec<f64> = (0..n).map(|_| nrm.sample(&mut rng)).collect();
            let drift = low_pass(&white, 0.05, h);
            let dsd = variance(&drift).sqrt();
            let rec: Vec<f64> = (0..n)
                .map(|i| truth[i] - wind_amp * wind[i] / sd + 2e-3 * drift[i] / dsd)
                .collect();
            // WHEN they are fused
            let (f, fc) = fuse(&vane, &rec, h, None);
            // THEN calm air takes the reconstruction (low crossover), wind the vane (high), and
            // the fused error is below the better source's (the sources' errors sit in different
            // bands, so the fusion beats both)
            assert_eq!(fc < 0.5, low, "wind {wind_amp}: crossover {fc} Hz");
            let e_f = rms(&f, &truth);
            let e_best = rms(&vane, &truth).min(rms(&rec, &truth));
            assert!(e_f < e_best, "fused {e_f} vs best source {e_best}");
        }
    }
}
