//! Whatever a client sends, the server answers every line with exactly one JSON line
//! (`id`, boolean `ok`, an `error.kind` string when not ok) and never panics: arbitrary bytes,
//! and valid requests of every op with fields replaced by arbitrary JSON.

use crate::run_bytes;
use proptest::prelude::*;
use serde_json::{Map, Value, json};

/// Input lines as the server splits them: on b'\n', with a last unterminated line counted.
fn line_count(bytes: &[u8]) -> usize {
    let newlines = bytes.iter().filter(|&&b| b == b'\n').count();
    newlines + usize::from(!bytes.is_empty() && bytes.last() != Some(&b'\n'))
}

fn check_answers(input: &[u8]) -> Vec<Value> {
    let answers = run_bytes(input);
    assert_eq!(
        answers.len(),
        line_count(input),
        "one answer per input line"
    );
    answers
        .into_iter()
        .map(|(raw, a)| {
            assert!(a.get("id").is_some(), "id missing: {raw}");
            assert!(a["ok"].is_boolean(), "ok not a boolean: {raw}");
            if a["ok"] == false {
                let k = a["error"]["kind"]
                    .as_str()
                    .unwrap_or_else(|| panic!("kind: {raw}"));
                assert!(a["error"]["message"].is_string(), "message: {raw}");
                assert_ne!(k, "internal_error", "an op panicked: {raw}");
            }
            a
        })
        .collect()
}

/// Bytes biased towards JSON's punctuation and newlines, so that lines are short and some
/// parse.
fn jsonish_bytes() -> impl Strategy<Value = Vec<u8>> {
    let byte = prop_oneof![
        4 => any::<u8>(),
        2 => Just(b'\n'),
        1 => Just(b'\r'),
        2 => prop::sample::select(b"{}[]:,\" 0123456789.-eE".to_vec()),
        1 => prop::sample::select(vec![b'n', b'u', b'l', b't', b'r', b'f', b'a', b's']),
    ];
    prop::collection::vec(byte, 0..300)
}

/// A JSON value from the kinds of things a confused client sends: wrong types, non-finite
/// strings, huge and tiny numbers, nested arrays and objects.
fn arb_json() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        (-3i64..20).prop_map(|i| json!(i)),
        prop::sample::select(vec![0.0, -1.0, 0.5, 1.5, 1e-300, 1e300, -1e300, 3.3])
            .prop_map(|x| json!(x)),
        prop::sample::select(vec![
            "NaN", "inf", "", "puma560", "panda", "stanford", "eclss", "box", "sphere", "exact",
            "tool", "rk4", "dopri5", "newton", "analytic"
        ])
        .prop_map(|s| json!(s)),
        "[a-z_]{0,8}".prop_map(Value::String),
    ];
    leaf.prop_recursive(3, 40, 8, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..8).prop_map(Value::Array),
            prop::collection::vec((prop::sample::select(KEYS.to_vec()), inner), 0..6).prop_map(
                |kv| Value::Object(kv.into_iter().map(|(k, v)| (k.to_owned(), v)).collect())
            ),
        ]
    })
}

/// Request fields of all ops. Left out on purpose: the work budgets (`max_steps`,
/// `max_iterations`, `restarts`) and `file`, so that a fuzz case stays fast and reads no files.
const KEYS: &[&str] = &[
    "id",
    "robot",
    "q",
    "qd",
    "qdd",
    "tau",
    "frames",
    "frame",
    "pose",
    "method",
    "all",
    "q0",
    "tolerances",
    "respect_limits",
    "seed",
    "bits",
    "qd0",
    "t_end",
    "outputs",
    "integrator",
    "dt",
    "rtol",
    "atol",
    "limits",
    "a",
    "b",
    "pose_a",
    "pose_b",
    "mode",
    "scene",
    "objects",
    "links",
    "allowed",
    "self_collision",
    "link_radius",
    "shape",
    "size",
    "radius",
    "height",
    "facets",
    "points",
    "vertices",
    "polygons",
    "parts",
    "name",
    "params",
    "geometry",
    "model",
    "faults",
    "fault",
    "alarms",
    "alarm",
    "drop",
    "until",
    "sample",
    "convention",
    "joints",
    "type",
];

fn eye(x: f64) -> Value {
    json!([
        [1.0, 0.0, 0.0, x],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0]
    ])
}

/// One valid request per op, the starting points of the mutations (bounded work budgets).
fn valid_requests() -> Vec<Value> {
    let q = json!([0.1, -0.4, 0.7, 0.2, -0.6, 0.3]);
    let inline = json!({"convention": "standard", "joints": [
        {"type": "revolute", "a": 0.5, "d": 0.0, "alpha": 0.0, "mass": 1.0, "com": [-0.25, 0, 0], "inertia": [[0.01,0,0],[0,0.02,0],[0,0,0.02]]},
        {"type": "prismatic", "a": 0.0, "theta": 0.0, "alpha": 0.0, "qlim": [0.0, 0.5], "mass": 0.5}]});
    vec![
        json!({"op": "fk", "robot": "puma560", "q": q, "frames": true}),
        json!({"op": "jacobian", "robot": inline, "q": [0.3, 0.1], "frame": "tool"}),
        json!({"op": "ik", "robot": "puma560", "pose": [[1,0,0,0.45],[0,1,0,-0.15],[0,0,1,1.1],[0,0,0,1]], "method": "dls", "max_iterations": 50, "restarts": 1}),
        json!({"op": "ik", "robot": "panda", "pose": eye(0.4), "method": "newton", "max_iterations": 30, "restarts": 0}),
        json!({"op": "encoder_error", "robot": "stanford", "q": q, "bits": [10, 10, 12, 12, 12, 12]}),
        json!({"op": "id", "robot": "puma560", "q": q, "qd": q, "qdd": q}),
        json!({"op": "mass_matrix", "robot": inline, "q": [0.2, 0.1]}),
        json!({"op": "gravity", "robot": "panda", "q": [0, 0, 0, -1.5, 0, 1.5, 0]}),
        json!({"op": "fd", "robot": "puma560", "q": q, "qd": q, "tau": q, "method": "cholesky"}),
        json!({"op": "simulate", "robot": inline, "q0": [0.1, 0.2], "t_end": 0.02, "integrator": "dopri5", "rtol": 1e-6, "max_steps": 500}),
        json!({"op": "simulate", "robot": "puma560", "q0": q, "t_end": 0.01, "integrator": "rk4", "dt": 0.005, "max_steps": 500}),
        json!({"op": "collide", "a": {"shape": "cylinder", "radius": 0.2, "height": 1.0, "facets": 12}, "pose_a": eye(0.0), "b": {"shape": "cone", "radius": 0.3, "height": 0.5}, "pose_b": eye(0.3), "mode": "polygon"}),
        json!({"op": "collide", "a": {"shape": "convex", "points": [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]}, "pose_a": eye(0.0), "b": {"shape": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0],[0,0,1]], "polygons": [[0,2,1],[0,1,3],[0,3,2],[1,2,3]]}, "pose_b": eye(0.5)}),
        json!({"op": "check", "robot": "puma560", "q": q, "scene": {"objects": [{"shape": "box", "size": [0.2, 0.2, 0.2], "pose": eye(0.5), "name": "crate"}]}, "all": true}),
        json!({"op": "lib_params", "name": "puma560"}),
        json!({"op": "lib_evaluate", "name": "puma560", "geometry": false}),
        json!({"op": "diag_check", "model": "eclss"}),
        json!({"op": "diag_simulate", "model": "eclss", "faults": [{"fault": "Shower.consumer_leaking", "t": 1.0}]}),
        json!({"op": "diag_diagnose", "model": "eclss", "alarms": [{"alarm": "A_shower_leak", "t": 0.0}]}),
    ]
}

#[derive(Debug, Clone)]
enum Mutation {
    Set(&'static str, Value),
    Remove(usize),
    /// Replace a value nested one level down (e.g. one entry of `q` or a field of `a`).
    SetInner(usize, usize, Value),
}

fn arb_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (prop::sample::select(KEYS.to_vec()), arb_json()).prop_map(|(k, v)| Mutation::Set(k, v)),
        any::<usize>().prop_map(Mutation::Remove),
        (any::<usize>(), any::<usize>(), arb_json())
            .prop_map(|(i, j, v)| Mutation::SetInner(i, j, v)),
    ]
}

fn apply(req: &mut Map<String, Value>, m: &Mutation) {
    // `op` is never touched: a mutated op would only test unknown_op, and a request turned
    // into `simulate` without its step budget could run for minutes.
    // Nor are the work budgets removed (the defaults allow millions of steps).
    let keys: Vec<String> = req
        .keys()
        .filter(|k| !["op", "max_steps", "max_iterations", "restarts"].contains(&k.as_str()))
        .cloned()
        .collect();
    match m {
        Mutation::Set(k, v) => {
            req.insert((*k).to_owned(), v.clone());
        }
        Mutation::Remove(i) if !keys.is_empty() => {
            req.remove(&keys[i % keys.len()]);
        }
        Mutation::SetInner(i, j, v) if !keys.is_empty() => {
            match req.get_mut(&keys[i % keys.len()]) {
                Some(Value::Array(a)) if !a.is_empty() => {
                    let n = a.len();
                    a[j % n] = v.clone();
                }
                Some(Value::Object(o)) if !o.is_empty() => {
                    let k: Vec<String> = o.keys().cloned().collect();
                    o.insert(k[j % k.len()].clone(), v.clone());
                }
                _ => {}
            }
        }
        _ => {}
    }
}

proptest! {
    // 256 cases by default, from a fixed seed (the same cases on every run: CI never meets a
    // new random case); a deeper run: PROPTEST_CASES=20000 cargo test -p robosim-hl-interface fuzz
    #![proptest_config(ProptestConfig {
        rng_seed: proptest::test_runner::RngSeed::Fixed(0xF0_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn arbitrary_bytes_get_one_answer_per_line(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        check_answers(&bytes);
    }

    #[test]
    fn jsonish_bytes_get_one_answer_per_line(bytes in jsonish_bytes()) {
        check_answers(&bytes);
    }

    #[test]
    fn mutated_requests_of_every_op_are_answered(
        picks in prop::collection::vec((any::<usize>(), prop::collection::vec(arb_mutation(), 0..4)), 1..6)
    ) {
        let bases = valid_requests();
        let mut input = Vec::new();
        let mut ids = Vec::new();
        for (n, (pick, mutations)) in picks.iter().enumerate() {
            let Value::Object(mut req) = bases[pick % bases.len()].clone() else { unreachable!() };
            req.insert("id".to_owned(), json!(n));
            for m in mutations {
                apply(&mut req, m);
            }
            ids.push(req.get("id").cloned().unwrap_or(Value::Null));
            input.extend_from_slice(Value::Object(req).to_string().as_bytes());
            input.push(b'\n');
        }
        let answers = check_answers(&input);
        for (a, id) in answers.iter().zip(&ids) {
            prop_assert_eq!(&a["id"], id);
        }
    }
}

/// The unmutated starting points are all valid: the fuzz mutates requests that work.
#[test]
fn fuzz_starting_points_are_answered_ok() {
    let reqs = valid_requests();
    let mut input = Vec::new();
    for r in &reqs {
        input.extend_from_slice(r.to_string().as_bytes());
        input.push(b'\n');
    }
    for (r, a) in reqs.iter().zip(check_answers(&input)) {
        // ik from a crude target may legitimately fail to converge; every other op answers.
        if r["op"] != "ik" {
            assert_eq!(a["ok"], true, "{r} -> {a}");
        }
    }
}
