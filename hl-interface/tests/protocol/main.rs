//! The JSON-lines transport driven as a client would: whole sessions through [`serve`], bad
//! lines, a fuzz of arbitrary input, interactive use through pipes and of the real process;
//! and each area's ops (`kinematics`, `dynamics`, `collision`, `library`) through its `dispatch`.
//! One test binary (the modules below) to keep link time down: it is the crate's only one
//! (Cargo.toml: `autotests = false`), so the other files of tests/ are modules of it too —
//! `cargo test -p robosim-hl-interface --test hl_interface FILE::`. A new file of tests/ needs
//! its `mod` line here.

#[path = "../concurrency.rs"]
mod concurrency;
#[path = "../diag_cli.rs"]
mod diag_cli;
#[path = "../hostile_input.rs"]
mod hostile_input;
#[path = "../lib_cli.rs"]
mod lib_cli;
#[path = "../sim_cli.rs"]
mod sim_cli;

mod bad_lines;
mod collision;
mod dynamics;
mod error_source;
mod extension;
mod floating;
mod fuzz;
mod fuzz_corpus;
mod kinematics;
mod library;
mod mimic;
mod overflow;
mod pipes;
mod process;
mod session;

/// The `protocol` fuzz target's body, replayed over its corpus by [`fuzz_corpus`].
#[path = "../../../fuzz/src/protocol.rs"]
mod fuzz_body;
/// The corpus replay shared with the other crates' `fuzz_corpus` tests.
#[path = "../../../fuzz/src/replay.rs"]
mod fuzz_replay;

use robosim_hl_interface::serve;
use serde_json::Value;

/// Runs `input` through [`serve`] and returns the answer lines, each parsed, with the raw text.
pub fn run_bytes(input: &[u8]) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    let stats = serve(input, &mut out).expect("in-memory streams do not fail");
    let text = String::from_utf8(out).expect("answers are UTF-8");
    assert!(
        text.is_empty() || text.ends_with('\n'),
        "answer not newline-terminated"
    );
    let lines: Vec<(String, Value)> = text
        .lines()
        .map(|l| {
            let v: Value =
                serde_json::from_str(l).unwrap_or_else(|e| panic!("answer is not JSON ({e}): {l}"));
            (l.to_owned(), v)
        })
        .collect();
    assert_eq!(stats.lines, lines.len() as u64, "stats.lines");
    assert_eq!(stats.ok + stats.errors, stats.lines, "stats add up");
    let ok = lines
        .iter()
        .filter(|(_, v)| v["ok"] == Value::Bool(true))
        .count();
    assert_eq!(stats.ok, ok as u64, "stats.ok");
    lines
}

/// One request per line.
pub fn run_values(reqs: &[Value]) -> Vec<(String, Value)> {
    let mut input = String::new();
    for r in reqs {
        input.push_str(&r.to_string());
        input.push('\n');
    }
    run_bytes(input.as_bytes())
}

/// The error kind of an answer (panics on an ok answer, with the answer shown).
pub fn kind(answer: &Value) -> &str {
    assert_eq!(answer["ok"], false, "expected an error answer: {answer}");
    answer["error"]["kind"]
        .as_str()
        .unwrap_or_else(|| panic!("error.kind missing: {answer}"))
}

/// The numbers of a JSON array (panics with the path otherwise).
pub fn numbers(v: &Value, what: &str) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("{what}: not an array: {v}"))
        .iter()
        .map(|x| {
            x.as_f64()
                .unwrap_or_else(|| panic!("{what}: not a number: {x}"))
        })
        .collect()
}

/// Rows of numbers of a JSON matrix.
pub fn rows(v: &Value, what: &str) -> Vec<Vec<f64>> {
    v.as_array()
        .unwrap_or_else(|| panic!("{what}: not an array: {v}"))
        .iter()
        .enumerate()
        .map(|(i, r)| numbers(r, &format!("{what}[{i}]")))
        .collect()
}

pub fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol * (1.0 + w.abs()),
            "{what}[{i}]: got {g}, want {w}"
        );
    }
}
