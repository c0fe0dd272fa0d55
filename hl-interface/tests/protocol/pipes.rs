//! Interactive use: a client writes one request, waits for its answer, then writes the next,
//! through OS pipes, with the server's output behind a `BufWriter` — only a flush after every
//! answer lets this conversation proceed.

use robosim_hl_interface::serve;
use serde_json::Value;
use std::io::{BufRead, BufReader, BufWriter, Write};

#[test]
fn a_client_talks_to_serve_one_request_at_a_time_through_pipes() {
    let (req_rx, mut req_tx) = std::io::pipe().expect("pipe");
    let (ans_rx, ans_tx) = std::io::pipe().expect("pipe");
    let server = std::thread::spawn(move || serve(BufReader::new(req_rx), BufWriter::new(ans_tx)));
    let mut answers = BufReader::new(ans_rx);
    let mut line = String::new();
    let mut previous = Value::Null;
    for i in 0..5 {
        // Each request depends on the previous answer, as a planner's would.
        let q = if previous.is_null() {
            Value::from(vec![0.0; 6])
        } else {
            previous["tau"].clone()
        };
        let req = serde_json::json!({"id": i, "op": "gravity", "robot": "puma560", "q": q});
        writeln!(req_tx, "{req}").expect("write request");
        req_tx.flush().expect("flush request");
        line.clear();
        answers.read_line(&mut line).expect("read answer");
        let a: Value = serde_json::from_str(&line).expect("answer is JSON");
        assert_eq!(a["id"], i, "{line}");
        assert_eq!(a["ok"], true, "{line}");
        previous = a;
    }
    writeln!(req_tx, "not json").expect("write");
    req_tx.flush().expect("flush");
    line.clear();
    answers.read_line(&mut line).expect("read answer");
    assert!(line.contains("parse_error"), "{line}");
    drop(req_tx); // end of input: the server returns its counts
    let stats = server.join().expect("server thread").expect("serve");
    assert_eq!((stats.lines, stats.ok, stats.errors), (6, 5, 1));
    line.clear();
    assert_eq!(
        answers.read_line(&mut line).expect("read"),
        0,
        "nothing after the last answer"
    );
}

/// The flush contract without pipes: after each answer the writer is flushed, and what was
/// flushed ends with a whole line.
#[test]
fn serve_flushes_after_every_answer() {
    #[derive(Default)]
    struct Recorder {
        bytes: Vec<u8>,
        flushed_at: Vec<usize>,
    }
    impl Write for Recorder {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.bytes.extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            self.flushed_at.push(self.bytes.len());
            Ok(())
        }
    }
    let mut rec = Recorder::default();
    let input =
        "{\"id\":1,\"op\":\"ops\"}\nbad\n\n{\"id\":4,\"op\":\"lib_params\",\"name\":\"puma560\"}\n";
    serve(input.as_bytes(), &mut rec).expect("serve");
    let ends: Vec<usize> = rec
        .bytes
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(ends.len(), 4);
    assert_eq!(
        rec.flushed_at, ends,
        "one flush right after each answer line"
    );
}

/// The client notices a stream out of step or a server that is not speaking the protocol.
#[test]
fn the_client_refuses_answers_that_are_not_the_protocol() {
    use robosim_hl_interface::client::{Client, ClientError};
    let wrong_id: &[u8] = b"{\"id\":7,\"ok\":true}\n";
    let mut c = Client::new(wrong_id, Vec::new());
    assert!(matches!(
        c.call("ops", serde_json::json!({})),
        Err(ClientError::IdMismatch { sent: 1, .. })
    ));
    let mut c = Client::new(&b"hello\n"[..], Vec::new());
    assert!(matches!(
        c.call("ops", serde_json::json!({})),
        Err(ClientError::BadAnswer { id: 1, .. })
    ));
    let mut c = Client::new(&b""[..], Vec::new());
    assert!(matches!(
        c.call("ops", serde_json::json!({})),
        Err(ClientError::Closed { id: 1 })
    ));
    let no_kind: &[u8] = b"{\"id\":1,\"ok\":false,\"error\":{}}\n";
    let mut c = Client::new(no_kind, Vec::new());
    assert!(matches!(
        c.call("ops", serde_json::json!({})),
        Err(ClientError::BadAnswer { .. })
    ));
}
