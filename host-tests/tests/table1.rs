//! Seed 001, Table 1: 50 seeded flights of the A-4D longitudinal model in Dryden
//! turbulence, with the paper's input and with a designed one, through the paper's filter error
//! method, ours on board (one recursive pass, Dryden gust states, an accelerometer), ours offline
//! (batch Gauss–Newton) and seed 000's equation-error PCA-GTLS; and the Cramér–Rao bound of the
//! records. The campaigns are computed once and shared by the tests (`results()`); every figure
//! asserted below is the measured one, printed with `--nocapture` (and by `aerosid table1`).
//!
//! What is required and what the measurements say:
//! * ≥ 90 % of the runs with all nine within 2σ, σ honest: the batch method's σ is honest (rms z
//!   0.88–1.24 on every data-determined parameter), and honest σ on nine parameters puts all nine
//!   within 2σ in 76–77 % of the runs (measured 40/50 and 41/50). The 90 % figure and honest σ
//!   cannot both hold; we keep σ honest. One recursive pass overstates the information on `CL0`,
//!   `Cm0` (σ 2.4× too small: `one_recursive_pass_overstates_the_information_on_cl0_and_cm0`).
//! * `CLα̇`, `Cmα̇`, `Cmq` below 5 % median error: physically out of reach with elevator inputs in
//!   this turbulence, shown by the bound (the first three tests), with what it would take.

// Index loops over the nine parameters walk several arrays together.
#![allow(clippy::needless_range_loop)]

use aerosid::table1::{
    bound, comparison_table, design_scan, predicted_null_direction, prior, requirement_bounds, requirement_table,
    summary_table, Bound, Conditions, Input, Method, Summary, DESIGNED_SECONDS, DESIGNED_STEP_S, NAMES, PAPER_SECONDS,
    RUNS, SIGMA_FOR_5_PERCENT_MEDIAN,
};
use aerosid_core::fem::models::Longitudinal;
use std::sync::OnceLock;

/// Table 1's true values.
const TRUE: [f64; 9] = Longitudinal::<f64>::TABLE1_TRUE;

/// Indices in Table 1's order.
const CL0: usize = 0;
const CLALPHA: usize = 1;
const CLALPHADOT: usize = 2;
const CLDE: usize = 3;
const CM0: usize = 4;
const CMALPHA: usize = 5;
const CMALPHADOT: usize = 6;
const CMQ: usize = 7;
const CMDE: usize = 8;
/// The parameters the records determine (the bound below 25 % of the truth; `Cm0` absolute):
/// all but `CLα̇`, `Cmα̇`, `Cmq`.
const DATA_DETERMINED: [usize; 6] = [CL0, CLALPHA, CLDE, CM0, CMALPHA, CMDE];

struct Results {
    /// Per input (paper's, designed), per method in `Method::ALL` order.
    campaigns: [[Summary; 4]; 2],
    /// The paper's input (15 s), then the design scan.
    bounds: Vec<Bound>,
    /// `requirement_bounds()`: both inputs under `WHAT_IT_TAKES`.
    requirements: Vec<Bound>,
}

fn results() -> &'static Results {
    static R: OnceLock<Results> = OnceLock::new();
    R.get_or_init(|| {
        let run = |input: Input, seconds: f64| Method::ALL.map(|m| aerosid::table1::campaign(input, seconds, m));
        let campaigns = [run(Input::PAPER, PAPER_SECONDS), run(Input::DESIGNED, DESIGNED_SECONDS)];
        let mut bounds = vec![bound(Input::PAPER, PAPER_SECONDS, Conditions::SIMULATED).expect("bound")];
        bounds.extend(design_scan());
        let r = Results {
            campaigns,
            bounds,
            requirements: requirement_bounds(),
        };
        for (k, (input, seconds)) in [(Input::PAPER, PAPER_SECONDS), (Input::DESIGNED, DESIGNED_SECONDS)]
            .into_iter()
            .enumerate()
        {
            for (m, s) in Method::ALL.iter().zip(&r.campaigns[k]) {
                print!("{}", summary_table(&format!("{}, {}", m.label(), input.label()), s));
            }
            let rows: Vec<(Method, &Summary)> = Method::ALL.iter().copied().zip(&r.campaigns[k]).collect();
            print!(
                "{}",
                comparison_table(&format!("{}, {seconds} s", input.label()), &rows)
            );
        }
        print!("{}", aerosid::table1::bound_table(&r.bounds));
        print!("{}", requirement_table(&r.requirements));
        r
    })
}

fn summary(input: usize, method: Method) -> &'static Summary {
    let k = Method::ALL.iter().position(|&m| m == method).expect("method");
    &results().campaigns[input][k]
}

const PAPER_INPUT: usize = 0;
const DESIGNED_INPUT: usize = 1;

fn requirement(input: Input, c: Conditions) -> &'static Bound {
    results()
        .requirements
        .iter()
        .find(|b| b.input == input && b.conditions == c)
        .expect("requirement bound")
}

/// The relative bound of parameter `j`.
fn rel(b: &Bound, j: usize) -> f64 {
    b.sigma[j] / TRUE[j].abs()
}

#[test]
fn cl_alphadot_is_not_identifiable_in_turbulence_by_its_cramer_rao_bound() {
    let r = results();
    // GIVEN the bound of each record (the inverse Fisher information of our filter's model at the
    // truth, no prior), WHEN read for CLα̇
    let (paper, designed) = (
        &r.bounds[0],
        r.bounds.iter().find(|b| b.input == Input::DESIGNED).expect("designed"),
    );
    // THEN with either input the data alone cannot tell CLα̇ from zero: σ_CRB is 378 % of it with
    // the paper's input and 336 % with the designed one (measured). CLα̇ moves α̇ by 0.1 %
    // (ρSc̄/(4m) = 9.5·10⁻⁴ per unit CLα̇), and the lift it adds equals that of a 0.6 m/s-per-rad/s
    // vertical gust, which the light turbulence (σ_w 1 m/s) hides.
    assert!(rel(paper, CLALPHADOT) > 3.0, "paper: {:.2}", rel(paper, CLALPHADOT));
    assert!(
        rel(designed, CLALPHADOT) > 3.0,
        "designed: {:.2}",
        rel(designed, CLALPHADOT)
    );
    // … so every filter-error run leaves CLα̇ at its prior (posterior σ ≥ 0.99 of the prior σ in
    // every run, measured), as the seed's own Table 1 does (0.233 vs the prior 0.238).
    for input in [PAPER_INPUT, DESIGNED_INPUT] {
        for m in [Method::Paper, Method::Recursive, Method::Batch] {
            let ratio = summary(input, m).cl_alphadot_sigma_ratio_min;
            assert!(ratio > 0.99, "{m:?}: CLα̇ σ/prior σ down to {ratio}");
        }
    }
    let seed_ratio = Longitudinal::<f64>::TABLE1_SEED_SIGMA[CLALPHADOT] / prior().1[(CLALPHADOT, CLALPHADOT)].sqrt();
    assert!(seed_ratio > 0.95, "seed's CLα̇ σ/prior {seed_ratio}");
    // What it would take: the turbulence, not the sensors, is the limit — a 10× better
    // accelerometer leaves the bound where it is (373 % vs 378 %), still air alone brings it to
    // 30 %, and only still air (σ_w 0.01 m/s) with 10× better sensors reaches the 7.4 % a 5 %
    // median error needs (6.7 % with the designed input, 7.6 % with the paper's).
    let az = requirement(
        Input::PAPER,
        Conditions {
            state_noise: 1.0,
            accelerometer_noise: 0.1,
            turbulence: 1.0,
        },
    );
    assert!(rel(az, CLALPHADOT) > 0.95 * rel(paper, CLALPHADOT));
    let calm_precise = Conditions {
        state_noise: 0.1,
        accelerometer_noise: 0.1,
        turbulence: 0.01,
    };
    let best = requirement(Input::DESIGNED, calm_precise);
    assert!(
        rel(best, CLALPHADOT) < SIGMA_FOR_5_PERCENT_MEDIAN,
        "{:.4}",
        rel(best, CLALPHADOT)
    );
}

#[test]
fn only_the_sum_cm_alphadot_plus_cmq_is_determined() {
    let r = results();
    let paper = &r.bounds[0];
    // GIVEN the bound with the paper's input, WHEN its worst-determined direction (the largest
    // principal axis, scaled to ΔCmα̇ = 1) is compared with the first-order null direction:
    // α̇ = q + (α̇ − q), and α̇ − q = −(q̄S/(mV))(CL0 + CLα α + CLδe δe) + (g/V)cos γ, so raising
    // Cmα̇ by ε and lowering Cmq by ε is cancelled by ΔCmα = ε ĉZα, ΔCmδe = ε ĉZδe
    let predicted = predicted_null_direction();
    let w = paper.worst_direction;
    println!("worst direction {w:?}\npredicted       {predicted:?}");
    // THEN they agree: Cmq −0.998 (−1), Cmα 0.003315 (ĉZα = 0.003277, 1.2 %), Cmδe 0.000372
    // (ĉZδe = 0.000380, 2.1 %), every other component below 2·10⁻⁴ (measured) …
    assert!((w[CMQ] + 1.0).abs() < 0.01, "Cmq {}", w[CMQ]);
    assert!(
        (w[CMALPHA] / predicted[CMALPHA] - 1.0).abs() < 0.03,
        "Cmα {}",
        w[CMALPHA]
    );
    assert!((w[CMDE] / predicted[CMDE] - 1.0).abs() < 0.05, "Cmδe {}", w[CMDE]);
    for j in [CL0, CLALPHA, CLALPHADOT, CLDE, CM0] {
        assert!(w[j].abs() < 5e-4, "{} {}", NAMES[j], w[j]);
    }
    // … so the elevator records determine Cmα̇ + Cmq (σ_CRB 9.0 % and 8.0 %) but not each
    // (1 580 % and 606 % with the paper's input, 336 % and 128 % with the designed one;
    // correlation −0.9998 and −0.9963).
    for b in [
        paper,
        r.bounds.iter().find(|b| b.input == Input::DESIGNED).expect("designed"),
    ] {
        let sum = (TRUE[CMALPHADOT] + TRUE[CMQ]).abs();
        assert!(
            b.sigma_cm_damping_sum / sum < 0.10,
            "sum {}",
            b.sigma_cm_damping_sum / sum
        );
        assert!(rel(b, CMALPHADOT) > 3.0 && rel(b, CMQ) > 1.0, "{:?}", b.sigma);
        assert!(b.corr_cmalphadot_cmq < -0.995, "ρ {}", b.corr_cmalphadot_cmq);
    }
    // What it would take: a second-order effect separates them (the speed and flight-path changes
    // of a slow input), so even still air with 10× better sensors leaves Cmα̇ at 9.0 % with the
    // designed input (Cmq 3.4 %) and 192 % with the paper's. A 5 % Cmα̇ needs α̇ excited apart from
    // q and α: a control that makes lift without moment (direct-lift flaps), not an elevator.
    let calm_precise = Conditions {
        state_noise: 0.1,
        accelerometer_noise: 0.1,
        turbulence: 0.01,
    };
    let best = requirement(Input::DESIGNED, calm_precise);
    assert!(
        rel(best, CMALPHADOT) > SIGMA_FOR_5_PERCENT_MEDIAN,
        "{:.4}",
        rel(best, CMALPHADOT)
    );
    assert!(rel(best, CMQ) < SIGMA_FOR_5_PERCENT_MEDIAN, "{:.4}", rel(best, CMQ));
    assert!(rel(requirement(Input::PAPER, calm_precise), CMALPHADOT) > 1.0);
}

#[test]
fn the_designed_input_minimises_the_bound_of_the_scan() {
    let r = results();
    // GIVEN 1° 3-2-1-1 inputs of every unit in the scan, all 30 s long
    let scan = &r.bounds[1..];
    let product = |b: &Bound| b.sigma[CMALPHADOT] * b.sigma[CMQ];
    // WHEN the one with the smallest σ_CRB(Cmα̇)·σ_CRB(Cmq) is picked
    let best = scan
        .iter()
        .min_by(|a, b| product(a).total_cmp(&product(b)))
        .expect("scan");
    // THEN it is Input::DESIGNED (4 s units: the slowest that fits the record — the separation
    // comes from the speed and flight-path changes of slow inputs), and it shrinks the product
    // 22-fold against the paper's input (measured 30.6 vs 679)
    assert_eq!(
        best.input,
        Input::Multistep3211 {
            step_s: DESIGNED_STEP_S,
            amplitude_rad: 0.0175
        }
    );
    assert!(
        product(best) < 0.1 * product(&r.bounds[0]),
        "{} vs {}",
        product(best),
        product(&r.bounds[0])
    );
    // … at a similar load: peak |Δa_z| 7.9 m/s² vs 5.7 m/s² (measured, with turbulence).
    assert!(best.peak_delta_az_mps2 < 1.5 * r.bounds[0].peak_delta_az_mps2);
}

#[test]
fn batch_sigma_is_honest() {
    for input in [PAPER_INPUT, DESIGNED_INPUT] {
        let s = summary(input, Method::Batch);
        // GIVEN 50 runs of the batch method, WHEN each data-determined parameter's normalised
        // error z = (p̂ − p)/σ is pooled, THEN √(mean z²) is within 1 ± 0.3 (for honest σ its
        // 50-run sampling σ is 1/√100 = 0.1; measured 0.88–1.24, CLα and Cmα highest, which the
        // Kalman gain held fixed in the propagated sensitivity may account for) and each is within
        // 2σ in ≥ 43 runs
        // (binomial 95.4 % of 50 less three of its σ of 1.5 runs; measured 45–50) …
        for j in DATA_DETERMINED {
            assert!(
                (0.7..=1.3).contains(&s.rms_z[j]),
                "input {input}: {} rms z {:.2}",
                NAMES[j],
                s.rms_z[j]
            );
            assert!(
                s.per_param_within_2sigma[j] >= 43,
                "{} {}",
                NAMES[j],
                s.per_param_within_2sigma[j]
            );
        }
        // … and all nine are within 2σ as often as honest σ predicts: 40/50 and 41/50 against
        // 76 % and 77 % (within three binomial σ of 6 points). Honest σ on nine parameters cannot
        // give the required 90 %: the expectation itself is below 85 %.
        let observed = s.all_within_2sigma as f64 / s.runs as f64;
        let e = s.expected_all_within_2sigma;
        let sd = (e * (1.0 - e) / s.runs as f64).sqrt();
        assert!((observed - e).abs() < 3.0 * sd, "observed {observed} vs expected {e}");
        assert!(e < 0.85, "expected {e}");
        assert_eq!(s.runs as u64, RUNS, "every run converged");
    }
}

#[test]
fn one_recursive_pass_overstates_the_information_on_cl0_and_cm0() {
    for input in [PAPER_INPUT, DESIGNED_INPUT] {
        let (rec, batch) = (summary(input, Method::Recursive), summary(input, Method::Batch));
        // GIVEN the same filter run once recursively (on board) and to convergence in batch
        // THEN the recursive σ of CL0 and Cm0 is too small by ≈ 2.4 (rms z 2.36–2.47, measured):
        // the data cannot tell CL0, Cm0 from the record's mean vertical gust (ΔCL0 = CLα w̄/V,
        // ΔCm0 = Cmα w̄/V), and the recursion sums the information along its path, linearised at
        // estimates where that direction looks better determined; the batch method's one
        // linearisation point gives 0.88–0.95 …
        for j in [CL0, CM0] {
            assert!(
                rec.rms_z[j] > 1.8,
                "input {input}: recursive {} rms z {:.2}",
                NAMES[j],
                rec.rms_z[j]
            );
            assert!(
                batch.rms_z[j] < 1.3,
                "input {input}: batch {} rms z {:.2}",
                NAMES[j],
                batch.rms_z[j]
            );
            assert!(rec.spread[j] > 1.8 * rec.mean_sigma[j]);
        }
        // … while its other data-determined σ are within 45 % (rms z 0.86–1.38) and its median
        // errors within 1.5 points of the batch method's.
        for j in [CLALPHA, CLDE, CMALPHA, CMDE] {
            assert!(rec.rms_z[j] < 1.45, "{} {:.2}", NAMES[j], rec.rms_z[j]);
        }
        for j in DATA_DETERMINED.into_iter().filter(|&j| j != CM0) {
            let d = (rec.median_abs_rel_error[j] - batch.median_abs_rel_error[j]).abs();
            assert!(d < 0.015, "{}: {d}", NAMES[j]);
        }
    }
}

#[test]
fn the_papers_method_reproduces_table_1_and_ours_beats_it() {
    let t = &TRUE;
    for input in [PAPER_INPUT, DESIGNED_INPUT] {
        let (paper, ours) = (summary(input, Method::Paper), summary(input, Method::Recursive));
        // GIVEN the paper's method (white process noise, one-step sensitivity, states measured)
        // THEN Cmα̇ stays at its prior as in the seed (posterior mean σ ≥ 0.9 of the prior σ; the
        // seed's 0.481 is its prior 0.475), and the coloured turbulence taken as white makes its
        // Cm σ dishonest (rms z of Cmα 4.2 with either input, measured) …
        let prior_sigma = |j: usize| prior().1[(j, j)].sqrt();
        assert!(paper.mean_sigma[CMALPHADOT] > 0.9 * prior_sigma(CMALPHADOT));
        assert!(Longitudinal::<f64>::TABLE1_SEED_SIGMA[CMALPHADOT] > 0.95 * prior_sigma(CMALPHADOT));
        assert!(paper.rms_z[CMALPHA] > 3.0, "{}", paper.rms_z[CMALPHA]);
        // … and ours on board (one pass, the same cost class) has the smaller median error on
        // every parameter the data determine and on Cmq (paper's input: CLα 21.4 → 2.1 %, CLδe
        // 23.3 → 6.6 %, Cmα 13.6 → 2.1 %, Cmq 10.4 → 7.2 %, Cmδe 6.6 → 0.8 %; measured).
        for j in [CL0, CLALPHA, CLDE, CMALPHA, CMQ, CMDE] {
            assert!(
                ours.median_abs_rel_error[j] < paper.median_abs_rel_error[j],
                "input {input}: {} ours {} paper {}",
                NAMES[j],
                ours.median_abs_rel_error[j],
                paper.median_abs_rel_error[j]
            );
        }
        // The seed's Table 1 is one run; against its errors ours beats Cmq (13.7 %: ours 7.2 and
        // 7.1 %) and on the sum Cmα̇ + Cmq the data determine (median error 2.1 % and 1.0 %, the
        // seed's 5.6 %), while Cmα̇ (ours 18–19 %, the seed 15.5 %) and CLα̇ (ours 21 %, the seed 28.8 %,
        // Table 1's initial value 20.7 % off) are the prior's.
        let seed_cmq = ((Longitudinal::<f64>::TABLE1_SEED[CMQ] - t[CMQ]) / t[CMQ]).abs();
        assert!(ours.median_abs_rel_error[CMQ] < seed_cmq);
        assert!(
            ours.median_abs_rel_error_cm_damping_sum < 0.03,
            "{}",
            ours.median_abs_rel_error_cm_damping_sum
        );
    }
}

#[test]
fn the_filter_error_method_beats_equation_error_where_the_states_must_be_filtered() {
    for input in [PAPER_INPUT, DESIGNED_INPUT] {
        let (fem, ee) = (summary(input, Method::Batch), summary(input, Method::EquationError));
        // GIVEN the same flights through seed 000's equation-error PCA-GTLS (C_L from a_z, C_m from
        // the differenced q, α̇ from the differenced α, the inertial α as regressor)
        // THEN the filter error method has the smaller median error on every slope and on Cmq
        // (paper's input: CLα 2.4 vs 9.5 %, Cmα 2.4 vs 7.6 %, Cmδe 0.7 vs 6.9 %, Cmq 7.9 vs 12.3 %;
        // designed: CLα 1.6 vs 42.5 %; measured): the aerodynamics see α + w_g/V while the
        // regressor is the inertial α — an error of σ_w/V ≈ 0.004 rad, coloured and not in the
        // equation-error weighting — and α̇, q̇ differenced from noisy samples are noisy regressors;
        // the filter models the gusts as states …
        for j in [CLALPHA, CLALPHADOT, CLDE, CMALPHA, CMALPHADOT, CMQ, CMDE] {
            assert!(
                fem.median_abs_rel_error[j] < ee.median_abs_rel_error[j],
                "input {input}: {} FEM {} EE {}",
                NAMES[j],
                fem.median_abs_rel_error[j],
                ee.median_abs_rel_error[j]
            );
        }
        // … while the intercepts, read straight off a_z and q̇ averaged over the record, are as
        // good either way (CL0 1.2 vs 2.1 % and 0.9 vs 0.7 %; Cm0 within a factor two)
        for j in [CL0, CM0] {
            let ratio = ee.median_abs_rel_error[j] / fem.median_abs_rel_error[j];
            assert!((0.5..2.0).contains(&ratio), "{} EE/FEM {ratio}", NAMES[j]);
        }
        // … and the PCA threshold (seed 000, eq. 21) finds the Cmα̇/Cmq direction unexcited in
        // every run, so it gives no σ there (eq. 17 does not apply): the same finding as the bound.
        assert!(ee.mean_sigma[CMQ].is_nan() && ee.per_param_within_2sigma[CMQ] == 0);
    }
}
