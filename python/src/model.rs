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
use robosim_kinematics::Robot;
use robosim_kinematics::fk;
use robosim_kinematics::jacobian::{Frame, jacobian};
use serde_json::{Value, json};
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

fn read_rows(py: Python<'_>, x: &Bound<'_, PyAny>, what: &str, n: usize) -> PyResult<Rows> {
    let (shape, values) = read_array(py, x, what)?;
    let batch = match shape.as_slice() {
        [k] if *k == n => None,
        [b, k] if *k == n => Some(*b),
        _ => {
            return Err(bad_request(
                py,
                format!(
                    "{what}: expected shape ({n},) or (N, {n}) for a robot of {n} joints, got {}",
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
#[pyclass(frozen, module = "robosim")]
pub struct Model {
    robot: Robot,
    /// The rigid-body model of `robot`, or why it has none (e.g. no inertias): the dynamics
    /// methods raise that error.
    dynamics: Result<DynModel, ProtocolError>,
    /// Scratch `Data` of finished calls, reused by the next (a call takes one or makes one, so
    /// threads never share one).
    scratch: Mutex<Vec<Data>>,
}

impl Model {
    pub fn of(robot: Robot) -> Model {
        let dynamics = DynModel::new(&robot).map_err(ProtocolError::from);
        Model {
            robot,
            dynamics,
            scratch: Mutex::new(Vec::new()),
        }
    }

    /// [`Model::of`] a robot this API can hold: one coordinate per joint. A floating base or a
    /// ball joint has more q than joints (`nq`) and fewer v (`nv`), which every method here
    /// sizes by the joint count — refused by name rather than answered in the wrong layout.
    /// The query protocol serves such robots (`robosim.Session.query`, `robosim query`).
    pub fn checked(robot: Robot) -> Result<Model, ProtocolError> {
        let why = if robot.root.is_some() {
            Some("has a floating root joint")
        } else if robot.has_spherical() {
            Some("has a ball (spherical) joint")
        } else {
            None
        };
        match why {
            Some(why) => Err(ProtocolError::new(
                ErrorKind::BadRobot,
                format!(
                    "robot {:?} {why} (nq {} / nv {} for {} joints): robosim.Model holds one \
                     coordinate per joint; use the query protocol (Session.query or `robosim \
                     query`) for this robot",
                    robot.name,
                    robot.nq(),
                    robot.nv(),
                    robot.dof()
                ),
            )),
            None => Ok(Model::of(robot)),
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

    /// A dynamics op of q (and two more vectors): shape (n,) per row.
    fn dyn_call<'py>(
        &self,
        py: Python<'py>,
        args: &[(&str, &Bound<'py, PyAny>)],
        what: &str,
        f: DynFn,
        out_shape: &[usize],
    ) -> PyResult<Bound<'py, PyAny>> {
        let model = self.dyn_model(py)?;
        let n = self.dof();
        let rows: Vec<(&str, Rows)> = args
            .iter()
            .map(|(name, x)| Ok((*name, read_rows(py, x, name, n)?)))
            .collect::<PyResult<_>>()?;
        let refs: Vec<(&str, &Rows)> = rows.iter().map(|(n, r)| (*n, r)).collect();
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
                    let vs: Vec<&[f64]> = rows.iter().map(|(_, r)| r.row(i, n)).collect();
                    result = f(model, &mut data, &vs)
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

/// One dynamics algorithm on a row's vectors (q, and v and a/tau when it takes them).
type DynFn = fn(&DynModel, &mut Data, &[&[f64]]) -> Result<Vec<f64>, ProtocolError>;

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

    /// The serial chain of a URDF file from its root link to `tip` (the protocol's
    /// `{"urdf": PATH, "tip": LINK}`; without `tip`, the file's one leaf).
    #[staticmethod]
    #[pyo3(signature = (path, tip = None))]
    fn from_urdf(py: Python<'_>, path: &str, tip: Option<&str>) -> PyResult<Self> {
        let mut v = json!({"urdf": path});
        if let Some(t) = tip {
            v["tip"] = json!(t);
        }
        robot_from(&v)
            .and_then(Model::checked)
            .map_err(|e| raise(py, e))
    }

    /// The serial chain of an MJCF (MuJoCo XML) file to body `tip` (the protocol's
    /// `{"mjcf": PATH, "tip": BODY}`).
    #[staticmethod]
    #[pyo3(signature = (path, tip = None))]
    fn from_mjcf(py: Python<'_>, path: &str, tip: Option<&str>) -> PyResult<Self> {
        let mut v = json!({"mjcf": path});
        if let Some(t) = tip {
            v["tip"] = json!(t);
        }
        robot_from(&v)
            .and_then(Model::checked)
            .map_err(|e| raise(py, e))
    }

    /// A robot in the protocol's inline JSON form (a dict), or a file form.
    #[staticmethod]
    fn from_json(py: Python<'_>, robot: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = to_json(py, robot, "robot")?;
        robot_from(&v)
            .and_then(Model::checked)
            .map_err(|e| raise(py, e))
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

    /// The number of joints (Pinocchio's `nq`; equal to `nv`: every joint is revolute or
    /// prismatic).
    #[getter]
    fn nq(&self) -> usize {
        self.dof()
    }

    /// The number of joint velocities (equal to `nq`).
    #[getter]
    fn nv(&self) -> usize {
        self.dof()
    }

    /// Joint limits, shape (n, 2): [lo, hi] per joint (rad / m).
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v: Vec<f64> = self.robot.joints.iter().flat_map(|j| j.qlim).collect();
        out_array(py, &v, &[self.dof(), 2])
    }

    /// The robot in the protocol's inline JSON form (a dict).
    fn to_json<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(
            py,
            &robosim_hl_interface::robot_json::robot_to_json(&self.robot),
        )
    }

    /// The tool pose in the world, 4×4 (or N×4×4 for a batch q), acting on column vectors (m).
    fn fk<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.dof();
        let rows = read_rows(py, q, "q", n)?;
        let out = self.per_row(py, rows.count(), 16, |i, out| {
            let t = fk::forward(&self.robot, rows.row(i, n));
            let start = out.len();
            matrix4_rows(&t, out);
            finite(&out[start..], "pose", rows.batch.map(|_| i))
        })?;
        out_array(py, &out, &batched(rows.batch, &[4, 4]))
    }

    /// Every link frame in the world: (n+2, 4, 4) — [0] the base, [j] the end of joint j
    /// (j = 1..n), [n+1] the tool; (N, n+2, 4, 4) for a batch.
    fn frames<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.dof();
        let rows = read_rows(py, q, "q", n)?;
        let k = n + 2;
        let out = self.per_row(py, rows.count(), 16 * k, |i, out| {
            let start = out.len();
            for t in fk::link_frames(&self.robot, rows.row(i, n)) {
                matrix4_rows(&t, out);
            }
            finite(&out[start..], "frames", rows.batch.map(|_| i))
        })?;
        out_array(py, &out, &batched(rows.batch, &[k, 4, 4]))
    }

    /// The geometric Jacobian of the tool, 6×n (rows vx vy vz wx wy wz; N×6×n for a batch):
    /// `frame="base"` in world axes (Pinocchio's LOCAL_WORLD_ALIGNED), `"tool"` in the tool
    /// frame's axes (LOCAL) — the protocol's `jacobian` op's two frames.
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
        let n = self.dof();
        let rows = read_rows(py, q, "q", n)?;
        let out = self.per_row(py, rows.count(), 6 * n, |i, out| {
            let j = jacobian(&self.robot, rows.row(i, n), frame);
            let start = out.len();
            for r in 0..6 {
                for c in 0..n {
                    out.push(j[(r, c)]);
                }
            }
            finite(&out[start..], "jacobian", rows.batch.map(|_| i))
        })?;
        out_array(py, &out, &batched(rows.batch, &[6, n]))
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
        let n = self.dof();
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
        let q0 = q0.map(|x| read_rows(py, x, "q0", n)).transpose()?;
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

    /// Inverse dynamics (RNEA, the protocol's `id`): the joint torques/forces for q, v, a (n,)
    /// or (N, n) — Pinocchio's `rnea(model, data, q, v, a)`.
    fn rnea<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        a: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.dof();
        self.dyn_call(
            py,
            &[("q", q), ("v", v), ("a", a)],
            "tau",
            |m, d, x| {
                Ok(robosim_dynamics::rnea(m, d, x[0], x[1], x[2])?
                    .as_slice()
                    .to_vec())
            },
            &[n],
        )
    }

    /// The joint-space mass matrix (CRBA, the protocol's `mass_matrix`), n×n (N×n×n), full
    /// (both triangles, unlike Pinocchio's `crba` which fills the upper one).
    fn crba<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.dof();
        self.dyn_call(
            py,
            &[("q", q)],
            "mass_matrix",
            |m, d, x| {
                let mm = robosim_dynamics::crba(m, d, x[0])?;
                let mut out = Vec::with_capacity(mm.len());
                for r in 0..mm.nrows() {
                    out.extend(mm.row(r).iter().copied());
                }
                Ok(out)
            },
            &[n, n],
        )
    }

    /// Forward dynamics (ABA, the protocol's `fd` with method aba): the joint accelerations for
    /// q, v, tau (n,) or (N, n).
    fn aba<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.dof();
        self.dyn_call(
            py,
            &[("q", q), ("v", v), ("tau", tau)],
            "qdd",
            |m, d, x| {
                Ok(robosim_dynamics::aba(m, d, x[0], x[1], x[2])?
                    .as_slice()
                    .to_vec())
            },
            &[n],
        )
    }

    /// The torques that hold the arm still at q (the protocol's `gravity`; Pinocchio's
    /// `computeGeneralizedGravity`), (n,) or (N, n).
    fn gravity<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.dof();
        self.dyn_call(
            py,
            &[("q", q)],
            "tau",
            |m, d, x| Ok(robosim_dynamics::gravity(m, d, x[0])?.as_slice().to_vec()),
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
        let n = self.dof();
        let one = |x: &Bound<'py, PyAny>, what: &str| -> PyResult<Vec<f64>> {
            let r = read_rows(py, x, what, n)?;
            if r.batch.is_some() {
                return Err(bad_request(py, format!("{what}: expected shape ({n},)")));
            }
            Ok(r.values)
        };
        let mut req = json!({"op": "simulate", "q0": one(q0, "q0")?, "t_end": t_end,
            "integrator": integrator, "limits": limits});
        if let Some(x) = qd0 {
            req["qd0"] = json!(one(x, "qd0")?);
        }
        if let Some(x) = tau {
            req["tau"] = json!(one(x, "tau")?);
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
        d.set_item("q", out_array(py, &col("q"), &[k, n])?)?;
        d.set_item("qd", out_array(py, &col("qd"), &[k, n])?)?;
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
        let n = self.dof();
        let rows = read_rows(py, q, "q", n)?;
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
        format!("<robosim.Model {:?} nq={}>", self.robot.name, self.dof())
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
