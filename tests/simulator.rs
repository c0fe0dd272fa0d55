//! The simulator daemon across processes: a planner process (`robosim simctl`) sends a joint
//! target to a running daemon in lock-step mode; a reader sees the resulting states in order;
//! `kill -9` of the daemon leaves the keeper serving, and a restarted daemon resumes from the
//! joint values committed in the Instance Space (the guarantee: high-rate state is the
//! daemon's alone and is not journaled).

use crate::common;

use common::{Procs, ROBOSIM, wait_for};
use robosim_instance_space::Client;
use robosim_instance_space::state::StateSubscriber;
use std::process::Command;
use std::time::Duration;

fn simctl(p: &Procs, cmds: &[&str]) {
    let st = Command::new(ROBOSIM)
        .arg("simctl")
        .args(["--session", &p.name])
        .args(cmds)
        .env("ROBOSIM_HOME", p.home.path())
        .status()
        .expect("simctl");
    assert!(st.success());
}

#[test]
fn planner_commands_a_lockstep_daemon_reader_sees_states_in_order_and_kill_9_restarts_from_committed_state()
 {
    let mut p = Procs::new("sim");
    let effects = p.home.path().join("effects.json");
    std::fs::write(
        &effects,
        r#"{"dt": 0.01, "max_speed": 1.0, "kinematics": true, "joint_limits": true}"#,
    )
    .expect("effects");
    let keeper = p.start_keeper(&["--scene", "puma560"]);
    let session = p.session();
    let eff = effects.to_str().expect("utf-8").to_owned();
    let daemon = p.spawn(&["simulator", "--mode", "lockstep", "--effects", &eff]);
    let mut state = wait_for("state service", || {
        StateSubscriber::open(&session, "simulator", "test-reader").ok()
    });
    wait_for("simulator registered", || {
        session
            .processes()
            .iter()
            .any(|x| x.role == "simulator")
            .then_some(())
    });

    // The planner: a target 0.5 rad away on two joints, then 100 steps of 10 ms.
    simctl(
        &p,
        &[
            r#"{"cmd": "target", "robot": "puma560", "q": [0.5, -0.5, 0, 0, 0, 0]}"#,
            r#"{"cmd": "step", "n": 100}"#,
        ],
    );
    let mut records = Vec::new();
    wait_for("100 states", || {
        records.extend(state.wait(Duration::from_millis(100)).expect("state"));
        (records.len() >= 100).then_some(())
    });
    let seqs: Vec<u64> = records.iter().map(|r| r.header.seq).collect();
    assert!(
        seqs.windows(2).all(|w| w[1] == w[0] + 1),
        "states in order, none missing: {seqs:?}"
    );
    assert!(records.windows(2).all(|w| w[1].header.t > w[0].header.t));
    let last = records.last().expect("records");
    assert!(
        (last.header.t - 1.0).abs() < 1e-9,
        "100 steps of 10 ms: t = {}",
        last.header.t
    );
    let q: Vec<f64> = last.joints.iter().map(|j| j.q).collect();
    assert!(
        (q[0] - 0.5).abs() < 1e-9 && (q[1] + 0.5).abs() < 1e-9,
        "target reached at 1 rad/s within 1 s: {q:?}"
    );
    let mid = &records[24];
    assert!(
        (mid.joints[0].q - 0.25).abs() < 1e-9,
        "speed-limited: 0.25 rad after 0.25 s, got {}",
        mid.joints[0].q
    );
    let v = last.header.structure_version;

    // kill -9 of the daemon: the keeper carries on.
    let _ = Command::new("kill")
        .args(["-KILL", &daemon.to_string()])
        .status();
    wait_for("daemon gone", || {
        (!robosim_instance_space::pid_alive(daemon)).then_some(())
    });
    assert!(robosim_instance_space::pid_alive(keeper));
    let mut c = Client::connect(&session, "writer").expect("keeper still serves");
    let mut tx = robosim_instance_space::Transaction::new();
    tx.set_name(1, "cell");
    assert_eq!(c.transact(&tx).expect("commit").version, v + 1);

    // Restart: it resumes from the committed joint values (zeros), at t = 0, seq 1.
    p.spawn(&["simulator", "--mode", "lockstep", "--effects", &eff]);
    wait_for("restarted daemon", || {
        session
            .processes()
            .iter()
            .any(|x| x.role == "simulator" && x.pid != daemon)
            .then_some(())
    });
    simctl(&p, &[r#"{"cmd": "step", "n": 1}"#]);
    let rec = wait_for("state after restart", || {
        state
            .wait(Duration::from_millis(100))
            .expect("state")
            .into_iter()
            .next()
    });
    assert_eq!(rec.header.seq, 1);
    assert_eq!(rec.header.structure_version, v + 1);
    assert!(
        rec.joints.iter().all(|j| j.q == 0.0),
        "uncommitted high-rate state is not recovered: {:?}",
        rec.joints
    );
}
