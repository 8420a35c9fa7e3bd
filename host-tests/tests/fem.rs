//! The filter error method (seed 001) in the core: Jacobians, refusal of bad input, and the real
//! HFB-320 flight data against the published filter-error estimates (issue 5).

use aerosid_core::fem::models::{hfb320_idx, Hfb320, Longitudinal};
use aerosid_core::fem::{central_difference, FilterError, Model, Sensitivity};
use aerosid_host::fem_report::{default_hfb320_path, hfb320_filter, step_data, PUBLISHED};
use nalgebra::{SMatrix, SVector};

fn hfb320_rows() -> Vec<[f64; 20]> {
    aerosid_host::fem_report::hfb320_rows(&default_hfb320_path()).expect("HFB-320 data")
}

#[test]
fn hfb320_analytic_parameter_jacobians_match_central_differences() {
    let m = Hfb320::<f64>::default();
    let x = SVector::<f64, 4>::new(106.0, 0.11, 0.10, 0.01);
    let u = SVector::<f64, 2>::new(-0.05, 12_000.0);
    let p = SVector::<f64, 11>::from_column_slice(&PUBLISHED);
    let fd_f: SMatrix<f64, 4, 11> = central_difference(&p, |pp| m.f(&x, &u, pp));
    let fd_h: SMatrix<f64, 7, 11> = central_difference(&p, |pp| m.h(&x, &u, pp));
    // Linear in p: central differences are exact up to rounding (ε^{2/3} relative).
    let ef = (m.df_dp(&x, &u, &p) - fd_f).abs().max() / fd_f.abs().max();
    let eh = (m.dh_dp(&x, &u, &p) - fd_h).abs().max() / fd_h.abs().max();
    assert!(ef < 1e-9 && eh < 1e-9, "∂f/∂p {ef:e}, ∂h/∂p {eh:e}");
}

fn run_hfb320(filter: &mut FilterError<f64, Hfb320<f64>, 4, 2, 7, 11>) {
    for w in hfb320_rows().windows(2) {
        let (u, un, y) = step_data::<f64>(&w[0], &w[1]);
        filter.step(&u, &un, &y).expect("step");
    }
}

#[test]
fn hfb320_flight_data_against_the_published_filter_error_estimates() {
    // GIVEN the real HFB-320 flight (601 samples, 0.1 s, turbulence), the book's model, its noise
    // (Q = F Fᵀ, R) and starting values, the Bauer–Andrisani prior
    // WHEN the filter makes one recursive pass over the data (as on board), Euler prediction,
    // with the paper's one-step sensitivity and with the propagated one
    let mut results = Vec::new();
    for sensitivity in [Sensitivity::OneStep, Sensitivity::Propagated] {
        let mut fem = hfb320_filter::<f64>(&hfb320_rows(), sensitivity).expect("filter");
        run_hfb320(&mut fem);
        let (p, s) = (*fem.parameters(), fem.parameter_sigma());
        println!("{sensitivity:?}: param       ours ± σ              published   |Δ|/σ");
        for i in 0..11 {
            println!(
                "  {:>10} {:>+10.5} ± {:8.5}  {:>+10.5}  {:6.2}",
                hfb320_idx::NAMES[i],
                p[i],
                s[i],
                PUBLISHED[i],
                (p[i] - PUBLISHED[i]).abs() / s[i]
            );
        }
        results.push((p, s));
    }
    // THEN with the propagated sensitivity every parameter but Cmq is within 2σ of the published
    // filter-error value (measured: CLα 4.357 vs 4.328, largest |Δ|/σ 1.97 for Cm0) …
    let (p, s) = results[1];
    for i in (0..11).filter(|&i| hfb320_idx::NAMES[i] != "Cmq") {
        let z = (p[i] - PUBLISHED[i]).abs() / s[i];
        assert!(
            z <= 2.0,
            "{}: {} vs {} ({z:.2}σ)",
            hfb320_idx::NAMES[i],
            p[i],
            PUBLISHED[i]
        );
    }
    // … and Cmq is not: −38.1 ± 0.8 vs −34.7 (4.3σ, 10 %). Why (measured, not tuned away): the plain
    // equation-error fit on these data gives −42.0 (flight-data README), the paper's one-step
    // sensitivity −37.7, the propagated one −38.1, RK4 prediction −36.6; the book's value is a batch
    // maximum-likelihood filter-error estimate whose gain and noise are iterated to convergence over
    // all 60 s, while a one-pass recursive filter with the book's fixed Q and R weights the pitch-rate
    // data like an equation-error method does. Cmq within 15 % is what we claim.
    let cmq = 9;
    assert!(
        ((p[cmq] - PUBLISHED[cmq]) / PUBLISHED[cmq]).abs() < 0.15,
        "Cmq {}",
        p[cmq]
    );
}

#[test]
fn a_non_finite_measurement_is_refused_and_leaves_the_filter_untouched() {
    let mut fem = hfb320_filter::<f64>(&hfb320_rows(), Sensitivity::OneStep).expect("filter");
    let before = fem;
    let u = SVector::<f64, 2>::new(0.0, 10_000.0);
    let mut y = SVector::<f64, 7>::from_column_slice(&[106.0, 0.11, 0.1, 0.0, 0.0, 0.5, -9.8]);
    y[3] = f64::NAN;
    assert!(fem.step(&u, &u, &y).is_err());
    // THEN the state, the parameters and both covariances are bit-identical; only the counter moved
    assert_eq!(fem.state(), before.state());
    assert_eq!(fem.state_covariance(), before.state_covariance());
    assert_eq!(fem.parameters(), before.parameters());
    assert_eq!(fem.parameter_covariance(), before.parameter_covariance());
    assert_eq!(fem.health().refused_input, 1);
    assert_eq!(fem.health().steps, 0);
}

#[test]
fn longitudinal_model_solves_alpha_dot_consistently() {
    // α̇ returned by the model satisfies the implicit lift equation it came from.
    let mut m = Longitudinal::<f64>::a4d();
    m.thrust_n = 8_000.0;
    let x = SVector::<f64, 5>::new(236.0, 0.02, 0.01, 0.03, 10_000.0);
    let u = SVector::<f64, 1>::new(-0.01);
    let p = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
    let ad = m.alpha_dot(&x, &u, &p);
    let (v, alpha, q, theta) = (x[0], x[1], x[2], x[3]);
    let qs = 0.5 * m.rho_kgpm3 * v * v * m.wing_area_m2;
    let lift = qs * (p[0] + p[1] * alpha + p[2] * ad * m.chord_m / (2.0 * v) + p[3] * u[0]);
    let rhs = q - (lift + m.thrust_n * alpha.sin() - m.mass_kg * 9.80665 * (theta - alpha).cos()) / (m.mass_kg * v);
    assert!((ad - rhs).abs() < 1e-12, "{ad} vs {rhs}");
    assert_eq!(m.f(&x, &u, &p)[1], ad);
}

#[test]
fn hfb320_in_f32_agrees_with_f64_within_a_quarter_of_sigma() {
    // GIVEN the same data and settings in f32 (as on the MCU)
    let rows = hfb320_rows();
    let mut fem32 = hfb320_filter::<f32>(&rows, Sensitivity::Propagated).expect("filter");
    // WHEN it runs over the data (every step must be accepted)
    for w in rows.windows(2) {
        let (u, un, y) = step_data::<f32>(&w[0], &w[1]);
        fem32.step(&u, &un, &y).expect("f32 step");
    }
    let mut fem64 = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    run_hfb320(&mut fem64);
    // THEN each parameter differs from the f64 run by less than a quarter of its σ — statistically
    // the same estimate (measured: at most 0.12σ, on CD0 and CDV: the f32 central-difference step
    // in V is ε^{1/3}·106 m/s ≈ 0.5 m/s, and the P_p entries span eight decades)
    let (p64, s64) = (fem64.parameters(), fem64.parameter_sigma());
    let mut worst = 0.0f64;
    for i in 0..11 {
        let d = (fem32.parameters()[i] as f64 - p64[i]).abs() / s64[i];
        println!(
            "{:>10}: f32 {:+.5} f64 {:+.5} ({d:.3}σ)",
            hfb320_idx::NAMES[i],
            fem32.parameters()[i],
            p64[i]
        );
        worst = worst.max(d);
    }
    assert!(worst < 0.25, "worst {worst:.3}σ");
}

#[test]
fn hfb320_report_fits_the_outputs_as_well_as_the_published_model() {
    // GIVEN, WHEN: the `aerosid fem-hfb320` report into a scratch folder
    let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fem-hfb320");
    let (text, figures) = aerosid_host::fem_report::hfb320_report(&default_hfb320_path(), &out).expect("report");
    println!("{text}");
    // THEN both figures exist, and the identified model's open-loop simulation explains every output
    // within 0.01 of R² of the published model's (measured: V 0.528 vs 0.498, q 0.848 vs 0.852,
    // q̇ 0.820 vs 0.824, a_z 0.705 vs 0.700)
    for f in &figures {
        assert!(f.exists(), "{}", f.display());
    }
    let r2: Vec<(f64, f64)> = text
        .lines()
        .skip_while(|l| !l.contains("R² pub."))
        .skip(1)
        .take(7)
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .rev()
                .take(4)
                .filter_map(|t| t.parse().ok())
                .collect();
            (v[2], v[0]) // (R² ours, R² published)
        })
        .collect();
    assert_eq!(r2.len(), 7, "{text}");
    for (ours, published) in r2 {
        assert!(ours >= published - 0.01, "R² {ours} vs published {published}");
    }
}
