//! docs/query.md against real runs (its two example sections, made by the `make_query_doc`
//! example of hl-interface, with the block format and cutting rule of its `doc.rs`), and the routing of an op that is both a pure and a session
//! op (`check`): a request file runs verbatim with and without `--session`.
//!
//! Each test starts its own session (`robosim up surgical_positioner_cell`, the README's
//! scene) in a temporary ROBOSIM_HOME and takes it down at the end, as a user would.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
#[path = "../hl-interface/examples/make_query_doc/doc.rs"]
#[allow(
    dead_code,
    reason = "shared with the make_query_doc example, which writes what this reads"
)]
mod doc;

use common::{Procs, ROBOSIM};

/// The repository root (the root package's manifest directory).
fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A session brought up with `robosim up SCENE` in a fresh home; `robosim down` when dropped
/// (then [`Procs`] removes whatever shared memory is left).
struct Up {
    procs: Procs,
}

impl Up {
    fn new(tag: &str, scene: &str) -> Self {
        let procs = Procs::new(tag);
        let up = Up { procs };
        let out = up.robosim(&["up", scene]);
        assert!(
            out.status.success(),
            "robosim up {scene}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        up
    }

    /// `robosim ARGS --session NAME` in this session's home, to completion.
    fn robosim(&self, args: &[&str]) -> std::process::Output {
        Command::new(ROBOSIM)
            .args(args)
            .args(["--session", &self.procs.name])
            .env("ROBOSIM_HOME", self.procs.home.path())
            .output()
            .expect("run robosim")
    }

    /// The answer lines of `robosim query --session NAME --input FILE`.
    fn query(&self, input: &Path) -> Vec<String> {
        let path = input.to_str().expect("UTF-8 path");
        let out = self.robosim(&["query", "--input", path]);
        assert!(
            out.status.success(),
            "robosim query --session: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        lines(out.stdout)
    }
}

impl Drop for Up {
    fn drop(&mut self) {
        let _ = self.robosim(&["down"]);
    }
}

fn lines(stdout: Vec<u8>) -> Vec<String> {
    String::from_utf8(stdout)
        .expect("UTF-8 answers")
        .lines()
        .map(str::to_owned)
        .collect()
}

/// The answer lines of `robosim query --input FILE` (no session).
fn query_pure(input: &Path) -> Vec<String> {
    // From the repository's root, as make_query_doc runs it: the examples name URDF files by
    // relative paths.
    let out = Command::new(ROBOSIM)
        .args(["query", "--input"])
        .arg(input)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run robosim query");
    assert!(
        out.status.success(),
        "robosim query: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    lines(out.stdout)
}

fn json(line: &str) -> Value {
    serde_json::from_str(line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"))
}

/// hl-interface/examples/requests.jsonl — the pure ops, the shared `check` among them in its
/// pure form — answered the same inside a session as without one; only the op listings differ
/// (a session adds its ops). The session form of `check` (a robot name only) is the session's.
#[test]
fn pure_requests_mean_the_same_in_a_session_and_a_named_robot_is_the_sessions() {
    let file = repo().join("hl-interface/examples/requests.jsonl");
    let requests: Vec<Value> = std::fs::read_to_string(&file)
        .expect("requests.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or(Value::Null))
        .collect();
    let up = Up::new("qroute", "surgical_positioner_cell");
    let pure = query_pure(&file);
    let in_session = up.query(&file);
    assert_eq!(pure.len(), requests.len());
    assert_eq!(in_session.len(), requests.len());
    let mut checks = 0;
    for ((req, p), s) in requests.iter().zip(&pure).zip(&in_session) {
        let (pv, sv) = (json(p), json(s));
        match (req["op"].as_str(), pv["error"]["kind"].as_str()) {
            (Some("ops"), _) => {
                let pure_ops = &pv["ops"];
                let without_session: Vec<&Value> = sv["ops"]
                    .as_array()
                    .expect("ops")
                    .iter()
                    .filter(|o| o["area"] != "session")
                    .collect();
                assert_eq!(
                    serde_json::to_value(without_session).expect("ops"),
                    *pure_ops
                );
            }
            (_, Some("unknown_op")) => assert_eq!(sv["error"]["kind"], "unknown_op", "{s}"),
            (op, _) => {
                checks += usize::from(op == Some("check"));
                assert_eq!(p, s, "{req}");
            }
        }
    }
    assert_eq!(checks, 1, "requests.jsonl has one (pure) check");
    assert_eq!(
        json(&in_session[10])["verdict"],
        "contact",
        "{}",
        in_session[10]
    );

    // The session form: a robot of the session by name, nothing else.
    let dir = tempfile::tempdir().expect("temp dir");
    let session_form = dir.path().join("session_check.jsonl");
    std::fs::write(
        &session_form,
        concat!(
            "{\"id\": 1, \"op\": \"check\", \"robot\": \"positioner\"}\n",
            "{\"id\": 2, \"op\": \"check\", \"robot\": \"puma560\"}\n",
            "{\"id\": 3, \"op\": \"check\", \"robot\": \"positioner\", \"mode\": \"bbox\"}\n",
        ),
    )
    .expect("write requests");
    let a: Vec<Value> = up.query(&session_form).iter().map(|l| json(l)).collect();
    assert_eq!(a[0]["status"], "clear", "{}", a[0]);
    assert_eq!(a[1]["error"]["kind"], "unknown_robot", "{}", a[1]);
    let m = a[1]["error"]["message"].as_str().expect("message");
    assert!(
        m.contains("robots: positioner"),
        "names the session's robots: {m}"
    );
    assert_eq!(a[2]["error"]["kind"], "bad_request", "{}", a[2]);
    let m = a[2]["error"]["message"].as_str().expect("message");
    assert!(m.starts_with("`mode`") && m.contains("c_switch"), "{m}");
}

/// Every documented example of `markers`' section against `answers`, the answer lines of a
/// fresh run of `file`: the request line verbatim, the heading, the answer by [`doc::compare`].
fn assert_documented(markers: doc::Markers, file: &Path, answers: &[String]) {
    let text = std::fs::read_to_string(repo().join("docs/query.md")).expect("docs/query.md");
    let examples = doc::parse(&text, markers).unwrap_or_else(|e| panic!("{e}"));
    let requests: Vec<String> = std::fs::read_to_string(file)
        .expect("request file")
        .lines()
        .map(str::to_owned)
        .collect();
    let regenerate = "(regenerate: cargo run -p robosim-hl-interface --example make_query_doc -- target/debug/robosim)";
    assert_eq!(
        examples.len(),
        requests.len(),
        "{}: one example per request line {regenerate}",
        markers.begin
    );
    assert_eq!(answers.len(), requests.len(), "one answer per request line");
    let mut stale = Vec::new();
    for ((ex, req), got) in examples.iter().zip(&requests).zip(answers) {
        if ex.request != *req {
            stale.push(format!(
                "request: documented {}, file has {req}",
                ex.request
            ));
        } else if ex.title != doc::title(req, got) {
            stale.push(format!("{req}: heading {}, answer {got}", ex.title));
        } else if let Err(why) = doc::compare(&ex.answer, got) {
            stale.push(format!("{req}: {why}\n  answer now: {got}"));
        }
    }
    assert!(
        stale.is_empty(),
        "docs/query.md and robosim disagree: a regression, or a stale doc {regenerate}:\n{}",
        stale.join("\n")
    );
}

#[test]
fn docs_query_pure_examples_are_what_robosim_query_answers() {
    let file = repo().join("hl-interface/examples/requests.jsonl");
    assert_documented(doc::PURE, &file, &query_pure(&file));
}

/// The session examples as the README runs them: `robosim up surgical_positioner_cell`, then
/// the file through `robosim query --session`, on a fresh session (the versions count from it).
#[test]
fn docs_query_session_examples_are_what_a_fresh_session_answers() {
    let file = repo().join("hl-interface/examples/session_requests.jsonl");
    let up = Up::new("qdocs", "surgical_positioner_cell");
    let answers = up.query(&file);
    assert_documented(doc::SESSION, &file, &answers);
    // What the story shows, said outright (ids are line numbers).
    let a = |id: usize| json(&answers[id - 1]);
    assert_eq!(a(8)["completed"], false, "MOVEJI toward the head stops");
    assert_eq!(a(11)["in_use"], false);
    assert_eq!(
        a(12)["completed"],
        true,
        "with the head out of use (its cylinder part too), the same move goes through: {}",
        a(12)
    );
    assert_eq!(a(14)["status"], "contact", "USE brings it back: {}", a(14));
    assert_eq!(a(3)["verdict"], "contact", "the pure check, in a session");
    // Every session op has an example (a new op needs one in session_requests.jsonl).
    let shown: std::collections::HashSet<String> = std::fs::read_to_string(&file)
        .expect("file")
        .lines()
        .filter_map(|l| json(l)["op"].as_str().map(str::to_owned))
        .collect();
    for op in robosim_hl_interface::session::OPS {
        assert!(shown.contains(*op), "session op {op} has no example");
    }
}
