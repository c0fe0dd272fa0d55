//! `serve_with`: ops from outside the crates (a session's, in `robosim query --session`)
//! answered first, with the same framing, and listed by `ops` and `unknown_op`.

use robosim_hl_interface::{ErrorKind, Extension, ProtocolError, serve_with};
use serde_json::{Value, json};

#[test]
fn extension_ops_are_answered_first_with_state_and_listed() {
    let mut count = 0u64;
    let mut answer = |op: &str, req: &Value| -> Option<Result<Value, ProtocolError>> {
        match op {
            "COUNT" => {
                count += 1;
                Some(Ok(json!({"count": count})))
            }
            "REFUSE" => Some(Err(ProtocolError::new(
                ErrorKind::from_wire("no_session"),
                format!("refused {}", req["id"]),
            ))),
            "PANIC" => panic!("extension bug"),
            _ => None,
        }
    };
    let input = [
        r#"{"id": 1, "op": "COUNT"}"#,
        r#"{"id": 2, "op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}"#,
        r#"{"id": 3, "op": "COUNT"}"#,
        r#"{"id": 4, "op": "REFUSE"}"#,
        r#"{"id": 5, "op": "PANIC"}"#,
        r#"{"id": 6, "op": "ops"}"#,
        r#"{"id": 7, "op": "nope"}"#,
        r#"{"id": 8, "op": "COUNT"}"#,
    ]
    .join("\n");
    let mut out = Vec::new();
    let ext = Extension {
        ops: &[
            ("COUNT", "session"),
            ("REFUSE", "session"),
            ("PANIC", "session"),
        ],
        answer: &mut answer,
    };
    let stats = serve_with(input.as_bytes(), &mut out, ext).expect("serve_with");
    let answers: Vec<Value> = String::from_utf8(out)
        .expect("utf-8")
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    assert_eq!(answers.len(), 8);
    assert_eq!((stats.lines, stats.ok, stats.errors), (8, 5, 3));
    assert_eq!(answers[0], json!({"id": 1, "ok": true, "count": 1}));
    assert_eq!(answers[1]["ok"], true, "crate ops still answered");
    assert_eq!(answers[2]["count"], 2, "the extension keeps its state");
    assert_eq!(
        answers[3]["error"],
        json!({"kind": "no_session", "message": "refused 4"})
    );
    assert_eq!(
        answers[4]["error"]["kind"], "internal_error",
        "{}",
        answers[4]
    );
    let ops: Vec<&str> = answers[5]["ops"]
        .as_array()
        .expect("ops")
        .iter()
        .filter_map(|o| o["op"].as_str())
        .collect();
    assert_eq!(&ops[..3], ["COUNT", "REFUSE", "PANIC"]);
    assert!(ops.contains(&"simulate"));
    let msg = answers[6]["error"]["message"].as_str().expect("message");
    assert!(
        msg.contains("COUNT") && msg.contains("diag_diagnose"),
        "{msg}"
    );
    assert_eq!(answers[7]["count"], 3, "the stream went on after the panic");
}
