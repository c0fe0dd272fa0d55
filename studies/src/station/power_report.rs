//! What the station study writes about its loads (issue 38 items 3–4): the per-step CSV
//! columns (each load's demand, served power and shed flag; the energy's flows), the
//! decisions file (`station_decisions.csv`: time, rule, target, action, reason), and the
//! summary's rows, notes and plot — energy served and unserved per priority, the ledger,
//! the experiments' runs, the fault and the reactions, and the same run with the scheduler
//! off beside it.
//!
//! Entry points: [`columns`], [`row`], [`write_decisions`], [`rows`], [`notes`], [`plot`].

use super::{Run, Step};
use crate::{Result, StudyError};
use robosim_simulator::consumers::{Mode, Priority};
use std::path::Path;

const KWH: f64 = 3.6e6;

/// The CSV columns of the loads, in [`row`]'s order.
pub fn columns(run: &Run) -> Vec<String> {
    let mut c: Vec<String> = Vec::new();
    let nc = run.loads.consumers.len();
    for (i, n) in run.loads.names().iter().enumerate() {
        c.push(format!("{n}_demand_kw"));
        c.push(format!("{n}_served_kw"));
        c.push(if i < nc {
            format!("{n}_shed")
        } else {
            format!("{n}_running")
        });
    }
    for x in [
        "interval_s",
        "produced_kw",
        "served_kw",
        "shunted_kw",
        "battery_in_kw",
        "battery_losses_kw",
        "unserved_kw",
    ] {
        c.push(x.into());
    }
    c
}

/// One step's values for [`columns`] (powers averaged over the interval that starts at the
/// step; the last step's interval is empty).
pub fn row(run: &Run, st: &Step) -> Vec<f64> {
    let l = &st.loads;
    let nc = run.loads.consumers.len();
    let mut out = Vec::new();
    for i in 0..l.demand_w.len() {
        out.push(l.demand_w[i] / 1e3);
        out.push(l.served_w[i] / 1e3);
        out.push(if i < nc {
            // shed: the scheduler has it below full (reduced or off)
            (l.modes[i] != Mode::Full) as u8 as f64
        } else {
            (l.demand_w[i] > 0.0) as u8 as f64
        });
    }
    let per = |j: f64| {
        if l.interval_s > 0.0 {
            j / l.interval_s / 1e3
        } else {
            0.0
        }
    };
    let f = &l.flow;
    out.extend([
        l.interval_s,
        per(f.produced_j),
        per(f.served_j),
        per(f.shunted_j),
        per(f.stored_j),
        per(f.losses_j),
        per(f.unserved_j),
    ]);
    out
}

fn csv_text(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

/// `station_decisions.csv`: every decision of the rules (t_s, rule, target, action, reason).
pub fn write_decisions(dir: &Path, run: &Run) -> Result<()> {
    let mut s = String::from("t_s,rule,target,action,reason\n");
    for d in &run.decisions {
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            d.t,
            csv_text(&d.rule),
            csv_text(&d.target),
            csv_text(&d.action),
            csv_text(&d.reason)
        ));
    }
    robosim_input::write_file_atomic(&dir.join("station_decisions.csv"), s.as_bytes())
        .map_err(StudyError::from)
}

/// Energy unserved to vital loads while a sheddable or reducible one was served, J — what the
/// invariant "no vital consumer unserved while a sheddable one is served" forbids.
pub fn vital_unserved_while_sheddable_served_j(run: &Run) -> f64 {
    let n = run.loads.names().len();
    run.steps
        .iter()
        .filter(|st| st.loads.interval_s > 0.0)
        .map(|st| {
            let l = &st.loads;
            let vital_short: f64 = (0..n)
                .filter(|&i| run.loads.priority(i) == Priority::Vital)
                .map(|i| (l.demand_w[i] - l.served_w[i]).max(0.0))
                .sum();
            let other_served =
                (0..n).any(|i| run.loads.priority(i) != Priority::Vital && l.served_w[i] > 0.0);
            if vital_short > 1e-6 && other_served {
                vital_short * l.interval_s
            } else {
                0.0
            }
        })
        .sum()
}

/// The summary's rows: quantity, value, unit.
pub fn rows(run: &Run) -> Vec<(String, String, &'static str)> {
    let t = &run.totals;
    let f = &t.flow;
    let kwh = |j: f64| format!("{:.2}", j / KWH);
    let mut r = vec![
        (
            "scheduler (station_power.clp)".to_owned(),
            format!(
                "{}{}",
                run.scheduling.name(),
                if run.rules_ran {
                    ""
                } else {
                    " (no rule engine ran)"
                }
            ),
            "",
        ),
        (
            "energy produced by the arrays".into(),
            kwh(f.produced_j),
            "kWh",
        ),
        ("energy served to the loads".into(), kwh(f.served_j), "kWh"),
        (
            "energy shunted (battery full)".into(),
            kwh(f.shunted_j),
            "kWh",
        ),
        ("change of the stored energy".into(), kwh(f.stored_j), "kWh"),
        (
            "battery charge and discharge losses".into(),
            kwh(f.losses_j),
            "kWh",
        ),
        (
            "ledger: produced − (served + shunted + Δstored + losses)".into(),
            format!("{:.3e}", f.imbalance_j() / KWH),
            "kWh",
        ),
    ];
    for p in Priority::ALL {
        let k = p as usize;
        r.push((
            format!(
                "{} loads: demanded / served / unserved / shed by the scheduler",
                p.name()
            ),
            format!(
                "{} / {} / {} / {}",
                kwh(t.demanded_j[k]),
                kwh(t.served_j[k]),
                kwh(t.demanded_j[k] - t.served_j[k]),
                kwh(t.shed_j[k])
            ),
            "kWh",
        ));
    }
    r.push((
        "vital energy unserved while a sheddable load was served".into(),
        kwh(vital_unserved_while_sheddable_served_j(run)),
        "kWh",
    ));
    let (asked, started, done, moved, stopped, run_s, dist_s) = experiments_total(run);
    r.push((
        "experiment runs asked / started / completed".into(),
        format!("{asked} / {started} / {done}"),
        "1",
    ));
    r.push((
        "experiments moved out of windows / stopped".into(),
        format!("{moved} / {stopped}"),
        "1",
    ));
    r.push((
        "experiment time run / of it sensitive runs disturbed by a desaturation or docking".into(),
        format!("{:.1} / {:.1}", run_s / 3600.0, dist_s / 60.0),
        "h / min",
    ));
    r.push((
        "decisions of the rules".into(),
        format!("{}", run.decisions.len()),
        "1",
    ));
    r
}

/// Σ over experiments: runs asked, started, completed, moved, stopped; time run and disturbed, s.
pub fn experiments_total(run: &Run) -> (usize, usize, usize, usize, usize, f64, f64) {
    run.loads
        .exps
        .iter()
        .fold((0, 0, 0, 0, 0, 0.0, 0.0), |a, x| {
            (
                a.0 + x.asked,
                a.1 + x.started,
                a.2 + x.completed,
                a.3 + x.moved,
                a.4 + x.stopped,
                a.5 + x.run_s,
                a.6 + x.disturbed_s,
            )
        })
}

/// The summary's notes: the consumers, the decisions (the first 30 in full, then a count per
/// rule), the fault and the reactions, the run with the scheduler off.
pub fn notes(run: &Run, off: Option<&Run>) -> Vec<String> {
    let mut n = vec![loads_note(run)];
    if !run.rules_ran {
        n.push(format!(
            "No rule engine ran: {}",
            if robosim_rules::BUILT_WITH_CLIPS {
                "the scheduler is off and there is no fault to handle."
            } else {
                robosim_rules::NOT_BUILT
            }
        ));
    }
    n.extend(run.attitude.as_ref().map(|a| desaturations_note(run, a)));
    if !run.predicted_windows.is_empty() {
        n.push(format!(
            "Desaturation windows predicted (momentum manager: |h| growth over the last orbit): {}.",
            run.predicted_windows
                .iter()
                .map(|(a, b)| format!("{:.1}–{:.1} min", a / 60.0, b / 60.0))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    n.extend(decision_notes(run));
    n.extend(run.fault.as_ref().map(|f| fault_note(run, f)));
    n.extend(off.map(|o| scheduler_off_note(run, o)));
    n
}

/// The loads and experiments, how a shortfall is shared, the scheduler's reserve.
fn loads_note(run: &Run) -> String {
    format!(
        "Loads (issue 38 item 3; model in robosim_simulator::consumers, demands assumed and named there): {}; experiments {}. Each interval the arrays' power meets the loads' demand through the battery (Battery::supply: surplus charged at 90 %, what a full store cannot take shunted; shortfall drawn at 1/0.9; what it cannot give unserved, shared among the loads in proportion to their demand: a bus browning out). The scheduler keeps a reserve of {} over the coming orbit.",
        run.loads
            .consumers
            .iter()
            .map(|c| format!(
                "{} {:.0} kW ({})",
                c.name,
                c.full_w / 1e3,
                c.priority.name()
            ))
            .collect::<Vec<_>>()
            .join(", "),
        run.loads
            .experiments
            .iter()
            .map(|e| format!(
                "{} {:.0} kW × {:.0} min every {:.1} orbit(s){}",
                e.name,
                e.power_w / 1e3,
                e.duration_s / 60.0,
                e.every_s / run.period_s,
                if e.sensitive {
                    ", microgravity-sensitive"
                } else {
                    ""
                }
            ))
            .collect::<Vec<_>>()
            .join("; "),
        "25 % of the capacity"
    )
}

/// How many desaturations began inside the window the scheduler was given one step before,
/// and how long ahead the windows foresaw them.
fn desaturations_note(run: &Run, a: &super::attitude::AttRun) -> String {
    // each desaturation against the window the scheduler had one step before it began
    let mut inside = 0;
    let mut lead: Vec<f64> = Vec::new();
    for d in &a.dumps {
        let before = run.steps.iter().rev().find(|st| st.t < d.start_s);
        if before
            .and_then(|st| st.desat_window)
            .is_some_and(|(w0, w1)| w0 <= d.start_s && d.start_s <= w1)
        {
            inside += 1;
            // how long before it the windows given contained its start, without a break
            let first = run
                .steps
                .iter()
                .rev()
                .filter(|st| st.t < d.start_s)
                .take_while(|st| {
                    st.desat_window
                        .is_some_and(|(w0, w1)| w0 <= d.start_s && d.start_s <= w1)
                })
                .last()
                .map_or(d.start_s, |st| st.t);
            lead.push(d.start_s - first);
        }
    }
    format!(
        "Desaturations predicted: {inside} of {} began inside the window the scheduler was given (the momentum manager's prediction from |h|'s growth over the last orbit){}.",
        a.dumps.len(),
        if lead.is_empty() {
            String::new()
        } else {
            format!(
                ", foreseen {:.0} min ahead on average (at least {:.0} min)",
                lead.iter().sum::<f64>() / lead.len() as f64 / 60.0,
                lead.iter().copied().fold(f64::INFINITY, f64::min) / 60.0
            )
        }
    )
}

/// The first 30 decisions in full, then a count per rule of the others.
fn decision_notes(run: &Run) -> Vec<String> {
    let mut n = Vec::new();
    for d in run.decisions.iter().take(30) {
        n.push(format!(
            "Decision {:.1} min, {} → {} {}: {}.",
            d.t / 60.0,
            d.rule,
            d.target,
            d.action,
            d.reason
        ));
    }
    if run.decisions.len() > 30 {
        let mut count: Vec<(String, usize)> = Vec::new();
        for d in &run.decisions[30..] {
            match count.iter_mut().find(|(r, _)| *r == d.rule) {
                Some(c) => c.1 += 1,
                None => count.push((d.rule.clone(), 1)),
            }
        }
        n.push(format!(
            "{} more decisions (station_decisions.csv has all): {}.",
            run.decisions.len() - 30,
            count
                .iter()
                .map(|(r, c)| format!("{r} × {c}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    n
}

/// The injected fault: its alarms, diagnoses, isolation, spare and what its consumers drew.
fn fault_note(run: &Run, f: &super::faults::EclssFault) -> String {
    let first_alarm = f.alarms.first().map(|a| a.time);
    format!(
        "Fault (issue 38 item 4): {} injected at {:.1} min ({}); {} alarm(s) rang{}; diagnoses: {}; isolated {}; spare on line {}; the consumer(s) {} drew {:.0} % of their demand while it stood still, then caught up at {:.0} %.",
        f.model.failure_modes[f.fm].path,
        f.spec.t_s / 60.0,
        f.components.join(", "),
        f.alarms.len(),
        first_alarm.map_or(String::new(), |t| format!(
            ", the first at {:.1} min",
            t / 60.0
        )),
        if f.diagnoses.is_empty() {
            "none".to_owned()
        } else {
            f.diagnoses
                .iter()
                .map(|(t, _, c, a)| format!("{:.1} min ({a} alarms → {})", t / 60.0, c.join(" ")))
                .collect::<Vec<_>>()
                .join(", ")
        },
        f.isolated_at
            .map_or("never".into(), |t| format!("at {:.1} min", t / 60.0)),
        f.spare_at
            .map_or("never".into(), |t| format!("at {:.1} min", t / 60.0)),
        f.consumers
            .iter()
            .map(|&i| run.loads.consumers[i].name)
            .collect::<Vec<_>>()
            .join(", "),
        super::faults::STANDBY * 100.0,
        super::faults::CATCH_UP * 100.0,
    )
}

/// The same run with the scheduler off `o` against `run`: what the rule base is worth.
fn scheduler_off_note(run: &Run, o: &Run) -> String {
    let (t_on, t_off) = (&run.totals, &o.totals);
    let v = Priority::Vital as usize;
    let (_, _, done_on, _, _, _, dist_on) = experiments_total(run);
    let (_, _, done_off, _, _, _, dist_off) = experiments_total(o);
    format!(
        "The same run with the scheduler off (every load at full, each experiment started when asked for): vital energy unserved {:.2} kWh (on: {:.2}); all loads unserved {:.2} kWh (on: {:.2}); vital energy unserved while a sheddable load was served {:.2} kWh (on: {:.2}); energy shunted {:.2} kWh (on: {:.2}); experiment runs completed {done_off} (on: {done_on}); sensitive experiment time disturbed by desaturations and dockings {:.1} min (on: {:.1}); lowest state of charge {:.3} (on: {:.3}). What the rule base is worth: {:.2} kWh of vital demand served that the unscheduled station leaves dark, and {:.1} min of undisturbed microgravity.",
        (t_off.demanded_j[v] - t_off.served_j[v]) / KWH,
        (t_on.demanded_j[v] - t_on.served_j[v]) / KWH,
        t_off.flow.unserved_j / KWH,
        t_on.flow.unserved_j / KWH,
        vital_unserved_while_sheddable_served_j(o) / KWH,
        vital_unserved_while_sheddable_served_j(run) / KWH,
        t_off.flow.shunted_j / KWH,
        t_on.flow.shunted_j / KWH,
        dist_off / 60.0,
        dist_on / 60.0,
        min_soc(o),
        min_soc(run),
        ((t_off.demanded_j[v] - t_off.served_j[v]) - (t_on.demanded_j[v] - t_on.served_j[v])) / KWH,
        (dist_off - dist_on) / 60.0,
    )
}

fn min_soc(run: &Run) -> f64 {
    run.steps.iter().map(|s| s.soc).fold(1.0, f64::min)
}

/// Served power per priority against time.
pub fn plot(run: &Run) -> robosim_report::Plot {
    use robosim_report::{Plot, Series};
    let series = |p: Priority, what: &str, served: bool| Series {
        label: format!("{} {what}", p.name()),
        points: run
            .steps
            .iter()
            .filter(|st| st.loads.interval_s > 0.0)
            .map(|st| {
                let v: f64 = (0..st.loads.demand_w.len())
                    .filter(|&i| run.loads.priority(i) == p)
                    .map(|i| {
                        if served {
                            st.loads.served_w[i]
                        } else {
                            st.loads.demand_w[i]
                        }
                    })
                    .sum();
                (st.t / 60.0, v / 1e3)
            })
            .collect(),
    };
    let mut s = Vec::new();
    for p in Priority::ALL {
        s.push(series(p, "served", true));
    }
    s.push(series(Priority::Vital, "demanded", false));
    Plot {
        title: format!(
            "Loads served per priority (scheduler {})",
            run.scheduling.name()
        ),
        x_label: "t (min)".into(),
        y_label: "power (kW)".into(),
        series: s,
        ..Plot::default()
    }
}
