//! A real process on real pipes: the `query` example (the same `cli::run` that `robosim query`
//! calls), driven one request at a time, then its end-of-input and a missing input file.

use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Command, Stdio};

/// `cargo test` builds the package's examples before it runs the tests; the example lands in
/// `<target>/<profile>/examples/`, beside this test's `deps/` directory.
fn query_example() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let profile_dir = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("the test runs from <target>/<profile>/deps");
    let path = profile_dir
        .join("examples")
        .join(format!("query{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.exists(),
        "{} is missing: run the tests through `cargo test -p robosim-hl-interface`, which builds the example",
        path.display()
    );
    path
}

#[test]
fn the_query_process_answers_one_line_at_a_time_through_pipes() {
    let mut child = Command::new(query_example())
        .arg("--stats")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn the query example");
    let mut to = child.stdin.take().expect("stdin");
    let mut from = BufReader::new(child.stdout.take().expect("stdout"));
    let mut line = String::new();
    let mut q = serde_json::json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    for i in 0..4 {
        writeln!(
            to,
            r#"{{"id": {i}, "op": "fk", "robot": "puma560", "q": {q}}}"#
        )
        .expect("write");
        to.flush().expect("flush");
        line.clear();
        from.read_line(&mut line).expect("read");
        let a: Value = serde_json::from_str(&line).expect("JSON answer");
        assert_eq!(
            (a["id"].clone(), a["ok"].clone()),
            (i.into(), true.into()),
            "{line}"
        );
        // The next request is built from this answer: the tool's x becomes q1.
        q[0] = a["pose"][0][3].clone();
    }
    writeln!(to, "{{\"id\": 9, \"op\": ").expect("write");
    drop(to);
    line.clear();
    from.read_line(&mut line).expect("read");
    assert!(
        line.contains("\"parse_error\"") && line.contains("input line 5"),
        "{line}"
    );
    let out = child.wait_with_output().expect("wait");
    assert!(out.status.success(), "exit status {:?}", out.status);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("5 lines, 4 ok, 1 errors"),
        "stats on stderr: {err}"
    );
}

#[test]
fn a_missing_input_file_is_an_error_exit() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("no-such-requests.jsonl");
    let out = Command::new(query_example())
        .arg("--input")
        .arg(&missing)
        .output()
        .expect("run");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot open") && err.contains("no-such-requests.jsonl"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}

/// The Rust client over the real process: answers, refusals, ids in step, a clean exit.
#[test]
fn the_client_talks_to_the_query_process() {
    use robosim_hl_interface::client::Client;
    let (mut child, mut client) = Client::spawn(Command::new(query_example())).expect("spawn");
    let g = client
        .call(
            "gravity",
            serde_json::json!({"robot": "puma560", "q": [0, 0.5, -1, 0, 0.3, 0]}),
        )
        .expect("conversation")
        .expect("gravity answers");
    assert_eq!(g["tau"].as_array().map(Vec::len), Some(6));
    assert!(
        g.get("id").is_none() && g.get("ok").is_none(),
        "envelope stripped: {g}"
    );
    let refused = client
        .call("fk", serde_json::json!({"robot": "nonesuch", "q": []}))
        .expect("conversation")
        .expect_err("unknown robot");
    assert_eq!(refused.kind, "unknown_robot");
    let ops = client
        .call("ops", serde_json::json!({}))
        .expect("conversation")
        .expect("ops");
    assert!(ops["ops"].as_array().is_some_and(|o| o.len() > 10));
    assert!(
        client.call("ops", serde_json::json!([1])).is_err(),
        "fields must be an object"
    );
    drop(client);
    assert!(child.wait().expect("wait").success());
}
