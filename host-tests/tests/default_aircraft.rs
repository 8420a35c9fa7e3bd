//! The aircraft file of the default airframe (`tool/data/aircraft/skywalker_2013_mod.aircraft`)
//! is the simulator's airframe exactly, so a simulated log analysed with it (`aerosid gaps --data
//! LOG.csv --with …`) runs with the constants it was simulated with.

use aerosid::io::aircraft::read_aircraft;
use aerosid::io::measured::Aircraft;
use aerosid_sim::SimAirframe;
use std::path::{Path, PathBuf};

fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data/aircraft/skywalker_2013_mod.aircraft")
}

/// What the simulator flies: the airframe of `SimAirframe::skywalker_2013_mod` with the sensors at
/// the CG (`Aircraft::from_airframe`, as the model-gap analysis of a simulated flight takes it).
fn simulated() -> Aircraft {
    let sim = SimAirframe::skywalker_2013_mod();
    Aircraft::from_airframe(&sim.name, &sim.frame)
}

#[test]
fn the_default_airframe_file_reads_as_the_simulator_constants_exactly() {
    // Exact equality: the file writes each constant as the shortest decimal that reads back as the
    // simulator's f64, so any edit on either side shows here.
    let file = read_aircraft(&shipped()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(file, simulated());
}

#[test]
fn a_simulated_log_reads_with_the_default_airframe_file() {
    let dir = std::env::temp_dir().join(format!("aerosid-default-aircraft-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let log = dir.join("flight.csv");
    let n = aerosid::replay::simulate_to_csv(&log, 5.0, 3).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(n, 500, "5 s at 100 Hz");
    let flight = aerosid::io::read_measured(&log, &shipped()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(flight.aircraft, simulated());
    assert_eq!(flight.len(), n);
    let _ = std::fs::remove_dir_all(&dir);
}
