//! Failure Source Process Identification (FSPI, seed §4.3 "Diagnostic Algorithm"), incremental.
//!
//! A [`Diagnoser`] holds the alarm state of one diagnosis session over a [`FaultGraph`] and a
//! sensor allocation (which alarms exist). Each new alarm updates the hypotheses without
//! starting over:
//!
//! 1. **Reachability + monitor.** When alarm `a` rings at `t`, one reverse search from the
//!    failure modes `a` detects finds every failure mode that can reach them *through failure
//!    modes whose alarms are not normal* — a failure mode monitored by a present alarm that has
//!    not rung by `t` is not active, so no fault passed through it (the monitor constraint), and
//!    it cannot be the source either (a source is active from the fault time on). The result is
//!    stored per alarm: source → `(dmin, dmax)`.
//! 2. **Temporal.** `dmin` is the least Σ`tmin` over the admissible paths and `dmax` the least
//!    Σ`tmax` over the admissible paths whose edges all have probability 1 (∞ when there is
//!    none). The seed takes both bounds from the shortest path; with probabilities below 1 the
//!    shortest path may not fire and a slower path deliver the fault after its Σ`tmax`, which
//!    would reject the true source — so the upper bound is taken only from paths that must
//!    fire. Each single-fault candidate keeps an interval for its unknown fault time `t0`;
//!    every alarm narrows it to `[t − dmax, t − dmin]`; an empty interval rejects the candidate.
//!    Incrementally: candidates are only ever intersected with the new alarm's map.
//! 3. **Consistency.** A failure mode that a candidate reaches along edges of probability 1 (so
//!    it *must* become active) within `dmax`, and whose alarm is still normal at `now` although
//!    `t0_max + dmax < now`, rejects the candidate (the seed: no ringing alarm later than the
//!    latest reachability time of a normal one). Only the nearest such failure mode matters; its
//!    distance is found by a forward search that stops there and is cached per source until
//!    that failure mode's alarm rings. Checked after each alarm and on
//!    [`Diagnoser::advance_to`].
//!
//! When no single failure mode satisfies all four, [`Diagnoser::verdict`] searches for the
//! smallest sets of failure modes that jointly explain the alarms (each alarm explained by a
//! member within that member's own fault-time interval; members pass the consistency check):
//! the multiple-fault case.
//!
//! While single-fault candidates exist, an alarm's reverse searches stop as soon as every
//! candidate is settled (nothing else can survive the intersection); the map is completed —
//! with admissibility judged as of the alarm's time from the recorded ring times — only when a
//! verdict needs every explanation (multiple faults, ILM scopes).
//!
//! Entry points: [`Diagnoser::new`], [`Diagnoser::add_alarm`], [`Diagnoser::add_batch`],
//! [`Diagnoser::advance_to`], [`Diagnoser::candidates`], [`Diagnoser::verdict`] (any scope).

use super::graph::FaultGraph;
use crate::model::{AlarmId, FmId};
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

const EPS: f64 = 1e-9;

/// An alarm's time and its explanations (source, dmin, dmax), sorted by source.
type Explained = (f64, Vec<(FmId, f64, f64)>);

/// A single-fault hypothesis: a source failure mode and the interval its fault time lies in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub fm: FmId,
    /// Earliest and latest fault time consistent with the alarms (seconds).
    pub t0: (f64, f64),
}

/// A ringing alarm and the sources that explain it.
#[derive(Debug, Clone)]
pub struct Ringing {
    pub alarm: AlarmId,
    pub time: f64,
    /// Source failure mode → (dmin, dmax) propagation time bounds to this alarm.
    pub explain: HashMap<FmId, (f64, f64)>,
    /// False when `explain` holds only the single-fault candidates of the moment (see
    /// [`Diagnoser::complete_explanations`]).
    pub complete: bool,
}

/// The answer of FSPI over a scope.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Verdict {
    /// Single-fault candidates (the ambiguity group), by failure-mode index.
    pub single: Vec<Candidate>,
    /// Minimal multiple-fault hypotheses, used when `single` is empty.
    pub multiple: Vec<Vec<FmId>>,
    /// Number of ringing alarms the verdict considered.
    pub alarms: usize,
}

impl Verdict {
    /// Every failure mode named by some hypothesis, sorted.
    pub fn failure_modes(&self) -> Vec<FmId> {
        let mut v: Vec<FmId> = if self.single.is_empty() {
            self.multiple.iter().flatten().copied().collect()
        } else {
            self.single.iter().map(|c| c.fm).collect()
        };
        v.sort_unstable();
        v.dedup();
        v
    }
}

/// Why an alarm was not accepted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AlarmError {
    #[error("alarm index {0} does not exist in the model")]
    Unknown(AlarmId),
    #[error("alarm index {0} is not in the sensor allocation")]
    NotAllocated(AlarmId),
    #[error("alarm at t = {time} s arrives before the diagnoser's current time {now} s")]
    OutOfOrder { time: f64, now: f64 },
    #[error("alarm time {0} is not finite")]
    BadTime(f64),
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Key(f64, FmId);
impl Eq for Key {}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// Epoch-stamped scratch arrays, so a search costs what it touches, not the graph size.
#[derive(Debug, Clone)]
struct Scratch {
    dist: Vec<f64>,
    stamp: Vec<u32>,
    done: Vec<u32>,
    epoch: u32,
    heap: BinaryHeap<Key>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Scratch {
            dist: vec![0.0; n],
            stamp: vec![0; n],
            done: vec![0; n],
            epoch: 0,
            heap: BinaryHeap::new(),
        }
    }
    fn begin(&mut self) {
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.done.iter_mut().for_each(|s| *s = 0);
            self.epoch = 1;
        }
        self.heap.clear();
    }
    fn relax(&mut self, v: FmId, d: f64) {
        if self.stamp[v] != self.epoch || d < self.dist[v] {
            self.stamp[v] = self.epoch;
            self.dist[v] = d;
            self.heap.push(Key(d, v));
        }
    }
    /// Pops the next settled node.
    fn pop(&mut self) -> Option<(FmId, f64)> {
        while let Some(Key(d, v)) = self.heap.pop() {
            if self.done[v] != self.epoch && d <= self.dist[v] {
                self.done[v] = self.epoch;
                return Some((v, d));
            }
        }
        None
    }
}

/// One incremental diagnosis session (see the module docs).
#[derive(Debug, Clone)]
pub struct Diagnoser<'g> {
    g: &'g FaultGraph,
    present: Vec<bool>,
    rung: Vec<Option<f64>>,
    /// Per failure mode: present alarms detecting it that have not rung.
    pending: Vec<u32>,
    now: f64,
    ringing: Vec<Ringing>,
    single: Vec<Candidate>,
    started: bool,
    scratch: Scratch,
    /// Per source: (distance, failure mode) of the nearest silent failure mode it must reach.
    silent_cache: HashMap<FmId, (f64, Option<FmId>)>,
    /// Largest hypothesis size the multiple-fault search tries (default 3).
    pub max_faults: usize,
    /// Stop each alarm's searches once the current candidates are settled (default true;
    /// false computes every explanation map in full — the same answers, slower).
    pub bound_searches: bool,
}

impl<'g> Diagnoser<'g> {
    /// A session over `g` where `present[a]` says whether alarm `a` is in the sensor allocation
    /// (`None`: all alarms present). Time starts at 0 s.
    pub fn new(g: &'g FaultGraph, present: Option<&[bool]>) -> Self {
        let na = g.alarm_fms.len();
        let present: Vec<bool> = match present {
            Some(p) => (0..na)
                .map(|a| p.get(a).copied().unwrap_or(false))
                .collect(),
            None => vec![true; na],
        };
        let mut pending = vec![0u32; g.len()];
        for (a, fms) in g.alarm_fms.iter().enumerate() {
            if present[a] {
                for &f in fms {
                    pending[f] += 1;
                }
            }
        }
        Diagnoser {
            g,
            present,
            rung: vec![None; na],
            pending,
            now: 0.0,
            ringing: Vec::new(),
            single: Vec::new(),
            started: false,
            scratch: Scratch::new(g.len()),
            silent_cache: HashMap::new(),
            max_faults: 3,
            bound_searches: true,
        }
    }

    /// The current time (the latest alarm or [`advance_to`](Self::advance_to)), seconds.
    pub fn now(&self) -> f64 {
        self.now
    }

    /// Alarms received so far, in order.
    pub fn ringing(&self) -> &[Ringing] {
        &self.ringing
    }

    /// When alarm `a` rang, if it did.
    pub fn rung_at(&self, a: AlarmId) -> Option<f64> {
        self.rung.get(a).copied().flatten()
    }

    /// The current single-fault candidates over the whole model (empty before any alarm, and
    /// when only a multiple fault explains the alarms).
    pub fn candidates(&self) -> &[Candidate] {
        &self.single
    }

    /// One alarm rang at `time` (seconds, not earlier than the previous alarm). Repeated alarms
    /// are ignored. Side effect: updates the hypotheses.
    pub fn add_alarm(&mut self, alarm: AlarmId, time: f64) -> Result<(), AlarmError> {
        self.add_batch(&[(alarm, time)])
    }

    /// Several alarms at once (those sharing a time stamp should come together, so none of them
    /// counts as "normal" for the others).
    pub fn add_batch(&mut self, alarms: &[(AlarmId, f64)]) -> Result<(), AlarmError> {
        for &(a, t) in alarms {
            if a >= self.present.len() {
                return Err(AlarmError::Unknown(a));
            }
            if !self.present[a] {
                return Err(AlarmError::NotAllocated(a));
            }
            if !t.is_finite() {
                return Err(AlarmError::BadTime(t));
            }
            if t + EPS < self.now {
                return Err(AlarmError::OutOfOrder {
                    time: t,
                    now: self.now,
                });
            }
        }
        let mut fresh = Vec::new();
        for &(a, t) in alarms {
            if self.rung[a].is_none() {
                self.rung[a] = Some(t);
                for &f in &self.g.alarm_fms[a] {
                    self.pending[f] -= 1;
                }
                fresh.push((a, t));
            }
        }
        for &(a, t) in &fresh {
            self.now = self.now.max(t);
            // While single-fault candidates exist, only they can survive: search until they are
            // all settled. The map is completed later if a verdict needs all explanations.
            let bound: Option<Vec<FmId>> =
                (self.bound_searches && self.started && !self.single.is_empty())
                    .then(|| self.single.iter().map(|c| c.fm).collect());
            let complete = bound.is_none();
            let explain = self.explain(a, bound.as_deref(), None);
            if !self.started {
                self.started = true;
                self.single = explain
                    .iter()
                    .map(|(&fm, &(dmin, dmax))| Candidate {
                        fm,
                        t0: (t - dmax, t - dmin),
                    })
                    .collect();
                self.single.sort_by_key(|c| c.fm);
            } else {
                self.single.retain_mut(|c| match explain.get(&c.fm) {
                    Some(&(dmin, dmax)) => {
                        c.t0 = (c.t0.0.max(t - dmax), c.t0.1.min(t - dmin));
                        c.t0.0 <= c.t0.1 + EPS
                    }
                    None => false,
                });
            }
            self.ringing.push(Ringing {
                alarm: a,
                time: t,
                explain,
                complete,
            });
        }
        self.apply_consistency();
        Ok(())
    }

    /// Moves the clock to `t` with no new alarm; alarms that should have rung by now but did not
    /// reject the candidates that predicted them.
    pub fn advance_to(&mut self, t: f64) {
        if t > self.now {
            self.now = t;
            self.apply_consistency();
        }
    }

    fn apply_consistency(&mut self) {
        let mut single = std::mem::take(&mut self.single);
        single.retain(|c| self.consistent(c.fm, c.t0.1));
        self.single = single;
    }

    /// Reverse search from the failure modes alarm `a` detects (reachability, monitor and the
    /// temporal bounds), see the module docs.
    ///
    /// `bound`: stop once every one of these failure modes is settled (the current single-fault
    /// candidates — nothing else can survive the intersection); the map is then partial.
    /// `as_of`: judge admissibility as of that time from the recorded ring times (used to
    /// complete a partial map later) instead of the current silent set.
    fn explain(
        &mut self,
        a: AlarmId,
        bound: Option<&[FmId]>,
        as_of: Option<f64>,
    ) -> HashMap<FmId, (f64, f64)> {
        let g = self.g;
        let (pending, rung, present) = (&self.pending, &self.rung, &self.present);
        let admissible = |u: FmId| match as_of {
            None => pending[u] == 0,
            Some(t) => g.fm_alarms[u]
                .iter()
                .all(|&b| !present[b] || rung[b].is_some_and(|tb| tb <= t + EPS)),
        };
        let targets: Vec<FmId> = g.alarm_fms[a]
            .iter()
            .copied()
            .filter(|&f| admissible(f))
            .collect();
        let run = |weight: fn(&super::graph::Arc) -> Option<f64>, sc: &mut Scratch| {
            sc.begin();
            for &t in &targets {
                sc.relax(t, 0.0);
            }
            let mut out = Vec::new();
            let mut left = bound.map(|b| b.len());
            while let Some((v, d)) = sc.pop() {
                out.push((v, d));
                if let Some(n) = left.as_mut()
                    && bound.is_some_and(|b| b.binary_search(&v).is_ok())
                {
                    *n -= 1;
                    if *n == 0 {
                        break;
                    }
                }
                for arc in g.pred(v) {
                    let u = arc.to;
                    if let Some(w) = weight(arc)
                        && admissible(u)
                    {
                        sc.relax(u, d + w);
                    }
                }
            }
            out
        };
        let mins = run(|a| Some(a.tmin), &mut self.scratch);
        // The latest arrival is bounded only along paths that certainly fire: with p < 1 the
        // fast path may not fire and a slower one deliver the fault later.
        let maxs = run(|a| (a.prob >= 1.0).then_some(a.tmax), &mut self.scratch);
        let mut map: HashMap<FmId, (f64, f64)> = HashMap::with_capacity(mins.len());
        for (v, d) in mins {
            if g.can_originate[v] {
                map.insert(v, (d, f64::INFINITY));
            }
        }
        for (v, d) in maxs {
            if let Some(e) = map.get_mut(&v) {
                e.1 = d;
            }
        }
        map
    }

    /// Completes the partial explanation maps of the ringing alarms selected by `which`
    /// (searches again with admissibility as of each alarm's time).
    fn complete_where(&mut self, which: &dyn Fn(AlarmId) -> bool) {
        for i in 0..self.ringing.len() {
            if !self.ringing[i].complete && which(self.ringing[i].alarm) {
                let (a, t) = (self.ringing[i].alarm, self.ringing[i].time);
                self.ringing[i].explain = self.explain(a, None, Some(t));
                self.ringing[i].complete = true;
            }
        }
    }

    /// Makes every stored explanation map complete (each update stores only what the
    /// single-fault candidates need while there are some).
    pub fn complete_explanations(&mut self) {
        self.complete_where(&|_| true);
    }

    /// The consistency constraint for source `s` with latest fault time `t0_max`.
    fn consistent(&mut self, s: FmId, t0_max: f64) -> bool {
        if self.now - t0_max <= EPS {
            return true;
        }
        let (d, _) = self.nearest_silent(s);
        t0_max + d >= self.now - EPS
    }

    /// The least Σtmax along probability-1 edges from `s` to a failure mode whose allocated
    /// alarm has not rung (through failure modes that are not silent), and that failure mode.
    /// Cached per source: the silent set only shrinks, so the distance can only change when
    /// the nearest silent failure mode itself rings (any other that rings lies at least as far).
    fn nearest_silent(&mut self, s: FmId) -> (f64, Option<FmId>) {
        if let Some(&(d, w)) = self.silent_cache.get(&s)
            && w.is_none_or(|w| self.pending[w] > 0)
        {
            return (d, w);
        }
        let g = self.g;
        let sc = &mut self.scratch;
        sc.begin();
        sc.relax(s, 0.0);
        let mut found = (f64::INFINITY, None);
        while let Some((v, d)) = sc.pop() {
            if self.pending[v] > 0 {
                found = (d, Some(v));
                break;
            }
            for arc in g.succ(v) {
                if arc.prob >= 1.0 {
                    sc.relax(arc.to, d + arc.tmax);
                }
            }
        }
        self.silent_cache.insert(s, found);
        found
    }

    /// FSPI over a scope: single-fault candidates among the failure modes with `fm_in(f)`,
    /// judged on the ringing alarms with `alarm_in(a)` (the seed: the alarms ringing "within
    /// that process and its subprocesses"); minimal multiple-fault hypotheses when no single
    /// failure mode explains them. Recomputed from the stored per-alarm searches; the partial
    /// ones among the scope's alarms are completed first (one search each, once).
    pub fn verdict(
        &mut self,
        fm_in: &dyn Fn(FmId) -> bool,
        alarm_in: &dyn Fn(AlarmId) -> bool,
    ) -> Verdict {
        self.complete_where(alarm_in);
        let rs: Vec<usize> = (0..self.ringing.len())
            .filter(|&i| alarm_in(self.ringing[i].alarm))
            .collect();
        if rs.is_empty() {
            return Verdict::default();
        }
        let first = &self.ringing[rs[0]];
        let mut single: Vec<Candidate> = first
            .explain
            .iter()
            .filter(|(f, _)| fm_in(**f))
            .map(|(&fm, &(dmin, dmax))| Candidate {
                fm,
                t0: (first.time - dmax, first.time - dmin),
            })
            .collect();
        for &i in &rs[1..] {
            let r = &self.ringing[i];
            single.retain_mut(|c| match r.explain.get(&c.fm) {
                Some(&(dmin, dmax)) => {
                    c.t0 = (c.t0.0.max(r.time - dmax), c.t0.1.min(r.time - dmin));
                    c.t0.0 <= c.t0.1 + EPS
                }
                None => false,
            });
        }
        single.retain(|c| self.consistent(c.fm, c.t0.1));
        single.sort_by_key(|c| c.fm);
        let multiple = if single.is_empty() {
            self.multiple(&rs, fm_in)
        } else {
            Vec::new()
        };
        Verdict {
            single,
            multiple,
            alarms: rs.len(),
        }
    }

    /// The whole-model verdict (the incremental candidates, or the multiple-fault search).
    pub fn global_verdict(&mut self) -> Verdict {
        if !self.single.is_empty() || self.ringing.is_empty() {
            return Verdict {
                single: self.single.clone(),
                multiple: Vec::new(),
                alarms: self.ringing.len(),
            };
        }
        self.verdict(&|_| true, &|_| true)
    }

    /// Minimal hitting sets of explanations by iterative deepening (2 ..= max_faults members).
    fn multiple(&mut self, rs: &[usize], fm_in: &dyn Fn(FmId) -> bool) -> Vec<Vec<FmId>> {
        const MAX_HYPOTHESES: usize = 64;
        const MAX_NODES: usize = 200_000;
        let ring: Vec<Explained> = rs
            .iter()
            .map(|&i| {
                let r = &self.ringing[i];
                let mut e: Vec<(FmId, f64, f64)> = r
                    .explain
                    .iter()
                    .filter(|(f, _)| fm_in(**f))
                    .map(|(&f, &(a, b))| (f, a, b))
                    .collect();
                e.sort_by_key(|x| x.0);
                (r.time, e)
            })
            .collect();
        struct Search<'a> {
            ring: &'a [Explained],
            k: usize,
            found: Vec<Vec<(FmId, f64, f64)>>,
            nodes: usize,
        }
        fn dfs(s: &mut Search<'_>, i: usize, members: &mut Vec<(FmId, f64, f64)>) {
            s.nodes += 1;
            if s.found.len() >= MAX_HYPOTHESES || s.nodes > MAX_NODES {
                return;
            }
            if i == s.ring.len() {
                s.found.push(members.clone());
                return;
            }
            let (t, ref ex) = s.ring[i];
            // First fit: an existing member explains alarm i within its fault-time interval.
            for m in 0..members.len() {
                let (f, lo, hi) = members[m];
                if let Ok(j) = ex.binary_search_by_key(&f, |x| x.0) {
                    let (_, dmin, dmax) = ex[j];
                    let (nlo, nhi) = (lo.max(t - dmax), hi.min(t - dmin));
                    if nlo <= nhi + EPS {
                        let saved = members[m];
                        members[m] = (f, nlo, nhi);
                        dfs(s, i + 1, members);
                        members[m] = saved;
                        return;
                    }
                }
            }
            if members.len() == s.k {
                return;
            }
            for &(f, dmin, dmax) in ex {
                if members.iter().any(|m| m.0 == f) {
                    continue;
                }
                members.push((f, t - dmax, t - dmin));
                dfs(s, i + 1, members);
                members.pop();
            }
        }
        for k in 2..=self.max_faults.max(2) {
            let mut s = Search {
                ring: &ring,
                k,
                found: Vec::new(),
                nodes: 0,
            };
            dfs(&mut s, 0, &mut Vec::new());
            let mut out: Vec<Vec<FmId>> = Vec::new();
            for h in s.found {
                if h.iter().all(|&(f, _, hi)| self.consistent(f, hi)) {
                    let mut set: Vec<FmId> = h.iter().map(|x| x.0).collect();
                    set.sort_unstable();
                    if !out.contains(&set) {
                        out.push(set);
                    }
                }
            }
            if !out.is_empty() {
                out.sort();
                return out;
            }
        }
        Vec::new()
    }
}
