//! The gap analysis of one flight into a folder ([`analyse`], what `aerosid gaps` runs), and of many
//! logs at once ([`run`], `aerosid batch`): one folder per log with its report.json, report.txt and
//! figures, and a summary of every log in `summary.csv` and `summary.jsonl`.
//!
//! A batch runs its logs on `jobs` threads (a rayon pool of its own), carries on past a log that
//! cannot be read or analysed (its row says `error` and why), and resumes: a log whose folder holds
//! a report.json is not analysed again unless `force` is set; its row is read back from that
//! report. The row of a log is always derived from its report.json content ([`row_from_report`]),
//! fresh or resumed, so both give the same status, top cause and reason.
//!
//! A log's folder is named after its file, followed by a hash of its canonical path
//! ([`folder_name`]): two logs of the same name in different folders get different folders, and a
//! log keeps its folder from one run to the next (resuming needs that). The hash is FNV-1a (64 bit),
//! written out here in a few lines because its value must not change between Rust releases (the
//! standard library's hasher makes no such promise) and the Python package reproduces nothing: it
//! calls this module.

use crate::gaps::GapSettings;
use crate::io::measured::MeasuredFlight;
use crate::io::ReadOptions;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What the analysis of one log came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// The analysis ran and the data support a verdict (named causes, or nothing missing).
    Verdict,
    /// The analysis ran but the data cannot support a verdict (the report says why).
    NoVerdict,
    /// The log could not be read, or the analysis could not run.
    Error,
}

impl Status {
    /// The name in the summary: `verdict`, `no_verdict`, `error`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Verdict => "verdict",
            Self::NoVerdict => "no_verdict",
            Self::Error => "error",
        }
    }

    /// The status of a summary name.
    pub fn parse(s: &str) -> Option<Self> {
        [Self::Verdict, Self::NoVerdict, Self::Error]
            .into_iter()
            .find(|x| x.name() == s)
    }
}

/// One log's line of the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The log, as given.
    pub file: String,
    /// Its folder under the batch's output folder.
    pub folder: String,
    /// What the analysis came to.
    pub status: Status,
    /// The top cause (`location: what`), empty when none was named.
    pub top_cause: String,
    /// The report's verdict (`verdict`), why there is none (`no_verdict`), or the error.
    pub reason: String,
    /// Wall-clock seconds of the analysis (`None`: resumed, and its time was not recorded).
    pub seconds: Option<f64>,
    /// Whether the log was skipped because its report.json exists.
    pub resumed: bool,
}

/// The outcome of [`analyse`] when the analysis ran and its files were written.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The report.json content.
    pub report: Value,
    /// The files written.
    pub files: Vec<PathBuf>,
}

/// What [`analyse`] printed and found.
#[derive(Debug)]
pub struct Analysis {
    /// The terminal text: the report's table, or the data-quality table when the analysis could
    /// not run (its report.json then has status `no_verdict` and the reasons).
    pub table: String,
    /// The report and files, or why the analysis did not run or its files were not written.
    pub outcome: Result<Outcome, String>,
}

/// The gap analysis of `flight` into `out`: report.json, report.txt and the figures; when the
/// analysis cannot run (too few samples, no coefficient), report.json still says what the data
/// can and cannot support, with status `no_verdict` ([`not_run_report`]).
pub fn analyse(flight: &MeasuredFlight, out: &Path, settings: &GapSettings) -> Analysis {
    let report = match crate::gaps::run_gaps(flight, settings) {
        Ok(r) => r,
        Err(e) => return not_analysed(flight, out, settings, &e),
    };
    let table = crate::gaps::report::table(&report);
    let outcome = crate::gaps::report::write(&report, out)
        .map(|files| Outcome {
            report: crate::gaps::report::json(&report),
            files,
        })
        .map_err(|e| e.to_string());
    Analysis { table, outcome }
}

/// The report of a flight the analysis refused: too short, or no coefficient to synthesise, is
/// still a report — the data-quality table and a report.json content with status `no_verdict` and
/// the reasons (a batch gets a report per log; the command exits 0). A time base or channel the
/// analysis refuses is invalid input: the error.
pub fn not_run_report(
    flight: &MeasuredFlight,
    settings: &GapSettings,
    e: &crate::gaps::GapError,
) -> Result<(String, Value), String> {
    use crate::gaps::GapError;
    let reason = format!("the analysis did not run: {e}");
    if matches!(e, GapError::NonUniformTime { .. } | GapError::BadChannel { .. }) {
        return Err(reason);
    }
    let prepared = crate::io::flow_angles::prepare(
        flight,
        settings.flow_angles,
        &crate::io::flow_angles::WindFitSettings::default(),
    );
    let q = crate::gaps::quality::assess(&prepared);
    let mut table = crate::io::quality::table(&q);
    table.push_str(&format!("\nno verdict: {reason}\n"));
    let reasons: Vec<String> = std::iter::once(reason).chain(q.why_not.iter().cloned()).collect();
    let mut json = serde_json::json!({
        "schema": "aerosid-gaps/3",
        "source": flight.source,
        "analysis": "not run",
        "data_quality": q,
    });
    crate::gaps::report::add_status(&mut json, false, &reasons);
    Ok((table, json))
}

/// The report.json content of `flight`, written nowhere: the analysis's, or
/// [`not_run_report`]'s when it cannot run.
pub fn report_value(flight: &MeasuredFlight, settings: &GapSettings) -> Result<Value, String> {
    match crate::gaps::run_gaps(flight, settings) {
        Ok(r) => Ok(crate::gaps::report::json(&r)),
        Err(e) => not_run_report(flight, settings, &e).map(|(_, v)| v),
    }
}

/// [`not_run_report`], its report.json written to `out`.
fn not_analysed(flight: &MeasuredFlight, out: &Path, settings: &GapSettings, e: &crate::gaps::GapError) -> Analysis {
    let (table, json) = match not_run_report(flight, settings, e) {
        Ok(x) => x,
        Err(reason) => {
            return Analysis {
                table: String::new(),
                outcome: Err(reason),
            }
        }
    };
    let file = out.join("report.json");
    let written = std::fs::create_dir_all(out).and_then(|_| {
        serde_json::to_string_pretty(&json)
            .map_err(std::io::Error::other)
            .and_then(|text| std::fs::write(&file, text))
    });
    Analysis {
        table,
        outcome: written
            .map(|()| Outcome {
                report: json,
                files: vec![file.clone()],
            })
            .map_err(|w| format!("{}: {w}", file.display())),
    }
}

/// The status, top cause and reason of a report.json content (schema `aerosid-gaps/3`).
pub fn row_from_report(report: &Value) -> (Status, String, String) {
    let supports = match report["status"].as_str() {
        Some(s) => s == "verdict",
        None => report["data_quality"]["supports_verdict"].as_bool().unwrap_or(false),
    };
    let top = &report["top_cause"];
    let top_cause = match (top["location"].as_str(), top["what"].as_str()) {
        (Some(l), Some(w)) => format!("{l}: {w}"),
        _ => String::new(),
    };
    let verdict = match report["verdict"].as_str() {
        Some(v) => v.to_owned(),
        None => report["reasons"]
            .as_array()
            .map(|r| r.iter().filter_map(Value::as_str).collect::<Vec<_>>().join("; "))
            .unwrap_or_default(),
    };
    if supports {
        (Status::Verdict, top_cause, verdict)
    } else {
        (Status::NoVerdict, top_cause, verdict)
    }
}

/// FNV-1a, 64 bit, of `bytes`.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The folder of a log under the batch's output folder: its file name (characters other than
/// letters, digits, `.`, `-`, `_` replaced by `_`), `-`, and eight hex digits of the FNV-1a hash of
/// its canonical path (the path as given when it cannot be resolved, e.g. a missing file).
pub fn folder_name(file: &Path) -> String {
    let base: String = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "log".into())
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let canonical = std::fs::canonicalize(file).unwrap_or_else(|_| file.to_path_buf());
    let h = fnv1a(canonical.to_string_lossy().as_bytes());
    format!("{base}-{:08x}", h >> 32)
}

/// Settings of a batch.
#[derive(Debug, Clone)]
pub struct BatchSettings {
    /// The output folder: one folder per log, summary.csv, summary.jsonl.
    pub out: PathBuf,
    /// The column map or aircraft file of every log (`None`: only .ulg and .bin logs read).
    pub with: Option<PathBuf>,
    /// Threads analysing logs at once (at least 1).
    pub jobs: usize,
    /// Analyse a log again even when its report.json exists.
    pub force: bool,
    /// A progress bar on stderr when it is a terminal.
    pub progress: bool,
    /// How the logs are read.
    pub read: ReadOptions,
    /// The analysis.
    pub gaps: GapSettings,
}

impl BatchSettings {
    /// The defaults of `aerosid batch` for the output folder `out`.
    pub fn new(out: impl Into<PathBuf>) -> Self {
        Self {
            out: out.into(),
            with: None,
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            force: false,
            progress: true,
            read: ReadOptions::default(),
            gaps: GapSettings::default(),
        }
    }
}

/// The file of a log folder that records the analysis's wall-clock seconds (for the summary of a
/// resumed batch).
const SECONDS_FILE: &str = "seconds.txt";

/// Reads, analyses and writes one log into its folder under `settings.out`; a log with a
/// report.json is read back instead unless `settings.force`. Never fails: a log that cannot be
/// read or analysed is an `error` row with the message.
pub fn run_one(file: &Path, settings: &BatchSettings) -> Row {
    let folder = folder_name(file);
    let dir = settings.out.join(&folder);
    let row = |status, top_cause, reason, seconds, resumed| Row {
        file: file.display().to_string(),
        folder: folder.clone(),
        status,
        top_cause,
        reason,
        seconds,
        resumed,
    };
    let existing = dir.join("report.json");
    if !settings.force && existing.is_file() {
        let seconds = std::fs::read_to_string(dir.join(SECONDS_FILE))
            .ok()
            .and_then(|s| s.trim().parse().ok());
        let read = std::fs::read_to_string(&existing)
            .map_err(|e| e.to_string())
            .and_then(|s| serde_json::from_str::<Value>(&s).map_err(|e| e.to_string()));
        return match read {
            Ok(v) => {
                let (status, top, reason) = row_from_report(&v);
                row(status, top, reason, seconds, true)
            }
            Err(e) => row(
                Status::Error,
                String::new(),
                format!("{}: {e} (--force analyses the log again)", existing.display()),
                seconds,
                true,
            ),
        };
    }
    let start = Instant::now();
    let result = crate::io::read_measured_with(file, settings.with.as_deref(), &settings.read)
        .map_err(|e| e.to_string())
        .and_then(|flight| analyse(&flight, &dir, &settings.gaps).outcome);
    let seconds = start.elapsed().as_secs_f64();
    // A stale report of an earlier run must not make the next run skip a log that now fails.
    if result.is_err() && settings.force {
        let _ = std::fs::remove_file(&existing);
    }
    match result {
        Ok(o) => {
            let _ = std::fs::write(dir.join(SECONDS_FILE), format!("{seconds}\n"));
            let (status, top, reason) = row_from_report(&o.report);
            row(status, top, reason, Some(seconds), false)
        }
        Err(e) => row(Status::Error, String::new(), e, Some(seconds), false),
    }
}

/// Why a batch could not run or write its summary.
#[derive(Debug)]
pub enum BatchError {
    /// No log was given.
    NoFiles,
    /// The thread pool could not be built.
    Pool(String),
    /// A summary file could not be written.
    Io(PathBuf, std::io::Error),
}

impl core::fmt::Display for BatchError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoFiles => f.write_str("no log given: name one or more files"),
            Self::Pool(e) => write!(f, "thread pool: {e}"),
            Self::Io(p, e) => write!(f, "{}: {e}", p.display()),
        }
    }
}

impl std::error::Error for BatchError {}

/// Analyses every log of `files` (in parallel, `settings.jobs` at a time) and writes
/// `summary.csv` and `summary.jsonl` to `settings.out`. The rows are in the order of `files`.
pub fn run(files: &[PathBuf], settings: &BatchSettings) -> Result<Vec<Row>, BatchError> {
    if files.is_empty() {
        return Err(BatchError::NoFiles);
    }
    std::fs::create_dir_all(&settings.out).map_err(|e| BatchError::Io(settings.out.clone(), e))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.jobs.max(1))
        .build()
        .map_err(|e| BatchError::Pool(e.to_string()))?;
    let bar = if settings.progress && std::io::stderr().is_terminal() {
        let bar = ProgressBar::with_draw_target(Some(files.len() as u64), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template("batch {bar:40} {pos}/{len} logs, {elapsed}, eta {eta} {msg}") {
            bar.set_style(style);
        }
        bar
    } else {
        ProgressBar::hidden()
    };
    let rows: Vec<Row> = pool.install(|| {
        files
            .par_iter()
            .map(|f| {
                let r = run_one(f, settings);
                bar.set_message(r.folder.clone());
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    write_summary(&settings.out, &rows)?;
    Ok(rows)
}

/// The summary's columns, in order.
pub const COLUMNS: [&str; 6] = ["file", "folder", "status", "top_cause", "reason", "seconds"];

/// A CSV field: quoted (inner quotes doubled) when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// Writes `summary.csv` and `summary.jsonl` of `rows` to `out` (the seconds with millisecond
/// resolution; empty in the CSV and null in the JSON when unknown).
pub fn write_summary(out: &Path, rows: &[Row]) -> Result<(), BatchError> {
    let mut csv = COLUMNS.join(",");
    csv.push('\n');
    let mut jsonl = String::new();
    for r in rows {
        let seconds = r.seconds.map(|s| format!("{s:.3}")).unwrap_or_default();
        let fields = [
            r.file.as_str(),
            &r.folder,
            r.status.name(),
            &r.top_cause,
            &r.reason,
            &seconds,
        ];
        csv.push_str(&fields.map(csv_field).join(","));
        csv.push('\n');
        let json = serde_json::json!({
            "file": r.file,
            "folder": r.folder,
            "status": r.status.name(),
            "top_cause": r.top_cause,
            "reason": r.reason,
            "seconds": r.seconds.map(|s| (s * 1000.0).round() / 1000.0),
        });
        jsonl.push_str(&json.to_string());
        jsonl.push('\n');
    }
    for (name, text) in [("summary.csv", csv), ("summary.jsonl", jsonl)] {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| BatchError::Io(p.clone(), e))?;
    }
    Ok(())
}

/// The terminal summary of a batch: one line per log and the counts.
pub fn table(rows: &[Row], out: &Path) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for r in rows {
        let what = match r.status {
            Status::Verdict if !r.top_cause.is_empty() => r.top_cause.clone(),
            _ => r.reason.lines().next().unwrap_or_default().to_owned(),
        };
        let resumed = if r.resumed { " (resumed)" } else { "" };
        let _ = writeln!(s, "{:<10} {}{resumed}: {what}", r.status.name(), r.file);
    }
    let count = |st| rows.iter().filter(|r| r.status == st).count();
    let _ = writeln!(
        s,
        "\n{} logs: {} verdict, {} no verdict, {} error; {} resumed (report.json exists; --force analyses again)",
        rows.len(),
        count(Status::Verdict),
        count(Status::NoVerdict),
        count(Status::Error),
        rows.iter().filter(|r| r.resumed).count()
    );
    let _ = writeln!(
        s,
        "summary: {} and {}",
        out.join("summary.csv").display(),
        out.join("summary.jsonl").display()
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        // FNV test vectors (Fowler, Noll, Vo: "FNV-1a 64-bit" of "" and "a").
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn same_name_in_two_folders_gets_two_folders_and_keeps_them() {
        let a = folder_name(Path::new("/flights/a/log 1.ulg"));
        let b = folder_name(Path::new("/flights/b/log 1.ulg"));
        assert_ne!(a, b);
        assert!(a.starts_with("log_1.ulg-") && a.len() == "log_1.ulg-".len() + 8, "{a}");
        assert_eq!(a, folder_name(Path::new("/flights/a/log 1.ulg")));
    }

    #[test]
    fn csv_fields_with_commas_and_quotes_are_quoted() {
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a, b"), "\"a, b\"");
        assert_eq!(csv_field("say \"x\""), "\"say \"\"x\"\"\"");
    }

    #[test]
    fn status_names_round_trip() {
        for s in [Status::Verdict, Status::NoVerdict, Status::Error] {
            assert_eq!(Status::parse(s.name()), Some(s));
        }
        assert_eq!(Status::parse("skipped"), None);
    }
}
