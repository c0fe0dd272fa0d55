//! The query protocol's JSON-lines transport (DESIGN.md, "The query protocol"; `robosim query`).
//!
//! One request per line, one answer per line, in order:
//!
//! ```text
//! {"id": 7, "op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}
//! {"id":7,"ok":true,"pose":[[..],[..],[..],[..]]}
//! {"id":8,"ok":false,"error":{"kind":"unreachable","message":"..."}}
//! ```
//!
//! The ops live in [`protocol`], one module per area, over the plain functions of the crates
//! that compute them. A request object is handed, whole, to each area's `dispatch` in turn
//! (kinematics, dynamics, collision, library, automation) until one claims its `op`; the answer
//! is that area's object with `id` (echoed from the request, `null` when absent) and `ok` put
//! first. Every refusal is one [`ProtocolError`] (an [`ErrorKind`] and a message); inline robots
//! and `{"urdf": PATH, "tip": LINK}` and `{"mjcf": PATH, "tip": BODY}` robots are read by
//! [`robot_json`].
//! Robot names resolve in the standard library first (`robosim_library::standard_robot`), then
//! among the kinematics crate's reference robots (`robosim_kinematics::builtin_robot`).
//!
//! Whatever a line holds, it gets exactly one answer line and the stream goes on. The
//! transport's own error kinds:
//!
//! * `parse_error` — the line is empty, not UTF-8, or not JSON (the message gives the input
//!   line number when [`serve`] reads it, and the column);
//! * `bad_request` — the line is JSON but not an object, or has no string `op`;
//! * `unknown_op` — no crate answers `op`; the message lists the known ops ([`OPS`]);
//! * `internal_error` — an op panicked. That is a bug in the op (input must never panic); the
//!   transport catches it so one bad request cannot take a planner's session down.
//!
//! Every other kind comes from the area that ran the op ([`ErrorKind`] lists them all).
//!
//! One op belongs to the transport itself: `{"op": "ops"}` answers `{"ops": [..]}`, the list of
//! every op this server answers, with the area that computes it.
//!
//! Entry points: [`handle_line`] (one line in, one line out), [`handle_request`] (an already
//! parsed request), [`serve`] (a whole stream, flushed after every answer), [`serve_with`]
//! (the same with more ops, e.g. a session's, answered first), [`protocol`] (the ops of each
//! area), [`robot_json`] (the inline robot format), [`cli`] (the `robosim query` command),
//! [`client::Client`] (a Rust client over a server's pipes), [`session`] (the simulation-library
//! ops on a running session: MOVEJ, MOVEJI, KINV, CHECK, …).

#![forbid(unsafe_code)]

pub mod cli;
pub mod client;
pub mod dataflow;
mod error;
pub mod planner;
pub mod plant;
pub mod protocol;
pub mod robot_json;
pub mod session;

pub use error::{ErrorKind, ProtocolError};

use robosim_kinematics::Robot;
use serde_json::{Map, Value};
use std::io::{self, BufRead, Write};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// Every op the transport answers, with the area (crate) that computes it, in dispatch order.
/// `ops` is the transport's own.
pub const OPS: &[(&str, &str)] = &[
    ("fk", "kinematics"),
    ("jacobian", "kinematics"),
    ("ik", "kinematics"),
    ("encoder_error", "kinematics"),
    ("id", "dynamics"),
    ("mass_matrix", "dynamics"),
    ("gravity", "dynamics"),
    ("fd", "dynamics"),
    ("simulate", "dynamics"),
    ("collide", "collision"),
    ("check", "collision"),
    ("lib_list", "library"),
    ("lib_params", "library"),
    ("lib_evaluate", "library"),
    ("diag_check", "automation"),
    ("diag_simulate", "automation"),
    ("diag_diagnose", "automation"),
    ("ops", "transport"),
];

/// Counts of one [`serve`] run: `lines` read, answered `ok` and answered with an error
/// (`lines == ok + errors` always).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ServeStats {
    pub lines: u64,
    pub ok: u64,
    pub errors: u64,
}

/// The robot resolver handed to every op: a standard-library name first, then a reference
/// robot of the kinematics crate. `None` for a name neither knows (the op answers
/// `unknown_robot`).
pub fn resolve_robot(name: &str) -> Option<Robot> {
    robosim_library::standard_robot(name).or_else(|| robosim_kinematics::builtin_robot(name))
}

/// Ops answered outside this crate's areas, consulted before them: e.g. the session ops of
/// `robosim query --session` (MOVEJ, CHECK, ... on a running Instance Space). `answer` returns
/// `None` for an op that is not its own; `ops` lists its ops with their area, for the `ops`
/// op and the `unknown_op` message.
pub struct Extension<'a> {
    pub ops: &'a [(&'a str, &'a str)],
    pub answer: &'a mut ExtensionFn<'a>,
}

/// An [`Extension`]'s answer function: `(op, whole request)` → its answer object or refusal,
/// `None` when `op` is not its own.
pub type ExtensionFn<'a> = dyn FnMut(&str, &Value) -> Option<Result<Value, ProtocolError>> + 'a;

/// Answers one parsed request with `extension`'s ops tried first, as [`serve_with`] does, and
/// returns the answer object (without `id` and `ok`) or the refusal — for clients that embed
/// the protocol instead of framing lines (the planner client, [`planner`]).
pub fn answer_with(
    req: &Value,
    extension: Extension<'_>,
) -> Result<Map<String, Value>, ProtocolError> {
    answer(req, &mut Some(extension))
}

/// Answers one request line; the result is one line of JSON without the trailing newline.
/// Never panics, whatever `line` holds (see the module docs for the error kinds).
pub fn handle_line(line: &str) -> String {
    handle_numbered(line, None, &mut None).0
}

/// Answers one parsed request value (an object with `op`, and `id` to echo), framed as one
/// JSON line without the trailing newline. [`handle_line`] is this after parsing.
pub fn handle_request(req: &Value) -> String {
    framed(id_of(req), answer(req, &mut None))
}

/// `line_no` (1-based) goes into transport error messages; the bool is "answered ok".
fn handle_numbered(
    line: &str,
    line_no: Option<u64>,
    ext: &mut Option<Extension<'_>>,
) -> (String, bool) {
    let at = line_no.map_or_else(String::new, |n| format!("input line {n}: "));
    let line = line.strip_suffix('\r').unwrap_or(line);
    if line.trim().is_empty() {
        let f = ProtocolError::new(
            ErrorKind::ParseError,
            format!("{at}empty line (expected one JSON request object)"),
        );
        return (framed(Value::Null, Err(f)), false);
    }
    match serde_json::from_str::<Value>(line) {
        Ok(req) => {
            let result = answer(&req, ext);
            let ok = result.is_ok();
            (framed(id_of(&req), result), ok)
        }
        Err(e) => {
            let f = ProtocolError::new(
                ErrorKind::ParseError,
                format!("{at}not JSON: {}", json_error(&e)),
            );
            (framed(Value::Null, Err(f)), false)
        }
    }
}

/// serde_json's message with "at line 1 column C" shortened to "at column C" (a request is a
/// single line, so its line number inside the request says nothing).
fn json_error(e: &serde_json::Error) -> String {
    let s = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    match s.strip_suffix(&suffix) {
        Some(head) if e.line() == 1 => format!("{head} at column {}", e.column()),
        _ => s,
    }
}

fn id_of(req: &Value) -> Value {
    req.get("id").cloned().unwrap_or(Value::Null)
}

/// The op's answer object (without `id`/`ok`) or its failure.
fn answer(
    req: &Value,
    ext: &mut Option<Extension<'_>>,
) -> Result<Map<String, Value>, ProtocolError> {
    let Some(obj) = req.as_object() else {
        return Err(ProtocolError::new(
            ErrorKind::BadRequest,
            format!(
                "expected a JSON object {{\"id\": .., \"op\": .., ..}}, got {}",
                type_name(req)
            ),
        ));
    };
    let op = match obj.get("op") {
        Some(Value::String(op)) => op.as_str(),
        None => return Err(ProtocolError::new(ErrorKind::BadRequest, "op: missing")),
        Some(other) => {
            return Err(ProtocolError::new(
                ErrorKind::BadRequest,
                format!("op: expected a string, got {}", type_name(other)),
            ));
        }
    };
    let extra_ops: &[(&str, &str)] = ext.as_ref().map_or(&[], |e| e.ops);
    if op == "ops" {
        let ops: Vec<Value> = extra_ops
            .iter()
            .chain(OPS)
            .map(|(op, area)| serde_json::json!({"op": op, "area": area}))
            .collect();
        let mut m = Map::new();
        m.insert("ops".to_owned(), Value::Array(ops));
        return Ok(m);
    }
    // The ops must not panic on input; should one do so all the same, the panic becomes this
    // request's `internal_error` answer and the session goes on. Nothing shared is mutated
    // by an op except the library's memo cache, whose mutex poisoning it already tolerates.
    let dispatched = guarded(op, || {
        ext.as_mut()
            .and_then(|e| (e.answer)(op, req))
            .or_else(|| dispatch(op, req))
    });
    match dispatched {
        None => Err(ProtocolError::new(
            ErrorKind::UnknownOp,
            format!(
                "op: no op named \"{op}\" (known: {})",
                extra_ops
                    .iter()
                    .chain(OPS)
                    .map(|(o, _)| *o)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
        Some(Ok(Value::Object(m))) => Ok(m),
        // Every crate answers an object; anything else is framed rather than dropped.
        Some(Ok(other)) => {
            let mut m = Map::new();
            m.insert("value".to_owned(), other);
            Ok(m)
        }
        Some(Err(f)) => Err(f),
    }
}

/// Runs one op's dispatch, turning a panic into that request's `internal_error`.
fn guarded(
    op: &str,
    f: impl FnOnce() -> Option<Result<Value, ProtocolError>>,
) -> Option<Result<Value, ProtocolError>> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        Some(Err(ProtocolError::new(
            ErrorKind::InternalError,
            panic_message(op, &p),
        )))
    })
}

/// Hands the request to each area's `dispatch` until one claims `op`.
fn dispatch(op: &str, req: &Value) -> Option<Result<Value, ProtocolError>> {
    dispatch_with_robots(op, req, &resolve_robot)
}

/// [`dispatch`] with robot names resolved by `robots` (a session's robots, then
/// [`resolve_robot`]: `session::Ops`), a panic of the op being its `internal_error`.
pub(crate) fn dispatch_with_robots(
    op: &str,
    req: &Value,
    robots: &dyn Fn(&str) -> Option<Robot>,
) -> Option<Result<Value, ProtocolError>> {
    protocol::mimic::dispatch(op, req)
        .or_else(|| protocol::kinematics::dispatch(op, req, robots))
        .or_else(|| protocol::dynamics::dispatch(op, req, robots))
        .or_else(|| protocol::collision::dispatch(op, req, robots))
        .or_else(|| protocol::library::dispatch(op, req, robots))
        .or_else(|| protocol::automation::dispatch(op, req, robots))
}

fn panic_message(op: &str, payload: &Box<dyn std::any::Any + Send>) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".to_owned());
    format!("op \"{op}\" panicked ({what}); this is a bug in the op, please report the request")
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// `{"id":ID,"ok":true,...answer}` or `{"id":ID,"ok":false,"error":{"kind","message"}}`, with
/// `id` and `ok` first so a reader of the stream sees them at a glance. An answer field named
/// `id` or `ok` would be shadowed by the envelope and is dropped.
fn framed(id: Value, result: Result<Map<String, Value>, ProtocolError>) -> String {
    let (ok, mut body) = match result {
        Ok(m) => (true, m),
        Err(f) => {
            let mut e = Map::new();
            e.insert("kind".to_owned(), Value::String(f.kind.as_str().to_owned()));
            e.insert("message".to_owned(), Value::String(f.message));
            let mut m = Map::new();
            m.insert("error".to_owned(), Value::Object(e));
            (false, m)
        }
    };
    body.remove("id");
    body.remove("ok");
    let head = format!("{{\"id\":{id},\"ok\":{ok}");
    if body.is_empty() {
        return head + "}";
    }
    // Display of a Value is compact JSON (no newlines; non-finite numbers become null).
    let rest = Value::Object(body).to_string();
    // `rest` is "{...}" with at least one member, so it is at least 2 bytes long and both
    // ends are ASCII braces.
    format!("{head},{}", &rest[1..])
}

/// Reads request lines from `input` until end of input and writes one answer line to `output`
/// for each, flushing after every answer (a planner can talk to it through pipes, one request
/// at a time). A line that is not UTF-8 is answered with `parse_error` like any other bad line;
/// so is a line longer than [`robosim_input::Limit::LINE`] (64 MiB, `ROBOSIM_MAX_LINE_BYTES`),
/// answered as soon as the limit is passed and then skipped to its newline without being held
/// (`robosim query < /dev/zero` answers once and holds at most the limit).
/// Returns the counts, or the first I/O error of either stream (e.g. a broken pipe when the
/// client goes away; an `InvalidInput` error when `ROBOSIM_MAX_LINE_BYTES` is not a size).
pub fn serve(input: impl BufRead, output: impl Write) -> io::Result<ServeStats> {
    serve_inner(input, output, &mut None)
}

/// [`serve`] with an [`Extension`]'s ops answered too (tried first), with the same framing,
/// error handling and flushing.
pub fn serve_with(
    input: impl BufRead,
    output: impl Write,
    extension: Extension<'_>,
) -> io::Result<ServeStats> {
    serve_inner(input, output, &mut Some(extension))
}

fn serve_inner(
    mut input: impl BufRead,
    mut output: impl Write,
    ext: &mut Option<Extension<'_>>,
) -> io::Result<ServeStats> {
    use robosim_input::{Limit, Line};
    let max = Limit::LINE
        .bytes()
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    let max = usize::try_from(max).unwrap_or(usize::MAX);
    let mut stats = ServeStats::default();
    let mut buf = Vec::new();
    loop {
        let line = robosim_input::read_line_bounded(&mut input, &mut buf, max)?;
        if line == Line::Eof {
            return Ok(stats);
        }
        stats.lines += 1;
        // A line past the limit is answered without looking at its bytes.
        let (text, ok) = if line == Line::TooLong {
            let f = ProtocolError::new(
                ErrorKind::ParseError,
                format!(
                    "input line {}: longer than {}, the limit for a request line (set {} to raise it); the rest of the line is skipped",
                    stats.lines,
                    robosim_input::format_bytes(max as u64),
                    Limit::LINE.env.unwrap_or("ROBOSIM_MAX_LINE_BYTES"),
                ),
            );
            (framed(Value::Null, Err(f)), false)
        } else {
            match std::str::from_utf8(&buf) {
                Ok(line) => handle_numbered(line, Some(stats.lines), ext),
                Err(e) => {
                    let f = ProtocolError::new(
                        ErrorKind::ParseError,
                        format!(
                            "input line {}: not UTF-8 (invalid byte at offset {})",
                            stats.lines,
                            e.valid_up_to()
                        ),
                    );
                    (framed(Value::Null, Err(f)), false)
                }
            }
        };
        if ok {
            stats.ok += 1;
        } else {
            stats.errors += 1;
        }
        output.write_all(text.as_bytes())?;
        output.write_all(b"\n")?;
        output.flush()?;
        if line == Line::TooLong {
            robosim_input::skip_line(&mut input)?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panicking_op_becomes_internal_error() {
        let r = guarded("boom_op", || panic!("index 9 out of range"));
        let Some(Err(f)) = r else {
            panic!("expected a failure, got {r:?}")
        };
        assert_eq!(f.kind, "internal_error");
        assert!(
            f.message.contains("boom_op") && f.message.contains("index 9"),
            "{}",
            f.message
        );
        let framed = framed(Value::from(3), Err(f));
        assert!(framed.starts_with(r#"{"id":3,"ok":false,"error":{"kind":"internal_error""#));
    }

    #[test]
    fn envelope_fields_win_over_answer_fields() {
        let mut m = Map::new();
        m.insert("ok".to_owned(), Value::from("shadowed"));
        m.insert("id".to_owned(), Value::from(99));
        m.insert("x".to_owned(), Value::from(1));
        assert_eq!(framed(Value::from(1), Ok(m)), r#"{"id":1,"ok":true,"x":1}"#);
        assert_eq!(
            framed(Value::Null, Ok(Map::new())),
            r#"{"id":null,"ok":true}"#
        );
    }
}
