//! Issue 35 item 4: a refusal made from a typed error keeps that error on the Rust side
//! (`source()`, downcastable) while the wire still carries `{"kind", "message"}` only, the
//! message naming the field and the reason as before.

use robosim_hl_interface::protocol::kinematics;
use robosim_hl_interface::{ErrorKind, ProtocolError, handle_line};
use robosim_kinematics::json::JsonError;
use serde_json::{Value, json};
use std::error::Error;

fn no_library(_: &str) -> Option<robosim_kinematics::Robot> {
    None
}

/// An inline robot with a bad joint type: `bad_robot`, the robot reader's error kept.
#[test]
fn a_bad_inline_robot_keeps_the_readers_error() {
    let req = json!({"op": "fk", "robot": {"joints": [{"type": "hinge"}]}, "q": [0.0]});
    let e = kinematics::dispatch("fk", &req, &no_library)
        .expect("a kinematics op")
        .expect_err("a bad robot");
    assert_eq!(e.kind, "bad_robot");
    let cause = e.source().expect("the reader's error is kept");
    let json = cause
        .downcast_ref::<JsonError>()
        .expect("it is the robot reader's JsonError");
    assert_eq!(json.path, "robot.joints[0].type");
    assert_eq!(e.message, json.to_string(), "the message is the reader's");
    assert!(e.message.contains("robot.joints[0].type"), "{}", e.message);
}

/// The wire is unchanged: the error object has the kind and the message, nothing of the cause.
#[test]
fn the_wire_error_is_kind_and_message_only() {
    let line = r#"{"id": 7, "op": "fk", "robot": {"joints": [{"type": "hinge"}]}, "q": [0.0]}"#;
    let out: Value = serde_json::from_str(&handle_line(line)).expect("a JSON line");
    assert_eq!(out["ok"], false);
    let err = out["error"].as_object().expect("an error object");
    let mut keys: Vec<&str> = err.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["kind", "message"]);
    assert_eq!(err["kind"], "bad_robot");
    assert!(
        err["message"]
            .as_str()
            .is_some_and(|m| m.contains("robot.joints[0].type")),
        "{out}"
    );
}

/// Two refusals a client cannot tell apart are equal, whatever cause each keeps.
#[test]
fn equality_is_what_the_client_sees() {
    let io = std::io::Error::other("disk on fire");
    let with = ProtocolError::caused(ErrorKind::Session, io);
    let without = ProtocolError::new(ErrorKind::Session, "disk on fire");
    assert_eq!(with, without);
    assert!(with.source().is_some() && without.source().is_none());
    assert_eq!(with.to_string(), "session: disk on fire");
}
