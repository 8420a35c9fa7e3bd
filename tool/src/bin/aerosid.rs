//! `aerosid` — the project's command-line tool: argument parsing (clap) and dispatch only; every
//! command's work is a function of the `aerosid` library.
//!
//! Adding a command: a variant of [`Command`] holding a struct of its arguments (its doc comment is
//! the command's `--help`), an [`Execute`] implementation that calls the library, and its arm in
//! [`Command::execute`]. Ranges of numeric arguments are stated once, in a constant that both the
//! value check ([`in_range`]) and the help text ([`range_help`]) read.

use aerosid::gaps::airdata::AirDataChoice;
use aerosid::gaps::hidden::{HiddenEffect, HiddenKind};
use aerosid::gaps::model::Term;
use aerosid::io::flow_angles::FlowAngleChoice;
use aerosid::report::MainJob;
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{ArgGroup, Args, CommandFactory, Parser, Subcommand, ValueEnum};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

// Every report line goes through `print!`/`println!`/`eprintln!` as defined here, not std's: std's
// panic when the reader has gone (`aerosid gaps | head -1`: "failed printing to stdout: Broken
// pipe"). These write through the locked stream; once stdout is closed further output to it is
// dropped and the command carries on (its files are still written) and ends with its own exit
// code, as cargo and ripgrep end quietly. Shadowing std's names keeps every print path covered,
// including ones added later.
macro_rules! print {
    ($($arg:tt)*) => { write_stdout(format_args!($($arg)*)) };
}
macro_rules! println {
    () => { write_stdout(format_args!("\n")) };
    ($($arg:tt)*) => { write_stdout(format_args!("{}\n", format_args!($($arg)*))) };
}
macro_rules! eprintln {
    ($($arg:tt)*) => { write_stderr(format_args!("{}\n", format_args!($($arg)*))) };
}

/// Set once a write to stdout failed with a broken pipe: the reader is gone.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes to stdout; after a broken pipe, nothing (see the macros above). Any other write error
/// (a full disk behind a redirection) is said once on stderr and also ends stdout output.
fn write_stdout(args: std::fmt::Arguments) {
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|_| out.flush()) {
        STDOUT_CLOSED.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            write_stderr(format_args!("aerosid: writing to stdout: {e}\n"));
        }
    }
}

/// Writes to stderr; a closed stderr is ignored (there is nowhere left to say so).
fn write_stderr(args: std::fmt::Arguments) {
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// The exit codes, in every command's `--help` and docs/cli.md.
const EXIT_CODES: &str = "Exit codes:
  0  done: the report or files were written (a report with no verdict is a report)
  1  the input could not be read or is invalid, an output could not be written, or a check failed
  2  usage: an argument is missing, unknown or out of range";

/// `run --seconds`: the main job keeps every sample's traces for its figures (~3 KB per sample,
/// about 1 GB per hour), hence the hour's cap; below 30 s the manoeuvres do not all fit.
const RUN_SECONDS: (f64, f64) = (30.0, 3600.0);
/// `simulate --seconds`: the log is written as it is simulated, so up to ten hours.
const SIMULATE_SECONDS: (f64, f64) = (1.0, 36_000.0);
/// `gaps --seconds` of a simulated flight: at least one manoeuvre cycle, at most an hour.
const GAPS_SECONDS: (f64, f64) = (20.0, 3600.0);
/// `long-run --hours`. Below 0.2 h the time line of `aerosid::longrun` (cycles of at least 100 s,
/// the first jump at a third of the flight rounded down to a cycle) puts the first jump at or before
/// the calm cruise, or at 0 s with nothing estimated before it, so its invariants cannot hold; at
/// 0.2 h the jumps fall at 200 s and 400 s, as in the CI slice.
const LONG_RUN_HOURS: (f64, f64) = (0.2, 100.0);

/// On-line aerodynamic model identification for small fixed-wing UAVs: the host tool (simulation,
/// replay of logs through the on-board estimators, model-gap analysis, firmware checks).
#[derive(Parser)]
#[command(name = "aerosid", version, propagate_version = true, after_help = EXIT_CODES)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    Run(RunArgs),
    Simulate(SimulateArgs),
    Card(CardArgs),
    Replay(ReplayArgs),
    #[command(name = "fem-hfb320")]
    FemHfb320(FemHfb320Args),
    Fem(FemArgs),
    Predict(PredictArgs),
    Table1(Table1Args),
    Gaps(Box<GapsArgs>),
    GapsBench(GapsBenchArgs),
    Batch(BatchArgs),
    LongRun(LongRunArgs),
    PanicAudit(PanicAuditArgs),
    StackBound(StackBoundArgs),
    Demo(DemoArgs),
    Completions(CompletionsArgs),
}

/// A command's work, run after its arguments were parsed and checked.
trait Execute {
    fn execute(self) -> ExitCode;
}

impl Command {
    fn execute(self) -> ExitCode {
        match self {
            Self::Run(a) => a.execute(),
            Self::Simulate(a) => a.execute(),
            Self::Card(a) => a.execute(),
            Self::Replay(a) => a.execute(),
            Self::FemHfb320(a) => a.execute(),
            Self::Fem(a) => a.execute(),
            Self::Predict(a) => a.execute(),
            Self::Table1(a) => a.execute(),
            Self::Gaps(a) => a.execute(),
            Self::GapsBench(a) => a.execute(),
            Self::Batch(a) => a.execute(),
            Self::LongRun(a) => a.execute(),
            Self::PanicAudit(a) => a.execute(),
            Self::StackBound(a) => a.execute(),
            Self::Demo(a) => a.execute(),
            Self::Completions(a) => a.execute(),
        }
    }
}

/// The command line with the exit codes under every subcommand's help too.
fn command() -> clap::Command {
    Cli::command().mut_subcommands(|c| c.after_help(EXIT_CODES))
}

fn main() -> ExitCode {
    let matches = command().get_matches();
    let cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(c) => c,
        Err(e) => e.format(&mut command()).exit(),
    };
    match cli.command {
        Some(command) => command.execute(),
        None => {
            print!("{}", command().render_long_help());
            ExitCode::SUCCESS
        }
    }
}

/// Creates `dir` (an output folder) and checks a file can be written in it, before any work: a
/// report computed for minutes and then not written is worse than an error at once.
fn check_out_dir(cmd: &str, dir: &Path) -> Result<(), ExitCode> {
    let probe = dir.join(".aerosid-write-test");
    let result = std::fs::create_dir_all(dir)
        .and_then(|_| std::fs::write(&probe, b""))
        .and_then(|_| std::fs::remove_file(&probe));
    result.map_err(|e| {
        fail(
            cmd,
            format!(
                "--out {}: cannot write there ({e}); give a folder you can write to",
                dir.display()
            ),
        )
    })
}

/// Prints `aerosid CMD: error` and returns failure.
fn fail(cmd: &str, e: impl std::fmt::Display) -> ExitCode {
    eprintln!("aerosid {cmd}: {e}");
    ExitCode::FAILURE
}

/// Prints a command's report and the files it wrote (under `heading`), or its error.
fn finish<E: std::fmt::Display>(cmd: &str, heading: &str, result: Result<(String, Vec<PathBuf>), E>) -> ExitCode {
    match result {
        Ok((text, files)) => {
            print!("{text}");
            println!("\n{heading}:");
            for f in files {
                println!("  {}", f.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(cmd, e),
    }
}

/// A value parser for a number in `[range.0, range.1]` (NaN refused).
fn in_range(range: (f64, f64)) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let v: f64 = s.trim().parse().map_err(|e| format!("`{s}` is not a number: {e}"))?;
        if (range.0..=range.1).contains(&v) {
            Ok(v)
        } else {
            Err(format!("{v} is outside the range {}–{}", range.0, range.1))
        }
    }
}

/// `what` with the accepted range appended, for an argument's help.
fn range_help(what: &str, range: (f64, f64)) -> String {
    format!("{what} [range: {}–{}]", range.0, range.1)
}

// ---------------------------------------------------------------------------------------------------
// run, simulate, replay, demo

/// The main job: simulate a flight of the default airframe (`skywalker_2013_mod`, every hidden
/// effect, light turbulence, realistic sensors), run the six on-board `f32` estimators over its log
/// exactly as the firmware would, print the identified model beside the truth and the RLS baseline,
/// and write the figures (the six coefficients, Fig. 1, Fig. 2) as SVG to DIR.
#[derive(Args)]
struct RunArgs {
    /// Folder the figures are written to (created if missing).
    #[arg(long, value_name = "DIR", default_value_os_t = MainJob::default().out_dir)]
    out: PathBuf,
    /// Seed of the flight (turbulence and sensor noise).
    #[arg(long, value_name = "N", default_value_t = MainJob::default().seed)]
    seed: u64,
    #[arg(long, value_name = "S", default_value_t = MainJob::default().seconds,
          value_parser = in_range(RUN_SECONDS),
          help = range_help("Duration of the flight, s", RUN_SECONDS))]
    seconds: f64,
}

impl Execute for RunArgs {
    fn execute(self) -> ExitCode {
        if let Err(code) = check_out_dir("run", &self.out) {
            return code;
        }
        let job = MainJob {
            out_dir: self.out,
            seed: self.seed,
            seconds: self.seconds,
            ..MainJob::default()
        };
        let start = std::time::Instant::now();
        let mut log = String::new();
        let result = aerosid::report::main_job(&job, &mut log);
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
            Err(e) => fail("run", e),
        }
    }
}

/// Write the main job's flight (every hidden effect, light turbulence, sensors with biases) as a
/// CSV log in the project's layout (docs/measured-data.md).
#[derive(Args)]
struct SimulateArgs {
    /// The CSV log to write.
    #[arg(long, value_name = "LOG.csv")]
    out: PathBuf,
    /// Seed of the flight (turbulence and sensor noise).
    #[arg(long, value_name = "N", default_value_t = MainJob::default().seed)]
    seed: u64,
    #[arg(long, value_name = "S", default_value_t = MainJob::default().seconds,
          value_parser = in_range(SIMULATE_SECONDS),
          help = range_help("Duration of the flight, s", SIMULATE_SECONDS))]
    seconds: f64,
}

impl Execute for SimulateArgs {
    fn execute(self) -> ExitCode {
        match aerosid::replay::simulate_to_csv(&self.out, self.seconds, self.seed) {
            Ok(n) => {
                println!(
                    "{}: {n} samples ({} s at 100 Hz, seed {})",
                    self.out.display(),
                    self.seconds,
                    self.seed
                );
                ExitCode::SUCCESS
            }
            Err(e) => fail("simulate", e),
        }
    }
}

/// Write a simulated flight-test card (docs/test-card.md): eight short manoeuvres (doublets and
/// 3-2-1-1s on each surface) of the skywalker in MIL-F-8785C turbulence, each from trim, logged as
/// a small UAV's autopilot logs it (channels at 5–50 Hz held on a 50 Hz grid, α and β estimated
/// from the inertial velocity and a lagged wind estimate, no vanes), with at most one hidden effect:
/// one project CSV per manoeuvre, the aircraft file and truth.json in DIR.
#[derive(Args)]
struct CardArgs {
    /// Folder of the card's files (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// The hidden effect (default: none). The kinds on the α vane (vane-scale, time-delay) are
    /// refused: the card has no vanes; a sensor bias sits on the pitch gyro or the z accelerometer.
    #[arg(long, value_name = "KIND", value_parser = hidden_kind_parser())]
    effect: Option<HiddenKind>,
    /// The hidden effect's size instead of the one drawn from the seed.
    #[arg(long, value_name = "X", allow_negative_numbers = true, requires = "effect")]
    size: Option<f64>,
    /// Seed of the card (turbulence, noise, logger timing, the effect's size).
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// Turbulence level (MIL-F-8785C low altitude: wind at 20 ft of 15 or 30 kt).
    #[arg(long, value_name = "LEVEL", default_value = "light",
          value_parser = PossibleValuesParser::new(["light", "moderate"]))]
    turbulence: String,
}

impl Execute for CardArgs {
    fn execute(self) -> ExitCode {
        use aerosid::card::{draw_effect, write_card, CardSettings};
        use aerosid::sim::test_card::CardTurbulence;
        let turbulence = if self.turbulence == "moderate" {
            CardTurbulence::Moderate
        } else {
            CardTurbulence::Light
        };
        let effect = match self.effect.map(|k| draw_effect(k, self.seed, self.size)).transpose() {
            Ok(e) => e,
            Err(e) => return fail("card", e),
        };
        let settings = CardSettings {
            effect,
            seed: self.seed,
            turbulence,
        };
        match write_card(&self.out, &settings) {
            Ok(files) => {
                let what = effect.map_or_else(|| "clean".to_string(), |e| format!("hidden {}", e.describe()));
                println!(
                    "{}: {} files ({what}, {} turbulence, seed {})",
                    self.out.display(),
                    files.len(),
                    turbulence.name(),
                    self.seed
                );
                for f in files {
                    println!("  {}", f.display());
                }
                ExitCode::SUCCESS
            }
            Err(e) => fail("card", e),
        }
    }
}

/// Identify the six coefficients from a CSV log with the on-board `f32` pipeline; with --qemu also
/// run the firmware under QEMU on the same log and check its telemetry against the host bit for bit.
#[derive(Args)]
struct ReplayArgs {
    /// The log, in the project's CSV layout (e.g. written by `aerosid simulate`).
    #[arg(value_name = "LOG.csv")]
    log: PathBuf,
    /// Also run the firmware under QEMU (needs qemu-system-arm and the firmware built with the
    /// `qemu` feature).
    #[arg(long)]
    qemu: bool,
}

impl Execute for ReplayArgs {
    fn execute(self) -> ExitCode {
        match aerosid::replay::replay(&self.log, self.qemu) {
            Ok(report) => {
                print!("{report}");
                ExitCode::SUCCESS
            }
            Err(e) => fail("replay", e),
        }
    }
}

/// Identify C_m from generated noisy 100 Hz data with the on-board `f32` PCA-GTLS (20 s of calm
/// cruise, then elevator doublets and sweeps), printing the estimates ± σ beside the truth and the
/// RLS baseline.
#[derive(Args)]
struct DemoArgs {
    /// Seed of the generated data.
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    #[arg(long, value_name = "S", default_value_t = 120.0,
          value_parser = in_range(aerosid::demo::SECONDS_RANGE),
          help = range_help("Duration of the generated data, s", aerosid::demo::SECONDS_RANGE))]
    seconds: f64,
}

impl Execute for DemoArgs {
    fn execute(self) -> ExitCode {
        match aerosid::demo::demo(self.seed, self.seconds) {
            Ok(text) => {
                print!("{text}");
                ExitCode::SUCCESS
            }
            Err(e) => fail("demo", e),
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Reports on the papers' data

/// The filter error method (seed 001) on the real HFB-320 flight: estimates ± σ beside the
/// published values, the prediction variants (Euler/RK4, held/interpolated input, recursive/batch),
/// measured vs model outputs and residuals (SVG). Reads `hfb320_1_10.asc` from the vendored
/// flight-test data, or from the folder `AEROSID_FLIGHT_DATA` names.
#[derive(Args)]
struct FemHfb320Args {
    /// Folder the figures are written to (created if missing).
    #[arg(long, value_name = "DIR", default_value = "out")]
    out: PathBuf,
}

impl Execute for FemHfb320Args {
    fn execute(self) -> ExitCode {
        if let Err(code) = check_out_dir("fem-hfb320", &self.out) {
            return code;
        }
        let data = aerosid::fem_report::default_hfb320_path();
        finish(
            "fem-hfb320",
            "figures",
            aerosid::fem_report::hfb320_report(&data, &self.out),
        )
    }
}

/// The filter error or output error method on a model file (states, inputs, outputs, parameters,
/// equations; docs/workflow.md, e.g. tool/models/hfb320.toml), the files and segments pooled
/// (each its own initial state), parameters fixed as asked, validated on other data; writes
/// identification.json (the saved model) and measured-vs-model figures (SVG). A model that names
/// measured channels reads what `gaps` reads (.csv, .asc/.txt/.dat or .mat with --with, .ulg and
/// .bin with or without it).
#[derive(Args)]
struct FemArgs {
    /// The model file (TOML); paths inside it resolve against its folder.
    #[arg(long, value_name = "FILE.toml")]
    model: PathBuf,
    /// A data file (repeatable; default the model file's `[data] file`).
    #[arg(long, value_name = "FILE")]
    data: Vec<PathBuf>,
    /// The column map or aircraft file of the data and validation files, for a model that names
    /// channels (default the model file's `[data] with` when its `[data] file` is read).
    #[arg(long = "with", value_name = "MAP_OR_AIRCRAFT")]
    with: Option<PathBuf>,
    /// A segment of each data file, seconds from its first sample (repeatable; default all).
    #[arg(long, value_name = "FROM:TO", value_parser = aerosid::workflow::parse_range, allow_hyphen_values = true)]
    segment: Vec<(f64, f64)>,
    /// A validation file (repeatable).
    #[arg(long, value_name = "FILE")]
    validate: Vec<PathBuf>,
    /// A validation segment, of the validation files or else of the data files (repeatable).
    #[arg(long, value_name = "FROM:TO", value_parser = aerosid::workflow::parse_range, allow_hyphen_values = true)]
    validate_segment: Vec<(f64, f64)>,
    /// Hold a parameter at a value instead of estimating it (repeatable).
    #[arg(long, value_name = "NAME=VALUE", value_parser = aerosid::workflow::parse_fix, allow_hyphen_values = true)]
    fix: Vec<(String, f64)>,
    /// Folder the JSON and figures are written to (created if missing).
    #[arg(long, value_name = "DIR", default_value = "out/fem")]
    out: PathBuf,
}

impl Execute for FemArgs {
    fn execute(self) -> ExitCode {
        if let Err(code) = check_out_dir("fem", &self.out) {
            return code;
        }
        let args = aerosid::workflow::FemArgs {
            model: self.model,
            data: self.data,
            with: self.with,
            segments: self.segment,
            validate: self.validate,
            validate_segments: self.validate_segment,
            fix: self.fix,
            out: self.out,
        };
        finish(
            "fem",
            "written",
            aerosid::workflow::run_fem(&args).map(|r| (r.text, r.files)),
        )
    }
}

/// Apply a saved model to other data. The identification.json of `fem`: the outputs simulated
/// from the first measured state with the measured inputs, RMS, R² and Theil's U per output,
/// prediction.json and a measured-vs-predicted figure (SVG). The report.json of `gaps` (schema
/// aerosid-gaps/3): each coefficient synthesised from the --data flight (read as `gaps` reads it,
/// --with MAP_OR_AIRCRAFT) and predicted by the saved baseline and extended models, RMS, R² and
/// Theil's U of both, the output simulation with both model sets, prediction.json,
/// prediction.svg and prediction_simulation.svg (docs/model-gaps.md).
#[derive(Args)]
struct PredictArgs {
    /// The saved identification (identification.json of `fem`, or report.json of `gaps`).
    #[arg(long, value_name = "FILE.json")]
    saved: PathBuf,
    /// A data file (repeatable for `fem`; default the files it was identified on, wherever the
    /// command runs; exactly one for a gap report).
    #[arg(long, value_name = "FILE")]
    data: Vec<PathBuf>,
    /// The column map or aircraft file of the --data flight (optional for .ulg and .bin; for a
    /// `fem` model without --data, default the one it was identified with).
    #[arg(long = "with", value_name = "MAP_OR_AIRCRAFT")]
    with: Option<PathBuf>,
    /// A segment of each data file, seconds from its first sample (repeatable; default all; `fem`
    /// models only).
    #[arg(long, value_name = "FROM:TO", value_parser = aerosid::workflow::parse_range, allow_hyphen_values = true)]
    segment: Vec<(f64, f64)>,
    /// Folder the JSON and figure are written to (created if missing).
    #[arg(long, value_name = "DIR", default_value = "out/predict")]
    out: PathBuf,
}

impl Execute for PredictArgs {
    fn execute(self) -> ExitCode {
        if let Err(code) = check_out_dir("predict", &self.out) {
            return code;
        }
        match aerosid::gaps::predict::is_gap_report(&self.saved) {
            Err(e) => return fail("predict", e),
            Ok(true) => return self.gap_report(),
            Ok(false) => {}
        }
        finish(
            "predict",
            "written",
            aerosid::workflow::run_predict_with(
                &self.saved,
                &self.data,
                self.with.as_deref(),
                &self.segment,
                &self.out,
            )
            .map(|(_, t, f)| (t, f)),
        )
    }
}

impl PredictArgs {
    /// Coefficient prediction with a gap report.
    fn gap_report(self) -> ExitCode {
        let [data] = self.data.as_slice() else {
            return usage(
                "predict",
                "a gap report predicts one flight: give exactly one --data FILE",
            );
        };
        if !self.segment.is_empty() {
            return usage(
                "predict",
                "--segment is for `fem` models; a gap report predicts the whole --data flight",
            );
        }
        let ext = data.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if self.with.is_none() && !matches!(ext.as_deref(), Some("ulg") | Some("bin")) {
            return usage(
                "predict",
                format!(
                    "--data {} needs --with MAP_OR_AIRCRAFT (only .ulg and .bin logs read without one)",
                    data.display()
                ),
            );
        }
        let report = match aerosid::gaps::predict::read_report(&self.saved) {
            Ok(r) => r,
            Err(e) => return fail("predict", e),
        };
        let flight = match aerosid::io::read_measured_with(data, self.with.as_deref(), &Default::default()) {
            Ok(f) => f,
            Err(e) => return fail("predict", e),
        };
        finish(
            "predict",
            "written",
            aerosid::gaps::predict::run(&report, &flight, &self.out).map(|(_, t, f)| (t, f)),
        )
    }
}

/// Seed 001's Table 1: the Cramér–Rao bound and input design, then 50 simulated A-4D flights with
/// the paper's and the designed input through the paper's method, ours (recursive and batch) and
/// equation-error PCA-GTLS, beside Table 1; the parameter histories ± σ of one flight per input (SVG).
#[derive(Args)]
struct Table1Args {
    /// Folder the figures are written to (created if missing).
    #[arg(long, value_name = "DIR", default_value = "out")]
    out: PathBuf,
}

impl Execute for Table1Args {
    fn execute(self) -> ExitCode {
        if let Err(code) = check_out_dir("table1", &self.out) {
            return code;
        }
        finish("table1", "figures", aerosid::table1::table1_report(&self.out))
    }
}

// ---------------------------------------------------------------------------------------------------
// Model-gap analysis

/// `--compatibility`: whether the flight-path reconstruction runs.
#[derive(Clone, Copy, ValueEnum)]
enum OnOff {
    On,
    Off,
}

/// `--low-rate-method` ([`aerosid::gaps::LowRateMethod`]).
#[derive(Clone, Copy, ValueEnum)]
enum LowRateArg {
    /// Output error on every axis.
    OutputError,
    /// The filter error method on every axis where a filter can be formed.
    FilterError,
    /// The filter error method where a likelihood-ratio test finds process noise, else output error.
    Test,
}

impl From<LowRateArg> for aerosid::gaps::LowRateMethod {
    fn from(a: LowRateArg) -> Self {
        match a {
            LowRateArg::OutputError => Self::OutputError,
            LowRateArg::FilterError => Self::FilterError,
            LowRateArg::Test => Self::Test,
        }
    }
}

/// The names `--air-data` accepts ([`AirDataChoice::parse`]).
const AIR_DATA_NAMES: [&str; 4] = ["auto", "measured", "reconstructed", "fused"];

fn hidden_kind_parser() -> impl TypedValueParser<Value = HiddenKind> {
    PossibleValuesParser::new(HiddenKind::ALL.map(|k| k.name()))
        .try_map(|s| HiddenKind::parse(&s).ok_or_else(|| format!("unknown kind `{s}`")))
}

fn flow_angles_parser() -> impl TypedValueParser<Value = FlowAngleChoice> {
    PossibleValuesParser::new(["auto", "vanes", "estimated", "none"])
        .try_map(|s| FlowAngleChoice::parse(&s).ok_or_else(|| format!("unknown flow-angle choice `{s}`")))
}

fn air_data_parser() -> impl TypedValueParser<Value = AirDataChoice> {
    PossibleValuesParser::new(AIR_DATA_NAMES)
        .try_map(|s| AirDataChoice::parse(&s).ok_or_else(|| format!("unknown air-data choice `{s}`")))
}

/// The model-gap analysis (docs/model-gaps.md) of a measured flight (--data FILE [--with FILE]), or
/// of a simulated flight with one hidden effect (--simulate KIND; its size drawn from the seed) or
/// none (--clean): data-quality assessment and table on the terminal, report.json, report.txt and
/// SVG figures in DIR. A PX4 `.ulg` or ArduPilot `.bin` log reads without --with (a placeholder
/// aircraft, so no verdict), its in-air window found unless --from/--to or --whole-log say
/// otherwise (docs/measured-data.md).
#[derive(Args)]
#[command(group(ArgGroup::new("flight").required(true).args(["data", "simulate", "clean"])))]
struct GapsArgs {
    /// A measured flight or manoeuvre (read by `aerosid::io::read_measured_with`): .csv,
    /// .asc/.txt/.dat or .mat with --with; a PX4 .ulg or ArduPilot .bin log with or without it.
    /// Several files (`--data a.csv b.csv`, `--data card/*.csv`, or the flag repeated): the
    /// manoeuvres are pooled, each its own piece, in a canonical order (by file, then time),
    /// whatever the order given (docs/model-gaps.md, "Pooled manoeuvres").
    #[arg(long, value_name = "FILE", num_args = 1..)]
    data: Vec<PathBuf>,
    /// The column map or aircraft file of every --data file (optional for .ulg and .bin).
    #[arg(long = "with", value_name = "MAP_OR_AIRCRAFT", requires = "data")]
    with: Option<PathBuf>,
    /// A manoeuvre of each --data file, seconds from its first sample (repeatable; default the
    /// whole file); every segment is its own piece.
    #[arg(long, value_name = "FROM:TO", requires = "data", value_parser = aerosid::workflow::parse_range, allow_hyphen_values = true)]
    segment: Vec<(f64, f64)>,
    /// Start of the window read from a .ulg/.bin log, s of its boot time (the scale the report
    /// prints). Default: the longest stretch in the air.
    #[arg(long, value_name = "S", requires = "data", value_parser = finite_seconds, allow_negative_numbers = true)]
    from: Option<f64>,
    /// End of the window read from a .ulg/.bin log, s of its boot time.
    #[arg(long, value_name = "S", requires = "data", value_parser = finite_seconds, allow_negative_numbers = true)]
    to: Option<f64>,
    /// Read the whole .ulg/.bin log (no automatic in-air window).
    #[arg(long, requires = "data")]
    whole_log: bool,
    /// The instance of a multi-instance topic (ULog) or message (DataFlash), TOPIC=N; repeatable.
    /// Default: instance 0 of every topic.
    #[arg(long, value_name = "TOPIC=N", requires = "data")]
    instance: Vec<String>,
    /// Output rate of a .ulg/.bin log, Hz (default: the rate topic's median rate).
    #[arg(long, value_name = "HZ", requires = "data", value_parser = positive_rate)]
    rate: Option<f64>,
    /// Print the topics (ULog) or messages (DataFlash) of the --data log with their instances,
    /// rates and fields, and stop.
    #[arg(long, requires = "data")]
    list: bool,
    /// A simulated flight with this hidden effect.
    #[arg(long, value_name = "KIND", value_parser = hidden_kind_parser())]
    simulate: Option<HiddenKind>,
    /// A simulated flight with no hidden effect.
    #[arg(long)]
    clean: bool,
    /// The simulated flight in calm air (default: the campaign's light turbulence).
    #[arg(long)]
    calm: bool,
    /// Seed of the simulated flight and of the hidden effect's size.
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// The hidden effect's size instead of the one drawn from the seed, in the unit of its
    /// parameter (docs/model-gaps.md); with --seed, reproduces a flight of `aerosid gaps-bench`
    /// (its manifest's `reproduce`).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    size: Option<f64>,
    /// The channel of a hidden sensor bias instead of the one drawn from the seed.
    #[arg(long, value_name = "CHANNEL",
          value_parser = PossibleValuesParser::new(aerosid::gaps::hidden::BIAS_CHANNELS.map(|c| c.0)))]
    channel: Option<String>,
    #[arg(long, value_name = "S", default_value_t = 90.0, value_parser = in_range(GAPS_SECONDS),
          help = range_help("Duration of the simulated flight, s", GAPS_SECONDS))]
    seconds: f64,
    /// Folder of report.json, report.txt and the figures (created if missing).
    #[arg(long, value_name = "DIR", default_value = "out/gaps")]
    out: PathBuf,
    /// The air data of the regressors: the sensors (measured), the flight-path reconstruction
    /// (reconstructed; assumes steady air, so take measured for turbulent data), their fusion, or
    /// auto (fused when both exist).
    #[arg(long, value_name = "CHOICE", default_value = "auto", value_parser = air_data_parser())]
    air_data: AirDataChoice,
    /// Where α and β come from: the vanes (vanes), an estimate from the ground velocity, the
    /// attitude and a wind fitted with the pitot scale (estimated; replaces any vanes), neither
    /// (none), or auto: the vanes when logged, else estimated when the data allow it
    /// (docs/measured-data.md, "the α-free mode").
    #[arg(long, value_name = "CHOICE", default_value = "auto", value_parser = flow_angles_parser())]
    flow_angles: FlowAngleChoice,
    /// Keep the named sensor errors instead of removing them before the aerodynamics.
    #[arg(long)]
    no_corrections: bool,
    /// Baseline models replacing eq. 3 for the coefficients named, e.g.
    /// "CL=1,alpha,dV;Cm=1,alpha,dV,q,de".
    #[arg(long, value_name = "SPEC", value_parser = aerosid::gaps::model::parse_baseline)]
    baseline: Option<[Vec<Term>; 6]>,
    /// `off` skips the flight-path reconstruction (the data are used as they are).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    compatibility: OnOff,
    /// The highest rate the analysis runs at, Hz: data logged twice as fast or faster are averaged
    /// in blocks of ⌊rate/cap⌋ samples first (docs/model-gaps.md, "Analysis rate"); `native`
    /// analyses them as logged
    #[arg(long, value_name = "HZ", default_value_t = MaxRate(Some(aerosid::gaps::MAX_ANALYSIS_RATE_HZ)), value_parser = max_rate_parser)]
    max_rate: MaxRate,
    /// How the low-rate path (below 20 Hz) fits an axis. The default, output error, names no
    /// cause on clean simulated 10 Hz flights; the filter error method (process noise) detected
    /// more but named an input delay on each of them (docs/model-gaps.md, "Low-rate data").
    #[arg(long, value_enum, value_name = "METHOD", default_value_t = LowRateArg::OutputError)]
    low_rate_method: LowRateArg,
    #[command(flatten)]
    levels: LevelArgs,
}

/// The test levels of `gaps` and `gaps-bench` ([`aerosid::gaps::Levels`]).
#[derive(Debug, Clone, Copy, clap::Args)]
struct LevelArgs {
    /// Family-wise level of the significance tests, divided among every candidate tested
    /// (Bonferroni): nominally a bound on the chance of a spurious cause per flight (measured
    /// rates: docs/benchmarks.md, "Operating points"). In [1e-12, 1].
    #[arg(long, value_name = "LEVEL", default_value_t = 0.01, value_parser = family_level, allow_negative_numbers = true)]
    alpha: f64,
    /// One-sided level of each candidate's held-out gain test (blocked cross-validation). In
    /// [1e-12, 0.5).
    #[arg(long, value_name = "LEVEL", default_value_t = 0.01, value_parser = one_sided_level, allow_negative_numbers = true)]
    gain_alpha: f64,
}

impl LevelArgs {
    fn levels(self) -> aerosid::gaps::Levels {
        aerosid::gaps::Levels {
            alpha: self.alpha,
            gain_alpha: self.gain_alpha,
        }
    }
}

/// `--alpha`: a family-wise level ([`aerosid::gaps::Levels::check_alpha`]).
fn family_level(s: &str) -> Result<f64, String> {
    let v = s.parse::<f64>().map_err(|_| format!("`{s}` is not a number"))?;
    aerosid::gaps::Levels::check_alpha(v)
}

/// `--gain-alpha`: a one-sided level ([`aerosid::gaps::Levels::check_gain_alpha`]).
fn one_sided_level(s: &str) -> Result<f64, String> {
    let v = s.parse::<f64>().map_err(|_| format!("`{s}` is not a number"))?;
    aerosid::gaps::Levels::check_gain_alpha(v)
}

/// `--max-rate`: a cap in Hz, or none (`native`).
#[derive(Debug, Clone, Copy)]
struct MaxRate(Option<f64>);

impl std::fmt::Display for MaxRate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(hz) => write!(f, "{hz}"),
            None => f.write_str("native"),
        }
    }
}

/// `--max-rate`: a positive finite rate in Hz, or `native` (no cap).
fn max_rate_parser(s: &str) -> Result<MaxRate, String> {
    if s == "native" {
        return Ok(MaxRate(None));
    }
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .map(|v| MaxRate(Some(v)))
        .ok_or_else(|| format!("`{s}` is neither a positive rate in Hz nor `native`"))
}

/// A finite number of seconds (`--from`, `--to`).
fn finite_seconds(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("`{s}` is not a finite time in seconds"))
}

/// A rate in Hz, 0 < rate ≤ 10 000 (`--rate`).
fn positive_rate(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|r| r.is_finite() && *r > 0.0 && *r <= 10_000.0)
        .ok_or_else(|| format!("`{s}` is not a rate in Hz in (0, 10000]"))
}

impl GapsArgs {
    /// The read options of the flags, or the usage error.
    fn read_options(&self) -> Result<aerosid::io::ReadOptions, String> {
        let mut o = aerosid::io::ReadOptions {
            from_s: self.from,
            to_s: self.to,
            whole_log: self.whole_log,
            rate_hz: self.rate,
            ..Default::default()
        };
        for spec in &self.instance {
            o.add_instance(spec)?;
        }
        if let (Some(a), Some(b)) = (o.from_s, o.to_s) {
            if a >= b {
                return Err(format!("--from {a} must be before --to {b}"));
            }
        }
        Ok(o)
    }
}

/// A usage error found after parsing: the message and exit code 2, as clap's own.
fn usage(cmd: &str, e: impl std::fmt::Display) -> ExitCode {
    eprintln!("aerosid {cmd}: {e}");
    ExitCode::from(2)
}

impl Execute for GapsArgs {
    fn execute(self) -> ExitCode {
        if self.list && self.data.len() > 1 {
            return usage("gaps", "--list lists one log: give one --data FILE");
        }
        if !self.list {
            if let Err(code) = check_out_dir("gaps", &self.out) {
                return code;
            }
        }
        if let Err(e) = self.check_with() {
            return usage("gaps", e);
        }
        if let (true, Some(data)) = (self.list, self.data.first()) {
            return list_log(data);
        }
        let settings = self.settings();
        let opts = match self.read_options() {
            Ok(o) => o,
            Err(e) => return usage("gaps", e),
        };
        if self.simulate.is_none() && (self.size.is_some() || self.channel.is_some()) {
            return usage(
                "gaps",
                "--size and --channel describe the hidden effect of --simulate KIND",
            );
        }
        if self.data.is_empty() {
            return self.simulated(settings);
        }
        match aerosid::io::read_pooled(&self.data, self.with.as_deref(), &self.segment, &opts) {
            Ok(f) => gaps(&f, &self.out, settings),
            Err(e) => fail("gaps", e),
        }
    }
}

/// The topics (ULog) or messages (DataFlash) of the log `data`, printed.
fn list_log(data: &Path) -> ExitCode {
    let ext = data.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let listing = match ext.as_deref() {
        Some("ulg") => aerosid::io::ulog::list_topics(data),
        Some("bin") => aerosid::io::dataflash::list_messages(data),
        _ => {
            return usage(
                "gaps",
                "--list lists the topics of a .ulg or the messages of a .bin log",
            )
        }
    };
    match listing {
        Ok(text) => {
            print!("{text}");
            ExitCode::SUCCESS
        }
        Err(e) => fail("gaps", e),
    }
}

impl GapsArgs {
    /// The usage error of the first --data file that needs --with and has none (only .ulg and
    /// .bin logs read without one).
    fn check_with(&self) -> Result<(), String> {
        for data in &self.data {
            let ext = data.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            let log = matches!(ext.as_deref(), Some("ulg") | Some("bin"));
            if self.with.is_none() && !log {
                return Err(format!(
                    "--data {} needs --with MAP_OR_AIRCRAFT (only .ulg and .bin logs read without one)",
                    data.display()
                ));
            }
        }
        Ok(())
    }

    /// The analysis's settings of the flags.
    fn settings(&self) -> aerosid::gaps::GapSettings {
        aerosid::gaps::GapSettings {
            air_data: self.air_data,
            flow_angles: self.flow_angles,
            apply_corrections: !self.no_corrections,
            compatibility: matches!(self.compatibility, OnOff::On),
            baseline: self.baseline.clone(),
            max_rate_hz: self.max_rate.0,
            low_rate_method: self.low_rate_method.into(),
            ..self.levels.levels().apply(aerosid::gaps::GapSettings::default())
        }
    }

    /// The simulated flight (`--simulate KIND` or `--clean`) analysed: the campaign's baseline
    /// (eq. 3 without the δa a kind hides) unless one is given.
    fn simulated(&self, settings: aerosid::gaps::GapSettings) -> ExitCode {
        let effect = match self.hidden_effect() {
            Ok(e) => e,
            Err(e) => return usage("gaps", e),
        };
        match aerosid::gaps::hidden::flight(effect.as_ref(), self.seconds, self.seed, !self.calm) {
            Ok(f) => {
                let baseline = settings
                    .baseline
                    .clone()
                    .or_else(|| Some(HiddenEffect::baseline(effect.as_ref())));
                gaps(&f, &self.out, aerosid::gaps::GapSettings { baseline, ..settings })
            }
            Err(e) => fail("gaps", e),
        }
    }

    /// The hidden effect of `--simulate KIND`, its size drawn from the seed unless `--size` gives
    /// it, its channel from `--channel`; the usage error of a size or channel the kind cannot
    /// take.
    fn hidden_effect(&self) -> Result<Option<HiddenEffect>, String> {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(self.seed);
        let mut effect = self.simulate.map(|k| k.draw(&mut rng));
        if let Some(e) = effect.as_mut() {
            if let Some(x) = self.size {
                check_size(e.kind, x)?;
                e.size = x;
            }
            if let Some(c) = &self.channel {
                if e.kind != HiddenKind::SensorBias {
                    return Err(format!(
                        "--channel {c}: only --simulate sensor-bias has a choice of channel"
                    ));
                }
                e.channel = aerosid::gaps::hidden::BIAS_CHANNELS
                    .iter()
                    .find(|x| x.0 == c)
                    .map(|x| x.1);
            }
        }
        Ok(effect)
    }
}

/// `--size x` for a hidden effect of `kind`: finite, of a kind with a size, and in the kind's
/// range.
fn check_size(kind: HiddenKind, x: f64) -> Result<(), String> {
    if !x.is_finite() || kind == HiddenKind::MissingRollControl {
        return Err(format!(
            "--size {x}: give a finite number, and only for a kind with a size (missing-roll-control has none)"
        ));
    }
    // A delay is a lag (≥ 0, at most 1 s); a scale factor below −1 flips the vane's sign (−1
    // zeroes it).
    let range = match kind {
        HiddenKind::TimeDelay | HiddenKind::ElevatorDelay => Some((0.0, 1.0, "0 to 1 s")),
        HiddenKind::VaneScale => Some((-0.99, 10.0, "−0.99 to 10")),
        _ => None,
    };
    if let Some((_, _, text)) = range.filter(|&(lo, hi, _)| !(lo..=hi).contains(&x)) {
        return Err(format!("--size {x}: a {} size must lie in {text}", kind.name()));
    }
    Ok(())
}

/// Analyses `flight`, prints the table, writes report.json, report.txt and the figures to `out`
/// ([`aerosid::batch::analyse`]).
fn gaps(flight: &aerosid::io::measured::MeasuredFlight, out: &Path, settings: aerosid::gaps::GapSettings) -> ExitCode {
    let analysis = aerosid::batch::analyse(flight, out, &settings);
    // The table first: it is printed even if the files cannot be written.
    print!("{}", analysis.table);
    finish("gaps", "files", analysis.outcome.map(|o| (String::new(), o.files)))
}

/// The model-gap analysis of many logs: one folder per log under DIR (report.json, report.txt and
/// the figures, as `gaps --data FILE --out DIR/FOLDER` writes them; FOLDER is the file's name and a
/// hash of its path), and DIR/summary.csv and DIR/summary.jsonl (file, folder, status `verdict`,
/// `no_verdict` or `error`, top cause, reason, seconds). Logs run in parallel; a log that cannot be
/// read or analysed is an `error` row and the batch carries on; a log whose report.json exists is
/// read back, not analysed again, unless --force. Exit code 0 when every log was analysed or read
/// back, 1 when any is an error.
#[derive(Args)]
struct BatchArgs {
    /// The logs (.ulg and .bin read without --with; other formats need it).
    #[arg(value_name = "FILES", required = true)]
    files: Vec<PathBuf>,
    /// Folder of the per-log folders and the summary (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Logs analysed at once (default: the number of cores).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=1024))]
    jobs: Option<u16>,
    /// Analyse every log again, even when its report.json exists.
    #[arg(long)]
    force: bool,
    /// The column map or aircraft file of every log (optional for .ulg and .bin).
    #[arg(long = "with", value_name = "MAP_OR_AIRCRAFT")]
    with: Option<PathBuf>,
}

impl Execute for BatchArgs {
    fn execute(self) -> ExitCode {
        let mut settings = aerosid::batch::BatchSettings::new(&self.out);
        settings.with = self.with;
        settings.force = self.force;
        if let Some(j) = self.jobs {
            settings.jobs = usize::from(j);
        }
        match aerosid::batch::run(&self.files, &settings) {
            Ok(rows) => {
                print!("{}", aerosid::batch::table(&rows, &self.out));
                if rows.iter().any(|r| r.status == aerosid::batch::Status::Error) {
                    ExitCode::FAILURE
                } else {
                    ExitCode::SUCCESS
                }
            }
            Err(e) => fail("batch", e),
        }
    }
}

/// The model-gap campaign behind scripts/bench/: simulated turbulent flights per hidden kind, clean
/// flights, the vendored JSBSim flights and the real flight-test data; writes DIR/manifest.json and
/// one regression table per flight.
#[derive(Args)]
struct GapsBenchArgs {
    /// Folder of the manifest and the tables (created if missing).
    #[arg(long, value_name = "DIR", default_value = "out/gaps-bench")]
    out: PathBuf,
    /// Simulated turbulent flights per hidden kind.
    #[arg(long, value_name = "N", default_value_t = 2)]
    draws: usize,
    /// Simulated clean flights.
    #[arg(long, value_name = "N", default_value_t = 10)]
    clean: usize,
    /// Instead of the single flights: the pooled-manoeuvre suites — N simulated test cards per
    /// kind a card accepts, light and moderate turbulence in turn, and the vendored JSBSim cards
    /// (docs/benchmarks.md, "Pooled manoeuvres").
    #[arg(long, value_name = "N")]
    cards: Option<usize>,
    /// Clean simulated test cards (with --cards).
    #[arg(long, value_name = "N", default_value_t = 20, requires = "cards")]
    card_clean: usize,
    #[command(flatten)]
    levels: LevelArgs,
}

impl Execute for GapsBenchArgs {
    fn execute(self) -> ExitCode {
        if let Err(code) = check_out_dir("gaps-bench", &self.out) {
            return code;
        }
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let data = aerosid::fem_report::flight_data_dir();
        let cards = self.cards.map(|n| aerosid::gaps::bench::Cards {
            seeds_per_kind: n,
            clean: self.card_clean,
            jsbsim: Some(root.join("data/jsbsim_card")),
        });
        let flights = cards.is_none();
        let campaign = aerosid::gaps::bench::Campaign {
            draws_per_kind: if flights { self.draws } else { 0 },
            clean: if flights { self.clean } else { 0 },
            jsbsim: flights.then(|| root.join("data/jsbsim")),
            real: data
                .is_dir()
                .then(|| (data, root.join("data/maps")))
                .filter(|_| flights),
            levels: self.levels.levels(),
            cards,
        };
        match aerosid::gaps::bench::write(&campaign, &self.out) {
            Ok(lines) => {
                for l in lines {
                    println!("{l}");
                }
                println!("wrote {}/manifest.json and its tables", self.out.display());
                ExitCode::SUCCESS
            }
            Err(e) => fail("gaps-bench", e),
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Reliability and firmware checks

/// H hours of simulated flight through the on-board `f32` pipeline: excitation, calm cruise, two
/// parameter jumps; prints the worst orthonormality, λ_F, k, N_eff, refusals per coefficient and how
/// each jump was tracked, and fails when an invariant is broken.
#[derive(Args)]
struct LongRunArgs {
    #[arg(long, value_name = "H", default_value_t = 10.0, value_parser = in_range(LONG_RUN_HOURS),
          help = range_help("Simulated hours", LONG_RUN_HOURS))]
    hours: f64,
    /// Seed of the flight.
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
}

impl Execute for LongRunArgs {
    fn execute(self) -> ExitCode {
        use aerosid::longrun;
        let cfg = longrun::LongRunConfig::hours(self.hours, self.seed);
        let start = std::time::Instant::now();
        // A bar of simulated minutes on a terminal; otherwise a line per simulated hour.
        let bar = aerosid::progress::bar((cfg.duration_s / 60.0).ceil() as u64, "simulated minutes");
        let result = longrun::run(&cfg, |t| {
            if !bar.is_hidden() {
                bar.set_position((t / 60.0) as u64);
            } else if (t as u64).is_multiple_of(3600) && t > 0.0 {
                eprintln!(
                    "long-run: {:.0} h simulated, {:.0} s wall",
                    t / 3600.0,
                    start.elapsed().as_secs_f64()
                );
            }
        });
        bar.finish_and_clear();
        match result {
            Ok(r) => {
                print!("{}", longrun::format_report(&r, start.elapsed().as_secs_f64()));
                let broken = r.violations(&longrun::Invariants::REQUIRED);
                if broken.is_empty() {
                    println!("invariants: all kept");
                    ExitCode::SUCCESS
                } else {
                    for b in &broken {
                        eprintln!("aerosid long-run: invariant broken: {b}");
                    }
                    ExitCode::FAILURE
                }
            }
            Err(e) => fail("long-run", e),
        }
    }
}

/// Every panic path left in a firmware image, checked against an allow-list; fails on a path the
/// list does not cover (CI: the release firmware with firmware/panic-allow.txt).
#[derive(Args)]
struct PanicAuditArgs {
    /// The firmware image.
    #[arg(value_name = "ELF")]
    elf: PathBuf,
    /// The allow-list (firmware/panic-allow.txt).
    #[arg(value_name = "ALLOW")]
    allow: PathBuf,
}

impl Execute for PanicAuditArgs {
    fn execute(self) -> ExitCode {
        match aerosid_elf_check::panic_audit::audit_elf(&self.elf, &self.allow) {
            Ok(a) => {
                print!("{}", a.report());
                if a.uncovered().is_empty() {
                    println!(
                        "panic audit: every panic path is on the allow-list ({})",
                        self.allow.display()
                    );
                    ExitCode::SUCCESS
                } else {
                    fail(
                        "panic-audit",
                        format!("{} new panic path(s) in {}", a.uncovered().len(), self.elf.display()),
                    )
                }
            }
            Err(e) => fail("panic-audit", e),
        }
    }
}

/// A static bound on a firmware image's stack from its machine code, plus its static RAM; fails
/// when the sum exceeds --ram-budget (CI: the flight computer, 16 384 B).
#[derive(Args)]
struct StackBoundArgs {
    /// The firmware image.
    #[arg(value_name = "ELF")]
    elf: PathBuf,
    /// The handlers' priorities and the targets of the indirect calls (firmware/stack-bound.txt).
    #[arg(value_name = "CONFIG")]
    config: PathBuf,
    /// Fail when static RAM plus the stack bound exceeds this many bytes.
    #[arg(long, value_name = "BYTES")]
    ram_budget: Option<u64>,
}

impl Execute for StackBoundArgs {
    fn execute(self) -> ExitCode {
        let b = match aerosid_elf_check::stack_bound::analyse_elf(&self.elf, &self.config) {
            Ok(b) => b,
            Err(e) => return fail("stack-bound", e),
        };
        print!("{}", b.report());
        match self.ram_budget {
            Some(budget) if b.ram() > budget => fail(
                "stack-bound",
                format!(
                    "{}: RAM {} B (static {} + stack {}) exceeds the budget of {budget} B",
                    self.elf.display(),
                    b.ram(),
                    b.static_ram,
                    b.total
                ),
            ),
            Some(budget) => {
                println!("RAM within the budget: {} B ≤ {budget} B", b.ram());
                ExitCode::SUCCESS
            }
            None => ExitCode::SUCCESS,
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Shell completion

/// Print a completion script for SHELL to stdout, e.g. `aerosid completions bash >
/// ~/.local/share/bash-completion/completions/aerosid`.
#[derive(Args)]
struct CompletionsArgs {
    #[arg(value_enum)]
    shell: clap_complete::Shell,
}

impl Execute for CompletionsArgs {
    fn execute(self) -> ExitCode {
        // Into a buffer, then out: clap_complete panics on a write error (a closed pipe).
        let mut script = Vec::new();
        clap_complete::generate(self.shell, &mut command(), "aerosid", &mut script);
        print!("{}", String::from_utf8_lossy(&script));
        ExitCode::SUCCESS
    }
}
