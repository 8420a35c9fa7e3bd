//! Corrupted copies of every vendored log — the autopilot logs of `tool/data/logs/` and the `.mat`
//! of `tool/data/flight/` — through the reader and the model-gap analysis as `aerosid gaps` runs
//! them, and a subset through the command itself. Each copy ends in a clear error (naming the
//! file) or a report with a verdict status; never a panic, and never an abort: an allocation sized
//! from a corrupt field would kill this test binary, so its passing is the check.
//!
//! The corruptions, seeded per file: single bytes changed at random positions, runs of bytes
//! overwritten (zeros, 0xFF, random), truncations, and — the case that once aborted — the high
//! bytes of message time stamps overwritten (a DataFlash `TimeUS`, a ULog data message's
//! `timestamp`), which make a log's time span years long.

use aerosid::gaps::{report, run_gaps, GapSettings};
use aerosid::io::{read_measured_with, ReadOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Per file: changed single bytes, overwritten runs, truncations, corrupt time stamps.
const FLIPS: usize = 20;
const RUNS: usize = 10;
const TRUNCATIONS: usize = 10;
const TIMESTAMPS: usize = 10;

/// The vendored logs and the companion each is read with (`None`: read as `aerosid gaps --data`
/// reads a `.ulg` or `.bin` without `--with`).
fn vendored() -> Vec<(PathBuf, Option<PathBuf>)> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let mut files: Vec<(PathBuf, Option<PathBuf>)> = std::fs::read_dir(data.join("logs"))
        .expect("tool/data/logs")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension()
                    .and_then(|e| e.to_str())
                    .map(str::to_ascii_lowercase)
                    .as_deref(),
                Some("ulg") | Some("bin")
            )
        })
        .map(|p| (p, None))
        .collect();
    files.sort();
    let map = data.join("maps/twin_otter.map");
    files.push((data.join("flight/totter_lon_020213f1_018.mat"), Some(map)));
    files
}

/// The byte offsets of the 64-bit time stamps of the file's messages: a DataFlash message's first
/// field (`TimeUS`, after the 3-byte header; FMT messages excepted), a ULog `D` message's
/// `timestamp` (after the 3-byte header and the 2-byte message id).
fn timestamp_offsets(bytes: &[u8], ext: &str) -> Vec<usize> {
    match ext {
        "bin" => (0..bytes.len().saturating_sub(11))
            .filter(|&p| bytes[p] == 0xA3 && bytes[p + 1] == 0x95 && bytes[p + 2] != 128)
            .map(|p| p + 3)
            .collect(),
        "ulg" => {
            let mut out = Vec::new();
            let mut pos = 16;
            while pos + 3 <= bytes.len() {
                let size = u16::from_le_bytes([bytes[pos], bytes[pos + 1]]) as usize;
                if bytes[pos + 2] == b'D' && size >= 10 && pos + 13 <= bytes.len() {
                    out.push(pos + 5);
                }
                pos += 3 + size;
            }
            out
        }
        _ => Vec::new(),
    }
}

/// The corrupted copies of `bytes`, each with a description for a failure message.
fn corruptions(bytes: &[u8], ext: &str, seed: u64) -> Vec<(String, Vec<u8>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = bytes.len();
    let mut out = Vec::new();
    for _ in 0..FLIPS {
        let i = rng.random_range(0..n);
        let mut d = bytes.to_vec();
        d[i] ^= rng.random_range(1..=255u8);
        out.push((format!("byte {i} changed"), d));
    }
    for _ in 0..RUNS {
        let i = rng.random_range(0..n);
        let len = rng.random_range(2..=256).min(n - i);
        let mut d = bytes.to_vec();
        let fill = rng.random_range(0..3);
        for b in &mut d[i..i + len] {
            *b = match fill {
                0 => 0,
                1 => 0xFF,
                _ => rng.random(),
            };
        }
        out.push((format!("{len} bytes from {i} overwritten (fill {fill})"), d));
    }
    for k in 0..TRUNCATIONS {
        // The empty file and the first bytes (a header cut short) too.
        let len = match k {
            0 => 0,
            1 => 1.min(n),
            2 => 20.min(n),
            _ => rng.random_range(0..n),
        };
        out.push((format!("truncated to {len} bytes"), bytes[..len].to_vec()));
    }
    let stamps = timestamp_offsets(bytes, ext);
    for _ in 0..TIMESTAMPS.min(stamps.len()) {
        let at = stamps[rng.random_range(0..stamps.len())];
        let mut d = bytes.to_vec();
        // Byte 5 or 6 of the little-endian µs count: 2^40 µs is 12.7 days, 2^48 µs 8.9 years.
        let byte = at + rng.random_range(5..7);
        d[byte] = rng.random_range(1..=255u8);
        out.push((format!("time stamp at byte {at} made years long"), d));
    }
    out
}

/// Calls `f(file, companion, extension, corrupted copies)` for each vendored log, its copies
/// seeded by its place in the list.
fn each_vendored(mut f: impl FnMut(&Path, Option<&Path>, &str, Vec<(String, Vec<u8>)>)) {
    for (seed, (file, companion)) in vendored().into_iter().enumerate() {
        let bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let ext = file
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or_default()
            .to_ascii_lowercase();
        let copies = corruptions(&bytes, &ext, seed as u64);
        f(&file, companion.as_deref(), &ext, copies);
    }
}

/// A fresh scratch folder.
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid-corrupt-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// The panic message of a caught panic.
fn message(e: &(dyn std::any::Any + Send)) -> String {
    e.downcast_ref::<String>()
        .cloned()
        .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default()
}

/// The copy `d` of `file` read and analysed as `aerosid gaps` does: an error that names the file,
/// or a report whose JSON carries a verdict status. Returns what happened, for the tally.
fn read_and_analyse(path: &Path, companion: Option<&Path>) -> &'static str {
    let name = path.display().to_string();
    let flight = match read_measured_with(path, companion, &ReadOptions::default()) {
        Err(e) => {
            let text = e.to_string();
            assert!(
                !e.message.trim().is_empty()
                    && (text.contains(&name) || companion.is_some_and(|c| text.contains(&c.display().to_string()))),
                "an error that does not name the file: {text}"
            );
            // The case that aborted before the time base was bounded by the file's samples.
            if e.message.contains("a time stamp is corrupt") {
                return "read error: time span";
            }
            return "read error";
        }
        Ok(f) => f,
    };
    match run_gaps(&flight, &GapSettings::default()) {
        Err(e) => {
            assert!(!e.to_string().trim().is_empty(), "an empty analysis error");
            "analysis refused"
        }
        Ok(r) => {
            let json = report::json(&r);
            let status = json["status"].as_str().unwrap_or_default();
            assert!(
                status == "verdict"
                    || (status == "no_verdict" && json["reasons"].as_array().is_some_and(|a| !a.is_empty())),
                "report.json status {status:?}, reasons {}",
                json["reasons"]
            );
            assert!(!report::table(&r).is_empty());
            "report"
        }
    }
}

#[test]
fn every_corrupted_vendored_log_gets_an_error_or_a_report_never_a_crash() {
    let dir = scratch("library");
    let mut tally = std::collections::BTreeMap::<&str, usize>::new();
    let mut cases = 0;
    each_vendored(|file, companion, ext, copies| {
        let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("log");
        cases += copies.len();
        // The copies in parallel (each is read and analysed on its own).
        let outcomes: Vec<&str> = copies
            .par_iter()
            .enumerate()
            .map(|(k, (what, d))| {
                let copy = dir.join(format!("{stem}-{k}.{ext}"));
                std::fs::write(&copy, d).expect("write the copy");
                let outcome = catch_unwind(AssertUnwindSafe(|| read_and_analyse(&copy, companion)));
                match outcome {
                    Ok(o) => {
                        let _ = std::fs::remove_file(&copy);
                        o
                    }
                    Err(e) => panic!(
                        "{} ({what}, kept as {}): panicked: {}",
                        file.display(),
                        copy.display(),
                        message(&*e)
                    ),
                }
            })
            .collect();
        for o in outcomes {
            *tally.entry(o).or_default() += 1;
        }
    });
    println!("{cases} corrupted copies: {tally:?}");
    // Each outcome occurs: the corruptions reach the analysis, not only the readers' first checks,
    // and the time stamps made years long are among them.
    assert!(cases >= 250, "{cases} cases");
    for o in ["read error", "read error: time span", "report"] {
        assert!(tally.get(o).copied().unwrap_or(0) > 0, "no `{o}` among {tally:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_command_ends_every_corrupted_log_with_exit_code_0_or_1() {
    let exe = env!("CARGO_BIN_EXE_aerosid");
    let dir = scratch("command");
    each_vendored(|file, companion, ext, all| {
        // One of each kind: the first flip, run, truncation and time stamp.
        let picks = [0, FLIPS, FLIPS + RUNS + 3, FLIPS + RUNS + TRUNCATIONS];
        for (k, (what, d)) in picks.iter().filter_map(|&i| all.get(i)).enumerate() {
            let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("log");
            let copy = dir.join(format!("{stem}-{k}.{ext}"));
            std::fs::write(&copy, d).expect("write the copy");
            let out = dir.join(format!("{stem}-{k}-out"));
            let mut cmd = std::process::Command::new(exe);
            cmd.args(["gaps", "--data"]).arg(&copy).arg("--out").arg(&out);
            if let Some(c) = companion {
                cmd.arg("--with").arg(c);
            }
            let o = cmd.output().expect("run aerosid");
            let stderr = String::from_utf8_lossy(&o.stderr);
            let case = format!(
                "{} ({what}): exit {:?}, stderr:\n{stderr}",
                file.display(),
                o.status.code()
            );
            match o.status.code() {
                Some(0) => {
                    let json: serde_json::Value =
                        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).expect(&case))
                            .expect(&case);
                    assert!(
                        matches!(json["status"].as_str(), Some("verdict") | Some("no_verdict")),
                        "{case}"
                    );
                }
                // (Not "starts with": the `.mat` parser's own panics, caught and turned into an
                // error, print the panic hook's line first.)
                Some(1) => assert!(stderr.contains("aerosid gaps: "), "{case}"),
                _ => panic!("{case}"),
            }
        }
    });
    let _ = std::fs::remove_dir_all(&dir);
}
