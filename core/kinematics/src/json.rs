//! The inline robot format of DESIGN.md ("The query protocol"), read and written by hand — the
//! one reader/writer of it, used by every op that takes or answers a robot and by the tests of
//! the core crates (their checked-in fixtures are in this form):
//! 4×4 transforms and 3×3 inertias are **row-major nested arrays** here, while nalgebra's serde
//! form is column-major and flat, so the conversion is explicit.
//!
//! Entry points: [`robot_from_json`], [`robot_to_json`], [`matrix4_from_json`],
//! [`matrix4_to_json`], [`matrix_to_json`], [`number`], [`number_array`]. Every error names the
//! field path (`joints[2].qlim[1]`). The query protocol's `{"urdf": PATH, "tip": LINK}` form
//! reads a file and lives with the protocol (`robosim_hl_interface::robot_json`), not here.

use crate::{Convention, Joint, JointType, Origin, Robot, RootJoint, RootKind};
use nalgebra::{Matrix3, Matrix4, Vector3};
use serde_json::{Map, Value, json};

/// A robot description (or a matrix inside a request) that could not be read.
#[derive(Debug, Clone)]
pub struct JsonError {
    /// Where: a field path such as `robot.joints[2].qlim`.
    pub path: String,
    /// Why, in words. When a reader below refused the value ([`Robot::validate`], a URDF or
    /// MJCF importer), this is that error's message and [`JsonError::source`] is the error.
    pub reason: String,
    /// The typed error of the reader below, if one refused the value ([`JsonError::caused`]):
    /// `std::error::Error::source` walks to it, and a caller can downcast it.
    pub source: Option<Cause>,
}

impl std::fmt::Display for JsonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.path, self.reason)
    }
}

/// The source is the reader's error itself (not the `Arc` around it), so it downcasts.
impl std::error::Error for JsonError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source
            .as_deref()
            .map(|e| e as &(dyn std::error::Error + 'static))
    }
}

/// The typed error behind a [`JsonError`] (shared so that the error stays `Clone`).
pub type Cause = std::sync::Arc<dyn std::error::Error + Send + Sync>;

impl JsonError {
    pub fn new(path: impl Into<String>, reason: impl Into<String>) -> Self {
        JsonError {
            path: path.into(),
            reason: reason.into(),
            source: None,
        }
    }

    /// `path` refused by a reader below with `source`: the reason is its message, and the
    /// error stays reachable, typed, through `source()`.
    pub fn caused(
        path: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        JsonError {
            path: path.into(),
            reason: source.to_string(),
            source: Some(std::sync::Arc::new(source)),
        }
    }
}

/// Equal when they say the same thing at the same place (a cause is compared by its message:
/// `dyn Error` has no equality).
impl PartialEq for JsonError {
    fn eq(&self, other: &Self) -> bool {
        self.path == other.path
            && self.reason == other.reason
            && self.source.as_ref().map(ToString::to_string)
                == other.source.as_ref().map(ToString::to_string)
    }
}

const JOINT_KEYS: &[&str] = &[
    "type",
    "a",
    "d",
    "alpha",
    "theta",
    "offset",
    "qlim",
    "mass",
    "com",
    "inertia",
    "motor_inertia",
    "viscous",
    "coulomb",
    "origin",
    "spherical",
];
const ORIGIN_KEYS: &[&str] = &["placement", "axis"];
const ROBOT_KEYS: &[&str] = &[
    "name",
    "convention",
    "joints",
    "parents",
    "gravity",
    "base",
    "tool",
    "source",
    "notes",
    "root",
];
const ROOT_KEYS: &[&str] = &["kind", "mass", "com", "inertia"];

/// Reads a robot in DESIGN.md's inline format and validates it ([`Robot::validate`]).
/// Unknown keys are refused (a misspelt `"alpah"` would otherwise silently be 0); `source` and
/// `notes` are free-form and ignored. Missing fields take [`Joint::default`] / [`Robot::default`].
pub fn robot_from_json(v: &Value) -> Result<Robot, JsonError> {
    let obj = v
        .as_object()
        .ok_or_else(|| JsonError::new("robot", "expected an object"))?;
    check_keys(obj, ROBOT_KEYS, "robot")?;
    let mut robot = Robot::default();
    if let Some(name) = obj.get("name") {
        robot.name = name
            .as_str()
            .ok_or_else(|| JsonError::new("robot.name", "expected a string"))?
            .to_owned();
    }
    if let Some(c) = obj.get("convention") {
        robot.convention = match c.as_str() {
            Some("standard") => Convention::Standard,
            Some("modified") => Convention::Modified,
            _ => {
                return Err(JsonError::new(
                    "robot.convention",
                    "expected \"standard\" or \"modified\"",
                ));
            }
        };
    }
    let joints = obj
        .get("joints")
        .ok_or_else(|| JsonError::new("robot.joints", "missing"))?
        .as_array()
        .ok_or_else(|| JsonError::new("robot.joints", "expected an array"))?;
    for (j, jv) in joints.iter().enumerate() {
        robot
            .joints
            .push(joint_from_json(jv, &format!("robot.joints[{j}]"))?);
    }
    if let Some(p) = obj.get("parents") {
        let arr = p
            .as_array()
            .ok_or_else(|| JsonError::new("robot.parents", "expected an array of link frames"))?;
        robot.parents = arr
            .iter()
            .enumerate()
            .map(|(k, v)| {
                v.as_u64().map(|x| x as usize).ok_or_else(|| {
                    JsonError::new(
                        format!("robot.parents[{k}]"),
                        "expected a link frame number (0 = the base)",
                    )
                })
            })
            .collect::<Result<_, _>>()?;
    }
    if let Some(g) = obj.get("gravity") {
        robot.gravity = vector3(g, "robot.gravity")?;
    }
    if let Some(b) = obj.get("base") {
        robot.base = matrix4_from_json(b, "robot.base")?;
    }
    if let Some(t) = obj.get("tool") {
        robot.tool = matrix4_from_json(t, "robot.tool")?;
    }
    if let Some(r) = obj.get("root").filter(|r| !r.is_null()) {
        robot.root = Some(root_from_json(r)?);
    }
    robot
        .validate()
        .map_err(|e| JsonError::caused("robot", e))?;
    Ok(robot)
}

/// `"root": {"kind": "free_flyer" | "planar", "mass", "com", "inertia"}`: a floating base
/// (see [`crate::root`]; q is then `[q_root, q_joints]`).
fn root_from_json(v: &Value) -> Result<RootJoint, JsonError> {
    let path = "robot.root";
    let obj = v
        .as_object()
        .ok_or_else(|| JsonError::new(path, "expected an object"))?;
    check_keys(obj, ROOT_KEYS, path)?;
    let kind = obj
        .get("kind")
        .and_then(Value::as_str)
        .and_then(RootKind::from_name)
        .ok_or_else(|| {
            JsonError::new(
                "robot.root.kind",
                "expected \"free_flyer\" (q: x y z qx qy qz qw, v: vx vy vz wx wy wz) or \"planar\" (q: x y cos sin, v: vx vy wz)",
            )
        })?;
    let mut root = RootJoint::new(kind);
    if let Some(m) = obj.get("mass") {
        root.mass = number(m, "robot.root.mass")?;
    }
    if let Some(c) = obj.get("com") {
        root.com = vector3(c, "robot.root.com")?;
    }
    if let Some(i) = obj.get("inertia") {
        root.inertia = matrix3_from_json(i, "robot.root.inertia")?;
    }
    Ok(root)
}

fn joint_from_json(v: &Value, path: &str) -> Result<Joint, JsonError> {
    let obj = v
        .as_object()
        .ok_or_else(|| JsonError::new(path, "expected an object"))?;
    check_keys(obj, JOINT_KEYS, path)?;
    let mut joint = Joint::default();
    if let Some(t) = obj.get("type") {
        joint.joint_type = match t.as_str() {
            Some("revolute") => JointType::Revolute,
            Some("prismatic") => JointType::Prismatic,
            _ => {
                return Err(JsonError::new(
                    format!("{path}.type"),
                    "expected \"revolute\" or \"prismatic\"",
                ));
            }
        };
    }
    for (key, slot) in [
        ("a", &mut joint.a),
        ("d", &mut joint.d),
        ("alpha", &mut joint.alpha),
        ("theta", &mut joint.theta),
        ("offset", &mut joint.offset),
        ("mass", &mut joint.mass),
        ("motor_inertia", &mut joint.motor_inertia),
        ("viscous", &mut joint.viscous),
        ("coulomb", &mut joint.coulomb),
    ] {
        if let Some(x) = obj.get(key) {
            *slot = number(x, &format!("{path}.{key}"))?;
        }
    }
    if let Some(q) = obj.get("qlim") {
        let p = format!("{path}.qlim");
        let arr = fixed_array(q, 2, &p)?;
        // Infinite limits cannot be written in JSON; null means unlimited on that side.
        let lo = if arr[0].is_null() {
            f64::NEG_INFINITY
        } else {
            number(&arr[0], &format!("{p}[0]"))?
        };
        let hi = if arr[1].is_null() {
            f64::INFINITY
        } else {
            number(&arr[1], &format!("{p}[1]"))?
        };
        joint.qlim = [lo, hi];
    }
    if let Some(c) = obj.get("com") {
        joint.com = vector3(c, &format!("{path}.com"))?;
    }
    if let Some(i) = obj.get("inertia") {
        joint.inertia = matrix3_from_json(i, &format!("{path}.inertia"))?;
    }
    match obj.get("origin") {
        None | Some(Value::Null) => {}
        Some(o) => {
            let p = format!("{path}.origin");
            let map = o.as_object().ok_or_else(|| {
                JsonError::new(&p, "expected {\"placement\": 4×4, \"axis\": [x, y, z]}")
            })?;
            check_keys(map, ORIGIN_KEYS, &p)?;
            let placement = map
                .get("placement")
                .ok_or_else(|| JsonError::new(format!("{p}.placement"), "missing"))
                .and_then(|v| matrix4_from_json(v, &format!("{p}.placement")))?;
            let axis = map
                .get("axis")
                .ok_or_else(|| JsonError::new(format!("{p}.axis"), "missing"))
                .and_then(|v| vector3(v, &format!("{p}.axis")))?;
            joint.origin = Some(Origin { placement, axis });
        }
    }
    // A spherical (ball) joint: 4 q, 3 v (`crate::spherical`); absent or false: one coordinate.
    if let Some(s) = obj.get("spherical") {
        joint.spherical = s
            .as_bool()
            .ok_or_else(|| JsonError::new(format!("{path}.spherical"), "expected true or false"))?;
    }
    Ok(joint)
}

/// Refuses a key of `obj` that is not in `allowed`, naming it by its path (`path.key`).
pub fn check_keys(obj: &Map<String, Value>, allowed: &[&str], path: &str) -> Result<(), JsonError> {
    for key in obj.keys() {
        if !allowed.contains(&key.as_str()) {
            return Err(JsonError::new(
                format!("{path}.{key}"),
                format!("unknown field (expected one of {})", allowed.join(", ")),
            ));
        }
    }
    Ok(())
}

/// A finite number at `path`.
pub fn number(v: &Value, path: &str) -> Result<f64, JsonError> {
    let x = v
        .as_f64()
        .ok_or_else(|| JsonError::new(path, format!("expected a number, got {v}")))?;
    if !x.is_finite() {
        return Err(JsonError::new(path, "not finite"));
    }
    Ok(x)
}

fn fixed_array<'a>(v: &'a Value, n: usize, path: &str) -> Result<&'a Vec<Value>, JsonError> {
    let arr = v
        .as_array()
        .ok_or_else(|| JsonError::new(path, format!("expected an array of {n}")))?;
    if arr.len() != n {
        return Err(JsonError::new(
            path,
            format!("expected {n} entries, got {}", arr.len()),
        ));
    }
    Ok(arr)
}

/// A vector of finite numbers of any length at `path`.
pub fn number_array(v: &Value, path: &str) -> Result<Vec<f64>, JsonError> {
    let arr = v
        .as_array()
        .ok_or_else(|| JsonError::new(path, "expected an array of numbers"))?;
    arr.iter()
        .enumerate()
        .map(|(i, x)| number(x, &format!("{path}[{i}]")))
        .collect()
}

/// A 3-vector of finite numbers at `path`.
pub fn vector3(v: &Value, path: &str) -> Result<Vector3<f64>, JsonError> {
    let arr = fixed_array(v, 3, path)?;
    Ok(Vector3::new(
        number(&arr[0], &format!("{path}[0]"))?,
        number(&arr[1], &format!("{path}[1]"))?,
        number(&arr[2], &format!("{path}[2]"))?,
    ))
}

fn rows<const N: usize>(v: &Value, path: &str) -> Result<[[f64; N]; N], JsonError> {
    let arr = fixed_array(v, N, path)?;
    let mut out = [[0.0; N]; N];
    // The element paths are formatted only for an error (a pose is read per request).
    for (i, row) in arr.iter().enumerate() {
        let r = match row.as_array() {
            Some(r) if r.len() == N => r,
            _ => fixed_array(row, N, &format!("{path}[{i}]"))?,
        };
        for (j, x) in r.iter().enumerate() {
            out[i][j] = match x.as_f64() {
                Some(f) if f.is_finite() => f,
                _ => number(x, &format!("{path}[{i}][{j}]"))?,
            };
        }
    }
    Ok(out)
}

/// A 4×4 matrix from nested row-major arrays (`m[i]` is row i).
pub fn matrix4_from_json(v: &Value, path: &str) -> Result<Matrix4<f64>, JsonError> {
    let r = rows::<4>(v, path)?;
    Ok(Matrix4::from_fn(|i, j| r[i][j]))
}

/// A 3×3 matrix from nested row-major arrays.
pub fn matrix3_from_json(v: &Value, path: &str) -> Result<Matrix3<f64>, JsonError> {
    let r = rows::<3>(v, path)?;
    Ok(Matrix3::from_fn(|i, j| r[i][j]))
}

/// Nested row-major arrays of any matrix (`m[i]` is row i).
pub fn matrix_to_json<R: nalgebra::Dim, C: nalgebra::Dim, S: nalgebra::RawStorage<f64, R, C>>(
    m: &nalgebra::Matrix<f64, R, C, S>,
) -> Value {
    Value::Array(
        (0..m.nrows())
            .map(|i| Value::Array((0..m.ncols()).map(|j| json!(m[(i, j)])).collect()))
            .collect(),
    )
}

/// A 4×4 transform as nested row-major arrays.
pub fn matrix4_to_json(m: &Matrix4<f64>) -> Value {
    matrix_to_json(m)
}

fn limit_to_json(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// Writes a robot in the inline format ([`robot_from_json`] reads it back unchanged).
pub fn robot_to_json(robot: &Robot) -> Value {
    let joints: Vec<Value> = robot
        .joints
        .iter()
        .map(|j| {
            let mut v = json!({
                "type": match j.joint_type { JointType::Revolute => "revolute", JointType::Prismatic => "prismatic" },
                "a": j.a, "d": j.d, "alpha": j.alpha, "theta": j.theta, "offset": j.offset,
                "qlim": [limit_to_json(j.qlim[0]), limit_to_json(j.qlim[1])],
                "mass": j.mass, "com": [j.com.x, j.com.y, j.com.z], "inertia": matrix_to_json(&j.inertia),
                "motor_inertia": j.motor_inertia, "viscous": j.viscous, "coulomb": j.coulomb,
            });
            // A general joint (URDF's origin and axis) carries them; a DH row does not.
            if let (Some(o), Some(m)) = (&j.origin, v.as_object_mut()) {
                m.insert(
                    "origin".into(),
                    json!({
                        "placement": matrix4_to_json(&o.placement),
                        "axis": [o.axis.x, o.axis.y, o.axis.z],
                    }),
                );
            }
            // written only for a spherical joint: the others' JSON is unchanged
            if let (true, Some(m)) = (j.spherical, v.as_object_mut()) {
                m.insert("spherical".into(), Value::Bool(true));
            }
            v
        })
        .collect();
    let mut out = json!({
        "name": robot.name,
        "convention": match robot.convention { Convention::Standard => "standard", Convention::Modified => "modified" },
        "joints": joints,
        "gravity": [robot.gravity.x, robot.gravity.y, robot.gravity.z],
        "base": matrix4_to_json(&robot.base),
        "tool": matrix4_to_json(&robot.tool),
    });
    if !robot.parents.is_empty()
        && let Some(m) = out.as_object_mut()
    {
        m.insert("parents".into(), json!(robot.parents));
    }
    if let (Some(r), Some(m)) = (&robot.root, out.as_object_mut()) {
        m.insert(
            "root".into(),
            json!({
                "kind": r.kind.name(), "mass": r.mass, "com": [r.com.x, r.com.y, r.com.z],
                "inertia": matrix_to_json(&r.inertia),
            }),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A general-joint tree (what `get_robot` answers for a URDF robot) reads back as itself:
    /// origins, axes and parents survive the inline form (before, they were dropped, and the
    /// session's kinv and jacob silently solved an all-zero DH chain).
    #[test]
    fn general_joints_and_trees_round_trip() {
        let mut robot = Robot {
            name: "y".into(),
            parents: vec![0, 1, 1],
            ..Robot::default()
        };
        for k in 0..3 {
            let mut placement = Matrix4::identity();
            placement[(0, 3)] = 0.1 * (k + 1) as f64;
            placement[(2, 3)] = -0.05;
            robot.joints.push(Joint {
                joint_type: if k == 2 {
                    JointType::Prismatic
                } else {
                    JointType::Revolute
                },
                qlim: [-1.0, 1.0],
                origin: Some(Origin {
                    placement,
                    axis: Vector3::new(0.0, 0.6, 0.8),
                }),
                ..Joint::default()
            });
        }
        let v = robot_to_json(&robot);
        assert_eq!(v["parents"], json!([0, 1, 1]));
        let back = robot_from_json(&v).expect("reads back");
        assert_eq!(back, robot);
        // A DH chain writes neither field.
        let dh = robot_to_json(&Robot {
            joints: vec![Joint::default()],
            ..Robot::default()
        });
        assert!(dh.get("parents").is_none() && dh["joints"][0].get("origin").is_none());
        let mut bad = v.clone();
        bad["joints"][0]["origin"]["axis"] = json!([0, 0]);
        let e = robot_from_json(&bad).expect_err("a short axis");
        assert!(e.to_string().contains("robot.joints[0].origin.axis"), "{e}");
    }

    #[test]
    fn transforms_are_row_major() {
        let v = json!([[1, 0, 0, 5], [0, 1, 0, 6], [0, 0, 1, 7], [0, 0, 0, 1]]);
        let m = matrix4_from_json(&v, "m").expect("valid matrix");
        assert_eq!((m[(0, 3)], m[(1, 3)], m[(2, 3)]), (5.0, 6.0, 7.0));
        assert_eq!(
            matrix4_to_json(&m),
            json!([
                [1.0, 0.0, 0.0, 5.0],
                [0.0, 1.0, 0.0, 6.0],
                [0.0, 0.0, 1.0, 7.0],
                [0.0, 0.0, 0.0, 1.0]
            ])
        );
    }

    #[test]
    fn errors_name_the_field() {
        let v = json!({"joints": [{"a": 1}, {"qlim": [0, "x"]}]});
        let e = robot_from_json(&v).expect_err("bad qlim");
        assert_eq!(e.path, "robot.joints[1].qlim[1]");
        let v = json!({"joints": [{"alpah": 1}]});
        assert_eq!(
            robot_from_json(&v).expect_err("typo").path,
            "robot.joints[0].alpah"
        );
        let v =
            json!({"joints": [], "base": [[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]});
        assert!(
            robot_from_json(&v)
                .expect_err("not rigid")
                .reason
                .contains("base")
        );
        let v = json!({"joints": [{"qlim": [1, -1]}]});
        assert!(
            robot_from_json(&v)
                .expect_err("reversed")
                .reason
                .contains("joint 0")
        );
        // a matrix's element paths (formatted only on error)
        let m = json!([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, "x"], [0, 0, 0, 1]]);
        assert_eq!(
            matrix4_from_json(&m, "pose").expect_err("x").path,
            "pose[2][3]"
        );
        let m = json!([[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
        let e = matrix4_from_json(&m, "pose").expect_err("short row");
        assert_eq!(
            (e.path.as_str(), e.reason.as_str()),
            ("pose[1]", "expected 4 entries, got 3")
        );
    }

    /// A robot that reads but does not validate keeps the model's typed error as its source.
    #[test]
    fn an_invalid_robot_keeps_the_model_error() {
        let e = robot_from_json(&json!({"joints": [{"qlim": [1, -1]}]})).expect_err("reversed");
        assert_eq!(e.path, "robot");
        let cause = std::error::Error::source(&e).expect("the model's error");
        assert_eq!(
            cause.downcast_ref::<crate::ModelError>(),
            Some(&crate::ModelError::ReversedLimits {
                joint: 0,
                lo: 1.0,
                hi: -1.0
            })
        );
        assert_eq!(e.to_string(), format!("robot: {cause}"));
    }

    /// The robots the kinematics crate writes out as Rust equal their checked-in JSON files.
    #[test]
    fn builtin_robots_match_their_json() {
        for (name, text) in [
            (
                "puma560",
                include_str!("../../../testdata/kinematics/puma560.json"),
            ),
            (
                "stanford",
                include_str!("../../../testdata/kinematics/stanford.json"),
            ),
            (
                "panda",
                include_str!("../../../testdata/kinematics/panda.json"),
            ),
        ] {
            let v: Value = serde_json::from_str(text).expect("shipped JSON parses");
            let from_file = robot_from_json(&v).expect("shipped robot is valid");
            assert_eq!(crate::builtin_robot(name), Some(from_file), "{name}");
        }
    }
}
