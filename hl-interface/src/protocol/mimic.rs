//! Mimic joints over the reduced coordinates (issue 36): `"mimic": true` on a file robot,
//! `{"urdf": PATH, "mimic": true, …}` (with `tip` the chain to it and the followers of its joints
//! that hang off it — a gripper's second finger —, with `floating` the tree on a
//! floating root, with neither **the whole tree** — not `{"urdf": PATH}`'s chain to the only
//! leaf: mimic joints are mostly on branches, a gripper's fingers) or
//! `{"mjcf": PATH, "mimic": true, …}` (MuJoCo's `<equality><joint>`), for `fk`, `jacobian`,
//! `id`, `fd`, `mass_matrix` and `gravity`.
//!
//! The robot is the file's full model (every movable joint a coordinate, what the other ops
//! use) and the file's coupling ([`robosim_kinematics::mimic::Coupling`]: a follower's
//! `q = multiplier · q_leader + offset`); q, v, q̈ and τ are the **reduced** coordinates — the
//! full ones without the followers, in the same order (a floating root's first), Pinocchio
//! 4.1's `buildModel(…, mimic=True)` layout. The answers have the ops' usual fields over the
//! reduced coordinates: fk's poses at `φ(q_r)`, the Jacobian `J G` (6 × reduced nv, its
//! singular values those of `J G`), `τ_r = Gᵀ τ`, `M_r = Gᵀ M G`, `g_r = Gᵀ g`, and `q̈_r`
//! solving `M_r q̈_r = τ_r − Gᵀ b` (Cholesky: Pinocchio's ABA refuses mimic joints, so `fd`
//! here has no `method`), plus `"coordinates"`: the full-model index of each reduced one. A
//! robot without mimic joints answers as without the option. Not with it: `passive`, inline
//! or library robots (they carry no coupling), session robots, the other ops.

use super::RobotArg;
use super::finite::check;
use crate::robot_json::{JsonError, matrix_to_json, number_array};
use crate::{ErrorKind, ProtocolError};
use robosim_dynamics::{Data, Model};
use robosim_kinematics::Robot;
use robosim_kinematics::jacobian::{Frame, Jacobian, singularity};
use robosim_kinematics::mimic::{Coupling, MimicError};
use serde_json::{Map, Value, json};
use std::path::Path;

/// The ops that take `"mimic": true`.
pub const OPS: &[&str] = &["fk", "jacobian", "id", "fd", "mass_matrix", "gravity"];

/// Answers `op` when the request's `robot` is a file robot with `"mimic": true`; `None`
/// otherwise (the op then goes where it always goes).
pub fn dispatch(op: &str, req: &Value) -> Option<Result<Value, ProtocolError>> {
    let obj = req.get("robot")?.as_object()?;
    if obj.get("mimic") != Some(&Value::Bool(true)) {
        return None;
    }
    if !OPS.contains(&op) {
        return Some(Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!(
                "`mimic` is for {}, not {op} (the other ops take the full model: leave `mimic` out)",
                OPS.join(", ")
            ),
        )));
    }
    Some(answer(op, req, obj))
}

fn invalid_robot(e: JsonError) -> ProtocolError {
    ProtocolError::new(
        ErrorKind::InvalidRobot,
        format!("robot description, `{}`: {}", e.path, e.reason),
    )
}

fn mimic_error(field: &str, e: MimicError) -> ProtocolError {
    ProtocolError::new(ErrorKind::BadRequest, format!("{field}: {e}"))
}

/// A file robot with `"mimic": true` (a request's `robot` object, the forms above): the file's
/// full model and its coupling, as the ops here use them (`robosim.Model(…, mimic=True)`).
pub fn robot_and_coupling_of(robot: &Value) -> Result<(Robot, Coupling), ProtocolError> {
    let obj = robot.as_object().ok_or_else(|| {
        invalid_robot(JsonError::new(
            "robot",
            "expected a file robot ({\"urdf\": PATH, …} or {\"mjcf\": PATH, …})",
        ))
    })?;
    robot_and_coupling(obj).map_err(invalid_robot)
}

/// The file's robot and its coupling (the identity for a file without mimic joints).
fn robot_and_coupling(obj: &Map<String, Value>) -> Result<(Robot, Coupling), JsonError> {
    let mut rest = obj.clone();
    rest.remove("mimic");
    let imported = if let Some(path) = rest.get("urdf") {
        let path = path
            .as_str()
            .ok_or_else(|| {
                JsonError::new("robot.urdf", "expected the URDF file's path (a string)")
            })?
            .to_owned();
        let tip = string(&rest, "tip")?;
        for k in rest.keys() {
            if !matches!(k.as_str(), "urdf" | "tip" | "floating") {
                return Err(JsonError::new(
                    format!("robot.{k}"),
                    "unknown key (urdf, tip, floating, mimic)",
                ));
            }
        }
        let floating = crate::robot_json::floating_field(&rest)?;
        match (floating, tip) {
            (Some(_), Some(_)) => {
                return Err(JsonError::new(
                    "robot.tip",
                    "a floating robot is the URDF's whole tree: leave `tip` out",
                ));
            }
            (Some(kind), None) => {
                robosim_file_io::urdf_import::import_urdf_tree_floating(Path::new(&path), kind)
                    .map_err(|e| JsonError::caused("robot.urdf", e))?
            }
            // the chain to the tip with its off-chain followers moving (a gripper's second
            // finger): the reduced coordinates are the chain's
            (None, Some(tip)) => robosim_file_io::urdf_import::import_urdf_with_followers(
                Path::new(&path),
                Some(&tip),
            )
            .map_err(|e| JsonError::caused("robot.urdf", e))?,
            // mimic joints are mostly on branches (a gripper's fingers): without a tip, the
            // whole tree (Pinocchio's model), not the chain to the only leaf
            (None, None) => robosim_file_io::urdf_import::import_urdf_tree(Path::new(&path))
                .map_err(|e| JsonError::caused("robot.urdf", e))?,
        }
    } else if let Some(path) = rest.get("mjcf") {
        let path = path
            .as_str()
            .ok_or_else(|| {
                JsonError::new("robot.mjcf", "expected the MJCF file's path (a string)")
            })?
            .to_owned();
        for k in rest.keys() {
            if !matches!(k.as_str(), "mjcf" | "tip") {
                return Err(JsonError::new(
                    format!("robot.{k}"),
                    "unknown key (mjcf, tip, mimic)",
                ));
            }
        }
        let tip = string(&rest, "tip")?;
        robosim_file_io::mjcf::import_mjcf(Path::new(&path), tip.as_deref())
            .map_err(|e| JsonError::caused("robot.mjcf", e))?
    } else {
        return Err(JsonError::new(
            "robot.mimic",
            "only a file robot ({\"urdf\": PATH, …} or {\"mjcf\": PATH, …}) has mimic joints",
        ));
    };
    let robot = imported.robot;
    let coupling = imported.coupling.unwrap_or_else(|| {
        Coupling::identity(robot.dof()).with_root(robot.root_nq(), robot.root_nv())
    });
    Ok((robot, coupling))
}

fn string(obj: &Map<String, Value>, key: &str) -> Result<Option<String>, JsonError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_str()
            .map(|s| Some(s.to_owned()))
            .ok_or_else(|| JsonError::new(format!("robot.{key}"), "expected a name (a string)")),
    }
}

/// The request's reduced vector `key` of `n` values (`what` says what n counts).
fn reduced(req: &Value, key: &str, n: usize, what: &str) -> Result<Vec<f64>, ProtocolError> {
    let v = req.get(key).ok_or_else(|| {
        ProtocolError::new(ErrorKind::InvalidRequest, format!("missing field `{key}`"))
    })?;
    let x = number_array(v, key)?;
    if x.len() != n {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!(
                "{key}: {} values but the robot has {n} {what} (mimic: the followers are not coordinates)",
                x.len()
            ),
        ));
    }
    Ok(x)
}

fn answer(op: &str, req: &Value, obj: &Map<String, Value>) -> Result<Value, ProtocolError> {
    let (robot, coupling) = robot_and_coupling(obj).map_err(invalid_robot)?;
    answer_given(op, req, &robot, &coupling)
}

/// Answers `op` (one of [`OPS`]) over the reduced coordinates of `robot` under `coupling`: the
/// request's `q`, `qd`, `qdd`, `tau` are reduced; its `robot` field is not read. What a file
/// robot with `"mimic": true` answers, and a session robot with mimic joints
/// (`Kinematics::Mimic` records) by name.
pub fn answer_given(
    op: &str,
    req: &Value,
    robot: &Robot,
    coupling: &Coupling,
) -> Result<Value, ProtocolError> {
    if !OPS.contains(&op) {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!(
                "robot {} has mimic joints: {op} is not taken on it (its reduced coordinates are taken by {})",
                robot.name,
                OPS.join(", ")
            ),
        ));
    }
    if req
        .get("passive")
        .is_some_and(|p| !p.is_null() && p != &Value::Bool(false))
    {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            "`passive` is not taken with `mimic` (the friction of a coupled joint pair is not modelled)",
        ));
    }
    let (nq, nv) = (coupling.reduced_nq(), coupling.reduced_nv());
    let qr = reduced(req, "q", nq, "reduced coordinates")?;
    let q = coupling.expand_q(&qr).map_err(|e| mimic_error("q", e))?;
    robot
        .check_q(&q)
        .map_err(|e| ProtocolError::new(ErrorKind::BadRequest, format!("q: {e}")))?;
    let coordinates = json!(coupling.free());
    let mut out = match op {
        "fk" => {
            let mut full = req.clone();
            full["q"] = json!(q);
            super::kinematics::dispatch_with("fk", &full, RobotArg::Given(robot))
                .unwrap_or_else(|| Err(ProtocolError::new(ErrorKind::UnknownOp, "fk")))?
        }
        "jacobian" => {
            let frame = super::kinematics::frame_field(req)?;
            let jr = robosim_kinematics::mimic::jacobian(robot, coupling, &qr, frame)
                .map_err(|e| mimic_error("jacobian", e))?;
            let j = Jacobian::from_fn(jr.ncols(), |r, c| jr[(r, c)]);
            check("jacobian", &j)?;
            let s = singularity(&j);
            check("singularity.sigma_min", &s.sigma_min)?;
            check("singularity.sigma_max", &s.sigma_max)?;
            check("singularity.manipulability", &s.manipulability)?;
            json!({
                "jacobian": matrix_to_json(&j),
                "frame": if frame == Frame::Base { "base" } else { "tool" },
                "singularity": {
                    "sigma_min": s.sigma_min, "sigma_max": s.sigma_max,
                    "manipulability": s.manipulability,
                    "condition": if s.condition.is_finite() { json!(s.condition) } else { Value::Null },
                },
            })
        }
        _ => {
            let model = Model::new(robot)?;
            let mut data = Data::new(&model);
            match op {
                "id" => {
                    let (v, a) = (
                        reduced(req, "qd", nv, "reduced velocities")?,
                        reduced(req, "qdd", nv, "reduced velocities")?,
                    );
                    let tau = robosim_dynamics::mimic::rnea_mimic(
                        &model, &mut data, coupling, &qr, &v, &a,
                    )?;
                    check("tau", tau.as_slice())?;
                    json!({ "tau": tau.as_slice() })
                }
                "gravity" => {
                    let tau =
                        robosim_dynamics::mimic::gravity_mimic(&model, &mut data, coupling, &qr)?;
                    check("tau", tau.as_slice())?;
                    json!({ "tau": tau.as_slice() })
                }
                "mass_matrix" => {
                    let m = robosim_dynamics::mimic::crba_mimic(&model, &mut data, coupling, &qr)?;
                    check("mass_matrix", &m)?;
                    let rows: Vec<Vec<f64>> = (0..m.nrows())
                        .map(|r| m.row(r).iter().copied().collect())
                        .collect();
                    json!({ "mass_matrix": rows })
                }
                _ => {
                    if req.get("method").is_some_and(|m| !m.is_null()) {
                        return Err(ProtocolError::new(
                            ErrorKind::BadRequest,
                            "`method` is not taken with `mimic`: the reduced forward dynamics is solved by Cholesky of M_r (Pinocchio's ABA refuses mimic joints too)",
                        ));
                    }
                    let (v, tau) = (
                        reduced(req, "qd", nv, "reduced velocities")?,
                        reduced(req, "tau", nv, "reduced velocities")?,
                    );
                    let qdd = robosim_dynamics::mimic::aba_mimic(
                        &model, &mut data, coupling, &qr, &v, &tau,
                    )?;
                    check("qdd", qdd.as_slice())?;
                    json!({ "qdd": qdd.as_slice() })
                }
            }
        }
    };
    out["coordinates"] = coordinates;
    Ok(out)
}
