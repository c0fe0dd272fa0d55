//! Issue #19, "a user's first hour": the command-line defects a newcomer met, each tried the way
//! they met it — the real binary, a real session, real pipes and directories.

use crate::common;

use common::{Procs, ROBOSIM};
use std::process::{Command, Output, Stdio};

/// `robosim ARGS` in the test's home (no `--session` added), from `cwd`.
fn robosim(p: &Procs, args: &[&str], cwd: &std::path::Path) -> Output {
    Command::new(ROBOSIM)
        .args(args)
        .env("ROBOSIM_HOME", p.home.path())
        .env_remove("ROBOSIM_SESSION")
        .current_dir(cwd)
        .output()
        .expect("run robosim")
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr)
}

/// Stops a session whatever the test's outcome.
struct Down<'a>(&'a Procs, String);
impl Drop for Down<'_> {
    fn drop(&mut self) {
        let _ = robosim(self.0, &["down", "--session", &self.1], self.0.home.path());
    }
}

/// Item 6: reading a session never creates it; a missing one is an error (exit 1) that names
/// the sessions that do run.
#[test]
fn reading_a_missing_session_is_an_error_and_creates_nothing() {
    let p = Procs::new("nope");
    let home = p.home.path();
    let _down = Down(&p, p.name.clone());
    // One running session, so the message has something to name.
    let up = robosim(&p, &["up", "puma560", "--session", &p.name], home);
    assert!(up.status.success(), "{}", text(&up));
    let before: Vec<_> = std::fs::read_dir(home).expect("home").flatten().collect();
    for args in [
        &["ps", "--session", "NOPE"][..],
        &["ps", "--json", "--session", "NOPE"],
        &["down", "--session", "NOPE"],
        &["query", "--session", "NOPE"],
        &["lib", "--session", "NOPE", "list"],
        &["simctl", "--session", "NOPE", r#"{"cmd": "pause"}"#],
        &["instantiate", "puma560", "--session", "NOPE"],
        &["set", "x", "a=1", "--session", "NOPE"],
        &["display", "--headless", "--session", "NOPE"],
        &["info", "--session", "NOPE"],
        &["export", "x.glb", "--session", "NOPE"],
        &["save", "x.rsm", "--session", "NOPE"],
    ] {
        let o = robosim(&p, args, home);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {t}");
        assert!(
            t.contains("no session NOPE") && t.contains(&format!("running sessions: {}", p.name)),
            "{args:?}: {t}"
        );
        assert!(!home.join("NOPE").exists(), "{args:?} created the session");
    }
    let after: Vec<_> = std::fs::read_dir(home).expect("home").flatten().collect();
    assert_eq!(before.len(), after.len());
    // The environment variable names the session as --session does.
    let o = Command::new(ROBOSIM)
        .args(["ps", "--json"])
        .env("ROBOSIM_HOME", home)
        .env("ROBOSIM_SESSION", &p.name)
        .output()
        .expect("ps");
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("ps --json is JSON");
    assert_eq!(v["session"], p.name.as_str());
    assert_eq!(v["processes"][0]["role"], "space");
}

/// Item 4: `up SCENE` on a session that holds another scene's model — running, or saved after
/// `down` — refuses, says what runs and how to do either other thing; `--fresh` moves the saved
/// model aside (nothing deleted) and starts SCENE.
#[test]
fn up_with_another_scene_says_what_happened_and_fresh_starts_over() {
    let p = Procs::new("again");
    let home = p.home.path();
    let s = p.name.clone();
    let _down = Down(&p, s.clone());
    let o = robosim(&p, &["up", "puma560", "--session", &s], home);
    assert!(o.status.success(), "{}", text(&o));
    // The same scene again: components are added to the running model, said on stderr.
    let o = robosim(&p, &["up", "puma560", "--session", &s], home);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("already runs scene puma560"),
        "{}",
        text(&o)
    );
    // Another scene while it runs.
    let o = robosim(&p, &["up", "stanford", "--session", &s], home);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    for want in [
        "already runs scene puma560",
        "stanford was not loaded",
        &format!("robosim instantiate stanford --session {s}"),
        &format!("robosim down --session {s} && robosim up stanford --session {s} --fresh"),
    ] {
        assert!(t.contains(want), "missing {want:?} in:\n{t}");
    }
    let o = robosim(&p, &["up", "stanford", "--fresh", "--session", &s], home);
    assert_eq!(o.status.code(), Some(1), "--fresh on a running session");
    // After down, from the journal.
    let o = robosim(&p, &["down", "--session", &s], home);
    assert!(o.status.success(), "{}", text(&o));
    let o = robosim(&p, &["up", "stanford", "--session", &s], home);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains("has a saved model (in its journal) of scene puma560")
            && t.contains(&format!(
                "robosim up puma560 --session {s} && robosim instantiate stanford"
            )),
        "{t}"
    );
    let o = robosim(&p, &["up", "stanford", "--fresh", "--session", &s], home);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let moved = t
        .lines()
        .find_map(|l| l.split_once("the saved model was moved to ").map(|x| x.1))
        .expect("says where the saved model went");
    assert!(
        std::fs::read_dir(moved)
            .expect("moved model")
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with("journal-")),
        "the journal was moved, not deleted"
    );
    let note = std::fs::read_to_string(
        robosim_instance_space::Session::open_in(home, Some(&s))
            .expect("session")
            .data_dir()
            .join(robosim_launcher::SCENE_NOTE),
    )
    .expect("scene note");
    assert_eq!(note, "stanford");
}

/// Item 7: a reader that closes the pipe early (`robosim up … | head -1`) ends the command
/// quietly: no panic message, exit 0, and the session is up (the work was done).
#[test]
fn a_closed_stdout_is_not_a_panic() {
    let p = Procs::new("pipe");
    let s = p.name.clone();
    let _down = Down(&p, s.clone());
    let mut child = Command::new(ROBOSIM)
        .args(["up", "puma560", "--session", &s])
        .env("ROBOSIM_HOME", p.home.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn up");
    // Close the read end before `up` prints anything: its first line meets a broken pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );
    let ps = robosim(&p, &["ps", "--json", "--session", &s], p.home.path());
    assert!(
        ps.status.success() && text(&ps).contains("\"space\""),
        "{}",
        text(&ps)
    );
}

/// Item 10: reports and benches without --out write under the working directory's
/// `robosim-reports/`, never into a `docs/` that happens to be there, and print the absolute
/// paths they wrote.
#[test]
fn reports_default_to_robosim_reports_and_say_where() {
    let p = Procs::new("rep");
    let cwd = tempfile::tempdir().expect("cwd");
    std::fs::create_dir(cwd.path().join("docs")).expect("a docs/ that is not ours");
    let o = robosim(&p, &["report", "library", "--quick"], cwd.path());
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let dir = cwd.path().join("robosim-reports");
    let abs = std::fs::canonicalize(&dir).expect("robosim-reports/ created");
    let written: Vec<&str> = t.lines().filter_map(|l| l.strip_prefix("wrote ")).collect();
    assert!(!written.is_empty(), "{t}");
    for w in written {
        assert!(
            std::path::Path::new(w).starts_with(&abs) && std::path::Path::new(w).is_file(),
            "{w} is not a file under {}",
            abs.display()
        );
    }
    assert_eq!(
        std::fs::read_dir(cwd.path().join("docs"))
            .expect("docs")
            .count(),
        0,
        "nothing written into docs/"
    );
}

/// Item 12: shell completions are generated for the usual shells and name the subcommands.
#[test]
fn completions_name_the_subcommands() {
    let p = Procs::new("compl");
    for shell in ["bash", "zsh", "fish"] {
        let o = robosim(&p, &["completions", shell], p.home.path());
        let t = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{shell}");
        for sub in ["up", "simctl", "render", "query"] {
            assert!(t.contains(sub), "{shell} completions lack {sub}");
        }
    }
    // Required arguments are clap's: `render` without an output is a usage error (exit 2).
    let o = robosim(&p, &["render", "puma560"], p.home.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}
