//! Target `program`: ROBOSIM programs (seed Table 1; `editor/src/lang.rs` `parse`,
//! `editor/src/program.rs` `run`) and what `robosim lang run --as NAME` makes of one without a
//! session: its links ordered into a robot (`editor/src/robot.rs`), the robot's transaction
//! against the keeper's checks (an in-memory `Store`).
//!
//! Whatever the bytes: an output or a `LangError` naming the file given (`fuzz.rsim`) and a line
//! inside it; never a panic, a stack overflow, unbounded time or memory (the language has
//! registers and `ADD`: what a program may build is the interpreter's to bound). Every link file
//! a program stores writes a file that reads back (`lang load` reads what `lang run` writes:
//! issue 34, item 11). A robot built from the links is applied or refused by the store with a
//! typed error (no panic).

use robosim_editor::program::run as run_program;
use robosim_editor::robot::{from_links, order_links, robot_transaction};
use robosim_file_io::linkfile::LinkFile;
use robosim_instance_space::Store;
use std::path::Path;

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let out = match run_program(text, "fuzz.rsim") {
        Ok(o) => o,
        Err(e) => {
            assert_eq!(e.file, "fuzz.rsim", "error names another file: {e}");
            let lines = text.bytes().filter(|&b| b == b'\n').count() + 1;
            assert!(
                e.span.line <= lines,
                "error at line {} of a {lines}-line file: {e}",
                e.span.line
            );
            let _ = e.to_string();
            return;
        }
    };
    for l in &out.links {
        let written = l.file.to_text();
        if let Err(e) = LinkFile::parse(&written, Path::new(&l.name)) {
            panic!(
                "link {} stored by the program does not read back: {e}\n{written}",
                l.name
            );
        }
    }
    if out.links.is_empty() {
        return;
    }
    let links = out
        .links
        .iter()
        .map(|l| (l.name.clone(), l.file.clone()))
        .collect();
    if let Ok((_, links)) = order_links(links)
        && let Ok(r) = from_links(links, "fuzz")
        && let Ok(tx) = robot_transaction(&r, "fuzz")
    {
        let _ = Store::new().apply(&tx).map_err(|e| e.to_string());
    }
}
