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
use super::{key_values, read_text, ReadError};
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

/// Parses an aircraft file from `text` (`file` names it in errors).
pub fn parse_aircraft(text: &str, file: &str) -> Result<Aircraft, ReadError> {
    let kvs = key_values(text, file)?;
    let mut name: Option<String> = None;
    let mut thrust_kind: Option<(&str, usize, usize)> = None;
    // base → (SI value, line, value column)
    let mut values: Vec<(&'static str, f64, usize, usize)> = Vec::new();
    for kv in &kvs {
        match kv.key {
            "name" => name = Some(kv.value.to_string()),
            "thrust" => match kv.value {
                "measured" | "measured_twin" | "propeller" | "unknown" => {
                    thrust_kind = Some((kv.value, kv.line, kv.value_col))
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
            key => {
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
                if let Some((_, _, l, _)) = values.iter().find(|(b, _, _, _)| *b == base) {
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
                values.push((base, v, kv.line, kv.value_col));
            }
        }
    }
    let get = |base: &str| values.iter().find(|(b, _, _, _)| *b == base);
    let required = |base: &str| {
        get(base).map(|(_, v, _, _)| *v).ok_or_else(|| {
            ReadError::new(
                file,
                0,
                0,
                format!("missing required key `{base}` (one of {})", spellings(base)),
            )
        })
    };
    let optional = |base: &str| get(base).map_or(0.0, |(_, v, _, _)| *v);
    let name = name.ok_or_else(|| ReadError::new(file, 0, 0, "missing required key `name`"))?;
    let mass = required("mass")?;
    let (jx, jy, jz) = (required("jx")?, required("jy")?, required("jz")?);
    let jxz = optional("jxz");
    let (area, span, chord) = (required("wing_area")?, required("span")?, required("chord")?);
    // Positivity, reported at the key's value.
    for base in ["mass", "jx", "jy", "jz", "wing_area", "span", "chord"] {
        if let Some((_, v, l, c)) = get(base) {
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
        let (l, c) = get("jxz").map_or((0, 0), |(_, _, l, c)| (*l, *c));
        return Err(ReadError::new(
            file,
            l,
            c,
            "inertia tensor not positive definite (Jx·Jz ≤ Jxz²)",
        ));
    }
    let vec3 = |p: &str| {
        Vector3::new(
            optional(&format!("{p}_x")),
            optional(&format!("{p}_y")),
            optional(&format!("{p}_z")),
        )
    };
    // `vec3` looks keys up by base name; the bases are 'static in NUMERIC, so compare by value.
    let thrust_position = vec3("thrust");
    let thrust_pitch = optional("thrust_pitch");
    let kind = thrust_kind.map_or("unknown", |(k, _, _)| k);
    let thrust_keys_given = ["thrust_x", "thrust_y", "thrust_z", "thrust_pitch"]
        .iter()
        .filter_map(|b| get(b))
        .next();
    let prop_keys_given = NUMERIC
        .iter()
        .filter(|(b, _, _)| b.starts_with("prop_"))
        .filter_map(|(b, _, _)| get(b))
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
    let thrust = match kind {
        "measured" => ThrustSource::Measured {
            position_m: thrust_position,
            pitch_rad: thrust_pitch,
        },
        "measured_twin" => {
            if thrust_position.y <= 0.0 {
                let (l, c) = thrust_kind.map_or((0, 0), |(_, l, c)| (l, c));
                return Err(ReadError::new(
                    file,
                    l,
                    c,
                    "`thrust = measured_twin` needs the right engine's `thrust_y_m` > 0",
                ));
            }
            ThrustSource::MeasuredTwin {
                right_engine_position_m: thrust_position,
                pitch_rad: thrust_pitch,
            }
        }
        "propeller" => {
            let d = optional("prop_diameter");
            if d <= 0.0 {
                let (l, c) = get("prop_diameter")
                    .map(|(_, _, l, c)| (*l, *c))
                    .or(thrust_kind.map(|(_, l, c)| (l, c)))
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
                ct: [optional("prop_ct0"), optional("prop_ct1"), optional("prop_ct2")],
                cp: [optional("prop_cp0"), optional("prop_cp1"), optional("prop_cp2")],
                position_m: thrust_position,
                pitch_rad: thrust_pitch,
            })
        }
        _ => ThrustSource::Unknown,
    };
    let mut inertia = Matrix3::from_diagonal(&Vector3::new(jx, jy, jz));
    inertia[(0, 2)] = -jxz;
    inertia[(2, 0)] = -jxz;
    Ok(Aircraft {
        name,
        mass_kg: mass,
        inertia_kgm2: inertia,
        wing_area_m2: area,
        span_m: span,
        chord_m: chord,
        accel_position_m: vec3("accel"),
        alpha_vane_position_m: vec3("alpha_vane"),
        beta_vane_position_m: vec3("beta_vane"),
        airspeed_position_m: vec3("airspeed"),
        moment_reference_m: vec3("moment_reference"),
        thrust,
    })
}

/// Reads an aircraft file.
pub fn read_aircraft(path: &Path) -> Result<Aircraft, ReadError> {
    let text = read_text(path)?;
    parse_aircraft(&text, &path.display().to_string())
}
