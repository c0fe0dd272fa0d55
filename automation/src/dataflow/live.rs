//! A [`GraphSpec`] running on the kernel: built once, sampled by passes, rewired in place.
//!
//! The graph runs on a manual kernel graph ([`Graph::manual`]): a pass fires the ready actors
//! on the caller's thread until the graph is quiescent, so a pass is deterministic and a
//! process that runs it needs no worker threads to stop.
//!
//! **A pass** ([`LiveGraph::pass`]): every source's value is written to its node (one token
//! per reader: an `ifall` actor fed by sources fires once per pass), every sink's node is
//! demanded ([`crate::kernel::Control::demand`]: a demand-driven chain computes what the sinks
//! read and nothing else), the graph is stepped until nothing is ready, and each sink's value is
//! the last value of its node.
//!
//! **Reconfiguration** ([`LiveGraph::reconfigure`]): the new spec is compared with the running
//! one by name. An actor whose declaration is the same ([`ActorDecl::same_as`]) is kept — its
//! memory (a filter's output, a PID's integral) and its read positions survive; an actor that
//! changed is replaced, its successor reading each input node from where it stopped
//! ([`crate::kernel::Edit::connect_in_from`]: no token lost or read twice); one that went is
//! removed; one that came is added, reading only what is written after it came. Data nodes are kept when their retention is the same (with their
//! values), re-created otherwise. All of it is one atomic kernel edit.

use super::{ActorDecl, GraphSpec, SinkDecl, actors};
use crate::kernel::{ActorId, DataId, Edit, Graph, KernelError, Retention, Value};
use std::collections::BTreeMap;

/// Most firings one pass may take: a graph that has not settled by then has a loop that
/// feeds itself (an actor whose output reaches its own input through data-driven actors).
pub const MAX_FIRINGS_PER_PASS: usize = 100_000;

/// The graph could not be built on the kernel. A spec made by the parser passes its checks,
/// so this names a spec built by hand wrongly.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The kernel refused an edit for actor or node `what`.
    #[error("{file}: building actor or node `{what}`: {source}")]
    Kernel {
        file: String,
        what: String,
        #[source]
        source: KernelError,
    },
    /// An actor of a kind the registry does not have.
    #[error("{file}: actor `{actor}`: {message}")]
    Kind {
        file: String,
        actor: String,
        message: String,
    },
    /// An actor port names a node the spec does not declare.
    #[error("{file}: actor `{actor}` names data node `{node}`, which the graph does not declare")]
    MissingNode {
        file: String,
        actor: String,
        node: String,
    },
}

/// A pass that did not complete.
#[derive(Debug, thiserror::Error)]
pub enum PassError {
    /// A source the spec does not declare was given a value.
    #[error("no source named `{0}` in the graph")]
    UnknownSource(String),
    /// The graph did not become quiescent (see [`MAX_FIRINGS_PER_PASS`]).
    #[error(
        "the graph did not settle within {0} firings: a data-driven loop feeds itself (close it through a sink and a source, or make one of its actors demand-driven)"
    )]
    Runaway(usize),
    #[error(transparent)]
    Kernel(#[from] KernelError),
}

/// One sink's value after a pass.
#[derive(Debug, Clone, PartialEq)]
pub struct SinkValue {
    pub sink: SinkDecl,
    /// The node's last value (`None`: nothing has written it yet).
    pub value: Option<f64>,
}

/// What [`LiveGraph::reconfigure`] did, by actor name.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Reconfigured {
    pub kept: Vec<String>,
    pub replaced: Vec<String>,
    pub added: Vec<String>,
    pub removed: Vec<String>,
}

impl std::fmt::Display for Reconfigured {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let list = |v: &[String]| {
            if v.is_empty() {
                "-".to_owned()
            } else {
                v.join(" ")
            }
        };
        write!(
            f,
            "kept {}; replaced {}; added {}; removed {}",
            list(&self.kept),
            list(&self.replaced),
            list(&self.added),
            list(&self.removed)
        )
    }
}

/// A graph spec running on a manual kernel graph (module docs).
pub struct LiveGraph {
    graph: Graph,
    spec: GraphSpec,
    nodes: BTreeMap<String, DataId>,
    actors: BTreeMap<String, ActorId>,
    errors_seen: usize,
}

fn build_err(file: &str, what: &str) -> impl Fn(KernelError) -> BuildError {
    let (file, what) = (file.to_owned(), what.to_owned());
    move |source| BuildError::Kernel {
        file: file.clone(),
        what: what.clone(),
        source,
    }
}

/// Every data node of `spec` with its retention, sources first.
fn node_list(spec: &GraphSpec) -> Vec<(String, Retention)> {
    spec.sources
        .iter()
        .map(|s| (s.name.clone(), Retention::LastValue))
        .chain(spec.data.iter().map(|d| (d.name.clone(), d.retention)))
        .collect()
}

/// Adds actor `a` and connects its ports to `nodes`.
/// Where a replaced actor's input ports stood: (actor, port) → (node name, reader position).
type Positions = BTreeMap<(String, String), (String, u64)>;

/// Adds actor `a` and connects its ports to `nodes`. An input port continues from the position
/// in `positions` (the actor it replaces, same node); any other reads only what is written from
/// now on — a new actor never takes a value computed before it came for a fresh token.
fn add_actor(
    e: &mut Edit<'_>,
    a: &ActorDecl,
    nodes: &BTreeMap<String, DataId>,
    positions: &Positions,
    file: &str,
) -> Result<ActorId, BuildError> {
    let be = build_err(file, &a.name);
    let spec = actors::spec(a).map_err(|message| BuildError::Kind {
        file: file.to_owned(),
        actor: a.name.clone(),
        message,
    })?;
    let missing = a
        .inputs
        .iter()
        .chain(&a.outputs)
        .find(|n| !nodes.contains_key(*n));
    if let Some(node) = missing {
        return Err(BuildError::MissingNode {
            file: file.to_owned(),
            actor: a.name.clone(),
            node: node.clone(),
        });
    }
    let id = e.add_actor(spec).map_err(&be)?;
    connect(e, id, a, nodes, positions).map_err(&be)?;
    Ok(id)
}

fn kind_ports(a: &ActorDecl) -> (&'static [&'static str], &'static [&'static str]) {
    actors::kind(&a.kind).map_or((&[], &[]), |k| (k.inputs, k.outputs))
}

fn connect(
    e: &mut Edit<'_>,
    id: ActorId,
    a: &ActorDecl,
    nodes: &BTreeMap<String, DataId>,
    positions: &Positions,
) -> Result<(), KernelError> {
    let (ins, outs) = kind_ports(a);
    for (port, node) in ins.iter().zip(&a.inputs) {
        if let Some(d) = nodes.get(node) {
            let cursor = positions
                .get(&(a.name.clone(), (*port).to_owned()))
                .filter(|(n, _)| n == node)
                .map_or(u64::MAX, |(_, c)| *c);
            e.connect_in_from(*d, id, port, cursor)?;
        }
    }
    for (port, node) in outs.iter().zip(&a.outputs) {
        if let Some(d) = nodes.get(node) {
            e.connect_out(id, port, *d)?;
        }
    }
    Ok(())
}

impl LiveGraph {
    /// Builds `spec` on a fresh manual graph.
    pub fn build(spec: GraphSpec) -> Result<LiveGraph, BuildError> {
        let graph = Graph::manual();
        let file = spec.file.clone();
        let (nodes, actors) = graph.edit(|e| -> Result<_, BuildError> {
            let mut nodes = BTreeMap::new();
            for (name, retention) in node_list(&spec) {
                let d = e
                    .add_data(&name, retention)
                    .map_err(build_err(&file, &name))?;
                nodes.insert(name, d);
            }
            let mut actors = BTreeMap::new();
            for a in &spec.actors {
                actors.insert(
                    a.name.clone(),
                    add_actor(e, a, &nodes, &Positions::new(), &file)?,
                );
            }
            Ok((nodes, actors))
        })?;
        Ok(LiveGraph {
            graph,
            spec,
            nodes,
            actors,
            errors_seen: 0,
        })
    }

    /// The spec running now.
    pub fn spec(&self) -> &GraphSpec {
        &self.spec
    }

    /// The kernel graph (for the DOT export, the trace, firing counts).
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// The last value of data node `name`.
    pub fn value(&self, name: &str) -> Option<f64> {
        let d = self.nodes.get(name)?;
        match self.graph.latest(*d).ok()?? {
            Value::F64(x) => Some(x),
            Value::Bool(b) => Some(f64::from(u8::from(b))),
            _ => None,
        }
    }

    /// How many times actor `name` has fired (since it was added).
    pub fn fired(&self, name: &str) -> Option<u64> {
        self.graph.fired(*self.actors.get(name)?).ok()
    }

    /// Script errors since the last call (`actor: message`).
    pub fn new_errors(&mut self) -> Vec<String> {
        let all = self.graph.errors();
        let new = all.get(self.errors_seen..).unwrap_or_default().to_vec();
        self.errors_seen = all.len();
        new
    }

    /// One sample (module docs): `sources` gives each source's value by name (a source left
    /// out gets no token this pass); returns every sink's value.
    pub fn pass(&mut self, sources: &[(&str, f64)]) -> Result<Vec<SinkValue>, PassError> {
        for (name, x) in sources {
            if !self.spec.sources.iter().any(|s| s.name == *name) {
                return Err(PassError::UnknownSource((*name).to_owned()));
            }
            let d = self
                .nodes
                .get(*name)
                .ok_or_else(|| PassError::UnknownSource((*name).to_owned()))?;
            self.graph.write(*d, Value::F64(*x))?;
        }
        for s in &self.spec.sinks {
            if let Some(d) = self.nodes.get(&s.node) {
                self.graph.demand(*d)?;
            }
        }
        let fired = self.graph.run_manual(MAX_FIRINGS_PER_PASS)?;
        if fired >= MAX_FIRINGS_PER_PASS && self.graph.step()?.is_some() {
            return Err(PassError::Runaway(MAX_FIRINGS_PER_PASS));
        }
        Ok(self
            .spec
            .sinks
            .iter()
            .map(|s| SinkValue {
                sink: s.clone(),
                value: self.value(&s.node),
            })
            .collect())
    }

    /// Rewires the running graph to `new` (module docs), in one atomic edit. Only a spec not
    /// made by the parser can fail here ([`BuildError`]); the graph is then partly rewired
    /// and should be built again.
    pub fn reconfigure(&mut self, new: GraphSpec) -> Result<Reconfigured, BuildError> {
        let old = &self.spec;
        let file = new.file.clone();
        let old_nodes: BTreeMap<String, Retention> = node_list(old).into_iter().collect();
        let new_nodes: Vec<(String, Retention)> = node_list(&new);
        // Nodes kept: same name, same retention.
        let kept_nodes: Vec<String> = new_nodes
            .iter()
            .filter(|(n, r)| old_nodes.get(n) == Some(r))
            .map(|(n, _)| n.clone())
            .collect();
        let mut report = Reconfigured::default();
        let mut keep_actor: BTreeMap<String, bool> = BTreeMap::new();
        for a in &new.actors {
            let same = old
                .actors
                .iter()
                .find(|o| o.name == a.name)
                .is_some_and(|o| {
                    o.same_as(a)
                        && a.inputs
                            .iter()
                            .chain(&a.outputs)
                            .all(|n| kept_nodes.contains(n))
                });
            keep_actor.insert(a.name.clone(), same);
        }
        for o in &old.actors {
            match keep_actor.get(&o.name) {
                Some(true) => report.kept.push(o.name.clone()),
                Some(false) => report.replaced.push(o.name.clone()),
                None => report.removed.push(o.name.clone()),
            }
        }
        for a in &new.actors {
            if !old.actors.iter().any(|o| o.name == a.name) {
                report.added.push(a.name.clone());
            }
        }
        let mut nodes = self.nodes.clone();
        let mut actor_ids = self.actors.clone();
        let result = self.graph.edit(|e| -> Result<(), BuildError> {
            // 1. Actors that go or change leave (their ports with them); where a changed
            // actor's inputs stood is noted for its successor.
            let mut positions = Positions::new();
            for o in &old.actors {
                if keep_actor.get(&o.name) != Some(&true)
                    && let Some(id) = actor_ids.remove(&o.name)
                {
                    let be = build_err(&file, &o.name);
                    let (ins, _) = kind_ports(o);
                    for (port, node) in ins.iter().zip(&o.inputs) {
                        if let Some((_, cursor)) = e.disconnect_in(id, port).map_err(&be)? {
                            positions.insert(
                                (o.name.clone(), (*port).to_owned()),
                                (node.clone(), cursor),
                            );
                        }
                    }
                    e.remove_actor(id).map_err(&be)?;
                }
            }
            // 2. Nodes that go or change retention leave; new ones come.
            for (name, d) in self.nodes.iter() {
                if !kept_nodes.contains(name) {
                    e.remove_data(*d).map_err(build_err(&file, name))?;
                    nodes.remove(name);
                }
            }
            for (name, retention) in &new_nodes {
                if !nodes.contains_key(name) {
                    let d = e
                        .add_data(name, *retention)
                        .map_err(build_err(&file, name))?;
                    nodes.insert(name.clone(), d);
                }
            }
            // 3. New and changed actors come, wired to the nodes.
            for a in &new.actors {
                if keep_actor.get(&a.name) != Some(&true) {
                    // A node re-created (retention changed) starts afresh: no position.
                    let carried: Positions = positions
                        .iter()
                        .filter(|(_, (n, _))| kept_nodes.contains(n))
                        .map(|(k, v)| (k.clone(), v.clone()))
                        .collect();
                    let id = add_actor(e, a, &nodes, &carried, &file)?;
                    actor_ids.insert(a.name.clone(), id);
                }
            }
            Ok(())
        });
        result?;
        self.nodes = nodes;
        self.actors = actor_ids;
        self.spec = new;
        Ok(report)
    }
}
