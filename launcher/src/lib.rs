//! The launcher: `robosim up / ps / down`, and the keeper process itself (`robosim space`).
//!
//! `up` starts the keeper and then only the components named with `--with` or declared by the
//! scene (an `automation { … }` effect: the automation plant, [`declared_components`]), each as its own
//! OS process in its own process group (so a Ctrl-C in the launching terminal does not take
//! the session down), logging to `<session>/run/<role>.log`. Processes register themselves in
//! the session's registry; `ps` reads it and `down` stops them (SIGTERM, then SIGKILL after
//! 10 s), components first and the keeper last so that its final checkpoint sees their last
//! writes.
//!
//! It sits beside the binary, above the spaces, the scene seam and the file interface it
//! starts sessions from: the keeper process ([`run_space`]) builds the Library Space and
//! instantiates the scene into an empty model (robosim-scene), or starts from a model file
//! ([`space_load`], robosim-file-io); [`up`] checks the scene exists before it starts anything.
//! Processes are started from the running executable (the `robosim` binary). Nothing below the
//! binary's floor depends on this crate.
//!
//! Entry points: [`run_space`] ([`run_space_with`] a [`Preload`]ed model, [`space_load`] from a
//! model file), [`up`], [`up_with_library`], [`up_from_file`] ([`up_load`] checks the file
//! first), [`ps`], [`down`]; errors are [`LaunchError`].

#![forbid(unsafe_code)]

pub mod entry;
mod error;

pub use error::LaunchError;

type Result<T> = std::result::Result<T, LaunchError>;

macro_rules! bail {
    ($($t:tt)*) => { return Err(LaunchError::Process(format!($($t)*))) };
}

fn io(what: &'static str) -> impl Fn(std::io::Error) -> LaunchError {
    move |source| LaunchError::Io { what, source }
}

use robosim_instance_space::{Client, KeeperOptions, Reader, Session};
use robosim_scene::load as scene;
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Components `up --with` can start: the name and the subcommand that runs it. Only what
/// this build has is offered (the design card's editor, file interface and high-level interface
/// processes join this list when they exist). `automation` is the automation layer's plant
/// (`robosim automation`, the ECLSS fault model by default); a scene that declares an
/// `automation { … }` effect has it started with its model and time scale without `--with`.
/// `dataflow` runs a dataflow graph file named with it, `--with dataflow=GRAPH` (`robosim
/// dataflow GRAPH`, docs/dataflow.md). `rules` runs a CLIPS rule base, `--with rules=FILE.clp`
/// or a shipped one by name (`rules=joint_guard`, [`robosim_rules::embedded::SHIPPED`]);
/// repeated, one process per rule base (`robosim rules FILE`, docs/rules.md).
pub const COMPONENTS: &[(&str, &str)] = &[
    ("simulator", "simulator"),
    ("display", "display"),
    ("automation", "automation"),
    ("dataflow", "dataflow"),
    ("rules", "rules"),
];

/// Where `rules=NAME` finds its rule base: a file NAME, else the shipped rule base NAME (with or
/// without `.clp`), whose compiled-in text the launcher writes into the session's run directory
/// (`run/rulebases/NAME.clp`) for the process to read.
enum RuleBase {
    File(PathBuf),
    Shipped(&'static str, &'static str),
}

fn rule_base(f: &str) -> Result<RuleBase> {
    let abs = std::path::absolute(f).map_err(io("the rule file"))?;
    if abs.is_file() {
        return Ok(RuleBase::File(abs));
    }
    let file = if f.ends_with(".clp") {
        f.to_owned()
    } else {
        format!("{f}.clp")
    };
    match robosim_rules::embedded::SHIPPED
        .iter()
        .find(|(n, _)| *n == file)
    {
        Some((n, text)) => Ok(RuleBase::Shipped(n, text)),
        None => bail!(
            "--with rules={f}: no such rule file, and not a shipped rule base (shipped: {})",
            robosim_rules::embedded::SHIPPED
                .iter()
                .map(|(n, _)| n.trim_end_matches(".clp"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The components scene `name` declares (its effects), with the arguments each is started with
/// besides `--session`: the automation plant of an `automation { … }` effect. A robot, link or
/// solid, and the built-in `demo`, declare none.
pub fn declared_components(
    lib: &robosim_library::Library,
    name: &str,
) -> Result<Vec<(String, Vec<String>)>> {
    if name == "demo" {
        return Ok(Vec::new());
    }
    let origin = robosim_scene::Origin::defaults(name);
    let Ok(robosim_library::Evaluated::Scene(sc)) = origin.evaluate(lib) else {
        return Ok(Vec::new());
    };
    Ok(sc
        .effects
        .automation
        .iter()
        .map(|a| {
            (
                "automation".to_owned(),
                vec![
                    "--model".to_owned(),
                    a.model.clone(),
                    "--time-scale".to_owned(),
                    a.time_scale.to_string(),
                ],
            )
        })
        .collect())
}

/// The file in `data/` where the keeper records the scene it loaded into the empty model, so
/// that a later `up` can tell whether the saved model is the scene it is asked for.
pub const SCENE_NOTE: &str = "scene";

/// How the scene note records a model the keeper started from a file (`space --load`).
const FILE_NOTE_PREFIX: &str = "file ";

/// A model the keeper starts from instead of its scene (`robosim space --load FILE`): what
/// [`preload`] makes of a model file.
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
        ) -> std::result::Result<
            robosim_instance_space::Transaction,
            robosim_file_io::ModelProblem,
        >,
    >,
}

/// Stands in a shipped rule base's arguments until its file is written (`up_start`).
const SHIPPED_MARK: &str = "\0shipped";

/// The dataflow graphs shipped in `automation/graphs/`, by file name, compiled in: `--with
/// dataflow=NAME` (with or without `.flow`) names one when no file NAME exists; its text is
/// written to `<session>/run/graphs/NAME.flow` for the process to read.
pub const SHIPPED_GRAPHS: &[(&str, &str)] = &[
    (
        "momentum_manager.flow",
        include_str!("../../automation/graphs/momentum_manager.flow"),
    ),
    (
        "energy_predictor.flow",
        include_str!("../../automation/graphs/energy_predictor.flow"),
    ),
];

/// What a bare `--with rules` or `--with dataflow` runs for a scene that names one (scene,
/// component, argument): the operational station's scheduler and momentum manager (issue 38
/// item 7). Any other scene needs `rules=FILE`, `dataflow=FILE`.
pub const SCENE_DEFAULTS: &[(&str, &str, &str)] = &[
    ("space_station_ops", "rules", "station_ops"),
    ("space_station_ops", "dataflow", "momentum_manager"),
];

/// Stands in a shipped graph's arguments until its file is written (`up_start`).
const SHIPPED_GRAPH_MARK: &str = "\0shipped-graph";

/// `robosim space`: recover, load the scene into an empty model, serve until SIGTERM.
pub fn run_space(
    session: Option<&str>,
    scene_name: Option<&str>,
    library: &[PathBuf],
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
    library: &[PathBuf],
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
    let lib = robosim_scene::instantiate::build_library_from(library, extra)?;
    let spin = robosim_instance_space::spin_from_env().map_err(LaunchError::Environment)?;
    let static_responses = std::env::var_os("ROBOSIM_BENCH_DYNAMIC_RESPONSES").is_none();
    // Writers and readers served at once (each `robosim query` is one of each).
    let defaults = KeeperOptions::default();
    let max_processes =
        robosim_instance_space::max_clients_from_env().map_err(LaunchError::Environment)?;
    let opts = KeeperOptions {
        durable,
        journal_copies,
        spin,
        static_responses,
        max_clients: max_processes.unwrap_or(defaults.max_clients),
        max_readers: max_processes.unwrap_or(defaults.max_readers),
        ..defaults
    };
    let (mut keeper, report) = robosim_instance_space::Keeper::start(&session, opts)?;
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
    // The sources (for tools that need the text: `save`, `load`) and the checked library
    // (what every process reads instead of parsing and checking the sources again).
    keeper.publish_library_checked(&lib.sources(), Some(&lib.encode_checked()))?;
    eprintln!(
        "space: Library Space published ({} declarations)",
        lib.declarations().len()
    );
    if let Some(p) = preload {
        let tx = (p.transaction)(keeper.store()).map_err(|source| LaunchError::Preload {
            what: p.what.clone(),
            source,
        })?;
        if !tx.is_empty() {
            let a = keeper
                .commit_local(&tx)
                .map_err(|source| LaunchError::Refused {
                    what: p.what.clone(),
                    source,
                })?;
            eprintln!(
                "space: loaded {} ({} objects, version {})",
                p.what,
                a.created.len(),
                a.version
            );
        }
        // What the model now comes from, for a later `up SCENE` (see `up_start`).
        robosim_instance_space::write_private(
            &session.data_dir().join(SCENE_NOTE),
            format!("{FILE_NOTE_PREFIX}{}", p.what).as_bytes(),
        )?;
    } else if keeper.store().is_empty()
        && let Some(name) = scene_name
    {
        let txs = scene::load_from(&lib, name)?;
        for tx in &txs {
            keeper
                .commit_local(tx)
                .map_err(|source| LaunchError::Refused {
                    what: format!("scene {name}"),
                    source,
                })?;
        }
        robosim_instance_space::write_private(
            &session.data_dir().join(SCENE_NOTE),
            name.as_bytes(),
        )?;
        eprintln!(
            "space: loaded scene {name} ({} objects, version {})",
            keeper.store().len(),
            keeper.store().version
        );
    }
    keeper.run()?;
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
        .map_err(|source| LaunchError::Start {
            role: role.to_owned(),
            source,
        })?;
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
    up_with_library(scene_name, with, session, &[], false, None)
}

/// What a session already holds when `up` is asked for a scene.
enum Existing {
    /// Nothing: a new session.
    Nothing,
    /// A saved model (journal/checkpoint in `data/`), from the recorded scene if known.
    Saved(Option<String>),
    /// A running keeper (pid), with the recorded scene if known.
    Running(u32, Option<String>),
}

fn existing(session: &Session) -> Existing {
    let recorded = std::fs::read_to_string(session.data_dir().join(SCENE_NOTE)).ok();
    if let Some(p) = session.processes().iter().find(|p| p.role == "space") {
        return Existing::Running(p.pid, recorded);
    }
    // The journal control file counts: a session whose journal vanished is refused by its
    // keeper, and `--fresh` must be able to move what is left aside.
    let saved = std::fs::read_dir(session.data_dir()).is_ok_and(|d| {
        d.flatten().any(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with("journal-")
                || n.starts_with("checkpoint-")
                || n == robosim_instance_space::journal::CONTROL_FILE
        })
    });
    if saved {
        Existing::Saved(recorded)
    } else {
        Existing::Nothing
    }
}

/// Moves a stopped session's saved model aside (`<session>/previous-<unix ms>/`) so the next
/// keeper starts empty; nothing is deleted.
fn move_aside(session: &Session) -> Result<PathBuf> {
    let ms = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis());
    let to = session.dir().join(format!("previous-{ms}"));
    std::fs::rename(session.data_dir(), &to).map_err(io("moving the saved model aside"))?;
    // Recreates data/ (0700).
    Session::open_in(
        session.dir().parent().unwrap_or(session.dir()),
        Some(session.name()),
    )?;
    Ok(to)
}

/// `robosim up SCENE --with … --library FILE… [--fresh]`
///
/// A session that already holds a model — a running keeper, or a saved journal after `down` —
/// keeps it: `up` adds the components to it when SCENE is the scene that model came from, and
/// otherwise refuses with the ways to do the other thing (instantiate SCENE into the session,
/// or `--fresh`, which moves the saved model aside and starts SCENE in an empty one).
///
/// `sim_mode`: the simulator's `--mode` (`realtime`, `fast`, `lockstep`) when `up` starts it;
/// without it the simulator's default (realtime). Naming it without a simulator to start is
/// refused.
pub fn up_with_library(
    scene_name: &str,
    with: &[String],
    session: Option<&str>,
    library: &[PathBuf],
    fresh: bool,
    sim_mode: Option<&str>,
) -> Result<()> {
    up_start(
        Start::Scene(scene_name),
        with,
        session,
        library,
        fresh,
        sim_mode,
    )
}

/// `robosim up --load FILE --with …`: a session whose keeper starts from a model file (checked
/// by the caller, the file interface). The file's model replaces what a stopped session held
/// (one journaled transaction); a running session is refused (use `robosim load`).
pub fn up_from_file(
    file: &Path,
    with: &[String],
    session: Option<&str>,
    library: &[PathBuf],
    sim_mode: Option<&str>,
) -> Result<()> {
    up_start(Start::File(file), with, session, library, false, sim_mode)
}

/// What a new keeper starts with.
#[derive(Clone, Copy)]
enum Start<'a> {
    Scene(&'a str),
    File(&'a Path),
    /// The model the session holds (saved or running), whatever it came from.
    Resume,
}

/// What the scene note says a session's model came from, in words.
fn origin_words(recorded: Option<&str>) -> String {
    match recorded {
        None => "a model of unknown origin".to_owned(),
        Some(r) => match r.strip_prefix(FILE_NOTE_PREFIX) {
            Some(file) => format!("the model loaded from {file}"),
            None => format!("scene {r}"),
        },
    }
}

/// The components named with `--with`, with their arguments, and the shipped rule bases and
/// graphs they name (written into the session's run directory once it exists).
struct Asked {
    named: Vec<(String, Vec<String>)>,
    shipped_rules: Vec<(&'static str, &'static str)>,
    shipped_graphs: Vec<(&'static str, &'static str)>,
}

/// Starts (or resumes, or adds to) a session: checks what `--with` names, what the keeper
/// starts from and what the session already holds, starts the keeper unless it runs, waits
/// until it serves the model, then starts the components that do not run yet.
fn up_start(
    start: Start<'_>,
    with: &[String],
    session: Option<&str>,
    library: &[PathBuf],
    fresh: bool,
    sim_mode: Option<&str>,
) -> Result<()> {
    if sim_mode.is_some() && !with.iter().any(|c| c == "simulator") {
        bail!("--sim-mode sets the mode of the simulator `up` starts: add `--with simulator`");
    }
    let asked = asked_components(start, with)?;
    let (mut components, start_args) = keeper_start(start, library)?;
    let session = Session::open(session)?;
    let running = reconcile_with_existing(&session, start, fresh, &start_args)?;
    let procs = session.processes();
    let keeper_pid = if running {
        procs
            .iter()
            .find(|p| p.role == "space")
            .map_or(0, |p| p.pid)
    } else {
        start_keeper(&session, &start_args)?
    };
    let version = wait_model_served(&session, keeper_pid)?;
    merge_asked(&mut components, asked.named);
    write_shipped(
        &session,
        &mut components,
        &asked.shipped_rules,
        &SHIPPED_RULES,
    )?;
    write_shipped(
        &session,
        &mut components,
        &asked.shipped_graphs,
        &SHIPPED_GRAPH,
    )?;
    if let Some(mode) = sim_mode {
        for (c, extra) in &mut components {
            if c == "simulator" {
                extra.extend(["--mode".to_owned(), mode.to_owned()]);
            }
        }
    }
    start_components(&session, &procs, &components, sim_mode)?;
    println!(
        "session {} up: keeper pid {keeper_pid}, model version {version}",
        session.name()
    );
    if components.iter().any(|(c, _)| c == "display") {
        println!("{}", display_note(&session));
    }
    print_ps(&session);
    Ok(())
}

/// Checks each `--with` component (`NAME` or `NAME=FILE`) and gives it its arguments; a bare
/// `rules`/`dataflow` runs what the scene names for it ([`SCENE_DEFAULTS`]). Nothing has
/// started yet when this refuses.
fn asked_components(start: Start<'_>, with: &[String]) -> Result<Asked> {
    let mut asked = Asked {
        named: Vec::new(),
        shipped_rules: Vec::new(),
        shipped_graphs: Vec::new(),
    };
    for c in with {
        // `NAME=FILE` names a component with the file it runs (`dataflow=GRAPH`).
        let (name, file) = match c.split_once('=') {
            Some((n, f)) => (n, Some(f)),
            None => (c.as_str(), None),
        };
        // a bare rules/dataflow runs what the scene names for it, if it does
        let file = file.or_else(|| match start {
            Start::Scene(scene_name) => SCENE_DEFAULTS
                .iter()
                .find(|(s, n, _)| *s == scene_name && *n == name)
                .map(|(_, _, a)| *a),
            _ => None,
        });
        if !COMPONENTS.iter().any(|(n, _)| *n == name) {
            bail!(
                "unknown component {name:?}; available: {}",
                COMPONENTS
                    .iter()
                    .map(|c| c.0)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        let extra = match (name, file) {
            ("dataflow", Some(f)) => dataflow_args(f, &mut asked.shipped_graphs)?,
            ("dataflow", None) => bail!(
                "the dataflow component runs a graph file: --with dataflow=FILE (docs/dataflow.md)"
            ),
            ("rules", Some(f)) => rules_args(f, &mut asked.shipped_rules)?,
            ("rules", None) => bail!(
                "the rules component runs a rule base: --with rules=FILE.clp, or a shipped one \
                 by name (rules=joint_guard) (docs/rules.md)"
            ),
            (_, Some(_)) => bail!("--with {c}: only dataflow=FILE and rules=FILE take a file"),
            (_, None) => Vec::new(),
        };
        asked.named.push((name.to_owned(), extra));
    }
    Ok(asked)
}

/// `dataflow=F`'s arguments: the graph file F (absolute: the component runs in another
/// directory), else the shipped graph F (noted in `shipped`, a mark until its file is written).
fn dataflow_args(f: &str, shipped: &mut Vec<(&'static str, &'static str)>) -> Result<Vec<String>> {
    let abs = std::path::absolute(f).map_err(io("the dataflow graph"))?;
    let file = if f.ends_with(".flow") {
        f.to_owned()
    } else {
        format!("{f}.flow")
    };
    if abs.is_file() {
        Ok(vec![abs.display().to_string()])
    } else if let Some((n, text)) = SHIPPED_GRAPHS.iter().find(|(n, _)| *n == file) {
        shipped.push((n, text));
        Ok(vec![SHIPPED_GRAPH_MARK.to_owned(), (*n).to_owned()])
    } else {
        bail!(
            "--with dataflow={f}: no such graph file, and not a shipped graph (shipped: {})",
            SHIPPED_GRAPHS
                .iter()
                .map(|(n, _)| n.trim_end_matches(".flow"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
}

/// `rules=F`'s arguments: the rule file F, else the shipped rule base F (noted in `shipped`).
/// A build without CLIPS says what to install, before anything starts.
fn rules_args(f: &str, shipped: &mut Vec<(&'static str, &'static str)>) -> Result<Vec<String>> {
    robosim_rules::available()
        .map_err(|e| LaunchError::Process(format!("--with rules={f}: {e}")))?;
    Ok(match rule_base(f)? {
        RuleBase::File(abs) => vec![abs.display().to_string()],
        RuleBase::Shipped(n, text) => {
            shipped.push((n, text));
            vec![SHIPPED_MARK.to_owned(), n.to_owned()]
        }
    })
}

/// What the keeper is started with (`--scene`/`--load`, then `--library` for each library
/// file), and the components the scene declares. A scene is checked against the library here,
/// before anything starts.
fn keeper_start(
    start: Start<'_>,
    library: &[PathBuf],
) -> Result<(Vec<(String, Vec<String>)>, Vec<String>)> {
    let mut components: Vec<(String, Vec<String>)> = Vec::new();
    let mut start_args: Vec<String> = match start {
        Start::Scene(scene_name) => {
            let lib = robosim_scene::build_library(library)?;
            scene::load_from(&lib, scene_name)?;
            components = declared_components(&lib, scene_name)?;
            vec!["--scene".into(), scene_name.into()]
        }
        Start::File(file) => {
            let abs = std::path::absolute(file).map_err(io("the model file"))?;
            vec!["--load".into(), abs.display().to_string()]
        }
        Start::Resume => Vec::new(),
    };
    // The keeper builds its own Library Space: it must be given the same library files the
    // scene was checked against here (absolute: the keeper runs in another directory), or a
    // scene that names a declaration only FILE declares is refused by the keeper.
    for file in library {
        let abs = std::path::absolute(file).map_err(io("the library file"))?;
        start_args.push("--library".into());
        start_args.push(abs.display().to_string());
    }
    Ok((components, start_args))
}

/// The refusal of `up SCENE` on a session that holds another model (`running` or saved),
/// with the two ways to get SCENE.
fn other_model(
    name: &str,
    scene_name: &str,
    running: bool,
    recorded: &Option<String>,
) -> LaunchError {
    let from = origin_words(recorded.as_deref());
    let (what, start, stop) = if running {
        (
            "already runs",
            String::new(),
            format!("robosim down --session {name} && "),
        )
    } else {
        let resume = match recorded.as_deref() {
            Some(r) if !r.starts_with(FILE_NOTE_PREFIX) => r,
            _ => "SCENE",
        };
        (
            "has a saved model (in its journal) of",
            format!("robosim up {resume} --session {name} && "),
            String::new(),
        )
    };
    LaunchError::Process(format!(
        "session {name} {what} {from}; {scene_name} was not loaded.\n  \
         to add {scene_name} to that model: {start}robosim instantiate {scene_name} --session {name}\n  \
         to start over with {scene_name}:   {stop}robosim up {scene_name} --session {name} --fresh   \
         (the saved model is moved aside, not deleted)"
    ))
}

/// Decides what happens to the model the session already holds (see [`up_with_library`]),
/// says so on stderr, and answers whether its keeper runs (else `up` starts one). `--fresh`
/// moves a saved model aside here.
fn reconcile_with_existing(
    session: &Session,
    start: Start<'_>,
    fresh: bool,
    start_args: &[String],
) -> Result<bool> {
    let name = session.name();
    Ok(match (existing(session), start) {
        (Existing::Running(pid, _), Start::File(_)) => bail!(
            "session {name} is running (keeper pid {pid}): load the file into it with \
             `robosim load {} --session {name}`",
            start_args[1]
        ),
        (Existing::Running(pid, _), Start::Scene(_)) if fresh => bail!(
            "session {name} is running (keeper pid {pid}); --fresh needs it stopped: \
             robosim down --session {name}"
        ),
        (Existing::Running(pid, recorded), Start::Scene(scene_name)) => {
            match recorded.as_deref() {
                Some(r) if r == scene_name => eprintln!(
                    "session {name} already runs scene {scene_name} (keeper pid {pid}); adding components"
                ),
                // A model whose origin was never recorded (a keeper started by hand, or by an
                // older robosim): keep it, and say that SCENE was not loaded.
                None => eprintln!(
                    "session {name} already runs a model (keeper pid {pid}) whose scene is not \
                     recorded; {scene_name} was not loaded (`robosim instantiate {scene_name}` adds \
                     it); adding components"
                ),
                Some(_) => return Err(other_model(name, scene_name, true, &recorded)),
            }
            true
        }
        (Existing::Saved(recorded), Start::File(file)) => {
            eprintln!(
                "session {name}: {} is replaced by {} (one journaled transaction)",
                origin_words(recorded.as_deref()),
                file.display()
            );
            false
        }
        (Existing::Saved(_), Start::Scene(_)) if fresh => {
            let to = move_aside(session)?;
            eprintln!(
                "session {name}: the saved model was moved to {}",
                to.display()
            );
            false
        }
        (Existing::Saved(recorded), Start::Scene(scene_name)) => {
            match recorded.as_deref() {
                Some(r) if r == scene_name => eprintln!(
                    "session {name}: resuming the saved model of scene {scene_name} from its \
                     journal (--fresh starts over)"
                ),
                None => eprintln!(
                    "session {name}: resuming its saved model from the journal; its scene is not \
                     recorded, so {scene_name} was not loaded (--fresh starts over with it)"
                ),
                Some(_) => return Err(other_model(name, scene_name, false, &recorded)),
            }
            false
        }
        (Existing::Running(pid, _), Start::Resume) => {
            eprintln!("session {name} already runs (keeper pid {pid}); adding components");
            true
        }
        (Existing::Saved(recorded), Start::Resume) => {
            eprintln!(
                "session {name}: resuming its saved model ({}) from the journal",
                origin_words(recorded.as_deref())
            );
            false
        }
        (Existing::Nothing, Start::Resume) => bail!("session {name} holds no model to resume"),
        (Existing::Nothing, _) => false,
    })
}

/// Starts the keeper (`robosim space`) and waits until it registers; says what its recovery
/// lost, if anything. Answers its pid.
fn start_keeper(session: &Session, start_args: &[String]) -> Result<u32> {
    let mut args = vec!["space", "--session", session.name()];
    args.extend(start_args.iter().map(String::as_str));
    let pid = spawn(session, "space", &args)?;
    wait_registered(session, "space", pid, Duration::from_secs(30))?;
    if let Ok(note) = std::fs::read_to_string(
        session
            .run_dir()
            .join(robosim_instance_space::journal::LOST_NOTE),
    ) {
        eprint!("robosim up: {note}");
    }
    Ok(pid)
}

/// Waits until the keeper serves: a client can connect and a reader sees the model. Answers
/// the model's version. A keeper that starts from a big model file (replacing what it
/// recovered) may publish later than a reader's 10 s: wait on while it lives, up to 5 minutes.
fn wait_model_served(session: &Session, keeper_pid: u32) -> Result<u64> {
    Client::connect(session, "launcher")?;
    let waiting = Instant::now();
    let reader = loop {
        match Reader::attach(session, "launcher-reader") {
            Err(robosim_instance_space::ReaderError::Timeout(_))
                if robosim_instance_space::pid_alive(keeper_pid)
                    && waiting.elapsed() < Duration::from_secs(300) => {}
            r => break r?,
        }
    };
    Ok(reader.snapshot().map_or(0, |s| s.version()))
}

/// Adds the `--with` components to the scene's declared ones: a name the scene declares is
/// started once, as the scene says; several rule bases are several processes (a rules
/// component is one per file).
fn merge_asked(components: &mut Vec<(String, Vec<String>)>, named: Vec<(String, Vec<String>)>) {
    for (c, extra) in named {
        if !components
            .iter()
            .any(|(n, e)| *n == c && (c != "rules" || *e == extra))
        {
            components.push((c, extra));
        }
    }
}

/// Where a kind of shipped file a component runs is written, and the mark its arguments hold
/// until then.
struct ShippedKind {
    component: &'static str,
    /// Subdirectory of `<session>/run/`.
    subdir: &'static str,
    mark: &'static str,
    dir_what: &'static str,
    file_what: &'static str,
}

const SHIPPED_RULES: ShippedKind = ShippedKind {
    component: "rules",
    subdir: "rulebases",
    mark: SHIPPED_MARK,
    dir_what: "the session's rulebases directory",
    file_what: "a shipped rule base",
};

const SHIPPED_GRAPH: ShippedKind = ShippedKind {
    component: "dataflow",
    subdir: "graphs",
    mark: SHIPPED_GRAPH_MARK,
    dir_what: "the session's graphs directory",
    file_what: "a shipped dataflow graph",
};

/// Writes each shipped rule base or graph into `<session>/run/<dir>/` and puts its path in
/// place of its mark in the components' arguments.
fn write_shipped(
    session: &Session,
    components: &mut [(String, Vec<String>)],
    shipped: &[(&str, &str)],
    kind: &ShippedKind,
) -> Result<()> {
    if shipped.is_empty() {
        return Ok(());
    }
    let dir = session.run_dir().join(kind.subdir);
    std::fs::create_dir_all(&dir).map_err(io(kind.dir_what))?;
    for (n, text) in shipped {
        let path = dir.join(n);
        std::fs::write(&path, text).map_err(io(kind.file_what))?;
        for (c, extra) in components.iter_mut() {
            if c == kind.component && extra[..] == [kind.mark, *n] {
                *extra = vec![path.display().to_string()];
            }
        }
    }
    Ok(())
}

/// Starts each component that does not run yet and waits until it registers. A running
/// rules process keeps its rule base, a running simulator its mode (both said on stderr).
fn start_components(
    session: &Session,
    procs: &[robosim_instance_space::ProcInfo],
    components: &[(String, Vec<String>)],
    sim_mode: Option<&str>,
) -> Result<()> {
    let rules_running = procs.iter().find(|p| p.role == "rules").map(|p| p.pid);
    for (c, extra) in components {
        if let (Some(pid), "rules") = (rules_running, c.as_str()) {
            // Which rule base a running rules process has is not recorded: keep what runs.
            eprintln!(
                "session {}: rules already run (pid {pid}); {} was not started (`robosim rules \
                 FILE --session {}` adds a rule base)",
                session.name(),
                extra.join(" "),
                session.name(),
            );
            continue;
        }
        if let Some(p) = procs.iter().find(|p| &p.role == c && c != "rules") {
            // A running simulator keeps its mode: say so when another was asked for.
            if let (Some(mode), "simulator") = (sim_mode, c.as_str()) {
                eprintln!(
                    "session {}: the simulator already runs (pid {}) in its own mode; --sim-mode \
                     {mode} was not applied (`robosim down`, then `up` again)",
                    session.name(),
                    p.pid,
                );
            }
            continue;
        }
        let Some((_, sub)) = COMPONENTS.iter().find(|(n, _)| n == c) else {
            continue;
        };
        let mut args = vec![*sub, "--session", session.name()];
        args.extend(extra.iter().map(String::as_str));
        let pid = spawn(session, c, &args)?;
        wait_registered(session, c, pid, Duration::from_secs(30))?;
    }
    Ok(())
}

/// Where the session's display shows its frames: a window with a display server, else PNG
/// files (`robosim display`'s headless default, `<session>/display/`).
fn display_note(session: &Session) -> String {
    let dir = session.dir().join("display");
    let server = ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()));
    if server {
        format!(
            "display: a window on this display server (without one its frames go to {}/latest.png)",
            dir.display()
        )
    } else {
        format!(
            "display: no display server, so headless: the latest frame is {}/latest.png (frames.jsonl beside it logs each)",
            dir.display()
        )
    }
}

/// `robosim up --session NAME` with no scene: resumes the session's saved model (or adds
/// `with` to the running one) — the scene it came from when one is recorded, with the
/// components that scene declares. A session that holds no model is refused, saying how to
/// start one.
pub fn up_resume(
    with: &[String],
    session: Option<&str>,
    library: &[PathBuf],
    sim_mode: Option<&str>,
) -> Result<()> {
    let s = Session::open(session)?;
    let name = s.name().to_owned();
    let recorded = match existing(&s) {
        Existing::Nothing => bail!(
            "session {name} holds no model to resume: start it with a scene \
             (`robosim up SCENE --session {name}`) or a model file \
             (`robosim up --load FILE --session {name}`)"
        ),
        Existing::Running(_, r) | Existing::Saved(r) => r,
    };
    // The recorded scene, when it can be found here (one of a user's library files needs
    // --library again), brings the components it declares; else the journal alone is resumed.
    let known = |scene: &str| {
        robosim_scene::build_library(library)
            .ok()
            .is_some_and(|lib| scene::load_from(&lib, scene).is_ok())
    };
    match recorded.as_deref() {
        Some(scene) if !scene.starts_with(FILE_NOTE_PREFIX) && known(scene) => {
            up_start(Start::Scene(scene), with, session, library, false, sim_mode)
        }
        _ => up_start(Start::Resume, with, session, library, false, sim_mode),
    }
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

/// `robosim ps [--json]`: a missing session is an error, and nothing is created.
pub fn ps(session: Option<&str>, json: bool) -> Result<()> {
    let session = Session::existing(session)?;
    if json {
        let v = serde_json::json!({
            "session": session.name(),
            "dir": session.dir(),
            "processes": session.processes(),
        });
        println!("{v}");
        return Ok(());
    }
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

/// `robosim down`. What it stopped is printed once everything is stopped, so a reader that
/// closes the pipe early (`| head -1`) cannot interrupt it half way.
pub fn down(session: Option<&str>) -> Result<()> {
    let session = Session::existing(session)?;
    let procs = session.processes();
    if procs.is_empty() {
        // Processes killed with -9 leave their shared memory behind: remove it.
        let left = session.remove_leftovers();
        println!("session {}: nothing running", session.name());
        if left.files > 0 {
            println!(
                "removed {} shared-memory file(s) left by processes that died ({} dead node(s))",
                left.files, left.dead_nodes
            );
        }
        return Ok(());
    }
    let (keepers, components): (Vec<_>, Vec<_>) =
        procs.into_iter().partition(|p| p.role == "space");
    let mut report = String::new();
    for p in components.iter().chain(keepers.iter()) {
        let clean = stop(p.pid, &p.role);
        report += &format!(
            "stopped {} (pid {}){}\n",
            p.role,
            p.pid,
            if clean { "" } else { " by SIGKILL" }
        );
    }
    print!("{report}");
    // Registry entries of processes that died without cleaning up; and, with every process of
    // the session gone, what they and iceoryx2 leave in /dev/shm (a killed process's segments,
    // the global management segment).
    if session.processes().is_empty() {
        session.remove_leftovers();
    }
    Ok(())
}

/// A keeper's start from a file (`robosim space --load FILE`): the file's Library Space
/// additions, and the transaction that replaces whatever the keeper recovered with the file's
/// model (one journaled transaction; an empty session just gets the creates).
pub fn preload(path: &Path) -> Result<Preload> {
    let model = robosim_file_io::format::read(path)?;
    let what = path.display().to_string();
    let library = model
        .library
        .iter()
        .map(|f| (f.name.clone(), f.text.clone()))
        .collect();
    Ok(Preload {
        what,
        library,
        transaction: Box::new(move |store: &robosim_instance_space::Store| {
            model
                .to_transaction(&robosim_file_io::session::roots_of(store))
                .map(|p| p.tx)
        }),
    })
}

/// `robosim up --load FILE --with …`: checks the file, then starts the session's keeper from it.
pub fn up_load(
    file: &Path,
    with: &[String],
    session: Option<&str>,
    library: &[PathBuf],
    sim_mode: Option<&str>,
) -> Result<()> {
    robosim_file_io::format::read(file)?;
    up_from_file(file, with, session, library, sim_mode)
}

/// `robosim space --load FILE`: the keeper, starting from the file's model (it replaces what
/// the session's journal held, as one journaled transaction).
pub fn space_load(
    file: &Path,
    session: Option<&str>,
    library: &[PathBuf],
    durable: bool,
    journal_copies: u8,
) -> Result<()> {
    let preload = preload(file)?;
    run_space_with(
        session,
        None,
        library,
        durable,
        journal_copies,
        Some(preload),
    )
}
