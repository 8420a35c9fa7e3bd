//! Channels held between samples: the staircases a logger or a converter leaves when it puts a
//! slow channel on a faster time base by sample-and-hold (a 10 Hz α on a 50 Hz grid repeats every
//! value five times).
//!
//! A staircase used as it is has a rate it does not carry: its jumps are steps of the hold, its
//! derivative is zero between them and a spike at each, and the data-quality assessment would
//! judge it by the grid's rate. So the readers that take a time base as given (the project CSV,
//! column-mapped ASCII and `.mat`) look for held channels, record their true rate in
//! [`crate::measured::LogMeta::logged_rate_hz`] (which [`super::quality`] judges) and replace each staircase by the
//! straight lines between its sample instants — the same linear interpolation the ULog and
//! DataFlash readers use between a topic's own messages — with a warning naming the channel.
//!
//! ## The rule
//! A channel is held when the runs of bit-identical consecutive values are regular:
//! * at least [`MIN_RUNS`] runs inside the record (the first and last runs, cut by the record's
//!   ends, are not counted);
//! * their median length is at least 2 samples;
//! * at least [`REGULAR_SHARE`] of them are within one sample of their mean length `m` (a hold
//!   of ratio 3.3 gives runs of 3 and 4, a hold whose clock drifts against the grid's an
//!   occasional run one longer or shorter).
//!
//! `m` is the mean length of the runs within one sample of the median (the mean, so that a
//! non-integer ratio such as 50 Hz / 15 Hz, runs of 3 and 4, comes out right). The true rate is the
//! number of true samples over the interior runs' span, a run merged from equal neighbours counted
//! as `round(length/m)` samples: the ATTAS record's Mach column, logged at about 8 Hz on the 25 Hz
//! time base, has runs of 3 and 4 and a few merged runs of 6 and 7, which a plain mean would
//! turn into 7.6 Hz.
//!
//! What the rule leaves alone, and why: a real constant (one run) or a channel constant for
//! stretches (a throttle at cruise, a control held between the pulses of a doublet: few runs, of
//! irregular lengths); a quantised channel (an encoder with a coarse step, a throttle in percent)
//! — its runs last as long as the signal stays within one step, so their lengths follow the
//! slope and spread far beyond ±1 sample; a noisy channel at the full rate (runs of 1). A held
//! channel that stays on one value for several of its own samples merges those runs into one
//! longer run; the rule tolerates up to `1 − REGULAR_SHARE` of such runs.
//!
//! ## The interpolation
//! A held value was sampled at (or just before) the first grid instant that shows it, so the
//! sample instants are the starts of the runs: between two of them the channel is the straight
//! line joining their values, after the last one it is held (no extrapolation), and the first,
//! partial run is joined to the second run's start. This also removes the hold's mean lag of half
//! a true sample interval.

use super::measured::{MeasuredFlight, Quantity};

/// The fewest interior runs for a channel to be judged held.
pub const MIN_RUNS: usize = 10;

/// The share of interior runs that must lie within one sample of the mean run length.
pub const REGULAR_SHARE: f64 = 0.9;

/// A channel found held between samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Held {
    /// Mean length of the interior runs, samples of the time base.
    pub run_samples: f64,
    /// The channel's true rate, Hz (the time base's rate over `run_samples`).
    pub rate_hz: f64,
}

/// The runs of bit-identical consecutive values of `x`: `(first sample, length)`.
fn runs(x: &[f64]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for (i, v) in x.iter().enumerate() {
        match out.last_mut() {
            Some((s, len)) if x[*s].to_bits() == v.to_bits() => *len += 1,
            _ => out.push((i, 1)),
        }
    }
    out
}

/// Whether `x` on the uniform-ish time base `t_s` is held between samples ([the rule](self)),
/// and at what rate.
pub fn detect(t_s: &[f64], x: &[f64]) -> Option<Held> {
    let n = t_s.len().min(x.len());
    if n < 2 {
        return None;
    }
    let r = runs(&x[..n]);
    if r.len() < MIN_RUNS + 2 {
        return None;
    }
    let interior = &r[1..r.len() - 1];
    let mut lens: Vec<usize> = interior.iter().map(|(_, l)| *l).collect();
    lens.sort_unstable();
    if lens[lens.len() / 2] < 2 {
        return None;
    }
    // The hold's run length: the mean of the runs within one sample of the median (runs of 3
    // and 4 for a ratio of 3.3; a run merged from equal neighbours left out).
    let med = lens[lens.len() / 2] as f64;
    let near: Vec<usize> = lens
        .iter()
        .copied()
        .filter(|&l| (l as f64 - med).abs() <= 1.0)
        .collect();
    let m = near.iter().sum::<usize>() as f64 / near.len().max(1) as f64;
    let regular = lens.iter().filter(|&&l| (l as f64 - m).abs() <= 1.0).count();
    if (regular as f64) < REGULAR_SHARE * lens.len() as f64 {
        return None;
    }
    // The rate: the true samples over the interior's span, a merged run counted as the samples
    // it holds.
    let samples: f64 = lens.iter().map(|&l| (l as f64 / m).round().max(1.0)).sum();
    let (a, b) = (interior[0].0, r[r.len() - 1].0);
    let span = t_s[b] - t_s[a];
    // (NaN-safe: a NaN span fails the positive test.)
    if span.is_nan() || span <= 0.0 {
        return None;
    }
    Some(Held {
        run_samples: m,
        rate_hz: samples / span,
    })
}

/// The staircase `x` as straight lines between its sample instants (the starts of its runs),
/// held after the last one ([the interpolation](self)).
pub fn interpolate(t_s: &[f64], x: &[f64]) -> Vec<f64> {
    let n = t_s.len().min(x.len());
    let r = runs(&x[..n]);
    // Knots: the second run's start onwards, with the first run anchored at the record's start.
    let knots: Vec<usize> = r.iter().map(|(s, _)| *s).collect();
    let mut out = Vec::with_capacity(n);
    let mut k = 0usize;
    for i in 0..n {
        while k + 1 < knots.len() && knots[k + 1] <= i {
            k += 1;
        }
        let a = knots[k];
        let v = match knots.get(k + 1) {
            Some(&b) if t_s[b] > t_s[a] => x[a] + (t_s[i] - t_s[a]) / (t_s[b] - t_s[a]) * (x[b] - x[a]),
            _ => x[a],
        };
        out.push(v);
    }
    out
}

/// Finds the held channels of `flight` (those without a logged rate of their own already) and
/// replaces each by its interpolation, recording its true rate in the flight's
/// [`super::measured::LogMeta::logged_rate_hz`] and a warning. Returns the channels changed.
pub fn resolve(flight: &mut MeasuredFlight) -> Vec<(Quantity, Held)> {
    let mut found = Vec::new();
    let t = flight.t_s.clone();
    for (q, x) in flight.channels.iter_mut() {
        if flight.log.logged_rate_hz.contains_key(q) {
            continue;
        }
        let Some(h) = detect(&t, x) else { continue };
        *x = interpolate(&t, x);
        flight.log.logged_rate_hz.insert(*q, h.rate_hz);
        flight.log.warnings.push(format!(
            "`{q}` is held between samples (runs of {:.2} identical values on the time base): logged at {:.2} Hz; used at that rate, linearly interpolated between its sample instants (the start of each run) instead of as a staircase",
            h.run_samples, h.rate_hz
        ));
        found.push((*q, h));
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const GRID_HZ: f64 = 50.0;

    fn grid(n: usize) -> Vec<f64> {
        (0..n).map(|i| i as f64 / GRID_HZ).collect()
    }

    /// A band-limited random signal: white noise through a first-order low-pass (seeded).
    fn signal(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut y = 0.0;
        (0..n)
            .map(|_| {
                y += 0.2 * (rng.random_range(-1.0..1.0) - y);
                0.05 + 0.1 * y
            })
            .collect()
    }

    /// Sample-and-hold of `x` (on the grid) at `rate_hz`, the samples taken at `phase_s` after
    /// each multiple of the true interval.
    fn hold(x: &[f64], rate_hz: f64, phase_s: f64) -> Vec<f64> {
        let t = grid(x.len());
        let mut out = Vec::with_capacity(x.len());
        let mut last = x[0];
        let mut next = phase_s;
        for (i, ti) in t.iter().enumerate() {
            if *ti + 1e-12 >= next {
                last = x[i];
                next += 1.0 / rate_hz;
            }
            out.push(last);
        }
        out
    }

    #[test]
    fn held_channels_are_found_at_their_true_rate() {
        let n = 3000;
        let t = grid(n);
        // Integer and non-integer ratios, each at two phases; the rate to 1 % (one run more or
        // less over the record's ≥ 150 runs is under 1 %).
        for (seed, rate) in [(1, 10.0), (2, 25.0), (3, 15.0), (4, 5.0), (5, 12.5)] {
            for phase in [0.0, 0.013] {
                let x = hold(&signal(n, seed), rate, phase);
                let h = detect(&t, &x).unwrap_or_else(|| panic!("{rate} Hz hold not found"));
                assert!(
                    (h.rate_hz - rate).abs() <= 0.01 * rate,
                    "{rate} Hz hold found at {} Hz",
                    h.rate_hz
                );
            }
        }
    }

    #[test]
    fn full_rate_constant_quantised_and_stepped_channels_are_not_held() {
        let n = 3000;
        let t = grid(n);
        // Noisy, at the full rate.
        assert_eq!(detect(&t, &signal(n, 7)), None);
        // A real constant.
        assert_eq!(detect(&t, &vec![1.225; n]), None);
        // A quantised slow sine (0.01 steps, 0.2 Hz, amplitude 0.1): runs follow the slope.
        let q: Vec<f64> = t
            .iter()
            .map(|ti| (0.1 * (2.0 * std::f64::consts::PI * 0.2 * ti).sin() / 0.01).round() * 0.01)
            .collect();
        assert_eq!(detect(&t, &q), None);
        // A quantised random signal (0.005 steps) at the full rate.
        let qr: Vec<f64> = signal(n, 8).iter().map(|v| (v / 0.005).round() * 0.005).collect();
        assert_eq!(detect(&t, &qr), None);
        // A control of doublets and 3-2-1-1s: long constant stretches of different lengths.
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut steps = Vec::with_capacity(n);
        while steps.len() < n {
            let len = rng.random_range(10..150);
            let v = rng.random_range(-0.1..0.1);
            steps.extend(std::iter::repeat_n(v, len));
        }
        steps.truncate(n);
        assert_eq!(detect(&t, &steps), None);
    }

    #[test]
    fn a_held_ramp_interpolates_back_to_the_ramp() {
        let n = 500;
        let t = grid(n);
        let ramp: Vec<f64> = t.iter().map(|ti| 0.3 * ti - 0.1).collect();
        let x = hold(&ramp, 10.0, 0.0);
        let y = interpolate(&t, &x);
        // Between the first and the last sample instant the line through the samples is the ramp
        // (to rounding); after the last instant it is held.
        let last = (0..n).rev().find(|&i| i % 5 == 0).expect("a knot");
        for i in 0..=last {
            assert!((y[i] - ramp[i]).abs() < 1e-12, "sample {i}: {} vs {}", y[i], ramp[i]);
        }
        assert!(y[last..].iter().all(|v| *v == ramp[last]));
    }

    #[test]
    fn resolve_records_the_rate_and_replaces_the_staircase() {
        let n = 2000;
        let t = grid(n);
        let alpha = hold(&signal(n, 11), 10.0, 0.0);
        let q = signal(n, 12);
        let mut f = MeasuredFlight {
            source: "test".into(),
            t_s: t.clone(),
            channels: [(Quantity::Alpha, alpha.clone()), (Quantity::PitchRate, q.clone())].into(),
            aircraft: super::super::placeholder_aircraft(),
            log: Default::default(),
        };
        let found = resolve(&mut f);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].0, Quantity::Alpha);
        let r = f.log.logged_rate_hz[&Quantity::Alpha];
        assert!((r - 10.0).abs() < 0.1, "{r}");
        assert!(!f.log.logged_rate_hz.contains_key(&Quantity::PitchRate));
        assert_eq!(f.channels[&Quantity::PitchRate], q);
        assert_eq!(f.channels[&Quantity::Alpha], interpolate(&t, &alpha));
        assert!(f.log.warnings.iter().any(|w| w.contains("`alpha` is held")));
    }
}
