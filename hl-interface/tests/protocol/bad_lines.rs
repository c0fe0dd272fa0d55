//! Lines a client should not send: each gets one error answer of the right kind, in place,
//! and the stream goes on.

use crate::{kind, run_bytes};
use robosim_hl_interface::handle_line;
use serde_json::{Value, json};

const GOOD: &str = r#"{"id": 100, "op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}"#;

#[test]
fn each_bad_line_gets_its_error_and_the_stream_goes_on() {
    // (line, expected id, expected kind, a piece of the message)
    let cases: Vec<(String, Value, &str, &str)> = vec![
        (
            "this is not json".into(),
            Value::Null,
            "parse_error",
            "input line 1: not JSON",
        ),
        (
            "[1, 2, 3]".into(),
            Value::Null,
            "bad_request",
            "got an array",
        ),
        ("42".into(), Value::Null, "bad_request", "got a number"),
        (
            r#"{"id": 3}"#.into(),
            json!(3),
            "bad_request",
            "op: missing",
        ),
        (
            r#"{"id": 4, "op": 7}"#.into(),
            json!(4),
            "bad_request",
            "op: expected a string",
        ),
        (
            r#"{"id": 5, "op": "fk", "robot": "puma560", "q": ["NaN", 0, 0, 0, 0, 0]}"#.into(),
            json!(5),
            "bad_request",
            "q[0]",
        ),
        // A bare NaN is not JSON at all.
        (
            r#"{"id": 6, "op": "fk", "robot": "puma560", "q": [NaN, 0, 0, 0, 0, 0]}"#.into(),
            Value::Null,
            "parse_error",
            "input line 13",
        ),
        // Wrong types: kinematics and dynamics name the field (their kinds are their own).
        (
            r#"{"id": 7, "op": "fk", "robot": "puma560", "q": "zero"}"#.into(),
            json!(7),
            "bad_request",
            "q",
        ),
        (
            r#"{"id": 8, "op": "gravity", "robot": "puma560", "q": {"a": 1}}"#.into(),
            json!(8),
            "invalid_request",
            "`q`",
        ),
        (
            r#"{"id": 81, "op": "gravity", "robot": "puma560", "q": [0, "NaN", 0, 0, 0, 0]}"#
                .into(),
            json!(81),
            "invalid_request",
            "`q`[1]",
        ),
        (
            r#"{"id": 82, "op": "check", "robot": "puma560", "q": [0, 0, "NaN", 0, 0, 0], "scene": {"objects": []}}"#
                .into(),
            json!(82),
            "bad_request",
            "q[2]",
        ),
        (
            r#"{"id": 9, "op": "fk", "robot": "nonesuch", "q": []}"#.into(),
            json!(9),
            "unknown_robot",
            "nonesuch",
        ),
        (
            r#"{"id": 10, "op": "mass_matrix", "robot": "nonesuch", "q": []}"#.into(),
            json!(10),
            "unknown_robot",
            "nonesuch",
        ),
        (
            r#"{"id": 11, "op": "fkk"}"#.into(),
            json!(11),
            "unknown_op",
            "known: fk, jacobian",
        ),
        (String::new(), Value::Null, "parse_error", "empty line"),
        ("   \t ".into(), Value::Null, "parse_error", "empty line"),
        (
            r#"{"id": 14, "op": "fk""#.into(),
            Value::Null,
            "parse_error",
            "not JSON",
        ),
        // Nesting deeper than the parser's limit is refused, not a stack overflow.
        ("[".repeat(100_000), Value::Null, "parse_error", "recursion"),
        (
            r#"{"id": 16, "op": "fk", "robot": "puma560", "q": [1e400, 0, 0, 0, 0, 0]}"#.into(),
            Value::Null,
            "parse_error",
            "out of range",
        ),
        (
            r#"{"id": {"nested": [1]}, "op": "collide", "a": {"shape": "blob"}}"#.into(),
            json!({"nested": [1]}),
            "bad_request",
            "a.shape",
        ),
    ];
    let mut input = Vec::new();
    for (line, ..) in &cases {
        input.extend_from_slice(line.as_bytes());
        input.push(b'\n');
        input.extend_from_slice(GOOD.as_bytes());
        input.push(b'\n');
    }
    let answers = run_bytes(&input);
    assert_eq!(answers.len(), 2 * cases.len());
    for (i, (line, id, want_kind, piece)) in cases.iter().enumerate() {
        let (raw, a) = &answers[2 * i];
        let short: String = line.chars().take(80).collect();
        assert_eq!(a["id"], *id, "{short} -> {raw}");
        assert_eq!(kind(a), *want_kind, "{short} -> {raw}");
        let msg = a["error"]["message"].as_str().expect("message");
        assert!(
            msg.contains(piece),
            "{short}: message {msg:?} lacks {piece:?}"
        );
        let (raw, next) = &answers[2 * i + 1];
        assert_eq!(next["id"], 100, "the good line after {short}: {raw}");
        assert_eq!(next["ok"], true, "the good line after {short}: {raw}");
    }
}

#[test]
fn invalid_utf8_crlf_and_a_last_line_without_newline() {
    let mut input = b"{\"id\": 1, \"op\": \"ops\"}\r\n".to_vec();
    input.extend_from_slice(b"{\"id\": 2, \"op\": \"f\xffk\"}\n");
    input.extend_from_slice(b"\xc3\x28\n");
    input.extend_from_slice(b"{\"id\": 4, \"op\": \"ops\"}");
    let answers = run_bytes(&input);
    assert_eq!(answers.len(), 4);
    assert_eq!(answers[0].1["ok"], true, "CRLF accepted");
    assert_eq!(kind(&answers[1].1), "parse_error");
    assert!(
        answers[1].0.contains("input line 2: not UTF-8"),
        "{}",
        answers[1].0
    );
    assert_eq!(kind(&answers[2].1), "parse_error");
    assert_eq!(
        answers[3].1["id"], 4,
        "a last line without a newline is answered"
    );
    assert_eq!(answers[3].1["ok"], true);
}

#[test]
fn handle_line_frames_one_line_with_id_and_ok_first() {
    let a = handle_line(
        r#"{"op": "gravity", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "id": "g1"}"#,
    );
    assert!(a.starts_with(r#"{"id":"g1","ok":true,"tau":["#), "{a}");
    assert!(!a.contains('\n'));
    let e = handle_line("nope");
    assert!(
        e.starts_with(r#"{"id":null,"ok":false,"error":{"kind":"parse_error""#),
        "{e}"
    );
    assert!(e.contains("at column 2"), "column of the bad token: {e}");
    assert_eq!(handle_line(""), handle_line("\r"));
}

#[test]
fn empty_input_gets_no_answers() {
    assert!(run_bytes(b"").is_empty());
}
