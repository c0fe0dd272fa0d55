//! A Rust client of the JSON-lines transport: a planner (or a test) holds one [`Client`] over
//! the two pipes of a `robosim query` process and calls ops one at a time.
//!
//! Each [`Client::call`] writes one request line with the next `id`, flushes, reads one answer
//! line and checks that it carries that `id`. The op's own failure (`ok: false`) is an
//! `Ok(Err(Refused))`; a broken conversation (I/O, end of stream, an answer that is not the
//! protocol's) is a [`ClientError`].
//!
//! Entry points: [`Client::spawn`] (start a process, e.g. `robosim query`), [`Client::new`]
//! (any reader/writer pair), [`Client::call`].

use serde_json::{Map, Value};
use std::io::{self, BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

/// The server answered `ok: false`: its error kind and message, unchanged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{kind}: {message}")]
pub struct Refused {
    pub kind: String,
    pub message: String,
}

/// The conversation itself failed; the client should not be used further after any of these.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// Writing the request or reading the answer failed (e.g. the server exited).
    #[error("query transport: {0}")]
    Io(#[from] io::Error),
    /// The server closed its output before answering request `id`.
    #[error("query transport: the server closed the stream before answering request {id}")]
    Closed { id: u64 },
    /// The answer line is not a protocol answer (not JSON, or no boolean `ok`).
    #[error("query transport: answer to request {id} is not a protocol answer: {line}")]
    BadAnswer { id: u64, line: String },
    /// The answer carries another `id`: the stream is out of step.
    #[error("query transport: sent request {sent}, got the answer to {got}")]
    IdMismatch { sent: u64, got: Value },
    /// `fields` given to [`Client::call`] is not a JSON object.
    #[error("query transport: request fields must be a JSON object, got {0}")]
    NotAnObject(Value),
}

/// One conversation with a query server over a reader (its answers) and a writer (requests).
pub struct Client<R, W> {
    answers: R,
    requests: W,
    next_id: u64,
    line: String,
}

impl Client<BufReader<ChildStdout>, ChildStdin> {
    /// Starts `command` (e.g. `robosim query`) with piped standard input and output and returns
    /// the process with a client on its pipes. Its standard error is inherited. The caller owns
    /// the `Child`: drop the client (closing the server's input, so it exits) and then wait.
    pub fn spawn(mut command: Command) -> io::Result<(Child, Self)> {
        let mut child = command
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            // Both were just configured as pipes, so `spawn` returned both handles.
            return Err(io::Error::other("child pipes missing"));
        };
        Ok((child, Client::new(BufReader::new(stdout), stdin)))
    }
}

impl<R: BufRead, W: Write> Client<R, W> {
    /// A client over any answer reader and request writer; ids start at 1.
    pub fn new(answers: R, requests: W) -> Self {
        Client {
            answers,
            requests,
            next_id: 1,
            line: String::new(),
        }
    }

    /// Sends `{"id": N, "op": op, ...fields}` and waits for its answer. Returns the answer's
    /// fields (without `id` and `ok`), or the server's refusal. `fields` must be an object
    /// (`serde_json::json!({})` for none); an `id` or `op` in it is replaced.
    pub fn call(&mut self, op: &str, fields: Value) -> Result<Result<Value, Refused>, ClientError> {
        let Value::Object(mut req) = fields else {
            return Err(ClientError::NotAnObject(fields));
        };
        let id = self.next_id;
        self.next_id += 1;
        req.insert("id".to_owned(), Value::from(id));
        req.insert("op".to_owned(), Value::from(op));
        writeln!(self.requests, "{}", Value::Object(req))?;
        self.requests.flush()?;
        self.line.clear();
        if self.answers.read_line(&mut self.line)? == 0 {
            return Err(ClientError::Closed { id });
        }
        let bad = || ClientError::BadAnswer {
            id,
            line: self.line.trim_end().to_owned(),
        };
        let Ok(Value::Object(mut answer)) = serde_json::from_str::<Value>(&self.line) else {
            return Err(bad());
        };
        let got = answer.remove("id").unwrap_or(Value::Null);
        if got != id {
            return Err(ClientError::IdMismatch { sent: id, got });
        }
        match answer.remove("ok") {
            Some(Value::Bool(true)) => Ok(Ok(Value::Object(answer))),
            Some(Value::Bool(false)) => {
                let e = answer.get("error").and_then(Value::as_object);
                let text = |m: Option<&Map<String, Value>>, k: &str| {
                    m.and_then(|m| m.get(k))
                        .and_then(Value::as_str)
                        .map(str::to_owned)
                };
                match (text(e, "kind"), text(e, "message")) {
                    (Some(kind), Some(message)) => Ok(Err(Refused { kind, message })),
                    _ => Err(bad()),
                }
            }
            _ => Err(bad()),
        }
    }
}
