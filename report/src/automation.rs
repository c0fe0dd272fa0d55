//! Random hierarchical fault models and the diagnosis benchmarks behind `robosim report diag`.
//!
//! * [`generate`] — a random, consistent hierarchical process/fault model of about `n` failure
//!   modes (a tree of processes of branching 2–4; leaves hold 6–24 failure modes with local
//!   propagation, inner processes hold 3 interface failure modes fed by their children;
//!   sibling edges run along declared signal connections; a chosen share of failure modes has
//!   an alarm).
//! * [`report_diag`] — writes three reports into a directory: `diag_update_time` (diagnosis
//!   update time per alarm against model size, with a from-scratch re-diagnosis measured in
//!   the same run as the baseline), `diag_eclss_resolution` (the ECLSS resolution table as
//!   alarms are filtered away) and `diag_advisor` (greedy sensor advice against exhaustive
//!   search on small models).

use crate::plot::RunError;
use crate::plot::{Plot, Report, Series, Table, percentile, write_report};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_automation::analysis::{Resolution, advise_exhaustive, advise_greedy, evaluate};
use robosim_automation::diag::{Diagnoser, FaultGraph};
use robosim_automation::model::{
    Alarm, Component, Connection, Edge, FailureMode, Model, Process, SignalRef, Span, load_model,
};
use robosim_automation::sim::{SimOptions, simulate};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Parameters of [`generate`].
#[derive(Debug, Clone, Copy)]
pub struct GenOptions {
    /// Target number of failure modes (the result is within a few of it).
    pub failure_modes: usize,
    /// Share of failure modes with an alarm, in [0, 1].
    pub alarm_density: f64,
    pub seed: u64,
}

struct Gen {
    m: Model,
    rng: ChaCha8Rng,
    density: f64,
}

impl Gen {
    fn fm(&mut self, p: usize, derived: bool) -> usize {
        let id = self.m.failure_modes.len();
        let name = format!("f{id}");
        let mut components = Vec::new();
        if !derived {
            components.push(self.m.components.len());
            self.m.components.push(Component {
                name: format!("c{id}"),
                span: Span::default(),
            });
        }
        self.m.failure_modes.push(FailureMode {
            path: format!("{}.{name}", self.m.processes[p].path),
            name,
            process: p,
            derived,
            components,
            alarms: Vec::new(),
            span: Span::default(),
        });
        self.m.processes[p].failure_modes.push(id);
        if self.rng.random::<f64>() < self.density {
            let a = self.m.alarms.len();
            self.m.alarms.push(Alarm {
                name: format!("A{id}"),
                process: p,
                detects: vec![id],
                generator: None,
                span: Span::default(),
            });
            self.m.failure_modes[id].alarms.push(a);
            self.m.processes[p].alarms.push(a);
        }
        id
    }

    fn edge(&mut self, from: usize, to: usize, owner: usize) {
        let prob = if self.rng.random::<f64>() < 0.5 {
            1.0
        } else {
            self.rng.random_range(0.5..1.0)
        };
        let tmin = self.rng.random_range(1.0..10.0);
        let tmax = tmin + self.rng.random_range(0.0..20.0);
        self.m.edges.push(Edge {
            from,
            to,
            prob,
            tmin,
            tmax,
            assumed: true,
            owner,
            span: Span::default(),
        });
    }

    fn process(&mut self, parent: Option<usize>, budget: usize) -> usize {
        let id = self.m.processes.len();
        let (path, depth) = match parent {
            Some(q) => (
                format!("{}.p{id}", self.m.processes[q].path),
                self.m.processes[q].depth + 1,
            ),
            None => ("R".to_string(), 0),
        };
        self.m.processes.push(Process {
            name: if parent.is_some() {
                format!("p{id}")
            } else {
                "R".into()
            },
            path,
            parent,
            children: Vec::new(),
            depth,
            inputs: vec!["i".into()],
            outputs: vec!["o".into()],
            failure_modes: Vec::new(),
            alarms: Vec::new(),
            span: Span::default(),
        });
        if budget <= 24 {
            // Leaf: sources first, then derived modes each fed by 1–2 earlier modes (and a few
            // slower back edges, so cycles exist, never of zero time).
            let n = budget.max(2);
            let ns = (n / 2).max(1);
            let fms: Vec<usize> = (0..n).map(|k| self.fm(id, k >= ns)).collect();
            for k in ns..n {
                for _ in 0..self.rng.random_range(1..=2) {
                    let from = fms[self.rng.random_range(0..k)];
                    self.edge(from, fms[k], id);
                }
            }
            if n > ns + 1 && self.rng.random::<f64>() < 0.3 {
                let (a, b) = (fms[n - 1], fms[ns]);
                self.edge(a, b, id);
            }
            return id;
        }
        let own: Vec<usize> = (0..3).map(|_| self.fm(id, true)).collect();
        // Branching 2..4, so that leaves end up with 6..24 failure modes at every model size.
        let nk = (((budget - 3) as f64 / 16.0).round() as usize).clamp(2, 4);
        let per_child = (budget - 3) / nk;
        let mut kids = Vec::new();
        for k in 0..nk {
            let b = if k == nk - 1 {
                budget - 3 - (nk - 1) * per_child
            } else {
                per_child
            };
            let c = self.process(Some(id), b);
            self.m.processes[id].children.push(c);
            kids.push(c);
        }
        // Signals: parent input -> first child, a chain of siblings, last child -> parent output.
        let sref = |p: usize, s: &str| SignalRef {
            process: p,
            signal: s.to_string(),
        };
        self.m.connections.push(Connection {
            owner: id,
            from: sref(id, "i"),
            to: sref(kids[0], "i"),
            span: Span::default(),
        });
        for w in kids.windows(2) {
            self.m.connections.push(Connection {
                owner: id,
                from: sref(w[0], "o"),
                to: sref(w[1], "i"),
                span: Span::default(),
            });
        }
        self.m.connections.push(Connection {
            owner: id,
            from: sref(kids[nk - 1], "o"),
            to: sref(id, "o"),
            span: Span::default(),
        });
        // The visible failure modes of a child: its own (interface) ones.
        let visible = |g: &Gen, c: usize| g.m.processes[c].failure_modes.clone();
        for w in kids.windows(2).flat_map(|w| [w, w]) {
            let (a, b) = (visible(self, w[0]), visible(self, w[1]));
            let derived_b: Vec<usize> = b
                .iter()
                .copied()
                .filter(|&f| self.m.failure_modes[f].derived)
                .collect();
            let target = if derived_b.is_empty() { &b } else { &derived_b };
            let from = a[self.rng.random_range(0..a.len())];
            let to = target[self.rng.random_range(0..target.len())];
            self.edge(from, to, id);
        }
        for &o in &own {
            for _ in 0..2 {
                let c = kids[self.rng.random_range(0..nk)];
                let v = visible(self, c);
                let from = v[self.rng.random_range(0..v.len())];
                self.edge(from, o, id);
            }
        }
        // Parent interface modes feed children (input disturbances travel down again).
        for &o in &own {
            let k = self.rng.random_range(0..nk);
            let v = visible(self, kids[k]);
            let to = v[self.rng.random_range(0..v.len())];
            self.edge(o, to, id);
        }
        id
    }
}

/// A random hierarchical process/fault model (see the module docs). Deterministic per seed;
/// passes `robosim_automation::model::check::check_model` without errors.
pub fn generate(opts: &GenOptions) -> Model {
    let mut g = Gen {
        m: Model {
            source: format!("<random n={} seed={}>", opts.failure_modes, opts.seed),
            processes: Vec::new(),
            connections: Vec::new(),
            failure_modes: Vec::new(),
            alarms: Vec::new(),
            edges: Vec::new(),
            components: Vec::new(),
        },
        rng: ChaCha8Rng::seed_from_u64(opts.seed),
        density: opts.alarm_density.clamp(0.0, 1.0),
    };
    g.process(None, opts.failure_modes.max(2));
    g.m
}

/// One row of the update-time curve.
#[derive(Debug, Clone)]
pub struct UpdateTimeRow {
    pub alarm_density: f64,
    pub failure_modes: usize,
    pub processes: usize,
    pub edges: usize,
    pub alarms: usize,
    /// Faults injected.
    pub faults: usize,
    /// Alarm updates timed.
    pub updates: usize,
    /// Incremental update time per alarm, microseconds: median, 95th percentile, max.
    pub median_us: f64,
    pub p95_us: f64,
    pub max_us: f64,
    /// Incremental update time over the first 32 alarms of each sequence, median µs.
    pub paired_median_us: f64,
    /// Re-diagnosing all alarms so far from scratch at each of the first 32 alarms of each
    /// sequence (the baseline), median µs.
    pub scratch_median_us: f64,
    /// Mean final ambiguity-group size.
    pub mean_group: f64,
}

/// Measures diagnosis update time per alarm for a model of `n` failure modes: `trials` random
/// single faults (alarms on a share `alarm_density` of the failure modes), sampled
/// propagation, each alarm fed to the incremental diagnoser and timed; the same alarm prefix
/// re-diagnosed from scratch is the baseline.
pub fn measure_update_time(
    n: usize,
    alarm_density: f64,
    trials: usize,
    seed: u64,
) -> UpdateTimeRow {
    let m = generate(&GenOptions {
        failure_modes: n,
        alarm_density,
        seed,
    });
    let g = FaultGraph::new(&m);
    let sources = m.source_failure_modes();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xd1a9);
    let mut times = Vec::new();
    let mut scratch = Vec::new();
    let mut paired = Vec::new();
    let mut groups = Vec::new();
    // At least `trials` faults, and more until 200 alarm updates were timed (sparse alarms
    // give short sequences), at most 20 × trials faults.
    let mut t = 0;
    while t < trials || (times.len() < 200 && t < 20 * trials) {
        t += 1;
        let f = sources[rng.random_range(0..sources.len())];
        let sim = simulate(
            &g,
            &[(f, 0.0)],
            &SimOptions {
                seed: seed + t as u64,
                sample_probabilities: true,
                window: 1e9,
            },
        );
        let mut d = Diagnoser::new(&g, None);
        for (k, e) in sim.alarms.iter().enumerate() {
            let t0 = Instant::now();
            // Simulated alarms are allocated and in order: never refused.
            let _ = d.add_alarm(e.alarm, e.time);
            let dt = t0.elapsed().as_secs_f64() * 1e6;
            times.push(dt);
            if k < 32 {
                paired.push(dt);
                let t1 = Instant::now();
                let mut fresh = Diagnoser::new(&g, None);
                for p in &sim.alarms[..=k] {
                    let _ = fresh.add_alarm(p.alarm, p.time);
                }
                scratch.push(t1.elapsed().as_secs_f64() * 1e6);
            }
        }
        if !sim.alarms.is_empty() {
            groups.push(d.global_verdict().failure_modes().len() as f64);
        }
    }
    let mean_group = if groups.is_empty() {
        0.0
    } else {
        groups.iter().sum::<f64>() / groups.len() as f64
    };
    let updates = times.len();
    let (median_us, p95_us, max_us) = if times.is_empty() {
        (0.0, 0.0, 0.0)
    } else {
        (
            percentile(&mut times, 50.0),
            percentile(&mut times, 95.0),
            percentile(&mut times, 100.0),
        )
    };
    UpdateTimeRow {
        alarm_density,
        failure_modes: m.failure_modes.len(),
        processes: m.processes.len(),
        edges: m.edges.len(),
        alarms: m.alarms.len(),
        faults: t,
        updates,
        median_us,
        p95_us,
        max_us,
        paired_median_us: if paired.is_empty() {
            0.0
        } else {
            percentile(&mut paired, 50.0)
        },
        scratch_median_us: if scratch.is_empty() {
            0.0
        } else {
            percentile(&mut scratch, 50.0)
        },
        mean_group,
    }
}

fn fmt(x: f64) -> String {
    if x.abs() >= 100.0 {
        format!("{x:.0}")
    } else {
        format!("{x:.2}")
    }
}

/// A named sensor allocation with its resolution.
pub struct AllocationRow {
    pub label: String,
    pub resolution: Resolution,
}

/// The ECLSS resolution table: all alarms; greedy allocations for shrinking budgets; random
/// allocations of the same sizes (mean of `random_draws`); symptom-only and source-only alarms.
pub fn eclss_resolution(
    budgets: &[usize],
    trials: usize,
    random_draws: usize,
) -> Result<Vec<AllocationRow>, RunError> {
    let m = load_model("eclss")?;
    let g = FaultGraph::new(&m);
    let na = m.alarms.len();
    let opts = SimOptions {
        seed: 11,
        sample_probabilities: true,
        ..SimOptions::default()
    };
    let mut rows = Vec::new();
    let mut push = |label: String, present: &[bool]| {
        rows.push(AllocationRow {
            label,
            resolution: evaluate(&m, &g, present, &opts, trials),
        });
    };
    push(format!("all {na} alarms"), &vec![true; na]);
    let max_b = budgets.iter().copied().max().unwrap_or(0).min(na);
    let order = advise_greedy(&m, &g, max_b, &opts, trials);
    for &b in budgets {
        let mut p = vec![false; na];
        for &(a, _) in order.iter().take(b) {
            p[a] = true;
        }
        push(format!("greedy {b}"), &p);
    }
    let symptoms: Vec<bool> = m
        .alarms
        .iter()
        .map(|a| a.detects.iter().all(|&f| m.failure_modes[f].derived))
        .collect();
    let n_sym = symptoms.iter().filter(|&&x| x).count();
    push(format!("symptoms only ({n_sym})"), &symptoms);
    let sources: Vec<bool> = symptoms.iter().map(|x| !x).collect();
    push(format!("sources only ({})", na - n_sym), &sources);
    // Random allocations: one row per budget holding the averages over the draws (the worst
    // group size over all draws).
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for &b in budgets {
        let mut acc: Option<Resolution> = None;
        let mut sum = (0.0, 0.0, 0.0, 0.0, 0usize);
        let mut detected = 0.0;
        let mut tti_n = 0;
        for _ in 0..random_draws.max(1) {
            let mut idx: Vec<usize> = (0..na).collect();
            idx.shuffle(&mut rng);
            let mut p = vec![false; na];
            for &a in idx.iter().take(b) {
                p[a] = true;
            }
            let r = evaluate(&m, &g, &p, &opts, trials);
            sum.0 += r.isolated as f64;
            detected += r.detected as f64;
            sum.1 += r.correct as f64;
            sum.2 += r.mean_group;
            if let Some(t) = r.mean_time_to_isolation {
                sum.3 += t;
                tti_n += 1;
            }
            sum.4 = sum.4.max(r.max_group);
            acc = Some(r);
        }
        if let Some(mut r) = acc {
            let k = random_draws.max(1) as f64;
            r.isolated = (sum.0 / k).round() as usize;
            r.detected = (detected / k).round() as usize;
            r.correct = (sum.1 / k).round() as usize;
            r.mean_group = sum.2 / k;
            r.max_group = sum.4;
            r.mean_time_to_isolation = if tti_n > 0 {
                Some(sum.3 / tti_n as f64)
            } else {
                None
            };
            rows.push(AllocationRow {
                label: format!("random {b} (mean of {})", random_draws.max(1)),
                resolution: r,
            });
        }
    }
    Ok(rows)
}

/// Greedy against exhaustive sensor advice on small random models: (model seed, alarms,
/// budget, greedy cost, optimal cost).
pub fn advisor_gap(
    models: usize,
    n_fm: usize,
    max_budget: usize,
) -> Vec<(u64, usize, usize, f64, f64)> {
    let mut out = Vec::new();
    for s in 0..models as u64 {
        let m = generate(&GenOptions {
            failure_modes: n_fm,
            alarm_density: 0.5,
            seed: 100 + s,
        });
        let g = FaultGraph::new(&m);
        let opts = SimOptions::default();
        let greedy = advise_greedy(&m, &g, max_budget, &opts, 1);
        for (k, &(_, gc)) in greedy.iter().enumerate() {
            let (_, oc) = advise_exhaustive(&m, &g, k + 1, &opts);
            out.push((100 + s, m.alarms.len(), k + 1, gc, oc));
        }
    }
    out
}

/// Writes the diagnosis reports (see the module docs) into `out_dir`; `quick` limits the
/// model sizes to 10,000 failure modes and the trial counts. Returns the files written.
pub fn report_diag(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, RunError> {
    let mut written = Vec::new();
    written.extend(write_report(out_dir, &update_time_report(quick))?);
    written.extend(write_report(out_dir, &eclss_resolution_report(quick)?)?);
    written.extend(write_report(out_dir, &advisor_report(quick))?);
    Ok(written)
}

/// `diag_update_time`: the incremental diagnoser's time per alarm against model size, with
/// re-diagnosing from scratch as the baseline measured in the same run.
fn update_time_report(quick: bool) -> Report {
    let sizes: &[usize] = if quick {
        &[100, 300, 1000, 3000, 10_000]
    } else {
        &[100, 300, 1000, 3000, 10_000, 30_000, 100_000]
    };
    let trials = if quick { 10 } else { 40 };
    let densities = [0.5, 0.1];
    let rows: Vec<UpdateTimeRow> = densities
        .iter()
        .flat_map(|&d| {
            sizes
                .iter()
                .map(move |&n| measure_update_time(n, d, trials, 42))
        })
        .collect();
    let table = Table {
        columns: [
            "alarm_density",
            "failure_modes",
            "processes",
            "edges",
            "alarms",
            "faults",
            "updates_timed",
            "median_us",
            "p95_us",
            "max_us",
            "from_scratch_median_us",
            "from_scratch_over_incremental",
            "mean_final_group",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
        rows: rows
            .iter()
            .map(|r| {
                vec![
                    format!("{:.1}", r.alarm_density),
                    r.failure_modes.to_string(),
                    r.processes.to_string(),
                    r.edges.to_string(),
                    r.alarms.to_string(),
                    r.faults.to_string(),
                    r.updates.to_string(),
                    fmt(r.median_us),
                    fmt(r.p95_us),
                    fmt(r.max_us),
                    fmt(r.scratch_median_us),
                    fmt(r.scratch_median_us / r.paired_median_us.max(1e-9)),
                    fmt(r.mean_group),
                ]
            })
            .collect(),
    };
    let series = |label: &str, density: f64, f: &dyn Fn(&UpdateTimeRow) -> f64| Series {
        label: format!("{label}, alarms on {:.0}%", density * 100.0),
        points: rows
            .iter()
            .filter(|r| r.alarm_density == density)
            .map(|r| (r.failure_modes as f64, f(r).max(1e-3)))
            .collect(),
    };
    Report {
        name: "diag_update_time".into(),
        title: "Diagnosis update time per alarm against model size".into(),
        notes: vec![
            format!(
                "Random hierarchical fault models (robosim_report::automation::generate, seed 42, branching 2-4, leaves of 6-24 failure modes, alarms on 50% or on 10% of the failure modes); at least {trials} random single faults per size and more until 200 alarm updates are timed, propagation probabilities sampled; every alarm of each sequence fed to the incremental FSPI diagnoser and timed (add_alarm: reverse search, candidate update, consistency check)."
            ),
            "Baseline measured in the same run: re-diagnosing the alarm prefix from scratch at each of the first 32 alarms of each sequence; the ratio column is from-scratch / incremental, medians over those same alarms. The max column catches scheduler preemption on this shared 2-core machine (isolated spikes of about 10 ms at any model size); the 95th percentile is the figure to read. The machine is shared and noisy: read the ratios and the shape of the curve, not the absolute microseconds.".into(),
            "Target from the issue: under 1 ms per alarm at 10,000 failure modes. We know of no published curve for TFPG reasoners to compare with.".into(),
        ],
        table,
        plots: vec![Plot {
            title: "update time per alarm".into(),
            x_label: "failure modes".into(),
            y_label: "microseconds".into(),
            log_x: true,
            log_y: true,
            series: densities
                .iter()
                .flat_map(|&d| {
                    [
                        series("incremental median", d, &|r| r.median_us),
                        series("incremental p95", d, &|r| r.p95_us),
                        series("from-scratch median", d, &|r| r.scratch_median_us),
                    ]
                })
                .collect(),
        }],
    }
}

/// `diag_eclss_resolution`: the ECLSS model's isolation rate as alarms are filtered away
/// (greedy, random, symptom-only and source-only allocations).
fn eclss_resolution_report(quick: bool) -> Result<Report, RunError> {
    let budgets: &[usize] = &[40, 30, 20, 15, 10, 5];
    let res = eclss_resolution(
        budgets,
        if quick { 2 } else { 5 },
        if quick { 3 } else { 10 },
    )?;
    let table = Table {
        columns: [
            "allocation",
            "alarms",
            "faults",
            "detected",
            "isolated",
            "correct",
            "isolation_rate",
            "mean_group",
            "max_group",
            "mean_time_to_isolation_s",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
        rows: res
            .iter()
            .map(|r| {
                let s = &r.resolution;
                vec![
                    r.label.clone(),
                    s.alarms_kept.to_string(),
                    s.faults.to_string(),
                    s.detected.to_string(),
                    s.isolated.to_string(),
                    s.correct.to_string(),
                    format!("{:.2}", s.isolation_rate()),
                    format!("{:.2}", s.mean_group),
                    s.max_group.to_string(),
                    s.mean_time_to_isolation
                        .map_or("-".into(), |t| format!("{t:.0}")),
                ]
            })
            .collect(),
    };
    let curve = |prefix: &str| Series {
        label: prefix.to_string(),
        points: res
            .iter()
            .filter(|r| r.label.starts_with(prefix) || r.label.starts_with("all"))
            .map(|r| {
                (
                    r.resolution.alarms_kept as f64,
                    r.resolution.isolation_rate(),
                )
            })
            .collect(),
    };
    Ok(Report {
        name: "diag_eclss_resolution".into(),
        title: "ECLSS diagnosability: resolution as alarms are filtered away".into(),
        notes: vec![
            "Every single fault of the shipped ECLSS model injected (seed §4.3, testing of diagnosability), its alarm sequence simulated with sampled propagation probabilities and times (all edge numbers are the model's assumptions), filtered by the sensor allocation and diagnosed by incremental FSPI; judged 6 h after the fault.".into(),
            "Greedy allocations come from the advisor (automation::analysis::advise_greedy: keep the alarm that lowers the expected ambiguity-group size most); random rows average random allocations of the same size; 'symptoms only' keeps alarms on derived failure modes, 'sources only' those on originating ones.".into(),
        ],
        table,
        plots: vec![Plot {
            title: "isolation rate against alarms kept".into(),
            x_label: "alarms kept".into(),
            y_label: "isolation rate".into(),
            log_x: false,
            log_y: false,
            series: vec![curve("greedy"), curve("random")],
        }],
    })
}

/// `diag_advisor`: the greedy sensor advisor against exhaustive search on small random models.
fn advisor_report(quick: bool) -> Report {
    let gap = advisor_gap(if quick { 2 } else { 6 }, 32, if quick { 4 } else { 6 });
    let worst = gap.iter().map(|g| g.3 / g.4.max(1e-12)).fold(1.0, f64::max);
    let optimal = gap.iter().filter(|g| (g.3 - g.4).abs() < 1e-9).count();
    let table = Table {
        columns: [
            "model_seed",
            "alarms",
            "budget",
            "greedy_cost",
            "optimal_cost",
            "greedy_over_optimal",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
        rows: gap
            .iter()
            .map(|g| {
                vec![
                    g.0.to_string(),
                    g.1.to_string(),
                    g.2.to_string(),
                    format!("{:.3}", g.3),
                    format!("{:.3}", g.4),
                    format!("{:.3}", g.3 / g.4.max(1e-12)),
                ]
            })
            .collect(),
    };
    Report {
        name: "diag_advisor".into(),
        title: "Sensor advisor: greedy against exhaustive search".into(),
        notes: vec![
            "Cost = expected ambiguity-group size over all single faults (an undetected or misdiagnosed fault counts as the whole fault set), every edge firing, one trial per fault. Small random models (about 32 failure modes in a root and two subprocesses, alarms on half of them) where every subset of the alarms can be tried.".into(),
            format!("Greedy found the optimum in {optimal} of {} cases; worst greedy/optimal ratio {worst:.3}.", gap.len()),
        ],
        table,
        plots: Vec::new(),
    }
}
