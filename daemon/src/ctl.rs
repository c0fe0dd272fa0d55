//! `robosim simctl --session S COMMAND…`: commands to the session's simulator, in order.
//!
//! A command is a JSON object (`'{"cmd": "target", "robot": "puma560", "q": [0, 0.5, 0, 0, 0, 0]}'`)
//! or one of the bare words `get`, `pause`, `resume`, `step` (one step) and `reset`. Each
//! answer goes to stdout — `ok`, or for `get` the simulator's state as one JSON line
//! ([`crate::status`]). A refused command stops there: the refusal is the error the caller
//! prints once (on stderr, exit status 1), and the commands after it are not sent.

use crate::{DaemonError, Result};
use robosim_instance_space::Session;
use robosim_instance_space::state::CommandSender;
use serde_json::Value;
use std::io::Write;
use std::time::Duration;

/// Commands that may be given as a bare word.
const BARE: &[&str] = &["get", "pause", "resume", "step", "reset"];

/// How long to wait for the simulator's answer to one command.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// The command as the JSON text the simulator reads: a bare word becomes `{"cmd": WORD}`.
fn command_text(c: &str) -> Result<String> {
    if BARE.contains(&c.trim()) {
        return Ok(serde_json::json!({"cmd": c.trim()}).to_string());
    }
    let v: Value = serde_json::from_str(c).map_err(|e| {
        DaemonError::Usage(format!(
            "command {c:?} is neither JSON ({e}) nor one of {}",
            BARE.join(", ")
        ))
    })?;
    if v.get("cmd").and_then(Value::as_str).is_none() {
        return Err(DaemonError::Usage(format!(
            "command {c} has no \"cmd\" string"
        )));
    }
    Ok(c.to_owned())
}

/// Sends `commands` to the simulator of `session` (module docs).
pub fn ctl(session: Option<&str>, commands: &[String]) -> Result<()> {
    // Every command is checked before the first is sent: a typo in the third must not leave
    // the first two applied.
    let texts = commands
        .iter()
        .map(|c| command_text(c))
        .collect::<Result<Vec<_>>>()?;
    let session = Session::open(session)?;
    let mut sender = CommandSender::open(&session, "simulator", "simctl")?;
    let mut out = std::io::stdout().lock();
    for text in texts {
        let answer = sender.send(text.as_bytes(), ANSWER_TIMEOUT)?;
        let answer = String::from_utf8_lossy(&answer).into_owned();
        if let Some(reason) = answer.strip_prefix("refused: ") {
            return Err(DaemonError::Refused {
                command: text,
                reason: reason.to_owned(),
            });
        }
        // A closed stdout (`| head -1`) ends the output, not the commands' effect.
        if writeln!(out, "{answer}").is_err() {
            return Ok(());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bare_words_become_commands_and_anything_else_must_be_a_json_command() {
        assert_eq!(command_text("get").expect("bare"), r#"{"cmd":"get"}"#);
        assert_eq!(command_text(" step ").expect("bare"), r#"{"cmd":"step"}"#);
        let j = r#"{"cmd": "step", "n": 3}"#;
        assert_eq!(command_text(j).expect("json"), j);
        let e = command_text("stpe").expect_err("typo").to_string();
        assert!(e.contains("\"stpe\"") && e.contains("get, pause"), "{e}");
        let e = command_text(r#"{"n": 3}"#).expect_err("no cmd").to_string();
        assert!(e.contains("no \"cmd\""), "{e}");
    }
}
