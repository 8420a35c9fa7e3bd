//! The filter error method on the real HFB-320 flight: the identified model beside the
//! published filter-error values, the parameter time histories with ±σ, and the measured outputs
//! beside the identified model's simulation with the residuals. `aerosid fem-hfb320 [--out DIR]`.

use crate::plot::{Band, Colour, Figure, Line, Panel, PlotError};
use aerosid_core::fem::models::{hfb320_idx, Hfb320};
use aerosid_core::fem::{
    bauer_andrisani, integrate, FemSettings, FilterError, InputHold, Integrator, Model, Sensitivity,
};
use aerosid_core::Real;
use nalgebra::{SMatrix, SVector};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The book's filter-error estimates (flight-data README §1).
pub const PUBLISHED: [f64; 11] = [
    0.122688, -0.0644969, 0.320055, -0.0929113, 0.148726, 4.32785, 0.111905, 0.00395154, -0.967854, -34.7098, -1.52913,
];
/// The book's starting values.
pub const START: [f64; 11] = [
    5.67516e-3, 7.72612e-3, 0.674256, -0.318267, 0.260317, 5.37576, 4.98218e-2, 1.89182e-2, -0.498586, -25.8439,
    -0.990687,
];
/// The book's process-noise distribution `F` (`Q = F Fᵀ`) for `V, α, θ, q`.
pub const PROCESS_F: [f64; 4] = [0.358553, 2.42099e-3, 4.47607e-4, 1.73778e-3];
/// The book's measurement-noise variances for `V, α, θ, q, q̇, a_x, a_z`.
pub const R_DIAG: [f64; 7] = [1.7587e-2, 9.902e-7, 1.977e-7, 3.384e-7, 3.168e-5, 4.191e-4, 2.020e-2];
/// Output names and units.
pub const OUTPUTS: [&str; 7] = [
    "V (m/s)",
    "α (rad)",
    "θ (rad)",
    "q (rad/s)",
    "q̇ (rad/s²)",
    "a_x (m/s²)",
    "a_z (m/s²)",
];

/// The HFB-320 flight file (`tool/data/flight/hfb320_1_10.asc`): rows of 20 numbers.
pub fn hfb320_rows(path: &Path) -> Result<Vec<[f64; 20]>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let mut row = [0.0; 20];
        let mut n = 0;
        for (col, tok) in line.split_whitespace().enumerate() {
            if col >= 20 {
                return Err(format!(
                    "{}:{}:{}: more than 20 columns",
                    path.display(),
                    i + 1,
                    col + 1
                ));
            }
            row[col] = tok
                .parse()
                .map_err(|e| format!("{}:{}:{}: `{tok}`: {e}", path.display(), i + 1, col + 1))?;
            n += 1;
        }
        if n != 20 {
            return Err(format!("{}:{}: {n} columns, expected 20", path.display(), i + 1));
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The environment variable naming another directory of the flight-test data than the vendored
/// copy (the tests, `aerosid fem-hfb320` and `aerosid gaps-bench` read the data from there).
pub const FLIGHT_DATA_ENV: &str = "AEROSID_FLIGHT_DATA";

/// The vendored flight-test data (HFB-320, ATTAS, Twin Otter; provenance and licence in its
/// `README.md`), inside this crate so that a bare clone runs every test.
pub const VENDORED_FLIGHT_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../tool/data/flight");

/// The directory of the flight-test data: `$AEROSID_FLIGHT_DATA` when set (and not empty), else
/// the vendored copy [`VENDORED_FLIGHT_DATA`].
pub fn flight_data_dir() -> PathBuf {
    match std::env::var_os(FLIGHT_DATA_ENV) {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => PathBuf::from(VENDORED_FLIGHT_DATA),
    }
}

/// The default location of the HFB-320 file: `hfb320_1_10.asc` in [`flight_data_dir`].
pub fn default_hfb320_path() -> PathBuf {
    flight_data_dir().join("hfb320_1_10.asc")
}

/// The prediction of [`hfb320_filter`]: the book's (`ruku4` of FVSysID: RK4 with the input
/// averaged between the samples at the half steps).
pub const HFB320_INTEGRATOR: (Integrator, InputHold) = (Integrator::Rk4, InputHold::Linear);

/// The filter over the HFB-320 model with the book's noise, starting values and the
/// Bauer–Andrisani prior (σ floor 0.05), in `f32` or `f64`, predicting as the book does
/// ([`HFB320_INTEGRATOR`]).
pub fn hfb320_filter<T: Real>(
    rows: &[[f64; 20]],
    sensitivity: Sensitivity,
) -> Result<FilterError<T, Hfb320<T>, 4, 2, 7, 11>, String> {
    hfb320_filter_with(rows, sensitivity, HFB320_INTEGRATOR.0, HFB320_INTEGRATOR.1)
}

/// [`hfb320_filter`] with another prediction: the integrator and how the input is held.
pub fn hfb320_filter_with<T: Real>(
    rows: &[[f64; 20]],
    sensitivity: Sensitivity,
    integrator: Integrator,
    input_hold: InputHold,
) -> Result<FilterError<T, Hfb320<T>, 4, 2, 7, 11>, String> {
    let l = T::lit;
    let settings = FemSettings {
        q_x: SMatrix::<T, 4, 4>::from_diagonal(&SVector::from_fn(|i, _| l(PROCESS_F[i] * PROCESS_F[i]))),
        r_x: SMatrix::<T, 7, 7>::from_diagonal(&SVector::from_fn(|i, _| l(R_DIAG[i]))),
        dt_s: l(0.1),
        integrator,
        input_hold,
        sensitivity,
    };
    let r0 = rows.first().ok_or("no data")?;
    let x0 = SVector::<T, 4>::from_fn(|i, _| l(r0[4 + i]));
    let p_x0 = SMatrix::<T, 4, 4>::from_diagonal(&SVector::from_fn(|i, _| l(R_DIAG[i])));
    let p0 = SVector::<T, 11>::from_fn(|i, _| l(START[i]));
    FilterError::new(Hfb320::default(), settings, x0, p_x0, p0, bauer_andrisani(&p0, l(0.05)))
        .map_err(|e| format!("{e:?}"))
}

/// One step's data: `(u(t), u(t+Δt), y(t+Δt))` from two consecutive rows.
#[allow(clippy::type_complexity)]
pub fn step_data<T: Real>(a: &[f64; 20], b: &[f64; 20]) -> (SVector<T, 2>, SVector<T, 2>, SVector<T, 7>) {
    let l = T::lit;
    (
        SVector::<T, 2>::new(l(a[1]), l(a[3])),
        SVector::<T, 2>::new(l(b[1]), l(b[3])),
        SVector::<T, 7>::from_fn(|i, _| l(b[4 + i])),
    )
}

/// One way of running the method on the HFB-320 record, for [`variants`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Variant {
    /// The prediction's integrator.
    pub integrator: Integrator,
    /// How the input is held between samples.
    pub input_hold: InputHold,
    /// One recursive pass (`false`) or batch Gauss–Newton to convergence (`true`).
    pub batch: bool,
}

impl Variant {
    /// A short label.
    pub fn label(&self) -> String {
        format!(
            "{:?}, input {:?}, {}",
            self.integrator,
            self.input_hold,
            if self.batch {
                "batch Gauss-Newton"
            } else {
                "one recursive pass"
            }
        )
    }
}

/// The variants [`variants`] runs: the paper's Euler with the input held, RK4 with the input held,
/// the book's RK4 with the input interpolated (recursive and batch), and RK2 with it.
pub const VARIANTS: [Variant; 5] = [
    Variant {
        integrator: Integrator::Euler,
        input_hold: InputHold::Zero,
        batch: false,
    },
    Variant {
        integrator: Integrator::Rk4,
        input_hold: InputHold::Zero,
        batch: false,
    },
    Variant {
        integrator: Integrator::Rk4,
        input_hold: InputHold::Linear,
        batch: false,
    },
    Variant {
        integrator: Integrator::Rk4,
        input_hold: InputHold::Linear,
        batch: true,
    },
    Variant {
        integrator: Integrator::Rk2,
        input_hold: InputHold::Linear,
        batch: false,
    },
];

/// A variant's estimates and their σ.
pub type VariantResult = (Variant, SVector<f64, 11>, SVector<f64, 11>);

/// Each of [`VARIANTS`] on the record (propagated sensitivity, the book's noise, the prior):
/// the estimates and their σ.
pub fn variants(rows: &[[f64; 20]]) -> Result<Vec<VariantResult>, String> {
    let data: Vec<_> = rows.windows(2).map(|w| step_data::<f64>(&w[0], &w[1])).collect();
    VARIANTS
        .iter()
        .map(|&v| {
            let mut fem = hfb320_filter_with::<f64>(rows, Sensitivity::Propagated, v.integrator, v.input_hold)?;
            if v.batch {
                let start = crate::fem_batch::StateStart {
                    model: *fem.model(),
                    settings: *fem.settings(),
                    x0: *fem.state(),
                    p_x0: *fem.state_covariance(),
                };
                let (p0, p_p0) = (*fem.parameters(), *fem.parameter_covariance());
                let fit = crate::fem_batch::gauss_newton(&start, &p0, &p0, &p_p0, &data, 20, 0.01)
                    .filter(|f| f.converged)
                    .ok_or("batch Gauss-Newton did not converge")?;
                Ok((v, fit.p, fit.sigma()))
            } else {
                for (u, un, y) in &data {
                    fem.step(u, un, y).map_err(|e| format!("{}: {e:?}", v.label()))?;
                }
                Ok((v, *fem.parameters(), fem.parameter_sigma()))
            }
        })
        .collect()
}

/// The noise check of [`hfb320_filter`] on the record: per output, the mean squared one-step
/// prediction error `Δz²` (eq. 7, before the parameter update) over the mean of its predicted
/// variance, the diagonal of `C P⁻ Cᵀ + R_x` (eq. 9 plus the measurement noise) — 1 when the
/// filter's noise model (`Q = F Fᵀ`, `R`) matches the data.
pub fn innovation_ratio(rows: &[[f64; 20]]) -> Result<[f64; 7], String> {
    let mut fem = hfb320_filter::<f64>(rows, Sensitivity::Propagated)?;
    let s = *fem.settings();
    let m = *fem.model();
    let (mut dz2, mut pred) = ([0.0; 7], [0.0; 7]);
    for w in rows.windows(2) {
        let (u, un, y) = step_data::<f64>(&w[0], &w[1]);
        let (x, p_x, p) = (*fem.state(), *fem.state_covariance(), *fem.parameters());
        let step = |xx: &SVector<f64, 4>| integrate(&m, s.integrator, s.input_hold, s.dt_s, xx, &u, &un, &p);
        let phi: SMatrix<f64, 4, 4> = aerosid_core::fem::central_difference(&x, step);
        let c = m.dh_dx(&step(&x), &un, &p);
        let r_p = c * (phi * p_x * phi.transpose() + s.q_x * s.dt_s) * c.transpose() + s.r_x;
        let dz = fem
            .step(&u, &un, &y)
            .map_err(|e| format!("t = {} s: {e:?}", w[1][0]))?
            .prediction_error;
        for i in 0..7 {
            dz2[i] += dz[i] * dz[i];
            pred[i] += r_p[(i, i)];
        }
    }
    Ok(core::array::from_fn(|i| dz2[i] / pred[i]))
}

/// [`variants`] as a table: `|Δ|/σ` of each parameter from the published value.
fn variants_table(rows: &[[f64; 20]]) -> Result<String, String> {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\nwhy Cmq was off: the prediction at 10 Hz. |ours − published|/σ per variant, and Cmq itself"
    );
    let _ = write!(out, "{:>50}", "variant");
    for name in hfb320_idx::NAMES {
        let _ = write!(out, " {name:>7}");
    }
    let _ = writeln!(out, " {:>9} {:>6}", "Cmq", "in 2σ");
    for (v, p, s) in variants(rows)? {
        let _ = write!(out, "{:>50}", v.label());
        let mut within = 0;
        for i in 0..11 {
            let z = (p[i] - PUBLISHED[i]).abs() / s[i];
            within += usize::from(z <= 2.0);
            let _ = write!(out, " {z:>7.2}");
        }
        let _ = writeln!(out, " {:>+9.2} {:>3}/11", p[9], within);
    }
    let _ = writeln!(
        out,
        "{:>50} {:>+9.2} (flight-data README)",
        "equation-error least squares, Cmq", -42.0
    );
    Ok(out)
}

/// Runs the report; returns the text and the figures written into `out_dir`.
pub fn hfb320_report(data: &Path, out_dir: &Path) -> Result<(String, Vec<PathBuf>), String> {
    let rows = hfb320_rows(data)?;
    let (t, hist) = recursive_pass(&rows)?;
    let (p, s) = hist[hist.len() - 1];
    let mut out = parameter_table(data, &p, &s);
    out += &variants_table(&rows)?;
    out += &noise_check(&rows)?;
    // The identified model simulated over the record from the first measured state with the measured
    // inputs (RK4 at the sample period), against the measurements; the published values likewise.
    let sim = simulate_record(&rows, &p);
    let sim_pub = simulate_record(&rows, &SVector::<f64, 11>::from_column_slice(&PUBLISHED));
    out += &simulation_table(&rows, &sim, &sim_pub);
    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let plot_err = |e: PlotError| format!("{e:?}");
    let f1 = out_dir.join("fem_hfb320_outputs.svg");
    outputs_figure(&rows, &sim).write_svg(&f1).map_err(plot_err)?;
    let f2 = out_dir.join("fem_hfb320_parameters.svg");
    parameters_figure(&t, &hist).write_svg(&f2).map_err(plot_err)?;
    Ok((out, vec![f1, f2]))
}

/// One parameter estimate with its standard deviation, per sample.
type Estimate = (SVector<f64, 11>, SVector<f64, 11>);

/// One recursive pass of the filter error method over the record: the times and the estimates
/// after each sample (the first the starting values).
fn recursive_pass(rows: &[[f64; 20]]) -> Result<(Vec<f64>, Vec<Estimate>), String> {
    let mut fem = hfb320_filter::<f64>(rows, Sensitivity::Propagated)?;
    let mut t = vec![rows[0][0]];
    let mut hist = vec![(*fem.parameters(), fem.parameter_sigma())];
    for w in rows.windows(2) {
        let (u, un, y) = step_data(&w[0], &w[1]);
        fem.step(&u, &un, &y).map_err(|e| format!("t = {} s: {e:?}", w[1][0]))?;
        t.push(w[1][0]);
        hist.push((*fem.parameters(), fem.parameter_sigma()));
    }
    Ok((t, hist))
}

/// The final estimates ± σ against the published ones.
fn parameter_table(data: &Path, p: &SVector<f64, 11>, s: &SVector<f64, 11>) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "HFB-320 ({}): filter error method (seed 001), one recursive pass, RK4 with the input interpolated (the book's), propagated sensitivity",
        data.display()
    );
    let _ = writeln!(
        out,
        "{:>10} {:>22} {:>12} {:>7}",
        "param", "ours ± σ", "published", "|Δ|/σ"
    );
    for i in 0..11 {
        let _ = writeln!(
            out,
            "{:>10} {:>+11.5} ± {:8.5} {:>+12.5} {:7.2}",
            hfb320_idx::NAMES[i],
            p[i],
            s[i],
            PUBLISHED[i],
            (p[i] - PUBLISHED[i]).abs() / s[i]
        );
    }
    out
}

/// The innovations' mean square over their predicted variance, per output.
fn noise_check(rows: &[[f64; 20]]) -> Result<String, String> {
    let mut out = String::new();
    let ratio = innovation_ratio(rows)?;
    let _ = writeln!(
        out,
        "noise check: mean Δz² over the predicted C P⁻ Cᵀ + R per output (1 if the book's F, R fit this filter):"
    );
    for (name, r) in OUTPUTS.iter().zip(ratio) {
        let _ = write!(out, " {name} {r:.2};");
    }
    let _ = writeln!(out);
    Ok(out)
}

/// The model with `params` simulated over the record from the first measured state with the
/// measured inputs (RK4 at the sample period, the input interpolated): its outputs per sample.
fn simulate_record(rows: &[[f64; 20]], params: &SVector<f64, 11>) -> Vec<SVector<f64, 7>> {
    let model = Hfb320::<f64>::default();
    let mut x = SVector::<f64, 4>::new(rows[0][4], rows[0][5], rows[0][6], rows[0][7]);
    let mut ys = Vec::with_capacity(rows.len());
    for (k, r) in rows.iter().enumerate() {
        let u = SVector::<f64, 2>::new(r[1], r[3]);
        ys.push(model.h(&x, &u, params));
        if let Some(next) = rows.get(k + 1) {
            let un = SVector::<f64, 2>::new(next[1], next[3]);
            x = integrate(&model, Integrator::Rk4, InputHold::Linear, 0.1, &x, &u, &un, params);
        }
    }
    ys
}

/// RMS and R² of each output of the two simulations (ours, the published model's) against the
/// measurements.
fn simulation_table(rows: &[[f64; 20]], sim: &[SVector<f64, 7>], sim_pub: &[SVector<f64, 7>]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\nmodels simulated over the whole record (open loop, no state filter; turbulence makes V and θ drift):"
    );
    let _ = writeln!(
        out,
        "{:>12} {:>10} {:>8} {:>16} {:>8}",
        "output", "RMS ours", "R² ours", "RMS published", "R² pub."
    );
    for (i, name) in OUTPUTS.iter().enumerate() {
        let meas: Vec<f64> = rows.iter().map(|r| r[4 + i]).collect();
        let mean = meas.iter().sum::<f64>() / meas.len() as f64;
        let ss_tot: f64 = meas.iter().map(|m| (m - mean).powi(2)).sum();
        let fit = |ys: &[SVector<f64, 7>]| {
            let ss_res: f64 = meas.iter().zip(ys.iter()).map(|(m, y)| (m - y[i]).powi(2)).sum();
            ((ss_res / meas.len() as f64).sqrt(), 1.0 - ss_res / ss_tot)
        };
        let ((r1, q1), (r2, q2)) = (fit(sim), fit(sim_pub));
        let _ = writeln!(out, "{name:>12} {r1:>10.4} {q1:>8.4} {r2:>16.4} {q2:>8.4}");
    }
    out
}

/// Each output measured against the identified model's simulation, and the residual.
fn outputs_figure(rows: &[[f64; 20]], sim: &[SVector<f64, 7>]) -> Figure {
    let time: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let mut outputs = Figure::new("t (s)").title("HFB-320: measured vs identified model (simulation), residuals");
    for (i, name) in OUTPUTS.iter().enumerate() {
        let meas: Vec<f64> = rows.iter().map(|r| r[4 + i]).collect();
        let model_y: Vec<f64> = sim.iter().map(|y| y[i]).collect();
        let resid: Vec<f64> = meas.iter().zip(model_y.iter()).map(|(m, y)| m - y).collect();
        outputs = outputs
            .panel(
                Panel::new(*name, *name)
                    .line(Line::new("measured", &time, &meas, Colour::BLACK))
                    .line(Line::new("model", &time, &model_y, Colour::BLUE)),
            )
            .panel(Panel::new(format!("{name} residual"), "residual").line(Line::new(
                "measured − model",
                &time,
                &resid,
                Colour::VERMILLION,
            )));
    }
    outputs
}

/// Each parameter's recursive estimate ± σ against the published value.
fn parameters_figure(t: &[f64], hist: &[Estimate]) -> Figure {
    let mut params = Figure::new("t (s)").title("HFB-320: filter-error parameter estimates ±σ");
    for i in 0..11 {
        let est: Vec<f64> = hist.iter().map(|h| h.0[i]).collect();
        let sig: Vec<f64> = hist.iter().map(|h| h.1[i]).collect();
        let published = vec![PUBLISHED[i]; t.len()];
        params = params.panel(
            Panel::new(hfb320_idx::NAMES[i], hfb320_idx::NAMES[i])
                .band(Band::around("±σ", t, &est, &sig, 1.0, Colour::BLUE))
                .line(Line::new("ours", t, &est, Colour::BLUE))
                .line(Line::new("published FEM", t, &published, Colour::BLACK).dashed()),
        );
    }
    params
}
