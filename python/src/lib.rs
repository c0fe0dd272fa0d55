//! `robosim._robosim`: the Python face of the planner client
//! (`robosim_hl_interface::planner::Planner`), wrapped by the package `robosim`
//! (python/robosim/, docs/python.md).
//!
//! Conversions: joint vectors and poses go out as numpy `float64` arrays (1-D, and 4×4 for
//! poses); requests and answers of `query` are dicts, any array of numbers in an answer
//! becoming a numpy array (a list of equal-length number lists, a 2-D one). Every refusal is a
//! `robosim.RobosimError` (or its subclass for the kind: `SessionError`, `TransactionError`,
//! `JointLimitError`) carrying `.kind` and `.message`.
//!
//! The client is single-threaded (it holds reference-counted views of shared memory): the
//! classes are `unsendable`, used from the thread that made them. Waits are cut into slices of
//! [`WAIT_SLICE`] so Ctrl-C interrupts them.

#![forbid(unsafe_code)]

use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use robosim_hl_interface::planner::{self, Planner};
use robosim_hl_interface::{ErrorKind, ProtocolError};
use robosim_instance_space::Snapshot as RsSnapshot;
use serde_json::{Map, Number, Value};
use std::rc::Rc;
use std::time::{Duration, Instant};

pyo3::create_exception!(
    _robosim,
    RobosimError,
    PyException,
    "A refusal from robosim: `.kind` (the query protocol's error kind) and `.message`."
);
pyo3::create_exception!(
    _robosim,
    SessionError,
    RobosimError,
    "No such session, no keeper or simulator running, or a peer went away (kind `session`)."
);
pyo3::create_exception!(
    _robosim,
    TransactionError,
    RobosimError,
    "The keeper refused a transaction, or a relative edit lost to concurrent writes on every attempt; nothing changed (kind `transaction` or `conflict`)."
);
pyo3::create_exception!(
    _robosim,
    JointLimitError,
    RobosimError,
    "Joint values outside the robot's limits; nothing changed (kind `joint_limit`)."
);

pyo3::create_exception!(
    _robosim,
    RequestError,
    RobosimError,
    "A request the op cannot read: a missing or malformed argument, a wrong shape, a non-finite number (kinds `bad_request`, `invalid_request`, `parse_error`)."
);
pyo3::create_exception!(
    _robosim,
    RobotError,
    RobosimError,
    "No robot of that name, or a robot description or file that does not make a robot (kinds `unknown_robot`, `bad_robot`, `invalid_robot`)."
);
pyo3::create_exception!(
    _robosim,
    UnreachableError,
    RobosimError,
    "The pose is outside the robot's workspace (kind `unreachable`)."
);
pyo3::create_exception!(
    _robosim,
    NotConvergedError,
    RobosimError,
    "An iterative solve did not reach the tolerance; the message gives the best q (kind `not_converged`)."
);
pyo3::create_exception!(
    _robosim,
    NotApplicableError,
    RobosimError,
    "The method does not apply to this robot, e.g. analytic IK of a geometry without a closed form (kind `not_applicable`)."
);
pyo3::create_exception!(
    _robosim,
    NumericalError,
    RobosimError,
    "The numbers failed: a singular inertia, a result beyond f64's range, a diverging or over-long simulation (kinds `singular`, `overflow`, `diverged`, `too_many_steps`)."
);
pyo3::create_exception!(
    _robosim,
    ShapeError,
    RobosimError,
    "The fields do not make a solid (kind `bad_shape`)."
);

mod dataflow;
mod model;

/// How long one uninterruptible piece of a wait may last.
const WAIT_SLICE: Duration = Duration::from_millis(50);

pub(crate) fn raise(py: Python<'_>, e: ProtocolError) -> PyErr {
    let text = format!("{}: {}", e.kind, e.message);
    let err = match e.kind {
        ErrorKind::Session => SessionError::new_err(text),
        // A conflict: the keeper refused a relative edit on every attempt; nothing changed.
        ErrorKind::Transaction | ErrorKind::Conflict => TransactionError::new_err(text),
        ErrorKind::JointLimit => JointLimitError::new_err(text),
        ErrorKind::BadRequest | ErrorKind::InvalidRequest | ErrorKind::ParseError => {
            RequestError::new_err(text)
        }
        ErrorKind::UnknownRobot | ErrorKind::BadRobot | ErrorKind::InvalidRobot => {
            RobotError::new_err(text)
        }
        ErrorKind::Unreachable => UnreachableError::new_err(text),
        ErrorKind::NotConverged => NotConvergedError::new_err(text),
        ErrorKind::NotApplicable => NotApplicableError::new_err(text),
        ErrorKind::Singular
        | ErrorKind::Overflow
        | ErrorKind::Diverged
        | ErrorKind::TooManySteps => NumericalError::new_err(text),
        ErrorKind::BadShape => ShapeError::new_err(text),
        _ => RobosimError::new_err(text),
    };
    let v = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail short of memory exhaustion;
    // should it, the exception still carries "kind: message" as its text.
    let _ = v.setattr("kind", e.kind.as_str());
    let _ = v.setattr("message", e.message.as_str());
    err
}

pub(crate) fn bad_request(py: Python<'_>, message: String) -> PyErr {
    raise(py, ProtocolError::new(ErrorKind::BadRequest, message))
}

/// A Python value as JSON: dict (str keys), list/tuple, numpy arrays and scalars, str, int,
/// float (finite), bool, None. `at` names the place for the error.
pub(crate) fn to_json(py: Python<'_>, v: &Bound<'_, PyAny>, at: &str) -> PyResult<Value> {
    if v.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if v.is_instance_of::<PyInt>() {
        if let Ok(i) = v.extract::<i64>() {
            return Ok(Value::from(i));
        }
        if let Ok(u) = v.extract::<u64>() {
            return Ok(Value::from(u));
        }
        return Err(bad_request(py, format!("{at}: integer out of range")));
    }
    if v.is_instance_of::<PyFloat>() {
        let x: f64 = v.extract()?;
        return Number::from_f64(x)
            .map(Value::Number)
            .ok_or_else(|| bad_request(py, format!("{at}: {x} is not a finite number")));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(Value::String(s.to_cow()?.into_owned()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut m = Map::new();
        for (k, x) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| bad_request(py, format!("{at}: dict keys must be strings")))?;
            let sub = format!("{at}.{k}");
            m.insert(k, to_json(py, &x, &sub)?);
        }
        return Ok(Value::Object(m));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, x) in v.try_iter()?.enumerate() {
            out.push(to_json(py, &x?, &format!("{at}[{i}]"))?);
        }
        return Ok(Value::Array(out));
    }
    // numpy arrays and scalars (np.int64 is no int subclass): their plain Python form.
    if v.hasattr("tolist")? {
        let plain = v.call_method0("tolist")?;
        if !plain.is(v) {
            return to_json(py, &plain, at);
        }
    }
    Err(bad_request(
        py,
        format!(
            "{at}: cannot send a {} (use dict, list, numpy array, str, number, bool or None)",
            v.get_type().name()?
        ),
    ))
}

fn numbers(a: &[Value]) -> Option<Vec<f64>> {
    a.iter().map(Value::as_f64).collect()
}

fn array1<'py>(py: Python<'py>, v: &[f64]) -> PyResult<Bound<'py, PyAny>> {
    let np = py.import("numpy")?;
    np.call_method1("array", (PyList::new(py, v)?, "float64"))
}

fn pose_array<'py>(py: Python<'py>, p: &[f64; 12]) -> PyResult<Bound<'py, PyAny>> {
    let rows = [
        PyList::new(py, &p[0..4])?,
        PyList::new(py, &p[4..8])?,
        PyList::new(py, &p[8..12])?,
        PyList::new(py, [0.0, 0.0, 0.0, 1.0])?,
    ];
    py.import("numpy")?
        .call_method1("array", (PyList::new(py, rows)?, "float64"))
}

/// JSON as Python: arrays of numbers become numpy arrays (module docs).
pub(crate) fn to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(a) => {
            if let Some(x) = (!a.is_empty()).then(|| numbers(a)).flatten() {
                return array1(py, &x);
            }
            let rows: Option<Vec<Vec<f64>>> = (!a.is_empty())
                .then(|| {
                    a.iter()
                        .map(|r| {
                            r.as_array()
                                .filter(|r| !r.is_empty())
                                .and_then(|r| numbers(r))
                        })
                        .collect()
                })
                .flatten();
            if let Some(rows) = rows
                && rows.iter().all(|r| r.len() == rows[0].len())
            {
                let list = PyList::empty(py);
                for r in &rows {
                    list.append(PyList::new(py, r)?)?;
                }
                return py.import("numpy")?.call_method1("array", (list, "float64"));
            }
            let list = PyList::empty(py);
            for x in a {
                list.append(to_py(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(m) => {
            let d = PyDict::new(py);
            for (k, x) in m {
                d.set_item(k, to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// A joint vector from any 1-D array-like of numbers.
fn vector(py: Python<'_>, q: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let np = py.import("numpy")?;
    let arr = np
        .call_method1("asarray", (q, "float64"))
        .map_err(|e| bad_request(py, format!("{what}: not an array of numbers ({e})")))?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    if ndim != 1 {
        return Err(bad_request(
            py,
            format!("{what}: expected a 1-D array, got {ndim} dimensions"),
        ));
    }
    arr.call_method0("tolist")?.extract()
}

/// One consistent version of a session's model (zero-copy: a view of shared memory).
#[pyclass(unsendable, module = "robosim")]
struct Snapshot {
    snap: Rc<RsSnapshot>,
}

#[pymethods]
impl Snapshot {
    /// The Instance Space version of this snapshot.
    #[getter]
    fn version(&self) -> u64 {
        self.snap.version()
    }

    /// The version of its structure (equal across snapshots differing only in joints/poses).
    #[getter]
    fn structure_version(&self) -> u64 {
        self.snap.structure_version()
    }

    /// The robots' names, in id order.
    fn robots(&self) -> Vec<String> {
        self.snap
            .robots()
            .iter()
            .map(|r| r.name.to_owned())
            .collect()
    }

    /// Every object's name, in index order.
    fn objects(&self) -> Vec<String> {
        (0..self.snap.len())
            .map(|i| self.snap.name(i).to_owned())
            .collect()
    }

    /// The committed joint values of `robot` (numpy float64, rad / m, chain order).
    fn joints<'py>(&self, py: Python<'py>, robot: &str) -> PyResult<Bound<'py, PyAny>> {
        let q = planner::joints_of(&self.snap, robot).map_err(|e| raise(py, e))?;
        array1(py, &q)
    }

    /// The joint limits of `robot`, shape (n, 2): [lo, hi] per joint (rad / m).
    fn limits<'py>(&self, py: Python<'py>, robot: &str) -> PyResult<Bound<'py, PyAny>> {
        planner::joints_of(&self.snap, robot).map_err(|e| raise(py, e))?;
        let r = self
            .snap
            .robot(robot)
            .ok_or_else(|| bad_request(py, robot.to_owned()))?;
        let rows: Vec<Value> = r
            .joints
            .iter()
            .map(|j| Value::from(vec![j.qlim[0], j.qlim[1]]))
            .collect();
        to_py(py, &Value::Array(rows))
    }

    /// The world pose of object `name`: a 4×4 numpy array (m), acting on column vectors.
    fn pose<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let i = self.snap.find(name).ok_or_else(|| {
            raise(
                py,
                ProtocolError::new(
                    ErrorKind::UnknownObject,
                    format!("no object named {name:?}"),
                ),
            )
        })?;
        pose_array(py, &self.snap.world_pose(i))
    }

    fn __repr__(&self) -> String {
        format!(
            "<robosim.Snapshot version={} objects={} robots={:?}>",
            self.snap.version(),
            self.snap.len(),
            self.robots()
        )
    }
}

/// An attachment to a running session (`robosim up …` or `robosim space`).
#[pyclass(unsendable, module = "robosim")]
struct Session {
    planner: Planner,
    name: String,
}

fn wait_sliced<T>(
    py: Python<'_>,
    timeout: f64,
    mut once: impl FnMut(Duration) -> Result<Option<T>, ProtocolError>,
) -> PyResult<Option<T>> {
    if !timeout.is_finite() || timeout < 0.0 {
        return Err(bad_request(
            py,
            format!("timeout: expected a finite number of seconds >= 0, got {timeout}"),
        ));
    }
    let total = Duration::from_secs_f64(timeout);
    let start = Instant::now();
    loop {
        let left = total.saturating_sub(start.elapsed());
        if let Some(x) = once(left.min(WAIT_SLICE)).map_err(|e| raise(py, e))? {
            return Ok(Some(x));
        }
        if start.elapsed() >= total {
            return Ok(None);
        }
        py.check_signals()?;
    }
}

#[pymethods]
impl Session {
    /// Attaches to the running session `name` (`SessionError` when it or its keeper is missing).
    #[new]
    fn new(py: Python<'_>, name: &str) -> PyResult<Self> {
        let planner = Planner::attach(name).map_err(|e| raise(py, e))?;
        Ok(Session {
            planner,
            name: name.to_owned(),
        })
    }

    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// The newest committed snapshot.
    fn snapshot(&mut self, py: Python<'_>) -> PyResult<Snapshot> {
        let snap = self.planner.snapshot().map_err(|e| raise(py, e))?;
        Ok(Snapshot { snap })
    }

    /// The newest version.
    #[getter]
    fn version(&mut self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.planner.snapshot().map_err(|e| raise(py, e))?.version())
    }

    /// The robots' names in the newest snapshot.
    fn robots(&mut self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.planner.robots().map_err(|e| raise(py, e))
    }

    /// `robot`'s committed joints in the newest snapshot (numpy float64).
    fn joints<'py>(&mut self, py: Python<'py>, robot: &str) -> PyResult<Bound<'py, PyAny>> {
        let q = self.planner.joints(robot).map_err(|e| raise(py, e))?;
        array1(py, &q)
    }

    /// Sets `robot`'s joints in one transaction (no collision check: that is `movej`);
    /// returns the acknowledged version. Refusals change nothing.
    fn set_joints(&mut self, py: Python<'_>, robot: &str, q: &Bound<'_, PyAny>) -> PyResult<u64> {
        let q = vector(py, q, "q")?;
        self.planner.set_joints(robot, &q).map_err(|e| raise(py, e))
    }

    /// One transaction of ops `[op, object, args…]` (docs/python.md); the acknowledged version.
    fn transact(&mut self, py: Python<'_>, ops: &Bound<'_, PyAny>) -> PyResult<u64> {
        let ops = to_json(py, ops, "ops")?;
        self.planner.transact_json(&ops).map_err(|e| raise(py, e))
    }

    /// Waits up to `timeout` s for commits after the last one seen; the newest version, or
    /// None on timeout.
    #[pyo3(signature = (timeout = 1.0))]
    fn wait_change(&mut self, py: Python<'_>, timeout: f64) -> PyResult<Option<u64>> {
        let p = &mut self.planner;
        Ok(wait_sliced(py, timeout, |d| p.wait_change(d))?.map(|c| c.version))
    }

    /// Like `wait_change`, with what each commit touched: a list of dicts
    /// {version, aspects, objects, ids, published_ns}, or None on timeout.
    #[pyo3(signature = (timeout = 1.0))]
    fn wait_changes<'py>(
        &mut self,
        py: Python<'py>,
        timeout: f64,
    ) -> PyResult<Option<Bound<'py, PyList>>> {
        let p = &mut self.planner;
        let Some(c) = wait_sliced(py, timeout, |d| p.wait_change(d))? else {
            return Ok(None);
        };
        let out = PyList::empty(py);
        for ch in c.changes {
            let d = PyDict::new(py);
            d.set_item("version", ch.version)?;
            d.set_item("aspects", ch.aspects)?;
            d.set_item("objects", ch.names)?;
            d.set_item("ids", ch.ids)?;
            d.set_item("published_ns", ch.published_ns)?;
            out.append(d)?;
        }
        Ok(Some(out))
    }

    /// Any op of the query protocol (session ops first, then the pure ops): the answer dict
    /// (numbers arrays as numpy arrays), or a raised `RobosimError`.
    fn query<'py>(
        &mut self,
        py: Python<'py>,
        request: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let req = to_json(py, request, "request")?;
        let answer = self.planner.query(&req).map_err(|e| raise(py, e))?;
        to_py(py, &answer)
    }

    /// One command to the session's automation plant (`robosim automation`): `{"cmd": "fault",
    /// "fault": NAME}` injects a failure mode now, `{"cmd": "get"}` reads its state; the plant's
    /// state as a dict (model, t_s, faults, the ringing alarms, online, isolated,
    /// spares_online). `SessionError` when no plant runs in the session or the plant refuses
    /// the command (an unknown or derived failure mode), which then changes nothing.
    fn plant_command<'py>(
        &mut self,
        py: Python<'py>,
        command: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let cmd = to_json(py, command, "command")?;
        let answer = self.planner.plant_command(&cmd).map_err(|e| raise(py, e))?;
        to_py(py, &answer)
    }

    /// The dataflow graph in file `graph` (docs/dataflow.md) on this session, run pass by
    /// pass in this process: `df.step()` reads the sources, fires the graph and writes the
    /// sinks (a sink closer than `tolerance` to the committed value is not written).
    /// `RequestError` naming file:line for a graph with an error.
    #[pyo3(signature = (graph, tolerance = dataflow::TOLERANCE))]
    fn dataflow(
        slf: Bound<'_, Self>,
        graph: std::path::PathBuf,
        tolerance: f64,
    ) -> PyResult<dataflow::Dataflow> {
        let py = slf.py();
        let graph = graph.to_string_lossy().into_owned();
        dataflow::Dataflow::load(py, slf.unbind(), &graph, tolerance)
    }

    /// Robot `name` of this session as a `robosim.Model`: the robot its session ops (`kinv`,
    /// `jacob`) use, compiled from the newest snapshot (base placed in the world).
    fn model(&mut self, py: Python<'_>, name: &str) -> PyResult<model::Model> {
        let snap = self.planner.snapshot().map_err(|e| raise(py, e))?;
        let scene = robosim_scene::CompiledScene::of(&snap);
        let r = scene.robot(name).map_err(|e| {
            raise(
                py,
                ProtocolError::new(ErrorKind::UnknownRobot, format!("robot {name:?}: {e}")),
            )
        })?;
        Ok(model::Model::of(r.robot.clone()))
    }

    /// The session's simulator.
    #[getter]
    fn sim(slf: Bound<'_, Self>) -> Sim {
        Sim {
            session: slf.unbind(),
        }
    }

    fn __repr__(&self) -> String {
        format!("<robosim.Session {:?}>", self.name)
    }
}

/// The session's simulator daemon (`robosim simulator`), commanded like `robosim simctl`.
#[pyclass(unsendable, module = "robosim")]
struct Sim {
    session: Py<Session>,
}

impl Sim {
    fn command<'py>(&self, py: Python<'py>, cmd: Value) -> PyResult<Bound<'py, PyAny>> {
        let mut s = self.session.bind(py).try_borrow_mut()?;
        let v = s.planner.sim_command(&cmd).map_err(|e| raise(py, e))?;
        to_py(py, &v)
    }
}

#[pymethods]
impl Sim {
    /// Lock-step: advances `n` steps and returns the state after them (a dict, `sim_state`).
    #[pyo3(signature = (n = 1))]
    fn step<'py>(&self, py: Python<'py>, n: u64) -> PyResult<Bound<'py, PyAny>> {
        let mut s = self.session.bind(py).try_borrow_mut()?;
        let v = s.planner.sim_step(n).map_err(|e| raise(py, e))?;
        to_py(py, &v)
    }

    /// The simulator's state now.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut s = self.session.bind(py).try_borrow_mut()?;
        let v = s.planner.sim_state().map_err(|e| raise(py, e))?;
        to_py(py, &v)
    }

    /// Sets `robot`'s joint-space target (the controller drives toward it while stepping).
    fn target<'py>(
        &self,
        py: Python<'py>,
        robot: &str,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = vector(py, q, "q")?;
        self.command(
            py,
            serde_json::json!({"cmd": "target", "robot": robot, "q": q}),
        )
    }

    /// Applies joint torques / forces (N·m / N) to `robot` while stepping.
    fn torque<'py>(
        &self,
        py: Python<'py>,
        robot: &str,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let tau = vector(py, tau, "tau")?;
        self.command(
            py,
            serde_json::json!({"cmd": "torque", "robot": robot, "tau": tau}),
        )
    }

    fn pause<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.command(py, serde_json::json!({"cmd": "pause"}))
    }

    fn resume<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.command(py, serde_json::json!({"cmd": "resume"}))
    }

    /// Rebuilds the pipelines from the committed joint values; the clock restarts at 0.
    fn reset<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.command(py, serde_json::json!({"cmd": "reset"}))
    }
}

#[pymodule]
fn _robosim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<Session>()?;
    m.add_class::<Snapshot>()?;
    m.add_class::<Sim>()?;
    m.add("RobosimError", py.get_type::<RobosimError>())?;
    m.add("SessionError", py.get_type::<SessionError>())?;
    m.add("TransactionError", py.get_type::<TransactionError>())?;
    m.add("JointLimitError", py.get_type::<JointLimitError>())?;
    m.add("RequestError", py.get_type::<RequestError>())?;
    m.add("RobotError", py.get_type::<RobotError>())?;
    m.add("UnreachableError", py.get_type::<UnreachableError>())?;
    m.add("NotConvergedError", py.get_type::<NotConvergedError>())?;
    m.add("NotApplicableError", py.get_type::<NotApplicableError>())?;
    m.add("NumericalError", py.get_type::<NumericalError>())?;
    m.add("ShapeError", py.get_type::<ShapeError>())?;
    m.add_class::<model::Model>()?;
    m.add_class::<dataflow::Dataflow>()?;
    m.add_function(wrap_pyfunction!(model::query, m)?)?;
    m.add_function(wrap_pyfunction!(model::collide, m)?)?;
    m.add_function(wrap_pyfunction!(model::distance, m)?)?;
    Ok(())
}
