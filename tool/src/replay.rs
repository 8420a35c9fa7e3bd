//! Replaying a flight log (the project's CSV layout) through the on-board pipeline: on the host in
//! `f32` exactly as the firmware computes (its sensor layer's stuck-sensor check, then the
//! pipeline: [`qemu::emulate`]), and optionally through the firmware itself under QEMU
//! ([`aerosid_qemu`]), with the two compared bit for bit. `aerosid simulate` writes such a log from
//! the simulator; `aerosid replay LOG.csv [--qemu]` runs this.

use crate::io::log::{read_log_file, write_log_file};
use crate::report::parameter_name;
use aerosid_core::aero::model::idx;
use aerosid_core::aero::SensorSample;
use aerosid_core::mavlink::CoefficientReport;
use aerosid_qemu as qemu;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

/// Writes the main job's flight ([`crate::flights::main_flight`]) of `seconds` as a CSV log.
pub fn simulate_to_csv(path: &Path, seconds: f64, seed: u64) -> Result<usize, String> {
    let out = crate::sim::simulate(&crate::flights::main_flight(seconds, seed)).map_err(|e| format!("{e:?}"))?;
    write_log_file(path, &out.samples).map_err(|e| e.to_string())?;
    Ok(out.samples.len())
}

/// The six reports as a table (θ ± σ, k, λ_F, refused).
pub fn report_table(reports: &[CoefficientReport; idx::COUNT], out: &mut String) {
    let regs = crate::experiment::regressor_lists(&aerosid_core::aero::AeroModels::<f32>::with_sigma_eps(
        [1.0; idx::COUNT],
    ));
    let _ = writeln!(
        out,
        "{:<9} {:>22} {:>6} {:>8} {:>8}",
        "param", "θ ± σ (eq. 17)", "k", "λ_F", "refused"
    );
    for (i, r) in reports.iter().enumerate() {
        for (j, reg) in regs[i].iter().enumerate() {
            let (k, lam, refused) = if j == 0 {
                (
                    format!("{}/{}", r.rank_k, r.n_params.saturating_sub(1)),
                    format!("{:.4}", r.lambda_f),
                    r.refused.to_string(),
                )
            } else {
                (String::new(), String::new(), String::new())
            };
            let sigma = if r.sigma[j].is_nan() {
                "   (n/a)".to_string()
            } else {
                format!("{:8.4}", r.sigma[j])
            };
            let _ = writeln!(
                out,
                "{:<9} {:>+12.4} ± {sigma} {k:>6} {lam:>8} {refused:>8}",
                parameter_name(i, *reg),
                r.theta[j]
            );
        }
    }
}

/// Replays `log` (CSV) through the on-board `f32` pipeline on the host, and with `with_qemu` also
/// through the firmware under QEMU; returns the printed report. With QEMU an inequality of any
/// θ, σ, k or λ_F bit is an error.
pub fn replay(log: &Path, with_qemu: bool) -> Result<String, String> {
    let samples: Vec<SensorSample<f32>> = read_log_file(log)
        .map_err(|e| e.to_string())?
        .iter()
        .map(|s| s.cast::<f32>())
        .collect();
    let emu = qemu::emulate(&qemu::Scenario::clean(&samples)).map_err(|e| e.to_string())?;
    let host = emu.reports;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {} samples through the on-board f32 pipeline (aero::onboard: skywalker_2013_mod, VFF)\n",
        log.display(),
        samples.len()
    );
    report_table(&host, &mut out);
    let h = &emu.pipeline_health;
    let _ = writeln!(
        out,
        "\nhealth: {} samples; invalid channels per bit {:?}; axial-speed fallbacks {}",
        h.samples, h.invalid_channel, h.axial_speed_fallbacks
    );
    if !with_qemu {
        return Ok(out);
    }
    let elf = qemu::build_firmware().map_err(|e| e.to_string())?;
    let dir = qemu::workspace_root().join("target").join("qemu-replay");
    let run = qemu::run(&elf, &samples, &dir, Duration::from_secs(3600)).map_err(|e| e.to_string())?;
    let _ = writeln!(
        out,
        "\nfirmware under QEMU (netduinoplus2, -icount shift=0): exit {:?}, {} samples, {} MAVLink frames ({} rejected)",
        run.exit_code,
        run.counts.len(),
        run.frames.0,
        run.frames.1
    );
    let mut equal = true;
    for (i, (fw, h)) in run.reports.iter().zip(host.iter()).enumerate() {
        let Some(fw) = fw else {
            equal = false;
            let _ = writeln!(out, "  coefficient {i}: no report received");
            continue;
        };
        let same = fw.same_estimate_bits(h);
        equal &= same;
    }
    let _ = writeln!(
        out,
        "  telemetry vs host f32: {}",
        if equal { "identical, bit for bit" } else { "DIFFERENT" }
    );
    let names = ["step", "synthesis", "C_L", "C_D", "C_Y", "C_l", "C_m", "C_n"];
    for (probe, name) in names.iter().enumerate() {
        if let Some((lo, med, hi)) = qemu::stats(&run.counts, probe) {
            let _ = writeln!(out, "  instructions {name:>9}: min {lo:6} median {med:6} max {hi:6}");
        }
    }
    if let Some(line) = run.log.lines().find(|l| l.contains("stack high water")) {
        let _ = writeln!(out, "  {}", line.trim());
    }
    if equal && run.exit_code == Some(0) {
        Ok(out)
    } else {
        Err(out + "\nthe firmware's estimates differ from the host's (or QEMU failed)")
    }
}
