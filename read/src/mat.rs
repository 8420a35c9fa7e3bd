//! MATLAB level-5 `.mat` → [`MeasuredFlight`], the format SIDPAC (Morelli) and Jategaonkar's book
//! publish their flight data in.
//!
//! **Parser.** The `matfile` crate (0.5, MIT): level-5 files, compressed or not, numeric arrays
//! (cell, struct, char and sparse arrays are skipped). Version 7.3 files are HDF5 and are refused
//! by it. The crate is run under `catch_unwind`, so that a malformed file it does not anticipate is
//! an error naming the file, never a crash of the command.
//!
//! **Which matrix, which column.** A `.mat` file is read through the same column map as an ASCII
//! file ([`super::colmap`], `format = ascii`): `$N` is column `N` of one 2-D real matrix, one
//! sample per row. The matrix is the map's `variable = NAME`; without it, the only matrix with the
//! map's `columns`; if several have that width, the one named `fdata` (SIDPAC's name for its
//! flight-data matrix) — else the error lists the candidates. The rows go through the ASCII reader
//! unchanged (each number written in Rust's shortest round-trip form, so read back exactly), so
//! both formats give the same flight and the same checks; an error's line is the matrix row.

use super::colmap::{parse_ascii, ColumnMap, Format};
use super::measured::MeasuredFlight;
use super::ReadError;
use matfile::{MatFile, NumericData};
use std::path::Path;

/// Reads a `.mat` file through `map`.
pub fn read_mat(path: &Path, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ReadError::new(&file, 0, 0, e.to_string()))?;
    parse_mat(&bytes, &file, map)
}

/// The real part of a numeric array as `f64`.
fn real(d: &NumericData) -> Vec<f64> {
    match d {
        NumericData::Int8 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::UInt8 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::Int16 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::UInt16 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::Int32 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::UInt32 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::Int64 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::UInt64 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::Single { real, .. } => real.iter().map(|&v| v as f64).collect(),
        NumericData::Double { real, .. } => real.clone(),
    }
}

/// [`read_mat`] on bytes already read (`file` names them in errors).
pub fn parse_mat(bytes: &[u8], file: &str, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    let err = |m: String| ReadError::new(file, 0, 0, m);
    if map.format != Format::Ascii {
        return Err(ReadError::new(
            &map.file,
            0,
            0,
            "a `.mat` file is read through a `format = ascii` map (`$N` is column N of the matrix)",
        ));
    }
    let parsed = std::panic::catch_unwind(|| MatFile::parse(bytes))
        .map_err(|_| err("not a readable MATLAB level-5 file (the parser gave up on its structure)".into()))?
        .map_err(|e| {
            err(format!(
                "not a readable MATLAB level-5 file: {e} (a v7.3 file is HDF5: save it with `save -v7`)"
            ))
        })?;
    let array = choose_matrix(&parsed, map, file)?;
    let (rows, cols) = (array.size()[0], array.size()[1]);
    let values = real(array.data());
    // The declared size against the data stored (a corrupt header can declare any size): every
    // index below and the text's capacity are bounded by the values actually read.
    if rows.checked_mul(cols) != Some(values.len()) {
        return Err(err(format!(
            "matrix {} declares {rows} × {cols} values but holds {} (a corrupt or truncated file)",
            describe(array),
            values.len()
        )));
    }
    let text = matrix_text(&values, rows, cols);
    let name = array.name().to_string();
    let mut flight = parse_ascii(&text, file, map).map_err(|mut e| {
        if e.file == file && e.line > 0 {
            e.message = format!("matrix `{name}` row {} column {}: {}", e.line, e.column, e.message);
        }
        e
    })?;
    flight.log.format = format!("MATLAB .mat (matrix `{name}`, {rows} × {cols})");
    Ok(flight)
}

/// A matrix for messages: its name and size (`` `fdata` 401×90 ``).
fn describe(a: &matfile::Array) -> String {
    let s: Vec<String> = a.size().iter().map(|d| d.to_string()).collect();
    format!("`{}` {}", a.name(), s.join("×"))
}

/// The matrix the map reads: the one `variable` names, else the only one with the map's column
/// count (of several, `fdata`); it must be rows × the map's columns.
fn choose_matrix<'p>(parsed: &'p MatFile, map: &ColumnMap, file: &str) -> Result<&'p matfile::Array, ReadError> {
    let err = |m: String| ReadError::new(file, 0, 0, m);
    let all: Vec<String> = parsed.arrays().iter().map(describe).collect();
    let fits = |a: &&matfile::Array| a.ndims() == 2 && a.size()[1] == map.columns && a.size()[0] >= 2;
    let array = match &map.variable {
        Some(v) => parsed.arrays().iter().find(|a| a.name() == v).ok_or_else(|| {
            err(format!(
                "no numeric matrix `{v}` (named by `variable` in {}); the file has: {}",
                map.file,
                all.join(", ")
            ))
        })?,
        None => {
            let c: Vec<&matfile::Array> = parsed.arrays().iter().filter(fits).collect();
            match c.as_slice() {
                [one] => *one,
                [] => {
                    return Err(err(format!(
                        "no matrix with {} columns (the map's `columns`); the file has: {}",
                        map.columns,
                        all.join(", ")
                    )))
                }
                several => match several.iter().find(|a| a.name() == "fdata") {
                    Some(a) => *a,
                    None => {
                        return Err(err(format!(
                            "several matrices have {} columns ({}); name one with `variable = NAME` in {}",
                            map.columns,
                            several.iter().map(|a| describe(a)).collect::<Vec<_>>().join(", "),
                            map.file
                        )))
                    }
                },
            }
        }
    };
    if !fits(&array) {
        return Err(err(format!(
            "matrix {} is not rows × {} columns (the map's `columns`)",
            describe(array),
            map.columns
        )));
    }
    Ok(array)
}

/// The matrix's values (column-major: element (i, j) at i + j·rows) as whitespace-separated
/// text, a row per line, for the ASCII reader.
fn matrix_text(values: &[f64], rows: usize, cols: usize) -> String {
    let mut text = String::with_capacity(values.len() * 24);
    for i in 0..rows {
        for j in 0..cols {
            if j > 0 {
                text.push(' ');
            }
            text.push_str(&format!("{:e}", values[i + j * rows]));
        }
        text.push('\n');
    }
    text
}
