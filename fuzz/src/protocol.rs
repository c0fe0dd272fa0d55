//! Target `protocol`: the query protocol's line → request → answer path without a session
//! (`hl-interface/src/lib.rs` `handle_line` / `handle_request`, the ops of
//! `hl-interface/src/protocol/`).
//!
//! Whatever the bytes: exactly one answer, on one line, a JSON object whose `ok` is a boolean,
//! whose `id` echoes the request's, and whose error (if any) has a `kind` and a `message`; no
//! op panics (under libFuzzer a panic aborts before the transport's `catch_unwind` sees it; in
//! the replay tests an `internal_error` answer fails the test).
//!
//! Resource limits, applied to the request before it is answered (the protocol lets a client
//! ask for long computations on purpose; a fuzzer would only measure them):
//! * fields naming files (`file` of the library ops, a `model` other than the shipped `eclss`)
//!   are not followed: reading files is the library's and automation's to test;
//! * `simulate` runs at most [`MAX_STEPS`] steps, `ik` at most [`MAX_IK_ITERATIONS`] iterations
//!   and [`MAX_IK_RESTARTS`] restarts, `lib_evaluate` no geometry arrays;
//! * round shapes (`sphere`, `cylinder`, `cone`, anywhere in the request) have at most
//!   [`MAX_ROUND_FACETS`] facets: the protocol allows 256-meridian spheres, whose collision
//!   solid takes seconds to build (10^9 vertex-face tests), minutes under AddressSanitizer.

use serde_json::Value;

pub const MAX_STEPS: u64 = 20_000;
pub const MAX_IK_ITERATIONS: u64 = 2_000;
pub const MAX_IK_RESTARTS: u64 = 8;
pub const MAX_ROUND_FACETS: u64 = 32;

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // The transport hands one line at a time to `handle_line`.
    let line = text.split('\n').next().unwrap_or("");
    let answer = match serde_json::from_str::<Value>(line) {
        Ok(mut req) => {
            if !limit(&mut req) {
                return;
            }
            let a = robosim_hl_interface::handle_request(&req);
            check(&a, req.get("id").cloned().unwrap_or(Value::Null));
            a
        }
        Err(_) => {
            let a = robosim_hl_interface::handle_line(line);
            check(&a, Value::Null);
            a
        }
    };
    let _ = answer;
}

/// Applies the limits above; `false` when the request names a file.
fn limit(req: &mut Value) -> bool {
    let Some(obj) = req.as_object_mut() else {
        return true;
    };
    if obj.get("file").is_some_and(|f| !f.is_null()) {
        return false;
    }
    if let Some(Value::String(m)) = obj.get("model")
        && m != "eclss"
    {
        return false;
    }
    let op = obj
        .get("op")
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_owned();
    // absent or above `max`: `max`; a value of another type is left for the op to refuse
    let cap = |obj: &mut serde_json::Map<String, Value>, key: &str, max: u64| {
        let above = obj
            .get(key)
            .is_none_or(|v| v.as_f64().is_some_and(|n| n > max as f64));
        if above {
            obj.insert(key.to_owned(), Value::from(max));
        }
    };
    limit_facets(req);
    let Some(obj) = req.as_object_mut() else {
        return true;
    };
    match op.as_str() {
        "simulate" => cap(obj, "max_steps", MAX_STEPS),
        "ik" => {
            cap(obj, "max_iterations", MAX_IK_ITERATIONS);
            cap(obj, "restarts", MAX_IK_RESTARTS);
        }
        "lib_evaluate" => {
            obj.insert("geometry".to_owned(), Value::Bool(false));
        }
        _ => {}
    }
    true
}

/// The framing contract of every answer.
fn check(answer: &str, id: Value) {
    assert!(!answer.contains('\n'), "answer spans lines: {answer}");
    let v: Value = serde_json::from_str(answer)
        .unwrap_or_else(|e| panic!("answer is not JSON ({e}): {answer}"));
    let ok = v.get("ok").and_then(Value::as_bool);
    assert!(ok.is_some(), "answer without a boolean `ok`: {answer}");
    // The id is echoed as the server read it. Compared as text, not re-parsed: serde_json's
    // default number parser is not correctly rounded, so a 17-digit float (or a 130-digit
    // integer) can read back one ULP off (docs/fuzzing.md, "Findings").
    assert!(
        answer.starts_with(&format!("{{\"id\":{id},")),
        "id not echoed: {answer}"
    );
    if ok == Some(false) {
        let kind = v["error"]["kind"].as_str().unwrap_or("");
        assert!(
            !kind.is_empty() && v["error"]["message"].is_string(),
            "error without kind and message: {answer}"
        );
        assert_ne!(kind, "internal_error", "an op panicked: {answer}");
    }
}

/// Gives every round shape of the request at most [`MAX_ROUND_FACETS`] facets (serde_json
/// nests at most 128 deep, so the recursion is bounded).
fn limit_facets(v: &mut Value) {
    match v {
        Value::Object(o) => {
            if matches!(
                o.get("shape").and_then(Value::as_str),
                Some("sphere" | "cylinder" | "cone")
            ) && o
                .get("facets")
                .is_none_or(|f| f.as_f64().is_some_and(|n| n > MAX_ROUND_FACETS as f64))
            {
                o.insert("facets".to_owned(), Value::from(MAX_ROUND_FACETS));
            }
            o.values_mut().for_each(limit_facets);
        }
        Value::Array(a) => a.iter_mut().for_each(limit_facets),
        _ => {}
    }
}
