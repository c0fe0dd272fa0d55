//! The seed's simulation library on a running session (appendix 2.2), across processes: a
//! `robosim query --session` process moves the surgical positioner of §2.7 toward the patient's
//! head; MOVEJI stops at the last safe step and names the colliding pair (link and object); a
//! reader sees exactly the steps that were taken; C_SWITCH off lets the same move through.

use robosim_instance_space::Reader;
use serde_json::{Value, json};
use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;

use common::{Procs as Keeper, ROBOSIM};

fn query(k: &Keeper, lines: &[Value]) -> Vec<Value> {
    let mut child = Command::new(ROBOSIM)
        .args(["query", "--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("query process");
    let mut stdin = child.stdin.take().expect("stdin");
    for l in lines {
        writeln!(stdin, "{l}").expect("write");
    }
    writeln!(stdin, "not json at all").expect("write");
    drop(stdin);
    let out = child.wait_with_output().expect("output");
    assert!(out.status.success());
    let answers: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON answer"))
        .collect();
    assert_eq!(
        answers.len(),
        lines.len() + 1,
        "one answer per line, the bad one included"
    );
    assert_eq!(
        answers.last().and_then(|a| a.get("ok")),
        Some(&json!(false))
    );
    answers
}

#[test]
fn moveji_toward_the_head_stops_at_the_last_safe_step_and_names_the_pair() {
    let mut k = Keeper::new("ops");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let session = k.session();
    let start = Instant::now();
    let mut reader = loop {
        if let Ok(r) = Reader::attach(&session, "test")
            && r.snapshot().is_some_and(|s| s.find("positioner").is_some())
        {
            break r;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "scene did not load"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let v0 = reader.snapshot().expect("snapshot").version();
    let target = json!([2.9, -1.3, 0.7, 0.0, 0.0, 0.0]);
    let a = query(
        &k,
        &[
            json!({"id": 1, "op": "get_robot", "robot": "positioner"}),
            json!({"id": 2, "op": "check", "robot": "positioner"}),
            json!({"id": 3, "op": "moveji", "robot": "positioner", "q": target, "steps": 30}),
            json!({"id": 4, "op": "moveji", "robot": "positioner", "q": [3.5, 0, 0, 0, 0, 0], "steps": 5}),
            json!({"id": 5, "op": "movej", "robot": "positioner", "q": [0.0, "NaN", 0, 0, 0, 0]}),
        ],
    );
    assert_eq!(a[0]["links"].as_array().map(Vec::len), Some(6));
    assert_eq!(
        a[1]["status"], "clear",
        "the folded start pose is clear: {}",
        a[1]
    );
    let m = &a[2];
    assert_eq!(m["completed"], false, "{m}");
    let done = m["steps_done"].as_u64().expect("steps_done");
    assert!(done < 30);
    let contact = &m["stopped_by"]["contacts"][0];
    let pair = contact.to_string();
    assert!(
        pair.contains("head") && pair.contains("\"robot\":\"positioner\""),
        "the pair names the head and a positioner link: {pair}"
    );
    assert!(contact["signed_distance"].as_f64().is_some_and(|d| d < 0.0));
    assert_eq!(
        m["version"].as_u64(),
        Some(v0 + done),
        "one transaction per step taken"
    );
    assert_eq!(a[3]["error"]["kind"], "joint_limit", "{}", a[3]);
    assert_eq!(a[4]["error"]["kind"], "bad_request", "{}", a[4]);
    // The Instance Space holds the last safe step.
    let deadline = Instant::now() + Duration::from_secs(20);
    while reader.snapshot().expect("snapshot").version() < v0 + done {
        reader
            .wait_change(Duration::from_millis(100))
            .expect("wait");
        assert!(Instant::now() < deadline);
    }
    let snap = reader.snapshot().expect("snapshot");
    let waist = snap.find("waist").expect("waist link");
    let expected_q0 = m["q"][0].as_f64().expect("q");
    assert!((snap.poses()[waist].joint - expected_q0).abs() < 1e-12);

    // C_SWITCH off: the same move goes through; PRE/POSTTRANSLATE moves the robot's base.
    let b = query(
        &k,
        &[
            json!({"id": 1, "op": "c_switch", "on": false}),
            json!({"id": 2, "op": "moveji", "robot": "positioner", "q": target, "steps": 4}),
            json!({"id": 3, "op": "c_switch", "on": true}),
            json!({"id": 4, "op": "check", "robot": "positioner"}),
            json!({"id": 5, "op": "posttranslate", "object": "positioner", "by": [0.5, 0, 0]}),
            json!({"id": 6, "op": "check", "robot": "positioner"}),
            json!({"id": 7, "op": "encoder", "robot": "positioner", "bits": 12}),
        ],
    );
    assert_eq!(b[1]["completed"], true, "{}", b[1]);
    assert_eq!(b[3]["status"], "contact", "now inside the head: {}", b[3]);
    assert_eq!(
        b[5]["status"], "clear",
        "moved 0.5 m away from the head: {}",
        b[5]
    );
    assert!(
        b[6]["position"]
            .as_f64()
            .is_some_and(|p| p > 0.0 && p < 0.01),
        "{}",
        b[6]
    );
}

/// Issue 39 item 4: in a session a pure op names a session robot (`{"op": "fk", "robot":
/// "positioner", …}` answered "no robot named positioner"; the user had to paste `get_robot`'s
/// description inline). The answers by name are the answers on `get_robot`'s inline robot; a
/// standard-library name keeps its library meaning; an unknown name is still `unknown_robot`.
#[test]
fn a_pure_op_names_a_session_robot() {
    let mut k = Keeper::new("pureops");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let session = k.session();
    let start = Instant::now();
    while !Reader::attach(&session, "test")
        .ok()
        .and_then(|r| r.snapshot())
        .is_some_and(|s| s.find("positioner").is_some())
    {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "scene did not load"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let q = json!([0.3, 0.9, -2.1, 0.2, 0.5, -0.4]);
    let inline =
        query(&k, &[json!({"op": "get_robot", "robot": "positioner"})])[0]["robot"].clone();
    assert!(inline.is_object(), "{inline}");
    let by_name = |op: &str, robot: Value| {
        let mut r = json!({"op": op, "robot": robot, "q": q});
        if op == "ik" {
            r = json!({"op": "ik", "robot": r["robot"], "pose": [[1,0,0,0.3],[0,1,0,0.1],[0,0,1,0.1],[0,0,0,1]], "q0": q});
        }
        r
    };
    let ops = ["fk", "jacobian", "gravity", "mass_matrix"];
    let mut lines: Vec<Value> = ops
        .iter()
        .map(|op| by_name(op, json!("positioner")))
        .collect();
    lines.extend(ops.iter().map(|op| by_name(op, inline.clone())));
    lines.push(json!({"op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}));
    lines.push(json!({"op": "fk", "robot": "arm_nobody_placed", "q": [0, 0, 0, 0, 0, 0]}));
    let a = query(&k, &lines);
    for (i, op) in ops.iter().enumerate() {
        assert_eq!(a[i]["ok"], json!(true), "{op} by name: {}", a[i]);
        assert_eq!(
            a[i],
            a[i + ops.len()],
            "{op}: by name and inline answer the same"
        );
    }
    let library = robosim_hl_interface::handle_line(
        r#"{"op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}"#,
    );
    let library: Value = serde_json::from_str(&library).expect("json");
    assert_eq!(
        a[2 * ops.len()],
        library,
        "a library name means the library's robot"
    );
    assert_eq!(
        a[2 * ops.len() + 1]["error"]["kind"],
        json!("unknown_robot")
    );
}
