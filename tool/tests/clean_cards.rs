//! False alarms on clean simulated test cards: short manoeuvres logged as a small UAV's autopilot
//! logs them (channels at 5–50 Hz held on a 50 Hz grid, α and β estimated), no hidden effect, read
//! back from their files as a user's would be and analysed pooled.

use aerosid::card::{write_card, CardSettings, AIRCRAFT_FILE};
use aerosid::gaps::hidden::HiddenEffect;
use aerosid::gaps::{run_gaps, GapSettings};
use aerosid::sim::test_card::CardTurbulence;

/// The causes named on a card (`what in location`) flown with `effect`, `seed`, `turbulence`,
/// written to files, read back pooled and analysed with the benchmark's baseline.
fn causes_named(
    root: &std::path::Path,
    effect: Option<HiddenEffect>,
    seed: u64,
    turbulence: CardTurbulence,
) -> Vec<String> {
    let dir = root.join(format!("card_{seed}"));
    let card = CardSettings {
        effect,
        seed,
        turbulence,
    };
    let csvs: Vec<_> = write_card(&dir, &card)
        .expect("the card is flown and written")
        .into_iter()
        .filter(|f| f.extension().is_some_and(|x| x == "csv"))
        .collect();
    let flight = aerosid::io::read_pooled(
        &csvs,
        Some(&dir.join(AIRCRAFT_FILE)),
        &[],
        &aerosid::io::ReadOptions::default(),
    )
    .expect("the card reads back");
    let settings = GapSettings {
        baseline: Some(HiddenEffect::baseline(effect.as_ref())),
        ..GapSettings::default()
    };
    let r = run_gaps(&flight, &settings).expect("the analysis runs");
    r.named
        .iter()
        .map(|c| format!("{} in {}", c.what, c.location))
        .collect()
}

/// Six clean cards (the benchmark's first six clean seeds, light and moderate turbulence in turn):
/// at most one names a cause.
///
/// Tolerance: the target is at most one clean campaign in 20 with a cause; at that rate, two or
/// more of six happen with probability 1 − 0.95⁶ − 6·0.05·0.95⁵ = 3.3 %, so the test allows one.
/// The seeds are fixed, so the outcome is reproducible. With the slow channels' noise read on the
/// grid (where it comes out as zero), four of these six name `ΔV/V` or `C_T` in `C_D`: the pitot's
/// and the propeller speed's error, shared by a candidate and by the coefficient, taken for an
/// effect (`aerosid::gaps::held_noise`).
#[test]
fn at_most_one_of_six_clean_cards_names_a_cause() {
    let root = std::env::temp_dir().join(format!("aerosid-clean-cards-{}", std::process::id()));
    let mut with_cause = Vec::new();
    for (i, seed) in (300u64..306).enumerate() {
        let turbulence = if i % 2 == 0 {
            CardTurbulence::Light
        } else {
            CardTurbulence::Moderate
        };
        let named = causes_named(&root, None, seed, turbulence);
        if !named.is_empty() {
            with_cause.push(format!("seed {seed} ({}): {}", turbulence.name(), named.join(", ")));
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    assert!(
        with_cause.len() <= 1,
        "{} of 6 clean cards name a cause:\n{}",
        with_cause.len(),
        with_cause.join("\n")
    );
}

/// The benchmark's clean cards 338 and 348 (light turbulence) named `C_T` and `ΔV/V` in `C_L`
/// when the gust the estimated α misses was left in `C_L`'s residual as noise; with it judged
/// (`aerosid::gaps::gust`) they name nothing, and `C_L` is reported not identifiable from the
/// manoeuvres. Cards 330 and 342 (light) named `δe²` in `C_D` and `α·p_n` in `C_l`, terms the
/// autopilot's loops correlate with that gust; with the candidates of the other coefficients
/// tested beyond the gust's proxies (the `C_L` and `C_Y` residuals) they name nothing either. The planted elevator drag of card 311 (light, `|δe|` in `C_D`, 1.5× the oracle's
/// limit and more) is still named: the check does not silence a coefficient whose residual an
/// effect dominates.
#[test]
fn the_gust_the_estimated_angles_miss_names_nothing_and_keeps_a_planted_drag() {
    let root = std::env::temp_dir().join(format!("aerosid-gust-cards-{}", std::process::id()));
    for seed in [330u64, 338, 342, 348] {
        let named = causes_named(&root, None, seed, CardTurbulence::Light);
        assert!(named.is_empty(), "clean card {seed} names {named:?}");
    }
    let drag = aerosid::card::draw_effect(aerosid::gaps::hidden::HiddenKind::ElevatorDrag, 311, None)
        .expect("an elevator drag on a card");
    let named = causes_named(&root, Some(drag), 311, CardTurbulence::Light);
    let _ = std::fs::remove_dir_all(&root);
    assert!(named.iter().any(|n| n == "|δe| in C_D"), "card 311 names {named:?}");
}
