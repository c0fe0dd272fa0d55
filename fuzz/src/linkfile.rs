//! Target `linkfile`: ROBOSIM link files (seed Table 2; `file-io/src/linkfile.rs`
//! `LinkFile::parse`, `polygons`, `solids`, `from_pseudo_inertia`) and what `robosim lang
//! load` makes of a set of them (`editor/src/robot.rs` `from_links`, `robot_transaction`,
//! against the keeper's checks in an in-memory `Store`).
//!
//! The input is one or more link files separated by lines `%%` (`fuzz.LOC`, `fuzz.L1`, …).
//! Whatever the bytes: each file parses or gives a `LinkFileError` naming it (a syntax error
//! at a line inside it); never a panic, unbounded time or memory. A file that parses writes
//! (`to_text`) a file that parses again to the same text (`lang load` reads what `lang run`
//! writes). When every file parses, the robot is built or refused with a message, and a built
//! robot's transaction is applied or refused by the store with a typed error (no panic).

use robosim_editor::robot::{from_links, robot_transaction};
use robosim_file_io::linkfile::{LinkFile, LinkFileError, from_pseudo_inertia};
use robosim_instance_space::Store;
use std::path::{Path, PathBuf};

/// Link files per input, at most (a robot's links).
pub const MAX_FILES: usize = 16;

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let parts: Vec<&str> = text.split("\n%%\n").collect();
    if parts.len() > MAX_FILES {
        return;
    }
    let mut links = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        let name = if k == 0 {
            "fuzz.LOC".to_string()
        } else {
            format!("fuzz.L{k}")
        };
        let path = PathBuf::from(&name);
        match LinkFile::parse(part, &path) {
            Ok(f) => {
                let written = f.to_text();
                match LinkFile::parse(&written, &path) {
                    Ok(g) => assert_eq!(
                        g.to_text(),
                        written,
                        "{name}: a written link file reads back different"
                    ),
                    Err(e) => panic!("{name}: a link file read, then written, does not read: {e}"),
                }
                if let Err(e) = f.solids(&path) {
                    check(&e, &path, part);
                }
                let _ = from_pseudo_inertia(&f.ainert);
                links.push((name, f));
            }
            Err(e) => check(&e, &path, part),
        }
    }
    if links.len() == parts.len()
        && let Ok(r) = from_links(links, "fuzz")
        && let Ok(tx) = robot_transaction(&r, "fuzz")
    {
        let _ = Store::new().apply(&tx).map_err(|e| e.to_string());
    }
}

fn check(e: &LinkFileError, path: &Path, text: &str) {
    match e {
        LinkFileError::Syntax { path: p, line, .. } => {
            assert_eq!(p, path, "error names another file: {e}");
            let lines = text.bytes().filter(|&b| b == b'\n').count() + 1;
            assert!(
                *line <= lines,
                "error at line {line} of a {lines}-line file: {e}"
            );
        }
        LinkFileError::Content { path: p, .. } | LinkFileError::Io { path: p, .. } => {
            assert_eq!(p, path, "error names another file: {e}");
        }
        // Reading and writing a file (robosim-input's errors): parsing text never gives these.
        LinkFileError::Input(_) | LinkFileError::Output(_) => {}
    }
    let _ = e.to_string();
}
