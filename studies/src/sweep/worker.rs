//! `robosim sweep-worker`: reads job lines on stdin, runs each, writes its result line on
//! stdout (flushed), and ends at the end of its input. A study's panic is caught and reported
//! as that job's error (it would fail the same way on any worker); a job line that cannot be
//! read is answered with an error under the index it carries (0 when it carries none).
//!
//! Test hook (for the tests of a worker dying mid-job, `tests/sweep.rs`): with
//! `ROBOSIM_SWEEP_DIE_ON=I` in its environment, the worker kills itself with SIGKILL on
//! receiving job I — every time, or, with `ROBOSIM_SWEEP_DIE_ONCE=PATH`, only if it is the first
//! to create PATH. Nothing else reads these variables.

use super::protocol::{self, Outcome};
use super::study;
use std::io::{BufRead, Write};

/// Runs one job line: the index it carries (if it could be read) and its outcome.
pub fn run_line(line: &str) -> (usize, Outcome) {
    let (name, job) = match protocol::parse_job(line) {
        Ok(j) => j,
        Err(e) => {
            let index = serde_json::from_str::<serde_json::Value>(line)
                .ok()
                .and_then(|v| v["index"].as_u64())
                .unwrap_or(0) as usize;
            return (index, Err(e));
        }
    };
    let Some(def) = study::find(&name) else {
        return (job.index, Err(format!("unknown study {name:?}")));
    };
    let run = std::panic::catch_unwind(|| (def.run)(&job.params));
    let outcome = match run {
        Ok(Ok(values)) if values.len() == def.results.len() => Ok(values),
        Ok(Ok(values)) => Err(format!(
            "study {name} gave {} values for {} columns",
            values.len(),
            def.results.len()
        )),
        Ok(Err(e)) => Err(robosim_instance_space::error_chain(&e)),
        Err(p) => Err(format!(
            "the study panicked: {}",
            p.downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)")
        )),
    };
    (job.index, outcome)
}

/// The test hook: true when this worker should die on job `index`.
fn die_on(index: usize) -> bool {
    let Some(i) = std::env::var("ROBOSIM_SWEEP_DIE_ON")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    else {
        return false;
    };
    if i != index {
        return false;
    }
    match std::env::var_os("ROBOSIM_SWEEP_DIE_ONCE") {
        None => true,
        Some(path) => std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .is_ok(),
    }
}

/// Serves jobs from `input` to `output` until `input` ends.
pub fn serve(input: impl BufRead, mut output: impl Write) -> std::io::Result<()> {
    for line in input.lines() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        if let Some(i) = serde_json::from_str::<serde_json::Value>(&line)
            .ok()
            .and_then(|v| v["index"].as_u64())
            && die_on(i as usize)
        {
            // SAFETY: kill(2) on our own pid with a valid signal number; no memory is touched.
            unsafe {
                libc::kill(libc::getpid(), libc::SIGKILL);
            }
        }
        let (index, outcome) = run_line(&line);
        writeln!(output, "{}", protocol::result_line(index, &outcome))?;
        output.flush()?;
    }
    Ok(())
}
