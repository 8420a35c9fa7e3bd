//! Wall time of the host Monte Carlo of seed 000, Section V (eq. 34–41; `aerosid::mc`): 10⁶
//! draws per coefficient — the paper's `M > 10⁶` and `McSettings::default()` — on a rayon pool of
//! two threads (the CI machine's cores), for each of the six synthesised coefficients (eq. 1–2
//! solved for it, `mc::synth`) of the default `skywalker_2013_mod` problem. One criterion
//! iteration is one whole `mc::run`: draws, eq. 35's errors and the two order statistics of eq. 40.
//!
//! Run: `cargo bench -p aerosid-host-tests --bench mc -- --warm-up-time 1 --measurement-time 10`
//! (criterion takes at least 10 iterations, so each coefficient runs ≥ 10·10⁶ draws).

use aerosid::mc::synth::{self, Airframe, Coefficient, Sensors};
use aerosid::mc::{self, McSettings};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

/// Draws per coefficient (the paper's `M > 10⁶`; `McSettings::default().draws`).
const DRAWS: usize = 1_000_000;
/// Threads of the rayon pool: the two cores the benchmark's budget is stated for.
const THREADS: usize = 2;

fn monte_carlo(c: &mut Criterion) {
    let airframe = Airframe::skywalker_2013_mod();
    let problem = synth::default_problem(&Sensors::default());
    let settings = McSettings {
        draws: DRAWS,
        progress: false,
        ..McSettings::default()
    };
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(THREADS).build() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("mc bench: cannot build a rayon pool of {THREADS} threads: {e}");
            return;
        }
    };
    let mut g = c.benchmark_group("monte_carlo_1e6_draws_2_threads");
    g.sample_size(10);
    for coefficient in Coefficient::ALL {
        g.bench_function(coefficient.name(), |b| {
            b.iter(|| {
                pool.install(|| {
                    let f = |x: &[f64]| synth::synthesise(&airframe, coefficient, x);
                    black_box(mc::run(&problem, &settings, f))
                })
            })
        });
    }
    g.finish();
}

criterion_group!(benches, monte_carlo);
criterion_main!(benches);
