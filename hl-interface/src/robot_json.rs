//! The inline robot format of DESIGN.md ("The query protocol"): the core's reader and writer
//! ([`robosim_kinematics::json`], re-exported here under the protocol's path) plus the one form
//! that read a file, `{"urdf": PATH, "tip": LINK}` ([`robot_from_urdf_json`]) and
//! `{"mjcf": PATH, "tip": BODY}` ([`robot_from_mjcf_json`]), which [`robot_from_json`] here
//! accepts too.
//!
//! Entry points: [`robot_from_json`], [`robot_to_json`], [`matrix4_from_json`],
//! [`matrix4_to_json`], [`matrix_to_json`], [`number`], [`number_array`]. Every error names the
//! field path (`joints[2].qlim[1]`).

use crate::{ErrorKind, ProtocolError};
use robosim_kinematics::json::check_keys;
pub use robosim_kinematics::json::{
    JsonError, matrix_to_json, matrix3_from_json, matrix4_from_json, matrix4_to_json, number,
    number_array, robot_to_json,
};
use robosim_kinematics::{Robot, RootKind};
use serde_json::{Map, Value};

/// A field of a request that could not be read is a `bad_request`.
impl From<JsonError> for ProtocolError {
    fn from(e: JsonError) -> Self {
        ProtocolError::new(
            ErrorKind::BadRequest,
            robosim_instance_space::error_chain(&e),
        )
    }
}

/// Reads a robot in DESIGN.md's inline format ([`robosim_kinematics::json::robot_from_json`]:
/// validated, unknown keys refused) or, for an object with a `urdf` key, a URDF file:
/// `{"urdf": PATH, "tip": LINK}` — the serial chain from the file's root link to `tip`
/// ([`robot_from_urdf_json`]).
pub fn robot_from_json(v: &Value) -> Result<Robot, JsonError> {
    if let Some(obj) = v.as_object()
        && obj.contains_key("urdf")
    {
        return robot_from_urdf_json(obj);
    }
    if let Some(obj) = v.as_object()
        && obj.contains_key("mjcf")
    {
        return robot_from_mjcf_json(obj);
    }
    robosim_kinematics::json::robot_from_json(v)
}

const MJCF_KEYS: &[&str] = &["mjcf", "tip"];

/// `{"mjcf": PATH, "tip": BODY}` (issue 36 item 5): the serial chain of the MuJoCo model at
/// PATH from the world to the body `tip` (absent: the only leaf body), imported by
/// [`robosim_file_io::mjcf::import_mjcf`]: q is the hinge and slide joints of the bodies on that
/// path, in MuJoCo's qpos order; other joints are held at their reference position; the base
/// frame is the world, the tool frame the tip body's. A ball or free joint on the model is
/// refused by name. Errors: `robot.mjcf` / `robot.tip` for a field of the wrong type, else
/// `robot.mjcf` with the importer's message (file, line, element and what).
pub fn robot_from_mjcf_json(obj: &Map<String, Value>) -> Result<Robot, JsonError> {
    check_keys(obj, MJCF_KEYS, "robot")?;
    let path = obj
        .get("mjcf")
        .and_then(Value::as_str)
        .ok_or_else(|| JsonError::new("robot.mjcf", "expected the MJCF file's path (a string)"))?;
    let tip = match obj.get("tip") {
        None | Some(Value::Null) => None,
        Some(t) => Some(t.as_str().ok_or_else(|| {
            JsonError::new("robot.tip", "expected the tip body's name (a string)")
        })?),
    };
    robosim_file_io::mjcf::import_mjcf(std::path::Path::new(path), tip)
        .map(|imported| imported.robot)
        .map_err(|e| JsonError::caused("robot.mjcf", e))
}

const URDF_KEYS: &[&str] = &["urdf", "tip", "floating"];

/// A file robot's `floating` field: absent, null or false → a fixed base; true → a free-flyer
/// root; `"free_flyer"` or `"planar"` → that root.
pub fn floating_field(obj: &Map<String, Value>) -> Result<Option<RootKind>, JsonError> {
    match obj.get("floating") {
        None | Some(Value::Null) | Some(Value::Bool(false)) => Ok(None),
        Some(Value::Bool(true)) => Ok(Some(RootKind::FreeFlyer)),
        Some(v) => v
            .as_str()
            .and_then(RootKind::from_name)
            .map(Some)
            .ok_or_else(|| {
                JsonError::new(
                    "robot.floating",
                    "expected true, false, \"free_flyer\" or \"planar\"",
                )
            }),
    }
}

/// `{"urdf": PATH, "tip": LINK}` (DESIGN.md, the query protocol): the serial chain of the URDF
/// at PATH (relative paths from the answering process's working directory) from its root link
/// to the link `tip` (absent: the only leaf link, when there is exactly one), imported by
/// [`robosim_file_io::urdf_import::import_urdf`]. q is the chain's movable joints from the root;
/// joints off the chain are held at 0, rigid with the link they hang from; the base frame is the
/// root link's frame and the tool frame the tip link's. The file is read on every request.
/// Errors: `robot.urdf` / `robot.tip` for a field of the wrong type, else `robot.urdf` with the
/// importer's message (file, line, element and what: a missing file, malformed XML, a tip that
/// is not a link, ...).
///
/// `{"urdf": PATH, "floating": true}` (or `"floating": "free_flyer" | "planar"`; issue 36 item
/// 2): the whole tree on a floating root joint between the world and the root link
/// ([`robosim_file_io::urdf_import::import_urdf_tree_floating`], Pinocchio's
/// `buildModel(urdf, JointModelFreeFlyer())`): q has `nq` values (the root's coordinates first),
/// v, q̈ and τ `nv`; the tool frame is the last joint's child link. `tip` is refused with it.
pub fn robot_from_urdf_json(obj: &Map<String, Value>) -> Result<Robot, JsonError> {
    check_keys(obj, URDF_KEYS, "robot")?;
    let path = obj
        .get("urdf")
        .and_then(Value::as_str)
        .ok_or_else(|| JsonError::new("robot.urdf", "expected the URDF file's path (a string)"))?;
    let floating = floating_field(obj)?;
    if let Some(kind) = floating {
        if obj.get("tip").is_some_and(|t| !t.is_null()) {
            return Err(JsonError::new(
                "robot.tip",
                "a floating robot is the URDF's whole tree: leave `tip` out",
            ));
        }
        return robosim_file_io::urdf_import::import_urdf_tree_floating(
            std::path::Path::new(path),
            kind,
        )
        .map(|imported| imported.robot)
        .map_err(|e| JsonError::caused("robot.urdf", e));
    }
    let tip = match obj.get("tip") {
        None | Some(Value::Null) => None,
        Some(t) => Some(t.as_str().ok_or_else(|| {
            JsonError::new("robot.tip", "expected the tip link's name (a string)")
        })?),
    };
    robosim_file_io::urdf_import::import_urdf(std::path::Path::new(path), tip)
        .map(|imported| imported.robot)
        .map_err(|e| JsonError::caused("robot.urdf", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_urdf_key_reads_the_file_and_other_objects_the_inline_form() {
        let e = robot_from_json(&serde_json::json!({"urdf": "/no/such/file.urdf"}))
            .expect_err("no such file");
        assert_eq!(e.path, "robot.urdf");
        // The importer's error is kept typed behind the field path.
        let cause = std::error::Error::source(&e).expect("the importer's error");
        assert!(
            cause
                .downcast_ref::<robosim_file_io::urdf_import::UrdfError>()
                .is_some(),
            "{cause:?}"
        );
        let e = robot_from_json(&serde_json::json!({"urdf": "x.urdf", "tpi": "a"}))
            .expect_err("a misspelt key");
        assert_eq!(e.path, "robot.tpi");
        let e = robot_from_json(&serde_json::json!({"mjcf": "/no/such/file.xml"}))
            .expect_err("no such file");
        assert_eq!(e.path, "robot.mjcf");
        let e = robot_from_json(&serde_json::json!({"mjcf": "x.xml", "tpi": "a"}))
            .expect_err("a misspelt key");
        assert_eq!(e.path, "robot.tpi");
        let e = robot_from_json(&serde_json::json!({"joints": [{"alpah": 1}]})).expect_err("typo");
        assert_eq!(e.path, "robot.joints[0].alpah");
    }

    /// `{"mjcf": PATH, "tip"}` through the protocol: the UR5 that MuJoCo wrote from its URDF
    /// (testdata/mjcf) has MuJoCo's mass matrix at the reference's first q.
    #[test]
    fn an_mjcf_robot_answers_with_mujocos_mass_matrix() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../testdata/mjcf");
        let reference: Value = serde_json::from_str(
            &std::fs::read_to_string(format!("{dir}/mujoco_reference.json")).expect("reference"),
        )
        .expect("JSON");
        let ur5 = &reference["robots"][0];
        assert_eq!(ur5["name"], "ur5");
        let sample = &ur5["samples"][0];
        let req = serde_json::json!({"id": 1, "op": "mass_matrix",
            "robot": {"mjcf": format!("{dir}/ur5.xml"), "tip": "wrist_3_link"}, "q": sample["q"]});
        let a: Value = serde_json::from_str(&crate::handle_request(&req)).expect("answer");
        let ours = &a["mass_matrix"];
        let theirs = &sample["mass_matrix"];
        for r in 0..6 {
            for c in 0..6 {
                let (x, y) = (ours[r][c].as_f64(), theirs[r][c].as_f64().expect("number"));
                assert!(x.is_some_and(|x| (x - y).abs() < 1e-10), "{a}");
            }
        }
    }

    /// The dynamics crate's fixture robots equal `testdata/dynamics/robots/*.json`.
    #[test]
    fn fixture_robots_match_their_json() {
        for (name, text) in [
            (
                "puma560",
                include_str!("../../testdata/dynamics/robots/puma560.json"),
            ),
            (
                "stanford",
                include_str!("../../testdata/dynamics/robots/stanford.json"),
            ),
            (
                "panda",
                include_str!("../../testdata/dynamics/robots/panda.json"),
            ),
        ] {
            let v: Value = serde_json::from_str(text).expect("fixture JSON parses");
            let from_file = robot_from_json(&v).expect("fixture robot is valid");
            assert_eq!(
                robosim_dynamics::fixture_robot(name),
                Some(from_file),
                "{name}"
            );
        }
    }
}
