//! Standard errors that match the scatter: the same simulated manoeuvres flown again and again with
//! independent turbulence and sensor-noise seeds, every parameter of the short-period (`C_L`,
//! `C_m`: α, q, δe) and roll/yaw (`C_Y`, `C_l`, `C_n`: β, p, r, δa, δr) models estimated on each,
//! and the sample standard deviation of the estimates divided by the median standard error the
//! analysis states. A stated σ that matches the scatter gives a ratio near 1; white-residual bounds
//! on coloured residuals give ratios of several.
//!
//! * `gaps`: the pooled test card (`aerosid card`, eight records, light MIL-F-8785C turbulence),
//!   the baseline's fit of each coefficient, σ the manoeuvre-level sandwich
//!   (`regress::manoeuvre_sandwich`). The draws are kept apart by estimator: where PCA-GTLS is
//!   not determined the fit is OLS (said so in the report), and the two estimate different
//!   things with an estimated flow angle (attenuated or not), so a mixture's scatter is not any
//!   σ's. The band is asserted on an estimator's draws when it fitted at least 3/4 of the cards.
//! * `fem`: output error on one 6 s manoeuvre at a time (`tool/models/skywalker_short_period_physical.toml`
//!   and `tool/models/skywalker_lateral.toml`), σ from the residual modelled per output as a
//!   first-order Gauss–Markov or a band-pass process plus white noise
//!   (`workflow::gust_covariance`; the Morelli–Klein lag-sum
//!   σ and the white-residual bound printed beside it), the gap campaign's flight with vanes in its light
//!   turbulence (every surface excited in the same window, so both models are identifiable from
//!   one record). (On the test card's `elevator_3211` of seed 100, α estimated from a lagged
//!   wind, the short-period output error stopped on a refused step or did not converge with every
//!   prior tried.)
//!
//! Beside them (ignored): `gaps_varied_scatter_sweep`, the cards with each manoeuvre's amplitude
//! and period drawn per card, as repeated flight tests vary (the model error's pull on each
//! manoeuvre then enters the scatter); `fem_model_error_sweep`, the same manoeuvres in calm air,
//! which splits σ into what a model error adds on every seed and the rest, for the linear and
//! the physical short-period models (`skywalker_short_period_physical.toml`) and roll/yaw;
//! `fem_input_noise_sweep`, the physical model with its input channels logged without noise
//! (docs/fem.md, docs/model-gaps.md).
//!
//! The sweeps (`fem_scatter_sweep`, `gaps_scatter_sweep`, ignored: N = 40) print the tables
//! docs/benchmarks.md records; the always-on test uses N = 16 (roll/yaw by `fem`) and asserts the band 0.7 ≤ ratio ≤ 1.5 widened by the
//! sampling error of a standard deviation from N draws, `≈ 1/√(2N)` relative (0.18 at N = 16):
//! two of those, `[0.7 − 2·0.18·0.7, 1.5 + 2·0.18·1.5] ≈ [0.45, 2.0]`, so a correct σ fails
//! with a probability of a few percent per parameter only if its true ratio sits at a band edge,
//! and the white-residual σ (ratios 3–10) always fails.

use aerosid::card::{write_card, CardSettings, AIRCRAFT_FILE};
use aerosid::gaps::hidden;
use aerosid::gaps::{run_gaps, GapSettings};
use aerosid::io::log::write_log_file;
use aerosid::io::{read_pooled, ReadOptions};
use aerosid::sim::simulate;
use aerosid::sim::test_card::CardTurbulence;
use aerosid::usermodel::UserModel;
use aerosid::workflow::{apply_aircraft, coloured_covariance, gust_covariance, identify, read_segments_with};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Draws of one parameter: estimates, stated σ, and (fem) the Morelli–Klein lag-sum σ and the
/// white-residual σ beside it.
#[derive(Default)]
struct Draws {
    values: Vec<f64>,
    sigmas: Vec<f64>,
    white: Vec<f64>,
    lag_sums: Vec<f64>,
}

fn sd(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    s.sort_by(f64::total_cmp);
    if s.is_empty() {
        return f64::NAN;
    }
    let k = s.len() / 2;
    if s.len() % 2 == 1 {
        s[k]
    } else {
        0.5 * (s[k - 1] + s[k])
    }
}

impl Draws {
    fn ratio(&self) -> f64 {
        sd(&self.values) / median(&self.sigmas)
    }
    fn white_ratio(&self) -> f64 {
        sd(&self.values) / median(&self.white)
    }
    fn lag_sum_ratio(&self) -> f64 {
        sd(&self.values) / median(&self.lag_sums)
    }
}

/// `n` clean cards in light turbulence, seeds `first..first + n`, written under `dir`; each card's
/// record files.
fn cards(dir: &Path, first: u64, n: u64) -> Vec<Vec<PathBuf>> {
    (first..first + n)
        .map(|seed| {
            let folder = dir.join(format!("card_{seed}"));
            let settings = CardSettings {
                effect: None,
                seed,
                turbulence: CardTurbulence::Light,
            };
            write_card(&folder, &settings)
                .expect("the card flies")
                .into_iter()
                .filter(|p| p.extension().is_some_and(|e| e == "csv"))
                .collect()
        })
        .collect()
}

const SHORT_PERIOD: [&str; 2] = ["C_L", "C_m"];
const ROLL_YAW: [&str; 3] = ["C_Y", "C_l", "C_n"];

/// `gaps` on every pooled card: the baseline's estimates and stated σ per `coefficient:term`
/// (the short-period and roll/yaw coefficients; the constant term left out).
/// `n` clean cards like [`cards`] whose manoeuvres vary from card to card as repeated flight tests
/// do: each manoeuvre's amplitude scaled by a factor drawn from U(0.7, 1.3) and its base period by
/// one from U(0.8, 1.25) (the record lengthened by what the manoeuvre gained, so its free
/// response stays as long), drawn from the card's seed. The same records, file names and logging
/// as the standard card otherwise (`sim::test_card::fly_card`).
fn varied_cards(dir: &Path, first: u64, n: u64) -> Vec<Vec<PathBuf>> {
    use aerosid::card::{config, csv_text, record_file};
    use aerosid::sim::test_card::{fly_card, standard_card};
    use aerosid::sim::uav_log::UavLogging;
    use rand::{Rng, SeedableRng};
    let aircraft = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/aircraft")
        .join(AIRCRAFT_FILE);
    (first..first + n)
        .map(|seed| {
            let settings = CardSettings {
                effect: None,
                seed,
                turbulence: CardTurbulence::Light,
            };
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7A71_ED00);
            let card: Vec<_> = standard_card()
                .into_iter()
                .map(|mut c| {
                    let end = c.manoeuvre.end_s();
                    c.manoeuvre.amplitude *= rng.random_range(0.7..1.3);
                    c.manoeuvre.period_s *= rng.random_range(0.8..1.25);
                    c.duration_s += (c.manoeuvre.end_s() - end).max(0.0);
                    c
                })
                .collect();
            let records =
                fly_card(&config(&settings), &card, &UavLogging::default(), 0.0, seed).expect("the card flies");
            let folder = dir.join(format!("card_{seed}"));
            std::fs::create_dir_all(&folder).expect("a scratch folder");
            std::fs::copy(&aircraft, folder.join(AIRCRAFT_FILE)).expect("the aircraft file copies");
            records
                .iter()
                .map(|r| {
                    let p = folder.join(record_file(r));
                    std::fs::write(&p, csv_text(&r.log)).expect("the record writes");
                    p
                })
                .collect()
        })
        .collect()
}

/// Each baseline parameter's draws over the cards, and how many cards gave a parameter no
/// standard error (a term the report states not identifiable, e.g. from an estimated flow angle
/// that errs by more than the manoeuvres move it): those cards state no estimate, so they are no
/// draw of one.
fn gaps_draws(cards: &[Vec<PathBuf>]) -> (BTreeMap<String, Draws>, BTreeMap<String, usize>) {
    let mut out: BTreeMap<String, Draws> = BTreeMap::new();
    let mut undetermined: BTreeMap<String, usize> = BTreeMap::new();
    for files in cards {
        let aircraft = files[0].parent().expect("a folder").join(AIRCRAFT_FILE);
        let flight = read_pooled(files, Some(&aircraft), &[], &ReadOptions::default()).expect("the card reads");
        let report = run_gaps(&flight, &GapSettings::default()).expect("the analysis runs");
        for c in &report.coefficients {
            if !SHORT_PERIOD.contains(&c.name.as_str()) && !ROLL_YAW.contains(&c.name.as_str()) {
                continue;
            }
            let estimator = if c.baseline.estimator.starts_with("OLS") {
                "OLS"
            } else {
                "GTLS"
            };
            for p in c.baseline.parameters.iter().filter(|p| p.term != "1") {
                let name = format!("{}:{} ({estimator})", c.name, p.term);
                if !p.sigma.is_finite() {
                    *undetermined.entry(name).or_default() += 1;
                    continue;
                }
                let d = out.entry(name).or_default();
                d.values.push(p.value);
                d.sigmas.push(p.sigma);
            }
        }
    }
    (out, undetermined)
}

fn model_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models").join(name)
}

/// One simulated manoeuvre per seed: the gap campaign's clean flight (`gaps::hidden::config`: vanes,
/// [`hidden::CAMPAIGN_TURBULENCE`]) of 12 s, written as a project CSV. Its 2–8 s window
/// ([`WINDOW`]) flies an elevator 3-2-1-1 and doublet, an aileron 3-2-1-1 and a rudder doublet from
/// trim, and ends before the throttle step at 8 s (whose speed change the short-period model does
/// not have).
fn manoeuvres(dir: &Path, first: u64, n: u64, turbulence: bool) -> Vec<PathBuf> {
    manoeuvres_with(dir, first, n, turbulence, false)
}

/// [`manoeuvres`], with `quiet_inputs` the channels the physical short-period model takes as
/// inputs (airspeed, attitude, propeller speed, surfaces, density) logged without noise; the
/// outputs' sensors (vanes, gyros) keep theirs.
fn manoeuvres_with(dir: &Path, first: u64, n: u64, turbulence: bool, quiet_inputs: bool) -> Vec<PathBuf> {
    std::fs::create_dir_all(dir).expect("a scratch folder");
    (first..first + n)
        .map(|seed| {
            let mut cfg = hidden::config(None, 12.0, seed, turbulence);
            if quiet_inputs {
                let s = &mut cfg.sensors;
                (
                    s.airspeed_mps,
                    s.attitude_rad,
                    s.prop_speed_rel,
                    s.surface_rad,
                    s.density_rel,
                ) = (0.0, 0.0, 0.0, 0.0, 0.0);
            }
            let out = simulate(&cfg).expect("the simulator flies");
            let f = dir.join(format!("manoeuvre_{seed}.csv"));
            write_log_file(&f, &out.samples).expect("the log writes");
            f
        })
        .collect()
}

/// The manoeuvre's window in each flight, s.
const WINDOW: (f64, f64) = (2.0, 8.0);

/// `fem` (output error, Gauss–Newton) of `model` on the [`WINDOW`] of every file: the
/// estimates, the σ `fem` reports and the white-residual Cramér–Rao σ, per parameter.
fn fem_draws(files: &[PathBuf], model: &str) -> BTreeMap<String, Draws> {
    let aircraft = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/aircraft/skywalker_2013_mod.aircraft");
    let mut out: BTreeMap<String, Draws> = BTreeMap::new();
    for f in files {
        let mut m = UserModel::read(&model_path(model)).expect("the model reads");
        let segs = read_segments_with(&m, f, Some(&aircraft), &[WINDOW]).expect("the record reads");
        apply_aircraft(&mut m, &segs).expect("the aircraft applies");
        let id = identify(&m, &segs).expect("the fit runs");
        assert!(
            id.converged,
            "{model} on {}: Gauss-Newton did not converge",
            f.display()
        );
        let (cov, _) = gust_covariance(&m, &segs, &id).expect("the covariance");
        let lag_sums = coloured_covariance(&m, &segs, &id).expect("the covariance");
        for (k, &i) in m.free().iter().enumerate() {
            let d = out.entry(m.file.parameters[i].name.clone()).or_default();
            d.values.push(id.p[k]);
            d.sigmas.push(cov[(k, k)].max(0.0).sqrt());
            d.white.push(id.covariance[(k, k)].max(0.0).sqrt());
            d.lag_sums.push(lag_sums[(k, k)].max(0.0).sqrt());
        }
    }
    out
}

/// `r` to two decimals, or a dash where `of` (the σ's it divides by) was not recorded.
fn ratio_or_dash(of: &[f64], r: f64) -> String {
    if of.is_empty() {
        "—".to_string()
    } else {
        format!("{r:.2}")
    }
}

fn table(title: &str, d: &BTreeMap<String, Draws>) -> String {
    let mut s = format!("{title}\n| parameter | mean | s.d. | median σ | s.d./σ | s.d./σ white | s.d./σ lag sums |\n");
    for (name, v) in d {
        let n = v.values.len() as f64;
        s.push_str(&format!(
            "| {name} | {:.4} | {:.4} | {:.4} | {:.2} | {} | {} |\n",
            v.values.iter().sum::<f64>() / n,
            sd(&v.values),
            median(&v.sigmas),
            v.ratio(),
            ratio_or_dash(&v.white, Draws::white_ratio(v)),
            ratio_or_dash(&v.lag_sums, Draws::lag_sum_ratio(v)),
        ));
    }
    s
}

/// The band for `n` draws (module doc): 0.7–1.5 widened by two sampling errors of a s.d.
fn band(n: usize) -> (f64, f64) {
    let e = 1.0 / (2.0 * n as f64).sqrt();
    (0.7 * (1.0 - 2.0 * e), 1.5 * (1.0 + 2.0 * e))
}

fn assert_band(what: &str, d: &BTreeMap<String, Draws>) {
    let mut bad = Vec::new();
    for (name, v) in d {
        let (lo, hi) = band(v.values.len());
        let r = v.ratio();
        if !(lo..=hi).contains(&r) {
            bad.push(format!("{name}: {r:.2} outside [{lo:.2}, {hi:.2}]"));
        }
    }
    assert!(bad.is_empty(), "{what}: s.d./σ out of band:\n{}", bad.join("\n"));
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid_scatter_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn fem_sigma_matches_the_scatter_of_repeated_manoeuvres() {
    // GIVEN 16 simulated manoeuvres of independent seeds, WHEN `fem` fits the roll/yaw model to
    // each (output error, one manoeuvre at a time)
    let dir = temp("fem");
    let f = manoeuvres(&dir, 100, 16, true);
    let lat = fem_draws(&f, "skywalker_lateral.toml");
    println!("{}", table("roll/yaw", &lat));
    let _ = std::fs::remove_dir_all(&dir);
    // THEN the scatter over the σ `fem` reports is inside the band for every parameter, and over
    // the white-residual Cramér–Rao σ it is far above it (measured 3.4–8.2 on these seeds)
    assert_band("fem roll/yaw", &lat);
    let white_low = lat.values().map(Draws::white_ratio).fold(f64::INFINITY, f64::min);
    assert!(
        white_low > band(16).1,
        "the white σ already matches the scatter ({white_low:.2})"
    );
}

#[test]
#[ignore = "the sweep: 40 manoeuvres through fem (minutes); prints docs/benchmarks.md's table"]
fn fem_scatter_sweep() {
    let dir = temp("fem_sweep");
    let f = manoeuvres(&dir, 1000, 40, true);
    let lon = fem_draws(&f, "skywalker_short_period_physical.toml");
    println!("fem, N = {}\n{}", f.len(), table("short period", &lon));
    let lat = fem_draws(&f, "skywalker_lateral.toml");
    println!("{}", table("roll/yaw", &lat));
    let _ = std::fs::remove_dir_all(&dir);
    // The short period as the simulator computes it (`skywalker_short_period_physical.toml`: the
    // linear `skywalker_short_period.toml` keeps a bias from the moment it lacks, alike on every
    // repetition, which no seed-to-seed scatter sees: `fem_model_error_sweep`, docs/fem.md).
    // Measured on these seeds: short period 0.99–1.25; roll/yaw 0.65–1.36 (`Lr` 0.65, inside the
    // widened band; `Y0` 0.72: docs/fem.md, "With the fitted residual model").
    assert_band("fem short period", &lon);
    assert_band("fem roll/yaw", &lat);
}

#[test]
#[ignore = "the sweep: 40 pooled cards through gaps (minutes); prints docs/benchmarks.md's table"]
fn gaps_scatter_sweep() {
    let dir = temp("gaps_sweep");
    let c = cards(&dir, 1000, 40);
    gaps_sweep("gaps, the same manoeuvres", &dir, &c);
}

/// `gaps` on every card of `c` (written under `dir`, removed after): prints the table and asserts
/// the band on each estimator that gave an estimate (a finite σ) on at least 3/4 of the cards.
fn gaps_sweep(what: &str, dir: &Path, c: &[Vec<PathBuf>]) {
    let (g, undetermined) = gaps_draws(c);
    println!("{what}, N = {}\n{}", c.len(), table("pooled card, baseline", &g));
    for (name, k) in &undetermined {
        println!(
            "{name}: no estimate (no standard error: not identifiable) on {k} of {} cards",
            c.len()
        );
    }
    let _ = std::fs::remove_dir_all(dir);
    let most: BTreeMap<String, Draws> = g
        .into_iter()
        .filter(|(_, d)| 4 * d.values.len() >= 3 * c.len())
        .collect();
    assert_band(what, &most);
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// The σ's split into what repeats on every seed and what does not: `model` fitted to the same
/// manoeuvres in turbulence (T) and in calm air (C; same seeds and inputs, the sensors' noise
/// white). In calm air the residual is the model's error, the same on every seed, plus white
/// noise, whose scatter `s.d. C` is real: the part of σ that only the model error adds is
/// `σ_C² − s.d._C²`, and `σ rand = √(σ_T² − σ_C² + s.d._C²)` (rms over the seeds) is the σ of
/// the turbulence and the noise alone, which the seed-to-seed scatter `s.d. T` measures.
fn model_error_table(model: &str, turbulent: &[PathBuf], calm: &[PathBuf]) -> String {
    let t = fem_draws(turbulent, model);
    let c = fem_draws(calm, model);
    let mut s = format!(
        "{model}, N = {}\n| parameter | mean T | s.d. T | rms σ T | s.d./rms σ T | mean C | s.d. C | rms σ C | s.d./σ C | σ rand | s.d. T/σ rand |\n",
        turbulent.len()
    );
    for (name, d) in &t {
        let e = &c[name];
        let n = d.values.len() as f64;
        let (st, sc) = (rms(&d.sigmas), rms(&e.sigmas));
        let rand = (st * st - sc * sc + sd(&e.values).powi(2)).max(0.0).sqrt();
        s.push_str(&format!(
            "| {name} | {:.4} | {:.4} | {st:.4} | {:.2} | {:.4} | {:.4} | {sc:.4} | {:.2} | {rand:.4} | {:.2} |\n",
            d.values.iter().sum::<f64>() / n,
            sd(&d.values),
            sd(&d.values) / st,
            e.values.iter().sum::<f64>() / e.values.len() as f64,
            sd(&e.values),
            sd(&e.values) / sc,
            sd(&d.values) / rand,
        ));
    }
    s
}

#[test]
#[ignore = "the sweep: 40 manoeuvres in turbulence and in calm air through fem (minutes)"]
fn fem_model_error_sweep() {
    let dir = temp("fem_model_error");
    let t = manoeuvres(&dir.join("turbulent"), 1000, 40, true);
    let c = manoeuvres(&dir.join("calm"), 1000, 40, false);
    for model in [
        "skywalker_short_period.toml",
        "skywalker_short_period_physical.toml",
        "skywalker_lateral.toml",
    ] {
        println!("{}", model_error_table(model, &t, &c));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[ignore = "the sweep: 40 pooled cards of varied manoeuvres through gaps (minutes)"]
fn gaps_varied_scatter_sweep() {
    let dir = temp("gaps_varied_sweep");
    let c = varied_cards(&dir, 1000, 40);
    gaps_sweep("gaps, varied manoeuvres", &dir, &c);
}

#[test]
#[ignore = "the sweep: 24 manoeuvres, inputs logged without noise, through fem (minutes)"]
fn fem_input_noise_sweep() {
    let dir = temp("fem_input_noise");
    let t = manoeuvres_with(&dir.join("turbulent"), 1000, 24, true, true);
    let c = manoeuvres_with(&dir.join("calm"), 1000, 24, false, true);
    println!("{}", model_error_table("skywalker_short_period_physical.toml", &t, &c));
    let _ = std::fs::remove_dir_all(&dir);
}
