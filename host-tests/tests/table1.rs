//! Seed 001, Table 1 (issue 5 §2): 50 seeded flights of the A-4D longitudinal model with
//! turbulence, the filter error method from Table 1's ±15 % initial values. IN PROGRESS: the tables
//! are printed (`--nocapture`); what is asserted is the one finding established so far — `CLα̇` is
//! not identifiable at this flight condition (below). Reaching the 2σ-coverage and 5 %
//! goals is open (see the issue notes).

// Index loops over the nine parameters walk several arrays together.
#![allow(clippy::needless_range_loop)]

use aerosid_core::fem::Sensitivity;
use aerosid_host::table1::{campaign, summary_table, Input};

#[test]
fn table1_with_the_papers_input_cl_alphadot_is_not_identifiable() {
    for sens in [Sensitivity::OneStep, Sensitivity::Propagated] {
        let s = campaign(Input::PAPER, 15.0, sens, false);
        print!(
            "{}",
            summary_table(&format!("paper's input (3-2-1-1, 0.4 s), {sens:?}"), &s)
        );
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
        let s = campaign(Input::DualMultistep { amplitude_rad: 0.0175 }, 20.0, sens, false);
        print!("{}", summary_table(&format!("dual 3-2-1-1, {sens:?}"), &s));
    }
}

#[test]
#[ignore = "in progress (issue 5 §2): gust states in the filter, printed for comparison"]
fn table1_with_gust_states() {
    for input in [Input::PAPER, Input::DualMultistep { amplitude_rad: 0.0175 }] {
        for sens in [Sensitivity::OneStep, Sensitivity::Propagated] {
            let s = campaign(input, 20.0, sens, true);
            print!("{}", summary_table(&format!("gust states, {input:?}, {sens:?}"), &s));
        }
    }
}

#[test]
#[ignore = "in progress (issue 5 §2): gust states and a z accelerometer, printed for comparison"]
fn table1_with_an_accelerometer() {
    for sens in [Sensitivity::OneStep, Sensitivity::Propagated] {
        let s =
            aerosid_host::table1::campaign_by(Input::PAPER, 15.0, sens, aerosid_host::table1::Filter::Accelerometer);
        print!(
            "{}",
            summary_table(&format!("gust states + a_z, 3-2-1-1, {sens:?}"), &s)
        );
    }
}

#[test]
#[ignore = "issue 5 §2 comparison: equation-error PCA-GTLS on the Table 1 flights, printed"]
fn table1_equation_error_pca_gtls() {
    use aerosid_host::table1::{campaign_by, Filter};
    for (label, input, seconds) in [
        ("3-2-1-1", Input::PAPER, 15.0),
        ("dual 3-2-1-1", Input::DualMultistep { amplitude_rad: 0.0175 }, 20.0),
    ] {
        // The sensitivity setting is a filter's; the equation-error method ignores it.
        let s = campaign_by(input, seconds, Sensitivity::OneStep, Filter::EquationError);
        print!(
            "{}",
            summary_table(&format!("equation-error PCA-GTLS, {label}, {seconds} s"), &s)
        );
    }
}
