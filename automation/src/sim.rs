//! The real-time alarm pattern simulator (seed §4.3, "Research Plan", step 2) and the alarm
//! sequence text format.
//!
//! Semantics of a fault propagation edge `u → v (p, [tmin, tmax])`: when `u` becomes active,
//! the edge fires with probability `p` (or always, when probabilities are not sampled), and
//! then `v` becomes active after a delay drawn uniformly from `[tmin, tmax]` — unless it is
//! already active earlier. An alarm rings when the first failure mode it detects becomes active
//! (alarm generators are taken as instantaneous). All sampling comes from one seeded ChaCha8
//! stream, so a scenario is reproducible.
//!
//! Entry points: [`simulate`], [`filter`], [`write_alarms`] / [`parse_alarms`].

use crate::diag::FaultGraph;
use crate::model::{AlarmId, FmId, Model};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// How to simulate.
#[derive(Debug, Clone, Copy)]
pub struct SimOptions {
    /// Seed of the random stream.
    pub seed: u64,
    /// Sample each edge's probability (false: every edge fires — the seed's "complete alarm
    /// sequence").
    pub sample_probabilities: bool,
    /// Activations later than this many seconds after the first fault are not simulated.
    pub window: f64,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            seed: 1,
            sample_probabilities: false,
            window: 6.0 * 3600.0,
        }
    }
}

/// One alarm of a sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlarmEvent {
    /// Seconds.
    pub time: f64,
    pub alarm: AlarmId,
}

/// What a simulated scenario produced.
#[derive(Debug, Clone)]
pub struct SimResult {
    /// Activation time of each failure mode (None: never active within the window).
    pub activation: Vec<Option<f64>>,
    /// The complete alarm sequence, sorted by time (then alarm index).
    pub alarms: Vec<AlarmEvent>,
}

#[derive(PartialEq)]
struct Ev(f64, FmId);
impl Eq for Ev {}
impl Ord for Ev {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}
impl PartialOrd for Ev {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// Injects `faults` (failure mode, injection time in seconds) and propagates them.
pub fn simulate(g: &FaultGraph, faults: &[(FmId, f64)], opts: &SimOptions) -> SimResult {
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let n = g.len();
    let mut act: Vec<Option<f64>> = vec![None; n];
    let mut best = vec![f64::INFINITY; n];
    let mut heap = BinaryHeap::new();
    let t_first = faults.iter().map(|f| f.1).fold(f64::INFINITY, f64::min);
    let limit = t_first + opts.window;
    for &(f, t) in faults {
        if f < n && t < best[f] {
            best[f] = t;
            heap.push(Ev(t, f));
        }
    }
    while let Some(Ev(t, u)) = heap.pop() {
        if act[u].is_some() || t > best[u] {
            continue;
        }
        act[u] = Some(t);
        for arc in g.succ(u) {
            let fires =
                !opts.sample_probabilities || arc.prob >= 1.0 || rng.random::<f64>() < arc.prob;
            if !fires {
                continue;
            }
            let delay = if arc.tmax > arc.tmin {
                rng.random_range(arc.tmin..=arc.tmax)
            } else {
                arc.tmin
            };
            let tv = t + delay;
            if tv <= limit && act[arc.to].is_none() && tv < best[arc.to] {
                best[arc.to] = tv;
                heap.push(Ev(tv, arc.to));
            }
        }
    }
    let mut alarms: Vec<AlarmEvent> = g
        .alarm_fms
        .iter()
        .enumerate()
        .filter_map(|(a, fms)| {
            fms.iter()
                .filter_map(|&f| act[f])
                .min_by(f64::total_cmp)
                .map(|time| AlarmEvent { time, alarm: a })
        })
        .collect();
    alarms.sort_by(|x, y| x.time.total_cmp(&y.time).then(x.alarm.cmp(&y.alarm)));
    SimResult {
        activation: act,
        alarms,
    }
}

/// A sensor allocation as a filter: keeps the alarms with `present[a]`.
pub fn filter(alarms: &[AlarmEvent], present: &[bool]) -> Vec<AlarmEvent> {
    alarms
        .iter()
        .copied()
        .filter(|e| present.get(e.alarm).copied().unwrap_or(false))
        .collect()
}

/// Writes an alarm sequence as text: one `TIME ALARM` line per alarm (seconds, alarm name).
pub fn write_alarms(m: &Model, alarms: &[AlarmEvent]) -> String {
    let mut s = String::from("# time_s alarm\n");
    for e in alarms {
        s.push_str(&format!("{} {}\n", e.time, m.alarms[e.alarm].name));
    }
    s
}

/// Reads an alarm sequence (`TIME ALARM` per line, `#` comments). Errors name `file:line:col`.
pub fn parse_alarms(m: &Model, text: &str, file: &str) -> Result<Vec<AlarmEvent>, String> {
    let mut out: Vec<AlarmEvent> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        let Some(t) = words.next() else { continue };
        let col = |w: &str| raw.find(w).map_or(1, |c| c + 1);
        let time: f64 = t.parse().map_err(|_| {
            format!(
                "{file}:{}:{}: `{t}` is not a time in seconds",
                i + 1,
                col(t)
            )
        })?;
        if !time.is_finite() {
            return Err(format!(
                "{file}:{}:{}: time `{t}` is not finite",
                i + 1,
                col(t)
            ));
        }
        let name = words.next().ok_or_else(|| {
            format!(
                "{file}:{}:{}: missing alarm name after the time",
                i + 1,
                raw.len() + 1
            )
        })?;
        let alarm = m
            .find_alarm(name)
            .map_err(|e| format!("{file}:{}:{}: {e}", i + 1, col(name)))?;
        if let Some(extra) = words.next() {
            return Err(format!(
                "{file}:{}:{}: unexpected `{extra}` (one alarm per line)",
                i + 1,
                col(extra)
            ));
        }
        if let Some(prev) = out.last()
            && time < prev.time
        {
            return Err(format!(
                "{file}:{}:{}: alarms must be in time order ({time} < {})",
                i + 1,
                col(t),
                prev.time
            ));
        }
        out.push(AlarmEvent { time, alarm });
    }
    Ok(out)
}
