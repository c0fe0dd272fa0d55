//! Reading the checked-in reference values (testdata/urdf/pinocchio_reference.json and kin):
//! shared by the URDF tests that compare against Pinocchio.
#![allow(dead_code)]

use nalgebra::DMatrix;

/// `testdata/`.
pub fn testdata() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata")
}

/// A JSON array of numbers.
pub fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// A JSON array of rows.
pub fn matrix(v: &serde_json::Value) -> DMatrix<f64> {
    let rows: Vec<Vec<f64>> = v.as_array().expect("rows").iter().map(floats).collect();
    DMatrix::from_fn(rows.len(), rows[0].len(), |r, c| rows[r][c])
}

/// Largest difference relative to the reference's largest magnitude (at least 1).
pub fn rel(ours: &[f64], theirs: &[f64]) -> f64 {
    let d = ours
        .iter()
        .zip(theirs)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    d / theirs.iter().map(|x| x.abs()).fold(1.0, f64::max)
}
