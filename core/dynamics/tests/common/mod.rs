//! Shared helpers for the integration tests: the checked-in fixture robots.
#![allow(dead_code)]

use nalgebra::DMatrix;
use robosim_kinematics::Robot;
use robosim_kinematics::json::robot_from_json;
use serde_json::Value;
use std::path::PathBuf;

pub fn testdata() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/dynamics")
}

/// A fixture robot from `testdata/dynamics/robots/<name>.json`.
pub fn fixture(name: &str) -> Robot {
    let path = testdata().join("robots").join(format!("{name}.json"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    robot_from_json(&value).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

pub const FIXTURES: [&str; 5] = [
    "puma560",
    "stanford",
    "panda",
    "synthetic_standard",
    "synthetic_modified",
];

/// The numbers of a JSON array (reference data checked in by the make_*reference.py scripts).
pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// A JSON array of rows as a matrix.
pub fn matrix(v: &Value) -> DMatrix<f64> {
    let rows: Vec<Vec<f64>> = v.as_array().expect("rows").iter().map(floats).collect();
    let (r, c) = (rows.len(), rows.first().map_or(0, Vec::len));
    DMatrix::from_fn(r, c, |i, j| rows[i][j])
}

/// max |a − b| over max(1, max |b|): the relative error the reference comparisons bound.
pub fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}
