//! Command-line edges of issue 34 (items 12 and 17), across real processes:
//! `robosim up SCENE --library FILE` gives FILE to the keeper; `robosim completions bash`
//! ends quietly when its reader closes the pipe early.

use std::io::Read;
use std::process::{Command, Stdio};

use crate::common;

use common::{Procs, ROBOSIM};

/// `robosim down` of the test's session when the test ends, however it ends.
struct Down<'a>(&'a Procs);

impl Drop for Down<'_> {
    fn drop(&mut self) {
        let _ = Command::new(ROBOSIM)
            .args(["down", "--session", &self.0.name])
            .env("ROBOSIM_HOME", self.0.home.path())
            .output();
    }
}

#[test]
fn up_with_library_gives_the_library_file_to_the_keeper() {
    let p = Procs::new("uplib");
    let lib = p.home.path().join("only_here.rsl");
    std::fs::write(
        &lib,
        "solid only_here_block {\n    part box(1 m, 1 m, 1 m)\n}\n\n\
         scene only_here_scene {\n    place block = only_here_block()\n}\n",
    )
    .expect("write the library file");
    let _down = Down(&p);
    let out = Command::new(ROBOSIM)
        .args(["up", "only_here_scene", "--library"])
        .arg(&lib)
        .args(["--session", &p.name])
        .env("ROBOSIM_HOME", p.home.path())
        .output()
        .expect("run robosim up");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "robosim up failed: {text}");
    let reader =
        robosim_instance_space::Reader::attach(&p.session(), "uplib-reader").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    assert!(
        snap.find("block").is_some(),
        "the scene's solid is not in the model: {text}"
    );
}

#[test]
fn completions_end_quietly_when_the_reader_closes_the_pipe() {
    let mut child = Command::new(ROBOSIM)
        .args(["completions", "bash"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run robosim completions");
    // `| head -c 16`: read a little, then close the pipe while the script is being written
    // (the script is larger than a pipe's buffer, checked below).
    let mut stdout = child.stdout.take().expect("stdout");
    let mut first = [0u8; 16];
    stdout.read_exact(&mut first).expect("the script's start");
    drop(stdout);
    let out = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    let full = Command::new(ROBOSIM)
        .args(["completions", "bash"])
        .output()
        .expect("run robosim completions");
    assert!(
        full.stdout.len() > 1 << 16,
        "the script ({} bytes) fits in a pipe's buffer: the test would not close the pipe mid-write",
        full.stdout.len()
    );
}
