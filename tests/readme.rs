//! Issue #19 item 1: every shell block of README.md runs verbatim, the way doc tests run Rust
//! blocks. A block fenced ```` ```sh ```` runs; one fenced ```` ```sh norun ```` is shown only (the
//! first block is cargo itself: `tests/demo.rs` runs the demo and CI runs the tests).
//!
//! The blocks run in order, each as `bash -euo pipefail`, from a scratch directory that links
//! every top-level entry of the repository (so relative paths such as
//! `hl-interface/examples/…` resolve as from the repository root, and what the blocks write —
//! `puma.png`, `shots/` — lands in the scratch directory), with the built `robosim` first on
//! PATH, a fresh `ROBOSIM_HOME`, and no display server (the display runs headless).

use std::path::{Path, PathBuf};
use std::process::Command;

const ROBOSIM: &str = env!("CARGO_BIN_EXE_robosim");

/// The README's fenced blocks: (info string, first line number, text).
fn blocks(readme: &str) -> Vec<(String, usize, String)> {
    let mut out = Vec::new();
    let mut open: Option<(String, usize, String)> = None;
    for (i, line) in readme.lines().enumerate() {
        match (&mut open, line.strip_prefix("```")) {
            (None, Some(info)) => open = Some((info.trim().to_owned(), i + 2, String::new())),
            (Some(_), Some(rest)) if rest.trim().is_empty() => {
                out.extend(open.take());
            }
            (Some((_, _, text)), _) => {
                text.push_str(line);
                text.push('\n');
            }
            (None, None) => {}
        }
    }
    out
}

/// The sessions the README names (`--session NAME`), to stop whatever happens.
fn sessions(text: &str) -> Vec<String> {
    let words: Vec<&str> = text.split_whitespace().collect();
    let mut names: Vec<String> = words
        .windows(2)
        .filter(|w| w[0] == "--session")
        .map(|w| w[1].to_owned())
        .collect();
    names.sort();
    names.dedup();
    names
}

struct Cleanup {
    home: PathBuf,
    sessions: Vec<String>,
}

impl Drop for Cleanup {
    fn drop(&mut self) {
        for s in &self.sessions {
            let _ = Command::new(ROBOSIM)
                .args(["down", "--session", s])
                .env("ROBOSIM_HOME", &self.home)
                .output();
            robosim_instance_space::remove_shm_files(s);
        }
    }
}

#[test]
fn every_readme_shell_block_runs_verbatim() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let all = blocks(&readme);
    let runnable: Vec<_> = all
        .iter()
        .filter(|(info, _, _)| info == "sh" || info == "bash")
        .collect();
    assert!(
        runnable.len() >= 2,
        "the README's session and render blocks are runnable"
    );
    // Every shell block is either run or deliberately marked.
    for (info, line, _) in &all {
        if info.starts_with("sh") || info.starts_with("bash") {
            assert!(
                info == "sh" || info == "bash" || info.ends_with(" norun"),
                "README.md:{line}: block `{info}` is neither run nor marked norun"
            );
        }
    }
    let names = sessions(
        &runnable
            .iter()
            .map(|b| b.2.as_str())
            .collect::<Vec<_>>()
            .join("\n"),
    );
    // Session names are machine-wide in /dev/shm: a live session of the same name (someone's
    // own `lab`) would be joined, not created. Say so instead of disturbing it.
    for s in &names {
        let prefix = format!("rs_{s}_");
        let busy = std::fs::read_dir("/dev/shm")
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with(&prefix));
        assert!(
            !busy,
            "a session named {s} has shared memory on this machine (/dev/shm/{prefix}*): \
             stop it (`robosim down --session {s}`) before running this test"
        );
    }
    let scratch = tempfile::tempdir().expect("scratch dir");
    let home = tempfile::tempdir().expect("session home");
    let _cleanup = Cleanup {
        home: home.path().to_owned(),
        sessions: names,
    };
    for e in std::fs::read_dir(root).expect("repo root").flatten() {
        let name = e.file_name();
        if name == "target" || name == ".git" {
            continue;
        }
        std::os::unix::fs::symlink(e.path(), scratch.path().join(&name)).expect("symlink");
    }
    let bin_dir = Path::new(ROBOSIM).parent().expect("bin dir");
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for (_, line, text) in runnable {
        let out = Command::new("bash")
            .args(["-euo", "pipefail", "-c", text])
            .current_dir(scratch.path())
            .env("PATH", &path)
            .env("ROBOSIM_HOME", home.path())
            .env_remove("ROBOSIM_SESSION")
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .expect("run bash");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "README.md:{line}: the block failed ({}):\n{text}\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
            out.status
        );
        // A successful run says nothing called an error (issue #19 item 3).
        for l in stdout.lines().chain(stderr.lines()) {
            let lower = l.to_lowercase();
            assert!(
                !lower.starts_with("error") && !lower.contains(" error:"),
                "README.md:{line}: a successful block printed {l:?}"
            );
        }
    }
    // What the blocks say they write is there.
    assert!(scratch.path().join("puma.png").is_file());
    assert!(scratch.path().join("shots/latest.png").is_file());
}

#[test]
fn the_block_reader_finds_fences_and_info_strings() {
    let text = "a\n```sh norun\nx\n```\n\n```sh\ny --session s1\nz\n```\n";
    let b = blocks(text);
    assert_eq!(
        b,
        vec![
            ("sh norun".to_owned(), 3, "x\n".to_owned()),
            ("sh".to_owned(), 7, "y --session s1\nz\n".to_owned()),
        ]
    );
    assert_eq!(sessions(&b[1].2), vec!["s1".to_owned()]);
}
