//! Target `edit`: `robosim edit` command lines (`editor/src/commands.rs` `execute`: the line
//! split into verb, words and `KEY = VALUE [UNIT]` arguments, then the edit) against an editor
//! on an in-memory `Store` instead of a session (the keeper's checks, no processes).
//!
//! Whatever the bytes, line by line: a message or an error message; never a panic, unbounded
//! time or memory. After the last line the store holds the editor's design: a restarted editor
//! reads back the same design (`design_from_snapshot`).
//!
//! Not run: the verbs that read or write files (`save`, `load`, `code`, `read-code`, `run`:
//! reading files is not what this target tests, and a fuzzer must not write where it is told);
//! lines asking more than [`MAX_FACETS`] facets (`N = …`; the editor allows 16,384, whose
//! sphere has 1.3·10⁸ polygons — see docs/fuzzing.md); lines after the [`MAX_LINES`]th.

use robosim_editor::commands::{Prompt, execute};
use robosim_editor::session::{Editor, design_from_snapshot};
use robosim_instance_space::{Snapshot, Store};

pub const MAX_LINES: usize = 64;
pub const MAX_FACETS: f64 = 64.0;
const FILE_VERBS: &[&str] = &["save", "load", "code", "read-code", "run"];

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let robot = "fuzzbot";
    let mut ed = match Editor::new(Store::new(), robot) {
        Ok(e) => e,
        Err(e) => panic!("a new design is refused by an empty store: {e}"),
    };
    let mut prompt = Prompt::default();
    for line in text.lines().take(MAX_LINES) {
        if skipped(line) {
            continue;
        }
        if let Ok(robosim_editor::commands::Outcome::Quit) = execute(&mut ed, &mut prompt, line) {
            break;
        }
    }
    let snap = Snapshot::from_store(&ed.space);
    match design_from_snapshot(&snap, robot) {
        Ok(d) => assert_eq!(
            &d,
            ed.design(),
            "the design read back from the store differs"
        ),
        Err(e) => panic!("the design cannot be read back from the store: {e}"),
    }
}

/// A line the target does not run (see the module docs). Mirrors the editor's own split:
/// text after `#` or `!` is a comment, `K = V` is `K=V`, words end at spaces and commas.
fn skipped(line: &str) -> bool {
    let code = line.split(['#', '!']).next().unwrap_or("");
    let glued: String = code.split('=').map(str::trim).collect::<Vec<_>>().join("=");
    let mut toks = glued
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty());
    let Some(verb) = toks.next() else {
        return false;
    };
    if FILE_VERBS.contains(&verb.to_ascii_lowercase().as_str()) {
        return true;
    }
    toks.any(|t| {
        t.split_once('=').is_some_and(|(k, v)| {
            k.eq_ignore_ascii_case("n")
                && v.trim_end_matches(|c: char| c.is_ascii_alphabetic())
                    .parse::<f64>()
                    .is_ok_and(|n| !(n <= MAX_FACETS))
        })
    })
}
