//! The reference robots shipped as data (`testdata/kinematics/*.json`, generated from Robotics
//! Toolbox for Python 1.5.0 by `testdata/kinematics/generate.py`; sources in the README there),
//! usable by name before the library language lands.
//!
//! Entry points: [`builtin_robot`], [`BUILTIN_NAMES`].

use crate::json::robot_from_json;
use crate::model::Robot;

/// The names [`builtin_robot`] knows.
pub const BUILTIN_NAMES: &[&str] = &["puma560", "stanford", "panda"];

const PUMA560: &str = include_str!("../../../testdata/kinematics/puma560.json");
const STANFORD: &str = include_str!("../../../testdata/kinematics/stanford.json");
const PANDA: &str = include_str!("../../../testdata/kinematics/panda.json");

/// A shipped robot by name: `"puma560"` (standard DH, Corke & Armstrong-Helouvry 1994 kinematics
/// and dynamics, with the 0.672 m pedestal as d1), `"stanford"` (standard DH, RRPRRR) or
/// `"panda"` (Franka Emika Panda, modified DH, 7 DOF, with inertial parameters). `None` for any
/// other name.
pub fn builtin_robot(name: &str) -> Option<Robot> {
    let text = match name {
        "puma560" => PUMA560,
        "stanford" => STANFORD,
        "panda" => PANDA,
        _ => return None,
    };
    // The shipped files are checked by the `builtin_robots_parse` test below; a parse failure
    // here would be a build-time data error, reported as "unknown" rather than a panic.
    let v: serde_json::Value = serde_json::from_str(text).ok()?;
    robot_from_json(&v).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_robots_parse() {
        for name in BUILTIN_NAMES {
            let text = match *name {
                "puma560" => PUMA560,
                "stanford" => STANFORD,
                _ => PANDA,
            };
            let v: serde_json::Value = serde_json::from_str(text).expect("shipped JSON parses");
            robot_from_json(&v).expect("shipped robot is valid");
            assert!(builtin_robot(name).is_some());
        }
        assert_eq!(builtin_robot("puma560").map(|r| r.dof()), Some(6));
        assert_eq!(builtin_robot("panda").map(|r| r.dof()), Some(7));
        assert!(builtin_robot("nope").is_none());
    }
}
