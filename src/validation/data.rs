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
    read_curve_in(&data_dir(), folder, file, x_col, y_col, filter, label)
}

/// [`read_curve`] from the data folder `dir`.
pub fn read_curve_in(
    dir: &std::path::Path,
    folder: &str,
    file: &str,
    x_col: &str,
    y_col: &str,
    filter: Option<(&str, &str)>,
    label: &str,
) -> SphResult<Curve> {
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
