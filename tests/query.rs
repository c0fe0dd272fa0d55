//! `robosim query` as a real process: a planner's conversation through pipes, one request at a
//! time (each built from the previous answer), bad lines answered in place, the counts on
//! standard error and a clean exit at end of input; and `--input FILE`. The protocol itself is
//! tested in `hl-interface/tests/protocol/`.

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};

const ROBOSIM: &str = env!("CARGO_BIN_EXE_robosim");

#[test]
fn robosim_query_converses_through_pipes() {
    let mut child = Command::new(ROBOSIM)
        .args(["query", "--stats"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn robosim query");
    let mut to = child.stdin.take().expect("stdin");
    let mut from = BufReader::new(child.stdout.take().expect("stdout"));
    let mut ask = |line: String| -> Value {
        writeln!(to, "{line}").expect("write request");
        to.flush().expect("flush request");
        let mut answer = String::new();
        from.read_line(&mut answer).expect("read answer");
        serde_json::from_str(&answer).unwrap_or_else(|e| panic!("answer not JSON ({e}): {answer}"))
    };
    let q = json!([0.3, -0.4, 0.6, 1.0, -0.8, 0.5]);
    let fk = ask(json!({"id": 1, "op": "fk", "robot": "puma560", "q": q}).to_string());
    assert_eq!(
        (fk["id"].clone(), fk["ok"].clone()),
        (json!(1), json!(true)),
        "{fk}"
    );
    // The planner asks for the joints of the pose it was just given, then the torque there.
    let ik = ask(
        json!({"id": 2, "op": "ik", "robot": "puma560", "pose": fk["pose"], "method": "analytic", "all": true})
            .to_string(),
    );
    let sols = ik["solutions"].as_array().expect("solutions");
    assert_eq!(sols.len(), 8, "{ik}");
    let back = sols
        .iter()
        .find(|s| {
            s["q"].as_array().is_some_and(|qs| {
                qs.iter().zip(q.as_array().expect("q")).all(|(a, b)| {
                    (a.as_f64().unwrap_or(f64::NAN) - b.as_f64().unwrap_or(0.0)).abs() < 1e-9
                })
            })
        })
        .expect("the original q is among the solutions");
    let g =
        ask(json!({"id": "g", "op": "gravity", "robot": "puma560", "q": back["q"]}).to_string());
    assert_eq!(g["id"], "g");
    assert_eq!(g["tau"].as_array().map(Vec::len), Some(6), "{g}");
    // Bad lines are answered in place and the conversation goes on.
    let e = ask("not json".to_owned());
    assert_eq!(e["error"]["kind"], "parse_error", "{e}");
    let e = ask("[1, 2]".to_owned());
    assert_eq!(e["error"]["kind"], "bad_request", "{e}");
    let e = ask(json!({"id": 6, "op": "teleport"}).to_string());
    assert_eq!(
        (e["id"].clone(), e["error"]["kind"].clone()),
        (json!(6), json!("unknown_op"))
    );
    let c = ask(json!({"id": 7, "op": "collide",
        "a": {"shape": "sphere", "radius": 0.5}, "pose_a": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],
        "b": {"shape": "box", "size": [1, 1, 1]}, "pose_b": [[1,0,0,1.5],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})
    .to_string());
    assert_eq!(c["intersect"], false, "{c}");
    drop(to);
    let mut rest = String::new();
    assert_eq!(
        from.read_line(&mut rest).expect("read"),
        0,
        "nothing after the answers: {rest}"
    );
    let out = child.wait_with_output().expect("wait");
    assert!(out.status.success(), "exit status {:?}", out.status);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("7 lines, 4 ok, 3 errors"), "stats: {err}");
}

#[test]
fn robosim_query_reads_an_input_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("requests.jsonl");
    std::fs::write(
        &path,
        "{\"id\": 1, \"op\": \"ops\"}\n\n{\"id\": 3, \"op\": \"lib_params\", \"name\": \"puma560\"}\n",
    )
    .expect("write requests");
    let out = Command::new(ROBOSIM)
        .args(["query", "--input"])
        .arg(&path)
        .output()
        .expect("run robosim query");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let answers: Vec<Value> = String::from_utf8(out.stdout)
        .expect("utf-8")
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON answer"))
        .collect();
    assert_eq!(answers.len(), 3, "{answers:?}");
    assert_eq!(answers[0]["ok"], true);
    assert_eq!(
        answers[1]["error"]["kind"], "parse_error",
        "an empty line is answered too"
    );
    assert_eq!(answers[2]["id"], 3);
    let missing = Command::new(ROBOSIM)
        .args(["query", "--input"])
        .arg(dir.path().join("missing.jsonl"))
        .output()
        .expect("run");
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("missing.jsonl"));
}
