//! The benchmark campaign of the model-gap analysis: runs [`super::run_gaps`] on simulated
//! turbulent flights with planted effects, on the vendored JSBSim flights and on the real
//! flight-test data, and writes what other tools need to run on the same flights — one regression
//! table per flight (the synthesised coefficients and every candidate's column) and a manifest
//! with the truth and this analysis's answer. `scripts/bench/peers.py` runs pysindy and
//! sysidentpy on the tables, `scripts/bench/score.py` scores all three (contract:
//! `scripts/bench/README.md`).
//!
//! **Time**: each flight's analysis ([`run_gaps`], from the flight in memory to the report) is
//! timed on its own thread (the flights run in parallel, one thread each, so a flight's time is
//! single-threaded): `seconds` wall-clock, `cpu_seconds` the thread's CPU time (what a shared,
//! loaded machine does not inflate by time-slicing). `timing.json` gives the medians per suite
//! and the number of threads.

use super::hidden::{flight, HiddenEffect, HiddenKind};
use super::model::COEFFICIENTS;
use super::{run_gaps, GapReport, GapSettings, Levels};
use crate::io::read_measured;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// The shared real flight-test files and their column maps (`tool/data/maps/`).
pub const REAL_FLIGHTS: [(&str, &str); 5] = [
    ("hfb320_1_10.asc", "hfb320.map"),
    ("fAttasElv1_pqrDot.asc", "attas.map"),
    ("fAttasAil1_pqrDot.asc", "attas.map"),
    ("fAttasRud1_pqrDot.asc", "attas.map"),
    ("totter_lon_020213f1_018_fdata.asc", "twin_otter.map"),
];

/// What the campaign runs.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// Simulated turbulent flights per kind of [`HiddenKind::ALL`].
    pub draws_per_kind: usize,
    /// Simulated clean flights.
    pub clean: usize,
    /// The vendored JSBSim flights (`tool/data/jsbsim`), if wanted.
    pub jsbsim: Option<PathBuf>,
    /// The folder of the real flight-test data (`shared/data/flight`) and the maps'
    /// folder, if wanted.
    pub real: Option<(PathBuf, PathBuf)>,
    /// The test levels of every flight's analysis (the rest are the defaults; a simulated
    /// flight's baseline is its own).
    pub levels: Levels,
    /// The pooled-manoeuvre suites (simulated test cards and the vendored JSBSim cards), if
    /// wanted.
    pub cards: Option<Cards>,
}

/// The pooled-manoeuvre suites: per campaign a test card (docs/test-card.md) analysed as one
/// pooled flight, again with its files in reverse order, and one of its manoeuvres alone.
#[derive(Debug, Clone)]
pub struct Cards {
    /// Cards per kind a card accepts ([`crate::card::check_effect`]), seeds drawn in turn.
    pub seeds_per_kind: usize,
    /// Clean cards.
    pub clean: usize,
    /// The vendored JSBSim cards (`tool/data/jsbsim_card`), if wanted.
    pub jsbsim: Option<PathBuf>,
}

/// One flight of the campaign.
struct Case {
    id: String,
    suite: &'static str,
    planted: Value,
    table_effects: Value,
    /// The `aerosid gaps` command line that analyses this flight alone.
    reproduce: String,
    result: Result<(GapReport, Seconds), String>,
    /// Pooled cards: the order and single-manoeuvre checks ([`pooled_checks`]).
    pooled: Option<Value>,
}

/// Wall-clock and thread CPU seconds of one analysis.
#[derive(Debug, Clone, Copy)]
struct Seconds {
    wall: f64,
    cpu: f64,
}

/// Writes `dir/manifest.json`, `dir/tables/*.csv` and each flight's report (`dir/reports/*.json`,
/// the schema of `aerosid gaps`); returns one line per flight.
pub fn write(c: &Campaign, dir: &Path) -> Result<Vec<String>, String> {
    let tables = dir.join("tables");
    std::fs::create_dir_all(&tables).map_err(|e| format!("{}: {e}", tables.display()))?;
    let reports = dir.join("reports");
    std::fs::create_dir_all(&reports).map_err(|e| format!("{}: {e}", reports.display()))?;
    let settings = &c.levels.apply(GapSettings::default());
    let level_args = c.levels.args();
    let mut jobs: Vec<Job<'_>> = Vec::new();
    sim_jobs(c.draws_per_kind, c.clean, settings, &mut jobs);
    if let Some(j) = &c.jsbsim {
        jsbsim_jobs(j, settings, &level_args, &mut jobs)?;
    }
    if let Some((data, maps)) = &c.real {
        real_jobs(data, maps, settings, &level_args, &mut jobs);
    }
    if let Some(cards) = &c.cards {
        card_jobs(cards, dir, settings, &level_args, &mut jobs)?;
    }
    let cases = run_jobs(&jobs);
    let (manifest, mut lines) = write_cases(&cases, &tables, &reports)?;
    let timing = write_manifest(dir, manifest)?;
    lines.extend(timing_lines(&timing));
    Ok(lines)
}

/// A job of the campaign: one flight or card, analysed on its own thread.
type Job<'a> = Box<dyn Fn() -> Case + Send + Sync + 'a>;

/// The simulated flights' jobs: `draws_per_kind` rounds over [`HiddenKind::ALL`], then `clean`
/// clean flights; the campaign's turbulence, one seeded draw sequence.
fn sim_jobs<'a>(draws_per_kind: usize, clean: usize, settings: &'a GapSettings, jobs: &mut Vec<Job<'a>>) {
    let mut rng = ChaCha8Rng::seed_from_u64(0xB3);
    let mut seed = 20_000u64;
    for _ in 0..draws_per_kind {
        for k in HiddenKind::ALL {
            let e = k.draw(&mut rng);
            seed += 1;
            let s = seed;
            jobs.push(Box::new(move || sim_case(Some(e), s, settings)));
        }
    }
    for _ in 0..clean {
        seed += 1;
        let s = seed;
        jobs.push(Box::new(move || sim_case(None, s, settings)));
    }
}

/// The vendored JSBSim flights' jobs (`truth.json`'s `flights`).
fn jsbsim_jobs<'a>(
    j: &Path,
    settings: &'a GapSettings,
    level_args: &str,
    jobs: &mut Vec<Job<'a>>,
) -> Result<(), String> {
    let (truth, truth_path) = read_truth(j)?;
    for (file, t) in truth_object(&truth, "flights", &truth_path)? {
        let flight = FlightFile {
            id: format!("jsbsim/{}", file.trim_end_matches(".csv")),
            suite: "jsbsim",
            planted: planted_list(&t["planted"]),
            table_effects: t["table_effects"].clone(),
            data: j.join(&file),
            companion: j.join("c172x.aircraft"),
        };
        jobs.push(flight.job(settings, level_args));
    }
    Ok(())
}

/// The real flight-test files' jobs ([`REAL_FLIGHTS`] in `data`, their maps in `maps`).
fn real_jobs<'a>(data: &Path, maps: &Path, settings: &'a GapSettings, level_args: &str, jobs: &mut Vec<Job<'a>>) {
    for (file, map) in REAL_FLIGHTS {
        let flight = FlightFile {
            id: format!("real/{}", file.trim_end_matches(".asc")),
            suite: "real",
            planted: Value::Null,
            table_effects: Value::Null,
            data: data.join(file),
            companion: maps.join(map),
        };
        jobs.push(flight.job(settings, level_args));
    }
}

/// One flight file of the campaign, analysed alone with its companion file (the aircraft or
/// the column map).
struct FlightFile {
    id: String,
    suite: &'static str,
    planted: Value,
    table_effects: Value,
    data: PathBuf,
    companion: PathBuf,
}

impl FlightFile {
    /// Its job, and the `aerosid gaps` command line that repeats it.
    fn job<'a>(self, settings: &'a GapSettings, level_args: &str) -> Job<'a> {
        let reproduce = format!(
            "aerosid gaps --data {} --with {}{}",
            self.data.display(),
            self.companion.display(),
            level_args
        );
        Box::new(move || Case {
            id: self.id.clone(),
            suite: self.suite,
            planted: self.planted.clone(),
            table_effects: self.table_effects.clone(),
            reproduce: reproduce.clone(),
            result: analyse(&self.data, &self.companion, settings),
            pooled: None,
        })
    }
}

/// Every job, in parallel (one thread each), with a progress bar; the cases in the jobs' order.
fn run_jobs(jobs: &[Job<'_>]) -> Vec<Case> {
    let bar = crate::progress::bar(jobs.len() as u64, "flights analysed");
    let cases: Vec<Case> = jobs
        .par_iter()
        .map(|j| {
            let case = j();
            bar.inc(1);
            case
        })
        .collect();
    bar.finish_and_clear();
    cases
}

/// Each analysed case's regression table (in `tables`) and report (in `reports`) written; its
/// manifest entry, and one line per case (errors included).
fn write_cases(cases: &[Case], tables: &Path, reports: &Path) -> Result<(Vec<Value>, Vec<String>), String> {
    let mut manifest = Vec::new();
    let mut lines = Vec::new();
    for case in cases {
        match &case.result {
            Err(e) => lines.push(format!("{:<40} ERROR {e}", case.id)),
            Ok((r, t)) => {
                let name = format!("{}.csv", case.id.replace('/', "_"));
                let path = tables.join(&name);
                std::fs::write(&path, table_csv(r)).map_err(|e| format!("{}: {e}", path.display()))?;
                let path = reports.join(format!("{}.json", case.id.replace('/', "_")));
                let text = serde_json::to_string_pretty(&super::report::json(r)).map_err(|e| e.to_string())?;
                std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
                let mut e = entry(case, r, *t, &format!("tables/{name}"));
                if let Some(p) = &case.pooled {
                    e["pooled"] = p.clone();
                    e["report"] = json!(format!("reports/{}.json", case.id.replace('/', "_")));
                }
                manifest.push(e);
                lines.push(format!(
                    "{:<40} {:>6.2} s ({:.2} s CPU)  {}",
                    case.id,
                    t.wall,
                    t.cpu,
                    r.named
                        .iter()
                        .map(|n| format!("{:?} in {}: {}", n.kind, n.location, n.what))
                        .collect::<Vec<_>>()
                        .join("; ")
                ));
            }
        }
    }
    Ok((manifest, lines))
}

/// `dir/manifest.json` and `dir/timing.json` written; the timing summary.
fn write_manifest(dir: &Path, manifest: Vec<Value>) -> Result<Value, String> {
    let m = dir.join("manifest.json");
    let timing = timing_summary(&manifest);
    let text = serde_json::to_string_pretty(&Value::Array(manifest)).map_err(|e| e.to_string())?;
    std::fs::write(&m, text).map_err(|e| format!("{}: {e}", m.display()))?;
    let t = dir.join("timing.json");
    let text = serde_json::to_string_pretty(&timing).map_err(|e| e.to_string())?;
    std::fs::write(&t, text).map_err(|e| format!("{}: {e}", t.display()))?;
    Ok(timing)
}

/// One line per suite of the timing summary.
fn timing_lines(timing: &Value) -> Vec<String> {
    let Some(suites) = timing["suites"].as_object() else {
        return Vec::new();
    };
    suites
        .iter()
        .map(|(suite, v)| {
            format!(
                "{suite}: median {:.3} s ({:.3} s CPU) per flight over {} flights ({} threads)",
                v["median_s"].as_f64().unwrap_or(f64::NAN),
                v["median_cpu_s"].as_f64().unwrap_or(f64::NAN),
                v["flights"],
                timing["threads"]
            )
        })
        .collect()
}

/// The card suites' jobs: the simulated cards are flown and written here (into
/// `dir/cards/<id>/`, so that each campaign's files can be analysed again by hand), analysed in
/// the jobs.
fn card_jobs<'a>(
    c: &Cards,
    dir: &Path,
    settings: &'a GapSettings,
    level_args: &str,
    jobs: &mut Vec<Job<'a>>,
) -> Result<(), String> {
    // The kinds a card accepts (not the α-vane kinds: a card has no vanes).
    let kinds: Vec<HiddenKind> = HiddenKind::ALL
        .into_iter()
        .filter(|k| crate::card::draw_effect(*k, 0, None).is_ok())
        .collect();
    let mut plan: Vec<Option<HiddenKind>> = Vec::new();
    for _ in 0..c.seeds_per_kind {
        plan.extend(kinds.iter().map(|k| Some(*k)));
    }
    plan.extend(std::iter::repeat_n(None, c.clean));
    for (i, kind) in plan.into_iter().enumerate() {
        let card = SimulatedCard::new(i, kind, kinds.len(), c.seeds_per_kind, dir, settings, level_args)?;
        jobs.push(Box::new(move || card.fly_and_analyse()));
    }
    if let Some(j) = &c.jsbsim {
        jsbsim_card_jobs(j, settings, level_args, jobs)?;
    }
    Ok(())
}

/// One simulated test card of the suite: how it is flown, where its files go, what was planted
/// and how to repeat it by hand.
struct SimulatedCard {
    id: String,
    card: crate::card::CardSettings,
    folder: PathBuf,
    aircraft: PathBuf,
    planted: Value,
    reproduce: String,
    /// The campaign's settings with the card's own baseline.
    settings: GapSettings,
}

impl SimulatedCard {
    /// The `i`-th card of the plan, with `kind` planted (or clean); `kinds` kinds a card accepts,
    /// `seeds_per_kind` rounds over them.
    fn new(
        i: usize,
        kind: Option<HiddenKind>,
        kinds: usize,
        seeds_per_kind: usize,
        dir: &Path,
        settings: &GapSettings,
        level_args: &str,
    ) -> Result<Self, String> {
        use crate::card::{draw_effect, CardSettings, AIRCRAFT_FILE};
        use crate::sim::test_card::CardTurbulence;
        // Card seeds from 300 on; turbulence light and moderate in turn, for every kind (each
        // round over the kinds flips the parity, which an even number of kinds would fix).
        let seed = 300 + i as u64;
        let round = if i < kinds * seeds_per_kind {
            i / kinds.max(1)
        } else {
            0
        };
        let turbulence = if (i + round).is_multiple_of(2) {
            CardTurbulence::Light
        } else {
            CardTurbulence::Moderate
        };
        let effect = match kind {
            Some(k) => Some(draw_effect(k, seed, None).map_err(|e| e.to_string())?),
            None => None,
        };
        let card = CardSettings {
            effect,
            seed,
            turbulence,
        };
        let name = effect.map_or("clean", |e| e.kind.name());
        let id = format!("card/{name}_{}_{seed}", turbulence.name());
        let folder = dir.join("cards").join(id.replace('/', "_"));
        let aircraft = folder.join(AIRCRAFT_FILE);
        let baseline = HiddenEffect::baseline(effect.as_ref());
        let reproduce = format!(
            "aerosid card --out {f} --seed {seed} --turbulence {t}{effect_args} && aerosid gaps --data {f}/*.csv --with {a} --baseline '{spec}'{level_args}",
            f = folder.display(),
            t = turbulence.name(),
            effect_args = card_effect_args(effect.as_ref()),
            a = aircraft.display(),
            spec = baseline_spec(&baseline),
        );
        Ok(Self {
            id,
            card,
            folder,
            aircraft,
            planted: card_planted(effect.as_ref()),
            reproduce,
            settings: GapSettings {
                baseline: Some(baseline),
                ..settings.clone()
            },
        })
    }

    /// The card flown and written (its files in the card's order), then analysed as a pooled
    /// campaign ([`pooled_case`]).
    fn fly_and_analyse(&self) -> Case {
        let csvs = crate::card::write_card(&self.folder, &self.card).map(|files| {
            files
                .into_iter()
                .filter(|f| f.extension().is_some_and(|x| x == "csv"))
                .collect::<Vec<_>>()
        });
        match csvs {
            Ok(csvs) => pooled_case(
                &self.id,
                "card",
                self.planted.clone(),
                Value::Null,
                self.reproduce.clone(),
                &csvs,
                &self.aircraft,
                &self.settings,
            ),
            Err(e) => Case {
                id: self.id.clone(),
                suite: "card",
                planted: self.planted.clone(),
                table_effects: Value::Null,
                reproduce: self.reproduce.clone(),
                result: Err(e.to_string()),
                pooled: None,
            },
        }
    }
}

/// A card's planted effect as the manifest lists it (empty for a clean card).
fn card_planted(effect: Option<&HiddenEffect>) -> Value {
    match effect {
        None => json!([]),
        Some(e) => {
            let (k, l) = e.expected();
            let mut p = json!({"kind": format!("{k:?}"), "location": l, "size": e.size, "effect": e.kind.name()});
            if let Some(t) = e.expected_terms() {
                p["terms"] = json!(t);
            }
            json!([p])
        }
    }
}

/// ` --effect NAME [--size S]` of `aerosid card` for a planted effect.
fn card_effect_args(effect: Option<&HiddenEffect>) -> String {
    effect.map_or(String::new(), |e| {
        let size = if e.kind == HiddenKind::MissingRollControl {
            String::new()
        } else {
            format!(" --size {:?}", e.size)
        };
        format!(" --effect {}{size}", e.kind.name())
    })
}

/// The vendored JSBSim cards' jobs (`truth.json`'s `cards`: each a list of records, one file
/// each, pooled).
fn jsbsim_card_jobs<'a>(
    j: &Path,
    settings: &'a GapSettings,
    level_args: &str,
    jobs: &mut Vec<Job<'a>>,
) -> Result<(), String> {
    let (truth, truth_path) = read_truth(j)?;
    let cards = truth_object(&truth, "cards", &truth_path)?;
    let aircraft = j.join(truth["aircraft_file"].as_str().unwrap_or("c172x.aircraft"));
    for (name, t) in cards {
        let records = t["records"]
            .as_array()
            .ok_or_else(|| format!("{}: card {name} has no `records` list", truth_path.display()))?;
        let csvs: Vec<PathBuf> = records
            .iter()
            .map(|r| r["file"].as_str().map(|f| j.join(f)))
            .collect::<Option<_>>()
            .ok_or_else(|| format!("{}: a record of card {name} has no `file`", truth_path.display()))?;
        let planted = planted_list(&t["planted"]);
        let reproduce = format!(
            "aerosid gaps{} --with {}{level_args}",
            data_args(&csvs),
            aircraft.display()
        );
        let id = format!("jsbsim_card/{name}");
        let effects = truth["table_effects"].clone();
        let aircraft = aircraft.clone();
        jobs.push(Box::new(move || {
            pooled_case(
                &id,
                "jsbsim_card",
                planted.clone(),
                effects.clone(),
                reproduce.clone(),
                &csvs,
                &aircraft,
                settings,
            )
        }));
    }
    Ok(())
}

/// `dir/truth.json` of a vendored JSBSim folder, and its path.
fn read_truth(dir: &Path) -> Result<(Value, PathBuf), String> {
    let truth_path = dir.join("truth.json");
    let text = std::fs::read_to_string(&truth_path).map_err(|e| format!("{}: {e}", truth_path.display()))?;
    let truth: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", truth_path.display()))?;
    Ok((truth, truth_path))
}

/// The object `truth[key]` (the flights or the cards), or an error naming the file.
fn truth_object(truth: &Value, key: &str, truth_path: &Path) -> Result<serde_json::Map<String, Value>, String> {
    truth[key]
        .as_object()
        .ok_or_else(|| format!("{}: no `{key}` object", truth_path.display()))
        .cloned()
}

/// A truth entry's planted effect as the manifest lists it: `[]` for none, else `[p]`.
fn planted_list(p: &Value) -> Value {
    match p {
        Value::Null => json!([]),
        p => json!([p]),
    }
}

/// ` --data F` for every file.
fn data_args(files: &[PathBuf]) -> String {
    files.iter().map(|f| format!(" --data {}", f.display())).collect()
}

/// A baseline as `aerosid gaps --baseline` reads it ([`super::model::parse_baseline`]).
fn baseline_spec(b: &[Vec<super::model::Term>; 6]) -> String {
    COEFFICIENTS
        .iter()
        .zip(b)
        .map(|(c, terms)| format!("{c}={}", terms.iter().map(|t| t.name()).collect::<Vec<_>>().join(",")))
        .collect::<Vec<_>>()
        .join(";")
}

/// One pooled campaign: the files in the given order (timed; the manifest's answer and table),
/// in reverse order, and the first file alone ([`pooled_checks`]).
#[allow(clippy::too_many_arguments)]
fn pooled_case(
    id: &str,
    suite: &'static str,
    planted: Value,
    table_effects: Value,
    reproduce: String,
    csvs: &[PathBuf],
    aircraft: &Path,
    s: &GapSettings,
) -> Case {
    if csvs.is_empty() {
        return Case {
            id: id.to_string(),
            suite,
            planted,
            table_effects,
            reproduce,
            result: Err("the campaign has no manoeuvre file".into()),
            pooled: None,
        };
    }
    let read =
        |files: &[PathBuf]| crate::io::read_pooled(files, Some(aircraft), &[], &crate::io::ReadOptions::default());
    let result = read(csvs).and_then(|f| timed(&f, s));
    let mut reversed: Vec<PathBuf> = csvs.to_vec();
    reversed.reverse();
    let again = read(&reversed).and_then(|f| run_gaps(&f, s).map_err(|e| e.to_string()));
    let alone = read(&csvs[..1]).and_then(|f| run_gaps(&f, s).map_err(|e| e.to_string()));
    let pooled = pooled_checks(result.as_ref().ok().map(|r| &r.0), &again, &alone, &csvs[0]);
    Case {
        id: id.to_string(),
        suite,
        planted,
        table_effects,
        reproduce,
        result,
        pooled: Some(pooled),
    }
}

/// The named causes as (kind, location, term), sorted.
fn causes(r: &GapReport) -> Vec<(String, String, String)> {
    let mut v: Vec<_> = r
        .named
        .iter()
        .map(|n| (format!("{:?}", n.kind), n.location.clone(), n.what.clone()))
        .collect();
    v.sort();
    v
}

/// What the order and single-manoeuvre checks found: the causes named with the files reversed
/// and whether they are the forward run's; what the first manoeuvre alone gives (an error of the
/// analysis, or its verdict and any cause it names).
fn pooled_checks(
    forward: Option<&GapReport>,
    reversed: &Result<GapReport, String>,
    alone: &Result<GapReport, String>,
    first: &Path,
) -> Value {
    let list = |c: &[(String, String, String)]| {
        c.iter()
            .map(|(k, l, w)| json!({"kind": k, "location": l, "what": w}))
            .collect::<Vec<_>>()
    };
    let order = match reversed {
        Ok(r) => json!({
            "named": list(&causes(r)),
            "same_causes": forward.map(|f| causes(f) == causes(r)),
        }),
        Err(e) => json!({"error": e, "same_causes": forward.is_none()}),
    };
    let single = match alone {
        Ok(r) => json!({"verdict": r.verdict, "named": list(&causes(r)), "error": Value::Null}),
        Err(e) => json!({"verdict": Value::Null, "named": [], "error": e}),
    };
    let mut single = single;
    single["file"] = json!(first.file_name().map(|f| f.to_string_lossy().to_string()));
    json!({"reversed": order, "single_manoeuvre": single})
}

/// The median, smallest and largest analysis time per suite of the manifest's entries.
pub fn timing_summary(manifest: &[Value]) -> Value {
    let mut by_suite: std::collections::BTreeMap<String, (Vec<f64>, Vec<f64>)> = Default::default();
    for e in manifest {
        let a = &e["aerosid"];
        if let (Some(suite), Some(s), Some(c)) = (e["suite"].as_str(), a["seconds"].as_f64(), a["cpu_seconds"].as_f64())
        {
            let v = by_suite.entry(suite.to_string()).or_default();
            v.0.push(s);
            v.1.push(c);
        }
    }
    let median = |t: &mut Vec<f64>| {
        t.sort_by(f64::total_cmp);
        let k = t.len();
        if k % 2 == 1 {
            t[k / 2]
        } else {
            0.5 * (t[k / 2 - 1] + t[k / 2])
        }
    };
    let suites: serde_json::Map<String, Value> = by_suite
        .into_iter()
        .map(|(suite, (mut wall, mut cpu))| {
            let k = wall.len();
            let (mw, mc) = (median(&mut wall), median(&mut cpu));
            (
                suite,
                json!({"flights": k, "median_s": mw, "min_s": wall[0], "max_s": wall[k - 1], "median_cpu_s": mc}),
            )
        })
        .collect();
    json!({
        "what": "seconds of run_gaps per flight (flight in memory to report), one thread per flight: wall-clock (`_s`) and the thread's CPU time (`_cpu_s`)",
        "threads": rayon::current_num_threads(),
        "suites": suites,
    })
}

/// Duration of each simulated benchmark flight, s.
const SIM_SECONDS: f64 = 90.0;

fn sim_case(e: Option<HiddenEffect>, seed: u64, settings: &GapSettings) -> Case {
    let id = format!(
        "sim/{}_{seed}",
        e.map_or("clean".to_string(), |e| e.kind.name().to_string())
    );
    let reproduce = match &e {
        Some(e) => e.command_line(seed, SIM_SECONDS),
        None => format!("aerosid gaps --clean --seed {seed} --seconds {SIM_SECONDS:?}"),
    } + &Levels::of(settings).args();
    let planted = match &e {
        None => json!([]),
        Some(e) => {
            let (k, l) = e.expected();
            let mut p = json!({"kind": format!("{k:?}"), "location": l, "size": e.size});
            if let Some(t) = e.expected_terms() {
                p["terms"] = json!(t);
            }
            json!([p])
        }
    };
    let result = flight(e.as_ref(), SIM_SECONDS, seed, true)
        .map_err(|x| x.to_string())
        .and_then(|f| {
            let s = GapSettings {
                baseline: Some(HiddenEffect::baseline(e.as_ref())),
                ..settings.clone()
            };
            timed(&f, &s)
        });
    Case {
        id,
        suite: "sim",
        planted,
        table_effects: Value::Null,
        reproduce,
        result,
        pooled: None,
    }
}

fn analyse(data: &Path, companion: &Path, s: &GapSettings) -> Result<(GapReport, Seconds), String> {
    let f = read_measured(data, companion).map_err(|e| e.to_string())?;
    timed(&f, s)
}

fn timed(f: &crate::io::measured::MeasuredFlight, s: &GapSettings) -> Result<(GapReport, Seconds), String> {
    let t0 = std::time::Instant::now();
    let c0 = cpu_time::ThreadTime::now();
    let r = run_gaps(f, s).map_err(|e| e.to_string())?;
    let cpu = c0.elapsed().as_secs_f64();
    Ok((
        r,
        Seconds {
            wall: t0.elapsed().as_secs_f64(),
            cpu,
        },
    ))
}

fn entry(case: &Case, r: &GapReport, t: Seconds, table: &str) -> Value {
    let reg = &r.regression;
    let coefficients: serde_json::Map<String, Value> = reg
        .coefficients
        .iter()
        .map(|(name, _, base, lib)| {
            let i = COEFFICIENTS.iter().position(|c| c == name).unwrap_or(0);
            let cands: serde_json::Map<String, Value> = lib
                .iter()
                .map(|t| (t.name().to_string(), json!(format!("{:?}", t.kind(i)))))
                .collect();
            (
                name.clone(),
                json!({
                    "baseline": base.iter().map(|t| t.name()).collect::<Vec<_>>(),
                    "candidates": cands,
                }),
            )
        })
        .collect();
    let mut e = json!({
        "id": case.id,
        "suite": case.suite,
        "table": table,
        "split": reg.n_id,
        "planted": case.planted,
        "reproduce": case.reproduce,
        "coefficients": coefficients,
        "aerosid": {
            "named": r.named.iter().map(|n| json!({
                "kind": format!("{:?}", n.kind), "location": n.location, "what": n.what,
            })).collect::<Vec<_>>(),
            "seconds": t.wall,
            "cpu_seconds": t.cpu,
            "verdict": r.verdict,
            "air_data": r.air_data,
        },
    });
    if !case.table_effects.is_null() {
        e["table_effects"] = case.table_effects.clone();
    }
    e
}

/// The regression table: `t_s`, `z:C_L` …, `x:<term>` for every term with a column.
fn table_csv(r: &GapReport) -> String {
    let reg = &r.regression;
    let mut s = String::from("t_s");
    for (name, ..) in &reg.coefficients {
        s.push_str(&format!(",z:{name}"));
    }
    for t in reg.columns.keys() {
        s.push_str(&format!(",x:{}", t.name()));
    }
    s.push('\n');
    for (k, t) in reg.t_s.iter().enumerate() {
        s.push_str(&format!("{t}"));
        for (_, z, ..) in &reg.coefficients {
            s.push_str(&format!(",{:.6e}", z[k]));
        }
        for c in reg.columns.values() {
            s.push_str(&format!(",{:.6e}", c[k]));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clean simulated card through the card suite: one manifest entry with its regression
    /// table (the split inside it), its report, the causes of the reversed files equal to the
    /// forward run's (the analysis sorts its pieces), and the first manoeuvre alone (6 s) with no
    /// cause and a reason — the 20 s the held-out test needs.
    #[test]
    fn a_clean_card_is_order_invariant_and_one_manoeuvre_gets_no_verdict() {
        let dir = std::env::temp_dir().join(format!("aerosid-bench-card-{}", std::process::id()));
        let campaign = Campaign {
            draws_per_kind: 0,
            clean: 0,
            jsbsim: None,
            real: None,
            levels: Levels::default(),
            cards: Some(Cards {
                seeds_per_kind: 0,
                clean: 1,
                jsbsim: None,
            }),
        };
        let lines = write(&campaign, &dir).expect("the campaign runs");
        let text = std::fs::read_to_string(dir.join("manifest.json")).expect("a manifest");
        let m: Vec<Value> = serde_json::from_str(&text).expect("JSON");
        assert_eq!(m.len(), 1, "{lines:?}");
        let e = &m[0];
        assert_eq!(e["suite"], "card");
        assert_eq!(e["planted"], json!([]));
        let table = std::fs::read_to_string(dir.join(e["table"].as_str().expect("a table"))).expect("the table");
        let rows = table.lines().count() - 1;
        let split = e["split"].as_u64().expect("a split") as usize;
        assert!(split > 0 && split < rows, "split {split} of {rows} rows");
        assert!(dir.join(e["report"].as_str().expect("a report")).is_file());
        let p = &e["pooled"];
        assert_eq!(p["reversed"]["same_causes"], json!(true), "{p}");
        let single = &p["single_manoeuvre"];
        assert_eq!(single["named"], json!([]), "{single}");
        let reason = single["error"].as_str().or(single["verdict"].as_str()).unwrap_or("");
        assert!(reason.contains("20 s"), "{single}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
