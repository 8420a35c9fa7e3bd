//! `aerosid batch` over the vendored logs (`tool/data/logs/`), the vendored flight-test data with
//! their column maps (`tool/data/flight/`) and a file that is not a log: one summary row per file
//! in the order given, each row's status agreeing with what its folder holds, the bad file an
//! error row naming it while the others run, a second run reading every report back, `--force`
//! analysing again, and two logs of the same name in different folders kept apart.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// A fresh scratch folder per test.
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid-batch-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

fn batch(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .arg("batch")
        .args(args)
        .output()
        .expect("run aerosid batch")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The rows of summary.jsonl.
fn rows(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join("summary.jsonl"))
        .expect("summary.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON row"))
        .collect()
}

/// The status and top cause of each row, for comparing two runs.
fn verdicts(rows: &[serde_json::Value]) -> Vec<(String, String, String)> {
    rows.iter()
        .map(|r| {
            (
                r["file"].as_str().unwrap_or_default().to_owned(),
                r["status"].as_str().unwrap_or_default().to_owned(),
                r["top_cause"].as_str().unwrap_or_default().to_owned(),
            )
        })
        .collect()
}

/// Every row's status agrees with its folder: `verdict` / `no_verdict` have a report.json whose
/// data quality says whether a verdict is supported; `error` has none and a reason.
fn check_rows_against_folders(out: &Path, rows: &[serde_json::Value]) {
    for r in rows {
        let folder = out.join(r["folder"].as_str().expect("folder"));
        let status = r["status"].as_str().expect("status");
        let report = folder.join("report.json");
        match status {
            "verdict" | "no_verdict" => {
                let v: serde_json::Value =
                    serde_json::from_str(&std::fs::read_to_string(&report).expect("report.json")).expect("parse");
                assert_eq!(v["status"].as_str(), Some(status), "{r}");
                assert_eq!(
                    v["data_quality"]["supports_verdict"].as_bool(),
                    Some(status == "verdict"),
                    "{r}"
                );
                if v["analysis"] == "not run" {
                    // Too short to analyse: the reasons stand for the verdict.
                    let reasons: Vec<&str> = v["reasons"]
                        .as_array()
                        .expect("reasons")
                        .iter()
                        .filter_map(serde_json::Value::as_str)
                        .collect();
                    assert_eq!(r["reason"].as_str(), Some(reasons.join("; ").as_str()), "{r}");
                } else {
                    assert_eq!(r["reason"], v["verdict"], "{r}");
                    assert!(folder.join("report.txt").is_file(), "{r}");
                }
            }
            "error" => {
                assert!(!report.exists(), "{r}");
                assert!(!r["reason"].as_str().unwrap_or_default().is_empty(), "{r}");
            }
            other => panic!("status {other}: {r}"),
        }
    }
}

#[test]
fn a_batch_of_logs_and_a_bad_file_resumes_and_reruns() {
    let dir = scratch("logs");
    let bad = dir.join("not_a_log.ulg");
    std::fs::write(&bad, "this is not a ULog\n").expect("write");
    let logs: Vec<PathBuf> = {
        let mut v: Vec<PathBuf> = std::fs::read_dir(data().join("logs"))
            .expect("logs")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                let ext = p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
                matches!(ext.as_deref(), Some("ulg") | Some("bin"))
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(logs.len(), 5, "{logs:?}");
    let out = dir.join("out");
    let mut args: Vec<&Path> = vec![Path::new("--out"), &out, Path::new("--jobs"), Path::new("2")];
    args.extend(logs.iter().map(PathBuf::as_path));
    args.push(&bad);
    let o = batch(&args);
    // A bad file makes the exit code 1, but every other log is analysed.
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let first = rows(&out);
    assert_eq!(first.len(), logs.len() + 1);
    for (r, f) in first.iter().zip(logs.iter().chain([&bad])) {
        assert_eq!(r["file"].as_str(), Some(f.display().to_string().as_str()));
    }
    check_rows_against_folders(&out, &first);
    let bad_row = first.last().expect("bad row");
    assert_eq!(bad_row["status"], "error");
    assert!(
        bad_row["reason"]
            .as_str()
            .unwrap_or_default()
            .contains("not_a_log.ulg: not a ULog"),
        "{bad_row}"
    );
    // log_52 flies but cannot support a verdict (real_logs.rs); the pymavlink bench log is too
    // short for the analysis to run: a report with no verdict all the same.
    let by_name = |n: &str| {
        first
            .iter()
            .find(|r| r["file"].as_str().is_some_and(|f| f.ends_with(n)))
            .unwrap_or_else(|| panic!("{n}"))
            .clone()
    };
    assert_eq!(by_name("log_52_2021-5-22-12-42-56.ulg")["status"], "no_verdict");
    assert_eq!(by_name("pymavlink_test.BIN")["status"], "no_verdict");
    // The CSV has the same rows, a header first.
    let csv = std::fs::read_to_string(out.join("summary.csv")).expect("csv");
    assert!(
        csv.starts_with("file,folder,status,top_cause,reason,seconds\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), first.len() + 1);

    // Resume: the reports are read back, not written again.
    let report = out
        .join(
            by_name("log_52_2021-5-22-12-42-56.ulg")["folder"]
                .as_str()
                .expect("folder"),
        )
        .join("report.json");
    let written = std::fs::metadata(&report).and_then(|m| m.modified()).expect("mtime");
    let o = batch(&args);
    let stdout = text(&o.stdout);
    assert!(stdout.contains("log_52_2021-5-22-12-42-56.ulg (resumed)"), "{stdout}");
    assert!(!stdout.contains("not_a_log.ulg (resumed)"), "{stdout}");
    assert_eq!(
        std::fs::metadata(&report).and_then(|m| m.modified()).expect("mtime"),
        written
    );
    let second = rows(&out);
    assert_eq!(verdicts(&second), verdicts(&first));

    // --force: every log analysed again, the same statuses.
    let mut forced = args.clone();
    forced.push(Path::new("--force"));
    let o = batch(&forced);
    assert!(!text(&o.stdout).contains("(resumed)"), "{}", text(&o.stdout));
    assert_ne!(
        std::fs::metadata(&report).and_then(|m| m.modified()).expect("mtime"),
        written
    );
    assert_eq!(verdicts(&rows(&out)), verdicts(&first));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_batch_of_flight_test_data_with_a_map() {
    let dir = scratch("flight");
    let flight = data().join("flight");
    let attas: Vec<PathBuf> = [
        "fAttasAil1_pqrDot.asc",
        "fAttasElv1_pqrDot.asc",
        "fAttasRud1_pqrDot.asc",
    ]
    .iter()
    .map(|f| flight.join(f))
    .collect();
    let map = data().join("maps").join("attas.map");
    let out = dir.join("out");
    let mut args: Vec<&Path> = vec![
        Path::new("--out"),
        &out,
        Path::new("--with"),
        &map,
        Path::new("--jobs"),
        Path::new("2"),
    ];
    args.extend(attas.iter().map(PathBuf::as_path));
    let o = batch(&args);
    assert!(o.status.success(), "{}\n{}", text(&o.stdout), text(&o.stderr));
    let rows = rows(&out);
    assert_eq!(rows.len(), 3);
    check_rows_against_folders(&out, &rows);
    assert!(rows.iter().all(|r| r["status"] != "error"), "{rows:?}");
    // The batch's report of a flight is the one `aerosid gaps` writes for it.
    let single = dir.join("single");
    let o = Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args(["gaps", "--data"])
        .arg(&attas[1])
        .arg("--with")
        .arg(&map)
        .arg("--out")
        .arg(&single)
        .output()
        .expect("run aerosid gaps");
    assert!(o.status.success(), "{}", text(&o.stderr));
    let read = |p: PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).expect("report.json")).expect("parse")
    };
    let a = read(single.join("report.json"));
    let b = read(
        out.join(rows[1]["folder"].as_str().expect("folder"))
            .join("report.json"),
    );
    assert_eq!(a["verdict"], b["verdict"]);
    assert_eq!(a["top_cause"], b["top_cause"]);
    assert_eq!(a["named"], b["named"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn logs_of_the_same_name_in_two_folders_get_two_folders() {
    let dir = scratch("names");
    for sub in ["a", "b"] {
        std::fs::create_dir_all(dir.join(sub)).expect("mkdir");
        std::fs::copy(data().join("logs/pymavlink_test.BIN"), dir.join(sub).join("log.bin")).expect("copy");
    }
    let out = dir.join("out");
    let (a, b) = (dir.join("a/log.bin"), dir.join("b/log.bin"));
    let o = batch(&[Path::new("--out"), &out, &a, &b]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let rows = rows(&out);
    assert_ne!(rows[0]["folder"], rows[1]["folder"]);
    // Each folder holds its own log's report (no verdict: the analysis cannot run on 41 samples),
    // and the batch succeeds.
    for r in &rows {
        assert!(
            out.join(r["folder"].as_str().expect("folder"))
                .join("report.json")
                .is_file(),
            "{r}"
        );
    }
    // A folder is the same from one run to the next.
    let o = batch(&[Path::new("--out"), &out, &b]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(rows_folder(&out), vec![rows[1]["folder"].clone()]);
    let _ = std::fs::remove_dir_all(&dir);
}

fn rows_folder(out: &Path) -> Vec<serde_json::Value> {
    rows(out).into_iter().map(|r| r["folder"].clone()).collect()
}
