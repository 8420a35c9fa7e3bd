//! The firmware under QEMU: a simulated flight log replayed through the same sampling →
//! synthesis → estimator → telemetry path as on the flight computer; the estimates it sends equal
//! the host's `f32` run bit for bit, and its per-sample instruction count stays within budget.
//!
//! Needs `qemu-system-arm` (`apt-get install -y qemu-system-arm`) and the thumb target; the defmt
//! log is decoded when `defmt-print` is installed (`.ci/run` installs all three).

use aerosid_core::aero::SensorSample;
use aerosid_qemu as qemu;
use aerosid_sim::{self as sim, flights};
use std::time::Duration;

/// Instructions per sample for the whole six-coefficient step (synthesis + six PCA-GTLS updates
/// with VFF): regression budgets, about 5 % above what was measured (median 24 270, max 41 584 on
/// this 30 s replay). The max budget is shared with the fault run (measured there 43 497). The
/// goal, median 17 000 and max 25 000, is NOT met: see docs/benchmarks.md for the profile and the
/// operation count.
const STEP_BUDGET_MEDIAN: u32 = 25_500;
/// See [`STEP_BUDGET_MEDIAN`] (shared with the fault run).
const STEP_BUDGET_MAX: u32 = qemu::STEP_BUDGET_MAX;
/// Instructions the whole firmware executes per sample (`qemu::PERIOD_PROBE`: the step, the
/// sample queue, the sampling task with the replay's reads, the count file, interrupts), median
/// and maximum: regression budgets ≈ 5 % above the measured 28 339 / 45 613. Not asserted on the
/// fault run, whose drops and bus retries put several sampling-task runs into one period.
const FIRMWARE_BUDGET_MEDIAN: u32 = 29_700;
/// See [`FIRMWARE_BUDGET_MEDIAN`].
const FIRMWARE_BUDGET_MAX: u32 = 47_900;
/// Instructions the telemetry task holds the estimator lock to encode one report part (one
/// coefficient report with eq. 17's covariance, the health report or the counters): regression
/// budget, ≈ 4 % above the measured 15 424 (the longest part of a period; the firmware's last two
/// report periods make the second's `lock_max` cover every part of the first). With the
/// longest step (≈ 41 700) that is ≈ 58 000 instructions, ≈ 1 ms at 168 MHz even at 3 cycles per
/// instruction, against the 40 ms a sample can wait in the firmware's queue of four.
const LOCK_BUDGET: u32 = 16_000;
/// Stack high-water mark, regression budget (shared with the fault run; measured figures there).
const STACK_BUDGET_BYTES: u32 = qemu::STACK_BUDGET_BYTES;

fn flight_samples(seconds: f64, seed: u64) -> Vec<SensorSample<f32>> {
    let out = sim::simulate(&flights::main_flight(seconds, seed)).expect("simulation");
    out.samples.iter().map(|s| s.cast::<f32>()).collect()
}

#[test]
fn qemu_replay_equals_host_f32_and_meets_the_instruction_budget() {
    // GIVEN a 30 s simulated flight (every hidden effect, light turbulence, sensors with biases)
    let samples = flight_samples(30.0, 7);
    // WHEN the firmware (QEMU board) replays it and the host runs the same f32 pipeline on it
    let elf = qemu::build_firmware().expect("firmware build");
    let dir = qemu::workspace_root().join("target").join("qemu-replay");
    let run = qemu::run(&elf, &samples, &dir, Duration::from_secs(600)).expect("QEMU run");
    let host = qemu::host_reports(&samples).expect("host run");
    println!("{}", run.log);

    // THEN QEMU exits 0 after processing every sample …
    assert_eq!(run.exit_code, Some(0), "QEMU exit status");
    assert_eq!(run.counts.len(), samples.len(), "samples processed");
    println!("telemetry: {} frames, {} rejected", run.frames.0, run.frames.1);
    assert_eq!(run.frames.1, 0, "telemetry frames rejected by the parser");
    // … the last report of every coefficient equals the host's f32 run bit for bit (θ, σ, k, λ_F)
    for (i, (fw, h)) in run.reports.iter().zip(host.iter()).enumerate() {
        let fw = fw.expect("a report for every coefficient");
        let n = usize::from(h.n_params);
        println!("coefficient {i}: k {} θ {:?}", fw.rank_k, &fw.theta[..n]);
        assert_eq!(fw.n_params, h.n_params);
        assert_eq!(fw.rank_k, h.rank_k, "coefficient {i}: k");
        assert_eq!(fw.lambda_f.to_bits(), h.lambda_f.to_bits(), "coefficient {i}: λ_F");
        for j in 0..n {
            assert_eq!(
                fw.theta[j].to_bits(),
                h.theta[j].to_bits(),
                "coefficient {i}: θ{j} {} vs {}",
                fw.theta[j],
                h.theta[j]
            );
            assert!(
                fw.sigma[j].to_bits() == h.sigma[j].to_bits() || (fw.sigma[j].is_nan() && h.sigma[j].is_nan()),
                "coefficient {i}: σ{j} {} vs {}",
                fw.sigma[j],
                h.sigma[j]
            );
        }
    }
    // … and the instruction counts per sample are within budget
    for (p, name) in qemu::PROBE_NAMES.iter().enumerate() {
        if let Some((lo, med, hi)) = qemu::stats(&run.counts, p) {
            println!("instructions {name:>9}: min {lo:6} median {med:6} max {hi:6}");
        }
    }
    let (_, median, max) = qemu::stats(&run.counts, 0).expect("counts");
    let (_, fw_median, fw_max) = qemu::stats(&run.counts, qemu::PERIOD_PROBE).expect("firmware counts");
    assert!(
        fw_median <= FIRMWARE_BUDGET_MEDIAN && fw_max <= FIRMWARE_BUDGET_MAX,
        "firmware per sample: median {fw_median} (budget {FIRMWARE_BUDGET_MEDIAN}), max {fw_max} (budget {FIRMWARE_BUDGET_MAX})"
    );
    assert!(
        fw_median > median,
        "the period ({fw_median}) must include the step ({median})"
    );
    // … the telemetry's own counters agree: `step_max` is the longest step in the count file …
    println!("telemetry counters: {:?}", run.counters);
    let counter = |name: &str| *run.counters.get(name).unwrap_or_else(|| panic!("no `{name}` counter"));
    let longest = run.counts.iter().map(|c| c[0]).max().expect("counts");
    assert_eq!(counter("step_max"), longest as f32, "step_max vs the count file");
    assert_eq!(counter("samples"), samples.len() as f32, "samples counter");
    // … and the telemetry encoding holds the estimator lock for a bounded time (the estimate task's
    // longest wait for it, on top of its own step, against the sample queue's slack).
    let lock = counter("lock_max");
    println!("longest estimator-lock hold by telemetry: {lock} instructions");
    assert!(lock > 0.0, "lock_max not measured");
    assert!(
        lock <= LOCK_BUDGET as f32,
        "lock_max {lock} > {LOCK_BUDGET} instructions"
    );
    assert!(
        median <= STEP_BUDGET_MEDIAN,
        "median step {median} > {STEP_BUDGET_MEDIAN} instructions"
    );
    assert!(
        max <= STEP_BUDGET_MAX,
        "max step {max} > {STEP_BUDGET_MAX} instructions"
    );
    // … and the stack stays within budget (read from the defmt log when defmt-print is installed)
    match stack_high_water(&run.log) {
        Some(bytes) => {
            println!("stack high water: {bytes} B");
            assert!(bytes <= STACK_BUDGET_BYTES, "stack {bytes} B > {STACK_BUDGET_BYTES} B");
            // … and the static bound of the same image (`aerosid stack-bound`, the analysis CI
            // applies to the flight computer, which cannot be run here) is not below it.
            let config = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/stack-bound.txt");
            let bound =
                aerosid_elf_check::stack_bound::analyse_elf(&elf, &config).expect("stack bound of the QEMU image");
            println!("{}", bound.report());
            assert!(
                u64::from(bytes) <= bound.total,
                "painted stack {bytes} B above the static bound {} B: the analysis is unsound",
                bound.total
            );
        }
        None if std::env::var_os("CI").is_some() || qemu::defmt_print_installed() => {
            panic!("no stack figure in the defmt log (defmt-print missing?)")
        }
        None => println!("defmt-print not installed: stack high water not read"),
    }
}

/// GIVEN the firmware image (QEMU board; the flight computer's `init` declares the same static),
/// THEN the pipeline's static lies in `.bss`: `Pipeline::PLACEHOLDER` is all zero bytes, so it
/// needs no initial image in flash (≈ 5 KB; a placeholder with a non-zero byte, such as an
/// identity matrix or an enum variant stored in a niche, puts the whole static in `.data`).
#[test]
fn pipeline_static_has_no_flash_image() {
    let elf = qemu::build_firmware().expect("firmware build");
    let tool = aerosid_elf_check::panic_audit::objdump();
    let out = std::process::Command::new(&tool)
        .arg("-t")
        .arg(&elf)
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", tool.display()));
    assert!(out.status.success(), "{} -t failed", tool.display());
    let table = String::from_utf8_lossy(&out.stdout);
    let line = table
        .lines()
        .find(|l| l.contains("__rtic_internal_local_init_pipeline"))
        .expect("the pipeline static in the symbol table");
    println!("{line}");
    // `20000204 l     O .bss	00001400 <name>`: address, flags, section, size, name.
    let section = line
        .split_whitespace()
        .find(|w| w.starts_with('.'))
        .expect("a section column");
    assert_eq!(section, ".bss", "the pipeline static is not zero-initialised: {line}");
}

/// `stack high water N B` from the decoded defmt log.
fn stack_high_water(log: &str) -> Option<u32> {
    let at = log.find("stack high water ")? + "stack high water ".len();
    log[at..].split_whitespace().next()?.parse().ok()
}

#[test]
#[ignore = "profiling helper: writes target/qemu-prof/replay.bin (samples 1000.. of the replay flight)"]
fn write_profile_replay() {
    // `AEROSID_PROFILE_SAMPLES` samples from sample 1000 on (default 60; at most 2 000, the rest of
    // the 30 s flight); `scripts/qemu-profile.py --classes` divides by the same variable.
    let count = match std::env::var("AEROSID_PROFILE_SAMPLES") {
        Ok(v) => v.parse::<usize>().expect("AEROSID_PROFILE_SAMPLES: a whole number"),
        Err(_) => 60,
    };
    let samples = flight_samples(30.0, 7);
    assert!(
        (1..=samples.len() - 1000).contains(&count),
        "AEROSID_PROFILE_SAMPLES: 1 to {}",
        samples.len() - 1000
    );
    let dir = qemu::workspace_root().join("target").join("qemu-prof");
    std::fs::create_dir_all(&dir).unwrap();
    qemu::write_replay(&dir.join("replay.bin"), &samples[1000..1000 + count]).unwrap();
}

#[test]
fn replay_of_a_csv_log_matches_the_samples_it_was_written_from() {
    // GIVEN a simulated flight written as a CSV log (the project's layout)
    let dir = qemu::workspace_root().join("target").join("replay-csv");
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("flight.csv");
    let n = aerosid::replay::simulate_to_csv(&path, 10.0, 3).expect("simulate");
    // WHEN it is replayed on the host
    let report = aerosid::replay::replay(&path, false).expect("replay");
    // THEN every sample went through the pipeline and every coefficient is reported
    assert!(
        report.contains(&format!("{n} samples through the on-board f32 pipeline")),
        "{report}"
    );
    for name in ["C_L0", "C_Dα²", "C_Yβ", "C_lp", "C_mq", "C_nδr"] {
        assert!(report.contains(name), "{name} missing:\n{report}");
    }
    // … and a missing file is an error that names it
    let err = aerosid::replay::replay(&dir.join("missing.csv"), false).expect_err("missing file");
    assert!(err.contains("missing.csv"), "{err}");
}
