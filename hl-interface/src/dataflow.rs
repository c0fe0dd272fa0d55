//! `robosim dataflow GRAPH --session S`: a MULTIGRAPH dataflow graph (seed §3.4; the file
//! format and the built-in actor kinds: `robosim_automation::dataflow`, docs/dataflow.md) run
//! as a process of a session.
//!
//! **A pass.** The sources are read from the session — committed joint values and pose
//! components from the Instance Space (zero-copy), numbers from the simulator's state
//! (`simctl get`), the automation plant's ringing alarms —, handed to the graph, which fires
//! until it is quiescent ([`LiveGraph::pass`]), and the sinks are written back: the joints of
//! one robot in one transaction ([`Planner::update_joints`], refused beyond the joint's
//! limits), each pose component in a transaction of its own, and only where the value differs
//! from the committed one by more than the tolerance — so a process that restarts writes
//! nothing until its graph says something new, and a controller that has settled stops
//! committing. Alarm sinks are raised while their value is non-zero: said on stderr, and listed
//! in the process's state.
//!
//! **When a pass runs.** A graph without a rate is data driven: a pass on every commit to the
//! Instance Space, and — when the graph reads the simulator, the plant or the clock, which
//! change without a commit — whenever one of those sources changed, looked at every [`POLL`].
//! A graph with `rate HZ` in its file (or `--rate`) is clocked: a pass at that rate, whatever
//! changed (filters, integrators and PIDs take their `dt` from it), and none in between — a
//! controller whose own write is a commit does not race its loop at commit speed.
//!
//! **Reconfiguration.** The file is looked at every [`POLL`]; when it changed, it is parsed
//! again and the running graph is rewired to it ([`LiveGraph::reconfigure`]): actors whose
//! declaration did not change keep their state. A file with an error is said (file:line) and
//! the running graph goes on. `{"cmd": "reload"}` on the process's command channel does the same
//! at once.
//!
//! **Commands** on `state/<name>/commands` (`name`: `dataflow` unless `--name` says; JSON):
//! `{"cmd": "get"}` answers the state
//! `{"graph": FILE, "passes": N, "writes": N, "values": {node: x, …}, "alarms": [NAME, …],
//!   "sinks": [{"node", "to", "value"}], "errors": […]}`; `{"cmd": "reload"}` reloads the file.
//!
//! A `sim NAME` sink sends `{"cmd": "set", "name": NAME, "value": x, "from": "dataflow"}` to
//! the simulator whenever its value changed (within the process: a restarted one sends it
//! again), before the pass is seen in the state: a reader that has seen step N in `values` knows
//! the simulator has the settings of that pass.
//!
//! The process exits on SIGTERM/SIGINT at once (the waits are interrupted), 0; with
//! `--passes N` after N passes.
//!
//! Entry points: [`run`] (the process), [`Runner`] (one graph on a [`Planner`]: load, pass,
//! reload, state — what Python's `robosim.Dataflow` drives).

use crate::planner::{Planner, joints_of};
use crate::{ErrorKind, ProtocolError};
use robosim_automation::dataflow::{
    GraphFileError, GraphSpec, LiveGraph, PassError, Reconfigured, SinkAddr, SourceAddr, load_graph,
};
use robosim_instance_space::state::CommandReceiver;
use robosim_instance_space::{Session, Transaction};
use serde_json::{Value, json};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// How often the file, the simulator's and the plant's state are looked at.
pub const POLL: Duration = Duration::from_millis(100);

/// A sink value closer than this to the committed one is not written (m or rad).
pub const DEFAULT_TOLERANCE: f64 = 1e-9;

#[derive(Debug, thiserror::Error)]
pub enum DataflowError {
    #[error(transparent)]
    File(#[from] GraphFileError),
    #[error("{file}: {source}")]
    Build {
        file: String,
        #[source]
        source: Box<robosim_automation::dataflow::BuildError>,
    },
    #[error("{file}: a pass failed: {source}")]
    Pass {
        file: String,
        #[source]
        source: PassError,
    },
    #[error("{0}")]
    Session(#[from] ProtocolError),
    #[error("session: {0}")]
    Registry(#[from] robosim_instance_space::SessionError),
    #[error("session: the command channel: {0}")]
    Commands(#[from] robosim_instance_space::state::StateError),
    #[error("--rate {0} must be a positive number of Hz")]
    Rate(f64),
    #[error("--tolerance {0} must be zero or a positive number")]
    Tolerance(f64),
}

/// What identifies a version of the graph file (changed: parse it again).
#[derive(Debug, Clone, PartialEq)]
struct Stamp {
    modified: Option<SystemTime>,
    len: u64,
    text: Option<String>,
}

fn stamp(path: &Path) -> Option<Stamp> {
    let m = std::fs::metadata(path).ok()?;
    Some(Stamp {
        modified: m.modified().ok(),
        len: m.len(),
        // Two writes within the file system's timestamp resolution keep the mtime: the text
        // decides (graph files are small).
        text: std::fs::read_to_string(path).ok(),
    })
}

/// What a pass did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PassReport {
    /// Versions of the transactions written.
    pub versions: Vec<u64>,
    /// Alarms raised (new) and cleared this pass.
    pub raised: Vec<String>,
    pub cleared: Vec<String>,
}

/// One graph attached to a session through a [`Planner`] (module docs).
pub struct Runner {
    path: PathBuf,
    live: LiveGraph,
    stamp: Option<Stamp>,
    /// A new version of the file seen once, reloaded when the next look sees it unchanged.
    pending: Option<Option<Stamp>>,
    start: Instant,
    tolerance: f64,
    alarms: BTreeSet<String>,
    /// The last value sent to each `sim NAME` sink (sent again only when it changes).
    sent: BTreeMap<String, f64>,
    /// Source values of the last pass (a pass with the same values is skipped).
    last_sources: Option<Vec<(String, f64)>>,
    /// Sources that could not be read, said once each until they can be read again.
    missing: BTreeMap<String, String>,
    errors: Vec<String>,
    passes: u64,
    writes: u64,
}

fn spec_reads(spec: &GraphSpec, f: impl Fn(&SourceAddr) -> bool) -> bool {
    spec.sources.iter().any(|s| f(&s.addr))
}

/// A number in `v` at the dotted `path` (`space.power.battery_kwh`, `robots.0.q.2`).
fn at_path<'a>(v: &'a Value, path: &str) -> Option<&'a Value> {
    path.split('.').try_fold(v, |v, key| match v {
        Value::Array(a) => a.get(key.parse::<usize>().ok()?),
        Value::Object(m) => m.get(key),
        _ => None,
    })
}

impl Runner {
    /// Loads the graph file at `path`.
    pub fn load(path: &Path, tolerance: f64) -> Result<Runner, DataflowError> {
        if !(tolerance >= 0.0 && tolerance.is_finite()) {
            return Err(DataflowError::Tolerance(tolerance));
        }
        let stamp = stamp(path);
        let spec = load_graph(path)?;
        let file = spec.file.clone();
        let live = LiveGraph::build(spec).map_err(|source| DataflowError::Build {
            file,
            source: Box::new(source),
        })?;
        Ok(Runner {
            path: path.to_owned(),
            live,
            stamp,
            pending: None,
            start: Instant::now(),
            tolerance,
            alarms: BTreeSet::new(),
            sent: BTreeMap::new(),
            last_sources: None,
            missing: BTreeMap::new(),
            errors: Vec::new(),
            passes: 0,
            writes: 0,
        })
    }

    /// The graph running now.
    pub fn spec(&self) -> &GraphSpec {
        self.live.spec()
    }

    /// The running graph on the kernel.
    pub fn live(&self) -> &LiveGraph {
        &self.live
    }

    /// The graph's `rate` line, Hz.
    pub fn rate_hz(&self) -> Option<f64> {
        self.live.spec().rate_hz
    }

    /// Parses the file again and rewires the running graph to it (module docs). On an error
    /// the running graph is unchanged.
    pub fn reload(&mut self) -> Result<Reconfigured, DataflowError> {
        self.stamp = stamp(&self.path);
        let spec = load_graph(&self.path)?;
        let file = spec.file.clone();
        let r = self
            .live
            .reconfigure(spec)
            .map_err(|source| DataflowError::Build {
                file,
                source: Box::new(source),
            })?;
        // The next pass runs whatever the sources say: the graph is new.
        self.last_sources = None;
        Ok(r)
    }

    /// [`reload`](Self::reload) when the file changed since it was last read; `None` when it
    /// did not.
    /// A change is acted on once the file has stayed the same for one look (an editor that
    /// writes the file in pieces is not read half-written).
    pub fn reload_if_changed(&mut self) -> Option<Result<Reconfigured, DataflowError>> {
        let now = stamp(&self.path);
        if now == self.stamp {
            self.pending = None;
            return None;
        }
        if self.pending.as_ref() != Some(&now) {
            self.pending = Some(now);
            return None;
        }
        self.pending = None;
        let r = self.reload();
        // A file with an error is said once, not on every look.
        self.stamp = now;
        Some(r)
    }

    /// Reads every source from the session; a source that cannot be read is left out (said
    /// once on stderr).
    fn read_sources(&mut self, p: &mut Planner) -> Result<Vec<(String, f64)>, DataflowError> {
        let spec = self.live.spec().clone();
        let snap = p.snapshot()?;
        let sim = if spec_reads(&spec, |a| matches!(a, SourceAddr::Sim { .. })) {
            Some(p.sim_state())
        } else {
            None
        };
        let plant = if spec_reads(&spec, |a| matches!(a, SourceAddr::Alarm { .. })) {
            Some(p.plant_command(&json!({"cmd": "get"})))
        } else {
            None
        };
        let mut out = Vec::new();
        for s in &spec.sources {
            let value: Result<f64, String> = match &s.addr {
                SourceAddr::Joint { robot, index } => joints_of(&snap, robot)
                    .map_err(|e| e.to_string())
                    .and_then(|q| {
                        q.get(*index).copied().ok_or_else(|| {
                            format!("robot {robot} has {} joints, no joint {index}", q.len())
                        })
                    }),
                SourceAddr::Pose { object, axis } => snap
                    .find(object)
                    .map(|i| snap.pose(i).pose[3 + 4 * axis.index()])
                    .ok_or_else(|| format!("no object named {object:?} in the session")),
                SourceAddr::Sim { path } => match &sim {
                    Some(Ok(state)) => at_path(state, path)
                        .and_then(|v| v.as_f64().or_else(|| v.as_bool().map(f64::from_bool)))
                        .ok_or_else(|| format!("the simulator's state has no number at {path}")),
                    Some(Err(e)) => Err(e.to_string()),
                    None => Err("the simulator's state was not read".into()),
                },
                SourceAddr::Alarm { name } => match &plant {
                    Some(Ok(state)) => Ok(f64::from_bool(
                        state
                            .get("alarms")
                            .and_then(Value::as_array)
                            .into_iter()
                            .flatten()
                            .any(|a| a.get("alarm").and_then(Value::as_str) == Some(name)),
                    )),
                    // No plant: no alarm rings.
                    Some(Err(_)) => Ok(0.0),
                    None => Ok(0.0),
                },
                SourceAddr::Const(x) => Ok(*x),
                SourceAddr::Clock => Ok(self.start.elapsed().as_secs_f64()),
            };
            match value {
                Ok(x) => {
                    if self.missing.remove(&s.name).is_some() {
                        eprintln!("dataflow: source {} ({}) reads again", s.name, s.addr);
                    }
                    out.push((s.name.clone(), x));
                }
                Err(m) => {
                    if self.missing.get(&s.name) != Some(&m) {
                        eprintln!(
                            "dataflow: source {} ({}) cannot be read: {m}",
                            s.name, s.addr
                        );
                        self.missing.insert(s.name.clone(), m);
                    }
                }
            }
        }
        Ok(out)
    }

    /// One pass (module docs). With `force` false the pass is skipped (`Ok(None)`) when no
    /// source changed since the last one (a clock source always changes: graphs that read it
    /// run on every look).
    pub fn pass(
        &mut self,
        p: &mut Planner,
        force: bool,
    ) -> Result<Option<PassReport>, DataflowError> {
        let sources = self.read_sources(p)?;
        if !force && self.last_sources.as_ref() == Some(&sources) {
            return Ok(None);
        }
        let file = self.live.spec().file.clone();
        let given: Vec<(&str, f64)> = sources.iter().map(|(n, x)| (n.as_str(), *x)).collect();
        let sinks = self
            .live
            .pass(&given)
            .map_err(|source| DataflowError::Pass { file, source })?;
        self.last_sources = Some(sources);
        self.passes += 1;
        for e in self.live.new_errors() {
            eprintln!("dataflow: {e}");
            self.errors.push(e);
            if self.errors.len() > 100 {
                self.errors.remove(0);
            }
        }
        let mut report = PassReport::default();
        let snap = p.snapshot()?;
        // Joints: one transaction per robot, only where the value moved.
        let mut joints: BTreeMap<String, Vec<(usize, f64)>> = BTreeMap::new();
        let mut poses: Vec<(String, usize, f64)> = Vec::new();
        let mut alarms = BTreeSet::new();
        let mut settings: Vec<(String, f64)> = Vec::new();
        for s in &sinks {
            let Some(x) = s.value else { continue };
            match &s.sink.addr {
                SinkAddr::Joint { robot, index } => {
                    let now = joints_of(&snap, robot)
                        .ok()
                        .and_then(|q| q.get(*index).copied());
                    if now.is_none_or(|q| (q - x).abs() > self.tolerance) {
                        joints.entry(robot.clone()).or_default().push((*index, x));
                    }
                }
                SinkAddr::Pose { object, axis } => {
                    let now = snap
                        .find(object)
                        .map(|i| snap.pose(i).pose[3 + 4 * axis.index()]);
                    if now.is_none_or(|t| (t - x).abs() > self.tolerance) {
                        poses.push((object.clone(), axis.index(), x));
                    }
                }
                SinkAddr::Alarm { name } => {
                    if x != 0.0 {
                        alarms.insert(name.clone());
                    }
                }
                SinkAddr::Sim { name } => {
                    if self
                        .sent
                        .get(name)
                        .is_none_or(|v| (v - x).abs() > self.tolerance)
                    {
                        settings.push((name.clone(), x));
                    }
                }
            }
        }
        drop(snap);
        let mut failed = Vec::new();
        // Simulator settings: one `set` command each, only when the value changed (a refused
        // one is said and sent again on the next pass).
        for (name, x) in settings {
            match p
                .sim_command(&json!({"cmd": "set", "name": name, "value": x, "from": "dataflow"}))
            {
                Ok(_) => {
                    self.sent.insert(name, x);
                }
                Err(e) => failed.push(format!("sink sim {name}: {e}")),
            }
        }
        for (robot, set) in joints {
            let r = p.update_joints(&robot, |q| {
                for (k, x) in &set {
                    let slot = q.get_mut(*k).ok_or_else(|| {
                        ProtocolError::new(
                            ErrorKind::BadRequest,
                            format!("robot {robot} has no joint {k}"),
                        )
                    })?;
                    *slot = *x;
                }
                Ok(())
            });
            match r {
                Ok(v) => report.versions.push(v),
                Err(e) => failed.push(format!("sink joint {robot}: {e}")),
            }
        }
        for (object, k, x) in poses {
            let r = (|| -> Result<u64, ProtocolError> {
                let snap = p.snapshot()?;
                let i = snap.find(&object).ok_or_else(|| {
                    ProtocolError::new(
                        ErrorKind::UnknownObject,
                        format!("no object named {object:?}"),
                    )
                })?;
                let mut pose = snap.pose(i).pose;
                pose[3 + 4 * k] = x;
                let mut tx = Transaction::new();
                tx.set_pose(snap.rec(i).id, pose);
                drop(snap);
                p.transact(&tx).map(|c| c.version)
            })();
            match r {
                Ok(v) => report.versions.push(v),
                Err(e) => failed.push(format!("sink pose {object}: {e}")),
            }
        }
        for f in failed {
            eprintln!("dataflow: {f}");
            self.errors.push(f);
        }
        self.writes += report.versions.len() as u64;
        report.raised = alarms.difference(&self.alarms).cloned().collect();
        report.cleared = self.alarms.difference(&alarms).cloned().collect();
        for a in &report.raised {
            eprintln!("dataflow: alarm {a} raised");
        }
        for a in &report.cleared {
            eprintln!("dataflow: alarm {a} cleared");
        }
        self.alarms = alarms;
        Ok(Some(report))
    }

    /// The alarms the graph raises now.
    pub fn alarms(&self) -> &BTreeSet<String> {
        &self.alarms
    }

    /// The `get` answer (module docs).
    pub fn state(&self) -> Value {
        let spec = self.live.spec();
        let mut values = serde_json::Map::new();
        let names = spec
            .sources
            .iter()
            .map(|s| &s.name)
            .chain(spec.data.iter().map(|d| &d.name));
        for n in names {
            values.insert(
                n.clone(),
                self.live.value(n).map_or(Value::Null, |x| json!(x)),
            );
        }
        json!({
            "graph": spec.file,
            "rate_hz": spec.rate_hz,
            "passes": self.passes,
            "writes": self.writes,
            "values": values,
            "alarms": self.alarms,
            "sinks": spec.sinks.iter().map(|s| json!({
                "node": s.node,
                "to": s.addr.to_string(),
                "value": self.live.value(&s.node),
            })).collect::<Vec<_>>(),
            "actors": spec.actors.iter().map(|a| json!({
                "name": a.name,
                "kind": a.kind,
                "fired": self.live.fired(&a.name),
            })).collect::<Vec<_>>(),
            "errors": self.errors,
        })
    }
}

trait FromBool {
    fn from_bool(b: bool) -> f64;
}
impl FromBool for f64 {
    fn from_bool(b: bool) -> f64 {
        f64::from(u8::from(b))
    }
}

/// The options of `robosim dataflow`.
#[derive(Debug, Clone)]
pub struct Options {
    /// The process's role and command channel (`dataflow`).
    pub name: String,
    /// Runs passes at this rate too (overrides the file's `rate` line for the process's
    /// clock; the actors' `dt` stays what the file says).
    pub rate_hz: Option<f64>,
    pub tolerance: f64,
    /// Stop after this many passes (scripts, the README); `None`: until SIGTERM.
    pub passes: Option<u64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            name: "dataflow".into(),
            rate_hz: None,
            tolerance: DEFAULT_TOLERANCE,
            passes: None,
        }
    }
}

/// `robosim dataflow GRAPH --session S`: runs until SIGTERM/SIGINT (module docs).
pub fn run(graph: &Path, session: Option<&str>, opts: &Options) -> Result<(), DataflowError> {
    if let Some(hz) = opts.rate_hz
        && !(hz > 0.0 && hz.is_finite())
    {
        return Err(DataflowError::Rate(hz));
    }
    let mut runner = Runner::load(graph, opts.tolerance)?;
    let session = Session::existing(session)?;
    let signals = session.node(&format!("{}-signals", opts.name), true)?;
    let Some(mut planner) = attach(&session, |t| signals.wait(t).is_err())? else {
        eprintln!("dataflow: stopped before the keeper came");
        return Ok(());
    };
    let mut commands = CommandReceiver::create(&session, &opts.name)?;
    let polls_peers = {
        let spec = runner.spec();
        spec_reads(spec, |a| {
            matches!(
                a,
                SourceAddr::Sim { .. } | SourceAddr::Alarm { .. } | SourceAddr::Clock
            )
        })
    };
    // The first pass catches up with the session as it is (a restarted process writes only
    // what differs from what is committed).
    let mut ran = u64::from(say_pass(runner.pass(&mut planner, true)));
    let done = |ran: u64| opts.passes.is_some_and(|n| ran >= n);
    let _registration = session.register(
        &opts.name,
        &[
            "space/objects",
            "space/poses",
            "space/changes",
            &format!("state/{}/commands", opts.name),
        ],
    )?;
    let s = runner.spec();
    eprintln!(
        "dataflow: {} on session {} ({} sources, {} actors, {} sinks{})",
        graph.display(),
        session.name(),
        s.sources.len(),
        s.actors.len(),
        s.sinks.len(),
        opts.rate_hz
            .or(s.rate_hz)
            .map_or(String::new(), |hz| format!(", {hz} Hz"))
    );
    let mut next_tick = Instant::now();
    let mut last_look = Instant::now();
    let mut planner_error: Option<String> = None;
    while !done(ran) && signals.wait(Duration::ZERO).is_ok() {
        let period = opts
            .rate_hz
            .or(runner.rate_hz())
            .map(|hz| Duration::from_secs_f64(1.0 / hz));
        let until_tick = period.map(|_| next_tick.saturating_duration_since(Instant::now()));
        let timeout = until_tick.map_or(POLL, |t| t.min(POLL));
        let changed = match planner.wait_change(timeout) {
            Ok(c) => {
                if planner_error.take().is_some() {
                    eprintln!("dataflow: the session answers again");
                }
                c.is_some()
            }
            Err(e) => {
                // SIGTERM/SIGINT interrupt the wait: stop cleanly.
                if signals.wait(Duration::ZERO).is_err() {
                    break;
                }
                let m = e.to_string();
                if planner_error.as_deref() != Some(m.as_str()) {
                    eprintln!("dataflow: following the session: {m}");
                    planner_error = Some(m);
                }
                std::thread::sleep(POLL);
                false
            }
        };
        let tick = period.is_some_and(|_| Instant::now() >= next_tick);
        if let Some(p) = period
            && tick
        {
            next_tick += p;
            // A pass slower than the period does not queue passes up.
            if next_tick < Instant::now() {
                next_tick = Instant::now() + p;
            }
        }
        let look = last_look.elapsed() >= POLL;
        let mut reloaded = false;
        if look {
            last_look = Instant::now();
            match runner.reload_if_changed() {
                None => {}
                Some(Ok(r)) => {
                    eprintln!("dataflow: {} reloaded: {r}", graph.display());
                    reloaded = true;
                }
                Some(Err(e)) => eprintln!("dataflow: {e} (the running graph goes on)"),
            }
        }
        for cmd in commands.drain()? {
            let answer = serde_json::from_slice::<Value>(cmd.bytes())
                .map_err(|e| format!("not JSON: {e}"))
                .and_then(|v| match v.get("cmd").and_then(Value::as_str) {
                    Some("get") => Ok(runner.state()),
                    Some("reload") => runner
                        .reload()
                        .map(|r| {
                            reloaded = true;
                            json!({"reloaded": r.to_string()})
                        })
                        .map_err(|e| e.to_string()),
                    other => Err(format!("unknown command {other:?} (get, reload)")),
                });
            match answer {
                Ok(v) => cmd.reply(v.to_string().as_bytes()),
                Err(e) => cmd.reply(format!("refused: {e}").as_bytes()),
            }
        }
        // Clocked graphs run at their rate; the others on every change (module docs).
        let due = if period.is_some() {
            tick || reloaded
        } else {
            changed || reloaded || (look && polls_peers)
        };
        if due {
            ran += u64::from(say_pass(runner.pass(&mut planner, tick || reloaded)));
        }
    }
    match opts.passes {
        Some(n) if done(ran) => eprintln!(
            "dataflow: stopped after {n} passes ({} written)",
            runner.writes
        ),
        _ => eprintln!("dataflow: stopped"),
    }
    Ok(())
}

/// Attaches a planner to `session`, waiting for its keeper when none runs yet (a dataflow
/// process may start before the keeper: processes of a session start in any order); `None`
/// when SIGTERM/SIGINT came first.
/// `stopped(t)` waits up to `t` for a termination signal and says whether one came.
fn attach(
    session: &Session,
    stopped: impl Fn(Duration) -> bool,
) -> Result<Option<Planner>, DataflowError> {
    let mut said = false;
    loop {
        match Planner::attach_to(session) {
            Ok(p) => {
                if said {
                    eprintln!("dataflow: the keeper of session {} is up", session.name());
                }
                return Ok(Some(p));
            }
            Err(e) if e.kind == ErrorKind::Session => {
                if !said {
                    eprintln!("dataflow: waiting for the keeper ({})", e.message);
                    said = true;
                }
                if stopped(POLL) {
                    return Ok(None);
                }
            }
            Err(e) => return Err(e.into()),
        }
    }
}

/// A failed pass is said; the process goes on (the next change may heal it).
/// Whether a pass ran.
fn say_pass(r: Result<Option<PassReport>, DataflowError>) -> bool {
    match r {
        Ok(ran) => ran.is_some(),
        Err(e) => {
            eprintln!("dataflow: {e}");
            true
        }
    }
}
