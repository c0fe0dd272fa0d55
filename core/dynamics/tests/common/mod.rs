//! Shared helpers for the integration tests: the checked-in fixture robots.
#![allow(dead_code)]

use robosim_kinematics::Robot;
use robosim_kinematics::json::robot_from_json;
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
