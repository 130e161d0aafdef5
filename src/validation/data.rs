//! Reference data of the validation scenes, read from `../shared/validation/` beside the
//! crate (see that folder's README for provenance and scalings). The data are not copied
//! into this repository.
//!
//! The folder is found at run time: `RAPIER_SPH_VALIDATION_DATA` if set, else
//! `<crate root>/../shared/validation` (the crate root as compiled, `CARGO_MANIFEST_DIR`).
//! A missing folder or file is a [`SphError::ReferenceData`] naming the path.

use crate::error::{SphError, SphResult};
use std::path::PathBuf;

/// One reference curve: dimensionless `(x, y)` points, in the order of the file.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// What the curve is, e.g. `"Martin & Moyce 1952, n² = 1, front"`.
    pub label: String,
    /// `(x, y)` points (dimensionless; see the scene for the scaling).
    pub points: Vec<(f64, f64)>,
}

/// The folder holding the reference data sets.
pub fn data_dir() -> PathBuf {
    match std::env::var_os("RAPIER_SPH_VALIDATION_DATA") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("shared")
            .join("validation"),
    }
}

fn data_error(path: &std::path::Path, reason: impl Into<String>) -> SphError {
    SphError::ReferenceData {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

/// Reads `folder/file` (a CSV with a header row) and returns the rows whose `filter_col`
/// equals `filter` (all rows when `filter_col` is `None`), as `(x_col, y_col)` pairs.
/// Points with `x ≤ 0` are dropped: they restate the initial condition, not a measurement.
pub fn read_curve(
    folder: &str,
    file: &str,
    x_col: &str,
    y_col: &str,
    filter: Option<(&str, &str)>,
    label: &str,
) -> SphResult<Curve> {
    let source = CurveSource {
        folder,
        file,
        x_col,
        y_col,
        filter,
        label,
    };
    read_curve_in(&data_dir(), &source)
}

/// Which curve of which file [`read_curve_in`] reads: [`read_curve`]'s arguments.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CurveSource<'a> {
    /// The data set's folder inside the data folder, e.g. `"lobovsky_2014"`.
    pub folder: &'a str,
    /// The CSV file inside `folder`.
    pub file: &'a str,
    /// The column of the x values.
    pub x_col: &'a str,
    /// The column of the y values.
    pub y_col: &'a str,
    /// `(column, value)`: only the rows whose `column` reads `value`; `None`: every row.
    pub filter: Option<(&'a str, &'a str)>,
    /// The curve's [`Curve::label`].
    pub label: &'a str,
}

/// [`read_curve`] from the data folder `dir`.
///
/// # Errors
/// [`SphError::ReferenceData`] naming the path: no folder `dir`, no file, an empty file, a
/// missing column, a cell that is not a finite number, or no matching row.
pub fn read_curve_in(dir: &std::path::Path, source: &CurveSource) -> SphResult<Curve> {
    let &CurveSource {
        folder,
        file,
        x_col,
        y_col,
        filter,
        label,
    } = source;
    if !dir.is_dir() {
        return Err(data_error(
            dir,
            "reference data folder not found: clone the shared data beside the crate \
             (../shared/validation) or set RAPIER_SPH_VALIDATION_DATA",
        ));
    }
    let path = dir.join(folder).join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| data_error(&path, e.to_string()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| data_error(&path, "empty file"))?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| data_error(&path, format!("no column `{name}`")))
    };
    let (xi, yi) = (col(x_col)?, col(y_col)?);
    let fi = match filter {
        Some((c, v)) => Some((col(c)?, v)),
        None => None,
    };
    let mut points = Vec::new();
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if let Some((c, v)) = fi
            && cells.get(c) != Some(&v)
        {
            continue;
        }
        let num = |i: usize| -> SphResult<f64> {
            cells
                .get(i)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| data_error(&path, format!("line {}: not a number", n + 2)))
        };
        let (x, y) = (num(xi)?, num(yi)?);
        if x > 0.0 {
            points.push((x, y));
        }
    }
    if points.is_empty() {
        return Err(data_error(&path, "no matching rows"));
    }
    Ok(Curve {
        label: label.to_string(),
        points,
    })
}
