//! The dynamics ops of the query protocol (DESIGN.md, "The query protocol"): `id`, `mass_matrix`,
//! `gravity`, `fd`, `simulate`. The transport (JSON lines, iceoryx2) lives elsewhere; this module
//! turns one request object into one answer object.
//!
//! | op | request | answer |
//! |---|---|---|
//! | `id` | robot, q, qd, qdd, passive? | tau (and tau_passive with `passive`) |
//! | `mass_matrix` | robot, q | mass_matrix (n×n rows) |
//! | `gravity` | robot, q | tau (holds the arm still) |
//! | `fd` | robot, q, qd, tau, method?: aba\|cholesky, passive? | qdd (and tau_passive with `passive`) |
//! | `simulate` | robot, q0, qd0?, tau?, t_end, outputs?, integrator, dt \| rtol+atol, limits?, max_steps?, passive? | samples [{t, q, qd, energy}], stats |
//!
//! For a robot with a floating `root` q (`q0`) has nq values and qd, qdd, tau (`qd0`) nv
//! (robosim_kinematics::root's layouts); `simulate` integrates on the manifold.
//!
//! `robot` is a library name (resolved by the caller's `robots`, then the fixtures compiled into
//! `robosim_dynamics::fixture_robot`: puma560, stanford, panda) or an inline description
//! ([`crate::robot_json`]).
//! The rigid-body equations, as Pinocchio computes them (DESIGN.md, "Dynamics contract"; motor
//! inertia is Pinocchio's armature): a robot's joint damping and Coulomb friction (a URDF's
//! `<dynamics>`) act only when the request says `"passive": true` (viscous, and Coulomb
//! stick–slip with a 1e-6 rad/s band) or `"passive": {"viscous": bool, "coulomb":
//! "off"|"regularised"|"stick_slip", "velocity": v}` (robosim_dynamics::friction). Then `id`
//! answers `tau` = τ_rigid − τ_passive (what the motors supply) and `tau_passive` (what friction
//! applies, static friction at rest reported as 0), `fd` answers q̈ under τ + friction
//! (stick–slip: a joint at rest under a torque below its Coulomb limit stays at rest) and the
//! friction torque as `tau_passive`. `simulate` starts at t = 0
//! holds `tau` constant, and answers one sample per `outputs` time (default `[t_end]`); `limits`
//! (default false) turns on the inelastic joint stops.
//!
//! Entry point: [`dispatch`].

use super::RobotArg;
use super::finite::check;
use super::kinematics::expected_len;
use crate::robot_json::robot_from_json;
use crate::{ErrorKind, ProtocolError};
use robosim_dynamics::{
    Coulomb, JointFriction, aba_with_friction, passive_torque, simulate_with_friction,
};
use robosim_dynamics::{Data, DynamicsError, Model, aba, crba, fd_cholesky, gravity, rnea};
use robosim_dynamics::{Integrator, IntegratorConfig, StepSize, fixture_robot};
use robosim_geometry::readable;
use robosim_kinematics::Robot;
use serde_json::{Map, Value, json};

impl From<DynamicsError> for ProtocolError {
    fn from(e: DynamicsError) -> Self {
        let kind = match &e {
            DynamicsError::Model(_)
            | DynamicsError::AsymmetricInertia { .. }
            | DynamicsError::NegativeInertia { .. } => ErrorKind::InvalidRobot,
            DynamicsError::WrongLength { .. }
            | DynamicsError::NonFinite { .. }
            | DynamicsError::BadOption { .. } => ErrorKind::InvalidRequest,
            DynamicsError::SingularInertia { .. } => ErrorKind::Singular,
            DynamicsError::Overflow { .. } => ErrorKind::Overflow,
            DynamicsError::Diverged { .. }
            | DynamicsError::NoConvergence { .. }
            | DynamicsError::StepUnderflow { .. } => ErrorKind::Diverged,
            DynamicsError::TooManySteps { .. } => ErrorKind::TooManySteps,
        };
        ProtocolError::caused(kind, e)
    }
}

/// One op's handler.
type OpFn = fn(&Value, RobotArg<'_>) -> Result<Value, ProtocolError>;

/// Default step budget of a `simulate` request (a planner must not stall the server by accident).
pub const DEFAULT_MAX_STEPS: u64 = 10_000_000;

/// Answers `op` if it is a dynamics op, `None` otherwise. `req` is the whole request object;
/// `robots` resolves library names.
pub fn dispatch(
    op: &str,
    req: &Value,
    robots: &dyn Fn(&str) -> Option<Robot>,
) -> Option<Result<Value, ProtocolError>> {
    dispatch_with(op, req, RobotArg::Request(robots))
}

/// [`dispatch`] with the robot given: by the request ([`RobotArg::Request`]) or typed by the
/// caller ([`RobotArg::Given`]; the request's `robot` is not read).
pub fn dispatch_with(
    op: &str,
    req: &Value,
    robot: RobotArg<'_>,
) -> Option<Result<Value, ProtocolError>> {
    let f: OpFn = match op {
        "id" => op_id,
        "mass_matrix" => op_mass_matrix,
        "gravity" => op_gravity,
        "fd" => op_fd,
        "simulate" => op_simulate,
        _ => return None,
    };
    Some(f(req, robot))
}

fn model_of(req: &Value, arg: RobotArg<'_>) -> Result<Model, ProtocolError> {
    let robots = match arg {
        RobotArg::Given(robot) => return Ok(Model::new(robot)?),
        RobotArg::Request(robots) => robots,
    };
    let robot = match req.get("robot") {
        None => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                "missing field `robot`",
            ));
        }
        Some(Value::String(name)) => {
            robots(name)
                .or_else(|| fixture_robot(name))
                .ok_or_else(|| {
                    ProtocolError::new(ErrorKind::UnknownRobot, format!("no robot named {name:?}"))
                })?
        }
        Some(v @ Value::Object(_)) => robot_from_json(v).map_err(|e| {
            ProtocolError::new(
                ErrorKind::InvalidRobot,
                format!("robot description, `{}`: {}", e.path, e.reason),
            )
        })?,
        Some(other) => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                format!("`robot` must be a name or an object, got {other}"),
            ));
        }
    };
    Ok(Model::new(&robot)?)
}

/// The lengths of the request's vectors ([`expected_len`]): q (`nq` values) and v, q̈, τ (`nv`),
/// each with how an error says it.
struct Dims {
    q: (usize, String),
    v: (usize, String),
}

impl Dims {
    fn of(model: &Model) -> Dims {
        Dims {
            q: expected_len(model.robot(), false),
            v: expected_len(model.robot(), true),
        }
    }
}

/// The configuration `field` (`nq` values); a floating root's rotation must be unit (a request
/// error, not the robot's).
fn configuration(
    req: &Value,
    field: &str,
    model: &Model,
    dims: &Dims,
) -> Result<Vec<f64>, ProtocolError> {
    let q = vector(req, field, &dims.q, false)?;
    if model.robot().root.is_some() || model.robot().has_spherical() {
        model.robot().check_q(&q).map_err(|e| {
            ProtocolError::new(ErrorKind::InvalidRequest, format!("`{field}`: {e}"))
        })?;
    }
    Ok(q)
}

fn vector(
    req: &Value,
    field: &str,
    (n, what): &(usize, String),
    default_zero: bool,
) -> Result<Vec<f64>, ProtocolError> {
    let n = *n;
    match req.get(field) {
        None if default_zero => Ok(vec![0.0; n]),
        None => Err(ProtocolError::new(
            ErrorKind::InvalidRequest,
            format!("missing field `{field}`"),
        )),
        Some(Value::Array(a)) => {
            if a.len() != n {
                return Err(ProtocolError::new(
                    ErrorKind::InvalidRequest,
                    format!("`{field}` has {} values but the robot has {what}", a.len()),
                ));
            }
            a.iter()
                .enumerate()
                .map(|(i, x)| {
                    x.as_f64().ok_or_else(|| {
                        ProtocolError::new(
                            ErrorKind::InvalidRequest,
                            format!("`{field}`[{i}] is not a number ({x})"),
                        )
                    })
                })
                .collect()
        }
        Some(other) => Err(ProtocolError::new(
            ErrorKind::InvalidRequest,
            format!("`{field}` must be an array of numbers, got {other}"),
        )),
    }
}

fn number(req: &Value, field: &str) -> Result<Option<f64>, ProtocolError> {
    match req.get(field) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v.as_f64().map(Some).ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::InvalidRequest,
                format!("`{field}` must be a number, got {v}"),
            )
        }),
    }
}

/// The request's `passive` field: absent or false, `None` (the rigid-body equations); true,
/// the default friction ([`JointFriction::default`]); an object, its settings.
fn passive_of(req: &Value) -> Result<Option<JointFriction>, ProtocolError> {
    let bad = |m: String| ProtocolError::new(ErrorKind::InvalidRequest, m);
    let friction = match req.get("passive") {
        None | Some(Value::Null) | Some(Value::Bool(false)) => return Ok(None),
        Some(Value::Bool(true)) => JointFriction::default(),
        Some(Value::Object(o)) => {
            for k in o.keys() {
                if !matches!(k.as_str(), "viscous" | "coulomb" | "velocity") {
                    return Err(bad(format!(
                        "`passive` has an unknown field {k:?} (viscous, coulomb, velocity)"
                    )));
                }
            }
            let viscous = match o.get("viscous") {
                None => true,
                Some(Value::Bool(b)) => *b,
                Some(v) => {
                    return Err(bad(format!("`passive.viscous` must be a boolean, got {v}")));
                }
            };
            let velocity =
                match o.get("velocity") {
                    None => None,
                    Some(v) => Some(v.as_f64().ok_or_else(|| {
                        bad(format!("`passive.velocity` must be a number, got {v}"))
                    })?),
                };
            let coulomb = match o.get("coulomb").map(|v| (v, v.as_str())) {
                None | Some((_, Some("stick_slip"))) => Coulomb::StickSlip {
                    velocity: velocity.unwrap_or(1e-6),
                },
                Some((_, Some("regularised"))) => Coulomb::Regularised {
                    velocity: velocity.unwrap_or(1e-3),
                },
                Some((_, Some("off"))) => Coulomb::Off,
                Some((v, _)) => {
                    return Err(bad(format!(
                        "`passive.coulomb` must be \"off\", \"regularised\" or \"stick_slip\", got {v}"
                    )));
                }
            };
            JointFriction { viscous, coulomb }
        }
        Some(v) => {
            return Err(bad(format!(
                "`passive` must be a boolean or an object, got {v}"
            )));
        }
    };
    friction.validate()?;
    Ok(Some(friction))
}

fn op_id(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let model = model_of(req, arg)?;
    let dims = Dims::of(&model);
    let (q, qd, qdd) = (
        configuration(req, "q", &model, &dims)?,
        vector(req, "qd", &dims.v, false)?,
        vector(req, "qdd", &dims.v, false)?,
    );
    let passive = passive_of(req)?;
    let mut data = Data::new(&model);
    let tau = rnea(&model, &mut data, &q, &qd, &qdd)?;
    check("tau", tau.as_slice())?;
    let Some(friction) = passive else {
        return Ok(json!({ "tau": tau.as_slice() }));
    };
    let mut tau_passive = vec![0.0; model.nv()];
    passive_torque(&model, &qd, &friction, &mut tau_passive)?;
    let total: Vec<f64> = tau.iter().zip(&tau_passive).map(|(t, p)| t - p).collect();
    check("tau", total.as_slice())?;
    Ok(json!({ "tau": total, "tau_passive": tau_passive }))
}

fn op_mass_matrix(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let model = model_of(req, arg)?;
    let q = configuration(req, "q", &model, &Dims::of(&model))?;
    let mut data = Data::new(&model);
    let m = crba(&model, &mut data, &q)?;
    check("mass_matrix", m)?;
    let rows: Vec<Vec<f64>> = (0..m.nrows())
        .map(|r| m.row(r).iter().copied().collect())
        .collect();
    Ok(json!({ "mass_matrix": rows }))
}

fn op_gravity(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let model = model_of(req, arg)?;
    let q = configuration(req, "q", &model, &Dims::of(&model))?;
    let mut data = Data::new(&model);
    let tau = gravity(&model, &mut data, &q)?;
    check("tau", tau.as_slice())?;
    Ok(json!({ "tau": tau.as_slice() }))
}

fn op_fd(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let model = model_of(req, arg)?;
    let dims = Dims::of(&model);
    let (q, qd, tau) = (
        configuration(req, "q", &model, &dims)?,
        vector(req, "qd", &dims.v, false)?,
        vector(req, "tau", &dims.v, false)?,
    );
    let mut data = Data::new(&model);
    if let Some(friction) = passive_of(req)? {
        if req.get("method").is_some_and(|m| m.as_str() != Some("aba")) {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                "`passive` forward dynamics is computed by ABA: leave `method` out or say \"aba\"",
            ));
        }
        let qdd = aba_with_friction(&model, &mut data, &q, &qd, &tau, &friction)?.clone();
        check("qdd", qdd.as_slice())?;
        return Ok(json!({ "qdd": qdd.as_slice(), "tau_passive": data.passive.as_slice() }));
    }
    let qdd = match req.get("method").and_then(Value::as_str) {
        None | Some("aba") => aba(&model, &mut data, &q, &qd, &tau)?,
        Some("cholesky") => fd_cholesky(&model, &mut data, &q, &qd, &tau)?,
        Some(other) => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                format!("`method` must be \"aba\" or \"cholesky\", got {other:?}"),
            ));
        }
    };
    check("qdd", qdd.as_slice())?;
    Ok(json!({ "qdd": qdd.as_slice() }))
}

fn op_simulate(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let model = model_of(req, arg)?;
    let dims = Dims::of(&model);
    let q0 = configuration(req, "q0", &model, &dims)?;
    let qd0 = vector(req, "qd0", &dims.v, true)?;
    let tau = vector(req, "tau", &dims.v, true)?;
    let t_end = number(req, "t_end")?
        .ok_or_else(|| ProtocolError::new(ErrorKind::InvalidRequest, "missing field `t_end`"))?;
    if !(t_end.is_finite() && t_end >= 0.0) {
        return Err(ProtocolError::new(
            ErrorKind::InvalidRequest,
            format!(
                "`t_end` must be a non-negative number of seconds, got {}",
                readable(t_end)
            ),
        ));
    }
    let outputs: Vec<f64> = match req.get("outputs") {
        None => vec![t_end],
        Some(Value::Array(a)) => a
            .iter()
            .enumerate()
            .map(|(i, x)| {
                x.as_f64().ok_or_else(|| {
                    ProtocolError::new(
                        ErrorKind::InvalidRequest,
                        format!("`outputs`[{i}] is not a number ({x})"),
                    )
                })
            })
            .collect::<Result<_, _>>()?,
        Some(other) => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                format!("`outputs` must be an array of times, got {other}"),
            ));
        }
    };
    if let Some((i, t)) = outputs.iter().enumerate().find(|(_, t)| **t > t_end) {
        return Err(ProtocolError::new(
            ErrorKind::InvalidRequest,
            format!(
                "`outputs`[{i}] = {} s is after t_end = {} s",
                readable(*t),
                readable(t_end)
            ),
        ));
    }
    let name = req
        .get("integrator")
        .and_then(Value::as_str)
        .ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::InvalidRequest,
                "missing field `integrator` (euler | semi_implicit_euler | rk4 | dopri5)",
            )
        })?;
    let integrator = Integrator::from_name(name).ok_or_else(|| {
        ProtocolError::new(
            ErrorKind::InvalidRequest,
            format!("unknown integrator {name:?} (euler | semi_implicit_euler | rk4 | dopri5)"),
        )
    })?;
    let (dt, rtol, atol) = (
        number(req, "dt")?,
        number(req, "rtol")?,
        number(req, "atol")?,
    );
    let step = match (dt, rtol, atol) {
        (Some(dt), None, None) => StepSize::Fixed(dt),
        (None, r, a) if r.is_some() || a.is_some() => StepSize::Adaptive {
            rtol: r.unwrap_or(1e-6),
            atol: a.unwrap_or(1e-9),
        },
        (None, None, None) => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                "give `dt` (fixed step) or `rtol`/`atol` (dopri5)",
            ));
        }
        _ => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                "give either `dt` or `rtol`/`atol`, not both",
            ));
        }
    };
    let joint_stops = match req.get("limits") {
        None => false,
        Some(Value::Bool(b)) => *b,
        Some(other) => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                format!("`limits` must be true or false, got {other}"),
            ));
        }
    };
    let max_steps = match number(req, "max_steps")? {
        None => DEFAULT_MAX_STEPS,
        Some(m) if m >= 1.0 && m.is_finite() => m as u64,
        Some(m) => {
            return Err(ProtocolError::new(
                ErrorKind::InvalidRequest,
                format!("`max_steps` must be at least 1, got {}", readable(m)),
            ));
        }
    };
    let config = IntegratorConfig {
        integrator,
        step,
        joint_stops,
        max_steps,
    };
    let friction = passive_of(req)?;
    let (samples, stats) =
        simulate_with_friction(&model, config, friction, &q0, &qd0, &tau, &outputs)?;
    for (i, s) in samples.iter().enumerate() {
        check(&format!("samples[{i}].q"), s.q.as_slice())?;
        check(&format!("samples[{i}].qd"), s.qd.as_slice())?;
        check(&format!("samples[{i}].energy"), &s.energy)?;
    }
    let samples: Vec<Value> = samples
        .into_iter()
        .map(|s| json!({ "t": s.t, "q": s.q, "qd": s.qd, "energy": s.energy }))
        .collect();
    let mut stats_obj = Map::new();
    stats_obj.insert("accepted_steps".into(), json!(stats.accepted));
    stats_obj.insert("rejected_steps".into(), json!(stats.rejected));
    stats_obj.insert("evaluations".into(), json!(stats.evaluations));
    Ok(json!({ "samples": samples, "stats": stats_obj }))
}
