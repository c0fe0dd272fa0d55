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

fn rules_file() -> String {
    format!("{ROOT}/hl-interface/rules/rulebases/station_ops.clp")
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
    let rules = k.spawn(&["rules", &rules_file()]);
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
    assert_eq!(
        before
            .iter()
            .map(|d| d["rule"].as_str().unwrap_or(""))
            .collect::<Vec<_>>(),
        ["ops-shed-hygiene", "ops-reduce-experiment-air"],
        "{s}"
    );
    assert!(
        before.iter().all(|d| d["reason"]
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
    k.spawn(&["rules", &rules_file()]);
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
