//! Dataflow graphs declared in a file and run on the [`kernel`](crate::kernel): the MULTIGRAPH
//! graphs of seed §3.4 as a user writes them, with **sources** and **sinks** that name aspects
//! of a session (a joint value, a pose component, the simulator's state, the plant's alarms).
//! The session itself is not known here: `robosim dataflow` (`robosim_hl_interface::dataflow`)
//! reads the sources from the Instance Space, hands their values to [`LiveGraph::pass`] and
//! writes the sinks back as transactions.
//!
//! The file format (docs/dataflow.md) is line-based:
//!
//! ```text
//! # a joint servo: the servicer's elbow follows a set-point held by a marker object
//! rate 10                                   # Hz: also run at this rate (default: on change only)
//! source q   = joint servicer 3             # committed joint value, rad / m
//! source ref = pose marker x                # a pose component in the parent frame, m
//! data   e                                  # a data node (last value; `stream` keeps them all)
//! data   u
//! data   q_next
//! actor  err  = sub(ref, q) -> e
//! actor  ctl  = pd(e) -> u        kp=2 kd=0.05
//! actor  step = add(q, u) -> q_next   ifall data
//! sink   q_next -> joint servicer 3
//! ```
//!
//! Entry points: [`parse_graph`] / [`load_graph`] → [`GraphSpec`]; [`kinds`] (the registry of
//! built-in actor kinds); [`LiveGraph::build`], [`LiveGraph::pass`] (one sample: source values
//! in, sink values out), [`LiveGraph::reconfigure`] (rewire the running graph to a new spec,
//! keeping the state of every actor whose declaration did not change).

mod actors;
mod live;
mod parse;

pub use actors::{KindInfo, kinds};
pub use live::{BuildError, LiveGraph, PassError, Reconfigured, SinkValue};
pub use parse::{GraphFileError, load_graph, parse_graph};

use crate::kernel::{Drive, Firing, Retention};
use std::collections::BTreeMap;

/// A translation component of a pose (parent frame, m).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    /// 0, 1, 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }
}

/// Where a source's value comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceAddr {
    /// The committed value of joint `index` (0-based, chain order) of `robot`, rad or m.
    Joint { robot: String, index: usize },
    /// A translation component of `object`'s pose in its parent frame, m.
    Pose { object: String, axis: Axis },
    /// A number in the simulator's state (`robosim simctl get`), by a dotted path:
    /// `t_s`, `space.power.battery_kwh`, `robots.0.q.2`.
    Sim { path: String },
    /// 1 while the automation plant rings alarm `name`, else 0.
    Alarm { name: String },
    /// A constant.
    Const(f64),
    /// Seconds since the dataflow process started.
    Clock,
}

/// Where a sink's value goes.
#[derive(Debug, Clone, PartialEq)]
pub enum SinkAddr {
    /// Joint `index` of `robot` (one transaction; refused beyond the joint's limits).
    Joint { robot: String, index: usize },
    /// A translation component of `object`'s pose in its parent frame, m.
    Pose { object: String, axis: Axis },
    /// An alarm this graph raises while the value is non-zero (the process says it and lists
    /// it in its state).
    Alarm { name: String },
    /// A simulator setting: `{"cmd": "set", "name": NAME, "value": x}` sent to the simulator
    /// when the value changes (what NAME means is the simulator's: its `set` command).
    Sim { name: String },
}

impl std::fmt::Display for SourceAddr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SourceAddr::Joint { robot, index } => write!(f, "joint {robot} {index}"),
            SourceAddr::Pose { object, axis } => write!(f, "pose {object} {}", axis.name()),
            SourceAddr::Sim { path } => write!(f, "sim {path}"),
            SourceAddr::Alarm { name } => write!(f, "alarm {name}"),
            SourceAddr::Const(x) => write!(f, "const {x}"),
            SourceAddr::Clock => write!(f, "clock"),
        }
    }
}

impl std::fmt::Display for SinkAddr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SinkAddr::Joint { robot, index } => write!(f, "joint {robot} {index}"),
            SinkAddr::Pose { object, axis } => write!(f, "pose {object} {}", axis.name()),
            SinkAddr::Alarm { name } => write!(f, "alarm {name}"),
            SinkAddr::Sim { name } => write!(f, "sim {name}"),
        }
    }
}

/// `source NAME = ADDRESS`: a data node the process writes every pass.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceDecl {
    pub name: String,
    pub addr: SourceAddr,
    pub line: usize,
}

/// `data NAME [last|stream]`.
#[derive(Debug, Clone, PartialEq)]
pub struct DataDecl {
    pub name: String,
    pub retention: Retention,
    pub line: usize,
}

/// `actor NAME = KIND(IN, …) -> OUT, … [key=value …] [ifall|ifany] [data|demand]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ActorDecl {
    pub name: String,
    pub kind: String,
    /// Every parameter of the kind, defaults filled in (`dt` from the graph's rate when the
    /// line does not give it).
    pub params: BTreeMap<String, f64>,
    /// Data node feeding each input port, in the kind's port order.
    pub inputs: Vec<String>,
    /// Data node each output port writes, in the kind's port order.
    pub outputs: Vec<String>,
    pub firing: Firing,
    pub drive: Drive,
    pub line: usize,
}

impl ActorDecl {
    /// Whether two declarations make the same actor (the line it sits on does not count): an
    /// actor whose declaration is unchanged by a reload keeps running with its state.
    pub fn same_as(&self, other: &ActorDecl) -> bool {
        self.kind == other.kind
            && self.params == other.params
            && self.inputs == other.inputs
            && self.outputs == other.outputs
            && self.firing == other.firing
            && self.drive == other.drive
    }
}

/// `sink NODE -> ADDRESS`.
#[derive(Debug, Clone, PartialEq)]
pub struct SinkDecl {
    pub node: String,
    pub addr: SinkAddr,
    pub line: usize,
}

/// A parsed and checked graph file.
#[derive(Debug, Clone, PartialEq)]
pub struct GraphSpec {
    /// The file it came from (for messages).
    pub file: String,
    /// `rate HZ`: passes also run at this rate, not only on changes.
    pub rate_hz: Option<f64>,
    pub sources: Vec<SourceDecl>,
    pub data: Vec<DataDecl>,
    pub actors: Vec<ActorDecl>,
    pub sinks: Vec<SinkDecl>,
}

impl GraphSpec {
    /// Retention of data node `name` (sources are last-value nodes).
    pub fn retention(&self, name: &str) -> Option<Retention> {
        if self.sources.iter().any(|s| s.name == name) {
            return Some(Retention::LastValue);
        }
        self.data
            .iter()
            .find(|d| d.name == name)
            .map(|d| d.retention)
    }
}
