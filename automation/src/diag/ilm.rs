//! Inter Level Migration (ILM, seed §4.3): the diagnostic manager's search of the process
//! hierarchy.
//!
//! * It finds the highest level with ringing alarms and runs FSPI (and FSCI) on the processes
//!   whose fault model holds them — the *parent* level, where the alarmed process and its
//!   siblings are the nodes of one fault propagation digraph (seed figure 5).
//! * Each FSPI answers with source *subprocesses* and their source failure modes; the next
//!   [`Ilm::step`] runs FSPI on exactly those subprocesses (breadth-first, one level per step),
//!   keeping only hypotheses the level above allowed, until the sources are failure modes of
//!   the processes themselves (the finest resolution the model has).
//! * An alarm that rings higher than the level being processed restarts the search there.
//!   If no hypothesis at all lies inside the processes of the starting level (the cause is in
//!   a sibling's subtree), the search climbs one level and starts again.
//! * [`Ilm::best_guess`] is available at any moment: the deepest level finished so far.
//!
//! FSPI on a process P considers the candidate failure modes in P's subtree and the alarms
//! ringing within P's subtree (the seed's definition); propagation paths are followed over the
//! whole model, so faults entering P from outside are still seen.

use super::fspi::{AlarmError, Diagnoser, Verdict};
use super::{FaultGraph, fsci};
use crate::model::{AlarmId, CompId, FmId, Model, ProcId};

/// FSPI + FSCI on one process at one level.
#[derive(Debug, Clone)]
pub struct ProcessVerdict {
    pub process: ProcId,
    pub verdict: Verdict,
    /// Source subprocess (a child of `process`, or `process` itself) → its source failure modes.
    pub groups: Vec<(ProcId, Vec<FmId>)>,
    /// FSCI over the verdict's failure modes.
    pub components: Vec<CompId>,
}

/// One level of the migration.
#[derive(Debug, Clone)]
pub struct LevelResult {
    /// Depth of the processes FSPI ran on.
    pub depth: usize,
    pub processes: Vec<ProcessVerdict>,
}

/// The best current answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Guess {
    /// Depth of the deepest finished level.
    pub depth: usize,
    /// The suspected source processes at that level's resolution.
    pub processes: Vec<ProcId>,
    /// The suspected source failure modes.
    pub failure_modes: Vec<FmId>,
    /// FSCI: the suspected physical components.
    pub components: Vec<CompId>,
    /// True when only a multiple fault explains the alarms.
    pub multiple: bool,
}

/// The ILM state machine over one diagnosis session.
#[derive(Debug, Clone)]
pub struct Ilm<'g> {
    model: &'g Model,
    diag: Diagnoser<'g>,
    top: Option<usize>,
    levels: Vec<LevelResult>,
    stale: bool,
    /// Restarts caused by higher-level alarms (not counting the first alarm).
    pub restarts: usize,
    /// A human-readable record of the migration.
    pub log: Vec<String>,
}

impl<'g> Ilm<'g> {
    /// A session over `model` (compiled as `graph`) with the sensor allocation `present`.
    pub fn new(model: &'g Model, graph: &'g FaultGraph, present: Option<&[bool]>) -> Self {
        Ilm {
            model,
            diag: Diagnoser::new(graph, present),
            top: None,
            levels: Vec::new(),
            stale: false,
            restarts: 0,
            log: Vec::new(),
        }
    }

    /// The underlying incremental FSPI session.
    pub fn diagnoser(&self) -> &Diagnoser<'g> {
        &self.diag
    }

    /// Levels finished since the last (re)start.
    pub fn levels(&self) -> &[LevelResult] {
        &self.levels
    }

    /// The depth of the highest process with a failure mode the alarm detects.
    pub fn alarm_level(&self, a: AlarmId) -> usize {
        let al = &self.model.alarms[a];
        al.detects
            .iter()
            .map(|&f| self.model.processes[self.model.failure_modes[f].process].depth)
            .min()
            .unwrap_or(self.model.processes[al.process].depth)
    }

    /// A new alarm: FSPI is updated at once; the migration restarts when the alarm rings
    /// higher than the level being processed.
    pub fn on_alarm(&mut self, a: AlarmId, t: f64) -> Result<(), AlarmError> {
        self.on_alarms(&[(a, t)])
    }

    /// Alarms that rang together (same time stamp): one FSPI update, so none of them counts
    /// as normal for the others; then the migration rule for the highest of them.
    pub fn on_alarms(&mut self, alarms: &[(AlarmId, f64)]) -> Result<(), AlarmError> {
        self.diag.add_batch(alarms)?;
        let Some(&(a, t)) = alarms.iter().min_by_key(|(a, _)| self.alarm_level(*a)) else {
            return Ok(());
        };
        let level = self.alarm_level(a);
        let start = level.saturating_sub(1);
        let current = match (self.top, self.levels.last()) {
            (None, _) => None,
            (Some(top), None) => Some(top),
            (Some(_), Some(l)) => Some(l.depth),
        };
        match current {
            None => {
                self.top = Some(start);
                self.log.push(format!(
                    "t={t}: alarm {} rings; start at depth {start}",
                    self.model.alarms[a].name
                ));
            }
            Some(cur) if level < cur => {
                self.top = Some(start.min(self.top.unwrap_or(start)));
                self.levels.clear();
                self.restarts += 1;
                self.log.push(format!(
                    "t={t}: alarm {} rings at a higher level than depth {cur}: restart at depth {start}",
                    self.model.alarms[a].name
                ));
            }
            Some(_) => self.stale = true,
        }
        Ok(())
    }

    /// Moves the clock (see [`Diagnoser::advance_to`]).
    pub fn advance_to(&mut self, t: f64) {
        self.diag.advance_to(t);
        self.stale = true;
    }

    /// Runs FSPI/FSCI on the next level down. Returns false when there is nothing (more) to do.
    pub fn step(&mut self) -> bool {
        if self.stale {
            // New alarms on or below the current level: redo the finished levels with them
            // (cheap: the per-alarm searches are stored), without repeating them in the log.
            self.stale = false;
            let n = self.levels.len();
            let logged = self.log.len();
            self.levels.clear();
            for _ in 0..n {
                if !self.step_inner() {
                    break;
                }
            }
            self.log.truncate(logged);
        }
        self.step_inner()
    }

    /// Steps until the finest level is reached.
    pub fn run_to_completion(&mut self) {
        while self.step() {}
    }

    fn in_subtree(&self, p: ProcId, f: FmId) -> bool {
        self.model
            .is_ancestor_or_self(p, self.model.failure_modes[f].process)
    }

    fn step_inner(&mut self) -> bool {
        let Some(top) = self.top else { return false };
        let m = self.model;
        let (depth, focus, prior): (usize, Vec<ProcId>, Option<Vec<FmId>>) =
            match self.levels.last() {
                None => {
                    let ringing: Vec<AlarmId> =
                        self.diag.ringing().iter().map(|r| r.alarm).collect();
                    let focus = (0..m.processes.len())
                        .filter(|&p| m.processes[p].depth == top)
                        .filter(|&p| {
                            ringing.iter().any(|&a| {
                                m.alarms[a].detects.iter().any(|&f| self.in_subtree(p, f))
                            })
                        })
                        .collect();
                    (top, focus, None)
                }
                Some(last) => {
                    let mut focus = Vec::new();
                    let mut prior = Vec::new();
                    for pv in &last.processes {
                        for (q, fms) in &pv.groups {
                            if *q != pv.process && !focus.contains(q) {
                                focus.push(*q);
                            }
                            prior.extend(fms.iter().copied());
                        }
                    }
                    (last.depth + 1, focus, Some(prior))
                }
            };
        if focus.is_empty() {
            return false;
        }
        let mut out = Vec::new();
        for &p in &focus {
            let fm_in = |f: FmId| m.is_ancestor_or_self(p, m.failure_modes[f].process);
            let alarm_in = |a: AlarmId| {
                m.alarms[a]
                    .detects
                    .iter()
                    .any(|&f| m.is_ancestor_or_self(p, m.failure_modes[f].process))
            };
            let mut v = self.diag.verdict(&fm_in, &alarm_in);
            if let Some(prior) = &prior {
                v.single.retain(|c| prior.contains(&c.fm));
                v.multiple.retain(|h| h.iter().all(|f| prior.contains(f)));
                if v.single.is_empty() && v.multiple.is_empty() {
                    // The subtree's own alarms alone allow nothing the level above allowed:
                    // keep the level above's hypotheses inside this process.
                    let mut inside: Vec<FmId> =
                        prior.iter().copied().filter(|&f| fm_in(f)).collect();
                    inside.sort_unstable();
                    inside.dedup();
                    v.single = inside
                        .into_iter()
                        .map(|fm| super::Candidate {
                            fm,
                            t0: (f64::NEG_INFINITY, f64::INFINITY),
                        })
                        .collect();
                }
            }
            let fms = v.failure_modes();
            let mut groups: Vec<(ProcId, Vec<FmId>)> = Vec::new();
            for &f in &fms {
                let owner = m.failure_modes[f].process;
                let q = if owner == p {
                    p
                } else {
                    m.ancestor_at_depth(owner, m.processes[p].depth + 1)
                };
                match groups.iter_mut().find(|g| g.0 == q) {
                    Some(g) => g.1.push(f),
                    None => groups.push((q, vec![f])),
                }
            }
            let components = fsci(m, &fms, v.single.is_empty());
            out.push(ProcessVerdict {
                process: p,
                verdict: v,
                groups,
                components,
            });
        }
        if prior.is_none() && out.iter().all(|pv| pv.groups.is_empty()) && top > 0 {
            self.top = Some(top - 1);
            self.log.push(format!(
                "no source inside the processes at depth {top}: climb to depth {}",
                top - 1
            ));
            return self.step_inner();
        }
        let names: Vec<String> = out
            .iter()
            .flat_map(|pv| pv.groups.iter().map(|(q, _)| m.processes[*q].path.clone()))
            .collect();
        self.log.push(format!(
            "depth {depth}: FSPI on {} process(es) -> sources in [{}]",
            focus.len(),
            names.join(", ")
        ));
        self.levels.push(LevelResult {
            depth,
            processes: out,
        });
        true
    }

    /// The best guess so far: the deepest finished level's sources (None before any step).
    pub fn best_guess(&self) -> Option<Guess> {
        let last = self.levels.last()?;
        let mut processes = Vec::new();
        let mut fms = Vec::new();
        // A multiple fault found higher up stays multiple when its members are refined apart.
        let multiple = self
            .levels
            .iter()
            .flat_map(|l| &l.processes)
            .any(|pv| pv.verdict.single.is_empty() && !pv.verdict.multiple.is_empty());
        for pv in &last.processes {
            for (q, f) in &pv.groups {
                if !processes.contains(q) {
                    processes.push(*q);
                }
                fms.extend(f.iter().copied());
            }
        }
        fms.sort_unstable();
        fms.dedup();
        processes.sort_unstable();
        let components = fsci(self.model, &fms, multiple);
        Some(Guess {
            depth: last.depth,
            processes,
            failure_modes: fms,
            components,
            multiple,
        })
    }
}
