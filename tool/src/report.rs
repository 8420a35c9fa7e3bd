//! What the main job prints and draws: the identified model beside the truth, and
//! the figures of an experiment ([`crate::experiment`]) as SVG.
//!
//! * [`model_table`] — per coefficient and parameter: the truth (the linearisation of the truth
//!   model at trim), the GTLS estimate ± σ (eq. 17) and the RLS estimate at the end of a flight.
//! * [`coefficient_figure`] — one coefficient over a flight: a panel per parameter (GTLS with its
//!   ±2σ band, RLS, the truth), the singular values with the eq. 21 threshold (log axis) and `λ_F`.
//!   Fig. 1 of the seed is this figure for `C_D` on the [`crate::flights::fig1_config`] flight.
//! * [`forgetting_figure`] — Fig. 2: one coefficient's parameters under two forgetting settings on
//!   the same flight, the truth stepping at the parameter jump, and both `λ_F` and `k`.
//!
//! Figures are drawn at 10 Hz (every tenth sample of a 100 Hz flight) to keep the files small.

use crate::experiment::{CoefficientTrace, Experiment, COEFFICIENT_NAMES};
use crate::plot::{Band, Colour, Figure, HLine, Line, Panel};
use aerosid_core::aero::model::idx;
use aerosid_core::aero::Regressor;
use std::fmt::Write as _;

/// Every how many samples a figure takes a point: every one, as the figures cut each trace to the
/// extremes of each pixel column themselves ([`crate::plot::decimate`]), which keeps the one-sample
/// spikes that taking every n-th sample would drop.
pub const FIGURE_DECIMATION: usize = 1;

/// The conventional name of a parameter: coefficient `C_X` and its regressor.
pub fn parameter_name(coefficient: usize, r: Regressor) -> String {
    let c = COEFFICIENT_NAMES.get(coefficient).copied().unwrap_or("C_?");
    let suffix = match r {
        Regressor::One => "0",
        Regressor::Alpha => "α",
        Regressor::Alpha2 => "α²",
        Regressor::Beta => "β",
        Regressor::RollRateN => "p",
        Regressor::PitchRateN => "q",
        Regressor::YawRateN => "r",
        Regressor::Elevator => "δe",
        Regressor::Aileron => "δa",
        Regressor::Rudder => "δr",
    };
    format!("{c}{suffix}")
}

/// The identified model at the last sample of `ex` beside the truth in force then, as a text table.
pub fn model_table(ex: &Experiment) -> String {
    let jump = ex.jump_s;
    let last = ex.t_s.len().saturating_sub(1);
    let t_end = ex.t_s.get(last).copied().unwrap_or(0.0);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<8} {:>10} {:>22} {:>10}   {:>3} {:>9}",
        "param", "truth", "GTLS ± σ (eq. 17)", "RLS", "k", "updates"
    );
    for (i, tr) in ex.coefficients.iter().enumerate() {
        let truth = tr.truth_at(t_end, jump);
        let k = tr.k.get(last).copied().unwrap_or(0);
        let updates = tr.updated.iter().filter(|u| **u).count();
        for (j, r) in tr.regressors.iter().enumerate() {
            let est = tr.theta.get(last).map_or(f64::NAN, |v| v[j]);
            let sig = tr.sigma.get(last).map_or(f64::NAN, |v| v[j]);
            let rls = tr.rls_theta.get(last).map_or(f64::NAN, |v| v[j]);
            let sig_s = if sig.is_finite() {
                format!("{est:+10.4} ± {sig:<9.4}")
            } else {
                format!("{est:+10.4} ± {:<9}", "–")
            };
            let (k_s, u_s) = if j == 0 {
                (format!("{k}/{}", tr.n_theta() - 1), updates.to_string())
            } else {
                (String::new(), String::new())
            };
            let line = format!(
                "{:<8} {:>+10.4} {:>22} {:>+10.4}   {:>3} {:>9}",
                parameter_name(i, *r),
                truth[j],
                sig_s,
                rls,
                k_s,
                u_s
            );
            let _ = writeln!(out, "{}", line.trim_end());
        }
    }
    out
}

fn decimate(v: &[f64]) -> Vec<f64> {
    v.iter().step_by(FIGURE_DECIMATION).copied().collect()
}

fn column(rows: &[Vec<f64>], j: usize) -> Vec<f64> {
    rows.iter()
        .step_by(FIGURE_DECIMATION)
        .map(|r| r.get(j).copied().unwrap_or(f64::NAN))
        .collect()
}

fn truth_series(ex: &Experiment, tr: &CoefficientTrace, j: usize) -> Vec<f64> {
    let jump = ex.jump_s;
    ex.t_s
        .iter()
        .step_by(FIGURE_DECIMATION)
        .map(|t| tr.truth_at(*t, jump)[j])
        .collect()
}

/// One coefficient over a flight (module doc).
pub fn coefficient_figure(ex: &Experiment, coefficient: usize, title: &str) -> Figure {
    let tr = &ex.coefficients[coefficient.min(idx::COUNT - 1)];
    let t = decimate(&ex.t_s);
    let mut fig = Figure::new("time [s]").title(title).size(1000, 220);
    for (j, r) in tr.regressors.iter().enumerate() {
        let name = parameter_name(coefficient, *r);
        let est = column(&tr.theta, j);
        let sig = column(&tr.sigma, j);
        fig = fig.panel(
            Panel::new(name.clone(), name)
                .band(Band::around("GTLS ±2σ", &t, &est, &sig, 2.0, Colour::BLUE))
                .line(Line::new("RLS", &t, &column(&tr.rls_theta, j), Colour::ORANGE))
                .line(Line::new("GTLS", &t, &est, Colour::BLUE))
                .line(Line::new("truth", &t, &truth_series(ex, tr, j), Colour::BLACK).dashed()),
        );
    }
    let mut sv = Panel::new("singular values (eq. 13) and threshold (eq. 21)", "σ").log_y();
    let n_sv = tr.singular_values.first().map_or(0, Vec::len);
    for j in 0..n_sv {
        sv = sv.line(Line::new(
            format!("σ{}", j + 1),
            &t,
            &column(&tr.singular_values, j),
            Colour::cycle(j),
        ));
    }
    sv = sv.line(Line::new("threshold", &t, &decimate(&tr.threshold), Colour::BLACK).dashed());
    fig.panel(sv)
        .panel(Panel::new("forgetting factor", "λ_F").line(Line::new("λ_F", &t, &decimate(&tr.lambda), Colour::GREEN)))
}

/// Fig. 2: coefficient `coefficient` under two forgetting settings on the same flight (module doc).
pub fn forgetting_figure(a: (&str, &Experiment), b: (&str, &Experiment), coefficient: usize, title: &str) -> Figure {
    let c = coefficient.min(idx::COUNT - 1);
    let (ta, tb) = (&a.1.coefficients[c], &b.1.coefficients[c]);
    let t = decimate(&a.1.t_s);
    let mut fig = Figure::new("time [s]").title(title).size(1000, 220);
    for (j, r) in ta.regressors.iter().enumerate() {
        let name = parameter_name(c, *r);
        fig = fig.panel(
            Panel::new(name.clone(), name)
                .line(Line::new(a.0, &t, &column(&ta.theta, j), Colour::BLUE))
                .line(Line::new(b.0, &t, &column(&tb.theta, j), Colour::ORANGE))
                .line(Line::new("truth", &t, &truth_series(a.1, ta, j), Colour::BLACK).dashed()),
        );
    }
    let k = |tr: &CoefficientTrace| -> Vec<f64> { tr.k.iter().step_by(FIGURE_DECIMATION).map(|k| *k as f64).collect() };
    let n_x = ta.n_theta() as f64 - 1.0;
    fig.panel(
        Panel::new("forgetting factor", "λ_F")
            .line(Line::new(a.0, &t, &decimate(&ta.lambda), Colour::BLUE))
            .line(Line::new(b.0, &t, &decimate(&tb.lambda), Colour::ORANGE)),
    )
    .panel(
        Panel::new("excited directions (eq. 21)", "k")
            .line(Line::new(a.0, &t, &k(ta), Colour::BLUE))
            .line(Line::new(b.0, &t, &k(tb), Colour::ORANGE))
            .hline(HLine::new("n_θ − 1", n_x, Colour::BLACK).dashed()),
    )
}

/// Settings of the main job ([`main_job`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MainJob {
    /// Folder the figures are written to (created if missing).
    pub out_dir: std::path::PathBuf,
    /// Seed of the main flight (turbulence and sensors).
    pub seed: u64,
    /// Duration of the main flight, s.
    pub seconds: f64,
    /// Monte Carlo draws for `σ_ε` (eq. 40–41).
    pub mc_draws: usize,
}

impl Default for MainJob {
    fn default() -> Self {
        Self {
            out_dir: "out".into(),
            seed: 1,
            seconds: 180.0,
            mc_draws: 1 << 18,
        }
    }
}

/// Why the main job stopped.
#[derive(Debug)]
pub enum MainJobError {
    /// The Monte Carlo failed.
    MonteCarlo(crate::mc::McError),
    /// An experiment failed.
    Experiment(crate::experiment::ExperimentError),
    /// A figure could not be written.
    Plot(crate::plot::PlotError),
}

impl std::fmt::Display for MainJobError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::MonteCarlo(e) => write!(f, "Monte Carlo: {e:?}"),
            Self::Experiment(e) => write!(f, "experiment: {e}"),
            Self::Plot(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for MainJobError {}

/// The main job (README): `σ_ε` from the Monte Carlo; the main flight ([`crate::flights::main_flight`])
/// through the on-board `f32` pipeline with RLS beside it; the Fig. 1 and Fig. 2 flights; the
/// identified model table and a few lines per figure on `log`; SVG figures in `out_dir`. The four
/// flights run in parallel. Returns the paths written.
pub fn main_job(job: &MainJob, log: &mut dyn std::fmt::Write) -> Result<Vec<std::path::PathBuf>, MainJobError> {
    let ex = run_experiments(job, log)?;
    let (main, fig1, vff, cst) = (&ex[0], &ex[1], &ex[2], &ex[3]);
    let _ = writeln!(
        log,
        "\nmain flight: skywalker_2013_mod, {} s, seed {}, every hidden effect on, light turbulence, \
         default sensors (noise and biases); f32 on-board pipeline, VFF",
        job.seconds, job.seed
    );
    let _ = writeln!(log, "{}", model_table(main));
    let mut written = Vec::new();
    let mut write = |name: &str, fig: Figure| -> Result<(), MainJobError> {
        let path = job.out_dir.join(name);
        fig.write_svg(&path).map_err(MainJobError::Plot)?;
        written.push(path);
        Ok(())
    };
    // C_L and C_l differ only in case: file names use the coefficient's meaning.
    let files = ["lift", "drag", "side", "roll", "pitch", "yaw"];
    for (i, name) in COEFFICIENT_NAMES.iter().enumerate() {
        write(
            &format!("main_{}.svg", files[i]),
            coefficient_figure(main, i, &format!("{name} — main flight")),
        )?;
    }
    log_fig1(log, fig1);
    write(
        "fig1_drag.svg",
        coefficient_figure(
            fig1,
            idx::DRAG,
            "Fig. 1 — C_D: PCA-GTLS vs RLS, excitation from t = 250 s",
        ),
    )?;
    log_fig2(log, vff, cst);
    write(
        "fig2_pitch.svg",
        forgetting_figure(
            ("VFF", vff),
            ("λ = 0.995", cst),
            idx::PITCH,
            "Fig. 2 — C_m: variable vs constant forgetting, parameter jump at t = 50 s",
        ),
    )?;
    Ok(written)
}

/// σ_ε by Monte Carlo (logged), then the four flights in parallel: the main flight (VFF), Fig. 1's,
/// and Fig. 2's with the variable and with a constant forgetting factor, in that order.
fn run_experiments(job: &MainJob, log: &mut dyn std::fmt::Write) -> Result<Vec<Experiment>, MainJobError> {
    use crate::experiment::{self, ExperimentConfig};
    use crate::flights;
    use aerosid_core::{Forgetting, VffSettings};
    let sigma = experiment::mc_sigma_eps(&experiment::onboard_mc_sensors(0.01), job.mc_draws, 7)
        .map_err(MainJobError::MonteCarlo)?;
    let _ = writeln!(
        log,
        "σ_ε (Monte Carlo, {} draws) C_L, C_D, C_Y, C_l, C_m, C_n: {:.4?}",
        job.mc_draws, sigma
    );
    let vff = Forgetting::Variable(VffSettings::for_aero_coefficients(100.0));
    let mut main = ExperimentConfig::new(flights::main_flight(job.seconds, job.seed), sigma);
    main.pipeline.gtls.forgetting = vff;
    let fig1 = ExperimentConfig::new(flights::fig1_config(250.0, 450.0, 11), sigma);
    let fig2_sim = flights::fig2_config(50.0, 150.0, 450.0, 5);
    let mut fig2_vff = ExperimentConfig::new(fig2_sim.clone(), sigma);
    fig2_vff.pipeline.gtls.forgetting = vff;
    let mut fig2_cst = ExperimentConfig::new(fig2_sim, sigma);
    fig2_cst.pipeline.gtls.forgetting = Forgetting::Constant(0.995);
    let configs = [main, fig1, fig2_vff, fig2_cst];
    let runs: Vec<_> = {
        use rayon::prelude::*;
        configs.par_iter().map(experiment::run).collect()
    };
    let mut ex = Vec::with_capacity(runs.len());
    for r in runs {
        ex.push(r.map_err(MainJobError::Experiment)?);
    }
    Ok(ex)
}

/// Fig. 1's line of the log: `C_D` at the end, GTLS and RLS beside the truth.
fn log_fig1(log: &mut dyn std::fmt::Write, fig1: &Experiment) {
    let d = &fig1.coefficients[idx::DRAG];
    let last = fig1.t_s.len().saturating_sub(1);
    let _ = writeln!(
        log,
        "Fig. 1 (C_D, excitation from 250 s): at {} s GTLS {:+.4?} (k = {} of {}), RLS {:+.4?}, truth {:+.4?}",
        fig1.t_s[last],
        d.theta[last],
        d.k[last],
        d.n_theta() - 1,
        d.rls_theta[last],
        d.truth
    );
}

/// Fig. 2's line of the log: `C_mα` 5 s after the jump with both forgetting factors, and `k` at
/// the end.
fn log_fig2(log: &mut dyn std::fmt::Write, vff: &Experiment, cst: &Experiment) {
    let v = &vff.coefficients[idx::PITCH];
    let i5 = vff.index_at(55.0);
    let _ = writeln!(
        log,
        "Fig. 2 (C_m jump at 50 s): C_mα at 55 s VFF {:+.4}, λ=0.995 {:+.4}, new truth {:+.4}; k at the end VFF {}, λ=0.995 {}",
        v.theta[i5][1],
        cst.coefficients[idx::PITCH].theta[i5][1],
        v.truth_after_jump[1],
        v.k.last().copied().unwrap_or(0),
        cst.coefficients[idx::PITCH].k.last().copied().unwrap_or(0)
    );
}
