//! `aerosid card`: a simulated flight-test card of short manoeuvres, logged as a small UAV's
//! autopilot logs it ([`crate::sim::test_card`], [`crate::sim::uav_log`]), with at most one hidden
//! effect of the model-gap campaign ([`crate::gaps::hidden`]), written as one project CSV per
//! manoeuvre plus the aircraft file and a `truth.json` (docs/test-card.md).
//!
//! The flight is the campaign's ([`hidden::config`]: the skywalker at 15 m/s, white-noise sensors
//! without biases, servos, the effect planted in the plant, the sensors or the log) with the card's
//! manoeuvres, flown in MANUAL (no stabiliser, [`fly_card`]), and MIL-F-8785C turbulence instead
//! of the campaign's long schedule and light Dryden gusts. The card has no vanes, so the hidden kinds that act on the α vane
//! (`vane-scale`, `time-delay`, a sensor bias on α) are refused; a drawn `sensor-bias` is drawn
//! again until it sits on the pitch gyro or the z accelerometer.

use crate::gaps::hidden::{self, HiddenEffect, HiddenKind};
use crate::io::measured::Quantity;
use crate::io::project_csv::csv_column;
use crate::sim::sensors::FaultChannel;
use crate::sim::test_card::{fly_card, standard_card, CardRecord, CardTurbulence};
use crate::sim::uav_log::{UavLog, UavLogging};
use crate::sim::{SimConfig, SimError};
use rand::SeedableRng;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The column of the estimated α (the reader takes it as α with an estimator as its origin).
pub const ALPHA_EST_COLUMN: &str = "alpha_est_rad";
/// The column of the estimated β.
pub const BETA_EST_COLUMN: &str = "beta_est_rad";
/// The aircraft file written beside the records (the nominal skywalker: a planted thrust-line
/// offset is not in it).
pub const AIRCRAFT_FILE: &str = "skywalker_2013_mod.aircraft";
const AIRCRAFT_TEXT: &str = include_str!("../data/aircraft/skywalker_2013_mod.aircraft");

/// Why a card could not be made.
#[derive(Debug)]
pub enum CardError {
    /// The hidden effect needs a vane, which the card's aircraft does not have.
    NoVane(HiddenKind),
    /// The simulation failed.
    Sim(SimError),
    /// A file could not be written.
    Io {
        /// The file.
        path: PathBuf,
        /// The system's message.
        message: String,
    },
}

impl core::fmt::Display for CardError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoVane(k) => write!(
                f,
                "--effect {}: acts on the α vane, and the card's aircraft has none (α and β are estimated); \
                 choose another kind, e.g. sensor-bias (pitch gyro or z accelerometer) or an aerodynamic one",
                k.name()
            ),
            Self::Sim(e) => write!(f, "{e}"),
            Self::Io { path, message } => write!(f, "{}: {message}", path.display()),
        }
    }
}

impl std::error::Error for CardError {}

impl From<SimError> for CardError {
    fn from(e: SimError) -> Self {
        Self::Sim(e)
    }
}

/// Whether a hidden effect can be planted on a card (not on the α vane it does not have).
pub fn check_effect(e: &HiddenEffect) -> Result<(), CardError> {
    let on_alpha = e.channel == Some(FaultChannel::Alpha);
    match e.kind {
        HiddenKind::VaneScale | HiddenKind::TimeDelay => Err(CardError::NoVane(e.kind)),
        HiddenKind::SensorBias if on_alpha => Err(CardError::NoVane(e.kind)),
        _ => Ok(()),
    }
}

/// The hidden effect of `kind` for a card of seed `seed`: its size (and a sensor bias's channel)
/// drawn from the seed as `aerosid gaps --simulate` does, a bias on α drawn again; `size`
/// replaces the drawn size.
pub fn draw_effect(kind: HiddenKind, seed: u64, size: Option<f64>) -> Result<HiddenEffect, CardError> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut e = kind.draw(&mut rng);
    while kind == HiddenKind::SensorBias && e.channel == Some(FaultChannel::Alpha) {
        e = kind.draw(&mut rng);
    }
    if let Some(s) = size {
        e.size = s;
    }
    check_effect(&e)?;
    Ok(e)
}

/// A card's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CardSettings {
    /// The hidden effect (`None`: clean).
    pub effect: Option<HiddenEffect>,
    /// The seed (record `i` flies with [`crate::sim::test_card::record_seed`]).
    pub seed: u64,
    /// The turbulence level.
    pub turbulence: CardTurbulence,
}

/// The simulator configuration every record of the card starts from (its schedule and duration
/// are the manoeuvre's).
pub fn config(s: &CardSettings) -> SimConfig {
    let mut cfg = hidden::config(s.effect.as_ref(), 10.0, s.seed, false);
    cfg.turbulence = Some(s.turbulence.turbulence(cfg.altitude_m));
    cfg
}

/// Flies and logs the card (no files).
pub fn fly(s: &CardSettings) -> Result<Vec<CardRecord>, CardError> {
    if let Some(e) = &s.effect {
        check_effect(e)?;
    }
    let lead = s
        .effect
        .filter(|e| e.kind == HiddenKind::ElevatorDelay)
        .map_or(0.0, |e| e.size);
    Ok(fly_card(
        &config(s),
        &standard_card(),
        &UavLogging::default(),
        lead,
        s.seed,
    )?)
}

/// The columns of a logged record, in file order: the project layout's names
/// ([`csv_column`]), the estimated flow angles, then the truth (ignored by the readers).
pub fn columns(log: &UavLog) -> Vec<(&'static str, &[f64])> {
    use Quantity::*;
    vec![
        (csv_column(AccelX), &log.accel_mps2[0][..]),
        (csv_column(AccelY), &log.accel_mps2[1]),
        (csv_column(AccelZ), &log.accel_mps2[2]),
        (csv_column(RollRate), &log.gyro_rad_s[0]),
        (csv_column(PitchRate), &log.gyro_rad_s[1]),
        (csv_column(YawRate), &log.gyro_rad_s[2]),
        (csv_column(Airspeed), &log.airspeed_mps),
        (ALPHA_EST_COLUMN, &log.alpha_est_rad),
        (BETA_EST_COLUMN, &log.beta_est_rad),
        (csv_column(Roll), &log.euler_rad[0]),
        (csv_column(Pitch), &log.euler_rad[1]),
        (csv_column(Yaw), &log.euler_rad[2]),
        (csv_column(VelocityNorth), &log.vel_ned_mps[0]),
        (csv_column(VelocityEast), &log.vel_ned_mps[1]),
        (csv_column(VelocityDown), &log.vel_ned_mps[2]),
        (csv_column(Elevator), &log.surfaces_rad[0]),
        (csv_column(Aileron), &log.surfaces_rad[1]),
        (csv_column(Rudder), &log.surfaces_rad[2]),
        (csv_column(Throttle), &log.throttle),
        (csv_column(AirDensity), &log.air_density_kgpm3),
        (csv_column(PropSpeed), &log.prop_speed_rad_s),
        ("truth_alpha_rad", &log.truth_alpha_rad),
        ("truth_beta_rad", &log.truth_beta_rad),
        ("truth_airspeed_mps", &log.truth_airspeed_mps),
    ]
}

/// A record as project CSV text (`t_s` first; six decimals, below every channel's noise).
pub fn csv_text(log: &UavLog) -> String {
    let cols = columns(log);
    let mut s = String::from("t_s");
    for (name, _) in &cols {
        s.push(',');
        s.push_str(name);
    }
    s.push('\n');
    for (i, t) in log.t_s.iter().enumerate() {
        let _ = write!(s, "{t:.2}");
        for (_, v) in &cols {
            let _ = write!(s, ",{:.6}", v[i]);
        }
        s.push('\n');
    }
    s
}

/// The file name of a record.
pub fn record_file(r: &CardRecord) -> String {
    format!("{}.csv", r.manoeuvre.name)
}

/// The card's `truth.json`: settings, the planted effect with what the analysis should name and
/// the baseline it is given, the logging model, and every record.
pub fn truth_json(s: &CardSettings, records: &[CardRecord]) -> serde_json::Value {
    use serde_json::json;
    let planted = s.effect.map(|e| {
        let (cause, location) = e.expected();
        json!({
            "kind": e.kind.name(),
            "cause": format!("{cause:?}"),
            "location": location,
            "size": e.size,
            "channel": e.channel.map(|c| format!("{c:?}")),
            "terms": e.expected_terms(),
            "description": e.describe(),
        })
    });
    let names = ["C_L", "C_D", "C_Y", "C_l", "C_m", "C_n"];
    let baseline: serde_json::Map<String, serde_json::Value> = hidden::HiddenEffect::baseline(s.effect.as_ref())
        .iter()
        .zip(names)
        .map(|(terms, n)| (n.to_string(), json!(terms.iter().map(|t| t.name()).collect::<Vec<_>>())))
        .collect();
    let cfg = config(s);
    let turb = cfg.turbulence.unwrap_or(crate::sim::Turbulence {
        lengths_m: [0.0; 3],
        sigma_mps: [0.0; 3],
    });
    let l = UavLogging::default();
    let timing = |t: &crate::sim::uav_log::ChannelTiming| json!({"rate_hz": t.rate_hz, "lag_s": t.lag_s, "jitter_s": t.jitter_s});
    json!({
        "generator": "aerosid card",
        "aircraft": "skywalker_2013_mod",
        "aircraft_file": AIRCRAFT_FILE,
        "seed": s.seed,
        "turbulence": {
            "level": s.turbulence.name(),
            "model": "MIL-F-8785C low altitude, Dryden",
            "sigma_mps": turb.sigma_mps,
            "lengths_m": turb.lengths_m,
        },
        "planted": planted,
        "baseline": baseline,
        "flow_angles": "estimated (no vanes): alpha_est_rad, beta_est_rad from the EKF velocity minus a lagged wind estimate",
        "logging": {
            "grid_hz": l.grid_hz,
            "resampling": "sample-and-hold",
            "imu": timing(&l.imu),
            "attitude": timing(&l.attitude),
            "gps_velocity": timing(&l.gps_velocity),
            "airspeed": timing(&l.airspeed),
            "servo": timing(&l.servo),
            "flow_angles": timing(&l.flow_angles),
            "baro": timing(&l.baro),
            "rpm": timing(&l.rpm),
            "wind_time_constant_s": l.wind_time_constant_s,
            "wind_error_mps": l.wind_error_mps,
        },
        "records": records.iter().map(|r| {
            let m = r.manoeuvre.manoeuvre;
            json!({
                "file": record_file(r),
                "manoeuvre": r.manoeuvre.name,
                "channel": format!("{:?}", m.channel),
                "shape": format!("{:?}", m.shape),
                "amplitude": m.amplitude,
                "period_s": m.period_s,
                "lead_in_s": m.start_s,
                "duration_s": r.manoeuvre.duration_s,
                "samples": r.log.t_s.len(),
                "seed": r.seed,
                "excursions": excursions_json(&r.excursions),
            })
        }).collect::<Vec<_>>(),
    })
}

/// A record's excursions (truth, from the lead-in's mean) as `[RMS, peak]` pairs in SI units.
fn excursions_json(e: &crate::sim::test_card::Excursions) -> serde_json::Value {
    let pair = |(rms, peak): (f64, f64)| serde_json::json!([rms, peak]);
    serde_json::json!({
        "alpha_rad": pair(e.alpha_rad),
        "beta_rad": pair(e.beta_rad),
        "bank_rad": pair(e.bank_rad),
        "p_rad_s": pair(e.rates_rad_s[0]),
        "q_rad_s": pair(e.rates_rad_s[1]),
        "r_rad_s": pair(e.rates_rad_s[2]),
        "airspeed_mps": pair(e.airspeed_mps),
        "surface_rad": pair(e.surface_rad),
    })
}

fn write(path: &Path, text: &str) -> Result<(), CardError> {
    std::fs::write(path, text).map_err(|e| CardError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Flies the card and writes it into `dir` (created if missing): one CSV per manoeuvre, the
/// aircraft file and `truth.json`. Returns the files written.
pub fn write_card(dir: &Path, s: &CardSettings) -> Result<Vec<PathBuf>, CardError> {
    let records = fly(s)?;
    std::fs::create_dir_all(dir).map_err(|e| CardError::Io {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut files = Vec::new();
    for r in &records {
        let p = dir.join(record_file(r));
        write(&p, &csv_text(&r.log))?;
        files.push(p);
    }
    let p = dir.join(AIRCRAFT_FILE);
    write(&p, AIRCRAFT_TEXT)?;
    files.push(p);
    let p = dir.join("truth.json");
    let text = serde_json::to_string_pretty(&truth_json(s, &records)).unwrap_or_default();
    write(&p, &text)?;
    files.push(p);
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_card::CardRecord;

    fn card(effect: Option<HiddenEffect>, seed: u64, turbulence: CardTurbulence) -> Vec<CardRecord> {
        fly(&CardSettings {
            effect,
            seed,
            turbulence,
        })
        .expect("the card flies")
    }

    fn changes(v: &[f64]) -> usize {
        v.windows(2).filter(|w| w[0] != w[1]).count()
    }

    fn rms(v: impl Iterator<Item = f64>) -> f64 {
        let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
        (s / n.max(1) as f64).sqrt()
    }

    /// Every record is its manoeuvre's length on the 50 Hz grid, and each channel is a staircase
    /// at its own rate: over a record of T s a channel at f Hz changes f·T times, give or take the
    /// sample straddling the end and the first samples, which (lagged before the record's start)
    /// all read its first value — at most 3 fewer (the GPS: 200 ms lag at 5 Hz), 1 more.
    #[test]
    fn records_have_their_lengths_and_staircase_rates() {
        let records = card(None, 3, CardTurbulence::Light);
        assert_eq!(records.len(), standard_card().len());
        let l = UavLogging::default();
        for r in &records {
            let t = r.manoeuvre.duration_s;
            assert_eq!(r.log.t_s.len(), (t * 50.0).round() as usize, "{}", r.manoeuvre.name);
            let log = &r.log;
            let channels: [(&str, &[f64], f64); 9] = [
                ("gyro q", &log.gyro_rad_s[1], l.imu.rate_hz),
                ("accel z", &log.accel_mps2[2], l.imu.rate_hz),
                ("pitch", &log.euler_rad[1], l.attitude.rate_hz),
                ("GPS v_n", &log.vel_ned_mps[0], l.gps_velocity.rate_hz),
                ("airspeed", &log.airspeed_mps, l.airspeed.rate_hz),
                ("α̂", &log.alpha_est_rad, l.flow_angles.rate_hz),
                ("elevator", &log.surfaces_rad[0], l.servo.rate_hz),
                ("density", &log.air_density_kgpm3, l.baro.rate_hz),
                ("propeller speed", &log.prop_speed_rad_s, l.rpm.rate_hz),
            ];
            for (name, v, f) in channels {
                let expected = f * t;
                let n = changes(v) as f64;
                assert!(
                    n >= expected - 3.0 && n <= expected + 1.0,
                    "{} {name}: {n} changes in {t} s, expected {expected} at {f} Hz",
                    r.manoeuvre.name
                );
            }
        }
    }

    /// α̂ differs from the true α by the wind the estimator does not see: mostly the vertical gust,
    /// which it takes as 0, so RMS(α̂ − α) ≈ σ_w/V (0.051 rad in light turbulence at 15 m/s). The
    /// bounds 0.5–2× allow for the records' shortness against the gust's correlation time
    /// (L_w/V ≈ 7 s: one record sees a fraction of the variance) and the attitude noise (0.5°) and
    /// hold. Moderate turbulence doubles σ_w; the error must grow with it (ratio 1.4–2.8), which
    /// white noise or the hold alone would not do.
    #[test]
    fn the_estimated_alpha_carries_the_unseen_wind() {
        let err = |turbulence: CardTurbulence| {
            let records = card(None, 11, turbulence);
            rms(records.iter().flat_map(|r| {
                r.log
                    .alpha_est_rad
                    .iter()
                    .zip(&r.log.truth_alpha_rad)
                    .map(|(a, b)| a - b)
                    .collect::<Vec<_>>()
            }))
        };
        let sigma_w_over_v = CardTurbulence::Light.turbulence(100.0).sigma_mps[2] / 15.0;
        let light = err(CardTurbulence::Light);
        let moderate = err(CardTurbulence::Moderate);
        assert!(
            (0.5 * sigma_w_over_v..=2.0 * sigma_w_over_v).contains(&light),
            "light: RMS(α̂ − α) {light:.4} rad for σ_w/V {sigma_w_over_v:.4}"
        );
        assert!(
            (1.4..=2.8).contains(&(moderate / light)),
            "moderate/light RMS(α̂ − α): {moderate:.4}/{light:.4}"
        );
    }

    /// The card's files read back through `read_measured` with the aircraft file written beside
    /// them: same length and, to the six decimals written, the same IMU, airspeed and GPS velocity.
    #[test]
    fn the_files_read_back() {
        let dir = std::env::temp_dir().join(format!("aerosid-card-test-{}", std::process::id()));
        let s = CardSettings {
            effect: Some(draw_effect(HiddenKind::SensorBias, 5, None).expect("a bias off α")),
            seed: 5,
            turbulence: CardTurbulence::Moderate,
        };
        let files = write_card(&dir, &s).expect("written");
        let records = fly(&s).expect("flies");
        let aircraft = dir.join(AIRCRAFT_FILE);
        for r in &records {
            let f = crate::io::read_measured(&dir.join(record_file(r)), &aircraft).expect("reads back");
            assert_eq!(f.t_s.len(), r.log.t_s.len());
            for (q, v) in [
                (Quantity::PitchRate, &r.log.gyro_rad_s[1]),
                (Quantity::Airspeed, &r.log.airspeed_mps),
                (Quantity::VelocityDown, &r.log.vel_ned_mps[2]),
                (Quantity::Elevator, &r.log.surfaces_rad[0]),
            ] {
                // The reader replaces a staircase by straight lines through the starts of its runs
                // (io::held), so the logged values stand at every sample where the log changed
                // (all of them for a channel at the grid's rate); 5e-7 is the CSV's rounding.
                let got = f.get(q).expect("channel read");
                let worst = (0..v.len())
                    .filter(|&i| i == 0 || v[i] != v[i - 1])
                    .map(|i| (got[i] - v[i]).abs())
                    .fold(0.0, f64::max);
                assert!(worst <= 5e-7 + 1e-12, "{q:?}: {worst}");
            }
        }
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).expect("truth")).expect("json");
        assert_eq!(truth["planted"]["kind"], "sensor-bias");
        assert_eq!(truth["records"].as_array().map(Vec::len), Some(records.len()));
        assert_eq!(files.len(), records.len() + 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The kinds on the α vane are refused with the reason; a drawn sensor bias never sits on α.
    #[test]
    fn vane_effects_are_refused() {
        for k in [HiddenKind::VaneScale, HiddenKind::TimeDelay] {
            let e = draw_effect(k, 1, None).expect_err("no vane");
            assert!(e.to_string().contains("no") && e.to_string().contains(k.name()), "{e}");
        }
        for seed in 0..40 {
            let e = draw_effect(HiddenKind::SensorBias, seed, None).expect("off α");
            assert_ne!(e.channel, Some(FaultChannel::Alpha));
        }
        let bias_on_alpha = HiddenEffect {
            kind: HiddenKind::SensorBias,
            size: 0.03,
            channel: Some(FaultChannel::Alpha),
        };
        assert!(check_effect(&bias_on_alpha).is_err());
    }

    /// A planted elevator delay makes the logged elevator lead the surface: the logged elevator
    /// of the doublet record crosses its first step earlier than in the clean card of the same
    /// seed, by the planted time within one servo sample (40 ms) plus the jitter.
    #[test]
    fn a_planted_elevator_delay_leads_the_log() {
        let clean = card(None, 2, CardTurbulence::Light);
        let e = draw_effect(HiddenKind::ElevatorDelay, 2, Some(0.08)).expect("plantable");
        let delayed = card(Some(e), 2, CardTurbulence::Light);
        let step = |r: &CardRecord| {
            let v = &r.log.surfaces_rad[0];
            let base = v[0];
            r.log.t_s[v.iter().position(|x| x - base > 0.05).expect("the step")]
        };
        let (a, b) = (step(&clean[0]), step(&delayed[0]));
        assert!(
            (a - b - 0.08).abs() <= 0.04 + 0.004 + 1e-9,
            "clean {a} s, planted {b} s"
        );
    }

    /// The vendored JSBSim cards (tool/data/jsbsim_card, scripts/bench/jsbsim_card.py) read back
    /// with their aircraft file, have the estimated-α column, and are staircases at the logger's
    /// rates: at most 1 change more than rate × length, as in
    /// `records_have_their_lengths_and_staircase_rates`, and at most 10 % + 3 fewer — written with
    /// 2–4 decimals, two consecutive noisy samples round to the same text with a probability of
    /// `δ/(σ√2·√(2π))` ≤ 2.8 % for these channels (δ the last decimal, σ the noise; thrust 1 N and
    /// 10 N); a channel at half its rate would miss by 50 %. The JSBSim thrust is at 10 Hz like the
    /// airspeed.
    #[test]
    fn the_vendored_jsbsim_cards_read_back_as_staircases() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/jsbsim_card");
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(root.join("truth.json")).expect("truth.json")).expect("json");
        let cards = truth["cards"].as_object().expect("cards");
        assert_eq!(cards.len(), 3);
        let l = UavLogging::default();
        for card in cards.values() {
            for r in card["records"].as_array().expect("records") {
                let file = root.join(r["file"].as_str().expect("file"));
                let f = crate::io::read_measured(&file, &root.join("c172x.aircraft")).expect("reads back");
                let t = r["duration_s"].as_f64().expect("duration");
                assert_eq!(f.t_s.len(), (t * 50.0).round() as usize, "{}", file.display());
                let text = std::fs::read_to_string(&file).expect("text");
                assert!(text.lines().next().is_some_and(|h| h.contains(ALPHA_EST_COLUMN)));
                for (q, rate) in [
                    (Quantity::PitchRate, l.imu.rate_hz),
                    (Quantity::Pitch, l.attitude.rate_hz),
                    (Quantity::VelocityNorth, l.gps_velocity.rate_hz),
                    (Quantity::Airspeed, l.airspeed.rate_hz),
                    (Quantity::Thrust, l.airspeed.rate_hz),
                ] {
                    // A held channel found by the reader (io::held) is found at its true rate,
                    // within 10 % (jitter and the record's ends); one it leaves as logged (the
                    // grid's rate, or a staircase too irregular for the detector) keeps its steps.
                    match f.log.logged_rate_hz.get(&q) {
                        Some(&found) => assert!(
                            (found - rate).abs() <= 0.1 * rate,
                            "{} {q:?}: found held at {found} Hz, logged at {rate} Hz",
                            file.display()
                        ),
                        None => {
                            let n = changes(f.get(q).expect("channel")) as f64;
                            let expected = rate * t;
                            assert!(
                                n >= 0.9 * expected - 3.0 && n <= expected + 1.0,
                                "{} {q:?}: {n} changes, expected {expected} at {rate} Hz",
                                file.display()
                            );
                        }
                    }
                }
            }
        }
    }
}
