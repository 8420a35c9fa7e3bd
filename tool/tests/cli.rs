//! The `aerosid` command line as a user meets it: every command answers `--help`, `--version`
//! works, out-of-range and missing values are refused with a message naming the argument (exit
//! code 2, nothing run), and the completion scripts name every command. Runs the binary cargo built
//! for these tests.

use std::process::{Command, Output};

fn aerosid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running aerosid {args:?}: {e}"))
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The command names listed under `Commands:` in the top-level help.
fn commands() -> Vec<String> {
    let help = stdout(&aerosid(&["--help"]));
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .filter(|c| c != "help")
        .collect()
}

#[test]
fn every_command_answers_help() {
    let cmds = commands();
    // The commands the README, CI and the scripts call; more may be added.
    for expected in [
        "run",
        "simulate",
        "replay",
        "fem-hfb320",
        "table1",
        "gaps",
        "gaps-bench",
        "long-run",
        "panic-audit",
        "stack-bound",
        "demo",
        "completions",
    ] {
        assert!(cmds.iter().any(|c| c == expected), "`{expected}` missing from {cmds:?}");
    }
    for c in &cmds {
        let o = aerosid(&[c, "--help"]);
        assert!(o.status.success(), "aerosid {c} --help: {}", stderr(&o));
        assert!(
            stdout(&o).contains(&format!("Usage: aerosid {c}")),
            "aerosid {c} --help:\n{}",
            stdout(&o)
        );
    }
}

#[test]
fn no_command_prints_the_help_and_succeeds() {
    let o = aerosid(&[]);
    assert!(o.status.success());
    assert!(stdout(&o).contains("Commands:"), "{}", stdout(&o));
}

#[test]
fn version_is_the_crate_version() {
    let version = env!("CARGO_PKG_VERSION");
    let o = aerosid(&["--version"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), format!("aerosid {version}"));
    // A command's own `--version` names the command (clap's form).
    let o = aerosid(&["gaps", "--version"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), format!("aerosid-gaps {version}"));
}

#[test]
fn stack_bound_usage_and_description_name_the_same_arguments() {
    let help = stdout(&aerosid(&["stack-bound", "--help"]));
    assert!(
        help.contains("Usage: aerosid stack-bound [OPTIONS] <ELF> <CONFIG>"),
        "{help}"
    );
    assert!(!help.contains("INDIRECT"), "{help}");
}

/// A refused invocation: exit code 2 (a usage error), the message names `needle`, nothing runs.
fn refused(args: &[&str], needle: &str) {
    let o = aerosid(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stdout(&o));
    assert!(
        stderr(&o).contains(needle),
        "{args:?}: `{needle}` not in:\n{}",
        stderr(&o)
    );
    assert!(stdout(&o).is_empty(), "{args:?} ran: {}", stdout(&o));
}

#[test]
fn values_out_of_range_or_missing_are_refused_with_the_argument_named() {
    refused(&["run", "--seconds", "10"], "--seconds");
    refused(&["run", "--seconds", "10"], "30–3600");
    refused(&["run", "--seconds", "NaN"], "--seconds");
    refused(&["run", "--seconds", "ten"], "not a number");
    refused(&["simulate", "--seconds", "60"], "--out");
    refused(&["gaps", "--seconds", "5", "--clean"], "20–3600");
    refused(&["long-run", "--hours", "0"], "--hours");
    refused(&["long-run", "--hours", "0.05"], "0.2–100");
    refused(&["gaps"], "--data");
    refused(&["gaps", "--data", "f.asc"], "--with");
    refused(&["gaps", "--clean", "--simulate", "alpha-dot"], "cannot be used with");
    refused(&["gaps", "--simulate", "no-such-kind"], "lift-quadratic");
    refused(&["gaps", "--clean", "--size", "1"], "--simulate");
    refused(&["gaps", "--simulate", "alpha-dot", "--size", "NaN"], "finite");
    refused(&["gaps", "--simulate", "time-delay", "--size", "-0.5"], "0 to 1 s");
    refused(&["gaps", "--simulate", "elevator-delay", "--size", "2"], "0 to 1 s");
    refused(&["gaps", "--simulate", "vane-scale", "--size", "-1"], "−0.99 to 10");
    refused(
        &["gaps", "--simulate", "missing-roll-control", "--size", "1"],
        "has none",
    );
    refused(
        &["gaps", "--simulate", "alpha-dot", "--channel", "alpha"],
        "sensor-bias",
    );
    refused(&["gaps", "--simulate", "sensor-bias", "--channel", "beta"], "accel-z");
    refused(&["gaps", "--clean", "--air-data", "vanes"], "reconstructed");
    refused(&["gaps", "--clean", "--compatibility", "maybe"], "off");
    refused(&["gaps", "--clean", "--baseline", "CQ=1"], "--baseline");
    refused(&["gaps", "--clean", "--alpha", "0"], "[1e-12, 1]");
    refused(&["gaps", "--clean", "--alpha", "1.5"], "--alpha");
    refused(&["gaps", "--clean", "--alpha", "x"], "not a number");
    refused(&["gaps", "--clean", "--gain-alpha", "0.5"], "[1e-12, 0.5)");
    // (a refusal that regressed would run an empty campaign, not the whole one)
    let empty = [
        "gaps-bench",
        "--draws",
        "0",
        "--clean",
        "0",
        "--out",
        "/nonexistent/aerosid",
    ];
    refused(&[&empty[..], &["--alpha", "NaN"]].concat(), "[1e-12, 1]");
    refused(&[&empty[..], &["--gain-alpha", "-0.1"]].concat(), "--gain-alpha");
    refused(&["stack-bound", "fw.elf"], "<CONFIG>");
    refused(&["replay"], "<LOG.csv>");
    refused(&["no-such-command"], "no-such-command");
}

#[test]
fn completion_scripts_name_every_command() {
    let cmds = commands();
    for shell in ["bash", "zsh", "fish"] {
        let o = aerosid(&["completions", shell]);
        assert!(o.status.success(), "{shell}: {}", stderr(&o));
        let script = stdout(&o);
        for c in &cmds {
            assert!(script.contains(c.as_str()), "{shell} completion lacks `{c}`");
        }
    }
    refused(&["completions", "tcsh"], "bash");
}

/// The report.json of a 30 s clean simulated flight analysed with `levels` added to the command.
fn clean_report(tag: &str, levels: &[&str]) -> serde_json::Value {
    let out = std::env::temp_dir().join(format!("aerosid-cli-{tag}-{}", std::process::id()));
    let mut args = vec!["gaps", "--clean", "--seconds", "30"];
    args.extend_from_slice(levels);
    args.extend_from_slice(&["--out", out.to_str().expect("a UTF-8 temporary path")]);
    let o = aerosid(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json written");
    let _ = std::fs::remove_dir_all(&out);
    serde_json::from_str(&text).expect("report.json is JSON")
}

#[test]
fn the_test_levels_reach_the_report() {
    // GIVEN a clean simulated flight analysed at other levels than the defaults (0.01, 0.01)
    let report = clean_report("levels", &["--alpha", "0.05", "--gain-alpha", "0.2"]);
    let default = clean_report("levels-d", &[]);
    // THEN the report's criterion carries them, and the entry threshold is the one of α = 0.05:
    // below the default's (Bonferroni over the same candidates, a larger level)
    assert_eq!(report["criterion"]["alpha"], 0.05);
    assert_eq!(report["criterion"]["gain_alpha"], 0.2);
    assert_eq!(
        report["criterion"]["candidates_tested"],
        default["criterion"]["candidates_tested"]
    );
    let t2 = |r: &serde_json::Value| r["criterion"]["threshold_t2"].as_f64().expect("a threshold");
    assert!(t2(&report) < t2(&default), "{} ≥ {}", t2(&report), t2(&default));
}

#[test]
fn card_writes_a_card_and_refuses_effects_on_a_vane() {
    // GIVEN a card with a planted α̇ in C_m
    let out = std::env::temp_dir().join(format!("aerosid-cli-card-{}", std::process::id()));
    let dir = out.to_str().expect("a UTF-8 temporary path");
    let o = aerosid(&[
        "card",
        "--out",
        dir,
        "--seed",
        "2",
        "--effect",
        "alpha-dot",
        "--turbulence",
        "moderate",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // THEN eight records, the aircraft file and the truth, which names the planted kind
    let csv = std::fs::read_dir(&out)
        .expect("the card's folder")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "csv"))
        })
        .count();
    assert_eq!(csv, 8);
    assert!(out.join("skywalker_2013_mod.aircraft").is_file());
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).expect("truth.json")).expect("JSON");
    assert_eq!(truth["planted"]["kind"], "alpha-dot");
    assert_eq!(truth["turbulence"]["level"], "moderate");
    let _ = std::fs::remove_dir_all(&out);
    // AND an effect on the α vane is refused with the reason, nothing written
    let o = aerosid(&["card", "--out", dir, "--effect", "vane-scale"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("has none"), "{}", stderr(&o));
    assert!(!out.exists());
    refused(&["card", "--out", dir, "--turbulence", "severe"], "--turbulence");
}

/// The shortest long run the command accepts keeps every invariant (a shorter time line would put
/// the first jump before anything is estimated; `LONG_RUN_HOURS` in the binary says why).
#[test]
fn the_shortest_accepted_long_run_keeps_its_invariants() {
    let o = aerosid(&["long-run", "--hours", "0.2"]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("invariants: all kept"), "{}", stdout(&o));
}
