//! The command's conventions for scripts and batch users: the exit codes (0 a report was
//! written, also one with no verdict; 1 the input could not be read or is invalid; 2 usage),
//! stated in every command's `--help`; `--out` checked before any work; a closed stdout (`aerosid
//! gaps | head -1`) ends the printing quietly, not in a panic, and the files are still written.

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn exe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_aerosid"))
}

/// A fresh scratch folder.
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid-exit-codes-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

#[test]
fn every_command_states_the_exit_codes_in_its_help() {
    for args in [
        &["--help"][..],
        &["gaps", "--help"],
        &["long-run", "--help"],
        &["predict", "--help"],
    ] {
        let o = exe().args(args).output().expect("run aerosid");
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{args:?}");
        for line in ["Exit codes:", "  0  ", "  1  ", "  2  "] {
            assert!(text.contains(line), "aerosid {args:?}: no `{line}` in\n{text}");
        }
    }
    // Usage errors are 2, as the help says.
    let o = exe()
        .args(["gaps", "--seconds", "1", "--clean"])
        .output()
        .expect("run aerosid");
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn an_unwritable_out_fails_at_once_with_exit_code_1() {
    // /proc refuses new entries; a file in place of the folder is refused everywhere.
    let dir = scratch("out");
    let file = dir.join("a-file");
    std::fs::write(&file, b"").expect("write");
    for out in [PathBuf::from("/proc/aerosid-out"), file.join("sub")] {
        let o = exe()
            .args(["gaps", "--clean", "--out"])
            .arg(&out)
            .output()
            .expect("run aerosid");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains(&format!("--out {}: cannot write there", out.display())),
            "{stderr}"
        );
        // Nothing ran: no report was printed.
        assert!(o.stdout.is_empty(), "{}", String::from_utf8_lossy(&o.stdout));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `aerosid ARGS` with its stdout a pipe whose reading end is closed before the command
/// writes anything (the deterministic form of `| head -0`); returns the exit code and stderr.
fn with_closed_stdout(args: &[&str]) -> (Option<i32>, String) {
    let mut child = exe()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run aerosid");
    drop(child.stdout.take());
    let mut stderr = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut stderr);
    }
    let status = child.wait().expect("wait");
    (status.code(), stderr)
}

#[test]
fn a_closed_stdout_ends_printing_quietly() {
    let dir = scratch("pipe");
    let out = dir.join("gaps");
    let out_arg = out.display().to_string();
    let (code, stderr) = with_closed_stdout(&["gaps", "--clean", "--calm", "--seconds", "20", "--out", &out_arg]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");
    // The report is still written.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).expect("report.json")).expect("json");
    assert!(json["status"].is_string());
    for args in [&["completions", "bash"][..], &["--help"], &["gaps", "--help"]] {
        let (code, stderr) = with_closed_stdout(args);
        assert_eq!(code, Some(0), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
