//! Issue 34, items 13 and 14, through a real `query` process (the example runs the same
//! `cli::run` as `robosim query`): an endless line (`/dev/zero`) is answered with a typed error
//! while holding at most the line limit, an over-long line is skipped and the next request
//! answered, and a URDF robot nested 20,000 deep is an error answer, not a stack overflow that
//! kills the server for every later request.

use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdout, Command, Stdio};

/// The `query` example, built by `cargo test -p robosim-hl-interface` beside `deps/`.
fn query_example() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let profile_dir = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("the test runs from <target>/<profile>/deps");
    let path = profile_dir
        .join("examples")
        .join(format!("query{}", std::env::consts::EXE_SUFFIX));
    assert!(path.exists(), "{} is missing", path.display());
    path
}

fn spawn(stdin: Stdio, line_limit: Option<&str>) -> (Child, BufReader<ChildStdout>) {
    let mut cmd = Command::new(query_example());
    cmd.stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    match line_limit {
        Some(l) => cmd.env("ROBOSIM_MAX_LINE_BYTES", l),
        None => cmd.env_remove("ROBOSIM_MAX_LINE_BYTES"),
    };
    let mut child = cmd.spawn().expect("spawn the query example");
    let from = BufReader::new(child.stdout.take().expect("stdout"));
    (child, from)
}

fn answer(from: &mut BufReader<ChildStdout>) -> Value {
    let mut line = String::new();
    from.read_line(&mut line).expect("read an answer");
    serde_json::from_str(&line).unwrap_or_else(|e| panic!("answer not JSON ({e}): {line:?}"))
}

/// A valid request (id 2) sent after a hostile one: the server must still answer it.
const NEXT: &str = r#"{"id": 2, "op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}"#;

/// The next answer is the successful one to [`NEXT`], and then the server (its input closed)
/// exits successfully.
fn next_answered_then_clean_exit(mut child: Child, from: &mut BufReader<ChildStdout>) {
    let b = answer(from);
    assert_eq!(
        (b["id"].clone(), b["ok"].clone()),
        (Value::from(2), Value::from(true)),
        "{b}"
    );
    assert!(child.wait().expect("wait").success());
}

#[test]
fn issue_34_query_of_dev_zero_answers_line_too_long_instead_of_running_out_of_memory() {
    let zero = std::fs::File::open("/dev/zero").expect("open /dev/zero");
    let (mut child, mut from) = spawn(Stdio::from(zero), Some("64K"));
    let a = answer(&mut from);
    assert_eq!(a["ok"], false, "{a}");
    assert_eq!(a["id"], Value::Null, "{a}");
    assert_eq!(a["error"]["kind"], "parse_error", "{a}");
    let msg = a["error"]["message"].as_str().expect("message");
    assert!(
        msg.starts_with("input line 1: longer than 64 KiB, the limit for a request line (set ROBOSIM_MAX_LINE_BYTES to raise it)"),
        "{msg}"
    );
    // Still running (skipping the endless line, holding nothing): it did not abort.
    assert!(
        child.try_wait().expect("try_wait").is_none(),
        "the server exited"
    );
    child.kill().expect("kill");
    child.wait().expect("wait");
}

#[test]
fn issue_34_query_skips_an_overlong_line_and_answers_the_next_request() {
    let (mut child, mut from) = spawn(Stdio::piped(), Some("1000"));
    let mut to = child.stdin.take().expect("stdin");
    let long = format!(
        "{{\"id\": 1, \"op\": \"fk\", \"pad\": \"{}\"}}",
        "x".repeat(5000)
    );
    writeln!(to, "{long}").expect("write");
    writeln!(to, "{NEXT}").expect("write");
    drop(to);
    let a = answer(&mut from);
    assert_eq!(a["error"]["kind"], "parse_error", "{a}");
    assert!(
        a["error"]["message"]
            .as_str()
            .is_some_and(|m| m.contains("longer than 1000 bytes")),
        "{a}"
    );
    next_answered_then_clean_exit(child, &mut from);
}

#[test]
fn issue_34_query_survives_a_urdf_robot_nested_20000_deep_and_answers_the_next_request() {
    let dir = tempfile::tempdir().expect("tempdir");
    let deep = dir.path().join("deep.urdf");
    std::fs::write(
        &deep,
        format!(
            "<robot name=\"deep\">\n<link name=\"base\"/>\n{}{}</robot>\n",
            "<a>".repeat(20_000),
            "</a>".repeat(20_000)
        ),
    )
    .expect("write");
    let (mut child, mut from) = spawn(Stdio::piped(), None);
    let mut to = child.stdin.take().expect("stdin");
    let req = serde_json::json!({"id": 1, "op": "fk", "robot": {"urdf": deep}, "q": []});
    writeln!(to, "{req}").expect("write");
    writeln!(to, "{NEXT}").expect("write");
    drop(to);
    let a = answer(&mut from);
    assert_eq!(
        (a["id"].clone(), a["ok"].clone()),
        (Value::from(1), Value::from(false)),
        "{a}"
    );
    let msg = a["error"]["message"].as_str().expect("message");
    assert!(
        msg.contains("deep.urdf:3: XML: elements nested more than 512 deep"),
        "{msg}"
    );
    next_answered_then_clean_exit(child, &mut from);
}

#[test]
fn issue_34_query_names_a_line_limit_that_is_not_a_size() {
    let (mut child, _from) = spawn(Stdio::null(), Some("lots"));
    let out = {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().expect("stderr"), &mut s)
            .expect("stderr");
        s
    };
    assert!(!child.wait().expect("wait").success());
    assert!(
        out.contains("ROBOSIM_MAX_LINE_BYTES=\"lots\" is not a size"),
        "{out}"
    );
}
