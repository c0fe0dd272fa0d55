//! `robosim.Model`: one robot's algorithms for Python, shaped as Pinocchio's users expect
//! (docs/python.md): forward kinematics, link frames, Jacobians, inverse kinematics, RNEA, CRBA,
//! ABA, gravity, simulation and collision checks, numpy in and out.
//!
//! The robot is resolved as the query protocol resolves a request's `robot` field
//! ([`robosim_hl_interface::resolve_robot`], the `{"urdf"|"mjcf": PATH, "tip"}` file forms and
//! the inline form of [`robosim_hl_interface::robot_json::robot_from_json`]), or taken from a
//! session's compiled scene — the robot its session ops (`kinv`, `jacob`) use. Each method gives
//! the numbers the protocol's op gives on the same robot and input: `fk`, `frames`, `jacobian`,
//! `rnea`, `crba`, `aba`, `gravity` call the same core functions as `fk`, `jacobian`, `id`,
//! `mass_matrix`, `fd`, `gravity`; `ik`, `simulate` and `check` call the protocol's op itself
//! with the robot given ([`RobotArg::Given`]).
//!
//! Batches: every per-configuration method takes one configuration `(n,)` or a batch `(N, n)`
//! (a pose `(4, 4)` or `(N, 4, 4)` for `ik`) and answers with the batch axis first. Arrays cross
//! the boundary whole (`tobytes` in, a `bytearray` viewed by `numpy.frombuffer` out), and the
//! loop over rows runs in Rust with the GIL released. A wrong shape, a non-finite entry or a
//! failing row is a [`crate::RequestError`] (or the op's own error kind) naming the argument and
//! the row.

use crate::{bad_request, raise, to_json, to_py};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyList, PyTuple};
use robosim_dynamics::{Data, Model as DynModel};
use robosim_hl_interface::protocol::{self, RobotArg};
use robosim_hl_interface::robot_json::robot_from_json;
use robosim_hl_interface::{ErrorKind, ProtocolError};
use robosim_kinematics::jacobian::{Frame, Jacobian, to_tool_frame};
use robosim_kinematics::mimic::Coupling;
use robosim_kinematics::{KinematicModel, Robot, RootKind};
use serde_json::{Value, json};
use std::borrow::Cow;
use std::sync::{Mutex, PoisonError};

static NUMPY: PyOnceLock<Py<PyModule>> = PyOnceLock::new();
static NDARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

fn numpy(py: Python<'_>) -> PyResult<&Bound<'_, PyModule>> {
    NUMPY
        .get_or_try_init(py, || py.import("numpy").map(Bound::unbind))
        .map(|m| m.bind(py))
}

/// An array-like as C-ordered float64: its shape and values. Every entry must be finite; the
/// error names `what` and the first bad index.
fn read_array(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let arr = numpy(py)?
        .call_method1("ascontiguousarray", (x, "float64"))
        .map_err(|e| bad_request(py, format!("{what}: not an array of numbers ({e})")))?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let bytes = arr.call_method0("tobytes")?;
    let bytes = bytes.cast::<PyBytes>()?.as_bytes();
    let values: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| {
            let mut b = [0u8; 8];
            b.copy_from_slice(c);
            f64::from_ne_bytes(b)
        })
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        let mut idx = vec![0usize; shape.len()];
        let mut rest = i;
        for (k, d) in shape.iter().enumerate().rev() {
            if *d > 0 {
                idx[k] = rest % d;
                rest /= d;
            }
        }
        let at: Vec<String> = idx.iter().map(usize::to_string).collect();
        return Err(bad_request(
            py,
            format!(
                "{what}[{}]: {} is not a finite number",
                at.join(", "),
                values[i]
            ),
        ));
    }
    Ok((shape, values))
}

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Configurations of `n` joints: `(n,)` (one: `None`) or `(N, n)` (a batch of N).
struct Rows {
    batch: Option<usize>,
    values: Vec<f64>,
}

impl Rows {
    fn count(&self) -> usize {
        self.batch.unwrap_or(1)
    }

    fn row(&self, i: usize, width: usize) -> &[f64] {
        &self.values[i * width..(i + 1) * width]
    }
}

/// Rows of `n` values; `size` says what n counts in an error ("6 joints", "nq = 19 (…)").
fn read_rows(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    what: &str,
    (n, size): (usize, &str),
) -> PyResult<Rows> {
    let (shape, values) = read_array(py, x, what)?;
    let batch = match shape.as_slice() {
        [k] if *k == n => None,
        [b, k] if *k == n => Some(*b),
        _ => {
            return Err(bad_request(
                py,
                format!(
                    "{what}: expected shape ({n},) or (N, {n}) for a robot of {size}, got {}",
                    shape_text(&shape)
                ),
            ));
        }
    };
    Ok(Rows { batch, values })
}

/// The arguments of one call agree on the batch: all single, or all batches of the same N.
fn same_batch(py: Python<'_>, args: &[(&str, &Rows)]) -> PyResult<Option<usize>> {
    let (first, r0) = args[0];
    for (name, r) in &args[1..] {
        if r.batch != r0.batch {
            let say = |b: Option<usize>| {
                b.map_or("one configuration".to_owned(), |n| {
                    format!("a batch of {n}")
                })
            };
            return Err(bad_request(
                py,
                format!(
                    "{name} is {} but {first} is {}: give every argument the same shape",
                    say(r.batch),
                    say(r0.batch)
                ),
            ));
        }
    }
    Ok(r0.batch)
}

/// A float64 numpy array of `shape` holding `values` (C order): one copy into a bytearray,
/// which the array owns as its (writable) buffer — one numpy call.
fn out_array<'py>(py: Python<'py>, values: &[f64], shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let buf = PyByteArray::new_with(py, values.len() * 8, |b| {
        for (c, v) in b.chunks_exact_mut(8).zip(values) {
            c.copy_from_slice(&v.to_ne_bytes());
        }
        Ok(())
    })?;
    let ndarray =
        NDARRAY.get_or_try_init(py, || numpy(py)?.getattr("ndarray").map(Bound::unbind))?;
    ndarray
        .bind(py)
        .call1((PyTuple::new(py, shape)?, "float64", buf))
}

/// `shape` with the batch axis first when there is one.
fn batched(batch: Option<usize>, shape: &[usize]) -> Vec<usize> {
    batch.into_iter().chain(shape.iter().copied()).collect()
}

/// The protocol's answer to a result that left f64's range (`overflow`, naming where).
fn finite(values: &[f64], what: &str, row: Option<usize>) -> Result<(), ProtocolError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(ProtocolError::new(
            ErrorKind::Overflow,
            format!(
                "{}{what}[{i}] is {} (the result left f64's range)",
                at(row),
                values[i]
            ),
        )),
    }
}

fn at(row: Option<usize>) -> String {
    row.map_or(String::new(), |r| format!("row {r}: "))
}

fn in_row(row: Option<usize>, e: ProtocolError) -> ProtocolError {
    match row {
        None => e,
        Some(r) => ProtocolError::new(e.kind, format!("row {r}: {}", e.message)),
    }
}

fn matrix4_rows(m: &nalgebra::Matrix4<f64>, out: &mut Vec<f64>) {
    for r in 0..4 {
        for c in 0..4 {
            out.push(m[(r, c)]);
        }
    }
}

fn pose_json(p: &[f64]) -> Value {
    json!([&p[0..4], &p[4..8], &p[8..12], &p[12..16]])
}

/// One robot and its dynamics model (module docs). Immutable, so shared across threads: the
/// batch loops run with the GIL released.
///
/// Sizes are Pinocchio's: q has `nq` values and v, a, τ `nv` (a floating root's 7 / 6 first,
/// a ball joint's 4 / 3; docs/query.md). With a mimic coupling (`mimic=True`) they are the
/// **reduced** coordinates (the followers left out, `Coupling::reduced_nq`/`reduced_nv`), and
/// every method composes the full model's algorithm with the coupling as the query protocol's
/// `"mimic": true` does ([`robosim_hl_interface::protocol::mimic`]).
#[pyclass(frozen, module = "robosim")]
pub struct Model {
    robot: Robot,
    /// `robot` compiled once (fk, frames, Jacobians: the protocol's `fk`/`jacobian` path).
    kin: KinematicModel,
    /// `mimic=True`: the file's coupling; q, v, τ are its reduced coordinates.
    coupling: Option<Coupling>,
    /// The rigid-body model of `robot`, or why it has none (e.g. no inertias): the dynamics
    /// methods raise that error.
    dynamics: Result<DynModel, ProtocolError>,
    /// Scratch `Data` of finished calls, reused by the next (a call takes one or makes one, so
    /// threads never share one).
    scratch: Mutex<Vec<Data>>,
}

impl Model {
    /// The robot in its own coordinates: q of [`Robot::nq`] values, v, a, τ of [`Robot::nv`]
    /// (a floating root's and ball joints' layouts, docs/query.md).
    pub fn of(robot: Robot) -> Model {
        Model::with_coupling(robot, None)
    }

    /// The robot over the reduced coordinates of `coupling` (its mimic relations).
    fn with_coupling(robot: Robot, coupling: Option<Coupling>) -> Model {
        let dynamics = DynModel::new(&robot).map_err(ProtocolError::from);
        Model {
            kin: KinematicModel::new(&robot),
            robot,
            coupling,
            dynamics,
            scratch: Mutex::new(Vec::new()),
        }
    }

    /// A robot description (the protocol's `robot` forms): with `"mimic": true` a file robot
    /// over its reduced coordinates, as the protocol's mimic ops take it.
    fn from_value(v: &Value) -> Result<Model, ProtocolError> {
        match v.get("mimic") {
            Some(Value::Bool(true)) => {
                let (robot, coupling) = protocol::mimic::robot_and_coupling_of(v)?;
                Ok(Model::with_coupling(robot, Some(coupling)))
            }
            // `"mimic": false` is the full model, as without the key
            Some(Value::Bool(false)) => {
                let mut full = v.clone();
                if let Some(obj) = full.as_object_mut() {
                    obj.remove("mimic");
                }
                robot_from(&full).map(Model::of)
            }
            _ => robot_from(v).map(Model::of),
        }
    }

    /// Configuration length (reduced with a coupling).
    fn nq_(&self) -> usize {
        self.coupling
            .as_ref()
            .map_or(self.robot.nq(), Coupling::reduced_nq)
    }

    /// Velocity length (reduced with a coupling).
    fn nv_(&self) -> usize {
        self.coupling
            .as_ref()
            .map_or(self.robot.nv(), Coupling::reduced_nv)
    }

    /// What q's (`velocity` false) or v's length counts, for an error: "6 joints" for a
    /// fixed-base robot of revolute and prismatic joints, else "nq = 19 (a free_flyer root's 7
    /// first, 12 joints)" and the like.
    fn size_text(&self, velocity: bool) -> String {
        let n = if velocity { self.nv_() } else { self.nq_() };
        let mut parts = Vec::new();
        if let Some(r) = &self.robot.root {
            let (k, layout) = match (r.kind, velocity) {
                (RootKind::FreeFlyer, false) => (7, "x y z qx qy qz qw"),
                (RootKind::FreeFlyer, true) => (6, "vx vy vz wx wy wz"),
                (RootKind::Planar, false) => (4, "x y cos sin"),
                (RootKind::Planar, true) => (3, "vx vy wz"),
            };
            parts.push(format!("a {} root's {k} first: {layout}", r.kind.name()));
        }
        if self.robot.has_spherical() {
            parts.push(format!(
                "{} ball joints with {} each",
                self.robot.spherical_count(),
                if velocity {
                    "3 (wx wy wz)"
                } else {
                    "4 (qx qy qz qw)"
                }
            ));
        }
        if let Some(c) = &self.coupling {
            parts.push(format!(
                "{} free joints: {} mimic followers are not coordinates",
                c.reduced_dof(),
                c.full_dof() - c.reduced_dof()
            ));
        }
        if parts.is_empty() {
            return format!("{n} joints");
        }
        let name = if velocity { "nv" } else { "nq" };
        format!("{name} = {n} ({})", parts.join("; "))
    }

    /// (length, what it counts) of q (`velocity` false) or of v, a, τ.
    fn size(&self, velocity: bool) -> (usize, String) {
        let n = if velocity { self.nv_() } else { self.nq_() };
        (n, self.size_text(velocity))
    }

    /// The full model's q of a row of q (expanded through the coupling), checked where a
    /// layout constrains it (a root's or ball joint's unit quaternion): a request error naming
    /// the entry.
    fn full_q<'a>(&self, q: &'a [f64]) -> Result<Cow<'a, [f64]>, ProtocolError> {
        // the message names the entry; the kinematics error is kept as the source
        fn bad(e: impl std::error::Error + Send + Sync + 'static) -> ProtocolError {
            ProtocolError::new(ErrorKind::BadRequest, format!("q: {e}")).with_source(e)
        }
        let full = match &self.coupling {
            Some(c) => Cow::Owned(c.expand_q(q).map_err(bad)?),
            None => Cow::Borrowed(q),
        };
        if self.coupling.is_some() || self.robot.root.is_some() || self.robot.has_spherical() {
            self.robot.check_q(&full).map_err(bad)?;
        }
        Ok(full)
    }

    /// An op the reduced coordinates of `mimic=True` do not serve (the protocol's `mimic`
    /// takes fk, jacobian, id, fd, mass_matrix, gravity only): refused by name.
    fn refuse_mimic(&self, py: Python<'_>, op: &str) -> PyResult<()> {
        match &self.coupling {
            None => Ok(()),
            Some(_) => Err(bad_request(
                py,
                format!(
                    "{op}: not served with mimic=True (the reduced coordinates serve fk, frames, \
                     jacobian, rnea, crba, aba, gravity, as the query protocol's `mimic`); load \
                     the robot without mimic for {op}"
                ),
            )),
        }
    }

    fn dof(&self) -> usize {
        self.robot.dof()
    }

    fn dyn_model(&self, py: Python<'_>) -> PyResult<&DynModel> {
        self.dynamics.as_ref().map_err(|e| raise(py, e.clone()))
    }

    /// Runs `f` on each row of a batch (GIL released); `f(row, out)` appends `width` values.
    fn per_row<F>(&self, py: Python<'_>, count: usize, width: usize, f: F) -> PyResult<Vec<f64>>
    where
        F: Fn(usize, &mut Vec<f64>) -> Result<(), ProtocolError> + Send + Sync,
    {
        py.detach(|| {
            let mut out = Vec::with_capacity(count * width);
            for i in 0..count {
                f(i, &mut out)?;
            }
            Ok(out)
        })
        .map_err(|e| raise(py, e))
    }

    /// One protocol op on this robot (`RobotArg::Given`), as the protocol's areas answer it.
    fn op(&self, area: Area, op: &str, req: &Value) -> Result<Value, ProtocolError> {
        let given = RobotArg::Given(&self.robot);
        let answer = match area {
            Area::Kinematics => protocol::kinematics::dispatch_with(op, req, given),
            Area::Dynamics => protocol::dynamics::dispatch_with(op, req, given),
            Area::Collision => protocol::collision::dispatch_with(op, req, given),
        };
        answer.unwrap_or_else(|| {
            Err(ProtocolError::new(
                ErrorKind::InternalError,
                format!("op {op:?} is not answered by its area"),
            ))
        })
    }

    /// A dynamics op of q (nq per row) and up to two more vectors (nv per row).
    fn dyn_call<'py>(
        &self,
        py: Python<'py>,
        args: &[(&str, &Bound<'py, PyAny>)],
        what: &str,
        f: DynFn,
        out_shape: &[usize],
    ) -> PyResult<Bound<'py, PyAny>> {
        let model = self.dyn_model(py)?;
        let (q_size, v_size) = (self.size(false), self.size(true));
        let rows: Vec<(&str, Rows, usize)> = args
            .iter()
            .enumerate()
            .map(|(k, (name, x))| {
                let (n, text) = if k == 0 { &q_size } else { &v_size };
                Ok((*name, read_rows(py, x, name, (*n, text))?, *n))
            })
            .collect::<PyResult<_>>()?;
        let refs: Vec<(&str, &Rows)> = rows.iter().map(|(n, r, _)| (*n, r)).collect();
        let batch = same_batch(py, &refs)?;
        let count = rows[0].1.count();
        let width: usize = out_shape.iter().product();
        let out = py
            .detach(|| {
                let mut data = pool(&self.scratch)
                    .pop()
                    .unwrap_or_else(|| Data::new(model));
                let mut out = Vec::with_capacity(count * width);
                let mut result = Ok(());
                for i in 0..count {
                    let row = batch.map(|_| i);
                    let vs: Vec<&[f64]> = rows.iter().map(|(_, r, n)| r.row(i, *n)).collect();
                    result = self
                        .full_q(vs[0])
                        .and_then(|_| f(model, &mut data, self.coupling.as_ref(), &vs))
                        .map_err(|e| in_row(row, e))
                        .and_then(|v| {
                            finite(&v, what, row)?;
                            out.extend_from_slice(&v);
                            Ok(())
                        });
                    if result.is_err() {
                        break;
                    }
                }
                pool(&self.scratch).push(data);
                result.map(|()| out)
            })
            .map_err(|e| raise(py, e))?;
        out_array(py, &out, &batched(batch, out_shape))
    }
}

/// One dynamics algorithm on a row's vectors (q, and v and a/tau when it takes them): over
/// the reduced coordinates of the coupling when there is one.
type DynFn =
    fn(&DynModel, &mut Data, Option<&Coupling>, &[&[f64]]) -> Result<Vec<f64>, ProtocolError>;

/// The scratch pool. A poisoned lock still holds usable `Data`: every algorithm recomputes from
/// q what it reads (tested: answers with reused `Data` equal the protocol's with fresh `Data`).
fn pool(s: &Mutex<Vec<Data>>) -> std::sync::MutexGuard<'_, Vec<Data>> {
    s.lock().unwrap_or_else(PoisonError::into_inner)
}

#[derive(Clone, Copy)]
enum Area {
    Kinematics,
    Dynamics,
    Collision,
}

fn unknown_robot(name: &str) -> ProtocolError {
    ProtocolError::new(
        ErrorKind::UnknownRobot,
        format!("robot: no robot named \"{name}\""),
    )
}

fn robot_from(v: &Value) -> Result<Robot, ProtocolError> {
    robot_from_json(v).map_err(|e| {
        ProtocolError::new(ErrorKind::BadRobot, robosim_instance_space::error_chain(&e))
    })
}

#[allow(clippy::too_many_arguments)]
fn ik_request(
    py: Python<'_>,
    method: Option<&str>,
    tol: Option<&Bound<'_, PyAny>>,
    all: bool,
    respect_limits: bool,
    max_iterations: Option<u64>,
    restarts: Option<u64>,
    seed: Option<u64>,
) -> PyResult<Value> {
    let mut req = json!({"op": "ik", "all": all, "respect_limits": respect_limits});
    if let Some(m) = method {
        req["method"] = json!(m);
    }
    if let Some(t) = tol {
        req["tolerances"] = if let Ok(x) = t.extract::<f64>() {
            json!({"position": x, "orientation": x})
        } else {
            to_json(py, t, "tol")?
        };
    }
    for (k, v) in [
        ("max_iterations", max_iterations),
        ("restarts", restarts),
        ("seed", seed),
    ] {
        if let Some(v) = v {
            req[k] = json!(v);
        }
    }
    Ok(req)
}

/// The joint vectors of an `ik` answer's solutions, row after row.
fn solution_qs(answer: &Value) -> Vec<Vec<f64>> {
    answer["solutions"]
        .as_array()
        .map(|s| {
            s.iter()
                .map(|s| {
                    s["q"]
                        .as_array()
                        .map(|q| q.iter().filter_map(Value::as_f64).collect())
                        .unwrap_or_default()
                })
                .collect()
        })
        .unwrap_or_default()
}

fn kwargs_json(py: Python<'_>, kw: Option<&Bound<'_, PyDict>>, req: &mut Value) -> PyResult<()> {
    if let Some(kw) = kw {
        for (k, v) in kw.iter() {
            let k: String = k.extract()?;
            let v = to_json(py, &v, &k)?;
            req[k.as_str()] = v;
        }
    }
    Ok(())
}

#[pymethods]
impl Model {
    /// A robot by name, resolved as the query protocol resolves `"robot": NAME`: the standard
    /// library's robots, then the kinematics crate's reference robots (`puma560`, `stanford`,
    /// `panda`).
    #[new]
    fn new(py: Python<'_>, name: &str) -> PyResult<Self> {
        robosim_hl_interface::resolve_robot(name)
            .map(Model::of)
            .ok_or_else(|| raise(py, unknown_robot(name)))
    }

    /// A URDF file's robot (the protocol's `{"urdf": PATH, "tip": LINK, "floating": …}`): the
    /// serial chain from its root link to `tip` (without `tip`, the file's one leaf);
    /// `floating=True` (or "free_flyer", "planar") the whole tree on a floating root (q: the
    /// root's 7 x y z qx qy qz qw first, v its 6). `mimic=True`: the file's `<mimic>` joints
    /// imposed, q, v, τ the reduced coordinates (the protocol's `"mimic": true`; without `tip`
    /// the whole tree, Pinocchio's `buildModel(…, mimic=True)`).
    #[staticmethod]
    #[pyo3(signature = (path, tip = None, floating = None, mimic = false))]
    fn from_urdf(
        py: Python<'_>,
        path: &str,
        tip: Option<&str>,
        floating: Option<&Bound<'_, PyAny>>,
        mimic: bool,
    ) -> PyResult<Self> {
        let mut v = json!({"urdf": path});
        if let Some(t) = tip {
            v["tip"] = json!(t);
        }
        if let Some(f) = floating {
            v["floating"] = to_json(py, f, "floating")?;
        }
        if mimic {
            v["mimic"] = json!(true);
        }
        Model::from_value(&v).map_err(|e| raise(py, e))
    }

    /// The serial chain of an MJCF (MuJoCo XML) file to body `tip` (the protocol's
    /// `{"mjcf": PATH, "tip": BODY}`); `mimic=True`: its `<equality><joint>` couplings imposed
    /// over the reduced coordinates.
    #[staticmethod]
    #[pyo3(signature = (path, tip = None, mimic = false))]
    fn from_mjcf(py: Python<'_>, path: &str, tip: Option<&str>, mimic: bool) -> PyResult<Self> {
        let mut v = json!({"mjcf": path});
        if let Some(t) = tip {
            v["tip"] = json!(t);
        }
        if mimic {
            v["mimic"] = json!(true);
        }
        Model::from_value(&v).map_err(|e| raise(py, e))
    }

    /// A robot in the protocol's inline JSON form (a dict), or a file form (with `"mimic":
    /// true`, over the reduced coordinates).
    #[staticmethod]
    fn from_json(py: Python<'_>, robot: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = to_json(py, robot, "robot")?;
        Model::from_value(&v).map_err(|e| raise(py, e))
    }

    /// Robot `name` of a running session as its session ops see it (its compiled scene: the
    /// base placed in the world, the links' geometry read from the model).
    #[staticmethod]
    fn from_session(
        py: Python<'_>,
        session: &Bound<'_, crate::Session>,
        name: &str,
    ) -> PyResult<Self> {
        session.borrow_mut().model(py, name)
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> &str {
        &self.robot.name
    }

    /// The configuration's length (Pinocchio's `nq`): one per revolute or prismatic joint, 4
    /// per ball joint, a floating root's 7 (or a planar root's 4) first; with `mimic=True` the
    /// reduced coordinates' (followers left out).
    #[getter]
    fn nq(&self) -> usize {
        self.nq_()
    }

    /// The velocity's length (Pinocchio's `nv`; also a, τ's and the Jacobian's columns): 3
    /// per ball joint, a free-flyer root's 6 (planar 3) first; with `mimic=True` reduced.
    #[getter]
    fn nv(&self) -> usize {
        self.nv_()
    }

    /// The number of joints of the full model (the root not counted; followers counted):
    /// `frames` gives `njoints + 2` frames.
    #[getter]
    fn njoints(&self) -> usize {
        self.dof()
    }

    /// The full model's joint index (0-based, q order, the root not counted) of each reduced
    /// joint coordinate: every joint without `mimic=True`, the free ones (leaders and
    /// unconstrained joints) with it — the protocol's `coordinates`.
    #[getter]
    fn coordinates(&self) -> Vec<usize> {
        self.coupling
            .as_ref()
            .map_or_else(|| (0..self.dof()).collect(), |c| c.free().to_vec())
    }

    /// The floating root's kind ("free_flyer", "planar"), or None for a fixed base.
    #[getter]
    fn root(&self) -> Option<&'static str> {
        self.robot.root.as_ref().map(|r| r.kind.name())
    }

    /// Joint limits, shape (k, 2): [lo, hi] (rad / m) per joint of `coordinates` (the root has
    /// none; a ball joint's row is [-inf, inf] where it has no limit).
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let joints = self.coordinates();
        let v: Vec<f64> = joints
            .iter()
            .flat_map(|&j| self.robot.joints[j].qlim)
            .collect();
        out_array(py, &v, &[joints.len(), 2])
    }

    /// The robot in the protocol's inline JSON form (a dict): the full model (a mimic
    /// coupling is a file's, not carried by the inline form).
    fn to_json<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(
            py,
            &robosim_hl_interface::robot_json::robot_to_json(&self.robot),
        )
    }

    /// The tool pose in the world, 4×4 (or N×4×4 for a batch q of shape (N, nq)), acting on
    /// column vectors (m).
    fn fk<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (n, size) = self.size(false);
        let rows = read_rows(py, q, "q", (n, &size))?;
        let out = self.per_row(py, rows.count(), 16, |i, out| {
            let row = rows.batch.map(|_| i);
            let q = self.full_q(rows.row(i, n)).map_err(|e| in_row(row, e))?;
            let t = self.kin.forward(&q);
            let start = out.len();
            matrix4_rows(&t, out);
            finite(&out[start..], "pose", row)
        })?;
        out_array(py, &out, &batched(rows.batch, &[4, 4]))
    }

    /// Every link frame in the world: (k+2, 4, 4) for k = `njoints` — [0] the base (a floating
    /// robot's base link at its root's pose), [j] the end of joint j (j = 1..k; with
    /// `mimic=True` the followers' links too, moved with their leaders), [k+1] the tool;
    /// (N, k+2, 4, 4) for a batch.
    fn frames<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (n, size) = self.size(false);
        let rows = read_rows(py, q, "q", (n, &size))?;
        let k = self.dof() + 2;
        let out = self.per_row(py, rows.count(), 16 * k, |i, out| {
            let row = rows.batch.map(|_| i);
            let q = self.full_q(rows.row(i, n)).map_err(|e| in_row(row, e))?;
            let mut frames = vec![nalgebra::Matrix4::identity(); k];
            self.kin.link_frames_into(&q, &mut frames);
            let start = out.len();
            for t in &frames {
                matrix4_rows(t, out);
            }
            finite(&out[start..], "frames", row)
        })?;
        out_array(py, &out, &batched(rows.batch, &[k, 4, 4]))
    }

    /// The geometric Jacobian of the tool, 6×nv (rows vx vy vz wx wy wz, columns v's — a
    /// floating root's first; N×6×nv for a batch): `frame="base"` in world axes (Pinocchio's
    /// LOCAL_WORLD_ALIGNED), `"tool"` in the tool frame's axes (LOCAL) — the protocol's
    /// `jacobian` op's two frames. With `mimic=True`, `J G` over the reduced coordinates.
    #[pyo3(signature = (q, frame = "base"))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        frame: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let frame = match frame {
            "base" => Frame::Base,
            "tool" => Frame::Tool,
            other => {
                return Err(bad_request(
                    py,
                    format!("frame: expected \"base\" or \"tool\", got {other:?}"),
                ));
            }
        };
        let (n, size) = self.size(false);
        let nv = self.nv_();
        let rows = read_rows(py, q, "q", (n, &size))?;
        let out = self.per_row(py, rows.count(), 6 * nv, |i, out| {
            let row = rows.batch.map(|_| i);
            let qr = rows.row(i, n);
            let q = self.full_q(qr).map_err(|e| in_row(row, e))?;
            let start = out.len();
            match &self.coupling {
                Some(c) => {
                    let j = robosim_kinematics::mimic::jacobian(&self.robot, c, qr, frame)
                        .map_err(|e| {
                            in_row(
                                row,
                                ProtocolError::new(ErrorKind::BadRequest, format!("q: {e}")),
                            )
                        })?;
                    for r in 0..6 {
                        out.extend(j.row(r).iter().copied());
                    }
                }
                None => {
                    let mut j = Jacobian::zeros(self.kin.nv());
                    let tee = self.kin.fk_and_jacobian_into(&q, &mut j);
                    if frame == Frame::Tool {
                        to_tool_frame(&mut j, &tee);
                    }
                    for r in 0..6 {
                        out.extend(j.row(r).iter().copied());
                    }
                }
            }
            finite(&out[start..], "jacobian", row)
        })?;
        out_array(py, &out, &batched(rows.batch, &[6, nv]))
    }

    /// Inverse kinematics of a tool pose (4×4, or N×4×4), by the protocol's `ik` op: `method`
    /// analytic | newton | dls | hybrid | auto (default auto), `q0` the start (n,) or (N, n),
    /// `tol` a number (m and rad on every axis) or {position, orientation} as the op takes,
    /// `all` every analytic solution (every branch). Returns q (n,) — or, with `all`, every
    /// solution (k, n) — per pose (a batch: (N, n), or a list of (k, n)); `full=True` returns
    /// the op's answer dicts (method, family, solutions with branch, residual, converged,
    /// within_limits, iterations, notes). Raises UnreachableError, NotConvergedError,
    /// NotApplicableError as the op refuses; a batch names the row.
    #[pyo3(signature = (pose, method = None, q0 = None, tol = None, all = false, full = false, respect_limits = true, max_iterations = None, restarts = None, seed = None))]
    #[allow(clippy::too_many_arguments)]
    fn ik<'py>(
        &self,
        py: Python<'py>,
        pose: &Bound<'py, PyAny>,
        method: Option<&str>,
        q0: Option<&Bound<'py, PyAny>>,
        tol: Option<&Bound<'py, PyAny>>,
        all: bool,
        full: bool,
        respect_limits: bool,
        max_iterations: Option<u64>,
        restarts: Option<u64>,
        seed: Option<u64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.refuse_mimic(py, "ik")?;
        let (n, size) = self.size(false);
        let (shape, poses) = read_array(py, pose, "pose")?;
        let batch = match shape.as_slice() {
            [4, 4] => None,
            [b, 4, 4] => Some(*b),
            _ => {
                return Err(bad_request(
                    py,
                    format!(
                        "pose: expected shape (4, 4) or (N, 4, 4), got {}",
                        shape_text(&shape)
                    ),
                ));
            }
        };
        let count = batch.unwrap_or(1);
        let q0 = q0.map(|x| read_rows(py, x, "q0", (n, &size))).transpose()?;
        if let Some(r) = &q0
            && r.batch.is_some()
            && r.batch != batch
        {
            return Err(bad_request(
                py,
                format!(
                    "q0: a batch of {} starts for {}",
                    r.count(),
                    batch.map_or("one pose".to_owned(), |b| format!("{b} poses"))
                ),
            ));
        }
        let base = ik_request(
            py,
            method,
            tol,
            all,
            respect_limits,
            max_iterations,
            restarts,
            seed,
        )?;
        let answers: Vec<Value> = py
            .detach(|| {
                (0..count)
                    .map(|i| {
                        let mut req = base.clone();
                        req["pose"] = pose_json(&poses[i * 16..(i + 1) * 16]);
                        if let Some(r) = &q0 {
                            req["q0"] = json!(r.row(if r.batch.is_some() { i } else { 0 }, n));
                        }
                        self.op(Area::Kinematics, "ik", &req)
                            .map_err(|e| in_row(batch.map(|_| i), e))
                    })
                    .collect::<Result<Vec<_>, _>>()
            })
            .map_err(|e| raise(py, e))?;
        if full {
            return match batch {
                None => to_py(py, &answers[0]),
                Some(_) => to_py(py, &Value::Array(answers)).and_then(|v| {
                    Ok(PyList::new(py, v.try_iter()?.collect::<PyResult<Vec<_>>>()?)?.into_any())
                }),
            };
        }
        let one = |a: &Value| -> PyResult<Bound<'py, PyAny>> {
            let qs = solution_qs(a);
            if all {
                let flat: Vec<f64> = qs.concat();
                out_array(py, &flat, &[qs.len(), n])
            } else {
                let q = qs.first().cloned().unwrap_or_default();
                out_array(py, &q, &[q.len()])
            }
        };
        match batch {
            None => one(&answers[0]),
            Some(_) if all => {
                let list = PyList::empty(py);
                for a in &answers {
                    list.append(one(a)?)?;
                }
                Ok(list.into_any())
            }
            Some(b) => {
                let flat: Vec<f64> = answers
                    .iter()
                    .flat_map(|a| solution_qs(a).into_iter().next().unwrap_or_default())
                    .collect();
                out_array(py, &flat, &[b, n])
            }
        }
    }

    /// Inverse dynamics (RNEA, the protocol's `id`): the generalised forces (nv,) for q (nq,),
    /// v, a (nv,) — or (N, ·) batches — Pinocchio's `rnea(model, data, q, v, a)` (a floating
    /// root's 6 first: the force and moment on the base link, in its frame). With
    /// `mimic=True`, `Gᵀ τ` over the reduced coordinates.
    fn rnea<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        a: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.nv_();
        self.dyn_call(
            py,
            &[("q", q), ("v", v), ("a", a)],
            "tau",
            |m, d, c, x| {
                let tau = match c {
                    Some(c) => robosim_dynamics::mimic::rnea_mimic(m, d, c, x[0], x[1], x[2])?,
                    None => robosim_dynamics::rnea(m, d, x[0], x[1], x[2])?.clone(),
                };
                Ok(tau.as_slice().to_vec())
            },
            &[n],
        )
    }

    /// The joint-space mass matrix (CRBA, the protocol's `mass_matrix`), nv×nv (N×nv×nv), full
    /// (both triangles, unlike Pinocchio's `crba` which fills the upper one); `Gᵀ M G` with
    /// `mimic=True`.
    fn crba<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.nv_();
        self.dyn_call(
            py,
            &[("q", q)],
            "mass_matrix",
            |m, d, c, x| {
                let reduced;
                let mm = match c {
                    Some(c) => {
                        reduced = robosim_dynamics::mimic::crba_mimic(m, d, c, x[0])?;
                        &reduced
                    }
                    None => robosim_dynamics::crba(m, d, x[0])?,
                };
                let mut out = Vec::with_capacity(mm.len());
                for r in 0..mm.nrows() {
                    out.extend(mm.row(r).iter().copied());
                }
                Ok(out)
            },
            &[n, n],
        )
    }

    /// Forward dynamics (ABA, the protocol's `fd` with method aba): the accelerations (nv,)
    /// for q (nq,), v, tau (nv,) — or (N, ·) batches. With `mimic=True` (the protocol's `fd`
    /// with `mimic`): `M_r⁻¹ (τ_r − Gᵀ b)` by Cholesky (Pinocchio's ABA refuses mimic joints).
    fn aba<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.nv_();
        self.dyn_call(
            py,
            &[("q", q), ("v", v), ("tau", tau)],
            "qdd",
            |m, d, c, x| {
                let qdd = match c {
                    Some(c) => robosim_dynamics::mimic::aba_mimic(m, d, c, x[0], x[1], x[2])?,
                    None => robosim_dynamics::aba(m, d, x[0], x[1], x[2])?.clone(),
                };
                Ok(qdd.as_slice().to_vec())
            },
            &[n],
        )
    }

    /// The torques that hold the arm still at q (the protocol's `gravity`; Pinocchio's
    /// `computeGeneralizedGravity`), (nv,) or (N, nv); `Gᵀ g` with `mimic=True`.
    fn gravity<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.nv_();
        self.dyn_call(
            py,
            &[("q", q)],
            "tau",
            |m, d, c, x| {
                let g = match c {
                    Some(c) => robosim_dynamics::mimic::gravity_mimic(m, d, c, x[0])?,
                    None => robosim_dynamics::gravity(m, d, x[0])?.clone(),
                };
                Ok(g.as_slice().to_vec())
            },
            &[n],
        )
    }

    /// A simulation from q0 (the protocol's `simulate`): `tau` held constant, samples at
    /// `outputs` (default [t_end]). Returns {"t": (k,), "q": (k, n), "qd": (k, n),
    /// "energy": (k,), "stats": {...}}. `integrator` euler | semi_implicit_euler | rk4 |
    /// dopri5; `dt` for a fixed step, `rtol`/`atol` for dopri5.
    #[pyo3(signature = (q0, t_end, integrator = "rk4", dt = None, qd0 = None, tau = None, outputs = None, rtol = None, atol = None, limits = false, max_steps = None))]
    #[allow(clippy::too_many_arguments)]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        q0: &Bound<'py, PyAny>,
        t_end: f64,
        integrator: &str,
        dt: Option<f64>,
        qd0: Option<&Bound<'py, PyAny>>,
        tau: Option<&Bound<'py, PyAny>>,
        outputs: Option<&Bound<'py, PyAny>>,
        rtol: Option<f64>,
        atol: Option<f64>,
        limits: bool,
        max_steps: Option<u64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.refuse_mimic(py, "simulate")?;
        let (nq, nv) = (self.nq_(), self.nv_());
        let one = |x: &Bound<'py, PyAny>, what: &str, velocity: bool| -> PyResult<Vec<f64>> {
            let (n, size) = self.size(velocity);
            let r = read_rows(py, x, what, (n, &size))?;
            if r.batch.is_some() {
                return Err(bad_request(py, format!("{what}: expected shape ({n},)")));
            }
            Ok(r.values)
        };
        let mut req = json!({"op": "simulate", "q0": one(q0, "q0", false)?, "t_end": t_end,
            "integrator": integrator, "limits": limits});
        if let Some(x) = qd0 {
            req["qd0"] = json!(one(x, "qd0", true)?);
        }
        if let Some(x) = tau {
            req["tau"] = json!(one(x, "tau", true)?);
        }
        if let Some(x) = outputs {
            let (shape, v) = read_array(py, x, "outputs")?;
            if shape.len() != 1 {
                return Err(bad_request(
                    py,
                    "outputs: expected a 1-D array of times".into(),
                ));
            }
            req["outputs"] = json!(v);
        }
        for (k, v) in [("dt", dt), ("rtol", rtol), ("atol", atol)] {
            if let Some(v) = v {
                req[k] = json!(v);
            }
        }
        if let Some(m) = max_steps {
            req["max_steps"] = json!(m);
        }
        let answer = py
            .detach(|| self.op(Area::Dynamics, "simulate", &req))
            .map_err(|e| raise(py, e))?;
        let samples = answer["samples"].as_array().cloned().unwrap_or_default();
        let k = samples.len();
        let col = |key: &str| -> Vec<f64> {
            samples
                .iter()
                .flat_map(|s| match &s[key] {
                    Value::Array(a) => a.iter().filter_map(Value::as_f64).collect::<Vec<f64>>(),
                    v => v.as_f64().into_iter().collect::<Vec<f64>>(),
                })
                .collect()
        };
        let d = PyDict::new(py);
        d.set_item("t", out_array(py, &col("t"), &[k])?)?;
        d.set_item("q", out_array(py, &col("q"), &[k, nq])?)?;
        d.set_item("qd", out_array(py, &col("qd"), &[k, nv])?)?;
        d.set_item("energy", out_array(py, &col("energy"), &[k])?)?;
        d.set_item("stats", to_py(py, &answer["stats"])?)?;
        Ok(d.into_any())
    }

    /// A collision check of the robot at q against `scene` ({"objects": [shape + name + pose]})
    /// by the protocol's `check` op; keyword options as the op takes them (mode,
    /// self_collision, all, links, allowed, link_radius, depth, tolerance). The op's answer
    /// dict (verdict, clear, contacts, ...); a list of them for a batch q (N, n).
    #[pyo3(signature = (q, scene, **options))]
    fn check<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        scene: &Bound<'py, PyAny>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.refuse_mimic(py, "check")?;
        let (n, size) = self.size(false);
        let rows = read_rows(py, q, "q", (n, &size))?;
        let mut base = json!({"op": "check", "scene": to_json(py, scene, "scene")?});
        kwargs_json(py, options, &mut base)?;
        let answers: Vec<Value> = py
            .detach(|| {
                (0..rows.count())
                    .map(|i| {
                        let mut req = base.clone();
                        req["q"] = json!(rows.row(i, n));
                        self.op(Area::Collision, "check", &req)
                            .map_err(|e| in_row(rows.batch.map(|_| i), e))
                    })
                    .collect::<Result<Vec<_>, _>>()
            })
            .map_err(|e| raise(py, e))?;
        match rows.batch {
            None => to_py(py, &answers[0]),
            Some(_) => {
                let list = PyList::empty(py);
                for a in &answers {
                    list.append(to_py(py, a)?)?;
                }
                Ok(list.into_any())
            }
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "<robosim.Model {:?} nq={} nv={}{}>",
            self.robot.name,
            self.nq_(),
            self.nv_(),
            if self.coupling.is_some() {
                " mimic"
            } else {
                ""
            }
        )
    }
}

/// Any pure op of the query protocol, answered in this process (no session): the answer dict,
/// or a raised RobosimError. Robot names resolve as in `robosim query`.
#[pyfunction]
pub fn query<'py>(py: Python<'py>, request: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let req = to_json(py, request, "request")?;
    let answer = py
        .detach(|| {
            let mut none = |_: &str, _: &Value| None;
            robosim_hl_interface::answer_with(
                &req,
                robosim_hl_interface::Extension {
                    ops: &[],
                    answer: &mut none,
                },
            )
        })
        .map_err(|e| raise(py, e))?;
    to_py(py, &Value::Object(answer))
}

fn collide_request(
    py: Python<'_>,
    a: &Bound<'_, PyAny>,
    pose_a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
    pose_b: &Bound<'_, PyAny>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Value> {
    let pose = |p: &Bound<'_, PyAny>, what: &str| -> PyResult<Value> {
        let (shape, v) = read_array(py, p, what)?;
        if shape != [4, 4] {
            return Err(bad_request(
                py,
                format!("{what}: expected shape (4, 4), got {}", shape_text(&shape)),
            ));
        }
        Ok(pose_json(&v))
    };
    let mut req = json!({"op": "collide", "a": to_json(py, a, "a")?, "pose_a": pose(pose_a, "pose_a")?,
        "b": to_json(py, b, "b")?, "pose_b": pose(pose_b, "pose_b")?});
    kwargs_json(py, options, &mut req)?;
    Ok(req)
}

fn collide_value(py: Python<'_>, req: &Value) -> PyResult<Value> {
    py.detach(|| {
        protocol::collision::dispatch("collide", req, &robosim_hl_interface::resolve_robot)
            .unwrap_or_else(|| Err(ProtocolError::new(ErrorKind::InternalError, "collide")))
    })
    .map_err(|e| raise(py, e))
}

/// Two shapes (the protocol's shape dicts) at 4×4 poses, by the protocol's `collide` op;
/// keyword options `mode` (bbox | polygon | exact) and `tolerance`. The op's answer dict
/// (verdict, intersect, distance, signed_distance, witness_a, witness_b, ...).
#[pyfunction]
#[pyo3(signature = (a, pose_a, b, pose_b, **options))]
pub fn collide<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    pose_a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    pose_b: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let req = collide_request(py, a, pose_a, b, pose_b, options)?;
    to_py(py, &collide_value(py, &req)?)
}

/// The signed distance of two shapes at their poses (m; negative: the penetration depth),
/// the `signed_distance` of the protocol's `collide` in exact mode; None when its verdict is
/// unknown.
#[pyfunction]
#[pyo3(signature = (a, pose_a, b, pose_b, **options))]
pub fn distance(
    py: Python<'_>,
    a: &Bound<'_, PyAny>,
    pose_a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
    pose_b: &Bound<'_, PyAny>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Option<f64>> {
    let req = collide_request(py, a, pose_a, b, pose_b, options)?;
    Ok(collide_value(py, &req)?["signed_distance"].as_f64())
}
