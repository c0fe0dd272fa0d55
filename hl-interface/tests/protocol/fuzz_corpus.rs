//! The `protocol` fuzz target's body (`fuzz/src/protocol.rs`) over every file of its corpus
//! (`fuzz/seeds/protocol/`: the documented requests, and each input the fuzzer once crashed
//! on), on stable, so `cargo test` re-checks them without nightly. See `docs/fuzzing.md`.
//!
//! Also issue #20 item 1 through the server: long parameter chains in `lib_evaluate` and a
//! `file` that is a device are answered with an error, never an abort.

use crate::fuzz_body;
use robosim_hl_interface::handle_line;
use serde_json::{Value, json};
use std::path::Path;

#[test]
fn protocol_fuzz_corpus_replays() {
    crate::fuzz_replay::replay(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz"),
        "protocol",
        fuzz_body::run,
    );
}

fn answer(req: &Value) -> Value {
    let line = handle_line(&req.to_string());
    serde_json::from_str(&line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"))
}

fn lib_evaluate_with_chain(terms: usize) -> Value {
    let chain = vec!["0.003 cm"; terms].join(" + ");
    answer(&json!({
        "id": terms, "op": "lib_evaluate", "name": "surgical_positioner",
        "params": {"upper_arm": chain}, "geometry": false
    }))
}

fn long_chains_are_answered() {
    // 10,000 terms of 0.003 cm: a 30 cm upper arm
    let a = lib_evaluate_with_chain(10_000);
    assert_eq!(a["ok"], true, "{a}");
    let a = lib_evaluate_with_chain(1_000_000);
    assert_eq!(a["ok"], false, "{a}");
    let msg = a["error"]["message"].as_str().unwrap_or("");
    assert!(
        msg.contains("expression too large: more than 100000"),
        "{msg}"
    );
    assert!(msg.contains("<parameter upper_arm>:1:"), "{msg}");
}

#[test]
fn issue_20_lib_evaluate_with_a_long_parameter_chain_answers_not_aborts() {
    long_chains_are_answered();
    // and on a 256 KiB stack: nothing recurses per operand
    std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(long_chains_are_answered)
        .expect("spawn")
        .join()
        .expect("the small-stack thread panicked");
}

#[test]
fn issue_20_lib_ops_refuse_a_file_that_is_a_device_or_a_directory() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (file, what) in [
        ("/dev/zero".to_owned(), "a character device"),
        (dir.path().display().to_string(), "a directory"),
    ] {
        for op in ["lib_list", "lib_evaluate"] {
            let a = answer(&json!({"id": 1, "op": op, "name": "x", "file": file}));
            assert_eq!(a["ok"], false, "{a}");
            assert_eq!(a["error"]["kind"], "library_error", "{a}");
            let msg = a["error"]["message"].as_str().unwrap_or("");
            assert!(
                msg.starts_with(&format!(
                    "cannot read {file}: it is {what}, not a regular file"
                )),
                "{msg}"
            );
        }
    }
}

#[test]
fn issue_20_collide_with_a_1024_meridian_sphere_is_refused_not_hours() {
    // Found by the `protocol` fuzz target (a timeout): building a sphere's collision solid
    // tests every vertex against every face, ~n⁴/4 for n meridians — 2.7·10^11 for the
    // geometry's explicit maximum of 1024. The protocol now takes at most the largest default.
    let sphere = |facets: usize| {
        answer(&json!({
            "id": 1, "op": "collide",
            "a": {"shape": "sphere", "radius": 1.0, "facets": facets},
            "pose_a": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
            "b": {"shape": "box", "size": [1, 1, 1]},
            "pose_b": [[1, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
        }))
    };
    let a = sphere(1024);
    assert_eq!(a["ok"], false, "{a}");
    assert_eq!(a["error"]["kind"], "bad_request", "{a}");
    assert_eq!(
        a["error"]["message"],
        "a.facets: at most 256 for a sphere, got 1024 (n meridians make about n²/2 faces)"
    );
    let a = sphere(16);
    assert_eq!(a["ok"], true, "{a}");
    assert_eq!(a["verdict"], "clear", "{a}");
}
