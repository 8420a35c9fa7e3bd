//! Time per step of the filter error method (seed 001, `aerosid_core::fem`): the 4-state,
//! 11-parameter HFB-320 model on the real flight data, and the 5-state, 9-parameter longitudinal
//! model of the seed's example on a simulated flight; `f32` and `f64`, Euler prediction, one-step
//! and propagated sensitivity. Each criterion iteration runs the whole record and reports the time
//! per step.
//!
//! Run: `cargo bench -p aerosid-host --bench fem -- --warm-up-time 1 --measurement-time 3`.

use aerosid_core::fem::models::Longitudinal;
use aerosid_core::fem::{bauer_andrisani, FemSettings, FilterError, InputHold, Integrator, Model, Sensitivity};
use aerosid_core::Real;
use aerosid_host::fem_report::{default_hfb320_path, hfb320_filter, hfb320_rows, step_data};
use aerosid_host::table1::{self, Input};
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{SMatrix, SVector};
use std::hint::black_box;
use std::time::Instant;

/// Times `fem0` over `data` (`(u, u_next, y_next)` per step): each iteration runs a fresh copy over
/// the whole record and reports the time per step.
#[allow(clippy::type_complexity)]
fn time_record<T, M, const NX: usize, const NU: usize, const NY: usize, const NP: usize>(
    c: &mut Criterion,
    name: &str,
    fem0: FilterError<T, M, NX, NU, NY, NP>,
    data: &[(SVector<T, NU>, SVector<T, NU>, SVector<T, NY>)],
) where
    T: Real,
    M: Model<T, NX, NU, NY, NP> + Copy,
{
    c.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let mut fem = fem0;
                for (u, un, y) in data {
                    let _ = black_box(fem.step(u, un, y));
                }
                black_box(fem.parameters());
            }
            start.elapsed() / data.len() as u32
        })
    });
}

fn hfb320<T: Real>(c: &mut Criterion, name: &str, sensitivity: Sensitivity) {
    let rows = hfb320_rows(&default_hfb320_path()).expect("HFB-320 data");
    let fem0 = hfb320_filter::<T>(&rows, sensitivity).expect("filter");
    let data: Vec<_> = rows.windows(2).map(|w| step_data::<T>(&w[0], &w[1])).collect();
    time_record(c, name, fem0, &data);
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
        input_hold: InputHold::Zero,
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
    time_record(c, name, fem0, &data);
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
