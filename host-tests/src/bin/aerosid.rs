//! `aerosid` — the project's command-line tool.
//!
//! `aerosid run [--out DIR] [--seed N] [--seconds S]` — the main job
//! ([`aerosid_host::report::main_job`]): simulates a flight of the default airframe, runs the six
//! on-board estimators over its log exactly as the firmware would (`f32`), prints the identified
//! model beside the truth and the RLS baseline, and writes the figures (the six coefficients,
//! Fig. 1, Fig. 2) as SVG to `DIR` (default `out/`).
//!
//! `aerosid simulate --out LOG.csv [--seed N] [--seconds S]` writes the main job's flight as a CSV
//! log; `aerosid replay LOG.csv [--qemu]` identifies the six coefficients from such a log with the
//! on-board `f32` pipeline and, with `--qemu`, runs the firmware under QEMU on the same log and
//! checks its telemetry against the host bit for bit ([`aerosid_host::replay`]).
//!
//! `aerosid gaps --data FILE --with MAP_OR_AIRCRAFT [--air-data measured|reconstructed] [--baseline SPEC] [--out DIR]`
//! (a measured flight, read by [`aerosid_host::io::read_measured`]) or
//! `aerosid gaps --simulate KIND | --clean [--seed N] [--seconds S] [--out DIR]`: the model-gap
//! analysis (issue 6, [`aerosid_host::gaps::run_gaps`]) of a measured flight, or of a simulated
//! flight with one hidden effect or none; table on the terminal, `report.json`, `report.txt` and
//! SVG figures in `DIR`. `--air-data measured` takes the regressors from the corrected air-data
//! sensors rather than from the flight-path reconstruction (which assumes steady air: use it for
//! turbulent data). `--baseline "CL=1,alpha,dV;Cm=1,alpha,dV,q,de"` replaces eq. 3 for the
//! coefficients it names ([`aerosid_host::gaps::model::parse_baseline`]); `--compatibility off`
//! skips the flight-path reconstruction.
//!
//! `aerosid fem --model FILE.toml [--data FILE]… [--segment FROM:TO]… [--fix NAME=VALUE]…
//! [--validate FILE]… [--validate-segment FROM:TO]… [--out DIR]`: the filter error / output error
//! method on a user model file ([`aerosid_host::usermodel`], e.g. `host-tests/models/hfb320.toml`),
//! pooled over the files and segments, validated on others; writes `identification.json` and SVG
//! fits. `aerosid predict --saved identification.json [--data FILE]… [--segment FROM:TO]…
//! [--out DIR]` applies a saved model to other data ([`aerosid_host::workflow`]).
//!
//! `aerosid panic-audit ELF ALLOW`: every panic path left in a firmware image, checked against the
//! allow-list `ALLOW` ([`aerosid_host::panic_audit`]; CI runs it on the release firmware with
//! `firmware/panic-allow.txt`).
//!
//! `aerosid stack-bound ELF CONFIG [--ram-budget BYTES]`: a static bound on the stack of a
//! firmware image from its machine code ([`aerosid_host::stack_bound`]; `CONFIG` gives the
//! handlers' priorities and resolves the indirect calls, `firmware/stack-bound.txt`), added to its
//! static RAM; with `--ram-budget` it fails when the sum exceeds the budget (CI: the flight
//! computer, 16 384 B).
//!
//! `aerosid demo [--seed N] [--seconds S]`: identifies a pitching-moment model
//! `C_m = C_m0 + C_mα α + C_mq q_n + C_mδe δe` (seed 000, eq. 3e; values of the `skywalker_2013_mod`
//! airframe) from generated 100 Hz data with realistic sensor noise on *every* regressor, running
//! the on-board `f32` recursive PCA-GTLS exactly as the firmware does, and prints the estimates with
//! their σ (eq. 17) beside the truth and the RLS baseline. The first 20 s are a calm cruise (no
//! excitation: the PCA threshold must refuse to invent parameters), then elevator doublets and
//! sweeps excite the short period.

use aerosid_core::{Estimator, Forgetting, Gtls, GtlsSettings, Rls, RlsSettings, Solution, VffSettings};
use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::process::ExitCode;

const NAMES: [&str; 4] = ["Cm0", "Cmα", "Cmq", "Cmδe"];
const TRUTH: [f64; 4] = [0.01, -1.3, -20.0, 1.0];
/// Sensor noise (1σ) on α [rad] (vane), q_n [-] (gyro 0.01 rad/s at V = 15 m/s, c̄ = 0.24 m),
/// δe [rad] (servo feedback), and the synthesised C_m [-].
const SIGMA: [f64; 4] = [0.0087, 0.01 * 0.24 / (2.0 * 15.0), 0.005, 0.004];
const RATE_HZ: f64 = 100.0;

enum Command {
    Demo(Args),
    Run(aerosid_host::report::MainJob),
    Simulate {
        out: std::path::PathBuf,
        seconds: f64,
        seed: u64,
    },
    Replay {
        log: std::path::PathBuf,
        qemu: bool,
    },
    FemHfb320 {
        out: std::path::PathBuf,
    },
    Fem(aerosid_host::workflow::FemArgs),
    Predict(aerosid_host::workflow::PredictArgs),
    Table1 {
        out: std::path::PathBuf,
    },
    GapsBench {
        out: std::path::PathBuf,
        draws: usize,
        clean: usize,
    },
    StackBound {
        elf: std::path::PathBuf,
        indirect: std::path::PathBuf,
        ram_budget: Option<u64>,
    },
    PanicAudit {
        elf: std::path::PathBuf,
        allow: std::path::PathBuf,
    },
    LongRun {
        hours: f64,
        seed: u64,
    },
    Gaps {
        hidden: Option<aerosid_host::gaps::hidden::HiddenKind>,
        /// A measured flight and its column map or aircraft file, instead of a simulated flight.
        data: Option<(std::path::PathBuf, std::path::PathBuf)>,
        seed: u64,
        seconds: f64,
        /// `--calm`: a simulated flight in calm air (default: the campaign's light turbulence).
        calm: bool,
        out: std::path::PathBuf,
        /// `--air-data auto|measured|reconstructed|fused` (default auto: fused when both exist).
        air_data: aerosid_host::gaps::airdata::AirDataChoice,
        /// `--apply-corrections`: remove the named sensor errors before the aerodynamics.
        apply_corrections: bool,
        /// `--baseline SPEC`: the baseline models (eq. 3 where not given).
        baseline: Option<[Vec<aerosid_host::gaps::model::Term>; 6]>,
        /// `--compatibility off`: skip the flight-path reconstruction (the data are used as they are).
        compatibility: bool,
    },
}

struct Args {
    seed: u64,
    seconds: f64,
}

/// The flags of a command whose only flag is `--out DIR` (default `out`).
fn out_dir(it: &mut impl Iterator<Item = String>, cmd: &str) -> Result<std::path::PathBuf, String> {
    let mut out = std::path::PathBuf::from("out");
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
        match flag.as_str() {
            "--out" => out = value.into(),
            _ => return Err(format!("unknown flag `{flag}` for `{cmd}`")),
        }
    }
    Ok(out)
}

fn parse() -> Result<Option<Command>, String> {
    let mut it = std::env::args().skip(1);
    let cmd = match it.next().as_deref() {
        Some("demo") => "demo",
        Some("run") => "run",
        Some("simulate") => {
            let (mut out, mut seconds, mut seed) = (None, 180.0, 1u64);
            while let Some(flag) = it.next() {
                let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
                match flag.as_str() {
                    "--out" => out = Some(std::path::PathBuf::from(value)),
                    "--seconds" => {
                        seconds = value.parse().map_err(|e| format!("--seconds {value}: {e}"))?;
                        if !(1.0..=36_000.0).contains(&seconds) {
                            return Err("--seconds must be between 1 and 36000".into());
                        }
                    }
                    "--seed" => seed = value.parse().map_err(|e| format!("--seed {value}: {e}"))?,
                    _ => return Err(format!("unknown flag `{flag}` for `simulate`")),
                }
            }
            let out = out.ok_or("simulate needs --out LOG.csv")?;
            return Ok(Some(Command::Simulate { out, seconds, seed }));
        }
        Some("panic-audit") => {
            let elf = it.next().ok_or("panic-audit needs the firmware ELF")?;
            let allow = it.next().ok_or("panic-audit needs the allow-list file")?;
            return Ok(Some(Command::PanicAudit {
                elf: elf.into(),
                allow: allow.into(),
            }));
        }
        Some("stack-bound") => {
            let elf = it.next().ok_or("stack-bound needs the firmware ELF")?;
            let indirect = it
                .next()
                .ok_or("stack-bound needs the configuration file (firmware/stack-bound.txt)")?;
            let mut ram_budget = None;
            while let Some(flag) = it.next() {
                let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
                match flag.as_str() {
                    "--ram-budget" => {
                        ram_budget = Some(value.parse().map_err(|e| format!("--ram-budget {value}: {e}"))?)
                    }
                    _ => return Err(format!("unknown flag `{flag}` for `stack-bound`")),
                }
            }
            return Ok(Some(Command::StackBound {
                elf: elf.into(),
                indirect: indirect.into(),
                ram_budget,
            }));
        }
        Some("long-run") => {
            let (mut hours, mut seed) = (10.0, 1u64);
            while let Some(flag) = it.next() {
                let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
                match flag.as_str() {
                    "--hours" => {
                        hours = value.parse().map_err(|e| format!("--hours {value}: {e}"))?;
                        if !(0.05..=100.0).contains(&hours) {
                            return Err("--hours must be between 0.05 and 100".into());
                        }
                    }
                    "--seed" => seed = value.parse().map_err(|e| format!("--seed {value}: {e}"))?,
                    _ => return Err(format!("unknown flag `{flag}` for `long-run`")),
                }
            }
            return Ok(Some(Command::LongRun { hours, seed }));
        }
        Some("gaps") => {
            // `aerosid gaps --simulate KIND | --clean [--seed N] [--seconds S] [--out DIR]`.
            let (mut hidden, mut clean, mut seed, mut seconds, mut out) =
                (None, false, 1u64, 90.0, std::path::PathBuf::from("out/gaps"));
            let (mut data, mut with): (Option<std::path::PathBuf>, Option<std::path::PathBuf>) = (None, None);
            let mut air_data = aerosid_host::gaps::airdata::AirDataChoice::Auto;
            let mut apply_corrections = true;
            let mut calm = false;
            let mut baseline = None;
            let mut compatibility = true;
            while let Some(flag) = it.next() {
                if flag == "--clean" {
                    clean = true;
                    continue;
                }
                if flag == "--no-corrections" {
                    apply_corrections = false;
                    continue;
                }
                if flag == "--calm" {
                    calm = true;
                    continue;
                }
                let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
                match flag.as_str() {
                    "--simulate" => {
                        hidden = Some(aerosid_host::gaps::hidden::HiddenKind::parse(&value).ok_or_else(|| {
                            let names: Vec<&str> = aerosid_host::gaps::hidden::HiddenKind::ALL
                                .iter()
                                .map(|k| k.name())
                                .collect();
                            format!("--simulate {value}: unknown kind (one of {})", names.join(", "))
                        })?)
                    }
                    "--seed" => seed = value.parse().map_err(|e| format!("--seed {value}: {e}"))?,
                    "--seconds" => {
                        seconds = value.parse().map_err(|e| format!("--seconds {value}: {e}"))?;
                        if !(20.0..=3600.0).contains(&seconds) {
                            return Err("--seconds for `gaps` must be between 20 and 3600".into());
                        }
                    }
                    "--out" => out = value.into(),
                    "--data" => data = Some(value.into()),
                    "--baseline" => {
                        baseline = Some(
                            aerosid_host::gaps::model::parse_baseline(&value)
                                .map_err(|e| format!("--baseline: {e}"))?,
                        )
                    }
                    "--compatibility" => {
                        compatibility = match value.as_str() {
                            "on" => true,
                            "off" => false,
                            _ => return Err(format!("--compatibility {value}: `on` or `off`")),
                        }
                    }
                    "--air-data" => {
                        air_data = aerosid_host::gaps::airdata::AirDataChoice::parse(&value)
                            .ok_or_else(|| format!("--air-data {value}: one of auto, measured, reconstructed, fused"))?
                    }
                    "--with" => with = Some(value.into()),
                    _ => return Err(format!("unknown flag `{flag}` for `gaps`")),
                }
            }
            let data = match (data, with) {
                (Some(d), Some(w)) => Some((d, w)),
                (None, None) => None,
                _ => return Err("`gaps --data FILE` needs `--with MAP_OR_AIRCRAFT_FILE` (and the reverse)".into()),
            };
            if [hidden.is_some(), clean, data.is_some()].iter().filter(|b| **b).count() != 1 {
                return Err("gaps needs exactly one of --data FILE --with FILE, --simulate KIND or --clean".into());
            }
            return Ok(Some(Command::Gaps {
                hidden,
                data,
                seed,
                seconds,
                calm,
                out,
                air_data,
                apply_corrections,
                baseline,
                compatibility,
            }));
        }
        Some("gaps-bench") => {
            // `aerosid gaps-bench [--out DIR] [--draws N] [--clean N]`.
            let (mut out, mut draws, mut clean) = (std::path::PathBuf::from("out/gaps-bench"), 2usize, 10usize);
            while let Some(flag) = it.next() {
                let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
                match flag.as_str() {
                    "--out" => out = value.into(),
                    "--draws" => draws = value.parse().map_err(|e| format!("--draws {value}: {e}"))?,
                    "--clean" => clean = value.parse().map_err(|e| format!("--clean {value}: {e}"))?,
                    _ => return Err(format!("unknown flag `{flag}` for `gaps-bench`")),
                }
            }
            return Ok(Some(Command::GapsBench { out, draws, clean }));
        }
        Some("table1") => {
            return Ok(Some(Command::Table1 {
                out: out_dir(&mut it, "table1")?,
            }))
        }
        Some("fem-hfb320") => {
            return Ok(Some(Command::FemHfb320 {
                out: out_dir(&mut it, "fem-hfb320")?,
            }))
        }
        Some("fem") => return aerosid_host::workflow::parse_fem_args(it).map(|a| Some(Command::Fem(a))),
        Some("predict") => return aerosid_host::workflow::parse_predict_args(it).map(|a| Some(Command::Predict(a))),
        Some("replay") => {
            let mut log = None;
            let mut qemu = false;
            for a in it.by_ref() {
                match a.as_str() {
                    "--qemu" => qemu = true,
                    f if f.starts_with("--") => return Err(format!("unknown flag `{f}` for `replay`")),
                    _ => log = Some(std::path::PathBuf::from(a)),
                }
            }
            let log = log.ok_or("replay needs a LOG.csv")?;
            return Ok(Some(Command::Replay { log, qemu }));
        }
        Some("-h") | Some("--help") | None => return Ok(None),
        Some(other) => return Err(format!("unknown command `{other}` (try `aerosid --help`)")),
    };
    let mut args = Args {
        seed: 1,
        seconds: 120.0,
    };
    let mut job = aerosid_host::report::MainJob::default();
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("`{flag}` needs a value"))?;
        match (cmd, flag.as_str()) {
            (_, "--seed") => {
                args.seed = value.parse().map_err(|e| format!("--seed {value}: {e}"))?;
                job.seed = args.seed;
            }
            (_, "--seconds") => {
                args.seconds = value.parse().map_err(|e| format!("--seconds {value}: {e}"))?;
                if !(args.seconds >= 30.0 && args.seconds <= 36_000.0) {
                    return Err("--seconds must be between 30 and 36000".into());
                }
                // `run` keeps every sample's traces for the figures (~3 KB per sample): cap it.
                if cmd == "run" && args.seconds > 3600.0 {
                    return Err("--seconds for `run` must be at most 3600 (it keeps per-sample traces for the figures, ~1 GB per hour)".into());
                }
                job.seconds = args.seconds;
            }
            ("run", "--out") => job.out_dir = value.into(),
            _ => return Err(format!("unknown flag `{flag}` for `{cmd}`")),
        }
    }
    Ok(Some(if cmd == "run" {
        Command::Run(job)
    } else {
        Command::Demo(args)
    }))
}

/// True short-period-like signals: α, q_n, δe at time `t` [s] (zero excitation in cruise).
fn manoeuvre(t: f64) -> [f64; 3] {
    let trim_alpha = 0.06;
    if t < 20.0 {
        return [trim_alpha, 0.0, -0.02];
    }
    let tau = t - 20.0;
    // Repeating 3-2-1-1 elevator (0.4 s unit) followed by a 0.2–2 Hz sweep, every 12 s.
    let cycle = tau % 12.0;
    let de = if cycle < 4.0 {
        let u = cycle / 0.4;
        let amp = 0.08;
        if u < 3.0 {
            amp
        } else if u < 5.0 {
            -amp
        } else if u < 6.0 {
            amp
        } else if u < 7.0 {
            -amp
        } else {
            0.0
        }
    } else {
        let s = cycle - 4.0;
        let f = 0.2 + (2.0 - 0.2) * s / 8.0;
        0.06 * (2.0 * std::f64::consts::PI * f * s).sin()
    };
    // A second-order pitch response to the elevator: α and q lag δe (not identical, so the regressors
    // are not collinear).
    let alpha = trim_alpha - 0.5 * de + 0.02 * (1.7 * tau).sin() + 0.01 * (0.37 * tau).cos();
    let qn = (0.004 * (2.3 * tau).cos() - 0.006 * de + 0.002 * (5.1 * tau).sin()) * 0.5;
    [alpha, qn, -0.02 + de]
}

fn run(args: &Args) {
    let n = (args.seconds * RATE_HZ) as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
    let unit = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
    let w_t = SMatrix::<f32, 4, 4>::from_fn(|i, j| if i == j { (SIGMA[i] * SIGMA[i]) as f32 } else { 0.0 });
    let settings = GtlsSettings {
        forgetting: Forgetting::Variable(VffSettings::for_dimension(4)),
        ..GtlsSettings::default()
    };
    let weights = SVector::<f32, 4>::repeat(1.0);
    let Ok(mut gtls) = Gtls::<f32, 4, 1, 4>::new(&w_t, &weights, settings) else {
        eprintln!("internal error: invalid estimator settings");
        return;
    };
    let Ok(mut rls) = Rls::<f32, 4>::new(RlsSettings::default()) else {
        eprintln!("internal error: invalid RLS settings");
        return;
    };
    println!(
        "aerosid demo — C_m of the skywalker_2013_mod airframe, {n} samples at 100 Hz, seed {}",
        args.seed
    );
    println!(
        "noise 1σ: α {:.2}°, q_n {:.1e}, δe {:.2}°, C_m {:.3}",
        SIGMA[0].to_degrees(),
        SIGMA[1],
        SIGMA[2].to_degrees(),
        SIGMA[3]
    );
    println!();
    println!(
        "{:>7} {:>4} {:>8} {:>10} {:>10}   solution",
        "t [s]", "k", "λ_F", "Cmα", "Cmq"
    );
    let mut refused = 0usize;
    for i in 0..n {
        let t = i as f64 / RATE_HZ;
        let x0 = manoeuvre(t);
        let cm = TRUTH[0] + TRUTH[1] * x0[0] + TRUTH[2] * x0[1] + TRUTH[3] * x0[2];
        let x = SVector::<f32, 4>::from([
            1.0,
            (x0[0] + SIGMA[0] * unit.sample(&mut rng)) as f32,
            (x0[1] + SIGMA[1] * unit.sample(&mut rng)) as f32,
            (x0[2] + SIGMA[2] * unit.sample(&mut rng)) as f32,
        ]);
        let z = (cm + SIGMA[3] * unit.sample(&mut rng)) as f32;
        let step = match gtls.update(&x, z) {
            Ok(s) => s,
            Err(e) => {
                refused += 1;
                eprintln!("t = {t:.2} s: sample refused: {e}");
                continue;
            }
        };
        if rls.update(&x, z).is_err() {
            refused += 1;
        }
        if i % (10 * RATE_HZ as usize) == 0 || i + 1 == n {
            let th = gtls.theta();
            let sol = match step.solution {
                Solution::Tls => "GTLS (eq. 16)",
                Solution::MinimumNorm => "minimum norm (eq. 22–23): not all parameters excited",
                Solution::NotEnoughData => "not enough data",
                Solution::Nongeneric => "non-generic, minimum norm",
                Solution::LeastSquares => "LS",
            };
            println!(
                "{t:7.1} {:>4} {:8.5} {:10.4} {:10.3}   {sol}",
                step.k, step.lambda_next, th[1], th[2]
            );
        }
    }
    println!();
    let cov = gtls.covariance().ok();
    println!(
        "{:<6} {:>10} {:>22} {:>10} {:>12}",
        "param", "truth", "GTLS f32 ± σ (eq. 17)", "RLS f32", "GTLS err/σ"
    );
    for i in 0..4 {
        let est = gtls.theta()[i] as f64;
        let sigma = cov.map(|c| (c[(i, i)] as f64).sqrt());
        let (pm, zs) = match sigma {
            Some(s) => (
                format!("{est:10.4} ± {s:<9.4}"),
                format!("{:+.2}", (est - TRUTH[i]) / s),
            ),
            None => (format!("{est:10.4} ± (n/a)    "), "n/a".into()),
        };
        println!(
            "{:<6} {:>10.4} {:>22} {:>10.4} {:>12}",
            NAMES[i],
            TRUTH[i],
            pm,
            rls.theta()[i],
            zs
        );
    }
    let h = gtls.health();
    println!();
    println!(
        "singular values {:?}, threshold {:.1}, re-orthonormalisations {}, refused samples {refused}",
        gtls.singular_values().as_slice(),
        gtls.threshold().unwrap_or(f32::NAN),
        h.reorthonormalisations
    );
    println!(
        "estimator state: {} bytes (f32, n_θ = 4)",
        core::mem::size_of::<Gtls<f32, 4, 1, 4>>()
    );
}

/// The hook every front end of the model-gap analysis calls: analyse `flight`, print the table,
/// write `report.json`, `report.txt` and the figures to `out`.
/// Prints a command's report and the files it wrote (under `heading`), or its error prefixed with
/// `aerosid <cmd>:`.
fn finish<E: std::fmt::Display>(
    cmd: &str,
    heading: &str,
    result: Result<(String, Vec<std::path::PathBuf>), E>,
) -> ExitCode {
    match result {
        Ok((text, files)) => {
            print!("{text}");
            println!("\n{heading}:");
            for f in files {
                println!("  {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("aerosid {cmd}: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_gaps_command(
    flight: &aerosid_host::io::measured::MeasuredFlight,
    out: &std::path::Path,
    air_data: aerosid_host::gaps::airdata::AirDataChoice,
    apply_corrections: bool,
    baseline: Option<[Vec<aerosid_host::gaps::model::Term>; 6]>,
    compatibility: bool,
) -> ExitCode {
    let settings = aerosid_host::gaps::GapSettings {
        air_data,
        apply_corrections,
        compatibility,
        baseline,
        ..aerosid_host::gaps::GapSettings::default()
    };
    let report = match aerosid_host::gaps::run_gaps(flight, &settings) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("aerosid gaps: {e}");
            return ExitCode::FAILURE;
        }
    };
    // The table first: it is printed even if the files cannot be written.
    print!("{}", aerosid_host::gaps::report::table(&report));
    finish(
        "gaps",
        "files",
        aerosid_host::gaps::report::write(&report, out).map(|f| (String::new(), f)),
    )
}

fn main() -> ExitCode {
    match parse() {
        Ok(Some(Command::Demo(args))) => {
            run(&args);
            ExitCode::SUCCESS
        }
        Ok(Some(Command::Run(job))) => {
            let start = std::time::Instant::now();
            let mut log = String::new();
            let result = aerosid_host::report::main_job(&job, &mut log);
            print!("{log}");
            match result {
                Ok(paths) => {
                    println!("\nfigures:");
                    for p in paths {
                        println!("  {}", p.display());
                    }
                    println!("done in {:.1} s", start.elapsed().as_secs_f64());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("aerosid run: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Ok(Some(Command::Simulate { out, seconds, seed })) => {
            match aerosid_host::replay::simulate_to_csv(&out, seconds, seed) {
                Ok(n) => {
                    println!("{}: {n} samples ({seconds} s at 100 Hz, seed {seed})", out.display());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("aerosid simulate: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Ok(Some(Command::StackBound {
            elf,
            indirect,
            ram_budget,
        })) => match aerosid_host::stack_bound::analyse_elf(&elf, &indirect) {
            Ok(b) => {
                print!("{}", b.report());
                match ram_budget {
                    Some(budget) if b.ram() > budget => {
                        eprintln!(
                            "aerosid stack-bound: {}: RAM {} B (static {} + stack {}) exceeds the budget of {budget} B",
                            elf.display(),
                            b.ram(),
                            b.static_ram,
                            b.total
                        );
                        ExitCode::FAILURE
                    }
                    Some(budget) => {
                        println!("RAM within the budget: {} B ≤ {budget} B", b.ram());
                        ExitCode::SUCCESS
                    }
                    None => ExitCode::SUCCESS,
                }
            }
            Err(e) => {
                eprintln!("aerosid stack-bound: {e}");
                ExitCode::FAILURE
            }
        },
        Ok(Some(Command::PanicAudit { elf, allow })) => match aerosid_host::panic_audit::audit_elf(&elf, &allow) {
            Ok(a) => {
                print!("{}", a.report());
                if a.uncovered().is_empty() {
                    println!(
                        "panic audit: every panic path is on the allow-list ({})",
                        allow.display()
                    );
                    ExitCode::SUCCESS
                } else {
                    eprintln!(
                        "aerosid panic-audit: {} new panic path(s) in {}",
                        a.uncovered().len(),
                        elf.display()
                    );
                    ExitCode::FAILURE
                }
            }
            Err(e) => {
                eprintln!("aerosid panic-audit: {e}");
                ExitCode::FAILURE
            }
        },
        Ok(Some(Command::LongRun { hours, seed })) => {
            let cfg = aerosid_host::longrun::LongRunConfig::hours(hours, seed);
            let start = std::time::Instant::now();
            let result = aerosid_host::longrun::run(&cfg, |t| {
                if (t as u64).is_multiple_of(3600) && t > 0.0 {
                    eprintln!(
                        "long-run: {:.0} h simulated, {:.0} s wall",
                        t / 3600.0,
                        start.elapsed().as_secs_f64()
                    );
                }
            });
            match result {
                Ok(r) => {
                    print!(
                        "{}",
                        aerosid_host::longrun::format_report(&r, start.elapsed().as_secs_f64())
                    );
                    let broken = r.violations(&aerosid_host::longrun::Invariants::ISSUE_7);
                    if broken.is_empty() {
                        println!("invariants (issue 7 §2): all kept");
                        ExitCode::SUCCESS
                    } else {
                        for b in &broken {
                            eprintln!("aerosid long-run: invariant broken: {b}");
                        }
                        ExitCode::FAILURE
                    }
                }
                Err(e) => {
                    eprintln!("aerosid long-run: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Ok(Some(Command::GapsBench { out, draws, clean })) => {
            let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
            let data = aerosid_host::fem_report::flight_data_dir();
            let campaign = aerosid_host::gaps::bench::Campaign {
                draws_per_kind: draws,
                clean,
                jsbsim: Some(root.join("data/jsbsim")),
                real: data.is_dir().then(|| (data, root.join("data/maps"))),
            };
            match aerosid_host::gaps::bench::write(&campaign, &out) {
                Ok(lines) => {
                    for l in lines {
                        println!("{l}");
                    }
                    println!("wrote {}/manifest.json and its tables", out.display());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("aerosid gaps-bench: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Ok(Some(Command::Table1 { out })) => finish("table1", "figures", aerosid_host::table1::table1_report(&out)),
        Ok(Some(Command::FemHfb320 { out })) => finish(
            "fem-hfb320",
            "figures",
            aerosid_host::fem_report::hfb320_report(&aerosid_host::fem_report::default_hfb320_path(), &out),
        ),
        Ok(Some(Command::Fem(args))) => finish(
            "fem",
            "written",
            aerosid_host::workflow::run_fem(&args).map(|r| (r.text, r.files)),
        ),
        Ok(Some(Command::Predict(a))) => finish(
            "predict",
            "written",
            aerosid_host::workflow::run_predict(&a.saved, &a.data, &a.segments, &a.out).map(|(_, t, f)| (t, f)),
        ),
        Ok(Some(Command::Replay { log, qemu })) => match aerosid_host::replay::replay(&log, qemu) {
            Ok(report) => {
                print!("{report}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("aerosid replay: {e}");
                ExitCode::FAILURE
            }
        },
        Ok(Some(Command::Gaps {
            data: Some((data, with)),
            out,
            air_data,
            apply_corrections,
            baseline,
            compatibility,
            ..
        })) => match aerosid_host::io::read_measured(&data, &with) {
            Ok(flight) => run_gaps_command(&flight, &out, air_data, apply_corrections, baseline, compatibility),
            Err(e) => {
                eprintln!("aerosid gaps: {e}");
                ExitCode::FAILURE
            }
        },
        Ok(Some(Command::Gaps {
            hidden,
            data: None,
            seed,
            seconds,
            calm,
            out,
            air_data,
            apply_corrections,
            baseline,
            compatibility,
        })) => {
            // A simulated flight with the hidden effect's size drawn from the seed; a file-reading
            // front end calls the same `run_gaps` on the `MeasuredFlight` its reader produces.
            use rand::SeedableRng;
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let effect = hidden.map(|k| k.draw(&mut rng));
            let flight = match aerosid_host::gaps::hidden::flight(effect.as_ref(), seconds, seed, !calm) {
                Ok(f) => f,
                Err(e) => {
                    eprintln!("aerosid gaps: {e}");
                    return ExitCode::FAILURE;
                }
            };
            // The campaign's baseline (eq. 3 without the δa a kind hides) unless one is given.
            let baseline =
                baseline.or_else(|| Some(aerosid_host::gaps::hidden::HiddenEffect::baseline(effect.as_ref())));
            run_gaps_command(&flight, &out, air_data, apply_corrections, baseline, compatibility)
        }
        Ok(None) => {
            println!("aerosid — on-line aerodynamic model identification\n");
            println!("usage: aerosid run [--out DIR] [--seed N] [--seconds S]");
            println!("       aerosid simulate --out LOG.csv [--seed N] [--seconds S]");
            println!("       aerosid replay LOG.csv [--qemu]");
            println!("       aerosid fem-hfb320 [--out DIR]");
            println!(
                "       aerosid fem --model FILE.toml [--data FILE]... [--segment FROM:TO]... [--fix NAME=VALUE]..."
            );
            println!("                   [--validate FILE]... [--validate-segment FROM:TO]... [--out DIR]");
            println!("       aerosid predict --saved identification.json [--data FILE]... [--segment FROM:TO]... [--out DIR]");
            println!("       aerosid table1 [--out DIR]");
            println!("       aerosid gaps-bench [--out DIR] [--draws N] [--clean N]   (tables for scripts/bench/)");
            println!("       aerosid gaps --data FILE --with MAP_OR_AIRCRAFT [--air-data auto|measured|reconstructed|fused] [--no-corrections]");
            println!("                    [--baseline \"CL=1,alpha,dV;Cm=1,alpha,q,de\"] [--compatibility on|off] [--out DIR]");
            println!("       aerosid gaps --simulate KIND | --clean [--seed N] [--seconds S] [--out DIR]");
            println!("       aerosid long-run [--hours H] [--seed N]");
            println!("       aerosid panic-audit ELF ALLOW");
            println!("       aerosid stack-bound ELF CONFIG [--ram-budget BYTES]");
            println!("       aerosid demo [--seed N] [--seconds S]\n");
            println!("  run    simulate a flight of the default airframe, identify the six coefficients with the");
            println!("         on-board f32 pipeline, print the model beside the truth and RLS, write the figures");
            println!("         (six coefficients, Fig. 1, Fig. 2) as SVG to DIR (default out/)");
            println!("  simulate  write the main job's flight (every hidden effect, light turbulence, sensors with");
            println!("         biases) as a CSV log in the project's layout");
            println!("  replay identify the six coefficients from a CSV log with the on-board f32 pipeline; with");
            println!("         --qemu also run the firmware under QEMU on it and compare bit for bit");
            println!("  fem-hfb320  the filter error method (seed 001) on the real HFB-320 flight: estimates ± σ");
            println!("         beside the published values, the prediction variants (Euler/RK4, held/interpolated");
            println!("         input, recursive/batch), measured vs model outputs and residuals (SVG)");
            println!("  fem    the filter error or output error method on a model file (host-tests/models/*.toml:");
            println!(
                "         states, inputs, outputs, parameters, equations), files and segments pooled (FROM:TO in s"
            );
            println!("         from the file's first sample); writes identification.json, fit figures (SVG)");
            println!("  predict  apply a saved identification to other data: simulated outputs, RMS, R², Theil's U");
            println!("  gaps   the model-gap analysis (docs/model-gaps.md) of a measured flight, or of a simulated");
            println!("         flight with one hidden effect (KIND: lift-quadratic, elevator-drag, alpha-dot,");
            println!("         thrust-moment, cross-coupling, vane-scale, sensor-bias, time-delay; size drawn from");
            println!("         the seed) or none: table, JSON, SVG");
            println!("  table1 seed 001's Table 1: the Cramér–Rao bound and input design, then 50 simulated A-4D");
            println!("         flights with the paper's and the designed input through the paper's method, ours");
            println!("         (recursive and batch) and equation-error PCA-GTLS, beside Table 1; the parameter");
            println!("         histories ±σ of one flight per input (SVG)");
            println!("  panic-audit ELF ALLOW  every panic path left in a firmware image against the allow-list");
            println!("         (issue 7 §5; `firmware/panic-allow.txt`, README \"Reliability\")");
            println!(
                "  stack-bound ELF INDIRECT  a static bound on a firmware image's stack from its machine code, plus"
            );
            println!("         its static RAM; fails above --ram-budget (issue 4 §5)");
            println!("  long-run  H hours (default 10) of simulated flight through the on-board f32 pipeline:");
            println!("         excitation, calm cruise, two parameter jumps; prints the worst orthonormality, λ_F,");
            println!("         k, N_eff, refusals per coefficient and how each jump was tracked (issue 7)");
            println!("  demo   identify C_m from generated noisy 100 Hz data with the on-board f32 PCA-GTLS,");
            println!("         printing the estimates ± σ beside the truth and the RLS baseline");
            ExitCode::SUCCESS
        }
        Err(msg) => {
            eprintln!("aerosid: {msg}");
            ExitCode::from(2)
        }
    }
}
