//! The aircraft file: the constants a measured flight needs (mass, inertia, geometry, sensor
//! positions, how thrust is known) as plain `key = value` text → [`Aircraft`].
//!
//! Format (the full key list is in `docs/measured-data.md`): one `key = value` per line, `#` starts
//! a comment, blank lines are ignored, each key at most once. The unit is the key's suffix; every
//! numeric key accepts its SI unit and, for data published in US units, the listed alternatives,
//! converted exactly on reading (1 ft = 0.3048 m, 1 in = 0.0254 m, 1 slug = 14.593 902 937 kg,
//! 1 slug·ft² = 1.355 817 948 kg·m², 1 lb = 0.453 592 37 kg):
//!
//! | key | units | required |
//! |---|---|---|
//! | `name` | text | yes |
//! | `mass` | `_kg`, `_slug`, `_lb` | yes |
//! | `jx`, `jy`, `jz`, `jxz` (positive `Jxz`, stored `−Jxz` off the diagonal) | `_kgm2`, `_slugft2` | `jy`; `jx`, `jz` yes but may be `unknown`; `jxz` default 0 |
//! | `wing_area` | `_m2`, `_ft2` | yes |
//! | `span`, `chord` | `_m`, `_ft` | `chord`; `span` yes but may be `unknown` |
//! | `accel_x`, `accel_y`, `accel_z`, `alpha_vane_…`, `beta_vane_…`, `airspeed_…` (pitot) (relative to the CG, body FRD) | `_m`, `_ft`, `_in` | no, default 0 |
//! | `moment_reference_x`, `…_y`, `…_z` (the point the moment coefficients refer to, relative to the CG) | `_m`, `_ft`, `_in` | no, default 0 (the CG) |
//! | `thrust` | `measured`, `measured_twin`, `propeller`, `unknown` | no, default `unknown` |
//! | `thrust_x`, `thrust_y`, `thrust_z` (thrust point; the right engine for `measured_twin`) | `_m`, `_ft`, `_in` | no, default 0 |
//! | `thrust_pitch` (positive nose up) | `_rad`, `_deg` | no, default 0 |
//! | `prop_diameter` | `_m`, `_in` | with `thrust = propeller` |
//! | `prop_ct0…2`, `prop_cp0…2` | – | no, default 0 |
//!
//! `unknown` (stored as NaN) is accepted only for `jx`, `jz`, `jxz` and `span`, which a
//! longitudinal-only test (the HFB-320) does not give; the analysis must not use them then.
//!
//! Every error names the file, the line and the column (1-based); a missing required key names the
//! file and the key. Nothing panics.

use super::measured::{Aircraft, ThrustSource};
use super::{key_values, read_text, KeyValue, ReadError};
use aerosid_core::aero::Propeller;
use nalgebra::{Matrix3, Vector3};
use std::path::Path;

/// Metres per foot (exact).
pub const M_PER_FT: f64 = 0.3048;
/// Metres per inch (exact).
pub const M_PER_IN: f64 = 0.0254;
/// Kilograms per pound mass (exact).
pub const KG_PER_LB: f64 = 0.453_592_37;
/// Standard gravity, m/s² (exact).
pub const G0_MPS2: f64 = 9.806_65;
/// Kilograms per slug (`lbf·s²/ft` = 0.453 592 37 · 9.806 65 / 0.3048).
pub const KG_PER_SLUG: f64 = KG_PER_LB * G0_MPS2 / M_PER_FT;

const LENGTH: &[(&str, f64)] = &[("m", 1.0), ("ft", M_PER_FT), ("in", M_PER_IN)];
const INERTIA: &[(&str, f64)] = &[("kgm2", 1.0), ("slugft2", KG_PER_SLUG * M_PER_FT * M_PER_FT)];

/// The numeric keys: base name, accepted unit suffixes with their factor to SI, and whether
/// `unknown` is accepted.
/// A numeric key: base name, unit suffixes with their factor to SI, `unknown` accepted.
type NumericKey = (&'static str, &'static [(&'static str, f64)], bool);

const NUMERIC: &[NumericKey] = &[
    ("mass", &[("kg", 1.0), ("slug", KG_PER_SLUG), ("lb", KG_PER_LB)], false),
    ("jx", INERTIA, true),
    ("jy", INERTIA, false),
    ("jz", INERTIA, true),
    ("jxz", INERTIA, true),
    ("wing_area", &[("m2", 1.0), ("ft2", M_PER_FT * M_PER_FT)], false),
    ("span", &[("m", 1.0), ("ft", M_PER_FT)], true),
    ("chord", &[("m", 1.0), ("ft", M_PER_FT)], false),
    ("accel_x", LENGTH, false),
    ("accel_y", LENGTH, false),
    ("accel_z", LENGTH, false),
    ("alpha_vane_x", LENGTH, false),
    ("alpha_vane_y", LENGTH, false),
    ("alpha_vane_z", LENGTH, false),
    ("beta_vane_x", LENGTH, false),
    ("beta_vane_y", LENGTH, false),
    ("beta_vane_z", LENGTH, false),
    ("airspeed_x", LENGTH, false),
    ("airspeed_y", LENGTH, false),
    ("airspeed_z", LENGTH, false),
    ("moment_reference_x", LENGTH, false),
    ("moment_reference_y", LENGTH, false),
    ("moment_reference_z", LENGTH, false),
    ("thrust_x", LENGTH, false),
    ("thrust_y", LENGTH, false),
    ("thrust_z", LENGTH, false),
    (
        "thrust_pitch",
        &[("rad", 1.0), ("deg", std::f64::consts::PI / 180.0)],
        false,
    ),
    ("prop_diameter", &[("m", 1.0), ("in", M_PER_IN)], false),
    ("prop_ct0", &[], false),
    ("prop_ct1", &[], false),
    ("prop_ct2", &[], false),
    ("prop_cp0", &[], false),
    ("prop_cp1", &[], false),
    ("prop_cp2", &[], false),
];

/// Splits `key` into its [`NUMERIC`] entry and the unit factor.
fn numeric_key(key: &str) -> Option<(&'static str, f64, bool)> {
    for (base, units, unknown_ok) in NUMERIC {
        if units.is_empty() {
            if key == *base {
                return Some((base, 1.0, *unknown_ok));
            }
            continue;
        }
        if let Some(suffix) = key.strip_prefix(base).and_then(|r| r.strip_prefix('_')) {
            if let Some((_, f)) = units.iter().find(|(u, _)| *u == suffix) {
                return Some((base, *f, *unknown_ok));
            }
        }
    }
    None
}

/// The accepted spellings of a numeric key, for error messages.
fn spellings(base: &str) -> String {
    NUMERIC
        .iter()
        .find(|(b, _, _)| *b == base)
        .map(|(b, units, _)| {
            if units.is_empty() {
                b.to_string()
            } else {
                units
                    .iter()
                    .map(|(u, _)| format!("{b}_{u}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        })
        .unwrap_or_default()
}

/// A numeric key as read: base name, SI value, line and value column.
type Entry = (&'static str, f64, usize, usize);

/// The keys of an aircraft file as read, before the checks across keys.
struct Entries<'t> {
    name: Option<String>,
    /// The `thrust` value, its line and value column.
    thrust_kind: Option<(&'t str, usize, usize)>,
    values: Vec<Entry>,
}

impl Entries<'_> {
    fn get(&self, base: &str) -> Option<&Entry> {
        self.values.iter().find(|(b, _, _, _)| *b == base)
    }

    fn required(&self, base: &str, file: &str) -> Result<f64, ReadError> {
        self.get(base).map(|(_, v, _, _)| *v).ok_or_else(|| {
            ReadError::new(
                file,
                0,
                0,
                format!("missing required key `{base}` (one of {})", spellings(base)),
            )
        })
    }

    /// The value of an optional key, 0 when absent.
    fn optional(&self, base: &str) -> f64 {
        self.get(base).map_or(0.0, |(_, v, _, _)| *v)
    }

    /// The position `{p}_x`, `{p}_y`, `{p}_z` (each 0 when absent).
    fn vec3(&self, p: &str) -> Vector3<f64> {
        Vector3::new(
            self.optional(&format!("{p}_x")),
            self.optional(&format!("{p}_y")),
            self.optional(&format!("{p}_z")),
        )
    }

    /// The line and value column of `thrust`, `(0, 0)` when absent.
    fn thrust_at(&self) -> (usize, usize) {
        self.thrust_kind.map_or((0, 0), |(_, l, c)| (l, c))
    }
}

/// Reads every key of the file, each checked on its own: known, a unit accepted, set once, a
/// finite number (or `unknown` where accepted).
fn read_entries<'t>(kvs: &[KeyValue<'t>], file: &str) -> Result<Entries<'t>, ReadError> {
    let mut e = Entries {
        name: None,
        thrust_kind: None,
        values: Vec::new(),
    };
    for kv in kvs {
        match kv.key {
            "name" => e.name = Some(kv.value.to_string()),
            "thrust" => match kv.value {
                "measured" | "measured_twin" | "propeller" | "unknown" => {
                    e.thrust_kind = Some((kv.value, kv.line, kv.value_col))
                }
                other => {
                    return Err(ReadError::new(
                        file,
                        kv.line,
                        kv.value_col,
                        format!("unknown thrust source `{other}` (measured, measured_twin, propeller or unknown)"),
                    ))
                }
            },
            _ => {
                let entry = numeric_entry(kv, file, &e.values)?;
                e.values.push(entry);
            }
        }
    }
    Ok(e)
}

/// One numeric key's entry; `earlier` are the entries before it (a key may be set once).
fn numeric_entry(kv: &KeyValue, file: &str, earlier: &[Entry]) -> Result<Entry, ReadError> {
    let key = kv.key;
    let Some((base, factor, unknown_ok)) = numeric_key(key) else {
        let hint = NUMERIC
            .iter()
            .find(|(b, _, _)| key.starts_with(b) && key[b.len()..].starts_with('_'))
            .map(|(b, _, _)| format!(" (unit not accepted; use one of {})", spellings(b)))
            .unwrap_or_default();
        return Err(ReadError::new(
            file,
            kv.line,
            kv.key_col,
            format!("unknown key `{key}`{hint}"),
        ));
    };
    if let Some((_, _, l, _)) = earlier.iter().find(|(b, _, _, _)| *b == base) {
        return Err(ReadError::new(
            file,
            kv.line,
            kv.key_col,
            format!("`{base}` already set on line {l} (in another unit)"),
        ));
    }
    let v = if kv.value == "unknown" {
        if !unknown_ok {
            return Err(ReadError::new(
                file,
                kv.line,
                kv.value_col,
                format!("`{key}` may not be `unknown`"),
            ));
        }
        f64::NAN
    } else {
        match kv.value.parse::<f64>() {
            Ok(v) if v.is_finite() => v * factor,
            _ => {
                return Err(ReadError::new(
                    file,
                    kv.line,
                    kv.value_col,
                    format!("`{}` is not a finite number", kv.value),
                ))
            }
        }
    };
    Ok((base, v, kv.line, kv.value_col))
}

/// The mass properties and geometry: the required keys, each positive, and the inertia tensor
/// positive definite.
struct MassGeometry {
    mass: f64,
    inertia: Matrix3<f64>,
    area: f64,
    span: f64,
    chord: f64,
}

fn mass_geometry(e: &Entries, file: &str) -> Result<MassGeometry, ReadError> {
    let mass = e.required("mass", file)?;
    let (jx, jy, jz) = (
        e.required("jx", file)?,
        e.required("jy", file)?,
        e.required("jz", file)?,
    );
    let jxz = e.optional("jxz");
    let (area, span, chord) = (
        e.required("wing_area", file)?,
        e.required("span", file)?,
        e.required("chord", file)?,
    );
    // Positivity, reported at the key's value.
    for base in ["mass", "jx", "jy", "jz", "wing_area", "span", "chord"] {
        if let Some((_, v, l, c)) = e.get(base) {
            if v.is_finite() && *v <= 0.0 {
                return Err(ReadError::new(
                    file,
                    *l,
                    *c,
                    format!("`{base}` must be positive, got {v}"),
                ));
            }
        }
    }
    if jx.is_finite() && jz.is_finite() && jxz.is_finite() && jx * jz - jxz * jxz <= 0.0 {
        let (l, c) = e.get("jxz").map_or((0, 0), |(_, _, l, c)| (*l, *c));
        return Err(ReadError::new(
            file,
            l,
            c,
            "inertia tensor not positive definite (Jx·Jz ≤ Jxz²)",
        ));
    }
    let mut inertia = Matrix3::from_diagonal(&Vector3::new(jx, jy, jz));
    inertia[(0, 2)] = -jxz;
    inertia[(2, 0)] = -jxz;
    Ok(MassGeometry {
        mass,
        inertia,
        area,
        span,
        chord,
    })
}

/// The thrust kind (`unknown` when not given), after checking that no thrust-point or propeller
/// key is given for a kind that does not use it.
fn thrust_kind_checked<'t>(e: &Entries<'t>, file: &str) -> Result<&'t str, ReadError> {
    let kind = e.thrust_kind.map_or("unknown", |(k, _, _)| k);
    let thrust_keys_given = ["thrust_x", "thrust_y", "thrust_z", "thrust_pitch"]
        .iter()
        .filter_map(|b| e.get(b))
        .next();
    let prop_keys_given = NUMERIC
        .iter()
        .filter(|(b, _, _)| b.starts_with("prop_"))
        .filter_map(|(b, _, _)| e.get(b))
        .next();
    if kind == "unknown" {
        if let Some((b, _, l, c)) = thrust_keys_given.or(prop_keys_given) {
            return Err(ReadError::new(
                file,
                *l,
                *c,
                format!(
                    "`{b}` given but `thrust` is `unknown` (set `thrust = measured`, `measured_twin` or `propeller`)"
                ),
            ));
        }
    }
    if kind != "propeller" {
        if let Some((b, _, l, c)) = prop_keys_given {
            return Err(ReadError::new(
                file,
                *l,
                *c,
                format!("`{b}` given but `thrust` is `{kind}`, not `propeller`"),
            ));
        }
    }
    Ok(kind)
}

/// How thrust is known, from the `thrust` kind and the thrust-point and propeller keys.
fn thrust_source(e: &Entries, file: &str) -> Result<ThrustSource, ReadError> {
    let position_m = e.vec3("thrust");
    let pitch_rad = e.optional("thrust_pitch");
    Ok(match thrust_kind_checked(e, file)? {
        "measured" => ThrustSource::Measured { position_m, pitch_rad },
        "measured_twin" => {
            if position_m.y <= 0.0 {
                let (l, c) = e.thrust_at();
                return Err(ReadError::new(
                    file,
                    l,
                    c,
                    "`thrust = measured_twin` needs the right engine's `thrust_y_m` > 0",
                ));
            }
            ThrustSource::MeasuredTwin {
                right_engine_position_m: position_m,
                pitch_rad,
            }
        }
        "propeller" => {
            let d = e.optional("prop_diameter");
            if d <= 0.0 {
                let (l, c) = e
                    .get("prop_diameter")
                    .map(|(_, _, l, c)| (*l, *c))
                    .or(e.thrust_kind.map(|(_, l, c)| (l, c)))
                    .unwrap_or((0, 0));
                return Err(ReadError::new(
                    file,
                    l,
                    c,
                    "`thrust = propeller` needs a positive `prop_diameter_m`",
                ));
            }
            ThrustSource::Propeller(Propeller {
                diameter_m: d,
                ct: [e.optional("prop_ct0"), e.optional("prop_ct1"), e.optional("prop_ct2")],
                cp: [e.optional("prop_cp0"), e.optional("prop_cp1"), e.optional("prop_cp2")],
                position_m,
                pitch_rad,
            })
        }
        _ => ThrustSource::Unknown,
    })
}

/// Parses an aircraft file from `text` (`file` names it in errors).
pub fn parse_aircraft(text: &str, file: &str) -> Result<Aircraft, ReadError> {
    let kvs = key_values(text, file)?;
    let e = read_entries(&kvs, file)?;
    let name = e
        .name
        .clone()
        .ok_or_else(|| ReadError::new(file, 0, 0, "missing required key `name`"))?;
    let m = mass_geometry(&e, file)?;
    let thrust = thrust_source(&e, file)?;
    Ok(Aircraft {
        name,
        mass_kg: m.mass,
        inertia_kgm2: m.inertia,
        wing_area_m2: m.area,
        span_m: m.span,
        chord_m: m.chord,
        accel_position_m: e.vec3("accel"),
        alpha_vane_position_m: e.vec3("alpha_vane"),
        beta_vane_position_m: e.vec3("beta_vane"),
        airspeed_position_m: e.vec3("airspeed"),
        moment_reference_m: e.vec3("moment_reference"),
        thrust,
    })
}

/// Reads an aircraft file.
pub fn read_aircraft(path: &Path) -> Result<Aircraft, ReadError> {
    let text = read_text(path)?;
    parse_aircraft(&text, &path.display().to_string())
}
