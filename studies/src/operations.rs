//! `robosim study operations --orbits N --out DIR` (issue 38 item 7): the operational station
//! as separate processes on one session, driven headless.
//!
//! The study starts scene [`SCENE`] on a session of its own (`robosim up` through
//! [`robosim_launcher`]): the keeper, the simulator in lock-step, the rules process running
//! `station_ops.clp` (the energy scheduler), the dataflow process running
//! `momentum_manager.flow` (predicted time to saturation of the CMGs) and the automation plant
//! (the ECLSS fault model). Who owns what:
//!
//! * **simulator** — orbit, sun tracking, power, battery, attitude and CMG momentum, the
//!   consumers' served power in their modes; it publishes all of it in its state (`get`,
//!   `space.ops`) and takes the rules' decisions as commands, acknowledging each;
//! * **rules** — the scheduler: reads the state as facts, predicts the energy to the end of the
//!   next eclipse, sheds and restores consumers by priority, then acknowledges the step;
//! * **dataflow** — the momentum manager: |h|, its rate and the threshold → the predicted time
//!   to saturation and the `desaturation_soon` alarm, in its process state;
//! * **automation** — the ECLSS fault model whose injected faults ring alarms;
//! * **faults** (`--fault FAILURE_MODE@T`): at T the study injects the failure mode into the
//!   plant (its alarms) and tells the simulator which consumer's unit failed (its demand); the
//!   rules diagnose the alarms, isolate the unit and bring its spare on line in the Instance
//!   Space, which the simulator follows (the consumer's spare starts, then catches up). The
//!   study waits for the spare (a condition, not time) before the next step, as the in-process
//!   study handles a fault within its step. With the scheduler off, `eclss_guard.clp` runs as
//!   the rules process instead (the guard without the energy scheduler, as in process);
//! * **this study** — the clock: it steps the simulator one decision interval at a time and
//!   waits until the rules and the dataflow process have acted on that step (acknowledgement
//!   and source value, not time), so the run is the same however fast the processes are; then
//!   it records the row.
//!
//! Outputs: `operations.csv` (one row per decision interval), `operations_summary.{md,csv,png}`
//! (desaturations and their interval, energy served and unserved per priority, the ledger,
//! the decisions with their reasons, faults and alarms) and `operations_decisions.csv`.

use crate::{Result, StudyError, bail, say};
use robosim_instance_space::Session;
use robosim_instance_space::state::CommandSender;
use serde_json::{Value, json};
use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The library scene the study runs.
pub const SCENE: &str = "space_station_ops";

/// The momentum manager's graph, compiled in (written into the session for its process).
pub const MOMENTUM_MANAGER: &str = include_str!("../../automation/graphs/momentum_manager.flow");

/// How long a process may take to act on one step before the study gives up, s (a condition
/// waited on, not a pace: a process that died is said at once by its missing acknowledgement).
const ACT_TIMEOUT: Duration = Duration::from_secs(120);

#[derive(Debug, Clone)]
pub struct OpsParams {
    pub orbits: f64,
    pub out: PathBuf,
    /// Session name (default `ops-study-<pid>`).
    pub session: Option<String>,
    /// Simulated time between the rules' decisions (the study's row interval), s.
    pub decide_every_s: f64,
    /// Run the rules process (the scheduler); off measures what it is worth.
    pub scheduler: bool,
    /// Faults for the automation plant: (fault name, simulated time s).
    pub faults: Vec<(String, f64)>,
    /// Leave the session running at the end (for inspection).
    pub keep: bool,
    /// The station's base load (consumer `station_base`), W; default the simulator's 100 kW.
    pub base_load_w: Option<f64>,
}

impl Default for OpsParams {
    fn default() -> Self {
        OpsParams {
            orbits: 1.0,
            out: PathBuf::from("operations"),
            session: None,
            decide_every_s: 60.0,
            scheduler: true,
            faults: Vec::new(),
            keep: false,
            base_load_w: None,
        }
    }
}

/// Stops the session's processes (`robosim down`) when dropped, unless kept.
struct Down {
    name: String,
    keep: bool,
}

impl Drop for Down {
    fn drop(&mut self) {
        if !self.keep {
            let _ = robosim_launcher::down(Some(&self.name));
        }
    }
}

fn f(v: &Value, p: &str) -> f64 {
    v.pointer(p).and_then(Value::as_f64).unwrap_or(f64::NAN)
}

/// One command to a session process's command channel (`dataflow`, …), its JSON answer.
fn ask(
    sender: &mut Option<CommandSender>,
    session: &Session,
    target: &str,
    cmd: &Value,
) -> Option<Value> {
    if sender.is_none() {
        *sender = CommandSender::open(session, target, &format!("ops-study-{target}")).ok();
    }
    let s = sender.as_mut()?;
    match s.send(cmd.to_string().as_bytes(), Duration::from_secs(5)) {
        Ok(a) => serde_json::from_slice(&a).ok(),
        Err(_) => {
            *sender = None;
            None
        }
    }
}

/// One row of `operations.csv`.
struct Row {
    t: f64,
    state: Value,
    tts_s: f64,
    soon: bool,
}

/// A fault the study injects: the plant's failure mode, when, and what it fails in the
/// simulator.
struct Injection {
    fault: String,
    /// When, simulated s.
    at: f64,
    /// The failure mode's path in the ECLSS model (what the plant is told).
    path: String,
    /// The consumer whose unit fails (empty when none).
    consumer: &'static str,
    /// Its failed units.
    components: Vec<String>,
}

/// Runs the study (module docs); returns the session's final simulator state.
pub fn run(p: &OpsParams, log: &mut dyn Write) -> Result<Value> {
    check_params(p)?;
    std::fs::create_dir_all(&p.out).map_err(|e| StudyError::io(&p.out, e))?;
    let name = p
        .session
        .clone()
        .unwrap_or_else(|| format!("ops-study-{}", std::process::id()));
    let with = processes(p)?;
    let faults = injections(p)?;
    say!(
        log,
        "== session {name}: robosim up {SCENE} --with {} (simulator lock-step)",
        with.join(",")
    );
    robosim_launcher::up_with_library(SCENE, &with, Some(&name), &[], true, Some("lockstep"))?;
    let _down = Down {
        name: name.clone(),
        keep: p.keep,
    };
    let session = Session::open(Some(&name))?;
    // SIGINT/SIGTERM end the run between steps, so that the guard above stops the session's
    // processes (a study killed mid-run used to leave them running)
    let signals = session.node("ops-study", true)?;
    let interrupted = |d: Duration| signals.wait(d).is_err();
    let mut clock = Clock {
        p,
        name: &name,
        session: &session,
        interrupted: &interrupted,
        planner: robosim_hl_interface::planner::Planner::attach(&name)?,
        dataflow: None,
        plant: None,
        faults,
        fault_log: Vec::new(),
        alarms_seen: Vec::new(),
    };
    let s0 = clock.planner.sim_state()?;
    let dt = s0.get("dt_s").and_then(Value::as_f64).unwrap_or(10.0);
    let period = f(&s0, "/space/orbit/period_s");
    if !period.is_finite() || s0.pointer("/space/ops/consumers").is_none() {
        bail!(
            "the simulator of {SCENE} publishes no operations state (space.ops): is the scene's attitude/consumers effect declared?"
        );
    }
    if let Some(w) = p.base_load_w {
        clock
            .planner
            .sim_command(&json!({"cmd": "demand", "name": "station_base", "full_w": w}))?;
        say!(log, "== base load {:.0} kW", w / 1e3);
    }
    let chunk = (p.decide_every_s / dt).round().max(1.0) as u64;
    let total = ((p.orbits * period) / dt).round() as u64;
    say!(
        log,
        "== {} orbit(s) of {period:.0} s: {total} steps of {dt} s, decisions every {chunk} step(s)",
        p.orbits
    );
    let mut rows = Vec::new();
    let mut done = 0u64;
    let started = Instant::now();
    while done < total {
        if interrupted(Duration::ZERO) {
            bail!(
                "interrupted (SIGINT or SIGTERM) after {done} of {total} steps; session {name} stopped"
            );
        }
        let n = chunk.min(total - done);
        done += n;
        rows.push(clock.step(n)?);
    }
    let wall = started.elapsed().as_secs_f64();
    let last = clock.planner.sim_state()?;
    write_outputs(p, period, &rows, &last, &clock.fault_log, wall, log)?;
    Ok(last)
}

/// Refuses a run length or decision interval that is not a positive number.
fn check_params(p: &OpsParams) -> Result<()> {
    if !(p.orbits > 0.0 && p.orbits.is_finite()) {
        bail!("--orbits {}: expected a positive number", p.orbits);
    }
    if !(p.decide_every_s > 0.0 && p.decide_every_s.is_finite()) {
        bail!(
            "--decide-every {}: expected a positive number of seconds",
            p.decide_every_s
        );
    }
    Ok(())
}

/// The session's processes (`--with`): the simulator, the dataflow process on the momentum
/// manager's graph (written into the output directory), the automation plant, and the rules
/// (the scheduler, or the ECLSS guard alone when the scheduler is off and faults are injected).
fn processes(p: &OpsParams) -> Result<Vec<String>> {
    let graph = p.out.join("momentum_manager.flow");
    std::fs::write(&graph, MOMENTUM_MANAGER).map_err(|e| StudyError::io(&graph, e))?;
    let graph = std::path::absolute(&graph).map_err(|e| StudyError::io(&graph, e))?;
    let mut with = vec![
        "simulator".to_owned(),
        format!("dataflow={}", graph.display()),
        "automation".to_owned(),
    ];
    if p.scheduler {
        with.push("rules=station_ops".to_owned());
    } else if !p.faults.is_empty() {
        with.push("rules=eclss_guard".to_owned());
    }
    Ok(with)
}

/// The `--fault`s in time order, each with the consumer and units it fails (the ECLSS model's
/// process and components).
fn injections(p: &OpsParams) -> Result<Vec<Injection>> {
    let catalogue =
        robosim_simulator::consumers::default_consumers(robosim_simulator::consumers::BASE_LOAD_W);
    let mut injected = Vec::new();
    for (fault, at) in &p.faults {
        let spec = crate::station::faults::FaultSpec {
            failure_mode: fault.clone(),
            t_s: *at,
        };
        let e = crate::station::faults::EclssFault::new(&spec, &catalogue)?;
        let consumer = e
            .consumers
            .first()
            .map(|&i| catalogue[i].name)
            .unwrap_or_default();
        injected.push(Injection {
            fault: fault.clone(),
            at: *at,
            path: e.model.failure_modes[e.fm].path.clone(),
            consumer,
            components: e.components.clone(),
        });
    }
    injected.sort_by(|a, b| a.at.total_cmp(&b.at));
    Ok(injected)
}

/// The study's clock over the session: it steps the simulator and waits for the processes to
/// act on each step; the faults still to inject and what has been logged so far.
struct Clock<'a> {
    p: &'a OpsParams,
    name: &'a str,
    session: &'a Session,
    /// Whether SIGINT or SIGTERM came within the wait.
    interrupted: &'a dyn Fn(Duration) -> bool,
    planner: robosim_hl_interface::planner::Planner,
    /// The dataflow process's command channel (opened on first use).
    dataflow: Option<CommandSender>,
    /// The automation plant's command channel (opened on first use).
    plant: Option<CommandSender>,
    /// Faults not yet injected, in time order.
    faults: Vec<Injection>,
    fault_log: Vec<String>,
    alarms_seen: Vec<String>,
}

impl Clock<'_> {
    /// `n` simulator steps, then what the processes made of them: the row recorded.
    fn step(&mut self, n: u64) -> Result<Row> {
        let st = self.planner.sim_step(n)?;
        let steps = st
            .pointer("/space/ops/steps")
            .and_then(Value::as_u64)
            .unwrap_or(0);
        let t = f(&st, "/space/t_s");
        // the rules and the momentum manager act on this step before the next
        let (state, df) = self.wait_acted(steps, t)?;
        let df = df.unwrap_or(Value::Null);
        // faults due by now go to the plant; its alarms are recorded
        self.inject_due(t, steps)?;
        self.record_alarms(t);
        Ok(Row {
            t,
            tts_s: df
                .pointer("/values/time_to_saturation")
                .and_then(Value::as_f64)
                .unwrap_or(f64::NAN),
            soon: df
                .get("alarms")
                .and_then(Value::as_array)
                .is_some_and(|a| a.iter().any(|x| x.as_str() == Some("desaturation_soon"))),
            state,
        })
    }

    /// Waits until the rules (when running) acknowledged step `steps` and the dataflow process
    /// took it: the simulator's state then, and the dataflow's.
    fn wait_acted(&mut self, steps: u64, t: f64) -> Result<(Value, Option<Value>)> {
        let wait = Instant::now();
        loop {
            let s = self.planner.sim_state()?;
            let rules_ok = !self.p.scheduler
                || s.pointer("/space/ops/acks/rules").and_then(Value::as_u64) >= Some(steps);
            let df = ask(
                &mut self.dataflow,
                self.session,
                "dataflow",
                &json!({"cmd": "get"}),
            );
            let df_steps = df
                .as_ref()
                .and_then(|d| d.pointer("/values/steps")?.as_f64())
                .unwrap_or(-1.0);
            if rules_ok && df_steps >= steps as f64 {
                return Ok((s, df));
            }
            if wait.elapsed() > ACT_TIMEOUT {
                bail!(
                    "step {steps} (t = {t} s): {} within {ACT_TIMEOUT:?} (see the session's run/*.log)",
                    if rules_ok {
                        "the dataflow process did not take the step"
                    } else {
                        "the rules process did not acknowledge the step"
                    }
                );
            }
            if (self.interrupted)(Duration::from_millis(5)) {
                bail!(
                    "interrupted (SIGINT or SIGTERM) at step {steps}; session {} stopped",
                    self.name
                );
            }
        }
    }

    /// Injects every fault due by `t` into the plant and the simulator, logging each; with the
    /// scheduler on, waits for its spare to come on line.
    fn inject_due(&mut self, t: f64, steps: u64) -> Result<()> {
        while self.faults.first().is_some_and(|f| f.at <= t) {
            let Injection {
                fault,
                at,
                path,
                consumer,
                components,
            } = self.faults.remove(0);
            let r = ask(
                &mut self.plant,
                self.session,
                robosim_hl_interface::plant::SERVICE,
                &json!({"cmd": "fault", "fault": path}),
            );
            let sim = self
                .planner
                .sim_command(&json!({"cmd": "fault", "fault": path,
                "consumer": consumer, "components": components}));
            self.fault_log.push(format!(
                "{fault} ({path}) injected at t = {at:.0} s (asked at {t:.0} s): {}; {consumer}'s unit {} failed in the simulator{}",
                if r.is_some() {
                    "taken by the plant"
                } else {
                    "the plant did not answer"
                },
                components.join(", "),
                match &sim {
                    Ok(_) => String::new(),
                    Err(e) => format!(" — refused: {e}"),
                }
            ));
            sim?;
            if self.p.scheduler {
                // the rules diagnose, isolate and bring the spare on line before the clock
                // moves on (the in-process study does it within the step)
                self.wait_spare(&fault, &components, t, steps)?;
            }
        }
        Ok(())
    }

    /// Waits until the simulator's last fault has its spare on line, and logs when.
    fn wait_spare(&mut self, fault: &str, components: &[String], t: f64, steps: u64) -> Result<()> {
        let wait = Instant::now();
        loop {
            let s = self.planner.sim_state()?;
            let spare = s
                .pointer("/space/ops/faults")
                .and_then(Value::as_array)
                .and_then(|fs| fs.last())
                .and_then(|f| f.get("spare_at_s"))
                .and_then(Value::as_f64);
            if let Some(at) = spare {
                self.fault_log.push(format!(
                    "{fault}: diagnosed, {} isolated and its spare on line (followed by the simulator at t = {at:.0} s)",
                    components.join(", ")
                ));
                return Ok(());
            }
            if wait.elapsed() > ACT_TIMEOUT {
                bail!(
                    "{fault} at t = {t} s: no spare on line within {ACT_TIMEOUT:?} (the rules' diagnosis and reconfiguration: see the session's run/rules.log)"
                );
            }
            if (self.interrupted)(Duration::from_millis(5)) {
                bail!(
                    "interrupted (SIGINT or SIGTERM) at step {steps}; session {} stopped",
                    self.name
                );
            }
        }
    }

    /// Logs each plant alarm the first time it is seen.
    fn record_alarms(&mut self, t: f64) {
        let Some(pl) = ask(
            &mut self.plant,
            self.session,
            robosim_hl_interface::plant::SERVICE,
            &json!({"cmd": "get"}),
        ) else {
            return;
        };
        for a in pl
            .get("alarms")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            let text = format!(
                "{} {}",
                a.get("process").and_then(Value::as_str).unwrap_or("?"),
                a.get("alarm").and_then(Value::as_str).unwrap_or("?")
            );
            if !self.alarms_seen.contains(&text) {
                self.fault_log
                    .push(format!("alarm {text} seen at t = {t:.0} s"));
                self.alarms_seen.push(text);
            }
        }
    }
}

/// What the outputs are written from: the run's rows, the simulator's final state and the
/// study's fault log.
struct Outputs<'a> {
    p: &'a OpsParams,
    /// The orbit's period, s (times are written in orbits too).
    period: f64,
    rows: &'a [Row],
    /// The operations part of the simulator's state after the last step (`/space/ops`):
    /// decisions, experiments, ledger, faults.
    ops: Value,
    fault_log: &'a [String],
    /// Wall time of the run, s.
    wall: f64,
}

impl Outputs<'_> {
    /// The rules' decisions the simulator kept.
    fn decisions(&self) -> Vec<&Value> {
        self.ops
            .get("decisions")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
            .collect()
    }

    /// The experiments' records.
    fn experiments(&self) -> Vec<&Value> {
        self.ops
            .get("experiments")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
            .collect()
    }
}

fn write_outputs(
    p: &OpsParams,
    period: f64,
    rows: &[Row],
    last: &Value,
    fault_log: &[String],
    wall: f64,
    log: &mut dyn Write,
) -> Result<()> {
    let o = Outputs {
        p,
        period,
        rows,
        ops: last.pointer("/space/ops").cloned().unwrap_or(Value::Null),
        fault_log,
        wall,
    };
    let consumers = names_at(last, "/space/ops/consumers");
    let experiments = names_at(last, "/space/ops/experiments");
    write_text(
        &p.out.join("operations.csv"),
        operations_csv(&o, &consumers, &experiments),
    )?;
    write_text(&p.out.join("operations_decisions.csv"), decisions_csv(&o))?;
    let report = robosim_report::Report {
        name: "operations_summary".into(),
        title: format!(
            "The operational station: {} orbit(s), processes on one session",
            p.orbits
        ),
        notes: summary_notes(&o),
        table: robosim_report::Table {
            columns: vec!["quantity".into(), "value".into(), "unit".into()],
            rows: summary_table(&o),
        },
        plots: summary_plots(&o, &consumers),
    };
    for n in &report.notes[..1] {
        say!(log, "{n}");
    }
    for r in &report.table.rows {
        say!(log, "  {}: {} {}", r[0], r[1], r[2]);
    }
    let written = robosim_report::write_report(&p.out, &report)?;
    say!(log, "wrote {}", p.out.join("operations.csv").display());
    say!(
        log,
        "wrote {}",
        p.out.join("operations_decisions.csv").display()
    );
    for w in written {
        say!(log, "wrote {}", w.display());
    }
    Ok(())
}

/// `text` into `path`, an error naming the file.
fn write_text(path: &std::path::Path, text: String) -> Result<()> {
    std::fs::write(path, text).map_err(|e| StudyError::io(path, e))
}

/// The `name`s of the records in the array at `pointer` of `state`, in order.
fn names_at(state: &Value, pointer: &str) -> Vec<String> {
    state
        .pointer(pointer)
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(|c| c.get("name")?.as_str().map(str::to_owned))
        .collect()
}

/// `operations.csv`: the header (a served/shed pair per consumer, a served/state pair per
/// experiment) and one line per recorded step.
fn operations_csv(o: &Outputs, consumers: &[String], experiments: &[String]) -> String {
    let mut csv = String::from(
        "t_s,orbit,attitude_error_deg,cmg_momentum_nms,cmg_capacity_fraction,desaturating,power_kw,battery_kwh,battery_soc,demand_kw,predicted_time_to_saturation_s,desaturation_soon",
    );
    for c in consumers {
        csv.push_str(&format!(",{c}_served_kw,{c}_shed"));
    }
    for e in experiments {
        csv.push_str(&format!(",{e}_served_kw,{e}_state"));
    }
    csv.push_str(",docking,vital_short_while_sheddable_s\n");
    for r in o.rows {
        csv.push_str(&operations_line(r, o.period));
    }
    csv
}

/// One line of `operations.csv` (with its newline).
fn operations_line(r: &Row, period: f64) -> String {
    let s = &r.state;
    let a = |k: &str| f(s, &format!("/space/ops/attitude/{k}"));
    let mut line = format!(
        "{},{:.5},{:.6},{:.3},{:.5},{},{:.3},{:.3},{:.5},{:.3},{:.1},{}",
        r.t,
        r.t / period,
        a("error_deg"),
        a("h_nms"),
        a("h_fraction"),
        u8::from(s.pointer("/space/ops/attitude/dumping") == Some(&Value::Bool(true))),
        f(s, "/space/power/power_w") / 1e3,
        f(s, "/space/power/battery_kwh"),
        f(s, "/space/power/battery_soc"),
        f(s, "/space/ops/demand_w") / 1e3,
        r.tts_s,
        u8::from(r.soon)
    );
    for c in s
        .pointer("/space/ops/consumers")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        line.push_str(&format!(
            ",{:.3},{}",
            c.get("served_w")
                .and_then(Value::as_f64)
                .unwrap_or(f64::NAN)
                / 1e3,
            u8::from(c.get("shed") == Some(&Value::Bool(true)))
        ));
    }
    for e in s
        .pointer("/space/ops/experiments")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        line.push_str(&format!(
            ",{:.3},{}",
            e.get("served_w")
                .and_then(Value::as_f64)
                .unwrap_or(f64::NAN)
                / 1e3,
            e.get("state").and_then(Value::as_str).unwrap_or("")
        ));
    }
    line.push_str(&format!(
        ",{},{}\n",
        u8::from(f(s, "/space/ops/docking/to_start_s") == 0.0),
        f(s, "/space/ops/vital_short_while_sheddable/s")
    ));
    line
}

/// `operations_decisions.csv`: one line per decision the simulator kept.
fn decisions_csv(o: &Outputs) -> String {
    let mut dcsv = String::from("seq,steps,t_s,orbit,rule,consumer,mode,reason\n");
    for d in o.decisions() {
        let t = d.get("t_s").and_then(Value::as_f64).unwrap_or(f64::NAN);
        dcsv.push_str(&format!(
            "{},{},{t},{:.4},{},{},{},\"{}\"\n",
            d.get("seq").and_then(Value::as_u64).unwrap_or(0),
            d.get("steps").and_then(Value::as_u64).unwrap_or(0),
            t / o.period,
            d.get("rule").and_then(Value::as_str).unwrap_or(""),
            d.get("consumer").and_then(Value::as_str).unwrap_or(""),
            d.get("mode").and_then(Value::as_str).unwrap_or(""),
            d.get("reason")
                .and_then(Value::as_str)
                .unwrap_or("")
                .replace('"', "'")
        ));
    }
    dcsv
}

/// The summary's table: quantity, value, unit.
fn summary_table(o: &Outputs) -> Vec<Vec<String>> {
    let mut table_rows = run_rows(o);
    table_rows.extend(energy_rows(&o.ops));
    table_rows.extend(experiment_rows(o));
    table_rows.push(vec![
        "wall time".into(),
        format!("{:.1}", o.wall),
        "s".into(),
    ]);
    table_rows
}

/// The run's parameters, its desaturations, and the worst attitude error and state of charge
/// at a recorded step.
fn run_rows(o: &Outputs) -> Vec<Vec<String>> {
    let (p, rows, period) = (o.p, o.rows, o.period);
    let starts: Vec<f64> = o
        .ops
        .pointer("/attitude/dump_starts_s")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(Value::as_f64)
        .collect();
    let mean_interval = (starts.len() >= 2)
        .then(|| (starts[starts.len() - 1] - starts[0]) / (starts.len() - 1) as f64 / period);
    vec![
        vec!["orbits run".into(), format!("{}", p.orbits), "".into()],
        vec![
            "base load (station_base)".into(),
            format!(
                "{:.0}",
                f(
                    &rows.last().map_or(Value::Null, |r| r.state.clone()),
                    "/space/ops/consumers/0/full_w"
                ) / 1e3
            ),
            "kW".into(),
        ],
        vec![
            "scheduler (rules process, station_ops.clp)".into(),
            if p.scheduler { "on" } else { "off" }.into(),
            "".into(),
        ],
        vec!["desaturations".into(), starts.len().to_string(), "".into()],
        vec![
            "mean interval between desaturations".into(),
            mean_interval.map_or("– (fewer than two)".into(), |i| format!("{i:.2}")),
            "orbits (the seed: about every tenth orbit)".into(),
        ],
        vec![
            "largest attitude error at a recorded step".into(),
            format!(
                "{:.4}",
                rows.iter()
                    .map(|r| f(&r.state, "/space/ops/attitude/error_deg"))
                    .fold(0.0, f64::max)
            ),
            "deg".into(),
        ],
        vec![
            "lowest battery state of charge at a recorded step".into(),
            format!(
                "{:.3}",
                rows.iter()
                    .map(|r| f(&r.state, "/space/power/battery_soc"))
                    .fold(1.0, f64::min)
            ),
            "".into(),
        ],
    ]
}

/// Energy served and unserved per priority, the ledger and its residue, and the vital
/// consumers' shortfall while a sheddable one drew.
fn energy_rows(ops: &Value) -> Vec<Vec<String>> {
    let mut table_rows = Vec::new();
    for pr in ["vital", "reducible", "sheddable"] {
        table_rows.push(vec![
            format!("energy served / unserved, {pr}"),
            format!(
                "{:.2} / {:.2}",
                f(ops, &format!("/served_kwh/{pr}")),
                f(ops, &format!("/unserved_kwh/{pr}"))
            ),
            "kWh".into(),
        ]);
    }
    let l = |k: &str| f(ops, &format!("/ledger_kwh/{k}"));
    let residue = l("produced") - (l("served") + l("shunted") + l("stored") + l("losses"));
    table_rows.push(vec![
        "ledger: produced = served + shunted + Δstored + losses".into(),
        format!(
            "{:.2} = {:.2} + {:.2} + {:.2} + {:.2} (residue {residue:.2e})",
            l("produced"),
            l("served"),
            l("shunted"),
            l("stored"),
            l("losses")
        ),
        "kWh".into(),
    ]);
    table_rows.push(vec![
        "vital consumer short while a sheddable one drew: time / sheddable energy".into(),
        format!(
            "{:.0} / {:.3}",
            f(ops, "/vital_short_while_sheddable/s"),
            f(ops, "/vital_short_while_sheddable/sheddable_kwh")
        ),
        "s / kWh".into(),
    ]);
    table_rows
}

/// The experiments' runs (asked, started, completed, moved, stopped, disturbed), the early
/// desaturations and the number of decisions.
fn experiment_rows(o: &Outputs) -> Vec<Vec<String>> {
    let exps = o.experiments();
    let sum = |k: &str| {
        exps.iter()
            .map(|e| e.get(k).and_then(Value::as_f64).unwrap_or(0.0))
            .sum::<f64>()
    };
    let mut table_rows = vec![
        vec![
            "experiment runs asked / started / completed".into(),
            format!(
                "{} / {} / {}",
                sum("asked"),
                sum("started"),
                sum("completed")
            ),
            "".into(),
        ],
        vec![
            "experiment runs moved / stopped (by the rules)".into(),
            format!("{} / {}", sum("moved"), sum("stopped")),
            "".into(),
        ],
    ];
    let sensitive_disturbed: f64 = exps
        .iter()
        .filter(|e| e.get("sensitive") == Some(&Value::Bool(true)))
        .map(|e| e.get("disturbed_s").and_then(Value::as_f64).unwrap_or(0.0))
        .sum();
    table_rows.push(vec![
        "microgravity run time disturbed (desaturation or docking under way)".into(),
        format!("{:.1}", sensitive_disturbed / 60.0),
        "min".into(),
    ]);
    let early = o
        .decisions()
        .iter()
        .filter(|d| d.get("mode").and_then(Value::as_str) == Some("desaturate"))
        .count();
    table_rows.push(vec![
        "desaturations started early by the momentum manager (dataflow)".into(),
        early.to_string(),
        "".into(),
    ]);
    let total_decisions = o
        .ops
        .get("decisions_total")
        .and_then(Value::as_u64)
        .unwrap_or(0);
    table_rows.push(vec![
        "decisions (rule firings the simulator acknowledged)".into(),
        total_decisions.to_string(),
        "".into(),
    ]);
    table_rows
}

/// The summary's notes: what ran, the decisions, the experiments moved and their runs, the
/// faults and the reactions to them.
fn summary_notes(o: &Outputs) -> Vec<String> {
    let p = o.p;
    let mut notes = vec![format!(
        "Scene {SCENE} run as separate processes on one session: the simulator (orbit, tracking, power, battery, attitude, consumers), the rules process (station_ops.clp: {}), the dataflow process (momentum_manager.flow), the automation plant (ECLSS fault model). The study steps the simulator {} s at a time and waits for the rules' acknowledgement and the dataflow's pass on each step before the next.",
        if p.scheduler { "on" } else { "not started" },
        p.decide_every_s
    )];
    notes.extend(decision_notes(o));
    notes.extend(experiment_notes(o));
    notes.extend(fault_notes(o));
    notes
}

/// The decisions (orbit, rule, consumer → mode: reason), then the experiments moved or
/// stopped by them.
fn decision_notes(o: &Outputs) -> Vec<String> {
    let decisions = o.decisions();
    let period = o.period;
    let mut notes = vec!["Decisions (orbit, rule, consumer → mode: reason):".to_owned()];
    for d in &decisions {
        notes.push(format!(
            "* orbit {:.3}: {} — {} → {}: {}",
            d.get("t_s").and_then(Value::as_f64).unwrap_or(f64::NAN) / period,
            d.get("rule").and_then(Value::as_str).unwrap_or(""),
            d.get("consumer").and_then(Value::as_str).unwrap_or(""),
            d.get("mode").and_then(Value::as_str).unwrap_or(""),
            d.get("reason").and_then(Value::as_str).unwrap_or("")
        ));
    }
    if decisions.is_empty() {
        notes.push("* none".into());
    }
    notes
        .push("Experiments moved (out of desaturation and docking windows, or for energy):".into());
    let moves: Vec<&&Value> = decisions
        .iter()
        .filter(|d| {
            d.get("mode")
                .and_then(Value::as_str)
                .is_some_and(|m| m.starts_with("moved") || m.starts_with("stopped"))
        })
        .collect();
    if moves.is_empty() {
        notes.push("* none".into());
    }
    for d in moves {
        notes.push(format!(
            "* orbit {:.3}: {} {} ({}): {}",
            d.get("t_s").and_then(Value::as_f64).unwrap_or(f64::NAN) / period,
            d.get("consumer").and_then(Value::as_str).unwrap_or(""),
            d.get("mode").and_then(Value::as_str).unwrap_or(""),
            d.get("rule").and_then(Value::as_str).unwrap_or(""),
            d.get("reason").and_then(Value::as_str).unwrap_or("")
        ));
    }
    notes
}

/// Each experiment's runs: asked, started, completed, moved, stopped, run and disturbed time.
fn experiment_notes(o: &Outputs) -> Vec<String> {
    let mut notes = vec![
        "Experiments (asked, started, completed, moved, stopped, run min, disturbed min):"
            .to_owned(),
    ];
    for e in o.experiments() {
        let g = |k: &str| e.get(k).and_then(Value::as_f64).unwrap_or(0.0);
        notes.push(format!(
            "* {}{}: {} / {} / {} / {} / {}, {:.0} min run, {:.1} min disturbed",
            e.get("name").and_then(Value::as_str).unwrap_or(""),
            if e.get("sensitive") == Some(&Value::Bool(true)) {
                " (microgravity)"
            } else {
                ""
            },
            g("asked"),
            g("started"),
            g("completed"),
            g("moved"),
            g("stopped"),
            g("run_s") / 60.0,
            g("disturbed_s") / 60.0
        ));
    }
    notes
}

/// The faults injected, the alarms seen, the simulator's fault records and how a fault's
/// consumer reacts.
fn fault_notes(o: &Outputs) -> Vec<String> {
    let mut notes = vec!["Faults and reactions:".to_owned()];
    if o.fault_log.is_empty() {
        notes.push("* none injected, no alarm rang".into());
    }
    notes.extend(o.fault_log.iter().map(|x| format!("* {x}")));
    for x in o
        .ops
        .get("faults")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        notes.push(format!(
            "* {}: {} failed at {:.0} s, spare on line at {} s, now {}",
            x.get("fault").and_then(Value::as_str).unwrap_or(""),
            x.get("consumer").and_then(Value::as_str).unwrap_or(""),
            x.get("at_s").and_then(Value::as_f64).unwrap_or(f64::NAN),
            x.get("spare_at_s")
                .and_then(Value::as_f64)
                .map_or("–".into(), |t| format!("{t:.0}")),
            x.get("state").and_then(Value::as_str).unwrap_or("")
        ));
    }
    notes.push(format!(
        "Reactions to faults: the failed unit's consumer draws {} of its demand until its spare runs ({} s after on line), then {} times it until the work missed is made up (the in-process study's model); the scheduler's notes (ops-fault-reaction) and any shedding they cause are among the decisions above.",
        crate::station::faults::STANDBY,
        crate::station::faults::SPARE_START_S,
        crate::station::faults::CATCH_UP
    ));
    notes
}

/// The summary's plots against orbits: CMG momentum and the desaturation flags, the attitude
/// error, and power, battery and each consumer's served power (the base load left out).
fn summary_plots(o: &Outputs, consumers: &[String]) -> Vec<robosim_report::Plot> {
    let (rows, period) = (o.rows, o.period);
    let series = |label: &str, g: &dyn Fn(&Row) -> f64| robosim_report::Series {
        label: label.into(),
        points: rows.iter().map(|r| (r.t / period, g(r))).collect(),
    };
    let mut power_series = vec![
        series("array power (kW)", &|r| {
            f(&r.state, "/space/power/power_w") / 1e3
        }),
        series("demand (kW)", &|r| f(&r.state, "/space/ops/demand_w") / 1e3),
        series("battery (kWh)", &|r| {
            f(&r.state, "/space/power/battery_kwh")
        }),
    ];
    for (k, c) in consumers.iter().enumerate() {
        if c == "station_base" {
            continue;
        }
        power_series.push(series(&format!("{c} served (kW)"), &|r| {
            f(&r.state, &format!("/space/ops/consumers/{k}/served_w")) / 1e3
        }));
    }
    vec![
        robosim_report::Plot {
            title: "CMG momentum".into(),
            x_label: "orbits".into(),
            y_label: "fraction of capacity / flags".into(),
            series: vec![
                series("|h| / capacity", &|r| {
                    f(&r.state, "/space/ops/attitude/h_fraction")
                }),
                series("desaturating", &|r| {
                    f64::from(u8::from(
                        r.state.pointer("/space/ops/attitude/dumping") == Some(&Value::Bool(true)),
                    ))
                }),
                series("desaturation_soon (dataflow)", &|r| {
                    f64::from(u8::from(r.soon))
                }),
            ],
            ..Default::default()
        },
        robosim_report::Plot {
            title: "Attitude error".into(),
            x_label: "orbits".into(),
            y_label: "deg".into(),
            series: vec![series("attitude error", &|r| {
                f(&r.state, "/space/ops/attitude/error_deg")
            })],
            ..Default::default()
        },
        robosim_report::Plot {
            title: "Power, battery, consumers".into(),
            x_label: "orbits".into(),
            y_label: "kW / kWh".into(),
            series: power_series,
            ..Default::default()
        },
    ]
}

/// `FAULT@SECONDS` (`--fault`).
pub fn parse_fault(s: &str) -> Result<(String, f64)> {
    let Some((name, at)) = s.rsplit_once('@') else {
        bail!("--fault {s:?}: expected FAULT@SECONDS (pump_failure@3000)");
    };
    let at: f64 = at
        .parse()
        .ok()
        .filter(|x: &f64| x.is_finite() && *x >= 0.0)
        .ok_or_else(|| {
            StudyError::Message(format!("--fault {s:?}: {at:?} is not a time in seconds"))
        })?;
    Ok((name.to_owned(), at))
}
