//! The kinematics ops of the query protocol (DESIGN.md, "The query protocol"): `fk`, `jacobian`,
//! `ik`, `encoder_error`. Requests and answers are JSON values; the transport (JSON lines,
//! iceoryx2) and the `id`/`ok` envelope are the caller's.
//!
//! Entry point: [`dispatch`]. Fields beyond DESIGN.md's table: `fk` answers `frames` when
//! asked; `jacobian` adds `singularity` {sigma_min, sigma_max, manipulability, condition};
//! `ik` takes `tolerances` {position, orientation} (a number or three per-axis numbers, target
//! frame, null for a free axis), `max_iterations`, `restarts`, `seed`, `respect_limits`, and
//! answers `method` (the one used) and per solution `branch` (Corke's label, e.g. "lun"),
//! `residual` {position, orientation}, `converged`, `within_limits`, `iterations`, `notes`;
//! `encoder_error` takes `bits` (one number for all joints or one per joint) and answers
//! `position`, `orientation`, `per_axis` [dx dy dz rx ry rz], `position_worst_case`,
//! `orientation_worst_case`, `resolution`. For a robot with a floating `root` q has nq values
//! and a Jacobian nv columns (the root's first). `ik` on such a robot holds the root where the
//! request's `q0` (nq values, required) puts it and moves the joints of the chain from the base
//! link to link frame `link` (1..=n, default n: the tip where the tool hangs), answering full
//! q's (nq) with the root and every other joint as in `q0`; `encoder_error` bounds the tool's
//! error from the n joint encoders with the root held at q (the Jacobian's joint columns,
//! nv-index root_nv + k; the root has no encoder).

use super::RobotArg;
use super::finite::check;
use crate::robot_json::{
    matrix_to_json, matrix4_from_json, matrix4_to_json, number, number_array, robot_from_json,
};
use crate::{ErrorKind, ProtocolError};
use nalgebra::Matrix4;
use robosim_kinematics::encoder::{EncoderErrorError, encoder_error};
use robosim_kinematics::ik::{self, IkError, IkOptions, IkSolution, Method, Note};
use robosim_kinematics::jacobian::{Frame, Jacobian, singularity, to_tool_frame};
use robosim_kinematics::pose::Tolerances;
use robosim_kinematics::{KinematicModel, Robot, RootKind, builtin_robot};
use serde_json::{Value, json};
use std::borrow::Cow;

/// Answers `op` if it is a kinematics op, else `None`. `robots` resolves library names;
/// names it does not know fall back to [`builtin_robot`].
pub fn dispatch(
    op: &str,
    req: &Value,
    robots: &dyn Fn(&str) -> Option<Robot>,
) -> Option<Result<Value, ProtocolError>> {
    dispatch_with(op, req, RobotArg::Request(robots))
}

/// [`dispatch`] with the robot given: by the request ([`RobotArg::Request`]) or typed by the
/// caller ([`RobotArg::Given`], a session's compiled robot; the request's `robot` is not read).
pub fn dispatch_with(
    op: &str,
    req: &Value,
    robot: RobotArg<'_>,
) -> Option<Result<Value, ProtocolError>> {
    let f = match op {
        "fk" => op_fk,
        "jacobian" => op_jacobian,
        "ik" => op_ik,
        "encoder_error" => op_encoder_error,
        _ => return None,
    };
    Some(f(req, robot))
}

fn robot<'a>(req: &Value, arg: RobotArg<'a>) -> Result<Cow<'a, Robot>, ProtocolError> {
    let robots = match arg {
        RobotArg::Given(r) => return Ok(Cow::Borrowed(r)),
        RobotArg::Request(robots) => robots,
    };
    match req.get("robot") {
        None => Err(ProtocolError::new(ErrorKind::BadRequest, "robot: missing")),
        Some(Value::String(name)) => robots(name)
            .or_else(|| builtin_robot(name))
            .map(Cow::Owned)
            .ok_or_else(|| {
                ProtocolError::new(
                    ErrorKind::UnknownRobot,
                    format!("robot: no robot named \"{name}\""),
                )
            }),
        Some(v @ Value::Object(_)) => robot_from_json(v)
            .map(Cow::Owned)
            .map_err(|e| ProtocolError::caused(ErrorKind::BadRobot, e)),
        Some(_) => Err(ProtocolError::new(
            ErrorKind::BadRequest,
            "robot: expected a library name or an inline robot object",
        )),
    }
}

fn q_field(req: &Value, key: &str, robot: &Robot) -> Result<Vec<f64>, ProtocolError> {
    let v = req
        .get(key)
        .ok_or_else(|| ProtocolError::new(ErrorKind::BadRequest, format!("{key}: missing")))?;
    let q = number_array(v, key)?;
    let (n, what) = expected_len(robot, false);
    if q.len() != n {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!("{key}: {} values but the robot has {what}", q.len()),
        ));
    }
    if robot.root.is_some() || robot.has_spherical() {
        robot
            .check_q(&q)
            .map_err(|e| ProtocolError::new(ErrorKind::BadRequest, format!("{key}: {e}")))?;
    }
    Ok(q)
}

/// The length a configuration (`velocity` false: [`Robot::nq`]) or a velocity, acceleration or
/// torque (`velocity` true: [`Robot::nv`]) must have, and how to say it in an error: "6 joints"
/// for a fixed base (the wording of every fixed-base answer), "nq = 19 (a free_flyer root's 7
/// coordinates x y z qx qy qz qw, then 12 joints)" for a floating one.
pub(super) fn expected_len(robot: &Robot, velocity: bool) -> (usize, String) {
    let Some(root) = &robot.root else {
        if robot.has_spherical() {
            // a ball joint has 4 coordinates in q (qx qy qz qw) and 3 in v, τ, q̈
            let (name, n, per) = if velocity {
                ("nv", robot.nv(), "3 (wx wy wz)")
            } else {
                ("nq", robot.nq(), "4 (qx qy qz qw)")
            };
            return (
                n,
                format!(
                    "{name} = {n} ({} joints, of which {} ball joints with {per} each)",
                    robot.dof(),
                    robot.spherical_count()
                ),
            );
        }
        return (robot.dof(), format!("{} joints", robot.dof()));
    };
    let (name, n, r, layout) = match (root.kind, velocity) {
        (RootKind::FreeFlyer, false) => ("nq", robot.nq(), 7, "x y z qx qy qz qw"),
        (RootKind::FreeFlyer, true) => ("nv", robot.nv(), 6, "vx vy vz wx wy wz"),
        (RootKind::Planar, false) => ("nq", robot.nq(), 4, "x y cos sin"),
        (RootKind::Planar, true) => ("nv", robot.nv(), 3, "vx vy wz"),
    };
    (
        n,
        format!(
            "{name} = {n} (a {} root's {r} coordinates {layout}, then {} joints)",
            root.kind.name(),
            robot.dof()
        ),
    )
}

/// `ik` and `encoder_error` work on the joints of a fixed base: a floating robot is refused.
/// A floating robot with its root held at `q`'s root coordinates: the same joints and tool on
/// a fixed base at `base · root(q)`, and `q`'s joint values (its last `dof`). `None` for a
/// fixed-base robot. Its link frames and Jacobian columns are the floating robot's at `q`
/// (column k is the floating robot's nv-index `root_nv + k`).
fn root_held(robot: &Robot, q: &[f64]) -> Option<(Robot, Vec<f64>)> {
    let root = robot.root.as_ref()?;
    let (q_root, q_joints) = q.split_at(robot.root_nq());
    let held = Robot {
        base: robot.base * root.kind.transform(q_root),
        root: None,
        ..robot.clone()
    };
    Some((held, q_joints.to_vec()))
}

fn bool_field(req: &Value, key: &str, default: bool) -> Result<bool, ProtocolError> {
    match req.get(key) {
        None | Some(Value::Null) => Ok(default),
        Some(Value::Bool(b)) => Ok(*b),
        Some(_) => Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!("{key}: expected true or false"),
        )),
    }
}

fn uint_field(req: &Value, key: &str, default: u64, max: u64) -> Result<u64, ProtocolError> {
    match req.get(key) {
        None | Some(Value::Null) => Ok(default),
        Some(v) => match v.as_u64() {
            Some(x) if x <= max => Ok(x),
            _ => Err(ProtocolError::new(
                ErrorKind::BadRequest,
                format!("{key}: expected an integer in 0..={max}"),
            )),
        },
    }
}

fn op_fk(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let robot = robot(req, arg)?;
    let q = q_field(req, "q", &robot)?;
    // Compiled once for the request (the frames and the pose read the same model).
    let kin = KinematicModel::new(&robot);
    if bool_field(req, "frames", false)? {
        let mut frames = vec![Matrix4::identity(); kin.dof() + 2];
        kin.link_frames_into(&q, &mut frames);
        let pose = frames.last().copied().unwrap_or_else(|| kin.forward(&q));
        check("pose", &pose)?;
        check("frames", frames.as_slice())?;
        Ok(
            json!({"pose": matrix4_to_json(&pose), "frames": frames.iter().map(matrix4_to_json).collect::<Vec<_>>()}),
        )
    } else {
        let pose = kin.forward(&q);
        check("pose", &pose)?;
        Ok(json!({"pose": matrix4_to_json(&pose)}))
    }
}

/// A request's `frame`: `"base"` (the default) or `"tool"`.
pub(super) fn frame_field(req: &Value) -> Result<Frame, ProtocolError> {
    match req.get("frame").map(|v| v.as_str()) {
        None | Some(Some("base")) => Ok(Frame::Base),
        Some(Some("tool")) => Ok(Frame::Tool),
        _ => Err(ProtocolError::new(
            ErrorKind::BadRequest,
            "frame: expected \"base\" or \"tool\"",
        )),
    }
}

fn op_jacobian(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let robot = robot(req, arg)?;
    let q = q_field(req, "q", &robot)?;
    let frame = frame_field(req)?;
    // The compiled model's tool pose and base-frame Jacobian: `jacobian::jacobian`'s numbers.
    let kin = KinematicModel::new(&robot);
    let mut j = Jacobian::zeros(kin.nv());
    let tee = kin.fk_and_jacobian_into(&q, &mut j);
    if frame == Frame::Tool {
        to_tool_frame(&mut j, &tee);
    }
    // before the SVD: a non-finite Jacobian has no singular values
    check("jacobian", &j)?;
    let s = singularity(&j);
    check("singularity.sigma_min", &s.sigma_min)?;
    check("singularity.sigma_max", &s.sigma_max)?;
    check("singularity.manipulability", &s.manipulability)?;
    Ok(json!({
        "jacobian": matrix_to_json(&j),
        "frame": if frame == Frame::Base { "base" } else { "tool" },
        "singularity": {
            "sigma_min": s.sigma_min, "sigma_max": s.sigma_max,
            "manipulability": s.manipulability, "condition": finite_or_null(s.condition),
        },
    }))
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

fn axis_tolerances(v: &Value, path: &str) -> Result<[f64; 3], ProtocolError> {
    let one = |x: &Value, p: &str| -> Result<f64, ProtocolError> {
        if x.is_null() {
            return Ok(f64::INFINITY);
        }
        let t = number(x, p)?;
        if t <= 0.0 {
            return Err(ProtocolError::new(
                ErrorKind::BadRequest,
                format!("{p}: a tolerance must be positive"),
            ));
        }
        Ok(t)
    };
    match v {
        Value::Array(a) if a.len() == 3 => Ok([
            one(&a[0], &format!("{path}[0]"))?,
            one(&a[1], &format!("{path}[1]"))?,
            one(&a[2], &format!("{path}[2]"))?,
        ]),
        Value::Array(_) => Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!("{path}: expected a number or 3 numbers"),
        )),
        x => Ok([one(x, path)?; 3]),
    }
}

/// The `ik` options; `q0` reads the seed (after the other fields' checks, in this order).
fn ik_options(
    req: &Value,
    q0: impl FnOnce() -> Result<Option<Vec<f64>>, ProtocolError>,
) -> Result<IkOptions, ProtocolError> {
    let mut o = IkOptions::default();
    if let Some(t) = req.get("tolerances").filter(|t| !t.is_null()) {
        let obj = t.as_object().ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::BadRequest,
                "tolerances: expected {position, orientation}",
            )
        })?;
        let mut tol = Tolerances::default();
        for key in obj.keys() {
            if key != "position" && key != "orientation" {
                return Err(ProtocolError::new(
                    ErrorKind::BadRequest,
                    format!("tolerances.{key}: unknown field (position, orientation)"),
                ));
            }
        }
        if let Some(p) = obj.get("position") {
            tol.position = axis_tolerances(p, "tolerances.position")?;
        }
        if let Some(r) = obj.get("orientation") {
            tol.orientation = axis_tolerances(r, "tolerances.orientation")?;
        }
        o.tolerances = tol;
    }
    o.q0 = q0()?;
    o.all = bool_field(req, "all", false)?;
    o.respect_limits = bool_field(req, "respect_limits", true)?;
    o.max_iterations =
        uint_field(req, "max_iterations", o.max_iterations as u64, 1_000_000)? as usize;
    o.restarts = uint_field(req, "restarts", o.restarts as u64, 100_000)? as usize;
    o.seed = uint_field(req, "seed", 0, u64::MAX)?;
    Ok(o)
}

fn solution_json(s: &IkSolution) -> Value {
    let notes: Vec<Value> = s
        .notes
        .iter()
        .map(|n| match n {
            Note::WristSingular => json!({"kind": "wrist_singular"}),
            Note::ShoulderSingular => json!({"kind": "shoulder_singular"}),
            Note::ElbowClamped { excess } => json!({"kind": "elbow_clamped", "excess": excess}),
            Note::ShoulderClamped { excess } => {
                json!({"kind": "shoulder_clamped", "excess": excess})
            }
        })
        .collect();
    let mut v = json!({
        "q": s.q,
        "residual": {"position": s.residual.position, "orientation": s.residual.orientation},
        "converged": s.converged,
        "within_limits": s.within_limits,
        "iterations": s.iterations,
        "notes": notes,
    });
    if let Some(b) = s.branch {
        v["branch"] = json!(b.label());
    }
    v
}

/// A floating robot's IK problem: the chain from the base link to link frame `link`, on a fixed
/// base where `q0` holds the root, `q0` itself (nq values), and the chain's joints' indices in q.
struct HeldChain {
    chain: Robot,
    q0: Vec<f64>,
    path: Vec<usize>,
    link: usize,
}

fn held_chain(req: &Value, robot: &Robot) -> Result<HeldChain, ProtocolError> {
    let n = robot.dof();
    let link = uint_field(req, "link", n as u64, n as u64)? as usize;
    let kind = robot.root.as_ref().map_or("", |r| r.kind.name());
    if req.get("q0").is_none_or(Value::is_null) {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!(
                "q0: missing; the robot has a {kind} root, held where q0 ({} values) puts it while the chain to link {link} moves",
                robot.nq()
            ),
        ));
    }
    let q0 = q_field(req, "q0", robot)?;
    let (Some((chain, path)), Some((held, _))) = (robot.chain_to(link), root_held(robot, &q0))
    else {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!("link: {link} is not a link frame of the robot (1..={n})"),
        ));
    };
    let chain = Robot {
        base: held.base,
        ..chain
    };
    Ok(HeldChain {
        chain,
        q0,
        path,
        link,
    })
}

impl HeldChain {
    /// The chain's solution as the floating robot's: `q0` with the chain's joints replaced.
    fn expand(&self, s: &IkSolution) -> IkSolution {
        let mut q = self.q0.clone();
        for (&i, &x) in self.path.iter().zip(&s.q) {
            q[i] = x;
        }
        IkSolution { q, ..s.clone() }
    }
}

fn op_ik(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let full = robot(req, arg)?;
    let held = match full.root {
        Some(_) => Some(held_chain(req, &full)?),
        None if req.get("link").is_some_and(|v| !v.is_null()) => {
            return Err(ProtocolError::new(
                ErrorKind::BadRequest,
                "link: only for a robot with a floating root (a fixed-base tree's tip is chosen by the robot's `tip`)",
            ));
        }
        None => None,
    };
    let robot: &Robot = held.as_ref().map_or(&full, |h| &h.chain);
    let pose = matrix4_from_json(
        req.get("pose")
            .ok_or_else(|| ProtocolError::new(ErrorKind::BadRequest, "pose: missing"))?,
        "pose",
    )?;
    let method = match req.get("method") {
        None | Some(Value::Null) => Method::Auto,
        Some(v) => v.as_str().and_then(Method::parse).ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::BadRequest,
                "method: expected analytic, newton, dls, hybrid or auto",
            )
        })?,
    };
    let options = ik_options(req, || match &held {
        Some(h) => Ok(Some(h.path.iter().map(|&i| h.q0[i]).collect())),
        None if req.get("q0").is_some_and(|v| !v.is_null()) => Ok(Some(q_field(req, "q0", robot)?)),
        None => Ok(None),
    })?;
    let expand = |s: &IkSolution| match &held {
        Some(h) => h.expand(s),
        None => s.clone(),
    };
    // The closed-form family the geometry admits, and whether it was read from DH rows or
    // from general joints' placements and axes (a URDF): what `auto` chose from.
    let family = ik::family::recognise(robot);
    let mut family_json = json!({
        "name": family.name(),
        "from": if ik::family::recognised_from_axes(robot) { "joint_axes" } else { "dh_rows" },
    });
    if let ik::family::Family::General(reason) = &family {
        family_json["reason"] = json!(reason);
    }
    match ik::solve(robot, &pose, method, &options) {
        Ok(r) => {
            let solutions: Vec<IkSolution> = r.solutions.iter().map(expand).collect();
            for (i, s) in solutions.iter().enumerate() {
                check(&format!("solutions[{i}].q"), &s.q)?;
                check(
                    &format!("solutions[{i}].residual"),
                    &[s.residual.position, s.residual.orientation],
                )?;
            }
            let mut answer = json!({
            "method": r.method.name(),
            "family": family_json,
            "solutions": solutions.iter().map(solution_json).collect::<Vec<_>>(),
            });
            if let Some(h) = &held {
                answer["link"] = json!(h.link);
                answer["chain"] = json!(h.path);
            }
            Ok(answer)
        }
        Err(e) => Err(match &e {
            IkError::Model(_) | IkError::BadTarget | IkError::BadOptions { .. } => {
                ProtocolError::caused(ErrorKind::BadRequest, e)
            }
            IkError::Unreachable { .. } => ProtocolError::caused(ErrorKind::Unreachable, e),
            IkError::NotApplicable { .. } => ProtocolError::caused(ErrorKind::NotApplicable, e),
            IkError::NotConverged { best, .. } => {
                let s = solution_json(&expand(best));
                ProtocolError::new(ErrorKind::NotConverged, format!("{e}; best q {}", s["q"]))
            }
        }),
    }
}

fn op_encoder_error(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let full = robot(req, arg)?;
    let q = q_field(req, "q", &full)?;
    // A floating robot: the n joint encoders' bound with the root held at q (the root is
    // estimated, not read by an encoder, so it adds no quantisation term).
    let (robot, q) = match root_held(&full, &q) {
        Some((held, q_joints)) => (Cow::Owned(held), q_joints),
        None => (full, q),
    };
    let bits_v = req
        .get("bits")
        .ok_or_else(|| ProtocolError::new(ErrorKind::BadRequest, "bits: missing"))?;
    let to_bits = |v: &Value, p: &str| -> Result<u32, ProtocolError> {
        v.as_u64()
            .and_then(|b| u32::try_from(b).ok())
            .ok_or_else(|| {
                ProtocolError::new(
                    ErrorKind::BadRequest,
                    format!("{p}: expected a whole number of bits"),
                )
            })
    };
    let bits: Vec<u32> = match bits_v {
        Value::Array(a) => a
            .iter()
            .enumerate()
            .map(|(i, b)| to_bits(b, &format!("bits[{i}]")))
            .collect::<Result<_, _>>()?,
        v => vec![to_bits(v, "bits")?; robot.dof()],
    };
    let e = encoder_error(&robot, &q, &bits).map_err(|e| match e {
        EncoderErrorError::Model(m) => ProtocolError::new(ErrorKind::BadRequest, format!("q: {m}")),
        other => ProtocolError::caused(ErrorKind::BadRequest, other),
    })?;
    check("position", &e.position)?;
    check("orientation", &e.orientation)?;
    check("per_axis", &e.per_axis)?;
    check("position_worst_case", &e.position_worst_case)?;
    check("orientation_worst_case", &e.orientation_worst_case)?;
    check("resolution", &e.resolution)?;
    Ok(json!({
        "position": e.position,
        "orientation": e.orientation,
        "per_axis": e.per_axis,
        "position_worst_case": e.position_worst_case,
        "orientation_worst_case": e.orientation_worst_case,
        "resolution": e.resolution,
    }))
}
