//! A second airframe from a plain `key = value` text file.
//!
//! Format: one `key = value` per line; `#` starts a comment; blank lines are ignored. An optional
//! `base = skywalker_2013_mod | rascal_110` (default skywalker), which must come before any other
//! key, gives the starting values; every other key overrides one number. Keys ([`KEYS`] and the
//! coefficient keys): `name`, the mass/inertia/geometry keys (`mass_kg`, `jx_kgm2`, `jy_kgm2`,
//! `jz_kgm2`, `jxz_kgm2` — positive `Jxz`, stored as `−Jxz` off the diagonal —, `wing_area_m2`,
//! `span_m`, `chord_m`), the propeller (`prop_diameter_m`, `prop_ct0…2`, `prop_cp0…2`,
//! `prop_x_m`, `prop_y_m`, `prop_z_m`, `prop_pitch_rad`, `max_prop_speed_rad_s`), surface limits
//! (`elevator_min_rad`, `elevator_max_rad`, likewise `aileron_…`, `rudder_…`), and coefficients as
//! `<lift|drag|side|roll|pitch|yaw>.<c0|alpha|alpha2|beta|p_n|q_n|r_n|aileron|elevator|rudder>`.
//!
//! Every error names the file, the line and the column (1-based); nothing panics.

use super::aero::CoeffModel;
use super::airframe::SimAirframe;
use std::fmt;
use std::path::Path;

/// The scalar keys besides the coefficient keys.
pub const KEYS: [&str; 28] = [
    "mass_kg",
    "jx_kgm2",
    "jy_kgm2",
    "jz_kgm2",
    "jxz_kgm2",
    "wing_area_m2",
    "span_m",
    "chord_m",
    "prop_diameter_m",
    "prop_ct0",
    "prop_ct1",
    "prop_ct2",
    "prop_cp0",
    "prop_cp1",
    "prop_cp2",
    "prop_x_m",
    "prop_y_m",
    "prop_z_m",
    "prop_pitch_rad",
    "max_prop_speed_rad_s",
    "elevator_min_rad",
    "elevator_max_rad",
    "aileron_min_rad",
    "aileron_max_rad",
    "rudder_min_rad",
    "rudder_max_rad",
    // Inertia products other than Jxz are not modelled; these two are accepted for clarity and
    // must be zero.
    "jxy_kgm2",
    "jyz_kgm2",
];

const COEFFS: [&str; 6] = ["lift", "drag", "side", "roll", "pitch", "yaw"];
const TERMS: [&str; 10] = [
    "c0", "alpha", "alpha2", "beta", "p_n", "q_n", "r_n", "aileron", "elevator", "rudder",
];

/// An error in an airframe file: `file:line:column: message`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AirframeFileError {
    /// The file.
    pub file: String,
    /// Line, 1-based (0 when the file could not be read).
    pub line: usize,
    /// Column, 1-based (0 when the file could not be read).
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for AirframeFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: {}", self.file, self.line, self.column, self.message)
    }
}

impl std::error::Error for AirframeFileError {}

fn coeff_slot<'a>(a: &'a mut SimAirframe, key: &str) -> Option<&'a mut f64> {
    let (c, t) = key.split_once('.')?;
    let m: &mut CoeffModel = match c {
        "lift" => &mut a.aero.lift,
        "drag" => &mut a.aero.drag,
        "side" => &mut a.aero.side,
        "roll" => &mut a.aero.roll,
        "pitch" => &mut a.aero.pitch,
        "yaw" => &mut a.aero.yaw,
        _ => return None,
    };
    Some(match t {
        "c0" => &mut m.c0,
        "alpha" => &mut m.alpha,
        "alpha2" => &mut m.alpha2,
        "beta" => &mut m.beta,
        "p_n" => &mut m.p_n,
        "q_n" => &mut m.q_n,
        "r_n" => &mut m.r_n,
        "aileron" => &mut m.aileron,
        "elevator" => &mut m.elevator,
        "rudder" => &mut m.rudder,
        _ => return None,
    })
}

/// Applies one numeric key; `false` if the key is unknown.
fn set(a: &mut SimAirframe, key: &str, v: f64) -> bool {
    let f = &mut a.frame;
    let p = &mut f.propeller;
    let l = &mut a.limits;
    match key {
        "mass_kg" => f.mass_kg = v,
        "jx_kgm2" => f.inertia_kgm2[(0, 0)] = v,
        "jy_kgm2" => f.inertia_kgm2[(1, 1)] = v,
        "jz_kgm2" => f.inertia_kgm2[(2, 2)] = v,
        "jxz_kgm2" => {
            f.inertia_kgm2[(0, 2)] = -v;
            f.inertia_kgm2[(2, 0)] = -v;
        }
        "jxy_kgm2" | "jyz_kgm2" => return v == 0.0,
        "wing_area_m2" => f.wing_area_m2 = v,
        "span_m" => f.span_m = v,
        "chord_m" => f.chord_m = v,
        "prop_diameter_m" => p.diameter_m = v,
        "prop_ct0" => p.ct[0] = v,
        "prop_ct1" => p.ct[1] = v,
        "prop_ct2" => p.ct[2] = v,
        "prop_cp0" => p.cp[0] = v,
        "prop_cp1" => p.cp[1] = v,
        "prop_cp2" => p.cp[2] = v,
        "prop_x_m" => p.position_m.x = v,
        "prop_y_m" => p.position_m.y = v,
        "prop_z_m" => p.position_m.z = v,
        "prop_pitch_rad" => p.pitch_rad = v,
        "max_prop_speed_rad_s" => a.max_prop_speed_rad_s = v,
        "elevator_min_rad" => l.elevator_rad.0 = v,
        "elevator_max_rad" => l.elevator_rad.1 = v,
        "aileron_min_rad" => l.aileron_rad.0 = v,
        "aileron_max_rad" => l.aileron_rad.1 = v,
        "rudder_min_rad" => l.rudder_rad.0 = v,
        "rudder_max_rad" => l.rudder_rad.1 = v,
        _ => match coeff_slot(a, key) {
            Some(s) => *s = v,
            None => return false,
        },
    }
    true
}

/// Parses an airframe from `text` (`file` names it in errors).
pub fn parse_airframe(text: &str, file: &str) -> Result<SimAirframe, AirframeFileError> {
    let mut a = SimAirframe::skywalker_2013_mod();
    let mut seen: Vec<(String, usize, usize)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let Some(e) = Entry::parse(raw, i + 1, file)? else {
            continue;
        };
        if let Some((_, l0, _)) = seen.iter().find(|(k, _, _)| k == e.key) {
            let key = e.key;
            return Err(file_error(
                file,
                e.line,
                e.key_col,
                format!("`{key}` already set on line {l0}"),
            ));
        }
        e.apply(&mut a, seen.is_empty(), file)?;
        seen.push((e.key.to_string(), e.line, e.value_col));
    }
    validate(&a, &seen, file)?;
    Ok(a)
}

/// An error at `line`, `column` of `file`.
fn file_error(file: &str, line: usize, column: usize, message: String) -> AirframeFileError {
    AirframeFileError {
        file: file.to_string(),
        line,
        column,
        message,
    }
}

/// One `key = value` line: the key and the value, trimmed, and the columns they start at.
struct Entry<'t> {
    line: usize,
    key: &'t str,
    key_col: usize,
    value: &'t str,
    value_col: usize,
}

impl<'t> Entry<'t> {
    /// The entry of line `line` (`None` for a blank or comment line).
    fn parse(raw: &'t str, line: usize, file: &str) -> Result<Option<Self>, AirframeFileError> {
        let content = raw.split('#').next().unwrap_or("");
        if content.trim().is_empty() {
            return Ok(None);
        }
        let key_col = content.len() - content.trim_start().len() + 1;
        let Some(eq) = content.find('=') else {
            return Err(file_error(file, line, key_col, "expected `key = value`".into()));
        };
        let key = content[..eq].trim();
        let rest = &content[eq + 1..];
        let value = rest.trim();
        let value_col = eq + 2 + (rest.len() - rest.trim_start().len());
        if key.is_empty() {
            return Err(file_error(file, line, key_col, "missing key before `=`".into()));
        }
        if value.is_empty() {
            return Err(file_error(file, line, value_col, format!("missing value for `{key}`")));
        }
        Ok(Some(Self {
            line,
            key,
            key_col,
            value,
            value_col,
        }))
    }

    /// Sets the entry's key in `a`: `base` (only `first`) restarts from a stock airframe,
    /// `name` names it, every other key is a finite number [`set`] knows.
    fn apply(&self, a: &mut SimAirframe, first: bool, file: &str) -> Result<(), AirframeFileError> {
        let (key, value, line) = (self.key, self.value, self.line);
        let err = |column: usize, message: String| file_error(file, line, column, message);
        match key {
            "base" => {
                if !first {
                    return Err(err(self.key_col, "`base` must come before every other key".into()));
                }
                *a = match value {
                    "skywalker_2013_mod" => SimAirframe::skywalker_2013_mod(),
                    "rascal_110" => SimAirframe::rascal_110(),
                    _ => {
                        return Err(err(
                            self.value_col,
                            format!("unknown base `{value}` (skywalker_2013_mod or rascal_110)"),
                        ))
                    }
                };
            }
            "name" => a.name = value.to_string(),
            _ => {
                let v = match value.parse::<f64>() {
                    Ok(v) if v.is_finite() => v,
                    _ => return Err(err(self.value_col, format!("`{value}` is not a finite number"))),
                };
                if !set(a, key, v) {
                    let msg = if key == "jxy_kgm2" || key == "jyz_kgm2" {
                        format!("`{key}` must be 0 (only Jxz is modelled)")
                    } else {
                        format!("unknown key `{key}`")
                    };
                    return Err(err(
                        if msg.starts_with("unknown") {
                            self.key_col
                        } else {
                            self.value_col
                        },
                        msg,
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Positive masses, inertias, sizes and propeller speed, a positive definite inertia and ordered
/// surface limits, each error reported at the key that set the offending value (`seen`: key,
/// line, value column; line 1, column 1 if from base).
fn validate(a: &SimAirframe, seen: &[(String, usize, usize)], file: &str) -> Result<(), AirframeFileError> {
    let at = |key: &str| {
        seen.iter()
            .find(|(k, _, _)| k == key)
            .map_or((1, 1), |(_, l, c)| (*l, *c))
    };
    let f = &a.frame;
    let positive = [
        ("mass_kg", f.mass_kg),
        ("jx_kgm2", f.inertia_kgm2[(0, 0)]),
        ("jy_kgm2", f.inertia_kgm2[(1, 1)]),
        ("jz_kgm2", f.inertia_kgm2[(2, 2)]),
        ("wing_area_m2", f.wing_area_m2),
        ("span_m", f.span_m),
        ("chord_m", f.chord_m),
        ("prop_diameter_m", f.propeller.diameter_m),
        ("max_prop_speed_rad_s", a.max_prop_speed_rad_s),
    ];
    for (k, v) in positive {
        if v <= 0.0 {
            let (l, c) = at(k);
            return Err(file_error(file, l, c, format!("`{k}` must be positive, got {v}")));
        }
    }
    let j = f.inertia_kgm2;
    if j[(0, 0)] * j[(2, 2)] - j[(0, 2)] * j[(0, 2)] <= 0.0 {
        let (l, c) = at("jxz_kgm2");
        return Err(file_error(
            file,
            l,
            c,
            "inertia tensor not positive definite (Jx·Jz ≤ Jxz²)".into(),
        ));
    }
    for (name, (lo, hi)) in [
        ("elevator", a.limits.elevator_rad),
        ("aileron", a.limits.aileron_rad),
        ("rudder", a.limits.rudder_rad),
    ] {
        if lo >= hi {
            let (l, c) = at(&format!("{name}_max_rad"));
            return Err(file_error(file, l, c, format!("{name} limits: min {lo} ≥ max {hi}")));
        }
    }
    Ok(())
}

/// Reads an airframe file.
pub fn read_airframe(path: &Path) -> Result<SimAirframe, AirframeFileError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| file_error(&name, 0, 0, e.to_string()))?;
    parse_airframe(&text, &name)
}

/// Writes every key of `a` (the inverse of [`parse_airframe`]; round trip exact).
pub fn airframe_to_text(a: &SimAirframe) -> String {
    let mut s = format!("# aerosid airframe\nname = {}\n", a.name);
    let mut probe = a.clone();
    for k in KEYS.iter().filter(|k| !k.starts_with("jxy") && !k.starts_with("jyz")) {
        let v = read_key(a, k);
        s.push_str(&format!("{k} = {v:e}\n"));
    }
    for c in COEFFS {
        for t in TERMS {
            let key = format!("{c}.{t}");
            let v = coeff_slot(&mut probe, &key).map_or(0.0, |x| *x);
            s.push_str(&format!("{key} = {v:e}\n"));
        }
    }
    s
}

fn read_key(a: &SimAirframe, key: &str) -> f64 {
    let f = &a.frame;
    let p = &f.propeller;
    let l = &a.limits;
    match key {
        "mass_kg" => f.mass_kg,
        "jx_kgm2" => f.inertia_kgm2[(0, 0)],
        "jy_kgm2" => f.inertia_kgm2[(1, 1)],
        "jz_kgm2" => f.inertia_kgm2[(2, 2)],
        "jxz_kgm2" => -f.inertia_kgm2[(0, 2)],
        "wing_area_m2" => f.wing_area_m2,
        "span_m" => f.span_m,
        "chord_m" => f.chord_m,
        "prop_diameter_m" => p.diameter_m,
        "prop_ct0" => p.ct[0],
        "prop_ct1" => p.ct[1],
        "prop_ct2" => p.ct[2],
        "prop_cp0" => p.cp[0],
        "prop_cp1" => p.cp[1],
        "prop_cp2" => p.cp[2],
        "prop_x_m" => p.position_m.x,
        "prop_y_m" => p.position_m.y,
        "prop_z_m" => p.position_m.z,
        "prop_pitch_rad" => p.pitch_rad,
        "max_prop_speed_rad_s" => a.max_prop_speed_rad_s,
        "elevator_min_rad" => l.elevator_rad.0,
        "elevator_max_rad" => l.elevator_rad.1,
        "aileron_min_rad" => l.aileron_rad.0,
        "aileron_max_rad" => l.aileron_rad.1,
        "rudder_min_rad" => l.rudder_rad.0,
        "rudder_max_rad" => l.rudder_rad.1,
        _ => 0.0,
    }
}
