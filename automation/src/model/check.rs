//! Consistency checks of a hierarchical process/fault model, expressed as graph properties
//! (seed §3.4, "Test and Validation Tools": map the declarative forms into one graph, state the
//! criteria as graph properties, check them with graph algorithms).
//!
//! Entry point: [`check_model`] → a list of [`Finding`]s; errors make a model unfit for
//! diagnosis, warnings describe incompleteness the seed's own models show (picture 22.b has
//! alarms "edited but not yet connected").
//!
//! | code | severity | property |
//! |---|---|---|
//! | `signal-hierarchy` | error | a signal connects only parent↔child or siblings (seed §4.3) |
//! | `signal-direction` | error | a connection runs from an input of the owner or an output of a child, to an output of the owner or an input of a child |
//! | `edge-hierarchy` | error | a propagation edge joins failure modes of one process, a parent and its child, or two siblings, and is declared in that family |
//! | `edge-without-link` | error | an edge between siblings follows a signal connection between them, in its direction (the HFM inherits the HPM's structure) |
//! | `zero-time-cycle` | error | no cycle of edges all with `tmin = 0` (a fault would re-cause itself instantly) |
//! | `alarm-unattached` | warning | an alarm detects at least one failure mode |
//! | `alarm-scope` | warning | an alarm detects failure modes of its own process or its subprocesses |
//! | `unobservable` | warning | some alarm is reachable from every failure mode |
//! | `unreachable` | warning | a `derived` failure mode has an incoming edge (else it can never become active) |

use super::*;

/// How serious a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    Warning,
    Error,
}

/// One violated property, with where it was declared.
#[derive(Debug, Clone)]
pub struct Finding {
    pub severity: Severity,
    /// Stable identifier of the property (see the module table).
    pub code: &'static str,
    pub message: String,
    pub span: Span,
}

impl Finding {
    /// `file:line:col: error[code]: message`.
    pub fn render(&self, file: &str) -> String {
        let sev = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        format!(
            "{file}:{}:{}: {sev}[{}]: {}",
            self.span.line, self.span.col, self.code, self.message
        )
    }
}

fn adjacent(m: &Model, a: ProcId, b: ProcId) -> bool {
    let pa = m.processes[a].parent;
    let pb = m.processes[b].parent;
    a == b || pa == Some(b) || pb == Some(a) || (pa.is_some() && pa == pb)
}

/// The findings of the checks, in the order they were found.
struct Findings(Vec<Finding>);

impl Findings {
    fn push(&mut self, severity: Severity, code: &'static str, message: String, span: Span) {
        self.0.push(Finding {
            severity,
            code,
            message,
            span,
        })
    }
}

/// Runs every check; findings are sorted errors first, then by place.
pub fn check_model(m: &Model) -> Vec<Finding> {
    let mut findings = Findings(Vec::new());
    check_connections(m, &mut findings);
    check_edges(m, &mut findings);
    check_zero_time_cycles(m, &mut findings);
    check_alarms(m, &mut findings);
    check_observability(m, &mut findings);
    let mut out = findings.0;
    out.sort_by_key(|f| (std::cmp::Reverse(f.severity), f.span.line, f.span.col));
    out
}

/// `signal-hierarchy` and `signal-direction`.
fn check_connections(m: &Model, out: &mut Findings) {
    for c in &m.connections {
        let (f, t) = (c.from.process, c.to.process);
        let fam = |p: ProcId| p == c.owner || m.processes[p].parent == Some(c.owner);
        let show = |s: &SignalRef| format!("{}.{}", m.processes[s.process].path, s.signal);
        if !fam(f) || !fam(t) {
            out.push(
                Severity::Error,
                "signal-hierarchy",
                format!(
                    "connection {} -> {} declared in `{}` crosses the hierarchy: signals run only between a parent and its child or between siblings",
                    show(&c.from),
                    show(&c.to),
                    m.processes[c.owner].path
                ),
                c.span,
            );
            continue;
        }
        let from_ok = if f == c.owner {
            m.processes[f].inputs.contains(&c.from.signal)
        } else {
            m.processes[f].outputs.contains(&c.from.signal)
        };
        let to_ok = if t == c.owner {
            m.processes[t].outputs.contains(&c.to.signal)
        } else {
            m.processes[t].inputs.contains(&c.to.signal)
        };
        if !from_ok || !to_ok {
            out.push(
                Severity::Error,
                "signal-direction",
                format!(
                    "connection {} -> {}: a signal must flow from an input of `{}` or an output of a subprocess, to an output of `{}` or an input of a subprocess",
                    show(&c.from),
                    show(&c.to),
                    m.processes[c.owner].path,
                    m.processes[c.owner].path
                ),
                c.span,
            );
        }
    }
}

/// `edge-hierarchy` and `edge-without-link`.
fn check_edges(m: &Model, out: &mut Findings) {
    for e in &m.edges {
        let (a, b) = (
            m.failure_modes[e.from].process,
            m.failure_modes[e.to].process,
        );
        let fam = |p: ProcId| p == e.owner || m.processes[p].parent == Some(e.owner);
        let name = |f: FmId| m.failure_modes[f].path.clone();
        if !adjacent(m, a, b) || !fam(a) || !fam(b) {
            out.push(
                Severity::Error,
                "edge-hierarchy",
                format!(
                    "propagation {} -> {} declared in `{}` joins non-adjacent processes: an edge stays within one process's fault model (its own failure modes and its direct subprocesses')",
                    name(e.from),
                    name(e.to),
                    m.processes[e.owner].path
                ),
                e.span,
            );
            continue;
        }
        if a != b
            && m.processes[a].parent == m.processes[b].parent
            && m.processes[a].parent.is_some()
        {
            let linked = m
                .connections
                .iter()
                .any(|c| c.from.process == a && c.to.process == b);
            if !linked {
                out.push(
                    Severity::Error,
                    "edge-without-link",
                    format!(
                        "propagation {} -> {} has no physical path: no signal connection from `{}` to `{}` in the process model (faults propagate only along physical interactions)",
                        name(e.from),
                        name(e.to),
                        m.processes[a].path,
                        m.processes[b].path
                    ),
                    e.span,
                );
            }
        }
    }
}

/// `zero-time-cycle`: strongly connected components of the tmin = 0 subgraph.
fn check_zero_time_cycles(m: &Model, out: &mut Findings) {
    let n = m.failure_modes.len();
    let mut zero_adj = vec![Vec::new(); n];
    for e in &m.edges {
        if e.tmin == 0.0 {
            zero_adj[e.from].push(e.to);
        }
    }
    for comp in tarjan_scc(&zero_adj) {
        if comp.len() > 1 {
            let mut names: Vec<_> = comp
                .iter()
                .map(|&f| m.failure_modes[f].path.clone())
                .collect();
            names.sort();
            let span = comp
                .iter()
                .map(|&f| m.failure_modes[f].span)
                .min_by_key(|s| (s.line, s.col))
                .unwrap_or_default();
            out.push(
                Severity::Error,
                "zero-time-cycle",
                format!(
                    "zero-time propagation cycle through {}: give one edge a tmin > 0",
                    names.join(", ")
                ),
                span,
            );
        }
    }
}

/// `alarm-scope` and `alarm-unattached`.
fn check_alarms(m: &Model, out: &mut Findings) {
    for a in &m.alarms {
        for &f in &a.detects {
            let p = m.failure_modes[f].process;
            if !m.is_ancestor_or_self(a.process, p) {
                out.push(
                    Severity::Warning,
                    "alarm-scope",
                    format!(
                        "alarm `{}` of `{}` detects `{}`, outside that process: move the alarm to `{}` or an ancestor of it",
                        a.name,
                        m.processes[a.process].path,
                        m.failure_modes[f].path,
                        m.processes[p].path
                    ),
                    a.span,
                );
            }
        }
        if a.detects.is_empty() {
            out.push(
                Severity::Warning,
                "alarm-unattached",
                format!("alarm `{}` detects no failure mode", a.name),
                a.span,
            );
        }
    }
}

/// `unobservable` (reverse reachability from every alarmed failure mode) and `unreachable`.
fn check_observability(m: &Model, out: &mut Findings) {
    let n = m.failure_modes.len();
    // Observability: reverse reachability from every alarmed failure mode.
    let mut radj = vec![Vec::new(); n];
    for e in &m.edges {
        radj[e.to].push(e.from);
    }
    let mut observable = vec![false; n];
    let mut stack: Vec<FmId> = (0..n)
        .filter(|&f| !m.failure_modes[f].alarms.is_empty())
        .collect();
    for &f in &stack {
        observable[f] = true;
    }
    while let Some(f) = stack.pop() {
        for &g in &radj[f] {
            if !observable[g] {
                observable[g] = true;
                stack.push(g);
            }
        }
    }
    for (f, fm) in m.failure_modes.iter().enumerate() {
        if !observable[f] {
            out.push(
                Severity::Warning,
                "unobservable",
                format!(
                    "failure mode `{}` reaches no alarm: it cannot be diagnosed",
                    fm.path
                ),
                fm.span,
            );
        }
        if fm.derived && radj[f].is_empty() {
            out.push(
                Severity::Warning,
                "unreachable",
                format!(
                    "derived failure mode `{}` has no incoming propagation: it can never become active",
                    fm.path
                ),
                fm.span,
            );
        }
    }
}

/// Tarjan's strongly connected components (iterative), in reverse topological order.
pub(crate) fn tarjan_scc(adj: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let n = adj.len();
    let mut index = vec![usize::MAX; n];
    let mut low = vec![0; n];
    let mut on = vec![false; n];
    let mut stack = Vec::new();
    let mut out = Vec::new();
    let mut next = 0;
    for s in 0..n {
        if index[s] != usize::MAX {
            continue;
        }
        let mut call: Vec<(usize, usize)> = vec![(s, 0)];
        index[s] = next;
        low[s] = next;
        next += 1;
        stack.push(s);
        on[s] = true;
        while let Some(&mut (v, ref mut i)) = call.last_mut() {
            if *i < adj[v].len() {
                let w = adj[v][*i];
                *i += 1;
                if index[w] == usize::MAX {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on[w] = true;
                    call.push((w, 0));
                } else if on[w] {
                    low[v] = low[v].min(index[w]);
                }
            } else {
                call.pop();
                if let Some(&(u, _)) = call.last() {
                    low[u] = low[u].min(low[v]);
                }
                if low[v] == index[v] {
                    let mut comp = Vec::new();
                    while let Some(w) = stack.pop() {
                        on[w] = false;
                        comp.push(w);
                        if w == v {
                            break;
                        }
                    }
                    out.push(comp);
                }
            }
        }
    }
    out
}

/// True when the model has no error-level finding.
pub fn is_consistent(findings: &[Finding]) -> bool {
    findings.iter().all(|f| f.severity != Severity::Error)
}
