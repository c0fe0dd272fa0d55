//! The launcher: `robosim up / ps / down`, and the keeper process itself (`robosim space`).
//!
//! `up` starts the keeper and then only the components named with `--with`, each as its own
//! OS process in its own process group (so a Ctrl-C in the launching terminal does not take
//! the session down), logging to `<session>/run/<role>.log`. Processes register themselves in
//! the session's registry; `ps` reads it and `down` stops them (SIGTERM, then SIGKILL after
//! 10 s), components first and the keeper last so that its final checkpoint sees their last
//! writes.
//!
//! It lives beside instantiation because starting a session means loading a scene: the keeper
//! process ([`run_space`]) builds the Library Space and instantiates the scene into an empty
//! model, and [`up`] checks the scene exists before it starts anything. Processes are started
//! from the running executable (the `robosim` binary).
//!
//! Entry points: [`run_space`] ([`run_space_with`] a [`Preload`]ed model), [`up`],
//! [`up_with_library`], [`up_from_file`], [`ps`], [`down`].

type Result<T> = std::result::Result<T, SceneError>;

macro_rules! bail {
    ($($t:tt)*) => { return Err(SceneError::Launch(format!($($t)*))) };
}

fn io(what: &str) -> impl Fn(std::io::Error) -> SceneError + '_ {
    move |e| SceneError::Launch(format!("{what}: {e}"))
}

fn keeper_err<E: std::fmt::Display>(e: E) -> SceneError {
    SceneError::Session(e.to_string())
}

use crate::SceneError;
use crate::load as scene;
use robosim_instance_space::{Client, KeeperOptions, Reader, Session};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Components `up --with` knows, and whether this build has them.
const COMPONENTS: &[(&str, Option<&str>)] = &[
    ("simulator", Some("simulator")),
    ("display", Some("display")),
    ("editor", None),
    ("file", None),
    ("hl", None),
];

/// A model the keeper starts from instead of its scene (`robosim space --load FILE`), prepared
/// by the file interface, which this crate does not depend on.
pub struct Preload {
    /// Where the model comes from (for messages).
    pub what: String,
    /// Library Space files the model's instances came from, besides the standard library.
    pub library: Vec<(String, String)>,
    /// The one transaction that replaces the recovered model with the preloaded one.
    #[expect(clippy::type_complexity, reason = "a one-off callback")]
    pub transaction: Box<
        dyn FnOnce(
            &robosim_instance_space::Store,
        ) -> std::result::Result<robosim_instance_space::Transaction, String>,
    >,
}

/// `robosim space`: recover, load the scene into an empty model, serve until SIGTERM.
pub fn run_space(
    session: Option<&str>,
    scene_name: Option<&str>,
    library: &[std::path::PathBuf],
    durable: bool,
    journal_copies: u8,
) -> Result<()> {
    run_space_with(session, scene_name, library, durable, journal_copies, None)
}

/// [`run_space`], starting from `preload` when given: its transaction replaces whatever the
/// keeper recovered (journaled like any other), and the scene is not loaded.
pub fn run_space_with(
    session: Option<&str>,
    scene_name: Option<&str>,
    library: &[std::path::PathBuf],
    durable: bool,
    journal_copies: u8,
    preload: Option<Preload>,
) -> Result<()> {
    if !(1..=2).contains(&journal_copies) {
        bail!("--journal-copies must be 1 or 2, got {journal_copies}");
    }
    let session = Session::open(session)?;
    // The Library Space: the standard library plus the given files, checked before anything
    // is published or instantiated.
    let extra = preload.as_ref().map_or(&[][..], |p| p.library.as_slice());
    let lib = crate::instantiate::build_library_from(library, extra)?;
    let opts = KeeperOptions {
        durable,
        journal_copies,
        ..KeeperOptions::default()
    };
    let (mut keeper, report) =
        robosim_instance_space::Keeper::start(&session, opts).map_err(keeper_err)?;
    eprintln!(
        "space: session {} at version {} (checkpoint {}, {} journal records replayed)",
        session.name(),
        keeper.store().version,
        report.checkpoint_version,
        report.replayed
    );
    for p in &report.problems {
        eprintln!("space: recovery: {p}");
    }
    // Lost data is said loudly, here and by `up` (from the keeper's note in run/).
    eprint!("{}", report.lost_message());
    keeper.publish_library(&lib.sources()).map_err(keeper_err)?;
    eprintln!(
        "space: Library Space published ({} declarations)",
        lib.declarations().len()
    );
    if let Some(p) = preload {
        let tx = (p.transaction)(keeper.store())
            .map_err(|e| SceneError::Instantiate(format!("{}: {e}", p.what)))?;
        if !tx.ops.is_empty() {
            let a = keeper
                .commit_local(&tx)
                .map_err(|e| SceneError::Instantiate(format!("{}: {e}", p.what)))?;
            eprintln!(
                "space: loaded {} ({} objects, version {})",
                p.what,
                a.created.len(),
                a.version
            );
        }
    } else if keeper.store().is_empty()
        && let Some(name) = scene_name
    {
        let txs = scene::load_from(&lib, name)?;
        for tx in &txs {
            keeper
                .commit_local(tx)
                .map_err(|e| SceneError::Instantiate(format!("scene {name}: {e}")))?;
        }
        eprintln!(
            "space: loaded scene {name} ({} objects, version {})",
            keeper.store().len(),
            keeper.store().version
        );
    }
    keeper.run().map_err(keeper_err)?;
    eprintln!("space: stopped at version {}", keeper.store().version);
    Ok(())
}

fn spawn(session: &Session, role: &str, args: &[&str]) -> Result<u32> {
    let exe = std::env::current_exe().map_err(io("the running executable"))?;
    let log_path = session.run_dir().join(format!("{role}.log"));
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .mode(0o600)
        .open(&log_path)
        .map_err(io("the log file"))?;
    let child = Command::new(exe)
        .args(args)
        .stdin(Stdio::null())
        .stdout(log.try_clone().map_err(io("the log file"))?)
        .stderr(log)
        .process_group(0)
        .spawn()
        .map_err(|e| SceneError::Launch(format!("cannot start {role}: {e}")))?;
    Ok(child.id())
}

fn wait_registered(session: &Session, role: &str, pid: u32, timeout: Duration) -> Result<()> {
    let start = Instant::now();
    loop {
        if session
            .processes()
            .iter()
            .any(|p| p.role == role && p.pid == pid)
        {
            return Ok(());
        }
        if !robosim_instance_space::pid_alive(pid) {
            let log = std::fs::read_to_string(session.run_dir().join(format!("{role}.log")))
                .unwrap_or_default();
            let tail: Vec<&str> = log.lines().rev().take(10).collect();
            bail!(
                "{role} (pid {pid}) exited during start-up; its log ends:\n{}",
                tail.into_iter().rev().collect::<Vec<_>>().join("\n")
            );
        }
        if start.elapsed() > timeout {
            bail!("{role} (pid {pid}) did not come up within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `robosim up SCENE --with …` with the standard library.
pub fn up(scene_name: &str, with: &[String], session: Option<&str>) -> Result<()> {
    up_with_library(scene_name, with, session, &[])
}

/// `robosim up SCENE --with … --library FILE…`
pub fn up_with_library(
    scene_name: &str,
    with: &[String],
    session: Option<&str>,
    library: &[std::path::PathBuf],
) -> Result<()> {
    up_start(Start::Scene(scene_name), with, session, library)
}

/// `robosim up --load FILE --with …`: a session whose keeper starts from a model file (checked
/// by the caller, the file interface). The file's model replaces what the session held.
pub fn up_from_file(
    file: &std::path::Path,
    with: &[String],
    session: Option<&str>,
    library: &[std::path::PathBuf],
) -> Result<()> {
    up_start(Start::File(file), with, session, library)
}

/// What a new keeper starts with.
enum Start<'a> {
    Scene(&'a str),
    File(&'a std::path::Path),
}

fn up_start(
    start: Start<'_>,
    with: &[String],
    session: Option<&str>,
    library: &[std::path::PathBuf],
) -> Result<()> {
    let session = Session::open(session)?;
    for c in with {
        match COMPONENTS.iter().find(|(n, _)| n == c) {
            None => bail!(
                "unknown component {c:?}; known: {}",
                COMPONENTS
                    .iter()
                    .map(|c| c.0)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Some((_, None)) => bail!(
                "component {c:?} is not part of this build yet; available: {}",
                COMPONENTS
                    .iter()
                    .filter(|c| c.1.is_some())
                    .map(|c| c.0)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Some(_) => {}
        }
    }
    let from_file = matches!(start, Start::File(_));
    let start_args: Vec<String> = match start {
        Start::Scene(scene_name) => {
            let lib = crate::build_library(library)?;
            scene::load_from(&lib, scene_name)?;
            vec!["--scene".into(), scene_name.into()]
        }
        Start::File(file) => {
            let abs = std::path::absolute(file).map_err(io("the model file"))?;
            vec!["--load".into(), abs.display().to_string()]
        }
    };
    let running = session.processes();
    let keeper_pid = match running.iter().find(|p| p.role == "space") {
        Some(p) if from_file => bail!(
            "session {} is running (keeper pid {}): load the file into it with `robosim load {} --session {}`",
            session.name(),
            p.pid,
            start_args[1],
            session.name()
        ),
        Some(p) => {
            eprintln!(
                "session {} already has a keeper (pid {}); adding components",
                session.name(),
                p.pid
            );
            p.pid
        }
        None => {
            let mut args = vec!["space", "--session", session.name()];
            args.extend(start_args.iter().map(String::as_str));
            let pid = spawn(&session, "space", &args)?;
            wait_registered(&session, "space", pid, Duration::from_secs(30))?;
            if let Ok(note) = std::fs::read_to_string(
                session
                    .run_dir()
                    .join(robosim_instance_space::journal::LOST_NOTE),
            ) {
                eprint!("robosim up: {note}");
            }
            pid
        }
    };
    // The keeper is up when a client can connect and a reader sees the model. A keeper that
    // starts from a big model file (replacing what it recovered) may publish later than a
    // reader's 10 s: wait on while it lives, up to 5 minutes.
    Client::connect(&session, "launcher").map_err(keeper_err)?;
    let waiting = Instant::now();
    let reader = loop {
        match Reader::attach(&session, "launcher-reader") {
            Err(robosim_instance_space::ReaderError::Timeout(_))
                if robosim_instance_space::pid_alive(keeper_pid)
                    && waiting.elapsed() < Duration::from_secs(300) => {}
            r => break r?,
        }
    };
    let version = reader.snapshot().map_or(0, |s| s.version());
    for c in with {
        if running.iter().any(|p| &p.role == c) {
            continue;
        }
        let Some((_, Some(sub))) = COMPONENTS.iter().find(|(n, _)| n == c) else {
            continue;
        };
        let pid = spawn(&session, c, &[sub, "--session", session.name()])?;
        wait_registered(&session, c, pid, Duration::from_secs(30))?;
    }
    println!(
        "session {} up: keeper pid {keeper_pid}, model version {version}",
        session.name()
    );
    print_ps(&session);
    Ok(())
}

fn print_ps(session: &Session) {
    let procs = session.processes();
    println!("{:<12} {:>8} {:>9}  attached to", "ROLE", "PID", "UPTIME");
    let now_ms = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64);
    for p in procs {
        let up_s = now_ms.saturating_sub(p.started_unix_ms) as f64 / 1000.0;
        println!(
            "{:<12} {:>8} {:>8.1}s  {}",
            p.role,
            p.pid,
            up_s,
            p.attached.join(", ")
        );
    }
}

/// `robosim ps`
pub fn ps(session: Option<&str>) -> Result<()> {
    let session = Session::open(session)?;
    println!("session {} ({})", session.name(), session.dir().display());
    print_ps(&session);
    Ok(())
}

fn signal(pid: u32, sig: &str) {
    let _ = Command::new("kill")
        .args([&format!("-{sig}"), &pid.to_string()])
        .stderr(Stdio::null())
        .status();
}

fn stop(pid: u32, role: &str) -> bool {
    signal(pid, "TERM");
    let start = Instant::now();
    while robosim_instance_space::pid_alive(pid) {
        if start.elapsed() > Duration::from_secs(10) {
            eprintln!("{role} (pid {pid}) ignored SIGTERM for 10 s; sending SIGKILL");
            signal(pid, "KILL");
            return false;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    true
}

/// `robosim down`
pub fn down(session: Option<&str>) -> Result<()> {
    let session = Session::open(session)?;
    let procs = session.processes();
    if procs.is_empty() {
        println!("session {}: nothing running", session.name());
        return Ok(());
    }
    let (keepers, components): (Vec<_>, Vec<_>) =
        procs.into_iter().partition(|p| p.role == "space");
    for p in components.iter().chain(keepers.iter()) {
        let clean = stop(p.pid, &p.role);
        println!(
            "stopped {} (pid {}){}",
            p.role,
            p.pid,
            if clean { "" } else { " by SIGKILL" }
        );
    }
    // Registry entries of processes that died without cleaning up; and, with every process of
    // the session gone, what iceoryx2 leaves in /dev/shm (its global management segment).
    if session.processes().is_empty() {
        for (path, _) in session.shm_files() {
            let _ = std::fs::remove_file(path);
        }
    }
    Ok(())
}
