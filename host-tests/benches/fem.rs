//! Time per step of the filter error method (seed 001, `aerosid_core::fem`): the 4-state,
//! 11-parameter HFB-320 model on the real flight data (the paper's Euler with the one-step
//! sensitivity, and the book's RK4 with the input interpolated and the propagated sensitivity), the
//! 5-state, 9-parameter longitudinal model of the seed's example on a simulated flight (the
//! paper's filter), and ours on it (8 states with the Dryden gusts, 6 outputs, RK4, propagated: one
//! recursive pass, and one Gauss–Newton pass of the batch method); `f32` and `f64`. Each criterion
//! iteration runs the whole record and reports the time per step.
//!
//! Run: `cargo bench -p aerosid-host-tests --bench fem -- --warm-up-time 1 --measurement-time 3`.

use aerosid::fem_report::{default_hfb320_path, hfb320_filter_with, hfb320_rows, step_data};
use aerosid::table1::{self, Input};
use aerosid_core::fem::models::{Longitudinal, LongitudinalDryden};
use aerosid_core::fem::{bauer_andrisani, FemSettings, FilterError, InputHold, Integrator, Model, Sensitivity};
use aerosid_core::Real;
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

fn hfb320<T: Real>(c: &mut Criterion, name: &str, integrator: Integrator, hold: InputHold, sensitivity: Sensitivity) {
    let rows = hfb320_rows(&default_hfb320_path()).expect("HFB-320 data");
    let fem0 = hfb320_filter_with::<T>(&rows, sensitivity, integrator, hold).expect("filter");
    let data: Vec<_> = rows.windows(2).map(|w| step_data::<T>(&w[0], &w[1])).collect();
    time_record(c, name, fem0, &data);
}

/// The seed's example model in `T` from the simulator's `f64` one.
fn a4d<T: Real>(m: &Longitudinal<f64>) -> Longitudinal<T> {
    let l = T::lit;
    Longitudinal::<T> {
        mass_kg: l(m.mass_kg),
        iy_kgm2: l(m.iy_kgm2),
        wing_area_m2: l(m.wing_area_m2),
        chord_m: l(m.chord_m),
        rho_kgpm3: l(m.rho_kgpm3),
        thrust_n: l(m.thrust_n),
        cd0: l(m.cd0),
        cd_alpha: l(m.cd_alpha),
    }
}

/// The paper's filter on a Table 1 flight: 5 states measured, Euler, one-step sensitivity.
fn longitudinal<T: Real>(c: &mut Criterion, name: &str) {
    let flight = table1::simulate(Input::PAPER, 15.0, 1);
    let q = table1::process_noise();
    let l = T::lit;
    let settings = FemSettings {
        q_x: q.map(l),
        r_x: SMatrix::<T, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| l(table1::NOISE[i] * table1::NOISE[i]))),
        dt_s: l(table1::DT_S),
        integrator: Integrator::Euler,
        input_hold: InputHold::Zero,
        sensitivity: Sensitivity::OneStep,
    };
    let p0 = SVector::<T, 9>::from_fn(|i, _| l(Longitudinal::<f64>::TABLE1_INITIAL[i]));
    let x0 = SVector::<T, 5>::from_fn(|i, _| l(flight.y[0][i]));
    let fem0 = FilterError::new(
        a4d::<T>(&flight.model),
        settings,
        x0,
        settings.r_x,
        p0,
        bauer_andrisani(&p0, l(0.01)),
    )
    .expect("filter");
    let data: Vec<_> = table1::steps::<5>(&flight)
        .iter()
        .map(|(u, un, y)| (u.map(l), un.map(l), y.map(l)))
        .collect();
    time_record(c, name, fem0, &data);
}

/// Ours on a Table 1 flight: the Dryden gust states and the accelerometer (8 states, 6 outputs),
/// RK4, propagated sensitivity — one recursive pass, or one Gauss–Newton pass (`pass = true`).
fn dryden<T: Real>(c: &mut Criterion, name: &str, pass: bool) {
    let flight = table1::simulate(Input::PAPER, 15.0, 1);
    let st = table1::dryden_filter(&flight);
    let l = T::lit;
    let s = st.settings;
    let settings = FemSettings {
        q_x: s.q_x.map(l),
        r_x: s.r_x.map(l),
        dt_s: l(s.dt_s),
        integrator: s.integrator,
        input_hold: s.input_hold,
        sensitivity: s.sensitivity,
    };
    let model = LongitudinalDryden {
        base: a4d::<T>(&flight.model),
        tau_u_per_s: l(st.model.tau_u_per_s),
        tau_w_per_s: l(st.model.tau_w_per_s),
    };
    let (p0, p_p0) = table1::prior();
    let (p0, p_p0) = (p0.map(l), p_p0.map(l));
    let (x0, p_x0) = (st.x0.map(l), st.p_x0.map(l));
    let fem0 = if pass {
        FilterError::new_pass(model, settings, x0, p_x0, p0, p0, p_p0)
    } else {
        FilterError::new(model, settings, x0, p_x0, p0, p_p0)
    }
    .expect("filter");
    let data: Vec<_> = table1::steps::<6>(&flight)
        .iter()
        .map(|(u, un, y)| (u.map(l), un.map(l), y.map(l)))
        .collect();
    time_record::<T, LongitudinalDryden<T>, 8, 1, 6, 9>(c, name, fem0, &data);
}

fn benches(c: &mut Criterion) {
    use InputHold::{Linear, Zero};
    use Integrator::{Euler, Rk4};
    use Sensitivity::{OneStep, Propagated};
    hfb320::<f64>(c, "fem/hfb320/f64/euler_one_step", Euler, Zero, OneStep);
    hfb320::<f64>(c, "fem/hfb320/f64/rk4_linear_propagated", Rk4, Linear, Propagated);
    hfb320::<f32>(c, "fem/hfb320/f32/euler_one_step", Euler, Zero, OneStep);
    hfb320::<f32>(c, "fem/hfb320/f32/rk4_linear_propagated", Rk4, Linear, Propagated);
    longitudinal::<f64>(c, "fem/a4d/f64/paper");
    longitudinal::<f32>(c, "fem/a4d/f32/paper");
    dryden::<f64>(c, "fem/a4d_dryden_az/f64/recursive", false);
    dryden::<f32>(c, "fem/a4d_dryden_az/f32/recursive", false);
    dryden::<f64>(c, "fem/a4d_dryden_az/f64/gauss_newton_pass", true);
}

criterion_group!(fem_benches, benches);
criterion_main!(fem_benches);
