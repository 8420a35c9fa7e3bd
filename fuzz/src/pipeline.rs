//! Fuzz target `pipeline`: the on-board six-coefficient pipeline fed arbitrary
//! [`SensorSample`]s.
//!
//! ## Input
//! * Byte 0: bit 0 the scalar — `f32` is exactly the firmware's pipeline
//!   ([`aerosid_core::aero::onboard::pipeline`]), `f64` the same configuration in `f64`; bytes
//!   1–8 the seed of the generator of flight-like signals (every channel a trim value plus two
//!   sinusoids of random frequency and phase plus noise, so coefficients get excited).
//! * Then operations until the input ends or [`MAX_STEPS`] samples: up to 256 generated samples;
//!   one sample with the fields of a 20-bit mask replaced by adversarial values
//!   ([`crate::input::scalar`], scaled to the field); the last sample repeated up to 256 times
//!   (time stamps advancing or frozen); one field frozen at its current value (a stuck sensor) for
//!   the next samples; a timing fault (`dt_s` 0, doubled, negative, NaN, huge; time going back).
//!
//! ## Invariants (every sample)
//! * A coefficient refused for any reason (warm-up, channels, its estimator) has its estimator
//!   bit-identical to before the sample, on every sample ([`crate::snapshot`], which also tells
//!   `-0.0` from `0.0`; measured: 16 % of the run time over the saved corpus, against comparing only
//!   every 8th sample); an estimator refusal is only ever `NumericalFault` (the channel checks must
//!   keep NaN, ±∞ and out-of-range values from it).
//! * An updated coefficient's estimator passes [`crate::gtls::check_estimator`].
//! * A synthesis, when there is one, is finite; the whole pipeline state (delay line,
//!   differentiator, six estimators, counters) is finite (checked every 32 samples and at the end).
//! * `Health::samples` is the number of samples, and each coefficient's counters add up to it.

use crate::assert_state_finite;
use crate::gtls::{assert_unchanged, check_estimator, lambda_range, LambdaRange};
use crate::input::{scalar, Gen, Input};
use aerosid_core::aero::model::idx;
use aerosid_core::aero::{onboard, AeroModels, Airframe, Pipeline, Refusal, SensorSample, SAMPLE_FIELDS};
use aerosid_core::{Error, Real};
use std::fmt::Debug;

/// Most samples per input.
pub const MAX_STEPS: usize = 1500;

/// Trim values of the 20 fields (CSV order), and the amplitude of their excitation.
const TRIM: [f64; SAMPLE_FIELDS] = [
    0.0, 0.01, 0.4, 0.0, -9.7, 0.0, 0.0, 0.0, 15.0, 0.05, 0.0, 0.0, 0.05, 0.0, 600.0, -0.05, 0.0, 0.0, 0.5, 1.2,
];
const AMPLITUDE: [f64; SAMPLE_FIELDS] = [
    0.0, 0.0, 1.0, 1.0, 3.0, 0.5, 0.5, 0.3, 2.0, 0.05, 0.04, 0.2, 0.05, 0.1, 50.0, 0.1, 0.1, 0.1, 0.1, 0.01,
];
/// White noise of each field (1 σ).
const NOISE: [f64; SAMPLE_FIELDS] = [
    0.0, 0.0, 0.05, 0.05, 0.05, 0.002, 0.002, 0.002, 0.1, 0.005, 0.005, 0.001, 0.001, 0.001, 2.0, 0.001, 0.001, 0.001,
    0.001, 0.0005,
];

/// The fuzz entry point.
pub fn run(data: &[u8]) {
    let mut inp = Input::new(data);
    let setup = inp.u8();
    if setup & 1 == 0 {
        match onboard::pipeline::<f32>() {
            Ok(p) => fuzz(p, &mut inp),
            Err(e) => panic!("on-board pipeline refused: {e:?}"),
        }
    } else {
        let p = Pipeline::<f64>::new(
            Airframe::skywalker_2013_mod(),
            AeroModels::with_sigma_eps(onboard::SIGMA_EPS),
            onboard::settings(),
        );
        match p {
            Ok(p) => fuzz(p, &mut inp),
            Err(e) => panic!("f64 on-board pipeline refused: {e:?}"),
        }
    }
}

struct Signals {
    gen: Gen,
    freq: [[f64; 2]; SAMPLE_FIELDS],
    phase: [[f64; 2]; SAMPLE_FIELDS],
    k: u64,
    t_s: f64,
    dt_s: f64,
    frozen: [Option<f64>; SAMPLE_FIELDS],
    frozen_left: usize,
}

impl Signals {
    fn new(seed: u64) -> Self {
        let mut gen = Gen::new(seed);
        let freq = core::array::from_fn(|_| [0.1 + 1.5 * (gen.sym() + 1.0), 0.05 + 0.2 * (gen.sym() + 1.0)]);
        let phase = core::array::from_fn(|_| [3.2 * gen.sym(), 3.2 * gen.sym()]);
        Self {
            gen,
            freq,
            phase,
            k: 0,
            t_s: 0.0,
            dt_s: 0.01,
            frozen: [None; SAMPLE_FIELDS],
            frozen_left: 0,
        }
    }

    fn next<T: Real>(&mut self) -> SensorSample<T> {
        self.k += 1;
        self.t_s += self.dt_s;
        let t = self.t_s;
        let mut f = [0.0f64; SAMPLE_FIELDS];
        for i in 0..SAMPLE_FIELDS {
            let [f1, f2] = self.freq[i];
            let [p1, p2] = self.phase[i];
            let tau = core::f64::consts::TAU;
            f[i] = TRIM[i]
                + AMPLITUDE[i] * (0.7 * (tau * f1 * t + p1).sin() + 0.3 * (tau * f2 * t + p2).sin())
                + NOISE[i] * self.gen.normal();
        }
        f[0] = t;
        f[1] = self.dt_s;
        if self.frozen_left > 0 {
            self.frozen_left -= 1;
            for (v, fz) in f.iter_mut().zip(self.frozen.iter()) {
                if let Some(c) = fz {
                    *v = *c;
                }
            }
        } else {
            self.frozen = [None; SAMPLE_FIELDS];
        }
        SensorSample::from_fields(&f.map(T::lit))
    }
}

struct Counts {
    updates: [u64; idx::COUNT],
    samples: u64,
}

fn fuzz<T: Real + Debug>(p: Pipeline<T>, inp: &mut Input<'_>) {
    let mut feed = Feed::new(p, inp.u64());
    while !inp.is_empty() && (feed.counts.samples as usize) < MAX_STEPS {
        let op = inp.u8();
        let budget = MAX_STEPS - feed.counts.samples as usize;
        match op % 8 {
            0..=2 => {
                let n = (usize::from(inp.u8()) + 1).min(budget);
                feed.ordinary(n);
            }
            3 | 4 => feed.special_values(inp),
            5 => {
                let n = (usize::from(inp.u8()) + 1).min(budget);
                feed.repeat_last(n, op & 0x80 != 0);
            }
            6 => {
                let field = usize::from(inp.u8()) % SAMPLE_FIELDS;
                feed.sig.frozen[field] = Some(feed.last.to_fields()[field].to_f64());
                feed.sig.frozen_left = usize::from(inp.u16() % 1024);
            }
            _ => feed.timing_fault(inp),
        }
    }
    assert_state_finite("pipeline at the end", &feed.p);
}

/// The pipeline being fed, the signals it is fed from and what the checks count.
struct Feed<T: Real> {
    p: Pipeline<T>,
    sig: Signals,
    lambda: LambdaRange<T>,
    counts: Counts,
    /// The last sample fed.
    last: SensorSample<T>,
}

impl<T: Real + Debug> Feed<T> {
    /// `p` fed from signals of `seed` (the first sample drawn as the last one).
    fn new(p: Pipeline<T>, seed: u64) -> Self {
        let mut sig = Signals::new(seed);
        let lambda = lambda_range(&p.settings().gtls.forgetting);
        let last = sig.next();
        Self {
            p,
            sig,
            lambda,
            counts: Counts {
                updates: [0; idx::COUNT],
                samples: 0,
            },
            last,
        }
    }

    fn step(&mut self, s: SensorSample<T>) {
        self.last = s;
        step(&mut self.p, &self.last, self.lambda, &mut self.counts);
    }

    /// `n` ordinary samples.
    fn ordinary(&mut self, n: usize) {
        for _ in 0..n {
            let s = self.sig.next();
            self.step(s);
        }
    }

    /// An ordinary sample with the fields a mask from the input names replaced by adversarial
    /// values ([`scalar`]).
    fn special_values(&mut self, inp: &mut Input<'_>) {
        let mask = inp.u32() & ((1 << SAMPLE_FIELDS) - 1);
        let mut f = self.sig.next::<T>().to_fields();
        for (i, v) in f.iter_mut().enumerate() {
            if mask & (1 << i) != 0 {
                let scale = (TRIM[i].abs() + AMPLITUDE[i]).max(1e-3);
                *v = scalar::<T>(inp, scale, 1e6).0;
            }
        }
        self.step(SensorSample::from_fields(&f));
    }

    /// The last sample `n` times, with the clock going on unless `frozen_time`.
    fn repeat_last(&mut self, n: usize, frozen_time: bool) {
        for _ in 0..n {
            let mut s = self.last;
            if !frozen_time {
                let t = self.sig.next::<T>();
                s.t_s = t.t_s;
                s.dt_s = t.dt_s;
            }
            self.step(s);
        }
    }

    /// An ordinary sample with a timing fault the input chooses: `dt` zero, doubled, negative,
    /// NaN or huge, or time going back.
    fn timing_fault(&mut self, inp: &mut Input<'_>) {
        let mut s = self.sig.next::<T>();
        match inp.u8() % 6 {
            0 => s.dt_s = T::zero(),
            1 => s.dt_s *= T::lit(2.0),
            2 => s.dt_s = -s.dt_s,
            3 => s.dt_s = T::lit(f64::NAN),
            4 => s.dt_s = T::lit(1e6),
            _ => {
                s.t_s -= T::lit(f64::from(inp.u8()));
            }
        }
        self.step(s);
    }
}

fn unchanged<E: Debug>(before: &E, after: &E) {
    assert_unchanged(before, after);
}

fn step<T: Real + Debug>(p: &mut Pipeline<T>, s: &SensorSample<T>, lambda: LambdaRange<T>, c: &mut Counts) {
    let before = *p;
    let out = p.process(s);
    c.samples += 1;
    if let Some(y) = &out.synthesis {
        assert!(
            y.coefficients.as_array().iter().all(|v| v.finite()),
            "non-finite synthesis {:?} of {s:?}",
            y.coefficients
        );
    }
    for i in 0..idx::COUNT {
        match out.status[i] {
            Ok(_) => {
                c.updates[i] += 1;
                let u = c.updates[i];
                match i {
                    idx::LIFT => check_estimator(p.lift(), lambda, u),
                    idx::DRAG => check_estimator(p.drag(), lambda, u),
                    idx::SIDE => check_estimator(p.side(), lambda, u),
                    idx::ROLL => check_estimator(p.roll(), lambda, u),
                    idx::PITCH => check_estimator(p.pitch(), lambda, u),
                    _ => check_estimator(p.yaw(), lambda, u),
                }
            }
            Err(r) => {
                if let Refusal::Estimator(e) = r {
                    assert_eq!(
                        e,
                        Error::NumericalFault,
                        "coefficient {i}: the estimator saw a bad input: {s:?}"
                    );
                }
                // The whole bit pattern (`Debug` text: every field, also the sign of zero).
                match i {
                    idx::LIFT => unchanged(before.lift(), p.lift()),
                    idx::DRAG => unchanged(before.drag(), p.drag()),
                    idx::SIDE => unchanged(before.side(), p.side()),
                    idx::ROLL => unchanged(before.roll(), p.roll()),
                    idx::PITCH => unchanged(before.pitch(), p.pitch()),
                    _ => unchanged(before.yaw(), p.yaw()),
                }
            }
        }
    }
    let h = p.health();
    assert_eq!(u64::from(h.samples), c.samples, "Health::samples");
    for (i, ch) in h.coefficients.iter().enumerate() {
        let sum = u64::from(ch.updates)
            + u64::from(ch.refused_channels)
            + u64::from(ch.refused_warmup)
            + u64::from(ch.refused_estimator);
        assert_eq!(sum, c.samples, "coefficient {i}: counters {ch:?} do not add up");
        assert_eq!(u64::from(ch.updates), c.updates[i], "coefficient {i}: updates");
    }
    if c.samples.is_multiple_of(32) {
        assert_state_finite("pipeline", p);
    }
}
