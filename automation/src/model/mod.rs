//! Hierarchical Process Models (HPM) and Hierarchical Fault Models (HFM), seed §4.3.
//!
//! A model file declares one process tree. Each process carries both aspects the seed keeps in
//! "view slots" of one declarative form (seed figure 9): the *process* aspect (input and output
//! signals, subprocesses, signal connections) and the *fault* aspect (failure modes, alarms with
//! their alarm generators, alarm → failure-mode and failure-mode → physical-component
//! associations, fault propagation edges with a probability and a `[tmin, tmax]` interval).
//! The fault aspect inherits its structure from the process aspect: a propagation edge between
//! two sibling subprocesses is only accepted when a signal connection links them in that
//! direction (the seed's consistency guarantee), see [`check`].
//!
//! Entry points:
//! * [`parse_model`] — text → [`Model`] (names resolved, typed [`ModelError`] with file:line:col);
//! * [`load_model`] — a file path or a shipped name (`eclss`) → [`Model`];
//! * [`check::check_model`] — the consistency checks, expressed as graph properties;
//! * [`Model`] — the flat, index-addressed model every algorithm reads.
//!
//! The text format is documented in `docs/automation.md`.

pub mod check;
mod parse;

pub use parse::parse_model;

use std::fmt;
use std::path::Path;

/// Index of a process in [`Model::processes`].
pub type ProcId = usize;
/// Index of a failure mode in [`Model::failure_modes`].
pub type FmId = usize;
/// Index of an alarm in [`Model::alarms`].
pub type AlarmId = usize;
/// Index of a physical component in [`Model::components`].
pub type CompId = usize;

/// A place in a model file (1-based line and column).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    pub line: u32,
    pub col: u32,
}

/// A model that could not be read: the file, the place and the reason.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{col}: {message}")]
pub struct ModelError {
    pub file: String,
    pub line: u32,
    pub col: u32,
    pub message: String,
}

/// A process of the HPM (seed figure 4): a functional unit mapping input to output signals.
#[derive(Debug, Clone)]
pub struct Process {
    pub name: String,
    /// Dotted path from the root, e.g. `ECLSS.AirControl.THC`.
    pub path: String,
    pub parent: Option<ProcId>,
    pub children: Vec<ProcId>,
    /// 0 for the root.
    pub depth: usize,
    pub inputs: Vec<String>,
    pub outputs: Vec<String>,
    pub failure_modes: Vec<FmId>,
    pub alarms: Vec<AlarmId>,
    pub span: Span,
}

/// One end of a signal connection: a signal of a process.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SignalRef {
    pub process: ProcId,
    pub signal: String,
}

/// A signal connection declared in process `owner` (material, energy or information flow).
#[derive(Debug, Clone)]
pub struct Connection {
    pub owner: ProcId,
    pub from: SignalRef,
    pub to: SignalRef,
    pub span: Span,
}

/// A failure mode of a process: a node of the fault propagation digraph (seed figure 5).
#[derive(Debug, Clone)]
pub struct FailureMode {
    pub name: String,
    /// `Process.path.name`.
    pub path: String,
    pub process: ProcId,
    /// A derived failure mode is only ever a consequence, never an originating fault.
    pub derived: bool,
    pub components: Vec<CompId>,
    pub alarms: Vec<AlarmId>,
    pub span: Span,
}

/// An alarm with its alarm generator, associated with the failure modes it detects.
#[derive(Debug, Clone)]
pub struct Alarm {
    pub name: String,
    pub process: ProcId,
    /// Failure modes whose activation makes this alarm ring.
    pub detects: Vec<FmId>,
    /// The alarm generator: which sensor reading and condition raise the alarm.
    pub generator: Option<String>,
    pub span: Span,
}

/// A fault propagation edge: `from` active makes `to` active with probability `prob` after a
/// delay in `[tmin, tmax]` seconds.
#[derive(Debug, Clone)]
pub struct Edge {
    pub from: FmId,
    pub to: FmId,
    pub prob: f64,
    pub tmin: f64,
    pub tmax: f64,
    /// The seed gives no value here; the numbers are this model's assumption.
    pub assumed: bool,
    /// The process whose fault model declares the edge.
    pub owner: ProcId,
    pub span: Span,
}

/// A physical component of the Hierarchical Physical Component Model (HPCM).
#[derive(Debug, Clone)]
pub struct Component {
    pub name: String,
    pub span: Span,
}

/// A whole hierarchical process and fault model, flat and index-addressed.
#[derive(Debug, Clone)]
pub struct Model {
    /// Where it came from (file path or `<eclss>`).
    pub source: String,
    pub processes: Vec<Process>,
    pub connections: Vec<Connection>,
    pub failure_modes: Vec<FailureMode>,
    pub alarms: Vec<Alarm>,
    pub edges: Vec<Edge>,
    pub components: Vec<Component>,
}

/// The ECLSS model of seed §4.3, shipped with the crate.
pub const ECLSS_SOURCE: &str = include_str!("eclss.hfm");

/// Names of the models shipped inside the crate.
pub const SHIPPED_MODELS: &[&str] = &["eclss"];

/// Loads a model by shipped name (`eclss`) or from a file path.
///
/// Errors: unreadable file — missing, not a regular file, larger than
/// [`robosim_input::Limit::TEXT`] — (reported at 0:0), or any parse/resolution error of [`parse_model`].
pub fn load_model(name_or_path: &str) -> Result<Model, ModelError> {
    if name_or_path == "eclss" {
        return parse_model(ECLSS_SOURCE, "<eclss>");
    }
    let text = robosim_input::read_to_string(
        Path::new(name_or_path),
        "a fault model",
        robosim_input::Limit::TEXT,
    )
    .map_err(|e| ModelError {
        file: name_or_path.to_string(),
        line: 0,
        col: 0,
        message: format!(
            "cannot read model (not a shipped model {SHIPPED_MODELS:?} either): {}",
            e.reason()
        ),
    })?;
    parse_model(&text, name_or_path)
}

impl Model {
    /// The root process (always index 0).
    pub fn root(&self) -> ProcId {
        0
    }

    /// Finds a failure mode by full path (`ECLSS.AirControl.humidity_high`) or by any dotted
    /// tail of it that is unique (`AirControl.humidity_high`, or a bare unique name).
    pub fn find_failure_mode(&self, name: &str) -> Result<FmId, String> {
        find_named(
            name,
            self.failure_modes.iter().map(|f| (&f.path, &f.name)),
            "failure mode",
        )
    }

    /// Finds an alarm by name (alarm names are unique in a model).
    pub fn find_alarm(&self, name: &str) -> Result<AlarmId, String> {
        self.alarms
            .iter()
            .position(|a| a.name == name)
            .ok_or_else(|| format!("no alarm named `{name}`"))
    }

    /// True when `anc` is `p` or one of its ancestors.
    pub fn is_ancestor_or_self(&self, anc: ProcId, mut p: ProcId) -> bool {
        loop {
            if p == anc {
                return true;
            }
            match self.processes[p].parent {
                Some(q) => p = q,
                None => return false,
            }
        }
    }

    /// The ancestor of `p` at `depth` (or `p` itself when it is not deeper than `depth`).
    pub fn ancestor_at_depth(&self, mut p: ProcId, depth: usize) -> ProcId {
        while self.processes[p].depth > depth {
            // A process deeper than 0 has a parent (only the root has depth 0).
            p = self.processes[p].parent.unwrap_or(p);
        }
        p
    }

    /// Failure modes that may originate a fault (not `derived`).
    pub fn source_failure_modes(&self) -> Vec<FmId> {
        (0..self.failure_modes.len())
            .filter(|&f| !self.failure_modes[f].derived)
            .collect()
    }

    /// The deepest process depth.
    pub fn max_depth(&self) -> usize {
        self.processes.iter().map(|p| p.depth).max().unwrap_or(0)
    }
}

fn find_named<'a>(
    name: &str,
    items: impl Iterator<Item = (&'a String, &'a String)>,
    what: &str,
) -> Result<usize, String> {
    let dotted = format!(".{name}");
    let mut hits = Vec::new();
    for (i, (path, _)) in items.enumerate() {
        if path == name {
            return Ok(i);
        }
        if path.ends_with(&dotted) {
            hits.push((i, path.clone()));
        }
    }
    match hits.len() {
        1 => Ok(hits[0].0),
        0 => Err(format!("no {what} named `{name}`")),
        _ => Err(format!(
            "{what} name `{name}` is ambiguous: {}",
            hits.iter()
                .map(|(_, p)| p.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

impl fmt::Display for Span {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

impl Model {
    /// The process and fault models as Graphviz DOT (the seed's pictures 14–22 as one
    /// drawing): a cluster per process (nested as the hierarchy), failure modes as ellipses
    /// (derived ones dashed), alarms as small boxes attached to what they detect, propagation
    /// edges labelled `p [tmin, tmax]` (assumed numbers in grey).
    pub fn to_dot(&self) -> String {
        use std::fmt::Write as _;
        fn esc(s: &str) -> String {
            s.replace('"', "\\\"")
        }
        fn cluster(m: &Model, p: ProcId, indent: usize, out: &mut String) {
            let pad = " ".repeat(indent);
            let proc_ = &m.processes[p];
            let _ = writeln!(out, "{pad}subgraph cluster_p{p} {{");
            let _ = writeln!(out, "{pad}  label=\"{}\"; style=rounded;", esc(&proc_.name));
            for &f in &proc_.failure_modes {
                let fm = &m.failure_modes[f];
                let style = if fm.derived { "dashed" } else { "solid" };
                let _ = writeln!(
                    out,
                    "{pad}  f{f} [shape=ellipse, style={style}, label=\"{}\"];",
                    esc(&fm.name)
                );
            }
            for &a in &proc_.alarms {
                let _ = writeln!(
                    out,
                    "{pad}  a{a} [shape=box, fontsize=9, height=0.2, label=\"{}\"];",
                    esc(&m.alarms[a].name)
                );
            }
            for &c in &proc_.children {
                cluster(m, c, indent + 2, out);
            }
            let _ = writeln!(out, "{pad}}}");
        }
        let mut s =
            String::from("digraph hfm {\n  rankdir=LR; compound=true; node [fontsize=10];\n");
        cluster(self, 0, 2, &mut s);
        for e in &self.edges {
            let colour = if e.assumed { "grey40" } else { "black" };
            let _ = writeln!(
                s,
                "  f{} -> f{} [label=\"{} [{}, {}]\", fontsize=8, color={colour}, fontcolor={colour}];",
                e.from, e.to, e.prob, e.tmin, e.tmax
            );
        }
        for (a, al) in self.alarms.iter().enumerate() {
            for &f in &al.detects {
                let _ = writeln!(s, "  a{a} -> f{f} [style=dotted, arrowhead=none];");
            }
        }
        s.push_str("}\n");
        s
    }
}
