//! A macro-dataflow kernel in the spirit of the Multigraph Execution Environment (MEE, seed §3.4
//! and figure 3).
//!
//! A control graph is made of **actor nodes** (active: they run a *script* — a Rust closure or
//! [`Script`] object — with a private *context*, through named input and output ports) and
//! **data nodes** (passive: they store what actors write, either a stream of values or only
//! the last one, [`Retention`]). Connections run data node → actor input port and actor output
//! port → data node.
//!
//! * Firing modes ([`Firing`]): `IfAll` fires when every input port holds a token, `IfAny` when
//!   one does. A token is a value written to the data node and not yet read by that port.
//! * Operation modes ([`Drive`]): a data-driven actor fires as soon as its tokens are there; a
//!   demand-driven actor fires only when something asked for its output. [`Control::request`]
//!   on a data node (an attempted read of an empty node) sends a request token to every actor
//!   writing it; an actor that cannot fire for lack of input sends requests on to the writers of
//!   its empty inputs. Graphs may mix both kinds.
//! * The **system interface**: a scheduler runs ready actors on a pool of worker threads
//!   (`std::thread` + `Mutex`/`Condvar`), or one at a time on the caller's thread
//!   ([`Graph::manual`] + [`Graph::step`], the stepper). Named pools ([`Graph::with_pools`],
//!   [`ActorSpec::pool`]) are the MEE's task structure: an actor runs only on its pool.
//! * The **builder and control interface** ([`Control::edit`]) adds, removes and rewires nodes
//!   of a *running* graph: an edit is applied atomically between firings, without stopping the
//!   workers; a script can edit the graph it runs in ([`Ctx::control`]). Tokens held in a data
//!   node survive rewiring ([`Edit::move_input`] carries the reader's position along).
//! * The **tracer** records each firing ([`TraceRecord`]); [`Control::to_dot`] exports the graph
//!   and its live state (queued tokens, last values, ready/running actors) as Graphviz DOT.
//!
//! Entry points: [`Graph::new`], [`Graph::manual`], [`ActorSpec`], [`Control::edit`],
//! [`Control::write`], [`Control::request`], [`Control::trigger`], [`Graph::wait_idle`],
//! [`Control::trace`], [`Control::to_dot`].

mod dot;

use std::any::Any;
use std::collections::VecDeque;
use std::fmt;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// A value carried by a token.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Unit,
    Bool(bool),
    F64(f64),
    Vec(Vec<f64>),
    Text(String),
}

impl Value {
    /// The number, if this is one.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::F64(x) => Some(*x),
            _ => None,
        }
    }
    /// The vector, if this is one.
    pub fn as_vec(&self) -> Option<&[f64]> {
        match self {
            Value::Vec(v) => Some(v),
            _ => None,
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Unit => write!(f, "()"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::F64(x) => write!(f, "{x:.4}"),
            Value::Vec(v) => {
                write!(f, "[")?;
                for (i, x) in v.iter().enumerate() {
                    if i > 0 {
                        write!(f, ", ")?;
                    }
                    write!(f, "{x:.4}")?;
                }
                write!(f, "]")
            }
            Value::Text(s) => write!(f, "{s:?}"),
        }
    }
}

/// When an actor with inputs may fire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Firing {
    /// Every input port holds a token (classical dataflow; an unconnected port never does).
    IfAll,
    /// At least one input port holds a token.
    IfAny,
}

/// What makes an actor fire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// Fires when its input tokens are present.
    Data,
    /// Fires only to answer a request token (and when its inputs are present).
    Demand,
}

/// What a data node keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Retention {
    /// Every value, in order, until each reader has read it.
    Stream,
    /// Only the last value; a reader sees it once per write.
    LastValue,
}

/// Handle of an actor node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ActorId(pub usize);
/// Handle of a data node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DataId(pub usize);

/// What went wrong in a graph operation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KernelError {
    #[error("no actor with id {0}")]
    UnknownActor(usize),
    #[error("no data node with id {0}")]
    UnknownData(usize),
    #[error("actor `{actor}` has no {dir} port `{port}`")]
    UnknownPort {
        actor: String,
        dir: &'static str,
        port: String,
    },
    #[error("input port `{port}` of actor `{actor}` is already connected")]
    InputTaken { actor: String, port: String },
    #[error("a data node or actor named `{0}` already exists")]
    DuplicateName(String),
    #[error("no worker pool named `{0}`")]
    UnknownPool(String),
    #[error("stepping needs a graph built with Graph::manual")]
    NotManual,
}

/// Why a script's read of an input port ([`Ctx::request`]) failed.
#[derive(Debug, thiserror::Error)]
pub enum PortError {
    /// The actor declares no input port of that name.
    #[error("no input port `{port}`")]
    NoInput { port: String },
    /// The port exists but no data node feeds it.
    #[error("input port `{port}` is not connected")]
    NotConnected { port: String },
    /// The kernel refused the read of the port's data node.
    #[error(transparent)]
    Kernel(#[from] KernelError),
}

/// The code an actor runs (reentrant: one script may serve several actors).
pub trait Script: Send + Sync {
    /// One firing. Reads inputs and writes outputs through `ctx`. An error (or a panic) is
    /// recorded in the trace and in [`Control::errors`]; the firing's outputs are still
    /// delivered and the graph goes on.
    fn fire(&self, ctx: &mut Ctx<'_>) -> Result<(), String>;
}

impl<F> Script for F
where
    F: Fn(&mut Ctx<'_>) -> Result<(), String> + Send + Sync,
{
    fn fire(&self, ctx: &mut Ctx<'_>) -> Result<(), String> {
        self(ctx)
    }
}

/// Declares an actor node.
pub struct ActorSpec {
    name: String,
    inputs: Vec<String>,
    outputs: Vec<String>,
    firing: Firing,
    drive: Drive,
    script: Arc<dyn Script>,
    context: Box<dyn Any + Send>,
    pool: Option<String>,
}

impl ActorSpec {
    /// An actor named `name` running `script`; no ports, `IfAll`, data-driven, unit context.
    pub fn new(name: &str, script: impl Script + 'static) -> Self {
        ActorSpec::shared(name, Arc::new(script))
    }
    /// The same, sharing a reentrant script with other actors.
    pub fn shared(name: &str, script: Arc<dyn Script>) -> Self {
        ActorSpec {
            name: name.to_string(),
            inputs: Vec::new(),
            outputs: Vec::new(),
            firing: Firing::IfAll,
            drive: Drive::Data,
            script,
            context: Box::new(()),
            pool: None,
        }
    }
    pub fn inputs(mut self, names: &[&str]) -> Self {
        self.inputs = names.iter().map(|s| s.to_string()).collect();
        self
    }
    pub fn outputs(mut self, names: &[&str]) -> Self {
        self.outputs = names.iter().map(|s| s.to_string()).collect();
        self
    }
    pub fn firing(mut self, f: Firing) -> Self {
        self.firing = f;
        self
    }
    pub fn drive(mut self, d: Drive) -> Self {
        self.drive = d;
        self
    }
    /// The worker pool that runs this actor (the MEE's task structure; default: the graph's
    /// first pool). See [`Graph::with_pools`].
    pub fn pool(mut self, name: &str) -> Self {
        self.pool = Some(name.to_string());
        self
    }
    /// The actor's local parameter structure, reachable from the script by [`Ctx::context`].
    pub fn context<T: Any + Send>(mut self, c: T) -> Self {
        self.context = Box::new(c);
        self
    }
}

/// Why a firing happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    Data,
    Demand,
    Trigger,
}

/// One firing as the tracer saw it.
#[derive(Debug, Clone)]
pub struct TraceRecord {
    /// Order in which firings started.
    pub seq: u64,
    pub actor: String,
    pub actor_id: ActorId,
    /// Worker thread index (0 for manual stepping).
    pub worker: usize,
    pub reason: Reason,
    /// (input port, value consumed).
    pub inputs: Vec<(String, Value)>,
    /// (output port, value written).
    pub outputs: Vec<(String, Value)>,
    pub error: Option<String>,
}

/// The firing context handed to a script.
pub struct Ctx<'a> {
    inputs: &'a [(String, Option<Value>)],
    latest: &'a [(Option<DataId>, Option<Value>)],
    out_names: &'a [String],
    outputs: Vec<(usize, Value)>,
    context: &'a mut (dyn Any + Send),
    control: &'a Control,
    actor: ActorId,
}

impl Ctx<'_> {
    /// The token consumed on input port `port` by this firing (None: no token on that port —
    /// possible in `IfAny` mode or for a triggered firing).
    pub fn input(&self, port: &str) -> Option<&Value> {
        self.inputs
            .iter()
            .find(|(n, _)| n == port)
            .and_then(|(_, v)| v.as_ref())
    }
    /// [`input`](Self::input) as a number.
    pub fn input_f64(&self, port: &str) -> Option<f64> {
        self.input(port).and_then(Value::as_f64)
    }
    /// The last value of the data node feeding `port`, even if already read (last-value read).
    pub fn latest(&self, port: &str) -> Option<&Value> {
        let i = self.inputs.iter().position(|(n, _)| n == port)?;
        self.latest[i].1.as_ref()
    }
    /// An attempted read of `port`'s data node from inside a script: when the node is empty,
    /// request tokens go to its writers (demand-driven operation); returns the node's last
    /// value. Errors: unknown or unconnected port.
    pub fn request(&self, port: &str) -> Result<Option<Value>, PortError> {
        let i = self
            .inputs
            .iter()
            .position(|(n, _)| n == port)
            .ok_or_else(|| PortError::NoInput { port: port.into() })?;
        let d = self.latest[i]
            .0
            .ok_or_else(|| PortError::NotConnected { port: port.into() })?;
        Ok(self.control.request(d)?)
    }
    /// Writes `value` on output port `port` (delivered to every connected data node when the
    /// firing ends). Unknown ports are an error of the script.
    pub fn emit(&mut self, port: &str, value: Value) -> Result<(), String> {
        let i = self
            .out_names
            .iter()
            .position(|n| n == port)
            .ok_or_else(|| format!("no output port `{port}`"))?;
        self.outputs.push((i, value));
        Ok(())
    }
    /// The actor's context, if it has type `T`.
    pub fn context<T: Any>(&mut self) -> Option<&mut T> {
        self.context.downcast_mut::<T>()
    }
    /// The builder and control interface of the graph this actor runs in.
    pub fn control(&self) -> &Control {
        self.control
    }
    /// This actor's handle.
    pub fn actor_id(&self) -> ActorId {
        self.actor
    }
}

struct InPort {
    name: String,
    source: Option<DataId>,
    /// Sequence number of the next value this port reads.
    cursor: u64,
}

struct OutPort {
    name: String,
    targets: Vec<DataId>,
}

struct ActorSlot {
    name: String,
    /// Index of the worker pool that runs it.
    pool: usize,
    inputs: Vec<InPort>,
    outputs: Vec<OutPort>,
    firing: Firing,
    drive: Drive,
    script: Arc<dyn Script>,
    /// None while the actor is firing (the worker holds it).
    context: Option<Box<dyn Any + Send>>,
    running: bool,
    queued: bool,
    removed: bool,
    requests: u64,
    permits: u64,
    fired: u64,
}

struct DataSlot {
    name: String,
    retention: Retention,
    buf: VecDeque<Value>,
    /// Sequence number of `buf[0]`.
    base: u64,
    /// Sequence number the next write gets.
    next: u64,
    last: Option<Value>,
    /// (actor, input port) reading this node.
    readers: Vec<(usize, usize)>,
    /// (actor, output port) writing this node.
    writers: Vec<(usize, usize)>,
}

impl DataSlot {
    fn unlink_reader(&mut self, a: usize, i: usize) {
        self.readers.retain(|&r| r != (a, i));
    }
    fn unlink_writer(&mut self, a: usize, i: usize) {
        self.writers.retain(|&w| w != (a, i));
    }
}

/// Forgets actor `a` as a writer of every node its outputs feed (when its slot is freed).
fn unlink_writers(data: &mut [Option<DataSlot>], a: usize, slot: &ActorSlot) {
    for (i, p) in slot.outputs.iter().enumerate() {
        for d in &p.targets {
            if let Some(dn) = data.get_mut(d.0).and_then(|x| x.as_mut()) {
                dn.unlink_writer(a, i);
            }
        }
    }
}

#[derive(Default)]
struct State {
    actors: Vec<Option<ActorSlot>>,
    data: Vec<Option<DataSlot>>,
    /// Ready actors, one queue per worker pool.
    ready: Vec<VecDeque<usize>>,
    /// Worker pool names (index 0 is the default).
    pools: Vec<String>,
    running: usize,
    shutdown: bool,
    tracing: bool,
    trace: Vec<TraceRecord>,
    seq: u64,
    errors: Vec<String>,
}

struct Shared {
    state: Mutex<State>,
    work: Condvar,
    idle: Condvar,
}

/// The builder and control interface (cheap to clone; scripts get one through [`Ctx`]).
#[derive(Clone)]
pub struct Control {
    shared: Arc<Shared>,
}

/// A control graph with its scheduler. Dropping it stops and joins the workers.
pub struct Graph {
    control: Control,
    workers: Vec<JoinHandle<()>>,
    manual: bool,
}

impl std::ops::Deref for Graph {
    type Target = Control;
    fn deref(&self) -> &Control {
        &self.control
    }
}

impl Graph {
    /// A graph whose ready actors run on `workers` threads (at least one), one pool.
    pub fn new(workers: usize) -> Graph {
        Graph::with_pools(&[("default", workers)])
    }

    /// A graph with named worker pools — the MEE's "environment and task structure" that
    /// assigns resources to actors: an actor declared with [`ActorSpec::pool`] runs only on its
    /// pool's threads (e.g. a real-time control loop apart from slow supervision). The first
    /// pool is the default. Each pool gets at least one thread.
    pub fn with_pools(pools: &[(&str, usize)]) -> Graph {
        let pools: Vec<(&str, usize)> = if pools.is_empty() {
            vec![("default", 1)]
        } else {
            pools.to_vec()
        };
        let control = Control::fresh_with(pools.iter().map(|p| p.0.to_string()).collect());
        let mut workers = Vec::new();
        let mut w = 0;
        for (pool, &(_, n)) in pools.iter().enumerate() {
            for _ in 0..n.max(1) {
                let c = control.clone();
                let id = w;
                workers.push(std::thread::spawn(move || c.worker_loop(id, pool)));
                w += 1;
            }
        }
        Graph {
            control,
            workers,
            manual: false,
        }
    }

    /// A graph without workers: actors fire only through [`Graph::step`] (the stepper).
    pub fn manual() -> Graph {
        Graph {
            control: Control::fresh_with(vec!["default".to_string()]),
            workers: Vec::new(),
            manual: true,
        }
    }

    /// The control interface (for handing to other threads).
    pub fn control(&self) -> Control {
        self.control.clone()
    }

    /// Fires one ready actor on this thread; returns its trace record (None: nothing ready).
    pub fn step(&self) -> Result<Option<TraceRecord>, KernelError> {
        if !self.manual {
            return Err(KernelError::NotManual);
        }
        let mut st = self.control.lock();
        while let Some(a) = st.ready.iter_mut().find_map(|q| q.pop_front()) {
            if let Some(slot) = st.actors[a].as_mut() {
                slot.queued = false;
                if self.control.can_fire(&st, a) {
                    let (st2, rec) = self.control.fire(st, a, 0);
                    drop(st2);
                    return Ok(Some(rec));
                }
            }
        }
        Ok(None)
    }

    /// Steps until nothing is ready or `max` firings happened; returns the number fired.
    pub fn run_manual(&self, max: usize) -> Result<usize, KernelError> {
        let mut n = 0;
        while n < max && self.step()?.is_some() {
            n += 1;
        }
        Ok(n)
    }

    /// Blocks until no actor is ready or running (the graph is quiescent).
    pub fn wait_idle(&self) {
        if self.manual {
            return;
        }
        let mut st = self.control.lock();
        while st.running > 0 || st.ready.iter().any(|q| !q.is_empty()) {
            st = self
                .control
                .shared
                .idle
                .wait(st)
                .unwrap_or_else(|e| e.into_inner());
        }
    }
}

impl Drop for Graph {
    fn drop(&mut self) {
        self.control.lock().shutdown = true;
        self.control.shared.work.notify_all();
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

/// Structural edits applied atomically to a (possibly running) graph, see [`Control::edit`].
pub struct Edit<'a> {
    st: &'a mut State,
}

fn actor_mut(st: &mut State, a: ActorId) -> Result<&mut ActorSlot, KernelError> {
    st.actors
        .get_mut(a.0)
        .and_then(|s| s.as_mut())
        .filter(|s| !s.removed)
        .ok_or(KernelError::UnknownActor(a.0))
}

fn data_ref(st: &State, d: DataId) -> Result<&DataSlot, KernelError> {
    st.data
        .get(d.0)
        .and_then(|s| s.as_ref())
        .ok_or(KernelError::UnknownData(d.0))
}

fn port_index(slot: &ActorSlot, port: &str, input: bool) -> Result<usize, KernelError> {
    let found = if input {
        slot.inputs.iter().position(|p| p.name == port)
    } else {
        slot.outputs.iter().position(|p| p.name == port)
    };
    found.ok_or_else(|| KernelError::UnknownPort {
        actor: slot.name.clone(),
        dir: if input { "input" } else { "output" },
        port: port.to_string(),
    })
}

impl Edit<'_> {
    /// Adds an actor node.
    pub fn add_actor(&mut self, spec: ActorSpec) -> Result<ActorId, KernelError> {
        if self
            .st
            .actors
            .iter()
            .flatten()
            .any(|a| !a.removed && a.name == spec.name)
        {
            return Err(KernelError::DuplicateName(spec.name));
        }
        let pool = match &spec.pool {
            None => 0,
            Some(p) => self
                .st
                .pools
                .iter()
                .position(|q| q == p)
                .ok_or_else(|| KernelError::UnknownPool(p.clone()))?,
        };
        self.st.actors.push(Some(ActorSlot {
            pool,
            name: spec.name,
            inputs: spec
                .inputs
                .into_iter()
                .map(|name| InPort {
                    name,
                    source: None,
                    cursor: 0,
                })
                .collect(),
            outputs: spec
                .outputs
                .into_iter()
                .map(|name| OutPort {
                    name,
                    targets: Vec::new(),
                })
                .collect(),
            firing: spec.firing,
            drive: spec.drive,
            script: spec.script,
            context: Some(spec.context),
            running: false,
            queued: false,
            removed: false,
            requests: 0,
            permits: 0,
            fired: 0,
        }));
        Ok(ActorId(self.st.actors.len() - 1))
    }

    /// Adds a data node.
    pub fn add_data(&mut self, name: &str, retention: Retention) -> Result<DataId, KernelError> {
        if self.st.data.iter().flatten().any(|d| d.name == name) {
            return Err(KernelError::DuplicateName(name.to_string()));
        }
        self.st.data.push(Some(DataSlot {
            name: name.to_string(),
            retention,
            buf: VecDeque::new(),
            base: 0,
            next: 0,
            last: None,
            readers: Vec::new(),
            writers: Vec::new(),
        }));
        Ok(DataId(self.st.data.len() - 1))
    }

    /// Connects output port `port` of `a` to data node `d` (an output may feed several nodes).
    pub fn connect_out(&mut self, a: ActorId, port: &str, d: DataId) -> Result<(), KernelError> {
        data_ref(self.st, d)?;
        let slot = actor_mut(self.st, a)?;
        let i = port_index(slot, port, false)?;
        if !slot.outputs[i].targets.contains(&d) {
            slot.outputs[i].targets.push(d);
            if let Some(dn) = self.st.data[d.0].as_mut() {
                dn.writers.push((a.0, i));
            }
        }
        Ok(())
    }

    /// Disconnects output port `port` of `a` from `d`.
    pub fn disconnect_out(&mut self, a: ActorId, port: &str, d: DataId) -> Result<(), KernelError> {
        let slot = actor_mut(self.st, a)?;
        let i = port_index(slot, port, false)?;
        slot.outputs[i].targets.retain(|&t| t != d);
        if let Some(dn) = self.st.data.get_mut(d.0).and_then(|x| x.as_mut()) {
            dn.unlink_writer(a.0, i);
        }
        Ok(())
    }

    /// Connects data node `d` to input port `port` of `a`. The new reader sees every value the
    /// node still holds (a stream's queue, or a last-value node's current value).
    pub fn connect_in(&mut self, d: DataId, a: ActorId, port: &str) -> Result<(), KernelError> {
        let dn = data_ref(self.st, d)?;
        let cursor = match dn.retention {
            Retention::Stream => dn.base,
            Retention::LastValue => {
                if dn.last.is_some() {
                    dn.next - 1
                } else {
                    dn.next
                }
            }
        };
        let slot = actor_mut(self.st, a)?;
        let i = port_index(slot, port, true)?;
        if slot.inputs[i].source.is_some() {
            return Err(KernelError::InputTaken {
                actor: slot.name.clone(),
                port: port.to_string(),
            });
        }
        slot.inputs[i].source = Some(d);
        slot.inputs[i].cursor = cursor;
        if let Some(dn) = self.st.data[d.0].as_mut() {
            dn.readers.push((a.0, i));
        }
        Ok(())
    }

    /// Connects data node `d` to input port `port` of `a` with the reader at position
    /// `cursor` — one that [`disconnect_in`](Self::disconnect_in) returned, so a replacing
    /// actor continues exactly where the one it replaces stopped (no token lost or read twice);
    /// `u64::MAX`: only values written from now on. The position is kept within what the node
    /// still holds.
    pub fn connect_in_from(
        &mut self,
        d: DataId,
        a: ActorId,
        port: &str,
        cursor: u64,
    ) -> Result<(), KernelError> {
        let dn = data_ref(self.st, d)?;
        let cursor = cursor.clamp(dn.base, dn.next);
        self.connect_in(d, a, port)?;
        let slot = actor_mut(self.st, a)?;
        let i = port_index(slot, port, true)?;
        slot.inputs[i].cursor = cursor;
        Ok(())
    }

    /// Disconnects input port `port` of `a`; returns the data node it read and the reader's
    /// position. Unread tokens stay in the node for the next reader.
    pub fn disconnect_in(
        &mut self,
        a: ActorId,
        port: &str,
    ) -> Result<Option<(DataId, u64)>, KernelError> {
        let slot = actor_mut(self.st, a)?;
        let i = port_index(slot, port, true)?;
        let taken = slot.inputs[i]
            .source
            .take()
            .map(|d| (d, slot.inputs[i].cursor));
        if let Some((d, _)) = taken
            && let Some(dn) = self.st.data.get_mut(d.0).and_then(|x| x.as_mut())
        {
            dn.unlink_reader(a.0, i);
        }
        Ok(taken)
    }

    /// Moves a reader: the data node feeding `(from, from_port)` now feeds `(to, to_port)`,
    /// which continues exactly where the old reader stopped — no held token is lost or read
    /// twice.
    pub fn move_input(
        &mut self,
        from: ActorId,
        from_port: &str,
        to: ActorId,
        to_port: &str,
    ) -> Result<(), KernelError> {
        {
            let slot = actor_mut(self.st, to)?;
            let j = port_index(slot, to_port, true)?;
            if slot.inputs[j].source.is_some() {
                return Err(KernelError::InputTaken {
                    actor: slot.name.clone(),
                    port: to_port.to_string(),
                });
            }
        }
        let Some((d, cursor)) = self.disconnect_in(from, from_port)? else {
            return Ok(());
        };
        let slot = actor_mut(self.st, to)?;
        let j = port_index(slot, to_port, true)?;
        slot.inputs[j].source = Some(d);
        slot.inputs[j].cursor = cursor;
        if let Some(dn) = self.st.data[d.0].as_mut() {
            dn.readers.push((to.0, j));
        }
        Ok(())
    }

    /// Removes an actor and its connections (a running actor finishes its firing first; its
    /// outputs are still delivered).
    pub fn remove_actor(&mut self, a: ActorId) -> Result<(), KernelError> {
        let slot = actor_mut(self.st, a)?;
        slot.removed = true;
        let running = slot.running;
        let sources: Vec<(usize, DataId)> = slot
            .inputs
            .iter_mut()
            .enumerate()
            .filter_map(|(i, p)| p.source.take().map(|d| (i, d)))
            .collect();
        for (i, d) in sources {
            if let Some(dn) = self.st.data.get_mut(d.0).and_then(|x| x.as_mut()) {
                dn.unlink_reader(a.0, i);
            }
        }
        // A firing actor keeps its writer links until its outputs are delivered.
        if !running && let Some(slot) = self.st.actors[a.0].take() {
            unlink_writers(&mut self.st.data, a.0, &slot);
        }
        Ok(())
    }

    /// Removes a data node, disconnecting every port attached to it.
    pub fn remove_data(&mut self, d: DataId) -> Result<(), KernelError> {
        data_ref(self.st, d)?;
        for slot in self.st.actors.iter_mut().flatten() {
            for p in &mut slot.inputs {
                if p.source == Some(d) {
                    p.source = None;
                }
            }
            for p in &mut slot.outputs {
                p.targets.retain(|&t| t != d);
            }
        }
        self.st.data[d.0] = None;
        Ok(())
    }

    /// Finds an actor by name.
    pub fn actor(&self, name: &str) -> Option<ActorId> {
        self.st
            .actors
            .iter()
            .position(|a| a.as_ref().is_some_and(|a| !a.removed && a.name == name))
            .map(ActorId)
    }

    /// Finds a data node by name.
    pub fn data(&self, name: &str) -> Option<DataId> {
        self.st
            .data
            .iter()
            .position(|d| d.as_ref().is_some_and(|d| d.name == name))
            .map(DataId)
    }
}

impl Control {
    fn fresh_with(pools: Vec<String>) -> Control {
        let state = State {
            ready: vec![VecDeque::new(); pools.len()],
            pools,
            ..State::default()
        };
        Control {
            shared: Arc::new(Shared {
                state: Mutex::new(state),
                work: Condvar::new(),
                idle: Condvar::new(),
            }),
        }
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A script never runs under the lock, so a poisoned lock means a kernel bug; the state
        // itself is still consistent between operations, so carry on.
        self.shared.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Applies structural edits atomically between firings; the workers keep running. After
    /// the edit every actor is re-examined for readiness.
    pub fn edit<R>(&self, f: impl FnOnce(&mut Edit<'_>) -> R) -> R {
        let mut st = self.lock();
        let r = f(&mut Edit { st: &mut st });
        let n = st.actors.len();
        for a in 0..n {
            self.check_ready(&mut st, a);
        }
        drop(st);
        self.shared.work.notify_all();
        r
    }

    /// Writes a value into a data node from outside (an external source).
    pub fn write(&self, d: DataId, v: Value) -> Result<(), KernelError> {
        let mut st = self.lock();
        data_ref(&st, d)?;
        self.deliver(&mut st, d, v);
        drop(st);
        self.shared.work.notify_all();
        Ok(())
    }

    /// An attempted read of `d` from outside: when `d` holds no value, a request token goes to
    /// every actor writing it (and on upstream through actors lacking inputs). Returns the
    /// node's last value.
    pub fn request(&self, d: DataId) -> Result<Option<Value>, KernelError> {
        let mut st = self.lock();
        let dn = data_ref(&st, d)?;
        let last = dn.last.clone();
        let empty = match dn.retention {
            Retention::Stream => dn.buf.is_empty(),
            Retention::LastValue => dn.last.is_none(),
        };
        if empty {
            let mut seen = Vec::new();
            self.propagate_request(&mut st, d, &mut seen);
        }
        drop(st);
        self.shared.work.notify_all();
        Ok(last)
    }

    /// A read of `d` that asks for a fresh value whether or not `d` holds one: a request token
    /// goes to every actor writing `d` (and on upstream through actors lacking inputs), as
    /// [`request`](Self::request) does for an empty node. This is how a consumer outside the
    /// graph samples a demand-driven chain once per period (a last-value node is never empty
    /// again after its first write).
    pub fn demand(&self, d: DataId) -> Result<(), KernelError> {
        let mut st = self.lock();
        data_ref(&st, d)?;
        let mut seen = Vec::new();
        self.propagate_request(&mut st, d, &mut seen);
        drop(st);
        self.shared.work.notify_all();
        Ok(())
    }

    /// Gives an actor one firing permit (how sources without inputs are clocked from outside).
    pub fn trigger(&self, a: ActorId) -> Result<(), KernelError> {
        let mut st = self.lock();
        actor_mut(&mut st, a)?.permits += 1;
        self.check_ready(&mut st, a.0);
        drop(st);
        self.shared.work.notify_all();
        Ok(())
    }

    /// The last value written to `d`.
    pub fn latest(&self, d: DataId) -> Result<Option<Value>, KernelError> {
        Ok(data_ref(&self.lock(), d)?.last.clone())
    }

    /// Values a stream node still holds (unread by at least one reader, or never read).
    pub fn queued(&self, d: DataId) -> Result<Vec<Value>, KernelError> {
        Ok(data_ref(&self.lock(), d)?.buf.iter().cloned().collect())
    }

    /// How many times actor `a` fired.
    pub fn fired(&self, a: ActorId) -> Result<u64, KernelError> {
        let mut st = self.lock();
        Ok(actor_mut(&mut st, a)?.fired)
    }

    /// Turns the tracer on or off.
    pub fn set_tracing(&self, on: bool) {
        self.lock().tracing = on;
    }

    /// The trace recorded so far, in firing order.
    pub fn trace(&self) -> Vec<TraceRecord> {
        let mut t = self.lock().trace.clone();
        t.sort_by_key(|r| r.seq);
        t
    }

    /// Script errors so far (`actor: message`).
    pub fn errors(&self) -> Vec<String> {
        self.lock().errors.clone()
    }

    /// The graph and its live state as Graphviz DOT.
    pub fn to_dot(&self) -> String {
        dot::render(&self.lock())
    }

    fn propagate_request(&self, st: &mut State, d: DataId, seen: &mut Vec<usize>) {
        let mut writers: Vec<usize> = st.data[d.0]
            .as_ref()
            .map_or(Vec::new(), |dn| dn.writers.iter().map(|w| w.0).collect());
        writers.dedup();
        writers.retain(|&w| st.actors[w].as_ref().is_some_and(|a| !a.removed));
        for w in writers {
            if seen.contains(&w) {
                continue;
            }
            seen.push(w);
            let missing: Vec<DataId> = {
                let Some(slot) = st.actors[w].as_mut() else {
                    continue;
                };
                slot.requests += 1;
                slot.inputs
                    .iter()
                    .filter(|p| p.source.is_some_and(|s| !has_token(&st.data, p, s)))
                    .filter_map(|p| p.source)
                    .collect()
            };
            for m in missing {
                self.propagate_request(st, m, seen);
            }
            self.check_ready(st, w);
        }
    }

    fn deliver(&self, st: &mut State, d: DataId, v: Value) {
        let Some(dn) = st.data[d.0].as_mut() else {
            return;
        };
        if dn.retention == Retention::Stream {
            dn.buf.push_back(v.clone());
        }
        dn.last = Some(v);
        dn.next += 1;
        let mut readers: Vec<usize> = dn.readers.iter().map(|r| r.0).collect();
        readers.sort_unstable();
        readers.dedup();
        for r in readers {
            self.check_ready(st, r);
        }
    }

    fn can_fire(&self, st: &State, a: usize) -> bool {
        let Some(slot) = st.actors[a].as_ref() else {
            return false;
        };
        if slot.running || slot.removed {
            return false;
        }
        if slot.permits > 0 {
            return true;
        }
        let connected: Vec<&InPort> = slot.inputs.iter().filter(|p| p.source.is_some()).collect();
        let inputs_ok = if slot.inputs.is_empty() {
            slot.requests > 0
        } else {
            let with: usize = connected
                .iter()
                .filter(|p| p.source.is_some_and(|s| has_token(&st.data, p, s)))
                .count();
            match slot.firing {
                Firing::IfAll => with > 0 && with == slot.inputs.len(),
                Firing::IfAny => with > 0,
            }
        };
        match slot.drive {
            Drive::Data => inputs_ok,
            Drive::Demand => inputs_ok && slot.requests > 0,
        }
    }

    fn check_ready(&self, st: &mut State, a: usize) {
        if st
            .actors
            .get(a)
            .and_then(|s| s.as_ref())
            .is_some_and(|s| !s.queued)
            && self.can_fire(st, a)
            && let Some(slot) = st.actors[a].as_mut()
        {
            slot.queued = true;
            let pool = slot.pool;
            st.ready[pool].push_back(a);
        }
    }

    /// Fires actor `a`: consumes tokens under the lock, runs the script without it, delivers.
    fn fire<'s>(
        &'s self,
        mut st: MutexGuard<'s, State>,
        a: usize,
        worker: usize,
    ) -> (MutexGuard<'s, State>, TraceRecord) {
        st.seq += 1;
        let seq = st.seq;
        st.running += 1;
        let State { actors, data, .. } = &mut *st;
        // `can_fire` was checked by the caller under this same lock: the slot exists.
        let Some(slot) = actors[a].as_mut() else {
            unreachable!("fire() is only called on a live actor")
        };
        let reason = if slot.permits > 0 {
            slot.permits -= 1;
            Reason::Trigger
        } else if slot.drive == Drive::Demand || slot.inputs.is_empty() {
            slot.requests = slot.requests.saturating_sub(1);
            Reason::Demand
        } else {
            Reason::Data
        };
        if reason == Reason::Data && slot.requests > 0 {
            slot.requests -= 1;
        }
        slot.running = true;
        let mut inputs = Vec::with_capacity(slot.inputs.len());
        let mut latest = Vec::with_capacity(slot.inputs.len());
        for p in &mut slot.inputs {
            let mut v = None;
            let mut l = None;
            if let Some(dn) = p.source.and_then(|d| data[d.0].as_ref()) {
                l = dn.last.clone();
                if p.cursor < dn.next {
                    match dn.retention {
                        Retention::Stream => {
                            let idx = (p.cursor.max(dn.base) - dn.base) as usize;
                            v = dn.buf.get(idx).cloned();
                            p.cursor = p.cursor.max(dn.base) + 1;
                        }
                        Retention::LastValue => {
                            v = dn.last.clone();
                            p.cursor = dn.next;
                        }
                    }
                }
            }
            inputs.push((p.name.clone(), v));
            latest.push((p.source, l));
        }
        let mut context = slot.context.take().unwrap_or_else(|| Box::new(()));
        let script = slot.script.clone();
        let out_names: Vec<String> = slot.outputs.iter().map(|p| p.name.clone()).collect();
        let name = slot.name.clone();
        // Streams drop what every reader has read.
        let consumed: Vec<DataId> = slot.inputs.iter().filter_map(|p| p.source).collect();
        for d in consumed {
            collect_garbage(actors, data, d);
        }
        drop(st);

        let mut ctx = Ctx {
            inputs: &inputs,
            latest: &latest,
            out_names: &out_names,
            outputs: Vec::new(),
            context: &mut *context,
            control: self,
            actor: ActorId(a),
        };
        // A panicking script must not take its worker (and the graph's bookkeeping) with it:
        // the panic becomes the firing's error.
        let result =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| script.fire(&mut ctx)))
                .unwrap_or_else(|p| {
                    let msg = p
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| p.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "unknown payload".into());
                    Err(format!("script panicked: {msg}"))
                });
        let outputs = std::mem::take(&mut ctx.outputs);

        let mut st = self.lock();
        st.running -= 1;
        let mut written = Vec::new();
        if let Some(slot) = st.actors[a].as_mut() {
            slot.running = false;
            slot.fired += 1;
            slot.context = Some(context);
            for (i, v) in &outputs {
                for &d in &slot.outputs[*i].targets {
                    written.push((d, v.clone()));
                }
            }
        }
        if st.actors[a].as_ref().is_some_and(|s| s.removed)
            && let Some(slot) = st.actors[a].take()
        {
            unlink_writers(&mut st.data, a, &slot);
        }
        for (d, v) in written {
            self.deliver(&mut st, d, v);
        }
        self.check_ready(&mut st, a);
        if let Err(e) = &result {
            st.errors.push(format!("{name}: {e}"));
        }
        let rec = TraceRecord {
            seq,
            actor: name,
            actor_id: ActorId(a),
            worker,
            reason,
            inputs: inputs
                .into_iter()
                .filter_map(|(n, v)| v.map(|v| (n, v)))
                .collect(),
            outputs: outputs
                .into_iter()
                .map(|(i, v)| (out_names[i].clone(), v))
                .collect(),
            error: result.err(),
        };
        if st.tracing {
            st.trace.push(rec.clone());
        }
        (st, rec)
    }

    fn worker_loop(&self, w: usize, pool: usize) {
        let mut st = self.lock();
        loop {
            if st.shutdown {
                return;
            }
            match st.ready[pool].pop_front() {
                Some(a) => {
                    if let Some(slot) = st.actors[a].as_mut() {
                        slot.queued = false;
                    }
                    if self.can_fire(&st, a) {
                        let (s, _) = self.fire(st, a, w);
                        st = s;
                        self.shared.work.notify_all();
                    }
                }
                None => {
                    if st.running == 0 {
                        self.shared.idle.notify_all();
                    }
                    st = self.shared.work.wait(st).unwrap_or_else(|e| e.into_inner());
                }
            }
        }
    }
}

fn has_token(data: &[Option<DataSlot>], p: &InPort, d: DataId) -> bool {
    data.get(d.0)
        .and_then(|s| s.as_ref())
        .is_some_and(|dn| p.cursor < dn.next)
}

fn collect_garbage(actors: &[Option<ActorSlot>], data: &mut [Option<DataSlot>], d: DataId) {
    let Some(dn) = data.get_mut(d.0).and_then(|x| x.as_mut()) else {
        return;
    };
    if dn.retention != Retention::Stream {
        return;
    }
    let floor = dn
        .readers
        .iter()
        .filter_map(|&(a, i)| {
            actors
                .get(a)
                .and_then(|x| x.as_ref())
                .and_then(|s| s.inputs.get(i))
                .map(|p| p.cursor)
        })
        .min();
    // Without readers nothing is dropped: the tokens wait for the next reader.
    if let Some(floor) = floor {
        while dn.base < floor && !dn.buf.is_empty() {
            dn.buf.pop_front();
            dn.base += 1;
        }
    }
}
