//! Seed 001, Table 1 (issue 5 §2): 50 seeded flights of the A-4D longitudinal model with
//! turbulence, the filter error method from Table 1's ±15 % initial values. IN PROGRESS: the tables
//! are printed (`--nocapture`); what is asserted is the one finding established so far — `CLα̇` is
//! not identifiable at this flight condition (below). Reaching the 2σ-coverage and 5 %
//! goals is open (see the issue notes).

// Index loops over the nine parameters walk several arrays together.
#![allow(clippy::needless_range_loop)]

use aerosid_core::fem::models::Longitudinal;
use aerosid_core::fem::Sensitivity;
use aerosid_host::table1::{self, Input};
use rayon::prelude::*;

const RUNS: u64 = 50;

struct Summary {
    /// Posterior σ of CLα̇ over its prior σ, largest over the runs.
    cl_alphadot_sigma_ratio_min: f64,
    median_abs_rel_error: [f64; 9],
    all_within_2sigma: usize,
    per_param_within_2sigma: [usize; 9],
    mean_sigma: [f64; 9],
    spread: [f64; 9],
    median_run: table1::Run,
}

fn campaign(input: Input, seconds: f64, sensitivity: Sensitivity) -> Summary {
    campaign_with(input, seconds, sensitivity, false)
}

fn campaign_with(input: Input, seconds: f64, sensitivity: Sensitivity, gust_states: bool) -> Summary {
    let q = table1::process_noise();
    let runs: Vec<table1::Run> = (1..=RUNS)
        .into_par_iter()
        .map(|seed| {
            let f = table1::simulate(input, seconds, seed);
            if gust_states {
                table1::identify_with_gust_states(&f, 1e-8, sensitivity).expect("every step accepted")
            } else {
                table1::identify(&f, &q, sensitivity).expect("every step accepted")
            }
        })
        .collect();
    let truth = Longitudinal::<f64>::TABLE1_TRUE;
    let prior = 0.25 * Longitudinal::<f64>::TABLE1_INITIAL[2];
    let mut s = Summary {
        cl_alphadot_sigma_ratio_min: runs.iter().map(|r| r.sigma[2] / prior).fold(f64::INFINITY, f64::min),
        median_abs_rel_error: [0.0; 9],
        all_within_2sigma: 0,
        per_param_within_2sigma: [0; 9],
        mean_sigma: [0.0; 9],
        spread: [0.0; 9],
        median_run: runs[0],
    };
    for r in &runs {
        let mut all = true;
        for j in 0..9 {
            let ok = (r.p[j] - truth[j]).abs() <= 2.0 * r.sigma[j];
            all &= ok;
            s.per_param_within_2sigma[j] += ok as usize;
            s.mean_sigma[j] += r.sigma[j] / RUNS as f64;
        }
        s.all_within_2sigma += all as usize;
    }
    for j in 0..9 {
        let mean = runs.iter().map(|r| r.p[j]).sum::<f64>() / RUNS as f64;
        s.spread[j] = (runs.iter().map(|r| (r.p[j] - mean).powi(2)).sum::<f64>() / (RUNS - 1) as f64).sqrt();
        let mut e: Vec<f64> = runs
            .iter()
            .map(|r| {
                if truth[j] != 0.0 {
                    ((r.p[j] - truth[j]) / truth[j]).abs()
                } else {
                    (r.p[j] - truth[j]).abs()
                }
            })
            .collect();
        e.sort_by(|a, b| a.total_cmp(b));
        s.median_abs_rel_error[j] = e[e.len() / 2];
    }
    // The median run: median of the summed squared normalised errors.
    let mut order: Vec<(f64, usize)> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            (
                (0..9).map(|j| ((r.p[j] - truth[j]) / r.sigma[j]).powi(2)).sum::<f64>(),
                i,
            )
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    s.median_run = runs[order[order.len() / 2].1];
    s
}

fn print(label: &str, s: &Summary) {
    let t = Longitudinal::<f64>::TABLE1_TRUE;
    let init = Longitudinal::<f64>::TABLE1_INITIAL;
    let (seed, seed_s) = (Longitudinal::<f64>::TABLE1_SEED, Longitudinal::<f64>::TABLE1_SEED_SIGMA);
    println!(
        "\n{label}: {RUNS} runs; all nine within 2σ in {}/{RUNS}",
        s.all_within_2sigma
    );
    println!(
        "{:>11} {:>8} {:>8} {:>20} {:>20} {:>8} {:>8} {:>7} {:>7} {:>6}",
        "param", "true", "initial", "seed ± σ", "ours (median) ± σ", "seed err", "our err", "mean σ", "spread", "in 2σ"
    );
    for j in 0..9 {
        let rel = |v: f64| {
            if t[j] != 0.0 {
                format!("{:7.1}%", 100.0 * ((v - t[j]) / t[j]).abs())
            } else {
                format!("{:8.5}", (v - t[j]).abs())
            }
        };
        println!(
            "{:>11} {:>+8.4} {:>+8.4} {:>+10.5} ± {:7.5} {:>+10.5} ± {:7.5} {} {} {:7.4} {:7.4} {:>4}/{RUNS}",
            Longitudinal::<f64>::NAMES[j],
            t[j],
            init[j],
            seed[j],
            seed_s[j],
            s.median_run.p[j],
            s.median_run.sigma[j],
            rel(seed[j]),
            rel(s.median_run.p[j]),
            s.mean_sigma[j],
            s.spread[j],
            s.per_param_within_2sigma[j]
        );
    }
    println!("median |rel. error| per parameter: {:.3?}", s.median_abs_rel_error);
}

#[test]
fn table1_with_the_papers_input_cl_alphadot_is_not_identifiable() {
    for sens in [Sensitivity::OneStep, Sensitivity::Propagated] {
        let s = campaign(Input::PAPER, 15.0, sens);
        print(&format!("paper's input (3-2-1-1, 0.4 s), {sens:?}"), &s);
        // CLα̇ enters only through α̇(1 + q̄S·CLα̇·c̄/(2V)/(mV)): at Mach 0.8, 35 000 ft that factor
        // is 1 + 1.1·10⁻³, so CLα̇ moves α̇ by 0.1 %. The data carry no information on it: its
        // posterior σ stays within 5 % of the Bauer–Andrisani prior σ in every run. (The seed's own
        // σ, 0.233, is its prior 0.238 too: Table 1's CLα̇ "estimate" is the prior.)
        assert!(
            s.cl_alphadot_sigma_ratio_min > 0.95,
            "CLα̇ σ/prior σ down to {}",
            s.cl_alphadot_sigma_ratio_min
        );
    }
}

#[test]
#[ignore = "in progress (issue 5 §2): the designed input is printed for comparison, nothing asserted yet"]
fn table1_with_a_designed_input() {
    for sens in [Sensitivity::OneStep, Sensitivity::Propagated] {
        let s = campaign(Input::DualMultistep { amplitude_rad: 0.0175 }, 20.0, sens);
        print(&format!("dual 3-2-1-1, {sens:?}"), &s);
    }
}

#[test]
#[ignore = "in progress (issue 5 §2): gust states in the filter, printed for comparison"]
fn table1_with_gust_states() {
    for input in [Input::PAPER, Input::DualMultistep { amplitude_rad: 0.0175 }] {
        for sens in [Sensitivity::OneStep, Sensitivity::Propagated] {
            let s = campaign_with(input, 20.0, sens, true);
            print(&format!("gust states, {input:?}, {sens:?}"), &s);
        }
    }
}
