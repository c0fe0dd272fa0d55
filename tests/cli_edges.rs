//! Command-line edges of issue 34 (items 12 and 17), across real processes:
//! `robosim up SCENE --library FILE` gives FILE to the keeper; `robosim completions bash`
//! ends quietly when its reader closes the pipe early.

use std::io::Read;
use std::process::{Command, Stdio};

use crate::common;

use common::{Down, Procs, ROBOSIM};

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

/// `robosim up SCENE --with simulator --sim-mode lockstep` (issue 39 item 2): the simulator `up`
/// starts steps only on command — it stands still until told, then takes exactly the steps
/// asked; `--sim-mode` without a simulator to start is refused, saying what to add.
#[test]
fn up_starts_a_lock_step_simulator_when_asked() {
    let p = Procs::new("uplock");
    let _down = Down(&p);
    let robosim = |args: &[&str]| {
        let out = Command::new(ROBOSIM)
            .args(args)
            .args(["--session", &p.name])
            .env("ROBOSIM_HOME", p.home.path())
            .output()
            .expect("run robosim");
        let text = String::from_utf8_lossy(&out.stdout).into_owned()
            + &String::from_utf8_lossy(&out.stderr);
        (out.status.success(), text)
    };
    let (ok, text) = robosim(&["up", "surgical_positioner_cell", "--sim-mode", "lockstep"]);
    assert!(!ok, "--sim-mode without a simulator was accepted: {text}");
    assert!(text.contains("--with simulator"), "{text}");
    let (ok, text) = robosim(&[
        "up",
        "surgical_positioner_cell",
        "--with",
        "simulator",
        "--sim-mode",
        "lockstep",
    ]);
    assert!(ok, "robosim up failed: {text}");
    let state = |what: &str| -> serde_json::Value {
        let (ok, text) = robosim(&["simctl", "get"]);
        assert!(ok, "simctl get ({what}) failed: {text}");
        serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{e}: {text}"))
    };
    let first = state("at start");
    assert_eq!(first["mode"], "lockstep", "{first}");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let still = state("after a wait");
    assert_eq!(
        still["steps"], first["steps"],
        "a lock-step simulator stepped on its own: {first} then {still}"
    );
    let (ok, text) = robosim(&["simctl", r#"{"cmd": "step", "n": 10}"#]);
    assert!(ok, "simctl step failed: {text}");
    // The steps are queued: wait until none is left (a deadline only against a hang), then
    // count them.
    let start = std::time::Instant::now();
    let after = loop {
        let s = state("while stepping");
        if s["queued_steps"] == 0 && s["steps"] != first["steps"] {
            break s;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "10 lock-step steps not done in 60 s: {s}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert_eq!(
        after["steps"].as_u64(),
        first["steps"].as_u64().map(|s| s + 10),
        "{after}"
    );
}
