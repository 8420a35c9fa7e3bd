//! Issue 6 §3: flights with one hidden effect, drawn at random; the model-gap analysis
//! ([`aerosid_host::gaps::run_gaps`]) is told nothing of the draw and must name the hidden effect as
//! its top cause, and name nothing on clean flights.
//!
//! The campaign: 40 flights whose hidden effect (kind and size) is drawn by a seeded ChaCha8 from
//! the 8 kinds of [`HiddenKind`], and 20 clean flights, each 90 s at 100 Hz with its own sensor-noise
//! seed. Required (issue 6 §3): ≥ 95 % named correctly (kind *and* place: the coefficient, or the
//! sensor channel), and nothing named on ≥ 95 % of the clean flights. The confusion table is
//! printed (`cargo test --test gaps -- --nocapture`).

use aerosid_host::gaps::hidden::{flight, HiddenEffect, HiddenKind};
use aerosid_host::gaps::{run_gaps, GapSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Number of flights with a hidden effect, and of clean flights (issue 6 §3: ≥ 40 and ≥ 20).
const HIDDEN: usize = 40;
const CLEAN: usize = 20;
/// Flight length, s.
const DURATION_S: f64 = 90.0;

struct Outcome {
    truth: String,
    named: String,
    correct: bool,
    detail: String,
}

fn case(effect: Option<HiddenEffect>, seed: u64) -> Outcome {
    let f = flight(effect.as_ref(), DURATION_S, seed).expect("the campaign's flights trim");
    let r = run_gaps(&f, &GapSettings::default()).expect("the simulated flight has every channel");
    let top = r.top_cause();
    let named = top.map_or("nothing".to_string(), |c| format!("{:?}", c.kind));
    let (truth, correct) = match &effect {
        None => ("clean".to_string(), top.is_none()),
        Some(e) => {
            let (kind, place) = e.expected();
            (
                format!("{:?}", e.kind),
                top.is_some_and(|c| c.kind == kind && c.location == place),
            )
        }
    };
    let detail = format!(
        "{:<48} → {}",
        effect.map_or("clean".into(), |e| e.describe()),
        top.map_or("nothing".into(), |c| format!(
            "{:?} in {}: {} (t² {:.0})",
            c.kind, c.location, c.what, c.t2
        ))
    );
    Outcome {
        truth,
        named,
        correct,
        detail,
    }
}

#[test]
fn the_analysis_names_the_hidden_effect_and_nothing_on_clean_flights() {
    // GIVEN 40 hidden effects drawn by a seeded generator from 8 kinds, and 20 clean flights
    let mut rng = ChaCha8Rng::seed_from_u64(0x6a95);
    let draws: Vec<(Option<HiddenEffect>, u64)> = (0..HIDDEN)
        .map(|i| (Some(HiddenEffect::draw(&mut rng)), 1000 + i as u64))
        .chain((0..CLEAN).map(|i| (None, 5000 + i as u64)))
        .collect();
    let kinds_drawn: std::collections::BTreeSet<HiddenKind> =
        draws.iter().filter_map(|d| d.0.map(|e| e.kind)).collect();
    assert!(
        kinds_drawn.len() >= 8,
        "the draw covers only {} kinds",
        kinds_drawn.len()
    );
    // WHEN the analysis runs on each, told nothing of the draw
    let out: Vec<Outcome> = draws.par_iter().map(|(e, seed)| case(*e, *seed)).collect();
    // THEN print the confusion table
    let mut table: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut columns = std::collections::BTreeSet::new();
    for o in &out {
        *table
            .entry(o.truth.clone())
            .or_default()
            .entry(o.named.clone())
            .or_default() += 1;
        columns.insert(o.named.clone());
    }
    let columns: Vec<String> = columns.into_iter().collect();
    println!("confusion table (rows: hidden effect; columns: top cause named)");
    print!("{:<15}", "");
    for c in &columns {
        print!(" {:>16}", c);
    }
    println!();
    for (row, counts) in &table {
        print!("{:<15}", row);
        for c in &columns {
            print!(" {:>16}", counts.get(c).copied().unwrap_or(0));
        }
        println!();
    }
    for o in out.iter().filter(|o| !o.correct) {
        println!("MISSED: {}", o.detail);
    }
    let hidden: Vec<&Outcome> = out.iter().filter(|o| o.truth != "clean").collect();
    let clean: Vec<&Outcome> = out.iter().filter(|o| o.truth == "clean").collect();
    let named_right = hidden.iter().filter(|o| o.correct).count();
    let quiet = clean.iter().filter(|o| o.correct).count();
    println!(
        "named correctly (kind and place): {named_right}/{} = {:.1} %; clean flights with nothing named: {quiet}/{} = {:.1} %",
        hidden.len(),
        100.0 * named_right as f64 / hidden.len() as f64,
        clean.len(),
        100.0 * quiet as f64 / clean.len() as f64
    );
    // AND at least 95 % of each (issue 6 §3)
    assert!(
        20 * named_right >= 19 * hidden.len(),
        "{named_right}/{} named correctly",
        hidden.len()
    );
    assert!(
        20 * quiet >= 19 * clean.len(),
        "{quiet}/{} clean flights quiet",
        clean.len()
    );
}

#[test]
fn each_kind_of_hidden_effect_is_named_in_its_place() {
    // GIVEN one flight per kind, the size drawn by a seeded generator (the first draw of each kind
    // from seed 7; no selection), and the analysis told nothing
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let effects: Vec<HiddenEffect> = HiddenKind::ALL.iter().map(|k| k.draw(&mut rng)).collect();
    // WHEN it runs on each
    let out: Vec<Outcome> = effects
        .par_iter()
        .enumerate()
        .map(|(i, e)| case(Some(*e), 300 + i as u64))
        .collect();
    // THEN each is named as the top cause, kind and place — every one: a kind that is never named
    // could hide inside the 5 % the campaign allows, so each kind is required on its own flight
    for o in &out {
        println!("{}", o.detail);
    }
    let missed: Vec<&String> = out.iter().filter(|o| !o.correct).map(|o| &o.detail).collect();
    assert!(missed.is_empty(), "missed: {missed:?}");
}
