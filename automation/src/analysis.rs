//! Diagnosability analysis and sensor-allocation advice (seed §4.3, "Testing of
//! Diagnosability" and "Research Plan", steps 2–5).
//!
//! Every single fault is run through the alarm pattern simulator, the sensor-allocation
//! filter and the incremental diagnoser; the resolution of an allocation is summarised by the
//! ambiguity-group sizes, the isolation rate and the mean time to isolation ([`evaluate`]).
//! [`advise_greedy`] proposes which alarms to keep for a sensor budget by greedy forward
//! selection; [`advise_exhaustive`] finds the optimum on small models, to measure how close the
//! greedy choice comes.

use crate::diag::{Diagnoser, FaultGraph};
use crate::model::{AlarmId, FmId, Model};
use crate::sim::{SimOptions, filter, simulate};

/// How one injected fault was diagnosed.
#[derive(Debug, Clone)]
pub struct FaultOutcome {
    pub fault: FmId,
    /// Some alarm of the allocation rang.
    pub detected: bool,
    /// The final ambiguity group (single-fault candidates; the union of the multiple-fault
    /// hypotheses when no single one fits).
    pub group: Vec<FmId>,
    /// The injected fault is in the group.
    pub correct: bool,
    /// The group is exactly the injected fault.
    pub isolated: bool,
    /// Seconds from the fault to the first moment the diagnoser had isolated it.
    pub time_to_isolation: Option<f64>,
}

/// The resolution of one sensor allocation.
#[derive(Debug, Clone)]
pub struct Resolution {
    pub alarms_kept: usize,
    pub faults: usize,
    pub detected: usize,
    pub isolated: usize,
    pub correct: usize,
    /// Mean ambiguity-group size over detected faults.
    pub mean_group: f64,
    pub max_group: usize,
    /// Mean time to isolation over isolated faults (seconds).
    pub mean_time_to_isolation: Option<f64>,
    pub outcomes: Vec<FaultOutcome>,
}

impl Resolution {
    /// Isolated faults / all faults.
    pub fn isolation_rate(&self) -> f64 {
        if self.faults == 0 {
            0.0
        } else {
            self.isolated as f64 / self.faults as f64
        }
    }

    /// The advisor's objective (lower is better): the expected ambiguity-group size, counting
    /// an undetected or wrongly diagnosed fault as the whole fault set.
    pub fn cost(&self, n_sources: usize) -> f64 {
        let total: usize = self
            .outcomes
            .iter()
            .map(|o| if o.correct { o.group.len() } else { n_sources })
            .sum();
        total as f64 / self.outcomes.len().max(1) as f64
    }
}

/// Runs every source failure mode (`trials` times each, seeds derived from `opts.seed`) through
/// simulator → filter(`present`) → diagnoser, judging the final verdict at the end of the
/// observation window `opts.window`.
pub fn evaluate(
    m: &Model,
    g: &FaultGraph,
    present: &[bool],
    opts: &SimOptions,
    trials: usize,
) -> Resolution {
    let sources = m.source_failure_modes();
    let mut outcomes = Vec::new();
    for &f in &sources {
        for trial in 0..trials.max(1) {
            let o = SimOptions {
                seed: opts.seed ^ ((f as u64) << 20) ^ trial as u64,
                ..*opts
            };
            outcomes.push(diagnose_one(g, f, present, &o));
        }
    }
    summarize(present, outcomes)
}

fn diagnose_one(g: &FaultGraph, fault: FmId, present: &[bool], opts: &SimOptions) -> FaultOutcome {
    let sim = simulate(g, &[(fault, 0.0)], opts);
    let seen = filter(&sim.alarms, present);
    let mut d = Diagnoser::new(g, Some(present));
    d.max_faults = 2;
    let mut tti = None;
    let mut i = 0;
    while i < seen.len() {
        let t = seen[i].time;
        let mut batch = Vec::new();
        while i < seen.len() && seen[i].time == t {
            batch.push((seen[i].alarm, t));
            i += 1;
        }
        // The events come from the simulator over the same allocation: always accepted.
        if d.add_batch(&batch).is_err() {
            break;
        }
        let c = d.candidates();
        if tti.is_none() && c.len() == 1 && c[0].fm == fault {
            tti = Some(t);
        }
    }
    d.advance_to(opts.window);
    let v = d.global_verdict();
    let group = v.failure_modes();
    let correct = group.contains(&fault);
    let isolated = correct && group.len() == 1;
    FaultOutcome {
        fault,
        detected: !seen.is_empty(),
        correct,
        isolated,
        time_to_isolation: if isolated {
            tti.or(seen.last().map(|e| e.time))
        } else {
            None
        },
        group,
    }
}

fn summarize(present: &[bool], outcomes: Vec<FaultOutcome>) -> Resolution {
    let detected: Vec<&FaultOutcome> = outcomes.iter().filter(|o| o.detected).collect();
    let tt: Vec<f64> = outcomes
        .iter()
        .filter_map(|o| o.time_to_isolation)
        .collect();
    Resolution {
        alarms_kept: present.iter().filter(|&&p| p).count(),
        faults: outcomes.len(),
        detected: detected.len(),
        isolated: outcomes.iter().filter(|o| o.isolated).count(),
        correct: outcomes.iter().filter(|o| o.correct).count(),
        mean_group: if detected.is_empty() {
            0.0
        } else {
            detected.iter().map(|o| o.group.len()).sum::<usize>() as f64 / detected.len() as f64
        },
        max_group: outcomes.iter().map(|o| o.group.len()).max().unwrap_or(0),
        mean_time_to_isolation: if tt.is_empty() {
            None
        } else {
            Some(tt.iter().sum::<f64>() / tt.len() as f64)
        },
        outcomes,
    }
}

fn mask(n: usize, keep: &[AlarmId]) -> Vec<bool> {
    let mut p = vec![false; n];
    for &a in keep {
        p[a] = true;
    }
    p
}

/// Greedy forward selection: starting from no alarm, repeatedly keep the alarm that lowers
/// [`Resolution::cost`] most — ties broken by the lower mean time to isolation, then the lower
/// alarm index — up to `budget` alarms. The cost is measured with `opts` (sampled propagation
/// when `opts.sample_probabilities`) over `trials` scenarios per fault. Returns the alarms in
/// the order chosen — every prefix is the greedy allocation for that smaller budget — with the
/// cost after each choice.
pub fn advise_greedy(
    m: &Model,
    g: &FaultGraph,
    budget: usize,
    opts: &SimOptions,
    trials: usize,
) -> Vec<(AlarmId, f64)> {
    let na = m.alarms.len();
    let n_src = m.source_failure_modes().len();
    let mut chosen: Vec<AlarmId> = Vec::new();
    let mut out = Vec::new();
    while chosen.len() < budget.min(na) {
        let mut best: Option<(AlarmId, f64, f64)> = None;
        for a in 0..na {
            if chosen.contains(&a) {
                continue;
            }
            chosen.push(a);
            let r = evaluate(m, g, &mask(na, &chosen), opts, trials);
            chosen.pop();
            let (c, t) = (
                r.cost(n_src),
                r.mean_time_to_isolation.unwrap_or(f64::INFINITY),
            );
            let better = match best {
                None => true,
                Some((_, bc, bt)) => c < bc - 1e-12 || ((c - bc).abs() <= 1e-12 && t < bt - 1e-9),
            };
            if better {
                best = Some((a, c, t));
            }
        }
        let Some((a, c, _)) = best else { break };
        chosen.push(a);
        out.push((a, c));
    }
    out
}

/// The optimal allocation of exactly `budget` alarms by exhaustive search over all subsets
/// (C(alarms, budget) evaluations — small models only). Returns the alarms and the cost.
pub fn advise_exhaustive(
    m: &Model,
    g: &FaultGraph,
    budget: usize,
    opts: &SimOptions,
) -> (Vec<AlarmId>, f64) {
    let na = m.alarms.len();
    let n_src = m.source_failure_modes().len();
    let o = SimOptions {
        sample_probabilities: false,
        ..*opts
    };
    let k = budget.min(na);
    let mut idx: Vec<usize> = (0..k).collect();
    let mut best = (idx.clone(), f64::INFINITY);
    loop {
        let c = evaluate(m, g, &mask(na, &idx), &o, 1).cost(n_src);
        if c < best.1 - 1e-12 {
            best = (idx.clone(), c);
        }
        // Next k-combination in lexicographic order: bump the rightmost index that can move.
        let mut i = k;
        let movable = loop {
            if i == 0 {
                break None;
            }
            i -= 1;
            if idx[i] < na - k + i {
                break Some(i);
            }
        };
        let Some(i) = movable else { return best };
        idx[i] += 1;
        for j in i + 1..k {
            idx[j] = idx[j - 1] + 1;
        }
    }
}
