//! `robosim diag check|simulate|run|analyze` over the automation crate (the binary wires
//! [`DiagCmd`]). MODEL is a model file or a shipped name (`eclss`).
//!
//! Entry points: [`run`] (prints to stdout) and [`execute`] (returns the text; what the tests
//! drive).

use super::CommandError;
use robosim_automation::analysis::{advise_greedy, evaluate};
use robosim_automation::diag::{FaultGraph, Ilm};
use robosim_automation::model::check::{Severity, check_model};
use robosim_automation::model::{Model, load_model};
use robosim_automation::sim::{SimOptions, filter, parse_alarms, simulate, write_alarms};
use std::fmt::Write as _;
use std::path::PathBuf;

/// `robosim diag …`
#[derive(Debug, Clone)]
pub enum DiagCmd {
    /// Load a hierarchical process/fault model and run its consistency checks.
    Check {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// Also write the process/fault model as Graphviz DOT to this file.
        dot: Option<PathBuf>,
    },
    /// Inject faults and print the timed alarm sequence (the format `diag run` reads).
    Simulate {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// Failure mode to inject, as NAME or NAME@SECONDS (repeat for multiple faults).
        faults: Vec<String>,
        /// Seed of the propagation-time (and probability) sampling.
        seed: u64,
        /// Sample edge probabilities (default: every edge fires, the complete alarm sequence).
        sample: bool,
        /// Alarms the sensor allocation lacks (filtered out), by name.
        drop: Vec<String>,
    },
    /// Diagnose an alarm sequence file (lines `SECONDS ALARM`) with FSPI, FSCI and ILM.
    Run {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// The alarm sequence: lines `SECONDS ALARM` (what `diag simulate` prints).
        alarms: PathBuf,
        /// Judge the diagnosis at this time (seconds; default: the last alarm).
        until: Option<f64>,
        /// Alarms not in the sensor allocation, by name (they count as absent, not normal).
        drop: Vec<String>,
    },
    /// Diagnosability: every single fault through simulator and diagnoser; resolution per
    /// sensor allocation; with --sensors N, the advisor's choice of N alarms.
    Analyze {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// Sensor budget: how many alarms to keep.
        sensors: Option<usize>,
        /// Simulated scenarios per fault (propagation sampled).
        trials: usize,
        /// Seed of the scenario sampling.
        seed: u64,
    },
}

/// Runs a command and prints its report to stdout.
pub fn run(cmd: DiagCmd) -> Result<(), CommandError> {
    let out = execute(cmd)?;
    print!("{out}");
    Ok(())
}

fn load(name: &str) -> Result<Model, CommandError> {
    Ok(load_model(name)?)
}

fn allocation(m: &Model, drop: &[String]) -> Result<Vec<bool>, CommandError> {
    let mut p = vec![true; m.alarms.len()];
    for d in drop {
        p[m.find_alarm(d)?] = false;
    }
    Ok(p)
}

/// Runs a command and returns its report (the last line of `analyze` is a one-line summary).
pub fn execute(cmd: DiagCmd) -> Result<String, CommandError> {
    match cmd {
        DiagCmd::Check { model, dot } => check(&model, dot.as_deref()),
        DiagCmd::Simulate {
            model,
            faults,
            seed,
            sample,
            drop,
        } => simulate_faults(&model, &faults, seed, sample, &drop),
        DiagCmd::Run {
            model,
            alarms,
            until,
            drop,
        } => diagnose(&model, &alarms, until, &drop),
        DiagCmd::Analyze {
            model,
            sensors,
            trials,
            seed,
        } => analyze(&model, sensors, trials, seed),
    }
}

/// `diag check`: the model's size and its consistency findings (optionally its DOT); refused
/// when a finding is an error.
fn check(model: &str, dot: Option<&std::path::Path>) -> Result<String, CommandError> {
    let mut o = String::new();
    let m = load(model)?;
    if let Some(path) = dot {
        robosim_input::write_file_atomic(path, m.to_dot().as_bytes())?;
    }
    let findings = check_model(&m);
    let _ = writeln!(
        o,
        "model {} ({}): {} processes (depth {}), {} failure modes ({} may originate), {} alarms, {} propagation edges ({} assumed), {} components, {} signal connections",
        m.processes[0].name,
        m.source,
        m.processes.len(),
        m.max_depth(),
        m.failure_modes.len(),
        m.source_failure_modes().len(),
        m.alarms.len(),
        m.edges.len(),
        m.edges.iter().filter(|e| e.assumed).count(),
        m.components.len(),
        m.connections.len()
    );
    for f in &findings {
        let _ = writeln!(o, "{}", f.render(&m.source));
    }
    let errors = findings
        .iter()
        .filter(|f| f.severity == Severity::Error)
        .count();
    if errors > 0 {
        return Err(CommandError::Refused(format!(
            "{o}{errors} error(s): the model is not consistent"
        )));
    }
    let _ = writeln!(o, "consistent ({} warning(s))", findings.len());
    Ok(o)
}

/// `diag simulate`: the alarm sequence the injected faults ring (a comment line, then the
/// alarms the sensor allocation keeps, in the format `diag run` reads).
fn simulate_faults(
    model: &str,
    faults: &[String],
    seed: u64,
    sample: bool,
    drop: &[String],
) -> Result<String, CommandError> {
    let mut o = String::new();
    let m = load(model)?;
    let g = FaultGraph::new(&m);
    let inj = injections(&m, faults)?;
    let present = allocation(&m, drop)?;
    let opts = SimOptions {
        seed,
        sample_probabilities: sample,
        ..SimOptions::default()
    };
    let sim = simulate(&g, &inj, &opts);
    let seen = filter(&sim.alarms, &present);
    let _ = writeln!(
        o,
        "# model {}; injected: {}; seed {seed}; {}; {} of {} alarms kept by the sensor allocation",
        m.source,
        inj.iter()
            .map(|(f, t)| format!("{}@{t}", m.failure_modes[*f].path))
            .collect::<Vec<_>>()
            .join(", "),
        if sample {
            "probabilities sampled"
        } else {
            "every edge fires"
        },
        seen.len(),
        sim.alarms.len()
    );
    o.push_str(&write_alarms(&m, &seen));
    Ok(o)
}

/// The `--fault NAME[@SECONDS]` arguments as (failure mode index, time in s).
fn injections(m: &Model, faults: &[String]) -> Result<Vec<(usize, f64)>, CommandError> {
    let mut inj = Vec::new();
    for f in faults {
        let (name, t) = match f.split_once('@') {
            Some((n, t)) => (
                n,
                t.parse::<f64>()
                    .map_err(|_| format!("--fault {f}: `{t}` is not a time in seconds"))?,
            ),
            None => (f.as_str(), 0.0),
        };
        if !t.is_finite() {
            return Err(CommandError::Refused(format!(
                "--fault {f}: time must be finite"
            )));
        }
        inj.push((m.find_failure_mode(name)?, t));
    }
    Ok(inj)
}

/// `diag run`: feeds the alarm file to the diagnoser one time stamp at a time (a line per
/// update: FSPI candidates, ILM's best guess), runs ILM to completion (from `until`, if
/// given), and writes its log and verdict.
fn diagnose(
    model: &str,
    alarms: &std::path::Path,
    until: Option<f64>,
    drop: &[String],
) -> Result<String, CommandError> {
    let mut o = String::new();
    let m = load(model)?;
    let g = FaultGraph::new(&m);
    let text = robosim_input::read_to_string(alarms, "an alarm file", robosim_input::Limit::TEXT)?;
    let events = parse_alarms(&m, &text, &alarms.display().to_string())?;
    let present = allocation(&m, drop)?;
    let mut ilm = Ilm::new(&m, &g, Some(&present));
    // Alarms with the same time stamp rang together: one update.
    let mut i = 0;
    while i < events.len() {
        let t = events[i].time;
        let mut batch = Vec::new();
        while i < events.len() && events[i].time == t {
            let e = events[i];
            if !present[e.alarm] {
                return Err(CommandError::Refused(format!(
                    "alarm {} is in the sequence but dropped from the allocation",
                    m.alarms[e.alarm].name
                )));
            }
            batch.push((e.alarm, e.time));
            i += 1;
        }
        ilm.on_alarms(&batch)?;
        ilm.step();
        write_update(&mut o, &m, &ilm, t, &batch);
    }
    if let Some(t) = until {
        ilm.advance_to(t);
    }
    ilm.run_to_completion();
    let _ = writeln!(o, "ILM:");
    for l in &ilm.log {
        let _ = writeln!(o, "  {l}");
    }
    write_verdict(&mut o, &m, &ilm);
    Ok(o)
}

/// One line of `diag run` after the alarms of time `t`: the alarms, FSPI's single-fault
/// candidates and ILM's best guess so far.
fn write_update(o: &mut String, m: &Model, ilm: &Ilm, t: f64, batch: &[(usize, f64)]) {
    let c = ilm.diagnoser().candidates();
    let guess = ilm.best_guess();
    let names: Vec<&str> = batch
        .iter()
        .map(|&(a, _)| m.alarms[a].name.as_str())
        .collect();
    let _ = writeln!(
        o,
        "t={:>8.1}  {:<24} FSPI: {} single-fault candidate(s){}",
        t,
        names.join(" "),
        c.len(),
        guess.map_or(String::new(), |g| format!(
            "; ILM depth {}: {}",
            g.depth,
            g.processes
                .iter()
                .map(|&p| m.processes[p].path.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    );
}

/// The end of `diag run`: no alarms, no hypothesis, or the diagnosis (its failure modes with
/// their components, the multiple-fault hypotheses, FSCI's components).
fn write_verdict(o: &mut String, m: &Model, ilm: &Ilm) {
    match ilm.best_guess() {
        None => {
            let _ = writeln!(o, "no alarms: nothing to diagnose");
        }
        Some(gs) if gs.failure_modes.is_empty() => {
            let _ = writeln!(
                o,
                "no hypothesis of up to 3 faults explains these alarms within the model (a sensor fault, or a fault the model lacks?)"
            );
        }
        Some(gs) => {
            let kind = if gs.multiple {
                "multiple fault"
            } else {
                "single fault"
            };
            let _ = writeln!(
                o,
                "diagnosis ({kind}, {} candidate failure mode(s)):",
                gs.failure_modes.len()
            );
            for &f in &gs.failure_modes {
                let fm = &m.failure_modes[f];
                let comps: Vec<&str> = fm
                    .components
                    .iter()
                    .map(|&c| m.components[c].name.as_str())
                    .collect();
                let _ = writeln!(o, "  {}  [{}]", fm.path, comps.join(", "));
            }
            if gs.multiple {
                let v = ilm.diagnoser().clone().global_verdict();
                for h in &v.multiple {
                    let names: Vec<&str> = h
                        .iter()
                        .map(|&f| m.failure_modes[f].path.as_str())
                        .collect();
                    let _ = writeln!(o, "  hypothesis: {{{}}}", names.join(", "));
                }
            }
            let comps: Vec<&str> = gs
                .components
                .iter()
                .map(|&c| m.components[c].name.as_str())
                .collect();
            let _ = writeln!(
                o,
                "FSCI components: {}",
                if comps.is_empty() {
                    "-".into()
                } else {
                    comps.join(", ")
                }
            );
        }
    }
}

/// `diag analyze`: the resolution of every single fault with all alarms, then with the
/// greedy advisor's choice at each sensor budget (`--sensors N`, else ¾, ½ and ¼ of the
/// alarms), the advice for N, and a one-line summary.
fn analyze(
    model: &str,
    sensors: Option<usize>,
    trials: usize,
    seed: u64,
) -> Result<String, CommandError> {
    let mut o = String::new();
    let m = load(model)?;
    let findings = check_model(&m);
    if findings.iter().any(|f| f.severity == Severity::Error) {
        return Err(CommandError::Refused(format!(
            "model {} is not consistent: run `diag check` first",
            m.source
        )));
    }
    let g = FaultGraph::new(&m);
    let na = m.alarms.len();
    let opts = SimOptions {
        seed,
        sample_probabilities: true,
        ..SimOptions::default()
    };
    let _ = writeln!(
        o,
        "{:<28} {:>6} {:>7} {:>9} {:>9} {:>10} {:>9} {:>12}",
        "allocation",
        "alarms",
        "faults",
        "detected",
        "isolated",
        "mean_group",
        "max_group",
        "mean_tti_s"
    );
    let all = evaluate(&m, &g, &vec![true; na], &opts, trials);
    write_resolution(&mut o, "all alarms", &all);
    let budgets = sensor_budgets(sensors, na);
    let max_b = budgets.iter().copied().max().unwrap_or(0);
    let order = advise_greedy(&m, &g, max_b, &opts, trials);
    let mut last = None;
    for &b in &budgets {
        let mut p = vec![false; na];
        for &(a, _) in order.iter().take(b) {
            p[a] = true;
        }
        let r = evaluate(&m, &g, &p, &opts, trials);
        write_resolution(&mut o, &format!("greedy {b}"), &r);
        last = Some((b, r));
    }
    if let Some(n) = sensors {
        let names: Vec<&str> = order
            .iter()
            .take(n)
            .map(|&(a, _)| m.alarms[a].name.as_str())
            .collect();
        let _ = writeln!(
            o,
            "advice: keep {} alarm(s): {}",
            names.len(),
            names.join(", ")
        );
    }
    let mut summary = format!(
        "summary: {}: {} single faults x {trials}; all {na} alarms isolate {}/{} (mean group {:.2})",
        m.processes[0].name,
        m.source_failure_modes().len(),
        all.isolated,
        all.faults,
        all.mean_group
    );
    if let Some((b, r)) = last {
        let _ = write!(
            summary,
            "; {b} greedy-chosen alarms isolate {}/{} (mean group {:.2})",
            r.isolated, r.faults, r.mean_group
        );
    }
    let _ = writeln!(o, "{summary}");
    Ok(o)
}

/// The sensor budgets `analyze` evaluates: `--sensors N` (at most all `na` alarms), else ¾,
/// ½ and ¼ of them (those strictly between 0 and `na`).
fn sensor_budgets(sensors: Option<usize>, na: usize) -> Vec<usize> {
    match sensors {
        Some(n) => vec![n.min(na)],
        None => [na * 3 / 4, na / 2, na / 4]
            .into_iter()
            .filter(|&b| b > 0 && b < na)
            .collect(),
    }
}

/// One row of `analyze`'s table.
fn write_resolution(o: &mut String, label: &str, r: &robosim_automation::analysis::Resolution) {
    let _ = writeln!(
        o,
        "{:<28} {:>6} {:>7} {:>9} {:>9} {:>10.2} {:>9} {:>12}",
        label,
        r.alarms_kept,
        r.faults,
        r.detected,
        r.isolated,
        r.mean_group,
        r.max_group,
        r.mean_time_to_isolation
            .map_or("-".into(), |t| format!("{t:.0}"))
    );
}
