//! Fuzz targets of the log readers (`aerosid-read`), through their public API only.
//!
//! | target | input | invariants of an `Ok` |
//! |---|---|---|
//! | `read_log` | a file in the project's CSV flight-log layout ([`log::read_log`]) | every field of every sample finite, `t_s` strictly increasing |
//! | `read_project_csv` | a project CSV, all or some columns ([`project_csv::parse_project_csv`]) with the `skywalker_2013_mod` aircraft | [`MeasuredFlight::validate`] passes (finite channels of the time base's length, increasing time) |
//! | `read_aircraft` | an aircraft file ([`aircraft::parse_aircraft`]) | the required constants finite and positive, the optional ones finite or NaN (`unknown`), never ±∞, inertia definite where known |
//! | `read_colmap_ascii` | a column map, a line `%%`, then a whitespace ASCII file ([`colmap::parse_map`] with the aircraft files of `tool/data` beside it, then [`colmap::parse_ascii`]) | the flight validates and its aircraft is as above |
//! | `read_ulog` | a PX4 ULog ([`ulog::parse_ulog`]) with the default topic map | the flight validates, its time base uniform |
//! | `read_dataflash` | an ArduPilot DataFlash log ([`dataflash::parse_dataflash`]) with the placeholder aircraft | the flight validates, its time base uniform |
//! | `read_mat` | a MATLAB level-5 `.mat` ([`mat::parse_mat`]) through the shipped Twin Otter map | the flight validates, its time base uniform |
//!
//! Any panic (index out of range, slicing inside a UTF-8 character, overflow) is a failure, and so
//! is an abort: an allocation sized from a corrupt field that fails aborts the process, which
//! libFuzzer reports as a crash (and one that succeeds but exceeds `-rss_limit_mb` as well).

use aerosid_read::measured::{Aircraft, MeasuredFlight};
use aerosid_read::{aircraft, colmap, dataflash, log, mat, project_csv, ulog};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn check_flight(what: &str, f: &MeasuredFlight) {
    if let Err(e) = f.validate() {
        panic!("{what}: reader returned a flight that does not validate: {e:?}");
    }
    check_aircraft(what, &f.aircraft);
}

fn check_aircraft(what: &str, a: &Aircraft) {
    let required = [
        ("mass", a.mass_kg),
        ("jy", a.inertia_kgm2[(1, 1)]),
        ("wing_area", a.wing_area_m2),
        ("chord", a.chord_m),
    ];
    for (k, v) in required {
        assert!(v.is_finite() && v > 0.0, "{what}: aircraft `{k}` = {v}");
    }
    let optional = [
        ("jx", a.inertia_kgm2[(0, 0)]),
        ("jz", a.inertia_kgm2[(2, 2)]),
        ("jxz", a.inertia_kgm2[(0, 2)]),
        ("span", a.span_m),
    ];
    for (k, v) in optional {
        assert!(!v.is_infinite(), "{what}: aircraft `{k}` = {v}");
    }
    for p in [a.accel_position_m, a.alpha_vane_position_m, a.beta_vane_position_m] {
        assert!(p.iter().all(|v| v.is_finite()), "{what}: sensor position {p:?}");
    }
    let (jx, jz, jxz) = (a.inertia_kgm2[(0, 0)], a.inertia_kgm2[(2, 2)], a.inertia_kgm2[(0, 2)]);
    if jx.is_finite() && jz.is_finite() && jxz.is_finite() {
        assert!(
            jx * jz - jxz * jxz > 0.0,
            "{what}: inertia not definite {:?}",
            a.inertia_kgm2
        );
    }
}

/// Fuzz target `read_log`.
pub fn read_log(data: &[u8]) {
    if let Ok(samples) = log::read_log(data, "fuzz.csv") {
        let mut prev = f64::NEG_INFINITY;
        for (i, s) in samples.iter().enumerate() {
            assert!(
                s.to_fields().iter().all(|v| v.is_finite()),
                "sample {i} not finite: {s:?}"
            );
            assert!(s.t_s > prev, "sample {i}: time {} after {prev}", s.t_s);
            prev = s.t_s;
        }
    }
}

fn skywalker() -> Aircraft {
    Aircraft::from_airframe(
        "skywalker_2013_mod",
        &aerosid_core::aero::Airframe::skywalker_2013_mod(),
    )
}

/// Fuzz target `read_project_csv`.
pub fn read_project_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(f) = project_csv::parse_project_csv(text, "fuzz.csv", skywalker()) {
        check_flight("read_project_csv", &f);
    }
}

/// Fuzz target `read_aircraft`.
pub fn read_aircraft(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(a) = aircraft::parse_aircraft(text, "fuzz.aircraft") {
        check_aircraft("read_aircraft", &a);
    }
}

/// The separator line between the map and the data of a `read_colmap_ascii` input.
pub const MAP_DATA_SEPARATOR: &str = "\n%%\n";

/// A folder `maps/` beside `aircraft/` holding the shipped aircraft files, so the shipped maps'
/// `aircraft = ../aircraft/NAME.aircraft` resolve (made once per process).
pub fn map_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = std::env::temp_dir().join(format!("aerosid-fuzz-maps-{}", std::process::id()));
        let files = [
            (
                "attas.aircraft",
                include_str!("../../tool/data/aircraft/attas.aircraft"),
            ),
            (
                "hfb320.aircraft",
                include_str!("../../tool/data/aircraft/hfb320.aircraft"),
            ),
            (
                "twin_otter.aircraft",
                include_str!("../../tool/data/aircraft/twin_otter.aircraft"),
            ),
        ];
        let aircraft = root.join("aircraft");
        let ok = std::fs::create_dir_all(&aircraft).is_ok()
            && std::fs::create_dir_all(root.join("maps")).is_ok()
            && files.iter().all(|(n, t)| std::fs::write(aircraft.join(n), t).is_ok());
        assert!(ok, "cannot write the aircraft files under {}", root.display());
        root.join("maps")
    })
}

/// Fuzz target `read_colmap_ascii`.
pub fn read_colmap_ascii(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let (map_text, ascii) = text.split_once(MAP_DATA_SEPARATOR).unwrap_or((text, ""));
    let Ok(map) = colmap::parse_map(map_text, "fuzz.map", map_dir()) else {
        return;
    };
    check_aircraft("read_colmap_ascii (map)", &map.aircraft);
    if let Ok(f) = colmap::parse_ascii(ascii, "fuzz.asc", &map) {
        check_flight("read_colmap_ascii", &f);
    }
}

/// A resampled log's flight: it validates and its time base is uniform (the grid is built in
/// integer microseconds, so a step differs from the first by rounding only, 1e-9 relative).
fn check_resampled(what: &str, f: &MeasuredFlight) {
    check_flight(what, f);
    if let [t0, t1, ..] = f.t_s[..] {
        let h = t1 - t0;
        assert!(
            f.t_s.windows(2).all(|w| ((w[1] - w[0]) - h).abs() <= 1e-9 * h.max(1.0)),
            "{what}: time base not uniform"
        );
    }
}

/// Fuzz target `read_ulog`.
pub fn read_ulog(data: &[u8]) {
    static MAP: OnceLock<colmap::ColumnMap> = OnceLock::new();
    let map = MAP.get_or_init(|| colmap::ColumnMap::ulog_default(skywalker()));
    if let Ok(f) = ulog::parse_ulog(data, "fuzz.ulg", map) {
        check_resampled("read_ulog", &f);
    }
}

/// Fuzz target `read_dataflash`.
pub fn read_dataflash(data: &[u8]) {
    let opts = aerosid_read::ReadOptions::default();
    if let Ok(f) = dataflash::parse_dataflash(data, "fuzz.bin", aerosid_read::placeholder_aircraft(), &opts) {
        check_resampled("read_dataflash", &f);
    }
}

/// Fuzz target `read_mat`.
pub fn read_mat(data: &[u8]) {
    static MAP: OnceLock<colmap::ColumnMap> = OnceLock::new();
    let map = MAP.get_or_init(|| {
        colmap::parse_map(
            include_str!("../../tool/data/maps/twin_otter.map"),
            "twin_otter.map",
            map_dir(),
        )
        .unwrap_or_else(|e| panic!("the shipped Twin Otter map: {e}"))
    });
    if let Ok(f) = mat::parse_mat(data, "fuzz.mat", map) {
        check_flight("read_mat", &f);
    }
}

/// The module functions under the names of their targets (`aerosid_fuzz::read_log::run`, …).
macro_rules! target_module {
    ($name:ident) => {
        /// Fuzz target entry point.
        pub mod $name {
            /// The fuzz entry point.
            pub fn run(data: &[u8]) {
                super::$name(data)
            }
        }
    };
}
target_module!(read_log);
target_module!(read_project_csv);
target_module!(read_aircraft);
target_module!(read_colmap_ascii);
target_module!(read_ulog);
target_module!(read_dataflash);
target_module!(read_mat);
