//! Time per step of the filter error method (seed 001, `aerosid_core::fem`): the 4-state,
//! 11-parameter HFB-320 model on the real flight data, and the 5-state, 9-parameter longitudinal
//! model of the seed's example on a simulated flight; `f32` and `f64`, Euler prediction, one-step
//! and propagated sensitivity. Each criterion iteration runs the whole record and reports the time
//! per step.
//!
//! Run: `cargo bench -p aerosid-host --bench fem -- --warm-up-time 1 --measurement-time 3`.

use aerosid_core::fem::models::{Hfb320, Longitudinal};
use aerosid_core::fem::{bauer_andrisani, FemSettings, FilterError, Integrator, Sensitivity};
use aerosid_core::Real;
use aerosid_host::table1::{self, Input};
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{SMatrix, SVector};
use std::hint::black_box;
use std::time::Instant;

fn hfb320_rows() -> Vec<[f64; 20]> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/flight/hfb320_1_10.asc");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().expect("number")).collect();
            v.try_into().expect("20 columns")
        })
        .collect()
}

const START: [f64; 11] = [
    5.67516e-3, 7.72612e-3, 0.674256, -0.318267, 0.260317, 5.37576, 4.98218e-2, 1.89182e-2, -0.498586, -25.8439,
    -0.990687,
];

fn hfb320<T: Real>(c: &mut Criterion, name: &str, sensitivity: Sensitivity) {
    let rows = hfb320_rows();
    let l = T::lit;
    let f = [0.358553, 2.42099e-3, 4.47607e-4, 1.73778e-3];
    let r = [1.7587e-2, 9.902e-7, 1.977e-7, 3.384e-7, 3.168e-5, 4.191e-4, 2.020e-2];
    let settings = FemSettings {
        q_x: SMatrix::<T, 4, 4>::from_diagonal(&SVector::from_fn(|i, _| l(f[i] * f[i]))),
        r_x: SMatrix::<T, 7, 7>::from_diagonal(&SVector::from_fn(|i, _| l(r[i]))),
        dt_s: l(0.1),
        integrator: Integrator::Euler,
        sensitivity,
    };
    let x0 = SVector::<T, 4>::from_fn(|i, _| l(rows[0][4 + i]));
    let p_x0 = SMatrix::<T, 4, 4>::from_diagonal(&SVector::from_fn(|i, _| l(r[i])));
    let p0 = SVector::<T, 11>::from_fn(|i, _| l(START[i]));
    let fem0 = FilterError::new(
        Hfb320::<T>::default(),
        settings,
        x0,
        p_x0,
        p0,
        bauer_andrisani(&p0, l(0.05)),
    )
    .expect("filter");
    let data: Vec<_> = rows
        .windows(2)
        .map(|w| {
            (
                SVector::<T, 2>::new(l(w[0][1]), l(w[0][3])),
                SVector::<T, 2>::new(l(w[1][1]), l(w[1][3])),
                SVector::<T, 7>::from_fn(|i, _| l(w[1][4 + i])),
            )
        })
        .collect();
    c.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let mut fem = fem0;
                for (u, un, y) in &data {
                    let _ = black_box(fem.step(u, un, y));
                }
                black_box(fem.parameters());
            }
            start.elapsed() / data.len() as u32
        })
    });
}

fn longitudinal<T: Real>(c: &mut Criterion, name: &str, sensitivity: Sensitivity) {
    let flight = table1::simulate(Input::PAPER, 15.0, 1);
    let q = table1::process_noise();
    let l = T::lit;
    let settings = FemSettings {
        q_x: q.map(l),
        r_x: SMatrix::<T, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| l(table1::NOISE[i] * table1::NOISE[i]))),
        dt_s: l(table1::DT_S),
        integrator: Integrator::Euler,
        sensitivity,
    };
    let m = flight.model;
    let model = Longitudinal::<T> {
        mass_kg: l(m.mass_kg),
        iy_kgm2: l(m.iy_kgm2),
        wing_area_m2: l(m.wing_area_m2),
        chord_m: l(m.chord_m),
        rho_kgpm3: l(m.rho_kgpm3),
        thrust_n: l(m.thrust_n),
        cd0: l(m.cd0),
        cd_alpha: l(m.cd_alpha),
    };
    let p0 = SVector::<T, 9>::from_fn(|i, _| l(Longitudinal::<f64>::TABLE1_INITIAL[i]));
    let x0 = SVector::<T, 5>::from_fn(|i, _| l(flight.y[0][i]));
    let fem0 = FilterError::new(model, settings, x0, settings.r_x, p0, bauer_andrisani(&p0, l(0.01))).expect("filter");
    let data: Vec<_> = (0..flight.y.len() - 1)
        .map(|k| {
            (
                SVector::<T, 1>::new(l(flight.u[k])),
                SVector::<T, 1>::new(l(flight.u[k + 1])),
                SVector::<T, 5>::from_fn(|i, _| l(flight.y[k + 1][i])),
            )
        })
        .collect();
    c.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let mut fem = fem0;
                for (u, un, y) in &data {
                    let _ = black_box(fem.step(u, un, y));
                }
                black_box(fem.parameters());
            }
            start.elapsed() / data.len() as u32
        })
    });
}

fn benches(c: &mut Criterion) {
    hfb320::<f64>(c, "fem/hfb320/f64/one_step", Sensitivity::OneStep);
    hfb320::<f64>(c, "fem/hfb320/f64/propagated", Sensitivity::Propagated);
    hfb320::<f32>(c, "fem/hfb320/f32/propagated", Sensitivity::Propagated);
    longitudinal::<f64>(c, "fem/a4d/f64/one_step", Sensitivity::OneStep);
    longitudinal::<f32>(c, "fem/a4d/f32/one_step", Sensitivity::OneStep);
}

criterion_group!(fem_benches, benches);
criterion_main!(fem_benches);
