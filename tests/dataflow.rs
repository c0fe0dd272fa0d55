//! `robosim dataflow` (issue 38 item 6, issue 39 item 7), with real processes: the shipped
//! carriage servo (automation/graphs/carriage_servo.flow) on the station — the servicer's
//! carriage follows the spare ORU when a planner moves it; the dataflow process killed
//! (SIGKILL) while the set-point moves, restarted, catches up; the graph file edited while it
//! runs is reloaded with the unchanged actors kept; SIGTERM ends it at once, exit 0; and a
//! dataflow process started before the keeper waits for it.

use robosim_hl_interface::planner::Planner;
use robosim_instance_space::Transaction;
use std::process::Command;
use std::time::Duration;

use crate::common;

use common::{Down, Procs, robosim, wait_for};

const SERVO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/automation/graphs/carriage_servo.flow"
);

/// The scene the servo is written for, and the rail's offset (q = y + 25 m).
const SCENE: &str = "space_station_study";

fn carriage(p: &mut Planner) -> f64 {
    p.joints("servicer").expect("servicer joints")[0]
}

/// Moves the spare ORU to station y = `y` (one transaction).
fn move_spare(p: &mut Planner, y: f64) {
    let snap = p.snapshot().expect("snapshot");
    let i = snap.find("spare_oru").expect("spare_oru in the scene");
    let mut pose = snap.pose(i).pose;
    pose[7] = y;
    let mut tx = Transaction::new();
    tx.set_pose(snap.rec(i).id, pose);
    drop(snap);
    p.transact(&tx).expect("move the spare ORU");
}

/// Waits until the carriage stands at `q` (m) — the servo settled there.
fn carriage_reaches(p: &mut Planner, q: f64) {
    wait_for(&format!("the carriage at {q} m"), || {
        let _ = p.wait_change(Duration::from_millis(50));
        ((carriage(p) - q).abs() < 1e-6).then_some(())
    });
}

/// Writes `text` to `path` whole at once (a rename), so the process never reads half a file.
fn write_whole(path: &std::path::Path, text: &str) {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).expect("write the graph");
    std::fs::rename(&tmp, path).expect("replace the graph");
}

fn wait_role(k: &Procs, role: &str) {
    let session = k.session();
    wait_for(role, || {
        session
            .processes()
            .iter()
            .any(|p| p.role == role)
            .then_some(())
    });
}

fn log_of(k: &Procs, pid: u32) -> String {
    std::fs::read_to_string(k.home.path().join(format!("logs/{pid}-dataflow.log")))
        .unwrap_or_default()
}

#[test]
fn the_carriage_servo_follows_its_set_point_restarts_and_reloads() {
    let mut k = Procs::new("dflow");
    k.start_keeper(&["--scene", SCENE]);
    let graph = k.home.path().join("servo.flow");
    std::fs::copy(SERVO, &graph).expect("copy the graph");
    let graph_arg = graph.to_str().expect("utf-8 path").to_owned();
    let mut p = Planner::attach_to(&k.session()).expect("planner");
    assert_eq!(carriage(&mut p), 20.0, "the scene's carriage position");
    // The spare ORU near the carriage (y = -4 m: 21 m on the rail), so that each move below
    // takes the servo a few passes (at most 0.1 m a pass), not hundreds: a loaded machine
    // commits slowly.
    move_spare(&mut p, -4.0);

    // The servo brings the carriage to the spare ORU.
    let pid = k.spawn(&["dataflow", &graph_arg]);
    wait_role(&k, "dataflow");
    carriage_reaches(&mut p, 21.0);

    // A planner moves the set-point: the carriage follows.
    move_spare(&mut p, -3.0);
    carriage_reaches(&mut p, 22.0);

    // Killed outright, the process writes nothing more: a moved set-point is not followed…
    let _ = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status();
    let _ = k
        .children
        .iter_mut()
        .find(|c| c.id() == pid)
        .map(|c| c.wait());
    move_spare(&mut p, -2.0);
    std::thread::sleep(Duration::from_millis(300));
    assert!((carriage(&mut p) - 22.0).abs() < 1e-6);
    // …until it is started again: it catches up from the committed state.
    let pid = k.spawn(&["dataflow", &graph_arg]);
    carriage_reaches(&mut p, 23.0);

    // The file edited while it runs: only the set-point actor changes (the rail's zero moves
    // 1 m); the other actors are kept with their state, and the carriage moves 1 m.
    let text = std::fs::read_to_string(&graph).expect("read the graph");
    let edited = text.replace("k=1 b=25", "k=1 b=26");
    assert_ne!(text, edited);
    write_whole(&graph, &edited);
    carriage_reaches(&mut p, 24.0);
    let log = log_of(&k, pid);
    assert!(
        log.contains("reloaded: kept error control limit move rail; replaced setpoint"),
        "{log}"
    );

    // A file with an error is said with its line, and the running graph goes on.
    write_whole(&graph, &text.replace("actor move", "actor move move"));
    wait_for("the error said", || {
        log_of(&k, pid).contains("servo.flow:").then_some(())
    });
    assert!(log_of(&k, pid).contains("the running graph goes on"));
    move_spare(&mut p, -1.5);
    carriage_reaches(&mut p, 24.5);

    // SIGTERM: a clean exit, 0.
    let status = k.stop(pid);
    assert!(status.success(), "{status}");
    assert!(log_of(&k, pid).contains("dataflow: stopped"));
}

#[test]
fn a_dataflow_process_started_before_the_keeper_waits_for_it() {
    let mut k = Procs::new("dflowfirst");
    // A session that exists (its keeper ran once) but has no keeper now.
    let keeper = k.start_keeper(&["--scene", SCENE]);
    // The spare ORU near the carriage (21 m on the rail): journaled, the next keeper has it.
    move_spare(
        &mut Planner::attach_to(&k.session()).expect("planner"),
        -4.0,
    );
    assert!(k.stop(keeper).success());
    let pid = k.spawn(&["dataflow", SERVO]);
    wait_for("the dataflow process waiting", || {
        log_of(&k, pid)
            .contains("waiting for the keeper")
            .then_some(())
    });
    k.start_keeper(&["--scene", SCENE]);
    let mut p = Planner::attach_to(&k.session()).expect("planner");
    carriage_reaches(&mut p, 21.0);
    assert!(k.stop(pid).success());
}

#[test]
fn up_with_dataflow_runs_the_graph_and_down_stops_it_by_sigterm() {
    let k = Procs::new("dflowup");
    let (ok, text) = robosim(&k, &["up", SCENE, "--with", "dataflow"]);
    assert!(!ok && text.contains("--with dataflow=FILE"), "{text}");
    let (ok, text) = robosim(&k, &["up", SCENE, "--with", "dataflow=/no/such.flow"]);
    assert!(!ok && text.contains("no such graph file"), "{text}");
    let down = Down(&k);
    let with = format!("dataflow={SERVO}");
    let (ok, text) = robosim(&k, &["up", SCENE, "--with", &with]);
    assert!(ok, "{text}");
    assert!(text.contains("dataflow"), "ps lists it: {text}");
    let mut p = Planner::attach_to(&k.session()).expect("planner");
    // The servo drives the carriage toward the spare ORU (39 m on the rail), 0.1 m a pass.
    wait_for("the carriage driven", || {
        let _ = p.wait_change(Duration::from_millis(50));
        (carriage(&mut p) >= 20.5).then_some(())
    });
    let (ok, text) = robosim(&k, &["down"]);
    assert!(ok, "{text}");
    assert!(text.contains("stopped dataflow (pid"), "{text}");
    assert!(!text.contains("SIGKILL"), "{text}");
    drop(down);
}

#[test]
fn passes_n_runs_n_passes_and_exits_0() {
    let mut k = Procs::new("dflowpasses");
    k.start_keeper(&["--scene", SCENE]);
    let (ok, text) = robosim(&k, &["dataflow", SERVO, "--passes", "5"]);
    assert!(ok, "{text}");
    assert!(
        text.contains("stopped after 5 passes (5 written)"),
        "{text}"
    );
    let mut p = Planner::attach_to(&k.session()).expect("planner");
    // Five passes of at most 0.1 m each.
    assert!(
        (carriage(&mut p) - 20.5).abs() < 1e-9,
        "{}",
        carriage(&mut p)
    );
}
