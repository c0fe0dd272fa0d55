//! `robosim rules` (issue 16), with real processes:
//! * a CLIPS rule base reacting to a change within one notification: a planner sets the
//!   positioner's waist past joint_guard.clp's soft limit; the very next commit is the rule's
//!   transaction setting it back to the limit, and it is journaled (a restarted keeper has it);
//! * joint_guard.clp's contact rule: the simulator reports a contact, the rules pause it and
//!   command the robot back to its last clear joints — the pause ordered before the back-off
//!   commit by the Instance Space version the simulator's `paused_at` carries;
//! * eclss_guard.clp on the automation plant (`robosim automation`): an injected ECLSS fault
//!   rings alarms, the rules diagnose them, isolate the faulty unit and then bring its spare on
//!   line — two transactions, in that order, journaled — and the plant's alarms stop;
//! * the launcher: `robosim up station_eclss` starts the plant the scene declares (and
//!   `up SCENE --with automation` one a scene does not), `ps` lists it, a fault injected into
//!   it rings, `down` stops it.

use robosim_hl_interface::planner::Planner;
use std::process::Command;
use std::time::Duration;

use crate::common;

use common::{Down, Procs, ROBOSIM, robosim, wait_for};

const RULES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/hl-interface/rules/rulebases/joint_guard.clp"
);
const ECLSS_RULES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/hl-interface/rules/rulebases/eclss_guard.clp"
);

/// Waits until a process with `role` is registered in the session.
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

/// A session of its own (`tag`) with a keeper on the surgical-positioner cell and then each of
/// `components` (`robosim ARGS`, whose first word is the role it registers as), each waited for
/// in turn; the keeper's pid first, then the components'.
fn session_with(tag: &str, components: &[&[&str]]) -> (Procs, Vec<u32>) {
    let mut k = Procs::new(tag);
    let mut pids = vec![k.start_keeper(&["--scene", "surgical_positioner_cell"])];
    for args in components {
        pids.push(k.spawn(args));
        wait_role(&k, args[0]);
    }
    (k, pids)
}

/// Drains the commits already made (the rules' start-up mirror makes none, the plant's set-up
/// one): returns when nothing is committed for 300 ms.
fn settle(p: &mut Planner) {
    while p
        .wait_change(Duration::from_millis(300))
        .expect("wait")
        .is_some()
    {}
}

/// The next commits after the planner's last seen version, until `n` more arrived (20 s at most).
fn next_commits(p: &mut Planner, n: usize) -> Vec<robosim_hl_interface::planner::ChangeInfo> {
    let mut seen = Vec::new();
    while seen.len() < n {
        let c = p
            .wait_change(Duration::from_secs(20))
            .expect("wait")
            .unwrap_or_else(|| panic!("{n} commits within 20 s, got {seen:?}"));
        seen.extend(c.changes);
    }
    seen
}

/// The parent's name of object `name` in the newest snapshot.
fn parent_of(p: &mut Planner, name: &str) -> String {
    let snap = p.snapshot().expect("snapshot");
    let i = snap
        .find(name)
        .unwrap_or_else(|| panic!("no object {name}"));
    let parent = snap.rec(i).parent;
    snap.index_of(parent)
        .map(|k| snap.name(k).to_owned())
        .unwrap_or_default()
}

#[test]
fn an_eclss_fault_is_diagnosed_isolated_then_reconfigured_in_order_and_journaled() {
    if robosim_rules::skipped_without_clips(
        "rules::an_eclss_fault_is_diagnosed_isolated_then_reconfigured_in_order_and_journaled",
    ) {
        return;
    }
    let (mut k, pids) = session_with(
        "rulesec",
        &[&["automation"], &["rules", ECLSS_RULES, "--watch", "rules"]],
    );
    let [keeper, plant, rules] = pids[..] else {
        unreachable!("a keeper and two components")
    };
    let session = k.session();
    let mut p = Planner::attach_to(&session).expect("attach");
    settle(&mut p);
    // The plant's units are in the session: on line, spares, none isolated.
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed"), "eclss");
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed_spare"), "eclss_spares");
    let before = p.snapshot().expect("snapshot").version();
    let state = p
        .plant_command(&serde_json::json!({"cmd": "fault", "fault": "sorbent_bed_failure"}))
        .expect("inject the fault");
    let alarms = state["alarms"].as_array().expect("alarms");
    assert_eq!(
        alarms[0]["alarm"], "A_co2_bed",
        "the fault's own alarm rings at once"
    );
    // Unknown and derived failure modes are refused, and change nothing.
    assert!(
        p.plant_command(&serde_json::json!({"cmd": "fault", "fault": "no_such_fault"}))
            .is_err()
    );
    assert!(
        p.plant_command(&serde_json::json!({"cmd": "fault", "fault": "co2_not_removed"}))
            .is_err()
    );
    let seen = next_commits(&mut p, 2);
    let versions: Vec<u64> = seen.iter().map(|c| c.version).collect();
    assert_eq!(
        versions,
        vec![before + 1, before + 2],
        "nothing between: {seen:?}"
    );
    assert_eq!(
        seen[0].names,
        vec!["co2_sorbent_bed"],
        "first the isolation"
    );
    assert_eq!(
        seen[1].names,
        vec!["co2_sorbent_bed_spare"],
        "then the reconfiguration"
    );
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed"), "eclss_isolated");
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed_spare"), "eclss");
    // The plant follows the committed model: the fault is contained and repaired, its alarms
    // stop ringing.
    let state = wait_for("the plant to see the repair", || {
        let s = p
            .plant_command(&serde_json::json!({"cmd": "get"}))
            .expect("plant state");
        (s["faults"][0]["repaired"] == true).then_some(s)
    });
    assert_eq!(state["faults"][0]["contained"], true);
    assert_eq!(state["alarms"], serde_json::json!([]));
    assert_eq!(state["isolated"], serde_json::json!(["co2_sorbent_bed"]));
    // Nothing more is done once the alarms are handled.
    assert!(
        p.wait_change(Duration::from_millis(500))
            .expect("wait")
            .is_none()
    );
    drop(p);
    k.stop(rules);
    k.stop(plant);
    k.stop(keeper);
    k.start_keeper(&[]);
    let mut p = Planner::attach_to(&k.session()).expect("attach again");
    assert_eq!(
        p.snapshot().expect("snapshot").version(),
        before + 2,
        "both journaled"
    );
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed"), "eclss_isolated");
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed_spare"), "eclss");
}

#[test]
fn a_contact_pauses_the_simulator_and_backs_the_robot_off_to_its_clear_joints() {
    if robosim_rules::skipped_without_clips(
        "rules::a_contact_pauses_the_simulator_and_backs_the_robot_off_to_its_clear_joints",
    ) {
        return;
    }
    // A free-running simulator: the rule's pause is what stops it.
    let (mut k, pids) = session_with("rulesct", &[&["simulator", "--mode", "realtime"]]);
    let [keeper, sim] = pids[..] else {
        unreachable!("a keeper and one component")
    };
    let session = k.session();
    let mut p = Planner::attach_to(&session).expect("attach");
    let st = wait_for("the simulator's commands", || p.sim_state().ok());
    assert_eq!(st["running"], true);
    assert_eq!(st["robots"][0]["contact"], false, "clear at the start");
    // A configuration that touches the head, found with the session's own CHECK: the shoulder
    // swung from the folded start towards the head (moves unchecked) until CHECK reports a
    // contact; then back to the start.
    let clear = p.joints("positioner").expect("joints");
    p.query(&serde_json::json!({"op": "c_switch", "on": false}))
        .expect("c_switch");
    let hit = (1..=40)
        .map(|k| {
            let mut q = clear.clone();
            q[1] = clear[1] + 0.05 * k as f64;
            q
        })
        .find(|q| {
            p.query(&serde_json::json!({"op": "movej", "robot": "positioner", "q": q}))
                .expect("movej");
            let r = p
                .query(&serde_json::json!({"op": "check", "robot": "positioner"}))
                .expect("check");
            r["status"] == "contact"
        })
        .expect("a joint configuration touching the head");
    p.query(&serde_json::json!({"op": "movej", "robot": "positioner", "q": clear}))
        .expect("back to the start");
    wait_for("the simulator to see the start joints clear", || {
        let st = p.sim_state().ok()?;
        (st["robots"][0]["contact"] == false && st["version"] == p.snapshot().ok()?.version())
            .then_some(())
    });
    let rules = k.spawn(&["rules", RULES, "--watch", "facts,rules"]);
    wait_role(&k, "rules");
    settle(&mut p);
    let v = p.set_joints("positioner", &hit).expect("move into contact");
    // The simulator takes the committed joints and finds the contact on its next step; the
    // rules pause it, then command the robot back.
    let seen = next_commits(&mut p, 2);
    let versions: Vec<u64> = seen.iter().map(|c| c.version).collect();
    assert_eq!(
        versions,
        vec![v, v + 1],
        "ours, then the rule's, nothing between"
    );
    let after = p.joints("positioner").expect("joints");
    assert_eq!(after, clear, "backed off to the last clear joints");
    // The pause and the back-off travel on different channels, so seeing the back-off says
    // nothing about the pause: wait for it, then order it by the newest committed version it
    // carries: after our contact commit, before the rule's back-off (joint_guard.clp pauses
    // first).
    let st = wait_for("the simulator paused", || {
        let st = p.sim_state().ok()?;
        (st["running"] == false).then_some(st)
    });
    assert_eq!(st["paused_at"]["cause"], "command", "{st}");
    assert_eq!(
        st["paused_at"]["version"],
        v,
        "paused after the contact commit {v} and before the back-off commit {}: {st}",
        v + 1
    );
    assert!(
        st["robots"][0]["contact_steps"].as_u64().unwrap_or(0) > 0,
        "it had seen the contact: {st}"
    );
    // Handled once: no further commit.
    assert!(
        p.wait_change(Duration::from_millis(500))
            .expect("wait")
            .is_none()
    );
    drop(p);
    k.stop(rules);
    k.stop(sim);
    k.stop(keeper);
}

#[test]
fn a_rule_sets_a_joint_back_in_the_next_commit_and_it_is_journaled() {
    if robosim_rules::skipped_without_clips(
        "rules::a_rule_sets_a_joint_back_in_the_next_commit_and_it_is_journaled",
    ) {
        return;
    }
    let (mut k, pids) = session_with("rules", &[&["rules", RULES]]);
    let [keeper, rules] = pids[..] else {
        unreachable!("a keeper and one component")
    };
    let session = k.session();
    let mut p = Planner::attach_to(&session).expect("attach");
    // The rules mirror the session when they start; let that settle (no commit expected:
    // the waist starts inside its soft limit).
    settle(&mut p);
    let mut q = p.joints("positioner").expect("joints");
    q[0] = 1.0;
    let v = p
        .set_joints("positioner", &q)
        .expect("set past the soft limit");
    let mut seen = Vec::new();
    while seen
        .last()
        .is_none_or(|c: &robosim_hl_interface::planner::ChangeInfo| c.version <= v)
    {
        let c = p
            .wait_change(Duration::from_secs(20))
            .expect("wait")
            .expect("the rule's transaction within 20 s");
        seen.extend(c.changes);
    }
    let versions: Vec<u64> = seen.iter().map(|c| c.version).collect();
    assert_eq!(
        versions,
        vec![v, v + 1],
        "ours, then the rule's, nothing between"
    );
    assert_eq!(seen[1].names[0], "waist");
    let after = p.snapshot().expect("snapshot");
    assert_eq!(after.version(), v + 1);
    let q_after = robosim_hl_interface::planner::joints_of(&after, "positioner").expect("joints");
    assert_eq!(q_after[0], 0.8, "set back to the soft limit");
    assert_eq!(q_after[1..], q[1..], "the other joints untouched");
    // No further commit: the rule does not fire again on its own write.
    assert!(
        p.wait_change(Duration::from_millis(500))
            .expect("wait")
            .is_none()
    );
    drop(after);
    drop(p);
    k.stop(rules);
    k.stop(keeper);
    k.start_keeper(&[]);
    let mut p = Planner::attach_to(&k.session()).expect("attach again");
    let snap = p.snapshot().expect("snapshot");
    assert_eq!(
        snap.version(),
        v + 1,
        "the rule's transaction was journaled"
    );
    assert_eq!(p.joints("positioner").expect("joints")[0], 0.8);
}

/// The roles `robosim ps --json` lists, with their pids.
fn ps(k: &Procs) -> Vec<(String, u32)> {
    let (ok, text) = robosim(k, &["ps", "--json"]);
    assert!(ok, "{text}");
    let v: serde_json::Value = serde_json::from_str(text.trim()).expect("ps --json");
    v["processes"]
        .as_array()
        .expect("processes")
        .iter()
        .map(|p| {
            (
                p["role"].as_str().unwrap_or_default().to_owned(),
                p["pid"].as_u64().unwrap_or(0) as u32,
            )
        })
        .collect()
}

#[test]
fn up_starts_the_eclss_plant_a_scene_declares_or_with_names_and_down_stops_it() {
    let k = Procs::new("upeclss");
    let down = Down(&k);
    let (ok, text) = robosim(&k, &["up", "station_eclss"]);
    assert!(ok, "{text}");
    let procs = ps(&k);
    let roles: Vec<&str> = procs.iter().map(|(r, _)| r.as_str()).collect();
    assert_eq!(
        roles,
        vec!["space", "automation"],
        "the scene's plant is started: {text}"
    );
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    // The plant the scene declares: its model and time scale.
    let st = p
        .plant_command(&serde_json::json!({"cmd": "get"}))
        .expect("the plant answers");
    assert_eq!(st["model"], "eclss");
    assert_eq!(st["time_scale"], 60.0, "station_eclss's time_scale");
    assert_eq!(st["alarms"], serde_json::json!([]));
    assert_eq!(parent_of(&mut p, "co2_sorbent_bed"), "eclss");
    assert!(
        p.snapshot()
            .expect("snapshot")
            .find("middle_truss")
            .is_some(),
        "and the scene itself"
    );
    let st = p
        .plant_command(&serde_json::json!({"cmd": "fault", "fault": "sorbent_bed_failure"}))
        .expect("inject the fault");
    assert_eq!(st["alarms"][0]["alarm"], "A_co2_bed", "{st}");
    let st = p
        .plant_command(&serde_json::json!({"cmd": "get"}))
        .expect("plant state");
    assert_eq!(st["alarms"][0]["alarm"], "A_co2_bed", "still ringing: {st}");
    drop(p);
    drop(down);
    for (role, pid) in &procs {
        assert!(
            !robosim_instance_space::pid_alive(*pid),
            "down stopped {role} (pid {pid})"
        );
    }
    assert!(ps(&k).is_empty(), "nothing left registered");

    // A scene that declares no plant gets one with --with: the default model at the wall clock.
    let k = Procs::new("upwith");
    let down = Down(&k);
    let (ok, text) = robosim(&k, &["up", "demo"]);
    assert!(ok, "{text}");
    assert_eq!(ps(&k).len(), 1, "demo declares no plant: the keeper alone");
    let (ok, text) = robosim(&k, &["up", "demo", "--with", "automation"]);
    assert!(ok, "{text}");
    let procs = ps(&k);
    assert_eq!(
        procs.iter().map(|(r, _)| r.as_str()).collect::<Vec<_>>(),
        vec!["space", "automation"]
    );
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    let st = p
        .plant_command(&serde_json::json!({"cmd": "get"}))
        .expect("the plant answers");
    assert_eq!(
        (&st["model"], &st["time_scale"]),
        (&serde_json::json!("eclss"), &serde_json::json!(1.0))
    );
    drop(p);
    let (ok, text) = robosim(&k, &["down"]);
    assert!(ok && text.contains("stopped automation"), "{text}");
    drop(down);
    for (role, pid) in &procs {
        assert!(!robosim_instance_space::pid_alive(*pid), "{role} stopped");
    }
}

/// Writes `text` as a rule file in the session's home; its path.
fn rule_file(k: &Procs, name: &str, text: &str) -> String {
    let path = k.home.path().join(name);
    std::fs::write(&path, text).expect("rule file");
    path.display().to_string()
}

/// The log of the process `pid` started by `Procs::spawn` (role `role`).
fn log_of(k: &Procs, pid: u32, role: &str) -> String {
    std::fs::read_to_string(k.home.path().join("logs").join(format!("{pid}-{role}.log")))
        .unwrap_or_default()
}

/// Waits (60 s at most) for the child `pid` this test started to exit; its status.
fn exit_of(k: &mut Procs, pid: u32) -> std::process::ExitStatus {
    let i = k
        .children
        .iter()
        .position(|c| c.id() == pid)
        .expect("a process this test started");
    let mut c = k.children.remove(i);
    wait_for("the rules process to end", || c.try_wait().expect("wait"))
}

/// Issue 34 item 5: `(robosim set-joint positioner 3 (/ 0.0 0.0))` printed "divide by zero …
/// Execution halted" and still committed joint 3 = 1.0.
#[test]
fn a_failed_clips_expression_in_a_robosim_call_commits_nothing() {
    if robosim_rules::skipped_without_clips(
        "rules::a_failed_clips_expression_in_a_robosim_call_commits_nothing",
    ) {
        return;
    }
    let mut k = Procs::new("rulesdiv");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    let before = p.snapshot().expect("snapshot");
    let q0 = robosim_hl_interface::planner::joints_of(&before, "positioner").expect("joints");
    let v0 = before.version();
    drop(before);
    let file = rule_file(
        &k,
        "div.clp",
        "(defrule bad (space (version ?v)) => (robosim set-joint positioner 3 (/ 0.0 0.0)))\n\
         (defrule inf (declare (salience 10)) (space (version ?v)) => (robosim set-joint positioner 2 (* 1e308 10.0)))\n",
    );
    let rules = k.spawn(&["rules", &file]);
    // Registered once its first pass (where both rules fired) is over.
    wait_role(&k, "rules");
    assert!(
        p.wait_change(Duration::from_millis(300))
            .expect("wait")
            .is_none(),
        "nothing committed"
    );
    let after = p.snapshot().expect("snapshot");
    assert_eq!(after.version(), v0, "no transaction");
    assert_eq!(
        robosim_hl_interface::planner::joints_of(&after, "positioner").expect("joints"),
        q0
    );
    drop(after);
    k.stop(rules);
    let log = log_of(&k, rules, "rules");
    assert!(
        log.contains(
            "(robosim set-joint …) failed: argument 4 of (robosim set-joint …) did not evaluate"
        ),
        "the failed argument is named: {log}"
    );
    assert!(
        log.contains("the joint value (argument 3) is not a finite number: inf"),
        "a non-finite value is refused: {log}"
    );
}

/// Issue 34 item 16: a rule whose right-hand side never ends hung the process for good (and
/// ignored SIGTERM). It is halted on the time limit, and the process fails naming the rule.
#[test]
fn an_endless_right_hand_side_stops_on_the_time_limit_with_an_error_naming_the_rule() {
    if robosim_rules::skipped_without_clips(
        "rules::an_endless_right_hand_side_stops_on_the_time_limit_with_an_error_naming_the_rule",
    ) {
        return;
    }
    let mut k = Procs::new("rulesspin");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let file = rule_file(
        &k,
        "spin.clp",
        "(defrule spin (space) => (while TRUE do (+ 1 1)))\n",
    );
    let rules = k.spawn(&["rules", &file, "--time-limit", "0.5"]);
    let status = exit_of(&mut k, rules);
    let log = log_of(&k, rules, "rules");
    assert_eq!(status.code(), Some(1), "a failure, not a signal: {log}");
    assert!(
        log.contains("rule spin: ran past the time limit of 500ms of rule execution in one pass"),
        "{log}"
    );
}

/// Issue 34 item 16: SIGTERM to a rules process inside an endless rule was ignored (`down`
/// waited 10 s and sent SIGKILL). It halts the rule; the process ends with exit 0 and says why.
#[test]
fn sigterm_halts_an_endless_rule_and_the_rules_process_exits_0() {
    if robosim_rules::skipped_without_clips(
        "rules::sigterm_halts_an_endless_rule_and_the_rules_process_exits_0",
    ) {
        return;
    }
    let mut k = Procs::new("rulesterm");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let file = rule_file(
        &k,
        "spin.clp",
        "(defrule spin (space) => (printout t \"spinning\" crlf) (while TRUE do (+ 1 1)))\n",
    );
    let rules = k.spawn(&["rules", &file, "--time-limit", "3600"]);
    // What the rule printed shows while it runs (flushed on the engine's periodic check).
    wait_for("the rule to run", || {
        log_of(&k, rules, "rules")
            .contains("spinning")
            .then_some(())
    });
    let status = k.stop(rules);
    let log = log_of(&k, rules, "rules");
    assert!(status.success(), "{status}: {log}");
    assert!(
        log.contains("rules: a termination request (SIGTERM/SIGINT) halted rule spin; stopped"),
        "{log}"
    );
}

/// Issue 34 item 16: deep recursion overflowed the stack and a string doubled 40 times
/// segfaulted the rules process; each is now an error naming the rule, and the process exits
/// with a failure, not a signal.
#[test]
fn deep_recursion_and_a_string_doubled_forty_times_are_errors_not_crashes() {
    if robosim_rules::skipped_without_clips(
        "rules::deep_recursion_and_a_string_doubled_forty_times_are_errors_not_crashes",
    ) {
        return;
    }
    let mut k = Procs::new("rulesmem");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let cases = [
        (
            "deep.clp",
            "(deffunction down (?n) (+ 1 (down (+ ?n 1))))\n(defrule dive (space) => (down 0))\n",
            "rule dive: deffunction down called",
        ),
        (
            "grow.clp",
            "(defrule grow (space) => (bind ?s \"ab\") (loop-for-count 40 (bind ?s (str-cat ?s ?s))))\n",
            "rule grow: CLIPS asked for",
        ),
    ];
    for (name, text, says) in cases {
        let file = rule_file(&k, name, text);
        let rules = k.spawn(&["rules", &file, "--max-memory", "64"]);
        let status = exit_of(&mut k, rules);
        let log = log_of(&k, rules, "rules");
        assert_eq!(
            status.code(),
            Some(1),
            "{name}: an error, not a crash: {log}"
        );
        assert!(log.contains(says), "{name}: {log}");
    }
}

/// Issue 34 item 16: `robosim down` with the shipped rule bases running took 10 s (the rules
/// processes were SIGKILLed after ignoring SIGTERM). They end on SIGTERM.
#[test]
fn down_stops_the_shipped_rule_bases_by_sigterm() {
    if robosim_rules::skipped_without_clips("rules::down_stops_the_shipped_rule_bases_by_sigterm") {
        return;
    }
    let k = Procs::new("rulesdown");
    let down = Down(&k);
    let (ok, text) = robosim(&k, &["up", "station_eclss"]);
    assert!(ok, "{text}");
    let mut k2 = Procs {
        children: Vec::new(),
        home: tempfile::tempdir().expect("unused home"),
        name: k.name.clone(),
    };
    for file in [RULES, ECLSS_RULES] {
        let c = Command::new(ROBOSIM)
            .args(["rules", file, "--session", &k.name])
            .env("ROBOSIM_HOME", k.home.path())
            .env("IOX2_LOG_LEVEL", "Error")
            .spawn()
            .expect("rules");
        k2.children.push(c);
    }
    wait_for("both rule bases registered", || {
        (ps(&k).iter().filter(|(r, _)| r == "rules").count() == 2).then_some(())
    });
    let (ok, text) = robosim(&k, &["down"]);
    assert!(ok, "{text}");
    assert_eq!(text.matches("stopped rules (pid").count(), 2, "{text}");
    assert!(!text.contains("SIGKILL"), "{text}");
    for c in &mut k2.children {
        let status = c.wait().expect("wait");
        assert!(
            status.success(),
            "a rules process ended by SIGTERM, exit 0: {status}"
        );
    }
    drop(down);
}

/// Issue 38 item 7: `up SCENE --with rules=joint_guard` (a shipped rule base by name) starts the
/// rules as a session process: a joint set past its soft limit is set back by the rule. The
/// rules process SIGKILLed, a violation made while none runs stays; `robosim rules FILE`
/// started again catches up and sets it back. `down` stops everything (the rules by SIGTERM,
/// exit 0).
#[test]
fn up_with_rules_starts_a_rule_base_and_a_restarted_one_catches_up() {
    if robosim_rules::skipped_without_clips(
        "rules::up_with_rules_starts_a_rule_base_and_a_restarted_one_catches_up",
    ) {
        return;
    }
    let k = Procs::new("rulesup");
    let down = Down(&k);
    // An unknown rule base is refused before anything starts.
    let (ok, text) = robosim(
        &k,
        &[
            "up",
            "surgical_positioner_cell",
            "--with",
            "rules=no_such_guard",
        ],
    );
    assert!(!ok && text.contains("not a shipped rule base"), "{text}");
    assert!(
        k.session().processes().is_empty(),
        "nothing started: {text}"
    );
    let (ok, text) = robosim(
        &k,
        &[
            "up",
            "surgical_positioner_cell",
            "--with",
            "rules=joint_guard",
        ],
    );
    assert!(ok, "{text}");
    let procs = ps(&k);
    assert_eq!(
        procs.iter().map(|(r, _)| r.as_str()).collect::<Vec<_>>(),
        vec!["space", "rules"],
        "{text}"
    );
    let rules = procs[1].1;
    let mut p = Planner::attach_to(&k.session()).expect("attach");
    let waist = |p: &mut Planner| p.joints("positioner").expect("joints")[0];
    let mut q = p.joints("positioner").expect("joints");
    q[0] = 1.0;
    p.set_joints("positioner", &q).expect("set past the limit");
    wait_for("the rule started by up sets the waist back", || {
        (waist(&mut p) == 0.8).then_some(())
    });

    // No rules process: the violation stays (looked at after the keeper has it).
    let _ = Command::new("kill")
        .args(["-KILL", &rules.to_string()])
        .status();
    wait_for("the rules process gone", || {
        (!robosim_instance_space::pid_alive(rules)).then_some(())
    });
    q[0] = 1.1;
    p.set_joints("positioner", &q).expect("set again");
    assert_eq!(waist(&mut p), 1.1, "nothing runs the rules now");

    // Started again by hand on the session: it catches up from the session's state.
    let mut again = Procs {
        children: Vec::new(),
        home: tempfile::tempdir().expect("unused home"),
        name: k.name.clone(),
    };
    let c = Command::new(ROBOSIM)
        .args(["rules", RULES, "--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .env("IOX2_LOG_LEVEL", "Error")
        .spawn()
        .expect("rules");
    let pid = c.id();
    again.children.push(c);
    wait_for("the restarted rules set the waist back", || {
        (waist(&mut p) == 0.8).then_some(())
    });
    assert!(
        ps(&k).iter().any(|(r, p)| r == "rules" && *p == pid),
        "the restarted process is registered"
    );
    drop(p);
    let (ok, text) = robosim(&k, &["down"]);
    assert!(ok && text.contains("stopped rules"), "{text}");
    assert!(!text.contains("SIGKILL"), "{text}");
    let status = again.children[0].wait().expect("wait");
    assert!(status.success(), "rules ended by SIGTERM, exit 0: {status}");
    assert!(
        !robosim_instance_space::pid_alive(procs[0].1),
        "the keeper stopped"
    );
    assert!(ps(&k).is_empty(), "nothing left registered");
    drop(down);

    // Several rule bases: one process each (a name repeated starts it once).
    let k = Procs::new("rulesup2");
    let down = Down(&k);
    let (ok, text) = robosim(
        &k,
        &[
            "up",
            "demo",
            "--with",
            "rules=joint_guard,rules=eclss_guard.clp,rules=joint_guard",
        ],
    );
    assert!(ok, "{text}");
    assert_eq!(
        ps(&k).iter().filter(|(r, _)| r == "rules").count(),
        2,
        "{text}"
    );
    let (ok, text) = robosim(&k, &["down"]);
    assert!(ok, "{text}");
    assert_eq!(text.matches("stopped rules (pid").count(), 2, "{text}");
    drop(down);
}
