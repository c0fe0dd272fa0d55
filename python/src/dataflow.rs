//! `Session.dataflow(graph)`: a dataflow graph file (docs/dataflow.md) run pass by pass in the
//! Python process, on the session's planner — the same passes `robosim dataflow` runs
//! (`robosim_hl_interface::dataflow::Runner`): sources read from the session, sinks written
//! back as transactions.

use crate::{Session, raise, to_py};
use pyo3::prelude::*;
use robosim_hl_interface::dataflow::{DEFAULT_TOLERANCE, DataflowError, Runner};
use robosim_hl_interface::{ErrorKind, ProtocolError};
use serde_json::json;

/// A dataflow error as the Python exception of its kind: a session's as `SessionError`, a
/// graph file's (file:line) and every other as `RequestError`.
fn err(py: Python<'_>, e: DataflowError) -> PyErr {
    match e {
        DataflowError::Session(p) => raise(py, p),
        other => raise(
            py,
            ProtocolError::new(ErrorKind::BadRequest, other.to_string()),
        ),
    }
}

/// A dataflow graph running on a session, one pass per `step()` (docs/dataflow.md).
#[pyclass(unsendable, module = "robosim")]
pub(crate) struct Dataflow {
    session: Py<Session>,
    runner: Runner,
}

impl Dataflow {
    pub(crate) fn load(
        py: Python<'_>,
        session: Py<Session>,
        graph: &str,
        tolerance: f64,
    ) -> PyResult<Dataflow> {
        let runner =
            Runner::load(std::path::Path::new(graph), tolerance).map_err(|e| err(py, e))?;
        Ok(Dataflow { session, runner })
    }
}

#[pymethods]
impl Dataflow {
    /// One pass: the sources read from the session, the graph fired until quiescent, the
    /// sinks written. A dict: `versions` (of the transactions written), `raised` and `cleared`
    /// (the graph's alarms).
    fn step<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut s = self.session.bind(py).try_borrow_mut()?;
        let r = self
            .runner
            .pass(&mut s.planner, true)
            .map_err(|e| err(py, e))?
            .unwrap_or_default();
        to_py(
            py,
            &json!({"versions": r.versions, "raised": r.raised, "cleared": r.cleared}),
        )
    }

    /// Parses the file again and rewires the graph to it, keeping the state of the actors
    /// whose declaration did not change: `{"kept", "replaced", "added", "removed"}` (actor
    /// names). `RequestError` (file:line) for a file with an error; the graph is then unchanged.
    fn reload<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let r = self.runner.reload().map_err(|e| err(py, e))?;
        to_py(
            py,
            &json!({"kept": r.kept, "replaced": r.replaced, "added": r.added, "removed": r.removed}),
        )
    }

    /// The last value of data node `name` (None: not written yet, or no such node).
    fn value(&self, name: &str) -> Option<f64> {
        self.runner.live().value(name)
    }

    /// The graph's state: the `{"cmd": "get"}` answer of `robosim dataflow` (values of every
    /// node, sinks, alarms, actors with their firing counts, passes, writes, errors).
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.runner.state())
    }

    fn __repr__(&self) -> String {
        let s = self.runner.spec();
        format!(
            "Dataflow({:?}: {} sources, {} actors, {} sinks)",
            s.file,
            s.sources.len(),
            s.actors.len(),
            s.sinks.len()
        )
    }
}

/// The default tolerance, for the signature.
pub(crate) const TOLERANCE: f64 = DEFAULT_TOLERANCE;
