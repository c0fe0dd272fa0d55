//! The operational station as separate processes on one session (issue 38 item 7): the
//! simulator of scene space_station_ops, the rules process running station_ops.clp and the
//! dataflow process running momentum_manager.flow. They start in any order (rules and dataflow
//! before the simulator here); the rules shed by priority on the simulator's state and the
//! simulator acknowledges each decision; a SIGKILLed rules process, started again, catches up
//! with the state it missed and every decision acknowledged before stays; a SIGKILLed dataflow
//! process, started again, takes the current step. Every wait is on a condition (an
//! acknowledgement, a value), never on a time.

use crate::common;
use common::{Procs, wait_for};
use robosim_hl_interface::planner::Planner;
use robosim_instance_space::state::CommandSender;
use serde_json::{Value, json};
use std::process::Command;
use std::time::Duration;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The shipped rule base `station_ops` (eclss_guard.clp's fault rules, then station_ops.clp)
/// written where the processes of `k` run, as the launcher writes it for `rules=station_ops`.
fn rules_file(k: &Procs) -> String {
    let text = robosim_rules::embedded::shipped("station_ops.clp").expect("shipped");
    let path = k.home.path().join("station_ops.clp");
    std::fs::write(&path, text).expect("the rule file");
    path.display().to_string()
}

fn graph_file() -> String {
    format!("{ROOT}/automation/graphs/momentum_manager.flow")
}

fn kill(pid: u32) {
    let _ = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status();
    wait_for("the process gone", || {
        (!robosim_instance_space::pid_alive(pid)).then_some(())
    });
}

/// The rules' last acknowledged step.
fn rules_ack(s: &Value) -> Option<u64> {
    s.pointer("/space/ops/acks/rules").and_then(Value::as_u64)
}

fn mode(s: &Value, name: &str) -> String {
    s.pointer("/space/ops/consumers")
        .and_then(Value::as_array)
        .and_then(|cs| cs.iter().find(|c| c["name"] == name))
        .and_then(|c| c["mode"].as_str())
        .unwrap_or("?")
        .to_owned()
}

fn decisions(s: &Value) -> Vec<Value> {
    s.pointer("/space/ops/decisions")
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default()
}

/// The dataflow process's state once it has taken step `steps` of the simulator.
fn dataflow_at(k: &Procs, steps: u64) -> Value {
    let session = k.session();
    let mut sender: Option<CommandSender> = None;
    wait_for("the dataflow process at the simulator's step", || {
        if sender.is_none() {
            sender = CommandSender::open(&session, "dataflow", "ops-test").ok();
        }
        let answer = sender
            .as_mut()?
            .send(br#"{"cmd": "get"}"#, Duration::from_secs(5))
            .map_err(|_| sender = None)
            .ok()?;
        let v: Value = serde_json::from_slice(&answer).ok()?;
        (v.pointer("/values/steps")?.as_f64()? == steps as f64).then_some(v)
    })
}

#[test]
fn station_processes_start_in_any_order_and_a_killed_rules_or_dataflow_process_catches_up() {
    if robosim_rules::skipped_without_clips("operations::station_processes_start_in_any_order") {
        return;
    }
    let mut k = Procs::new("opsx");
    k.start_keeper(&["--scene", "space_station_ops"]);
    // rules and dataflow before the simulator: they wait for it
    let rules = k.spawn(&["rules", &rules_file(&k)]);
    let dataflow = k.spawn(&["dataflow", &graph_file()]);
    k.spawn(&["simulator", "--mode", "lockstep"]);
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    let s = wait_for("the rules acknowledge the simulator's first state", || {
        let s = p.sim_state().ok()?;
        (rules_ack(&s) == Some(0)).then_some(s)
    });
    assert!(
        decisions(&s).is_empty(),
        "nothing decided before a step: {s}"
    );
    assert!(
        s.pointer("/space/ops/attitude/capacity_nms")
            .and_then(Value::as_f64)
            .is_some_and(|c| (c - 4.0 * 4760.0).abs() < 1e-9),
        "the declared CMG cluster: {s}"
    );

    // An operator raises the base load to 170 kW: the predicted minimum falls below the
    // reserve; the rules shed hygiene, then reduce the experiment modules' air control — never
    // a vital consumer.
    p.sim_command(&json!({"cmd": "demand", "name": "station_base", "full_w": 170e3}))
        .expect("demand");
    p.sim_step(60).expect("60 steps");
    let s = wait_for("the rules acknowledge step 60", || {
        let s = p.sim_state().ok()?;
        (rules_ack(&s) == Some(60)).then_some(s)
    });
    assert_eq!(mode(&s, "hygiene"), "off", "{s}");
    assert_eq!(mode(&s, "air_experiment"), "reduced", "{s}");
    for vital in ["station_base", "air_crew", "potable_water"] {
        assert_eq!(mode(&s, vital), "full", "{vital}: {s}");
    }
    let before = decisions(&s);
    // hygiene first, then the running experiment (life_sciences, on its timetable from 0 s),
    // then the experiment modules' air (seed §4.2's order)
    assert_eq!(
        before
            .iter()
            .filter(|d| d["rule"] != "ops-move-out-of-window")
            .map(|d| d["rule"].as_str().unwrap_or(""))
            .collect::<Vec<_>>(),
        [
            "ops-shed-hygiene",
            "ops-stop-experiment-for-energy",
            "ops-reduce-experiment-air"
        ],
        "{s}"
    );
    assert!(
        before
            .iter()
            .filter(|d| d["rule"] != "ops-move-out-of-window")
            .all(|d| d["reason"]
                .as_str()
                .is_some_and(|r| r.contains("below the reserve"))),
        "each decision says why: {before:?}"
    );
    // the momentum manager took the same step: a finite, positive time to saturation
    let df = dataflow_at(&k, 60);
    let tts = df
        .pointer("/values/time_to_saturation")
        .and_then(Value::as_f64)
        .expect("time to saturation");
    assert!(tts.is_finite() && tts > 0.0, "{df}");

    // The rules process dies; the load drops to 60 kW; 60 steps pass with nobody deciding.
    kill(rules);
    p.sim_command(&json!({"cmd": "demand", "name": "station_base", "full_w": 60e3}))
        .expect("demand");
    let s = p.sim_step(60).expect("60 steps");
    assert_eq!(
        rules_ack(&s),
        Some(60),
        "no rules process acknowledges: {s}"
    );
    assert_eq!(
        mode(&s, "hygiene"),
        "off",
        "nothing restores without the rules: {s}"
    );
    assert_eq!(decisions(&s), before, "nothing decided while none runs");

    // Started again: it mirrors the state it missed, restores the loads (the experiment air
    // first, then hygiene) and acknowledges the current step; the decisions acknowledged
    // before are all still there, in order.
    k.spawn(&["rules", &rules_file(&k)]);
    let s = wait_for("the restarted rules acknowledge step 120", || {
        let s = p.sim_state().ok()?;
        (rules_ack(&s) == Some(120)).then_some(s)
    });
    assert_eq!(mode(&s, "air_experiment"), "full", "{s}");
    assert_eq!(mode(&s, "hygiene"), "full", "{s}");
    let after = decisions(&s);
    assert_eq!(
        &after[..before.len()],
        &before[..],
        "acknowledged decisions kept"
    );
    assert_eq!(
        after[before.len()..]
            .iter()
            .filter(|d| d["consumer"] == "air_experiment" || d["consumer"] == "hygiene")
            .map(|d| (d["rule"].as_str().unwrap_or(""), d["steps"].as_u64()))
            .collect::<Vec<_>>(),
        [
            ("ops-restore-experiment-air", Some(120)),
            ("ops-restore-hygiene", Some(120))
        ],
        "{s}"
    );
    let seqs: Vec<u64> = after.iter().filter_map(|d| d["seq"].as_u64()).collect();
    assert_eq!(seqs, (1..=after.len() as u64).collect::<Vec<_>>());

    // The dataflow process dies and 60 steps pass; started again it takes the current step.
    kill(dataflow);
    p.sim_step(60).expect("60 steps");
    k.spawn(&["dataflow", &graph_file()]);
    let df = dataflow_at(&k, 180);
    assert!(
        df.pointer("/values/h")
            .and_then(Value::as_f64)
            .is_some_and(|h| h > 0.0),
        "the momentum manager reads the CMG momentum again: {df}"
    );
}

/// `robosim up space_station_ops --with simulator,rules,dataflow,automation`: the bare rules and
/// dataflow components run what the scene names (station_ops.clp, the shipped
/// momentum_manager.flow, written into the session's run directory); `down` stops them all.
#[test]
fn up_space_station_ops_with_bare_rules_and_dataflow_starts_the_station_processes() {
    if robosim_rules::skipped_without_clips("operations::up_space_station_ops_with_bare_rules") {
        return;
    }
    let k = Procs::new("opsup");
    let down = common::Down(&k);
    let (ok, text) = common::robosim(
        &k,
        &[
            "up",
            "space_station_ops",
            "--with",
            "simulator,rules,dataflow,automation",
            "--sim-mode",
            "lockstep",
        ],
    );
    assert!(ok, "{text}");
    let mut roles: Vec<String> = k
        .session()
        .processes()
        .iter()
        .map(|p| p.role.clone())
        .collect();
    roles.sort();
    assert_eq!(
        roles,
        ["automation", "dataflow", "rules", "simulator", "space"],
        "{text}"
    );
    let run = k.session().run_dir();
    assert!(run.join("rulebases/station_ops.clp").is_file(), "{text}");
    assert_eq!(
        std::fs::read_to_string(run.join("graphs/momentum_manager.flow")).expect("graph written"),
        std::fs::read_to_string(graph_file()).expect("shipped graph")
    );
    // the processes work together: the rules acknowledge the simulator's step, the momentum
    // manager takes it
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    p.sim_step(5).expect("5 steps");
    wait_for("the rules acknowledge step 5", || {
        (rules_ack(&p.sim_state().ok()?) == Some(5)).then_some(())
    });
    dataflow_at(&k, 5);
    drop(down);
    assert!(k.session().processes().is_empty(), "down stops them all");
}

/// `robosim study operations` stopped by SIGTERM mid-run stops the session it started: the
/// processes `up` launched are not its children and used to be left running.
#[test]
fn a_terminated_operations_study_stops_the_session_it_started() {
    let mut k = Procs::new("opsterm");
    let out = k.home.path().join("out");
    let out = out.to_str().expect("utf-8 path").to_owned();
    let pid = k.spawn(&[
        "study",
        "operations",
        "-q",
        "--orbits",
        "20",
        "--scheduler",
        "off",
        "--out",
        &out,
    ]);
    let _down = common::Down(&k);
    // running: the simulator has taken steps the study asked for
    wait_for("the study's simulator stepping", || {
        let mut p = Planner::attach_to(&k.session()).ok()?;
        let s = p.sim_state().ok()?;
        (s["steps"].as_u64()? > 0).then_some(())
    });
    let _ = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status();
    wait_for("the study gone", || {
        (!robosim_instance_space::pid_alive(pid)).then_some(())
    });
    wait_for("the session's processes stopped", || {
        k.session().processes().is_empty().then_some(())
    });
}

fn consumer(s: &Value, name: &str) -> Value {
    s.pointer("/space/ops/consumers")
        .and_then(Value::as_array)
        .and_then(|cs| cs.iter().find(|c| c["name"] == name))
        .cloned()
        .unwrap_or(Value::Null)
}

/// The simulator's state once the rules acknowledged step `steps`.
fn acked(p: &mut Planner, steps: u64) -> Value {
    wait_for("the rules acknowledge the step", || {
        let s = p.sim_state().ok()?;
        (rules_ack(&s) == Some(steps)).then_some(s)
    })
}

/// Issue 38 item 4 on the session: a pump failure injected into the plant (alarms) and the
/// simulator (the unit's consumer) drops potable water to its standby demand; the rules
/// (station_ops.clp) diagnose the plant's alarms, isolate the pump and bring its spare on line
/// in the Instance Space; the simulator follows that commit — without restarting its clock —
/// and the consumer's spare starts (300 s), catches up at twice its demand, then runs as
/// before; the scheduler notes every change with the demand and its prediction.
#[test]
fn a_pump_failure_changes_potable_water_and_the_rules_bring_its_spare_on_line() {
    if robosim_rules::skipped_without_clips("operations::a_pump_failure_changes_potable_water") {
        return;
    }
    let mut k = Procs::new("opsf");
    k.start_keeper(&["--scene", "space_station_ops"]);
    k.spawn(&["automation"]);
    k.spawn(&["rules", &rules_file(&k)]);
    k.spawn(&["simulator", "--mode", "lockstep"]);
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    acked(&mut p, 0);
    p.sim_step(60).expect("60 steps");
    let s = acked(&mut p, 60);
    assert_eq!(consumer(&s, "potable_water")["full_w"], 5e3, "{s}");
    // the plant's units are there before the fault (the rules isolate among them)
    let session = k.session();
    let mut plant: Option<CommandSender> = None;
    wait_for("the plant takes the fault", || {
        if plant.is_none() {
            plant = CommandSender::open(&session, "automation", "ops-test").ok();
        }
        let a = plant
            .as_mut()?
            .send(
                br#"{"cmd": "fault", "fault": "pump_failure"}"#,
                Duration::from_secs(5),
            )
            .map_err(|_| plant = None)
            .ok()?;
        serde_json::from_slice::<Value>(&a)
            .ok()?
            .get("faults")
            .map(|_| ())
    });
    p.sim_command(&json!({"cmd": "fault", "fault": "pump_failure",
        "consumer": "potable_water", "components": ["water_pump"]}))
        .expect("the simulator takes the fault");
    let s = p.sim_state().expect("state");
    assert_eq!(
        consumer(&s, "potable_water")["full_w"],
        500.0,
        "failed: standby demand (10 %): {s}"
    );
    // the rules' diagnosis, isolation and spare, followed by the simulator at t = 60 s
    let s = wait_for("the spare on line in the simulator", || {
        let s = p.sim_state().ok()?;
        s.pointer("/space/ops/faults/0/spare_at_s")?
            .as_f64()
            .map(|_| s)
    });
    assert_eq!(s["space"]["ops"]["faults"][0]["spare_at_s"], 60.0, "{s}");
    assert_eq!(s["space"]["t_s"], 60.0, "the clock did not restart: {s}");
    let snap = p.snapshot().expect("snapshot");
    let parent = |n: &str| {
        let i = snap.find(n).expect("unit");
        let par = snap.index_of(snap.rec(i).parent).expect("parent");
        snap.name(par).to_owned()
    };
    assert_eq!(parent("water_pump"), "eclss_isolated");
    assert_eq!(parent("water_pump_spare"), "eclss");
    drop(snap);
    // the spare starts: still at standby 300 s after it came on line …
    p.sim_step(240).expect("steps");
    let s = acked(&mut p, 300);
    assert_eq!(consumer(&s, "potable_water")["full_w"], 500.0, "{s}");
    // … then catches up at twice the demand for as long as the unit stood still (300 s) …
    p.sim_step(120).expect("steps");
    let s = acked(&mut p, 420);
    let c = consumer(&s, "potable_water");
    assert_eq!(c["full_w"], 10e3, "{s}");
    assert!(
        c["served_w"].as_f64().is_some_and(|w| w > 9.99e3),
        "served in full: {c}"
    );
    // … and is repaired
    p.sim_step(300).expect("steps");
    let s = acked(&mut p, 720);
    assert_eq!(consumer(&s, "potable_water")["full_w"], 5e3, "{s}");
    assert_eq!(s["space"]["ops"]["faults"][0]["state"], "repaired", "{s}");
    let notes: Vec<String> = decisions(&s)
        .iter()
        .filter(|d| d["rule"] == "ops-fault-reaction")
        .map(|d| d["reason"].as_str().unwrap_or("").to_owned())
        .collect();
    for (state, kw) in [("catching-up", "10.0 kW"), ("repaired", "5.0 kW")] {
        assert!(
            notes
                .iter()
                .any(|n| n.contains(&format!("water_pump {state}"))
                    && n.contains(kw)
                    && n.contains("predicted minimum")),
            "the scheduler notes {state}: {notes:?}"
        );
    }
}

/// Issue 38 item 6 → the simulator: the momentum manager (dataflow) predicts saturation inside
/// a docking window that opens within its lead and commands the desaturation early; the
/// simulator starts it at once (recorded with the prediction as its reason), so the thrusters
/// do not fire during the docking. Without the command the cluster would saturate inside the
/// window (the prediction the window is laid around).
#[test]
fn the_momentum_manager_moves_a_desaturation_out_of_a_docking_window() {
    let mut k = Procs::new("opsd");
    k.start_keeper(&["--scene", "space_station_ops"]);
    k.spawn(&["dataflow", &graph_file()]);
    k.spawn(&["simulator", "--mode", "lockstep"]);
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    wait_for("the simulator", || p.sim_state().ok());
    // an orbit, so that the momentum's growth over it is known
    let s = p.sim_step(5580).expect("an orbit");
    let steps = s["space"]["ops"]["steps"].as_u64().expect("steps");
    let df = dataflow_at(&k, steps);
    let tts = df
        .pointer("/values/time_to_saturation")
        .and_then(Value::as_f64)
        .expect("time to saturation");
    let t = s["space"]["t_s"].as_f64().expect("t");
    assert!(
        s["space"]["ops"]["attitude"]["desaturations"] == 0 && tts > 1200.0 && tts < 3.0 * 5554.0,
        "no dump yet, one predicted within three orbits: {tts} s, {s}"
    );
    // a docking opens in 300 s and lasts until 600 s past the predicted saturation
    let (from, to) = (t + 300.0, t + tts + 600.0);
    p.sim_command(&json!({"cmd": "docking", "from_s": from, "to_s": to}))
        .expect("docking");
    let s = p.sim_step(60).expect("a minute");
    dataflow_at(&k, s["space"]["ops"]["steps"].as_u64().expect("steps"));
    let s = p.sim_step(60).expect("a minute");
    let d = decisions(&s);
    assert!(
        d.iter().any(|d| d["rule"] == "momentum_manager.flow"
            && d["mode"] == "desaturate"
            && d["reason"]
                .as_str()
                .is_some_and(|r| r.contains("inside the docking window"))),
        "the early desaturation recorded with its reason: {d:?}"
    );
    // through the window: the dump started before it, none during it
    let s = p
        .sim_step((to - s["space"]["t_s"].as_f64().expect("t")).ceil() as u64)
        .expect("through the window");
    let starts: Vec<f64> = s["space"]["ops"]["attitude"]["dump_starts_s"]
        .as_array()
        .expect("dump starts")
        .iter()
        .filter_map(Value::as_f64)
        .collect();
    assert!(
        starts.first().is_some_and(|&a| a < from),
        "a desaturation before the window ({from} s): {starts:?}"
    );
    assert!(
        starts.iter().all(|&a| a < from || a >= to),
        "none in the docking window {from}–{to} s: {starts:?}"
    );
}
