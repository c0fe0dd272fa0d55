//! Target `hfm`: Hierarchical Process / Fault Model files (seed §4.3;
//! `automation/src/model/parse.rs`): lex, parse, resolve names, then the consistency checks
//! and the DOT rendering every tool runs on a loaded model, and the fault graph the diagnoser
//! builds from it.
//!
//! Whatever the bytes: `parse_model` returns a model or an error with file:line:col; a model's
//! indices are in range (the checks, the depth and the DOT writer walk them all).

use robosim_automation::model::{check, parse_model};

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_model(text, "fuzz.hfm") {
        Ok(m) => {
            let findings = check::check_model(&m);
            for f in &findings {
                let _ = f.render("fuzz.hfm");
            }
            let _ = check::is_consistent(&findings);
            let _ = m.max_depth();
            let _ = m.source_failure_modes();
            let _ = m.to_dot();
            let _ = robosim_automation::diag::FaultGraph::new(&m);
            for p in 0..m.processes.len() {
                let _ = m.ancestor_at_depth(p, 0);
                assert!(
                    m.is_ancestor_or_self(m.root(), p),
                    "process {p} not under the root"
                );
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.starts_with("fuzz.hfm:"),
                "error without the file: {msg}"
            );
        }
    }
}
