//! Where a candidate means something, and families of rival forms.
//!
//! ## Offering: a candidate only where the current model gives it a meaning
//! Some candidates modify a term of the model rather than add an effect of their own: a surface
//! rate `δ̇` is the first-order term of a delay of the surface, `C_δ·δ(t−τ) ≈ C_δ·δ − C_δτ·δ̇`, so
//! without `δ` in the model it has no delay to stand for (its ratio `τ = −θ_δ̇/θ_δ` has no
//! denominator) and, if it wins, it names a delay of a surface the model does not have. The same
//! holds for the curvature of a curve whose slope is missing (α², α³ and the stall forms without
//! α), a rate of an angle whose term is missing (α̇ without α, β̇ without β) and a product that
//! modulates a derivative the model lacks (α·δa without δa). Each such candidate has a
//! **parent** ([`parent`]): it is offered to a coefficient only while the parent is in the model
//! as it stands (the baseline or a term already added); until then the parent itself is the
//! candidate (a missing `C_n δa` is named `δa`, never a delay of δa). This is the heredity
//! principle of Wu & Hamada, *Experiments*, 2009, §4.6 (weak heredity: a higher-order term only
//! with its lower-order parent), applied to the parent the candidate modifies. Conversely the
//! removal step does not drop a parent while its child stays.
//!
//! Candidates whose meaning is a property of the flight, not of the model, are decided once per
//! flight ([`offered_on_flight`]): a Mach term is offered only when the flight reaches
//! [`MIN_MACH`] (below it compressibility changes a coefficient by less than 5 %, Prandtl–Glauert
//! `1/√(1−M²)`, and `ΔM` is `ΔV/V` scaled by the speed of sound: the same column under another
//! name); the thrust terms only when the thrust is known (the synthesis has no thrust
//! coefficient otherwise, [`super::model::synthesise`]).
//!
//! ## Families of rival forms
//! Some effects have several forms a flight may not separate: a lift curve bending with α is fitted
//! by α², α³, a smooth stall hinge or a stall break; a pitching moment that lags the motion by α̇,
//! q or a delay of the elevator. Within a [`Family`] the forms are ordered, lowest first. When the
//! selection has added one form (so the family passed both entry tests through it), every form
//! that in its place passes the `t²` test competes, and the **lowest-order form wins unless
//! another predicts held-out data better beyond noise** (the selection's own held-out test,
//! [`super::select::Design::noise_gain`] above the critical value, form against form). Every
//! competing form whose held-out prediction the winner does not beat beyond noise is named beside
//! it as a rival the flight cannot separate. Why the lowest order: with equal evidence the simpler curve is the smaller
//! claim (the hierarchy principle again), and a higher form fitted to a quadratic bends where the
//! flight has no data.
//!
//! The square of the elevator deflection follows α² on a flight flown in trim (α moves with δe),
//! so δe² can stand in for a curvature in α: an added δe² gives way to α² when α² is offered,
//! predicts the held-out data neither better nor worse beyond noise in its place, and passes the
//! entry tests itself (a nonlinear lift or moment curve is the physical effect; a quadratic
//! elevator effectiveness in lift or pitching moment has no mechanism at these deflections that a
//! flight of this kind could single out). δe² then shows among the forms the flight cannot
//! separate.

use super::model::{is_longitudinal, Term};
pub use super::model::{offered_on_flight, MIN_MACH};
use super::select::{Design, SubsetFit};

/// The term that must be in a coefficient's current model for `t` to be offered to it (`coef`
/// an index into [`super::model::COEFFICIENTS`]); `None`: no condition on the model.
pub fn parent(t: Term, coef: usize) -> Option<Term> {
    use Term::*;
    match t {
        // A delay of the surface.
        ElevatorRate | AbsElevator | Elevator2 | ThrustElevator | AlphaElevator => Some(Elevator),
        AileronRate | AlphaAileron => Some(Aileron),
        RudderRate => Some(Rudder),
        // The curvature of the curve whose slope is α.
        Alpha2 | Alpha3 | StallBreak | StallHinge | AlphaDot => Some(Alpha),
        // β³ and β̇ modify the β derivative; β², |β| in a longitudinal coefficient are the even
        // effect of sideslip on a symmetric aircraft, whose β term is zero.
        Beta3 | BetaDot => Some(Beta),
        Beta2 | AbsBeta if !is_longitudinal(coef) => Some(Beta),
        // α modulating a derivative the model has.
        AlphaBeta => Some(Beta),
        AlphaP => Some(P),
        AlphaR => Some(R),
        AlphaQ => Some(Q),
        _ => None,
    }
}

/// Why `t` is not offered to coefficient `coef` whose current model holds `model`; `None`: it is.
pub fn not_offered(t: Term, coef: usize, model: &[Term]) -> Option<String> {
    let p = parent(t, coef)?;
    if model.contains(&p) {
        return None;
    }
    let what = match t {
        Term::ElevatorRate | Term::AileronRate | Term::RudderRate => {
            format!("a delay of {}, which the model does not have", p.name())
        }
        Term::AlphaDot | Term::BetaDot => format!("the lag of the {} term, which the model does not have", p.name()),
        _ => format!("a change of the {} term, which the model does not have", p.name()),
    };
    Some(format!(
        "offered only with {} in the model: it would stand for {what}; {} itself is the candidate",
        p.name(),
        p.name()
    ))
}

/// A family of rival forms of one effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// A curve bending with α: α², α³, stall(α), (α−α_b)₊².
    NonlinearAlpha,
    /// An even effect of sideslip in a longitudinal coefficient: β², |β|.
    EvenBeta,
    /// A pitching or lift response that lags: q, α̇, an elevator delay.
    PitchLag,
    /// A lateral response that lags: r, β̇, a rudder delay.
    YawLag,
}

impl Family {
    /// The family of `t` in coefficient `coef` (`None`: a term of no family).
    pub fn of(t: Term, coef: usize) -> Option<Family> {
        Self::ALL
            .into_iter()
            .find(|f| f.applies(coef) && f.forms().contains(&t))
    }

    /// Every family.
    pub const ALL: [Family; 4] = [Self::NonlinearAlpha, Self::EvenBeta, Self::PitchLag, Self::YawLag];

    fn applies(self, coef: usize) -> bool {
        match self {
            Self::NonlinearAlpha | Self::EvenBeta | Self::PitchLag => is_longitudinal(coef),
            Self::YawLag => !is_longitudinal(coef),
        }
    }

    /// The forms, lowest order first.
    pub fn forms(self) -> &'static [Term] {
        use Term::*;
        match self {
            Self::NonlinearAlpha => &[Alpha2, Alpha3, StallHinge, StallBreak],
            Self::EvenBeta => &[Beta2, AbsBeta],
            Self::PitchLag => &[Q, AlphaDot, ElevatorRate],
            Self::YawLag => &[R, BetaDot, RudderRate],
        }
    }

    /// The family in words.
    pub fn name(self) -> &'static str {
        match self {
            Self::NonlinearAlpha => "nonlinear in α",
            Self::EvenBeta => "even in β",
            Self::PitchLag => "lag in pitch (q, α̇ or an elevator delay)",
            Self::YawLag => "lag in yaw (r, β̇ or a rudder delay)",
        }
    }

    /// Position of `t` among the forms (`usize::MAX` when it is not one).
    pub fn order(self, t: Term) -> usize {
        self.forms().iter().position(|x| *x == t).unwrap_or(usize::MAX)
    }
}

/// The family decision for an added term, as the report shows it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FamilyChoice {
    /// The family in words ([`Family::name`]).
    pub family: String,
    /// The form named.
    pub form: String,
    /// The other forms that, in its place, pass the `t²` test and predict the held-out data as
    /// well within noise: the flight cannot separate them from the form named.
    pub cannot_separate: Vec<String>,
}

impl FamilyChoice {
    /// "nonlinear in α: α² (α³, stall(α) predict as well on this flight)".
    pub fn describe(&self) -> String {
        if self.cannot_separate.is_empty() {
            format!("{}: {}", self.family, self.form)
        } else {
            format!(
                "{}: {} ({} predict{} as well on this flight)",
                self.family,
                self.form,
                self.cannot_separate.join(", "),
                if self.cannot_separate.len() == 1 { "s" } else { "" }
            )
        }
    }
}

/// One form's evidence in an added term's place.
pub struct Form {
    /// Its column in the design.
    pub col: usize,
    /// Its order in the family ([`Family::order`]).
    pub order: usize,
    /// The model with it in the added term's place.
    pub fit: SubsetFit,
}

/// The family rule on forms that each passed the entry tests in the same place, with `beats(a,
/// b)` true when `b` predicts the held-out data better than `a` beyond noise: returns the index
/// of the winner and of the forms the flight cannot separate from it. The lowest order starts; a
/// higher form takes over only when it beats the form holding the place.
pub fn decide(forms: &[Form], beats: impl Fn(&SubsetFit, &SubsetFit) -> bool) -> Option<(usize, Vec<usize>)> {
    let mut idx: Vec<usize> = (0..forms.len()).collect();
    idx.sort_by_key(|&i| forms[i].order);
    let mut win = *idx.first()?;
    for &h in &idx[1..] {
        if beats(&forms[win].fit, &forms[h].fit) {
            win = h;
        }
    }
    let tied = idx
        .into_iter()
        .filter(|&h| h != win && !beats(&forms[h].fit, &forms[win].fit))
        .collect();
    Some((win, tied))
}

/// The tests the family rule uses: the `t²` threshold, the held-out critical value.
#[derive(Debug, Clone, Copy)]
pub struct Tests {
    /// `t²` threshold.
    pub threshold_t2: f64,
    /// Critical value of the noise-referenced held-out gain.
    pub gain_crit: f64,
}

/// Whether `f1` predicts the held-out data better than `f0` beyond noise: the blocks' gains lean
/// positive and their noise-referenced sum exceeds the critical value (the entry test's held-out
/// half).
pub fn beyond_noise(design: &Design, f0: &SubsetFit, f1: &SubsetFit, gain_crit: f64) -> bool {
    let (z, _) = super::select::gain(&f0.cv_sse, &f1.cv_sse);
    z > 0.0 && design.noise_gain(f0, f1) > gain_crit
}

/// Applies the families to the added terms of `model` (its first `nb` columns are the baseline):
/// the δe² stand-in first, then per added term of a family the lowest-order rule ([`decide`]);
/// `excluded` columns are not tried. `model` and `current` are updated. Returns the decision per
/// added column (after any swap) and a note per swap.
#[allow(clippy::too_many_arguments)]
pub fn resolve(
    design: &Design,
    terms: &[Term],
    coef: usize,
    nb: usize,
    model: &mut [usize],
    excluded: &[usize],
    current: &mut SubsetFit,
    tests: Tests,
) -> (Vec<(usize, FamilyChoice)>, Vec<String>) {
    let mut choices = Vec::new();
    let mut notes = Vec::new();
    for k in nb..model.len() {
        let a = model[k];
        let without: Vec<usize> = model.iter().copied().filter(|&x| x != a).collect();
        let Ok(w) = design.fit(&without) else { continue };
        let without_terms: Vec<Term> = without.iter().map(|&c| terms[c]).collect();
        let slot = Slot {
            design,
            terms,
            coef,
            k,
            excluded,
            without_terms: &without_terms,
            tests,
        };
        let stood_in = terms[a] == Term::Elevator2 && slot.alpha_squared_stands_in(model, current, &w, &mut notes);
        if let Some(choice) = slot.family_form(model, current, stood_in, &mut notes) {
            choices.push(choice);
        }
    }
    (choices, notes)
}

/// One added term's place in the model (`model[k]`), and what trying another form there needs.
struct Slot<'a> {
    design: &'a Design,
    terms: &'a [Term],
    coef: usize,
    k: usize,
    excluded: &'a [usize],
    /// The model's terms without the one in this place.
    without_terms: &'a [Term],
    tests: Tests,
}

impl Slot<'_> {
    /// A form in the place: offered there, not excluded, fitted, its `t²` above the threshold
    /// (the family's held-out evidence is then weighed form against form).
    fn try_form(&self, model: &[usize], j: usize) -> Option<SubsetFit> {
        if model.contains(&j)
            || self.excluded.contains(&j)
            || not_offered(self.terms[j], self.coef, self.without_terms).is_some()
        {
            return None;
        }
        let swapped: Vec<usize> = model.iter().map(|&x| if x == model[self.k] { j } else { x }).collect();
        let f = self.design.fit(&swapped).ok()?;
        (f.t2(self.k) > self.tests.threshold_t2).then_some(f)
    }

    /// The term `t`'s column and its fit in the place, when it qualifies ([`Slot::try_form`]).
    fn form_of(&self, model: &[usize], t: Term) -> Option<(usize, SubsetFit)> {
        let j = self.terms.iter().position(|x| *x == t)?;
        self.try_form(model, j).map(|f| (j, f))
    }

    /// Whether `x` predicts held-out data better than `y` beyond noise.
    fn beats(&self, x: &SubsetFit, y: &SubsetFit) -> bool {
        beyond_noise(self.design, x, y, self.tests.gain_crit)
    }

    /// δe² in the place gives way to α² when the flight cannot tell them apart and α² passes the
    /// held-out entry test against the model without the place (`w`) itself: a curve nonlinear in
    /// α is preferred to the square of a control. Whether it did.
    fn alpha_squared_stands_in(
        &self,
        model: &mut [usize],
        current: &mut SubsetFit,
        w: &SubsetFit,
        notes: &mut Vec<String>,
    ) -> bool {
        let a = model[self.k];
        let Some((j, f)) = self.form_of(model, Term::Alpha2) else {
            return false;
        };
        // A change of kind: α² must pass the held-out entry test itself as well.
        if self.beats(current, &f) || self.beats(&f, current) || !beyond_noise(self.design, w, &f, self.tests.gain_crit)
        {
            return false;
        }
        notes.push(format!(
            "{} named in place of {}: the flight cannot tell them apart, and a curve nonlinear in α is preferred to the square of a control",
            self.terms[j].name(),
            self.terms[a].name()
        ));
        model[self.k] = j;
        *current = f;
        true
    }

    /// The form of the place's family named: the lowest-order one unless another predicts
    /// held-out data better beyond noise ([`decide`]); the model and its fit follow it. `None`
    /// when the term is of no family or no form is decided.
    fn family_form(
        &self,
        model: &mut [usize],
        current: &mut SubsetFit,
        stood_in: bool,
        notes: &mut Vec<String>,
    ) -> Option<(usize, FamilyChoice)> {
        let terms = self.terms;
        let a = model[self.k];
        let family = Family::of(terms[a], self.coef)?;
        let mut forms = vec![Form {
            col: a,
            order: family.order(terms[a]),
            fit: current.clone(),
        }];
        for &t in family.forms() {
            if t == terms[a] {
                continue;
            }
            if let Some((j, f)) = self.form_of(model, t) {
                forms.push(Form {
                    col: j,
                    order: family.order(t),
                    fit: f,
                });
            }
        }
        let (win, tied) = decide(&forms, |x, y| self.beats(x, y))?;
        let mut cannot: Vec<String> = tied.iter().map(|&h| terms[forms[h].col].name().to_string()).collect();
        // The stand-in δe², when it gave way, is a form the flight cannot separate as well.
        if stood_in {
            cannot.push(Term::Elevator2.name().to_string());
        }
        let w_col = forms[win].col;
        if w_col != a {
            notes.push(format!(
                "{} named in place of {}: within the family {} the lowest-order form is named unless another predicts held-out data better beyond noise",
                terms[w_col].name(),
                terms[a].name(),
                family.name()
            ));
            model[self.k] = w_col;
            *current = forms[win].fit.clone();
        }
        Some((
            w_col,
            FamilyChoice {
                family: family.name().to_string(),
                form: terms[w_col].name().to_string(),
                cannot_separate: cannot,
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaps::select::CvSettings;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use Term::*;

    const C_L: usize = 0;
    const C_D: usize = 1;
    const C_L_ROLL: usize = 3;
    const C_M: usize = 4;
    const C_N: usize = 5;

    #[test]
    fn a_surface_delay_is_offered_only_with_its_surface() {
        // GIVEN C_n without δa, and with it
        let without = [One, Beta, P, R, Rudder];
        let with = [One, Beta, P, R, Rudder, Aileron];
        // THEN δȧ is offered only with δa, and the reason names δa as the candidate
        let why = not_offered(AileronRate, C_N, &without).expect("not offered without δa");
        assert!(why.contains("δa itself is the candidate"), "{why}");
        assert!(not_offered(AileronRate, C_N, &with).is_none());
        // and the surface itself needs nothing
        assert!(not_offered(Aileron, C_N, &without).is_none());
        // and each surface's rate asks for its own surface
        assert!(not_offered(ElevatorRate, C_M, &[One, Alpha, Q]).is_some());
        assert!(not_offered(ElevatorRate, C_M, &[One, Alpha, Q, Elevator]).is_none());
        assert!(not_offered(RudderRate, C_N, &[One, Beta, P, R]).is_some());
    }

    #[test]
    fn the_nonlinear_alpha_forms_need_the_slope() {
        for t in [Alpha2, Alpha3, StallHinge, StallBreak] {
            assert!(not_offered(t, C_L, &[One, Q, Elevator]).is_some(), "{t:?}");
            assert!(not_offered(t, C_L, &[One, Alpha, Q, Elevator]).is_none(), "{t:?}");
        }
    }

    #[test]
    fn nonlinear_beta_needs_beta_in_a_lateral_coefficient_but_not_in_a_longitudinal_one() {
        assert!(not_offered(Beta3, C_L_ROLL, &[One, P, R, Aileron]).is_some());
        assert!(not_offered(Beta3, C_L_ROLL, &[One, Beta, P, R, Aileron]).is_none());
        // β² in C_m: the even effect of sideslip, whose odd β term a symmetric aircraft lacks
        assert!(not_offered(Beta2, C_M, &[One, Alpha, Q, Elevator]).is_none());
        assert!(not_offered(AbsBeta, C_M, &[One, Alpha, Q, Elevator]).is_none());
    }

    #[test]
    fn a_cross_coupling_product_needs_the_derivative_it_modulates() {
        assert!(not_offered(AlphaBeta, C_L_ROLL, &[One, P, R]).is_some());
        assert!(not_offered(AlphaBeta, C_L_ROLL, &[One, Beta, P, R]).is_none());
        assert!(not_offered(AlphaR, C_N, &[One, Beta, P]).is_some());
        assert!(not_offered(AlphaR, C_N, &[One, Beta, P, R]).is_none());
        assert!(not_offered(AlphaAileron, C_N, &[One, Beta, R]).is_some());
        assert!(not_offered(AlphaAileron, C_N, &[One, Beta, R, Aileron]).is_none());
    }

    #[test]
    fn a_flow_angle_rate_needs_its_angle() {
        assert!(not_offered(AlphaDot, C_M, &[One, Q, Elevator]).is_some());
        assert!(not_offered(AlphaDot, C_M, &[One, Alpha, Q, Elevator]).is_none());
        assert!(not_offered(BetaDot, C_N, &[One, P, R]).is_some());
        assert!(not_offered(BetaDot, C_N, &[One, Beta, P, R]).is_none());
    }

    #[test]
    fn thrust_terms_need_a_known_thrust_and_propwash_its_elevator() {
        for t in [Thrust, ThrustAlpha, ThrustBeta, ThrustElevator] {
            assert!(offered_on_flight(t, 0.05, true), "{t:?}");
            assert!(!offered_on_flight(t, 0.05, false), "{t:?}");
        }
        assert!(not_offered(Thrust, C_M, &[One]).is_none());
        assert!(not_offered(ThrustElevator, C_M, &[One, Alpha, Q]).is_some());
        assert!(not_offered(ThrustElevator, C_M, &[One, Alpha, Q, Elevator]).is_none());
    }

    #[test]
    fn a_mach_term_needs_compressibility_and_a_speed_term_nothing() {
        // At a small UAV's Mach 0.05 ΔM is ΔV/V under another name.
        assert!(!offered_on_flight(Mach, 0.05, true));
        assert!(offered_on_flight(Mach, MIN_MACH, true));
        assert!(offered_on_flight(Speed, 0.05, false));
        assert!(not_offered(Speed, C_D, &[One]).is_none());
    }

    #[test]
    fn families_order_their_forms_lowest_first() {
        assert_eq!(Family::of(Alpha3, C_L), Some(Family::NonlinearAlpha));
        assert_eq!(Family::of(StallBreak, C_M), Some(Family::NonlinearAlpha));
        assert_eq!(Family::of(AlphaDot, C_M), Some(Family::PitchLag));
        assert_eq!(Family::of(BetaDot, C_N), Some(Family::YawLag));
        assert_eq!(Family::of(Beta2, C_M), Some(Family::EvenBeta));
        // δe² is a control term, not a form of the family
        assert_eq!(Family::of(Elevator2, C_L), None);
        let f = Family::NonlinearAlpha;
        assert!(f.order(Alpha2) < f.order(Alpha3) && f.order(Alpha3) < f.order(StallHinge));
        assert!(f.order(StallHinge) < f.order(StallBreak));
        let c = FamilyChoice {
            family: f.name().into(),
            form: "α²".into(),
            cannot_separate: vec!["α³".into(), "stall(α)".into()],
        };
        assert_eq!(
            c.describe(),
            "nonlinear in α: α² (α³, stall(α) predict as well on this flight)"
        );
    }

    /// A lift-like regression `z = 1 + 5α + k α² + noise` over a seeded α history that spans
    /// ±0.15 rad, with columns [1, α, α², α³, (α−α_b)₊²] (α_b the 85th percentile).
    fn curve_design(k2: f64, k_break: f64, seed: u64) -> (Design, Vec<Term>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let nrm = Normal::new(0.0, 1.0).unwrap();
        let n = 6000;
        let alpha: Vec<f64> = (0..n)
            .map(|i| 0.1 * (i as f64 * 0.011).sin() + 0.05 * (i as f64 * 0.0037).cos() + 0.01 * nrm.sample(&mut rng))
            .collect();
        let mut sorted = alpha.clone();
        sorted.sort_by(f64::total_cmp);
        let ab = sorted[(0.85 * n as f64) as usize];
        let ones = vec![1.0; n];
        let a2: Vec<f64> = alpha.iter().map(|a| a * a).collect();
        let a3: Vec<f64> = alpha.iter().map(|a| a * a * a).collect();
        let brk: Vec<f64> = alpha.iter().map(|a| (a - ab).max(0.0).powi(2)).collect();
        let z: Vec<f64> = (0..n)
            .map(|i| 1.0 + 5.0 * alpha[i] + k2 * a2[i] + k_break * brk[i] + 0.02 * nrm.sample(&mut rng))
            .collect();
        let d = Design::new(&[&ones, &alpha, &a2, &a3, &brk], &z, 0.01, &CvSettings::default(), None).with_ones(0);
        (d, vec![One, Alpha, Alpha2, Alpha3, StallBreak])
    }

    fn tests_of(d: &Design) -> Tests {
        let g = d.n_blocks() as f64;
        Tests {
            threshold_t2: crate::gaps::select::student_t_upper_quantile(0.0005, g - 1.0).powi(2),
            gain_crit: crate::gaps::select::student_t_upper_quantile(0.01, g - 1.0),
        }
    }

    #[test]
    fn a_quadratic_named_as_a_higher_form_gives_way_to_alpha2() {
        // GIVEN a true α² effect, and a selection that added α³ in its place
        let (d, terms) = curve_design(-3.0, 0.0, 3);
        let mut model = vec![0, 1, 3];
        let mut current = d.fit(&model).unwrap();
        // WHEN the family rule applies
        let (choices, notes) = resolve(&d, &terms, C_L, 2, &mut model, &[], &mut current, tests_of(&d));
        // THEN α² is named, with a note on the swap
        assert_eq!(model, vec![0, 1, 2], "{notes:?}");
        assert_eq!(choices.len(), 1);
        assert_eq!(choices[0].1.form, "α²");
        assert!(notes.iter().any(|n| n.contains("lowest-order")), "{notes:?}");
    }

    #[test]
    fn a_higher_form_that_predicts_better_beyond_noise_stays() {
        // GIVEN a pure stall break (no α²), selected as the break
        let (d, terms) = curve_design(0.0, -40.0, 4);
        let mut model = vec![0, 1, 4];
        let mut current = d.fit(&model).unwrap();
        // WHEN the family rule applies
        let (choices, _) = resolve(&d, &terms, C_L, 2, &mut model, &[], &mut current, tests_of(&d));
        // THEN the break stays: α² does not predict as well
        assert_eq!(model, vec![0, 1, 4]);
        assert_eq!(choices[0].1.form, "(α−α_b)₊²");
        assert!(!choices[0].1.cannot_separate.contains(&"α²".to_string()), "{choices:?}");
    }

    #[test]
    fn the_rule_decides_on_held_out_evidence_only() {
        // Three forms, the lowest order first; `beats` says which predicts better beyond noise.
        let (d, _) = curve_design(-3.0, 0.0, 5);
        let f = d.fit(&[0, 1, 2]).unwrap();
        let forms: Vec<Form> = (0..3)
            .map(|o| Form {
                col: o,
                order: o,
                fit: SubsetFit {
                    cv_sse: vec![o as f64; 2],
                    ..f.clone()
                },
            })
            .collect();
        // Nothing beats anything: the lowest wins and the others are tied with it.
        assert_eq!(decide(&forms, |_, _| false), Some((0, vec![1, 2])));
        // Form 2 predicts better than form 0 beyond noise (the relation marks forms by their
        // held-out SSE entries) and is not beaten by form 1: it wins; form 0 is beaten, so it is
        // not a rival the flight cannot separate, while form 1 is.
        let beats = |a: &SubsetFit, b: &SubsetFit| a.cv_sse[0] == 0.0 && b.cv_sse[0] == 2.0;
        assert_eq!(decide(&forms, beats), Some((2, vec![1])));
        assert_eq!(decide(&[], |_, _| false), None);
    }
}
