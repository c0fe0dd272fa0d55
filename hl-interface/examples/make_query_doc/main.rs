//! Fills the two example sections of docs/query.md with real answers of the real binary:
//!
//! * between `<!-- examples:begin/end -->`: hl-interface/examples/requests.jsonl through
//!   `robosim query --input FILE` (the pure ops, no session);
//! * between `<!-- session-examples:begin/end -->`: hl-interface/examples/session_requests.jsonl
//!   through `robosim query --session docgen --input FILE` on a fresh session, brought up with
//!   `robosim up surgical_positioner_cell --session docgen` in a temporary ROBOSIM_HOME and
//!   taken down (`robosim down`) afterwards.
//!
//! Usage (any directory; the paths are the repository's):
//!
//! ```text
//! cargo build --bin robosim
//! cargo run -p robosim-hl-interface --example make_query_doc -- target/debug/robosim
//! ```
//!
//! The block format and the cutting rule are in `doc.rs`, shared with `tests/query_docs.rs`,
//! which checks that the doc still says what the binary answers.

#[allow(
    dead_code,
    reason = "doc.rs is shared with tests/query_docs.rs, which reads what this writes"
)]
mod doc;

use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The session the generator brings up (in its own temporary home, so no user session is
/// touched).
const SESSION: &str = "docgen";
/// The README's scene, whose robot (`positioner`) and object (`head`) the session requests name.
const SCENE: &str = "surgical_positioner_cell";

type Result<T> = std::result::Result<T, Box<dyn Error>>;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("hl-interface/ has a parent: the repository root")
        .to_owned()
}

/// `robosim ARGS` with ROBOSIM_HOME = `home`; its standard output, or an error naming the
/// command and carrying its standard error.
fn robosim(exe: &Path, home: &Path, args: &[&str]) -> Result<String> {
    // From the repository's root: the examples name URDF files by relative paths.
    let out = Command::new(exe)
        .args(args)
        .current_dir(repo())
        .env("ROBOSIM_HOME", home)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", exe.display()))?;
    if !out.status.success() {
        return Err(format!(
            "robosim {} failed ({}): {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        )
        .into());
    }
    Ok(String::from_utf8(out.stdout)?)
}

/// Each request line of `file` with its answer line.
fn pairs(file: &Path, answers: &str) -> Result<Vec<(String, String)>> {
    let requests: Vec<String> = std::fs::read_to_string(file)
        .map_err(|e| format!("{}: {e}", file.display()))?
        .lines()
        .map(str::to_owned)
        .collect();
    let answers: Vec<String> = answers.lines().map(str::to_owned).collect();
    if requests.len() != answers.len() {
        return Err(format!(
            "{}: {} requests but {} answers",
            file.display(),
            requests.len(),
            answers.len()
        )
        .into());
    }
    Ok(requests.into_iter().zip(answers).collect())
}

fn main() -> Result<()> {
    let exe = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .ok_or("usage: make_query_doc PATH/TO/robosim")?;
    let exe = std::fs::canonicalize(&exe).map_err(|e| format!("{}: {e}", exe.display()))?;
    let root = repo();
    let pure_file = root.join("hl-interface/examples/requests.jsonl");
    let session_file = root.join("hl-interface/examples/session_requests.jsonl");
    let home = tempfile::tempdir()?;

    let pure = robosim(
        &exe,
        home.path(),
        &["query", "--input", &pure_file.to_string_lossy()],
    )?;
    robosim(&exe, home.path(), &["up", SCENE, "--session", SESSION])?;
    let session = robosim(
        &exe,
        home.path(),
        &[
            "query",
            "--session",
            SESSION,
            "--input",
            &session_file.to_string_lossy(),
        ],
    );
    // Down whatever the query did; a failed query is the error to report.
    let down = robosim(&exe, home.path(), &["down", "--session", SESSION]);
    let session = session?;
    down?;

    let path = root.join("docs/query.md");
    let text = std::fs::read_to_string(&path)?;
    let text = doc::replace(&text, doc::PURE, &doc::render(&pairs(&pure_file, &pure)?))?;
    let text = doc::replace(
        &text,
        doc::SESSION,
        &doc::render(&pairs(&session_file, &session)?),
    )?;
    std::fs::write(&path, text)?;
    println!("wrote {}", path.display());
    Ok(())
}
