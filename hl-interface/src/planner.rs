//! The planner client: a process attached to a running session over iceoryx2 itself — not over
//! a child's pipes ([`crate::client`]) — reading the Instance Space zero-copy, waiting for its
//! changes, writing transactions, answering every op of the query protocol (the session ops of
//! [`crate::session`] and the pure ops) in-process, and driving the session's simulator.
//! The Python package `robosim` (python/, docs/python.md) and the CLIPS bridge
//! (`robosim rules`, docs/rules.md) are built on it.
//!
//! ```no_run
//! use robosim_hl_interface::planner::Planner;
//! use std::time::Duration;
//! let mut p = Planner::attach("lab")?;
//! let q = p.joints("puma560")?;
//! let v = p.set_joints("puma560", &q)?;              // one transaction, acknowledged
//! let next = p.wait_change(Duration::from_secs(1))?; // what changed after it, or None
//! let ik = p.query(&serde_json::json!({"op": "kinv", "robot": "puma560",
//!                                      "pose": [[1,0,0,0.5],[0,1,0,0],[0,0,1,0.3],[0,0,0,1]]}));
//! let state = p.sim_step(10)?;                       // lock-step: 10 steps, then the state
//! # Ok::<(), robosim_hl_interface::ProtocolError>(())
//! ```
//!
//! **Errors.** Every call answers a [`ProtocolError`] (kind and message), the same the query
//! protocol frames: `session` for a missing session or keeper, a dead keeper or simulator;
//! `transaction` for a refused transaction; `joint_limit`, `unknown_robot`, `bad_request`, …
//! from the ops. A refusal changes nothing.
//!
//! **Changes.** [`Planner::wait_change`] returns every commit after the last one it returned
//! (the planner's own writes included, in version order), with what each touched (the
//! [`aspect`] names and the objects' names), or `None` when nothing was committed within the
//! timeout. The snapshot then is the newest version.
//!
//! **Lock-step.** [`Planner::sim_step`] queues `n` steps on the simulator daemon and returns
//! only when they are done, with the simulator's state (the `sim_state` answer). It refuses a
//! free-running simulator (`--mode realtime|fast` and not paused): only a simulator that steps
//! when told can be kept from running ahead of the planner. A transaction acknowledged before
//! `sim_step` is seen by the simulator before its first step (the keeper publishes before it
//! acknowledges, and the daemon follows the published model before stepping), so the same
//! script gives the same states, bit for bit.

use crate::session::{OPS as SESSION_OPS, Ops};
use crate::{ErrorKind, Extension, ProtocolError};
use robosim_instance_space::state::CommandSender;
use robosim_instance_space::{Committed, Id, Session, Snapshot, Transaction, aspect};
use serde_json::{Value, json};
use std::rc::Rc;
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, ProtocolError>;

fn session_err(message: impl Into<String>) -> ProtocolError {
    ProtocolError::new(ErrorKind::Session, message)
}

/// A `session` error from the session layer's typed error: its message and every cause
/// ([`robosim_instance_space::error_chain`]), since the protocol's error carries words only.
fn session_failed(e: &dyn std::error::Error) -> ProtocolError {
    session_err(robosim_instance_space::error_chain(e))
}

/// How long a simulator command waits for the daemon's answer.
const SIM_TIMEOUT: Duration = Duration::from_secs(10);

/// One committed transaction as a planner sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct ChangeInfo {
    pub version: u64,
    /// [`aspect`] names: `structure`, `geometry`, `pose`, `appearance`, `kinematics`, `dynamics`.
    pub aspects: Vec<&'static str>,
    /// The ids of the objects the transaction touched.
    pub ids: Vec<Id>,
    /// Their names in the newest snapshot (`""` for an object deleted since).
    pub names: Vec<String>,
    /// CLOCK_MONOTONIC ns when the keeper published it.
    pub published_ns: u64,
}

/// The commits one [`Planner::wait_change`] returned, in version order (never empty).
#[derive(Debug, Clone, PartialEq)]
pub struct Changes {
    /// The newest version among them.
    pub version: u64,
    /// Some commits between the last return and these were not seen (the reader's change log
    /// had moved on); the snapshot is current all the same.
    pub lost: bool,
    pub changes: Vec<ChangeInfo>,
}

/// A planner's attachment to a session (module docs).
pub struct Planner {
    ops: Ops,
    sim: Option<CommandSender>,
    /// The automation plant's command channel (`robosim automation`), opened on first use.
    plant: Option<CommandSender>,
    /// The newest version [`Planner::wait_change`] returned (at first: the attached snapshot's).
    seen: u64,
}

impl Planner {
    /// Attaches to the running session `name`: a clear `session` error when there is no such
    /// session or no keeper runs in it.
    pub fn attach(name: &str) -> Result<Planner> {
        let session = Session::existing(Some(name)).map_err(|e| session_failed(&e))?;
        Self::attach_to(&session)
    }

    /// [`Planner::attach`] for an already opened [`Session`].
    pub fn attach_to(session: &Session) -> Result<Planner> {
        // A keeper that is gone may leave its services behind while other attachments hold
        // them open: ask the session's process registry first, so the answer is immediate.
        if !session.processes().iter().any(|p| p.role == "space") {
            return Err(session_err(format!(
                "no keeper is running in session {} (start one with `robosim up SCENE --session {}` or `robosim space --session {}`)",
                session.name(),
                session.name(),
                session.name()
            )));
        }
        let mut ops = Ops::attach(session).map_err(|e| session_failed(&e))?;
        let seen = ops.reader_mut().snapshot().map_or(0, |s| s.version());
        Ok(Planner {
            ops,
            sim: None,
            plant: None,
            seen,
        })
    }

    pub fn session(&self) -> &Session {
        self.ops.session()
    }

    /// The newest committed snapshot (zero-copy: the model stays in shared memory).
    pub fn snapshot(&mut self) -> Result<Rc<Snapshot>> {
        let r = self.ops.reader_mut();
        r.refresh().map_err(|e| session_failed(&e))?;
        r.snapshot()
            .ok_or_else(|| session_err("the keeper has published no model"))
    }

    /// The names of the robots in the newest snapshot, in id order.
    pub fn robots(&mut self) -> Result<Vec<String>> {
        let s = self.snapshot()?;
        Ok(s.robots().iter().map(|r| r.name.to_owned()).collect())
    }

    /// The committed joint values of `robot` (rad / m, chain order).
    pub fn joints(&mut self, robot: &str) -> Result<Vec<f64>> {
        let snap = self.snapshot()?;
        joints_of(&snap, robot)
    }

    /// Sets `robot`'s joints (and its link poses) in one transaction; the acknowledged version.
    /// See [`Ops::set_joints`] for what is refused.
    pub fn set_joints(&mut self, robot: &str, q: &[f64]) -> Result<u64> {
        self.ops.set_joints(robot, q)
    }

    /// Changes `robot`'s committed joint values by `change` (read, changed and written in one
    /// transaction, read again when another writer moved the robot in between); the
    /// acknowledged version. See [`Ops::update_joints`].
    pub fn update_joints(
        &mut self,
        robot: &str,
        change: impl FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<u64> {
        self.ops.update_joints(robot, change)
    }

    /// Sends a transaction and waits for the keeper's acknowledgement.
    pub fn transact(&mut self, tx: &Transaction) -> Result<Committed> {
        self.ops
            .client_mut()
            .transact(tx)
            .map_err(crate::session::client_err)
    }

    /// Builds one transaction from its JSON form and sends it: an array of ops, each an array
    /// `[op, object, args…]` naming objects as the newest snapshot does —
    /// `["set_joint", obj, value]` (rad / m), `["set_pose", obj, T]` (T: 4×4 or 3×4 row-major,
    /// parent frame, m), `["set_name", obj, new]`, `["attach", obj, parent]`, `["detach", obj]`,
    /// `["delete", obj, recursive?]`. All of it commits or none (a refusal changes nothing);
    /// the acknowledged version.
    pub fn transact_json(&mut self, ops: &Value) -> Result<u64> {
        let snap = self.snapshot()?;
        let tx = transaction_from_json(&snap, ops)?;
        self.transact(&tx).map(|c| c.version)
    }

    /// Waits up to `timeout` for commits after the last one returned (module docs). A zero
    /// timeout only looks; a timeout under 1 ms waits 1 ms (iceoryx2's timed wait blocks
    /// without end below its resolution).
    pub fn wait_change(&mut self, timeout: Duration) -> Result<Option<Changes>> {
        let seen = self.seen;
        let r = self.ops.reader_mut();
        let lost = |e: robosim_instance_space::ReaderError| session_failed(&e);
        // A planner that did not look for a long while may have missed change records (the
        // reader's log is bounded): it gets what is still known, marked `lost`.
        let mut missed = false;
        let mut since = |r: &mut robosim_instance_space::Reader| match r.changes_since(seen) {
            Err(robosim_instance_space::ReaderError::ChangesLost { oldest, .. }) => {
                missed = true;
                r.changes_since(oldest.saturating_sub(1)).map_err(lost)
            }
            other => other.map_err(lost),
        };
        let mut changes = since(r)?;
        if changes.is_empty() && !timeout.is_zero() {
            r.wait_change(timeout.max(Duration::from_millis(1)))
                .map_err(lost)?;
            changes = since(r)?;
        }
        if !changes.is_empty() {
            r.refresh().map_err(lost)?;
        }
        let Some(last) = changes.last() else {
            return Ok(None);
        };
        let version = last.version;
        self.seen = version;
        let snap = self.ops.reader_mut().snapshot();
        let name = |id: Id| -> String {
            snap.as_ref()
                .and_then(|s| s.index_of(id).map(|k| s.name(k).to_owned()))
                .unwrap_or_default()
        };
        Ok(Some(Changes {
            version,
            lost: missed,
            changes: changes
                .into_iter()
                .map(|c| ChangeInfo {
                    version: c.version,
                    aspects: aspect::names(c.aspects),
                    names: c.ids.iter().map(|id| name(*id)).collect(),
                    ids: c.ids,
                    published_ns: c.published_ns,
                })
                .collect(),
        }))
    }

    /// Answers one request of the query protocol — any op: the session ops (MOVEJ, MOVEJI,
    /// KINV, CHECK, …) on this session, every other op by the pure protocol — exactly as
    /// `robosim query --session` does, as the answer object (no `id`/`ok`) or the refusal.
    pub fn query(&mut self, req: &Value) -> Result<Value> {
        let listing: Vec<(&str, &str)> = SESSION_OPS.iter().map(|op| (*op, "session")).collect();
        let ops = &mut self.ops;
        let mut answer = |op: &str, req: &Value| ops.dispatch(op, req);
        crate::answer_with(
            req,
            Extension {
                ops: &listing,
                answer: &mut answer,
            },
        )
        .map(Value::Object)
    }

    /// Sends one command to the session's simulator (`robosim simctl`'s JSON form) and returns
    /// its answer: the state for `get`, `"ok"` otherwise; a refusal is a `session` error.
    pub fn sim_command(&mut self, cmd: &Value) -> Result<Value> {
        let session = self.ops.session().name().to_owned();
        command(
            self.ops.session(),
            &mut self.sim,
            "simulator",
            cmd,
            &format!(
                "no simulator runs in session {session}: start one with `robosim simulator --session {session} --mode lockstep`"
            ),
        )
    }

    /// Sends one command to the session's automation plant (`robosim automation`,
    /// [`crate::plant`]): `{"cmd": "fault", "fault": NAME}` or `{"cmd": "get"}`; the plant's
    /// state, or a `session` error (no plant, or the command refused).
    pub fn plant_command(&mut self, cmd: &Value) -> Result<Value> {
        let session = self.ops.session().name().to_owned();
        command(
            self.ops.session(),
            &mut self.plant,
            crate::plant::SERVICE,
            cmd,
            &format!(
                "no automation plant runs in session {session}: start one with `robosim automation --session {session}`"
            ),
        )
    }

    /// The simulator's state (`sim_state`).
    pub fn sim_state(&mut self) -> Result<Value> {
        self.sim_command(&json!({"cmd": "get"}))
    }

    /// Lock-step: advances the simulator `n` steps (1..=1,000,000) and returns its state after
    /// them. Refuses a free-running simulator (module docs).
    pub fn sim_step(&mut self, n: u64) -> Result<Value> {
        let before = self.sim_state()?;
        if before.get("running").and_then(Value::as_bool) == Some(true) {
            return Err(session_err(format!(
                "the simulator runs free (mode {}): lock-step needs `--mode lockstep` or a paused simulator (sim.pause())",
                before.get("mode").and_then(Value::as_str).unwrap_or("?")
            )));
        }
        let from = before.get("run_steps").and_then(Value::as_u64).unwrap_or(0);
        let queued = before
            .get("queued_steps")
            .and_then(Value::as_u64)
            .unwrap_or(0);
        self.sim_command(&json!({"cmd": "step", "n": n}))?;
        let want = from + queued + n;
        let start = Instant::now();
        loop {
            let s = self.sim_state()?;
            let done = s.get("run_steps").and_then(Value::as_u64).unwrap_or(0);
            let left = s.get("queued_steps").and_then(Value::as_u64).unwrap_or(0);
            if done >= want && left == 0 {
                return Ok(s);
            }
            if s.get("running").and_then(Value::as_bool) == Some(false) && left == 0 && done < want
            {
                // The daemon paused itself (a failed step) or was reset: the steps will not come.
                return Err(session_err(format!(
                    "the simulator stopped after {} of {n} steps: {}",
                    done.saturating_sub(from + queued),
                    s.get("robots")
                        .and_then(Value::as_array)
                        .and_then(|r| r.iter().find_map(|r| r.get("error")?.as_str()))
                        .unwrap_or("paused or reset")
                )));
            }
            if start.elapsed() > SIM_TIMEOUT + Duration::from_secs(n / 1000) {
                return Err(session_err(format!(
                    "the simulator did not finish {n} steps within {:?}",
                    start.elapsed()
                )));
            }
            std::thread::sleep(Duration::from_micros(100));
        }
    }
}

/// One command on the command channel `target` (the simulator's or the plant's), opened into
/// `slot` on first use and again after a failure (a restarted owner is a new service).
fn command(
    session: &Session,
    slot: &mut Option<CommandSender>,
    target: &str,
    cmd: &Value,
    missing: &str,
) -> Result<Value> {
    if slot.is_none() {
        let role = format!("planner-{target}");
        *slot =
            Some(CommandSender::open(session, target, &role).map_err(|_| session_err(missing))?);
    }
    let Some(sender) = slot.as_mut() else {
        return Err(session_err(missing));
    };
    let answer = match sender.send(cmd.to_string().as_bytes(), SIM_TIMEOUT) {
        Ok(a) => a,
        Err(e) => {
            *slot = None;
            return Err(session_err(format!("the {target}: {e}")));
        }
    };
    let text = String::from_utf8_lossy(&answer);
    if let Some(reason) = text.strip_prefix("refused: ") {
        return Err(session_err(format!("the {target} refused {cmd}: {reason}")));
    }
    Ok(serde_json::from_str(&text).unwrap_or_else(|_| Value::String(text.into_owned())))
}

/// The committed joint values of `robot` in `snap`.
pub fn joints_of(snap: &Snapshot, robot: &str) -> Result<Vec<f64>> {
    snap.robot(robot)
        .map(|r| r.joints.iter().map(|j| j.q).collect())
        .ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::UnknownRobot,
                format!(
                    "no robot named {robot:?} in the session (robots: {})",
                    snap.robots()
                        .iter()
                        .map(|r| r.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
}

fn bad(message: impl Into<String>) -> ProtocolError {
    ProtocolError::new(ErrorKind::BadRequest, message)
}

/// A pose from a 4×4 (last row 0 0 0 1) or 3×4 row-major array.
fn pose_from_json(v: &Value, at: &str) -> Result<robosim_instance_space::Pose> {
    let rows = v
        .as_array()
        .ok_or_else(|| bad(format!("{at}: a pose is a 4×4 or 3×4 array of rows")))?;
    if !(rows.len() == 3 || rows.len() == 4) {
        return Err(bad(format!(
            "{at}: a pose has 3 or 4 rows, got {}",
            rows.len()
        )));
    }
    let mut m = [0.0; 12];
    for (r, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .filter(|row| row.len() == 4)
            .ok_or_else(|| bad(format!("{at}: row {r} must hold 4 numbers")))?;
        for (c, x) in row.iter().enumerate() {
            let x = x
                .as_f64()
                .ok_or_else(|| bad(format!("{at}[{r}][{c}] is not a number")))?;
            if r == 3 {
                let want = if c == 3 { 1.0 } else { 0.0 };
                if x != want {
                    return Err(bad(format!(
                        "{at}: the last row of a pose must be [0, 0, 0, 1], got {x} at column {c}"
                    )));
                }
            } else {
                m[r * 4 + c] = x;
            }
        }
    }
    Ok(m)
}

/// [`Planner::transact_json`]'s transaction, validated against `snap` (objects must exist).
pub fn transaction_from_json(snap: &Snapshot, ops: &Value) -> Result<Transaction> {
    let list = ops
        .as_array()
        .ok_or_else(|| bad("a transaction is an array of ops [op, object, args…]"))?;
    if list.is_empty() {
        return Err(bad("a transaction needs at least one op"));
    }
    let mut tx = Transaction::new();
    for (k, op) in list.iter().enumerate() {
        let at = format!("op {k}");
        let parts = op
            .as_array()
            .filter(|p| p.len() >= 2)
            .ok_or_else(|| bad(format!("{at}: expected [op, object, args…]")))?;
        let name = parts[0]
            .as_str()
            .ok_or_else(|| bad(format!("{at}: the op name must be a string")))?;
        let object = |v: &Value| -> Result<Id> {
            let n = v
                .as_str()
                .ok_or_else(|| bad(format!("{at}: objects are named by strings")))?;
            snap.find(n).map(|i| snap.rec(i).id).ok_or_else(|| {
                ProtocolError::new(
                    ErrorKind::UnknownObject,
                    format!("{at}: no object named {n:?}"),
                )
            })
        };
        let arg = |i: usize| -> Result<&Value> {
            parts
                .get(i)
                .ok_or_else(|| bad(format!("{at}: `{name}` needs argument {i}")))
        };
        let id = object(&parts[1])?;
        match name {
            "set_joint" => {
                let x = arg(2)?
                    .as_f64()
                    .ok_or_else(|| bad(format!("{at}: the joint value must be a number")))?;
                tx.set_joint(id, x);
            }
            "set_pose" => {
                tx.set_pose(id, pose_from_json(arg(2)?, &at)?);
            }
            "set_name" => {
                let n = arg(2)?
                    .as_str()
                    .ok_or_else(|| bad(format!("{at}: the new name must be a string")))?;
                tx.set_name(id, n);
            }
            "attach" => {
                let parent = object(arg(2)?)?;
                tx.attach(id, parent);
            }
            "detach" => {
                tx.detach(id);
            }
            "delete" => {
                let recursive = parts.get(2).and_then(Value::as_bool).unwrap_or(false);
                tx.delete(id, recursive);
            }
            other => {
                return Err(bad(format!(
                    "{at}: unknown transaction op {other:?} (set_joint, set_pose, set_name, attach, detach, delete)"
                )));
            }
        }
    }
    Ok(tx)
}
