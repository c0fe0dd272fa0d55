//! Work follows the change, across processes (issue: "a MOVEJI of 30 steps then compiles the
//! robot once"). A real keeper and a real simulator daemon; this test process is the planner,
//! running the session ops of `robosim_hl_interface::session` against the keeper.
//!
//! * The planner's 30-step MOVEJI commits 30 joint-only transactions; its own compiled scene is
//!   compiled once and then only re-posed.
//! * The daemon follows every one of them without rebuilding a pipeline or re-parsing the
//!   Library Space (its counters, printed on SIGTERM), and its published state is the MOVEJI's
//!   last step. A structure change (a rename) does rebuild: the cache is not simply stuck.

use crate::common;

use common::{Procs, ROBOSIM, wait_for};
use robosim_hl_interface::session::Ops;
use robosim_instance_space::state::StateSubscriber;
use robosim_instance_space::{Client, Transaction};
use serde_json::json;
use std::process::Command;
use std::time::Duration;

fn simctl(p: &Procs, cmd: &str) {
    let st = Command::new(ROBOSIM)
        .args(["simctl", "--session", &p.name, cmd])
        .env("ROBOSIM_HOME", p.home.path())
        .status()
        .expect("simctl");
    assert!(st.success());
}

/// `(rebuilds, in place, library parses)` from the daemon's last line.
fn counters(log: &str) -> (u64, u64, u64) {
    let line = log
        .lines()
        .rev()
        .find(|l| l.contains("rebuild(s)"))
        .unwrap_or_else(|| panic!("no counters in the daemon's log:\n{log}"));
    let num_before = |what: &str| -> u64 {
        let head = &line[..line.find(what).expect(what)];
        let word = head.split_whitespace().last().expect("a number");
        word.parse()
            .unwrap_or_else(|_| panic!("{what} in {line:?}"))
    };
    (
        num_before(" rebuild(s)"),
        num_before(" change(s) applied in place"),
        num_before(" library parse(s)"),
    )
}

#[test]
fn a_30_step_moveji_compiles_once_and_the_daemon_follows_it_in_place() {
    let mut p = Procs::new("follow");
    let log = p.home.path().join("daemon.log");
    // The §2.7 cell: its effects (collision, encoders, logging) are declared in the Library
    // Space, so the daemon parses the library for them.
    p.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let session = p.session();
    let daemon = p.spawn_logged(&["simulator", "--mode", "lockstep"], &log);
    let mut state = wait_for("state service", || {
        StateSubscriber::open(&session, "simulator", "test-reader").ok()
    });
    // The daemon has built its pipelines from the start version once it publishes a step.
    wait_for("the daemon's first step", || {
        simctl(&p, r#"{"cmd": "step", "n": 1}"#);
        (!state
            .wait(Duration::from_millis(200))
            .expect("state")
            .is_empty())
        .then_some(())
    });

    // The planner: one MOVEJI of 30 steps, each step one acknowledged transaction.
    // from the folded start [0, 60°, -150°, 0, 0, 0] a little further from the head
    let target = [-0.3, 0.9, -2.4, 0.2, 0.1, 0.0];
    let mut ops = Ops::attach(&session).expect("attach the session ops");
    let moved = ops
        .dispatch(
            "moveji",
            &json!({"robot": "positioner", "q": target, "steps": 30}),
        )
        .expect("a session op")
        .expect("MOVEJI through free space");
    assert_eq!(moved["completed"], true, "{moved}");
    assert_eq!(moved["steps_done"], 30, "{moved}");
    let stats = ops.compiled().stats();
    assert_eq!(stats.compiles, 1, "compiled once for 30 steps: {stats:?}");
    // A CHECK after the 30 committed versions: the cache is keyed by structure, so it re-poses
    // (joint values and world poses) and compiles nothing.
    ops.dispatch("check", &json!({"robot": "positioner"}))
        .expect("a session op")
        .expect("check");
    let stats = ops.compiled().stats();
    assert_eq!(stats.compiles, 1, "still compiled once: {stats:?}");
    assert!(stats.pose_updates >= 1, "re-posed instead: {stats:?}");

    // The daemon adopts the committed joints (at rest) when it next looks: step it until its
    // published state is the MOVEJI's last step (no sleeping on a guess of how long it takes).
    let at_target = |q: &[f64]| q.iter().zip(target).all(|(a, b)| (a - b).abs() < 1e-12);
    wait_for("the daemon at the MOVEJI's last step", || {
        simctl(&p, r#"{"cmd": "step", "n": 1}"#);
        let recs = state.wait(Duration::from_millis(200)).expect("state");
        recs.last()
            .map(|r| r.joints.iter().map(|j| j.q).collect::<Vec<f64>>())
            .filter(|q| at_target(q))
    });

    // A structure change: the daemon must rebuild for it.
    let mut c = Client::connect(&session, "writer").expect("writer");
    let mut tx = Transaction::new();
    tx.set_name(1, "renamed");
    let v = c.transact(&tx).expect("rename").version;
    wait_for("the daemon on the renamed structure", || {
        simctl(&p, r#"{"cmd": "step", "n": 1}"#);
        let recs = state.wait(Duration::from_millis(200)).expect("state");
        recs.last()
            .filter(|r| r.header.structure_version >= v)
            .map(|_| ())
    });

    let status = p.stop(daemon);
    assert!(status.success(), "daemon stopped cleanly on SIGTERM");
    let text = std::fs::read_to_string(&log).expect("daemon log");
    let (rebuilds, in_place, parses) = counters(&text);
    assert_eq!(
        rebuilds, 2,
        "built at start and for the rename, never for a joint change:\n{text}"
    );
    assert!(
        in_place >= 1,
        "the MOVEJI's steps applied in place:\n{text}"
    );
    assert!(in_place <= 30, "at most one per committed version:\n{text}");
    assert_eq!(
        parses, 1,
        "the Library Space parsed once (its sources never changed):\n{text}"
    );
}

/// A paused daemon follows commits without stepping: `get` says which version its pipelines
/// follow (`version`) and at which version they last stepped (`stepped_version`, where each
/// robot's `contact` was computed), so a reader — the rules' clear-pose memory — never takes a
/// stale contact for the word on a newer commit.
#[test]
fn a_paused_daemon_says_its_contact_is_from_an_older_version() {
    let mut p = Procs::new("stepver");
    p.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let session = p.session();
    let log = p.home.path().join("daemon.log");
    let daemon = p.spawn_logged(&["simulator", "--mode", "lockstep"], &log);
    let mut ops = Ops::attach(&session).expect("attach the session ops");
    // `None` until the daemon answers (it makes its command service after it starts).
    let mut get = || -> Option<serde_json::Value> {
        ops.dispatch("sim_state", &json!({}))
            .expect("a session op")
            .ok()
    };
    // Step once so that there is a step to speak of (simctl fails until the daemon is there).
    let first = wait_for("the daemon's first step", || {
        let stepped = Command::new(ROBOSIM)
            .args(["simctl", "--session", &p.name, r#"{"cmd": "step", "n": 1}"#])
            .env("ROBOSIM_HOME", p.home.path())
            .stderr(std::process::Stdio::null())
            .status()
            .expect("simctl")
            .success();
        let g = get()?;
        (stepped && g["stepped_version"].as_u64() > Some(0)).then_some(g)
    });
    assert_eq!(first["stepped_version"], first["version"], "{first}");
    // A commit while it is idle (lock-step, nothing queued): followed, not stepped with.
    let mut c = Client::connect(&session, "writer").expect("writer");
    let view_q = {
        let snap = robosim_instance_space::Reader::attach(&session, "q")
            .expect("reader")
            .snapshot()
            .expect("snapshot");
        let r = snap.robot("positioner").expect("positioner");
        r.joints.iter().map(|j| (j.id, j.q)).collect::<Vec<_>>()
    };
    let mut tx = Transaction::new();
    tx.set_joint(view_q[0].0, view_q[0].1 + 0.01);
    let v = c.transact(&tx).expect("commit").version;
    let followed = wait_for("the daemon following the commit", || {
        let g = get()?;
        (g["version"].as_u64() >= Some(v)).then_some(g)
    });
    assert_eq!(followed["state"], "paused", "{followed}");
    assert!(
        followed["stepped_version"].as_u64() < Some(v),
        "no step since the commit, so its contact is not about it: {followed}"
    );
    // One step later it is.
    simctl(&p, r#"{"cmd": "step", "n": 1}"#);
    let stepped = wait_for("the step", || {
        let g = get()?;
        (g["stepped_version"].as_u64() >= Some(v)).then_some(g)
    });
    assert_eq!(stepped["stepped_version"], stepped["version"], "{stepped}");
    assert!(p.stop(daemon).success());
}

/// Issue 34 (messages): `sim_state` after the simulator was killed waited its whole 10 s
/// timeout and then said "no answer". A dead simulator is seen (iceoryx2 finds its node dead)
/// and named at once: the answer is the typed `session` error saying the simulator died, not
/// the timeout's.
#[test]
fn sim_state_of_a_killed_simulator_says_it_died_instead_of_timing_out() {
    let mut p = Procs::new("simdead");
    p.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let session = p.session();
    let daemon = p.spawn(&["simulator", "--mode", "lockstep"]);
    let mut ops = Ops::attach(&session).expect("attach the session ops");
    wait_for("the simulator's first answer", || {
        ops.dispatch("sim_state", &json!({}))
            .expect("a session op")
            .ok()
    });
    // Another process's sender, open when the simulator dies (a `simctl` or a planner in
    // the middle of a call): the command service outlives the simulator, so a request is
    // sent — and used to wait out the whole timeout for an answer that never came.
    let mut held =
        robosim_instance_space::state::CommandSender::open(&session, "simulator", "held")
            .expect("the simulator's command service");
    let _ = Command::new("kill")
        .args(["-KILL", &daemon.to_string()])
        .status();
    wait_for("the simulator gone", || {
        (!robosim_instance_space::pid_alive(daemon)).then_some(())
    });
    let dead = held
        .send(br#"{"cmd":"get"}"#, Duration::from_secs(120))
        .expect_err("no answer from a killed simulator");
    assert!(
        matches!(
            dead,
            robosim_instance_space::state::StateError::ReceiverDead { ref name, .. } if name == "simulator"
        ),
        "the sender sees the simulator dead (not a timeout): {dead}"
    );
    let e = ops
        .dispatch("sim_state", &json!({}))
        .expect("a session op")
        .expect_err("no state from a killed simulator");
    assert_eq!(e.kind, robosim_hl_interface::ErrorKind::Session, "{e}");
    assert!(
        e.message.contains("simulator") && e.message.contains("died"),
        "names the dead simulator: {e}"
    );
    assert!(
        !e.message.contains("no answer within"),
        "answered by the death seen, not by the timeout: {e}"
    );
}

/// The display's frame records (`frames.jsonl` in its output directory).
fn frames(dir: &std::path::Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("frames.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// Issue 34 item 4: with a simulator and a headless display running, `robosim edit 'delete
/// b'` of the newest object made both exit with "a published segment is malformed: section 1
/// is out of bounds". Both must follow the delete and the edits after it: each edit is seen by
/// the simulator (its `sim_state` version) and drawn by the display (a frame of that version),
/// and neither process exits.
#[test]
fn deleting_the_newest_object_keeps_the_simulator_and_the_display_following() {
    if robosim_display::skipped_without_vulkan(
        "deleting_the_newest_object_keeps_the_simulator_and_the_display_following",
    ) {
        return;
    }
    let mut p = Procs::new("newest");
    p.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let session = p.session();
    let daemon = p.spawn(&["simulator", "--mode", "lockstep"]);
    let out = p.home.path().join("display-out");
    let out_s = out.to_string_lossy().into_owned();
    let display = p.spawn(&["display", "--headless", "--size", "96x72", "--out", &out_s]);
    let mut ops = Ops::attach(&session).expect("attach the session ops");
    let mut sim_version = || -> Option<u64> {
        ops.dispatch("sim_state", &json!({}))
            .expect("a session op")
            .ok()
            .and_then(|v| v["version"].as_u64())
    };
    wait_for("the simulator's first answer", &mut sim_version);
    wait_for("the display's first frame", || {
        frames(&out).into_iter().next()
    });
    let mut c = Client::connect(&session, "probe").expect("client");
    let (home, name) = (p.home.path().to_owned(), p.name.clone());
    let mut edit = |k: usize, script: &str| -> u64 {
        let f = home.join(format!("edit{k}.edit"));
        std::fs::write(&f, format!("units cm\n{script}\n")).expect("script");
        let o = Command::new(ROBOSIM)
            .args(["edit", "--script", &f.to_string_lossy(), "--session", &name])
            .env("ROBOSIM_HOME", &home)
            .output()
            .expect("robosim edit");
        assert!(
            o.status.success(),
            "{script}: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        let model = c.snapshot().expect("the keeper's model").model;
        robosim_instance_space::journal::decode_store(&model)
            .expect("decode")
            .version
    };
    let steps = [
        "box a X = 10, Y = 10, Z = 10",
        "box b X = 5, Y = 5, Z = 5",
        // b is the newest object of the session.
        "delete b",
        "box c X = 4, Y = 4, Z = 4",
        "translate c X = 20",
        // c is the newest again.
        "delete c",
        "translate a Y = 5",
    ];
    for (k, script) in steps.iter().enumerate() {
        let v = edit(k, script);
        wait_for(
            &format!("the simulator following {script:?} (v{v})"),
            || (sim_version()? >= v).then_some(()),
        );
        wait_for(&format!("the display drawing {script:?} (v{v})"), || {
            frames(&out)
                .iter()
                .any(|f| f["version"].as_u64() >= Some(v))
                .then_some(())
        });
        for (pid, who) in [(daemon, "simulator"), (display, "display")] {
            let child = p
                .children
                .iter_mut()
                .find(|c| c.id() == pid)
                .expect("started here");
            assert!(
                child.try_wait().expect("try_wait").is_none(),
                "the {who} exited after {script:?}"
            );
        }
    }
    let log = |pid: u32, what: &str| {
        std::fs::read_to_string(p.home.path().join(format!("logs/{pid}-{what}.log")))
            .unwrap_or_default()
    };
    for (pid, what) in [(daemon, "simulator"), (display, "display")] {
        let text = log(pid, what);
        assert!(
            !text.contains("malformed"),
            "the {what} met a malformed segment:\n{text}"
        );
    }
}
