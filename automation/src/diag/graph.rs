//! The fault propagation digraph of a whole model, compiled for the diagnoser: compressed
//! adjacency (forward and reverse) over failure modes, alarm ↔ failure-mode incidence and the
//! process of each failure mode. Built once per model; read-only afterwards.

use crate::model::{AlarmId, FmId, Model};

/// One propagation edge as the search sees it.
#[derive(Debug, Clone, Copy)]
pub struct Arc {
    pub to: FmId,
    pub prob: f64,
    pub tmin: f64,
    pub tmax: f64,
}

/// The compiled fault propagation digraph (seed figure 5, all levels flattened).
#[derive(Debug, Clone)]
pub struct FaultGraph {
    out_start: Vec<usize>,
    out: Vec<Arc>,
    in_start: Vec<usize>,
    /// Reverse arcs: `to` holds the *source* of the edge.
    inc: Vec<Arc>,
    /// Alarms detecting each failure mode.
    pub fm_alarms: Vec<Vec<AlarmId>>,
    /// Failure modes each alarm detects.
    pub alarm_fms: Vec<Vec<FmId>>,
    /// May the failure mode originate a fault?
    pub can_originate: Vec<bool>,
}

impl FaultGraph {
    /// Compiles the propagation edges and alarm associations of `m`.
    pub fn new(m: &Model) -> Self {
        let n = m.failure_modes.len();
        let build = |key: &dyn Fn(&crate::model::Edge) -> (FmId, FmId)| {
            let mut start = vec![0usize; n + 1];
            for e in &m.edges {
                start[key(e).0 + 1] += 1;
            }
            for i in 0..n {
                start[i + 1] += start[i];
            }
            let mut fill = start.clone();
            let mut arcs = vec![
                Arc {
                    to: 0,
                    prob: 0.0,
                    tmin: 0.0,
                    tmax: 0.0
                };
                m.edges.len()
            ];
            for e in &m.edges {
                let (a, b) = key(e);
                arcs[fill[a]] = Arc {
                    to: b,
                    prob: e.prob,
                    tmin: e.tmin,
                    tmax: e.tmax,
                };
                fill[a] += 1;
            }
            (start, arcs)
        };
        let (out_start, out) = build(&|e| (e.from, e.to));
        let (in_start, inc) = build(&|e| (e.to, e.from));
        FaultGraph {
            out_start,
            out,
            in_start,
            inc,
            fm_alarms: m.failure_modes.iter().map(|f| f.alarms.clone()).collect(),
            alarm_fms: m.alarms.iter().map(|a| a.detects.clone()).collect(),
            can_originate: m.failure_modes.iter().map(|f| !f.derived).collect(),
        }
    }

    /// Number of failure modes.
    pub fn len(&self) -> usize {
        self.can_originate.len()
    }

    /// True for a model without failure modes.
    pub fn is_empty(&self) -> bool {
        self.can_originate.is_empty()
    }

    /// Edges leaving `f`.
    pub fn succ(&self, f: FmId) -> &[Arc] {
        &self.out[self.out_start[f]..self.out_start[f + 1]]
    }

    /// Edges entering `f`, with `to` naming their source.
    pub fn pred(&self, f: FmId) -> &[Arc] {
        &self.inc[self.in_start[f]..self.in_start[f + 1]]
    }
}
