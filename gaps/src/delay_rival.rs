//! A named sensor delay's error as the rival of the aerodynamic candidates.
//!
//! ## Why
//! A sensor delay named by the compatibility check ([`crate::compat`], for the vanes in turbulence
//! by instrumental variables, [`crate::instrumental`]) is removed from the data before the
//! aerodynamics, at its estimate `τ̂`. The estimate has an error of the order of its `σ_τ`; what
//! is left, `α(t − δτ)` in place of `α(t)`, reaches every coefficient whose synthesis or baseline
//! uses the channel (`C_L`, `C_D` through the rotation into wind axes and the α terms, `C_m`
//! through its α term) as `−δτ·(∂r/∂τ)`, a column that no baseline term holds. A bias's residual
//! is absorbed by the constant term and a scale factor's by the channel's own slope (`C_Lα/(1+k)`);
//! a delay's is not, so the candidates compete for it. **Measured** on the campaign's flight
//! `--simulate time-delay --seed 20008 --size 0.1432` (a planted α-vane delay of 0.143 s): the
//! instrumental estimate is 0.124 ± 0.007 s (the same test on the same turbulence with no delay
//! gives −0.019 ± 0.006 s: this flight's gusts, not a bias of the method, 20020's 0.1175 s is found
//! as 0.1177 s); uncorrected, the delay is fitted by `ΔV/V` in `C_L` and `C_m` at `t²` 320 and
//! 324; corrected at `τ̂`, the 0.02 s left is still named as `ΔV/V` in both (`t²` 20 and 40) — an
//! aerodynamic cause on a flight whose only effect is a sensor's.
//!
//! ## Rule
//! Two steps, both only for a delay named and removed, of a channel the synthesis takes from
//! the corrected sensor (not when the air data replace it).
//!
//! 1. **The delay removed is refined within the sensor test's interval** ([`refine`]): on a
//!    grid of `σ_τ/2` over `τ̂ ± 3σ_τ`, the delay that minimises `Σ_i (n/2)·ln RSS_i` of the
//!    baselines' least-squares fits (the profile likelihood of the delay from the aerodynamic
//!    equations, each coefficient with its own noise level). The equations carry most of the
//!    delay's information (uncorrected, `t²` above 300 in `C_L` and `C_m` on the flight above,
//!    against 210 for the instruments), but they alone would move the delay to absorb any
//!    aerodynamic effect that looks like it; the instruments' interval bounds that. The named
//!    delay keeps the sensor test's value; a note gives the value removed.
//! 2. **The delay's rival** in coefficient `i` is the change of the baseline's residual
//!    `r = z − Xθ̂` when the delay moves by `±3σ_τ` around the value removed,
//!    `r(τ + 3σ_τ) − r(τ − 3σ_τ)`, the table synthesised again at both delays with everything
//!    else as in the analysis and `θ̂` the baseline's least-squares fit on the identification
//!    samples (the effect on the equation of a delay error over the interval the estimate leaves
//!    open, output and regressors both). It enters the candidate tests as a nuisance column
//!    beside the gust proxies ([`crate::gust::Beyond`], Frisch–Waugh–Lovell): a candidate's
//!    `t²` and held-out gain count only what it predicts beyond an error of the delay, so a
//!    candidate that fits only that error is not named, and the coefficient's note names the
//!    delay. The rival is never named itself; none is built for a coefficient the delay does
//!    not change (the lateral ones for an α delay).
//!
//! **Measured** on the flight above: at `τ̂` with the rival, `C_L`'s `ΔV/V` falls to `t²` 8 and
//! `C_m`'s stays at 27 (named); removed at the exact 0.143 s, `C_m`'s is at 12 (`t²` threshold
//! 18.4); refined, the delay is removed at 0.135 s and nothing aerodynamic is named. On 20020
//! (0.1175 s, found as 0.1177 s) the refinement removes 0.1095 s and nothing aerodynamic is named
//! either. **Reading chosen**: one rival column per coefficient; a second (the secant from the
//! data as logged) made the pair span the second derivative of the residual, which resembles
//! the elevator rate, and `δė` was named on 20020 in `C_L` at `t²` 55.

use crate::compat::{Compatibility, SensorParam};
use crate::io::measured::{MeasuredFlight, Quantity};
use crate::model::{self, Corrections, Table, Term, TermRefs, COEFFICIENTS};
use crate::regress;
use std::collections::BTreeMap;

/// The delay rivals of a flight, `(coefficient, column)` as [`crate::gust::Beyond`] takes them,
/// and a note per coefficient that has one.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rivals {
    /// `(coefficient index, column over every sample)`, centred and of unit RMS on the
    /// identification samples.
    pub columns: Vec<(usize, Vec<f64>)>,
    /// `(coefficient index, note)`: which delay its candidates were tested beyond.
    pub notes: Vec<(usize, String)>,
}

/// The flight as the analysis sees it: its samples, its analysis rate, the compatibility
/// check's findings, the air data replacing sensors (if any), the smoothing half-width, the
/// baselines and the identification samples (the first `n_id`).
#[derive(Clone, Copy)]
pub struct Flight<'a> {
    pub flight: &'a MeasuredFlight,
    pub h_s: f64,
    pub compatibility: &'a Compatibility,
    pub air: Option<&'a BTreeMap<Quantity, Vec<f64>>>,
    pub sg_half: usize,
    pub baselines: &'a [Vec<Term>; 6],
    pub n_id: usize,
}

/// What the rivals are built from: the flight, the corrections applied, the table at them and
/// its references.
pub struct Inputs<'a> {
    pub on: Flight<'a>,
    pub corr: &'a Corrections,
    pub table: &'a Table,
    pub refs: &'a TermRefs,
}

/// The half-width of the interval, in the delay's standard errors, within which the aerodynamic
/// baselines refine the delay removed ([`refine`]).
const REFINE_SIGMAS: f64 = 3.0;
/// Steps of the refinement's grid per standard error.
const REFINE_STEPS_PER_SIGMA: f64 = 2.0;

/// Each delay named and removed, refined within `±3σ_τ` of its estimate by the aerodynamic
/// baselines: the delay removed is the one on a grid of `σ_τ/2` that minimises
/// `Σ_i (n/2)·ln RSS_i`, the baselines' least-squares residuals on the identification samples
/// (each coefficient with its own noise level: the profile likelihood of the delay from the
/// aerodynamic equations), over the coefficients the delay changes. The sensor test's interval
/// bounds it, so no aerodynamic effect can move the delay further than the sensor's own data
/// allow; within it, the equations that carry most of the delay's information decide. Changes
/// `corr` and returns a note; `None` when no delay was named or none moved.
pub fn refine(on: &Flight, corr: &mut Corrections) -> Option<String> {
    if below_equation_error_rate(on.h_s) {
        return None;
    }
    let Flight {
        flight,
        h_s,
        compatibility,
        air,
        sg_half,
        baselines,
        n_id,
    } = *on;
    let mut notes = Vec::new();
    for f in &compatibility.found {
        let SensorParam::Delay(q) = f.param else { continue };
        let Some(&tau) = corr.delay_s.get(&q) else { continue };
        if air.is_some_and(|a| a.contains_key(&q)) || !(f.sigma.is_finite() && f.sigma > 0.0) {
            continue;
        }
        let k_max = (REFINE_SIGMAS * REFINE_STEPS_PER_SIGMA).round() as i64;
        let step = f.sigma / REFINE_STEPS_PER_SIGMA;
        let mut best: Option<(f64, f64)> = None;
        for k in -k_max..=k_max {
            let t = tau + k as f64 * step;
            if !f.param.plausible(t) {
                continue;
            }
            let mut c = corr.clone();
            c.delay_s.insert(q, t);
            let table = model::synthesise(flight, h_s, &c, sg_half, air);
            let Some(cost) = profile_cost(&table, baselines, n_id) else {
                continue;
            };
            if best.is_none_or(|(_, b)| cost < b) {
                best = Some((t, cost));
            }
        }
        let Some((t, _)) = best else { continue };
        if t != tau {
            corr.delay_s.insert(q, t);
            // At the interval's edge the baselines would move the delay further than the
            // sensor's data allow: either its σ is too small or an aerodynamic term looks like a
            // delay. Say so; the rivals then test how far the residual points.
            let edge = if ((t - tau) / step).round().abs() as i64 >= k_max {
                " — at the interval's edge: the baselines would move it further than the sensor test allows (its σ too small, or an aerodynamic term such as α̇ that looks like a delay)"
            } else {
                ""
            };
            notes.push(format!(
                "{} removed at {t:.4} s, not at the estimate {tau:.4} ± {:.4} s: within ±{REFINE_SIGMAS}σ of it, the delay that best fits the aerodynamic baselines (their profile likelihood, docs/model-gaps.md){edge}",
                f.param.name(),
                f.sigma
            ));
        }
    }
    (!notes.is_empty()).then(|| notes.join("; "))
}

/// `Σ_i (n/2)·ln RSS_i` of the baselines' least-squares fits on the first `n_id` samples of
/// `table`, over every coefficient synthesised with all its baseline columns.
fn profile_cost(table: &Table, baselines: &[Vec<Term>; 6], n_id: usize) -> Option<f64> {
    let refs = TermRefs::of_identification(table, n_id);
    let mut cost = 0.0;
    let mut any = false;
    for (i, terms) in baselines.iter().enumerate() {
        let Some(z) = table.z[i].as_ref() else { continue };
        let Some(cols) = terms.iter().map(|t| t.column(table, &refs)).collect::<Option<Vec<_>>>() else {
            continue;
        };
        let n = n_id.min(z.len());
        let id: Vec<Vec<f64>> = cols.iter().map(|c| c[..n].to_vec()).collect();
        let Some(theta) = regress::ols_theta(&id, &z[..n]) else {
            continue;
        };
        let rss: f64 = (0..n)
            .map(|k| (z[k] - id.iter().zip(&theta).map(|(c, t)| c[k] * t).sum::<f64>()).powi(2))
            .sum();
        if rss > 0.0 && rss.is_finite() {
            cost += 0.5 * n as f64 * rss.ln();
            any = true;
        }
    }
    any.then_some(cost)
}

/// The half-width of the delay's interval the rival spans, in the delay's standard errors.
const SPAN_SIGMAS: f64 = 3.0;

/// The rivals of every delay named and removed ([`Rivals`]); empty when none was.
pub fn rivals(inp: &Inputs) -> Rivals {
    let mut out = Rivals::default();
    if below_equation_error_rate(inp.on.h_s) {
        return out;
    }
    for f in &inp.on.compatibility.found {
        let SensorParam::Delay(q) = f.param else { continue };
        let Some(&tau) = inp.corr.delay_s.get(&q) else { continue };
        if inp.on.air.is_some_and(|a| a.contains_key(&q)) {
            continue;
        }
        let step = if f.sigma.is_finite() && f.sigma > 0.0 {
            SPAN_SIGMAS * f.sigma
        } else {
            inp.on.h_s
        };
        let at = |d: f64| {
            let mut c = inp.corr.clone();
            c.delay_s.insert(q, tau + d);
            model::synthesise(inp.on.flight, inp.on.h_s, &c, inp.on.sg_half, inp.on.air)
        };
        let (plus, minus) = (at(step), at(-step));
        for i in 0..6 {
            let bound = Bound {
                step_s: step,
                estimate_s: f.value,
                removed_from_estimate_s: tau - f.value,
            };
            let note = match rival_column(i, inp, &plus, &minus, bound) {
                None => continue,
                Some(Rival::Column(c)) => {
                    out.columns.push((i, c));
                    format!(
                        "{}: candidates tested beyond an error of the {} removed at {tau:.4} s, up to ±{step:.4} s ({SPAN_SIGMAS}σ; the baseline's change with the delay, docs/model-gaps.md): a candidate that only fits what the delay's estimate left is not named",
                        COEFFICIENTS[i],
                        f.param.name()
                    )
                }
                Some(Rival::Beyond { implied_s }) => format!(
                    "{}: candidates tested without the {}'s rival: the residual along the delay's direction would take a delay of {implied_s:.4} s, outside the sensor test's {:.4} ± {step:.4} s — more than the delay's error can leave, so an aerodynamic term may be what fits it (docs/model-gaps.md)",
                    COEFFICIENTS[i],
                    f.param.name(),
                    f.value
                ),
            };
            out.notes.push((i, note));
        }
    }
    out
}

/// The least change of a coefficient's baseline residual over the delay's interval, relative to
/// the residual's RMS, for which a rival is built: a smaller change cannot carry a candidate's
/// test.
const RELEVANT: f64 = 1e-3;

/// What bounds a rival: the half-width of the delay's interval (`3σ_τ`), the sensor test's
/// estimate and how far the delay removed lies from it (the refinement's move).
#[derive(Clone, Copy)]
struct Bound {
    step_s: f64,
    estimate_s: f64,
    removed_from_estimate_s: f64,
}

/// A coefficient's rival, or why it has none although the delay changes it.
enum Rival {
    /// The rival column ([`Rivals::columns`]).
    Column(Vec<f64>),
    /// The baseline's residual along the delay's direction implies a delay of `implied_s`,
    /// further from the sensor test's estimate than its interval: a free nuisance column would
    /// take more than the delay's error can leave (an `α̇` term, say, whatever its size), so the
    /// coefficient's candidates are tested without it.
    Beyond { implied_s: f64 },
}

/// Coefficient `i`'s rival, `r(plus) − r(minus)` with `r = z − Xθ̂` and `θ̂` fitted on the
/// identification samples of `inp.table` (at `τ̂`), centred and scaled to unit RMS there. `None`
/// when the coefficient or a baseline column is missing, or the delay does not change the
/// coefficient (the change below [`RELEVANT`] of the baseline's residual RMS: the lateral
/// coefficients for an α delay).
///
/// **The bound.** With `g = (r(τ + s) − r(τ − s))/(2s) ≈ ∂r/∂τ`, the residual at the delay
/// removed is `r(τ) ≈ e + (τ − τ*)·g` for a true delay `τ*`, so its least-squares coefficient on
/// `g` estimates `τ − τ*`. When the delay this implies lies further from the sensor test's
/// estimate than three standard errors of the difference (the sensor test's and this fit's), the
/// residual along `g` is larger than a delay error the data allow: [`Rival::Beyond`].
fn rival_column(i: usize, inp: &Inputs, plus: &Table, minus: &Table, bound: Bound) -> Option<Rival> {
    let terms = &inp.on.baselines[i];
    let cols = |t: &Table| -> Option<Vec<Vec<f64>>> { terms.iter().map(|term| term.column(t, inp.refs)).collect() };
    let z = inp.table.z[i].as_ref()?;
    let x = cols(inp.table)?;
    let n = z.len();
    let n_fit = inp.on.n_id.min(n);
    let id: Vec<Vec<f64>> = x.iter().map(|c| c[..n_fit].to_vec()).collect();
    let theta = regress::ols_theta(&id, &z[..n_fit])?;
    let resid = |t: &Table| -> Option<Vec<f64>> {
        let (z, x) = (t.z[i].as_ref()?, cols(t)?);
        (z.len() == n).then(|| {
            (0..n)
                .map(|k| z[k] - x.iter().zip(&theta).map(|(c, th)| c[k] * th).sum::<f64>())
                .collect()
        })
    };
    let r0 = resid(inp.table)?;
    let (rp, rm) = (resid(plus)?, resid(minus)?);
    let d: Vec<f64> = rp.iter().zip(&rm).map(|(a, b)| a - b).collect();
    let column = unit_rms(d.clone(), n_fit, RELEVANT * rms(&r0[..n_fit]))?;
    match implied_delay_offset(&d[..n_fit], &r0[..n_fit], bound) {
        Some((off, se)) if off.abs() > SPAN_SIGMAS * se => Some(Rival::Beyond {
            implied_s: bound.estimate_s + off,
        }),
        _ => Some(Rival::Column(column)),
    }
}

/// How far from the sensor test's estimate the delay lies that the residual `r0` implies along
/// `d = r(τ + s) − r(τ − s)`, `(τ − τ̂) − c` with `c` the least-squares coefficient of the
/// centred `r0` on the centred `g = d/(2s)`, and that offset's standard error with both
/// uncertainties, `√(σ_τ² + σ_c²)` (`σ_τ = s/3`, `σ_c` the least-squares σ of `c`). `None` when `g`
/// has no variation.
fn implied_delay_offset(d: &[f64], r0: &[f64], bound: Bound) -> Option<(f64, f64)> {
    let n = d.len().min(r0.len());
    if n < 3 || !bound.step_s.is_finite() || bound.step_s <= 0.0 {
        return None;
    }
    let g: Vec<f64> = d[..n].iter().map(|v| v / (2.0 * bound.step_s)).collect();
    let (mg, mr) = (g.iter().sum::<f64>() / n as f64, r0[..n].iter().sum::<f64>() / n as f64);
    let (mut gg, mut gr) = (0.0, 0.0);
    for k in 0..n {
        gg += (g[k] - mg) * (g[k] - mg);
        gr += (g[k] - mg) * (r0[k] - mr);
    }
    let c = gr / gg;
    if !(gg > 0.0 && c.is_finite()) {
        return None;
    }
    let rss: f64 = (0..n).map(|k| (r0[k] - mr - c * (g[k] - mg)).powi(2)).sum();
    let var_c = rss / (n - 2) as f64 / gg;
    let sigma_tau = bound.step_s / SPAN_SIGMAS;
    let se = (sigma_tau * sigma_tau + var_c).sqrt();
    se.is_finite().then_some((bound.removed_from_estimate_s - c, se))
}

/// Whether the data are below the rate the equation-error baselines need
/// ([`crate::io::quality::MIN_RATE_HZ`]): there the low-rate path fits the coefficients by output
/// error from the table as corrected, and neither the refinement nor the rivals (both built on
/// equation-error fits that cannot resolve a delay there) run.
fn below_equation_error_rate(h_s: f64) -> bool {
    !(h_s > 0.0 && 1.0 / h_s >= crate::io::quality::MIN_RATE_HZ)
}

/// RMS of `x` about its mean.
fn rms(x: &[f64]) -> f64 {
    let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// `d` centred and scaled to unit RMS on its first `n_fit` samples; `None` when not finite, or
/// not above `floor` there.
fn unit_rms(d: Vec<f64>, n_fit: usize, floor: f64) -> Option<Vec<f64>> {
    if n_fit < 2 || d.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mean = d[..n_fit].iter().sum::<f64>() / n_fit as f64;
    let s = rms(&d[..n_fit]);
    (s > floor && s > 0.0).then(|| d.iter().map(|v| (v - mean) / s).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compat::Found;
    use crate::hidden::{self, HiddenEffect, HiddenKind};
    use crate::model::Signal;

    /// A 30 s turbulent simulated flight whose α vane lags by 0.12 s (the campaign's
    /// `time-delay` kind; 100 Hz).
    fn delayed_flight() -> MeasuredFlight {
        let effect = HiddenEffect {
            kind: HiddenKind::TimeDelay,
            size: 0.12,
            channel: None,
        };
        hidden::flight(Some(&effect), 30.0, 7, true).expect("the simulator flies")
    }

    /// The rivals of `table` with the α delay named as `tau ± 0.007 s` and removed at `tau`
    /// (the campaign's worst instrumental σ), the campaign's baselines.
    fn rivals_at(
        flight: &MeasuredFlight,
        sg_half: usize,
        n_id: usize,
        table: &Table,
        refs: &TermRefs,
        tau: f64,
    ) -> Rivals {
        let baselines = HiddenEffect::baseline(None);
        let compatibility = found_delay(tau, 0.007);
        let mut corr = Corrections::default();
        corr.delay_s.insert(Quantity::Alpha, tau);
        rivals(&Inputs {
            on: Flight {
                flight,
                h_s: 0.01,
                compatibility: &compatibility,
                air: None,
                sg_half,
                baselines: &baselines,
                n_id,
            },
            corr: &corr,
            table,
            refs,
        })
    }

    /// The compatibility check's finding `delay(α) = tau ± sigma`.
    fn found_delay(tau: f64, sigma: f64) -> Compatibility {
        Compatibility {
            found: vec![Found {
                param: SensorParam::Delay(Quantity::Alpha),
                value: tau,
                sigma,
                t2: (tau / sigma).powi(2),
                part: "instrumental",
                cv_gain_z: 5.0,
                cv_gain: 0.1,
                why: String::new(),
            }],
            ..Compatibility::default()
        }
    }

    /// The delayed flight, the smoothing half-width, the identification samples (the first 60 %)
    /// and the table with the delay removed at `tau`.
    fn fixture(tau: f64) -> (MeasuredFlight, usize, usize, Table) {
        let flight = delayed_flight();
        let (sg_half, n_id) = (10, flight.len() * 3 / 5);
        let table = table_at(&flight, tau, sg_half);
        (flight, sg_half, n_id, table)
    }

    /// The table with the α delay removed at `tau`.
    fn table_at(flight: &MeasuredFlight, tau: f64, sg_half: usize) -> Table {
        let mut corr = Corrections::default();
        corr.delay_s.insert(Quantity::Alpha, tau);
        model::synthesise(flight, 0.01, &corr, sg_half, None)
    }

    /// The baseline residual of coefficient `i` on `table` with `theta` fitted on `fit_on`.
    fn residual(i: usize, terms: &[Term], fit_on: &Table, table: &Table, refs: &TermRefs, n_id: usize) -> Vec<f64> {
        let cols =
            |t: &Table| -> Vec<Vec<f64>> { terms.iter().map(|term| term.column(t, refs).expect("column")).collect() };
        let (x0, x) = (cols(fit_on), cols(table));
        let z0 = fit_on.z[i].as_ref().expect("synthesised");
        let id: Vec<Vec<f64>> = x0.iter().map(|c| c[..n_id].to_vec()).collect();
        let theta = regress::ols_theta(&id, &z0[..n_id]).expect("fits");
        let z = table.z[i].as_ref().expect("synthesised");
        (0..z.len())
            .map(|k| z[k] - x.iter().zip(&theta).map(|(c, t)| c[k] * t).sum::<f64>())
            .collect()
    }

    fn correlation(a: &[f64], b: &[f64]) -> f64 {
        let (ma, mb) = (
            a.iter().sum::<f64>() / a.len() as f64,
            b.iter().sum::<f64>() / b.len() as f64,
        );
        let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
        for (x, y) in a.iter().zip(b) {
            sab += (x - ma) * (y - mb);
            saa += (x - ma).powi(2);
            sbb += (y - mb).powi(2);
        }
        sab / (saa * sbb).sqrt()
    }

    #[test]
    fn an_under_corrected_vane_delay_leaves_the_rivals_direction_in_the_longitudinal_coefficients_only() {
        // GIVEN a flight whose α vane lags by 0.12 s, the delay named as 0.10 ± 0.007 s (the
        // error and σ of the campaign's worst instrumental estimate) and removed at that value
        let (flight, sg_half, n_id, table) = fixture(0.10);
        let alpha = table.signals.get(&Signal::Alpha).expect("α");
        let refs = TermRefs {
            alpha_break_rad: 0.1,
            airspeed_mps: table
                .signals
                .get(&Signal::Airspeed)
                .map_or(20.0, |v| v.iter().sum::<f64>() / v.len() as f64),
            mach: 0.0,
        };
        assert!(alpha.iter().all(|a| a.is_finite()));
        // WHEN the rivals are built
        let r = rivals_at(&flight, sg_half, n_id, &table, &refs, 0.10);
        // THEN C_L, C_D and C_m have one (the delay reaches them through the synthesis's wind
        // axes and their α terms), the lateral coefficients none, and each has its note
        let with: Vec<usize> = r.columns.iter().map(|(i, _)| *i).collect();
        assert_eq!(with, vec![0, 1, 4], "{:?}", r.notes);
        assert_eq!(r.notes.len(), 3);
        assert!(
            r.notes[0]
                .1
                .contains("delay(Alpha) removed at 0.1000 s, up to ±0.0210 s"),
            "{}",
            r.notes[0].1
        );
        // AND the residual the under-correction leaves — the baseline's residual at the true
        // delay minus the one at the estimate, θ̂ fitted at the estimate — lies mostly along the
        // rival: correlation above 0.85 in each coefficient (measured 0.89 in C_L; the rival is
        // the symmetric change over ±0.021 s, the error the one-sided 0.02 s, and they differ by
        // the residual's curvature in the delay and by the vane noise the shifts move)
        let baselines = HiddenEffect::baseline(None);
        let truth = table_at(&flight, 0.12, sg_half);
        let corr_of: Vec<(usize, f64)> = r
            .columns
            .iter()
            .map(|(i, col)| {
                let left: Vec<f64> = residual(*i, &baselines[*i], &table, &truth, &refs, n_id)
                    .iter()
                    .zip(residual(*i, &baselines[*i], &table, &table, &refs, n_id))
                    .map(|(a, b)| a - b)
                    .collect();
                (*i, correlation(&left, col))
            })
            .collect();
        assert!(corr_of.iter().all(|(_, c)| *c > 0.85), "{corr_of:?}");
    }

    #[test]
    fn a_residual_along_the_delay_larger_than_its_interval_allows_gets_no_rival() {
        // GIVEN the delayed flight with its delay removed at the truth (0.12 ± 0.007 s), and a
        // pitching moment that also holds an α̇ term, −0.1 s·α̇ (C_mα̇ ≈ −10 at c̄/2V ≈ 0.01 s):
        // along the delay's direction that is a delay error of ≈ 0.08 s, four times the interval
        let (flight, sg_half, n_id, mut table) = fixture(0.12);
        let alpha = table.signals.get(&Signal::Alpha).expect("α").clone();
        let n = alpha.len();
        let alpha_dot = |k: usize| (alpha[(k + 1).min(n - 1)] - alpha[k.saturating_sub(1)]) / 0.02;
        let cm = table.z[4].as_mut().expect("C_m");
        for (k, z) in cm.iter_mut().enumerate() {
            *z -= 0.1 * alpha_dot(k);
        }
        let refs = TermRefs {
            alpha_break_rad: 0.1,
            airspeed_mps: 20.0,
            mach: 0.0,
        };
        // WHEN the rivals are built
        let r = rivals_at(&flight, sg_half, n_id, &table, &refs, 0.12);
        // THEN C_m's candidates are tested without the rival (its note says why), so an α̇ term
        // stays nameable; C_L keeps its rival
        let with: Vec<usize> = r.columns.iter().map(|(i, _)| *i).collect();
        assert!(!with.contains(&4), "{:?}", r.notes);
        assert!(with.contains(&0), "{:?}", r.notes);
        let cm_note = r
            .notes
            .iter()
            .find(|(i, _)| *i == 4)
            .map(|(_, t)| t.as_str())
            .unwrap_or("");
        assert!(cm_note.contains("without the delay(Alpha)'s rival"), "{:?}", r.notes);
    }

    #[test]
    fn no_rival_without_a_named_delay_or_when_the_air_data_replace_the_channel() {
        // GIVEN the same flight with no delay named, and with the delay named but α taken from
        // the air data (the reconstruction) instead of the vane
        let (flight, sg_half, n_id, table) = fixture(0.0);
        let refs = TermRefs {
            alpha_break_rad: 0.1,
            airspeed_mps: 20.0,
            mach: 0.0,
        };
        let baselines = HiddenEffect::baseline(None);
        let none = Compatibility::default();
        let named = found_delay(0.10, 0.007);
        let mut corr = Corrections::default();
        corr.delay_s.insert(Quantity::Alpha, 0.10);
        let alpha = flight.get(Quantity::Alpha).expect("α").to_vec();
        let air: BTreeMap<Quantity, Vec<f64>> = [(Quantity::Alpha, alpha)].into_iter().collect();
        let inputs = |compatibility, air| Inputs {
            on: Flight {
                flight: &flight,
                h_s: 0.01,
                compatibility,
                air,
                sg_half,
                baselines: &baselines,
                n_id,
            },
            corr: &corr,
            table: &table,
            refs: &refs,
        };
        // WHEN the rivals are built THEN there are none
        assert_eq!(rivals(&inputs(&none, None)), Rivals::default());
        assert_eq!(rivals(&inputs(&named, Some(&air))), Rivals::default());
    }

    #[test]
    fn the_delay_removed_moves_towards_the_truth_within_the_sensor_tests_interval() {
        // GIVEN the flight whose α vane lags by 0.12 s, the delay named as 0.10 ± 0.007 s
        let flight = delayed_flight();
        let (sg_half, n_id) = (10, flight.len() * 3 / 5);
        let baselines = HiddenEffect::baseline(None);
        let compatibility = found_delay(0.10, 0.007);
        let mut corr = Corrections::default();
        corr.delay_s.insert(Quantity::Alpha, 0.10);
        // WHEN the delay is refined by the aerodynamic baselines
        let on = |compatibility| Flight {
            flight: &flight,
            h_s: 0.01,
            compatibility,
            air: None,
            sg_half,
            baselines: &baselines,
            n_id,
        };
        let note = refine(&on(&compatibility), &mut corr);
        // THEN it moves towards the planted 0.12 s (closer than the estimate, within the 3σ
        // interval) and the note says where it was removed
        let tau = corr.delay_s[&Quantity::Alpha];
        assert!(
            (tau - 0.12).abs() < 0.02 && tau <= 0.10 + 3.0 * 0.007 + 1e-12,
            "τ {tau}"
        );
        let note = note.expect("moved");
        assert!(note.contains(&format!("removed at {tau:.4} s")), "{note}");
        // AND with no delay named nothing moves and there is no note
        let mut none = Corrections::default();
        let nothing = Compatibility::default();
        let r = refine(&on(&nothing), &mut none);
        assert!(r.is_none() && none == Corrections::default());
    }
}
