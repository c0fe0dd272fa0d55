//! `robosim`: one binary, one subcommand per process role and tool (DESIGN.md, "Layout").
//!
//! Processes: `space` (the keeper), `simulator`; launcher: `up`, `ps`, `down`; tools: `demo`,
//! `bench`.

mod bench;
mod cli;
mod reports;
mod sweep_remote;

use clap::{Parser, Subcommand};
use robosim_hl_interface::session;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "robosim",
    version,
    about = "Robot and structure simulation over a shared Instance Space (after NASA-CR-185444)"
)]
struct Cli {
    /// The session to start, join or read (its help line, with the default, is set at run time:
    /// see `session_help`).
    #[arg(long, global = true, env = "ROBOSIM_SESSION", value_name = "NAME")]
    session: Option<String>,
    /// Print less: no progress bars; iceoryx2 prints nothing. Results and errors still print.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Print more: -v iceoryx2's warnings, -vv its info, -vvv its debug messages.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the space keeper of a session (normally started by `robosim up`).
    Space {
        /// Scene to load when the session's model is empty.
        #[arg(long)]
        scene: Option<String>,
        /// Start from this model file (`robosim save`): it replaces what the session held.
        #[arg(long, conflicts_with = "scene")]
        load: Option<std::path::PathBuf>,
        /// Library files to add to the session's Library Space (besides the standard library).
        #[arg(long)]
        library: Vec<std::path::PathBuf>,
        /// Do not sync the journal before acknowledging (benchmarks only).
        #[arg(long, hide = true)]
        no_sync: bool,
        /// Copies of the journal: 2 (default) also writes every record to a mirror file, so one
        /// damaged record is read from the other copy instead of cutting the records after it.
        #[arg(long, default_value_t = 2)]
        journal_copies: u8,
    },
    /// Start a session: the keeper with SCENE, and only the components named with --with or
    /// declared by SCENE (an `automation { … }` effect starts the automation plant). A session
    /// that already holds a model (running, or saved in its journal) keeps it.
    Up {
        /// The library scene or robot to load (`robosim lib list`).
        #[arg(required_unless_present = "load")]
        scene: Option<String>,
        /// Start the session from this model file (`robosim save`) instead of a scene.
        #[arg(long, conflicts_with = "scene")]
        load: Option<std::path::PathBuf>,
        /// Comma-separated components to start beside the keeper.
        #[arg(long, value_delimiter = ',', value_parser = component_names())]
        with: Vec<String>,
        /// Library files to add to the session's Library Space.
        #[arg(long)]
        library: Vec<std::path::PathBuf>,
        /// Start SCENE in an empty model: a stopped session's saved model is moved aside to
        /// `<session>/previous-<time>/` (nothing is deleted).
        #[arg(long)]
        fresh: bool,
    },
    /// List a session's processes: role, pid, what each is attached to.
    Ps {
        /// One JSON object: session, dir, processes [{role, pid, attached, started_unix_ms}].
        #[arg(long)]
        json: bool,
    },
    /// Stop a session's processes cleanly (components first, the keeper last).
    Down,
    /// Run the simulator daemon of a session (normally started by `robosim up … --with simulator`).
    Simulator {
        /// realtime (one step per dt of wall time), fast, or lockstep (steps on command).
        #[arg(long, default_value = "realtime")]
        mode: robosim_simulator_daemon::Mode,
        /// The effects to simulate (the simulator's JSON form); default: the scene's declaration.
        #[arg(long)]
        effects: Option<String>,
        /// State publication rate, Hz (lockstep publishes every step).
        #[arg(long, default_value_t = 100.0)]
        publish_hz: f64,
        /// Also record the run to this MCAP file (joint states, link poses, contacts, events).
        #[arg(long)]
        record: Option<std::path::PathBuf>,
    },
    /// Run a CLIPS rule base on a session: the Instance Space, simulator and alarms as facts on
    /// every change; rules write through (robosim …) (docs/rules.md).
    Rules {
        /// The rule file (.clp), e.g. hl-interface/rules/rulebases/joint_guard.clp
        file: std::path::PathBuf,
        /// CLIPS watch items traced on stdout, e.g. `facts,rules` (any of facts, rules,
        /// activations, statistics, all).
        #[arg(long, value_delimiter = ',')]
        watch: Vec<String>,
        /// Rule execution time allowed per pass, seconds (waiting for the session's answers
        /// not counted); past it the rules are halted and the process fails naming the rule.
        #[arg(long, default_value_t = 5.0)]
        time_limit: f64,
        /// Nested deffunction/generic function calls allowed.
        #[arg(long, default_value_t = 2000)]
        max_depth: u32,
        /// Memory CLIPS may hold, MiB.
        #[arg(long, default_value_t = 256)]
        max_memory: usize,
    },
    /// Run the automation layer's plant on a session: a fault model (the ECLSS by default) whose
    /// injected faults raise alarms over time; its units live in the Instance Space, where
    /// isolating and replacing them are transactions (docs/rules.md).
    Automation {
        /// The fault model: a shipped name (`eclss`) or a model file (`robosim diag check`).
        #[arg(long, default_value = "eclss")]
        model: String,
        /// Plant seconds per wall-clock second (propagation delays are minutes to hours).
        #[arg(long, default_value_t = 1.0)]
        time_scale: f64,
    },
    /// Send commands to a session's simulator: target, torque, pause, resume, step, reset, get.
    Simctl {
        /// JSON, e.g. '{"cmd": "target", "robot": "puma560", "q": [0, 0.5, 0, 0, 0, 0]}', or a
        /// bare get, pause, resume, step or reset
        #[arg(required = true)]
        commands: Vec<String>,
    },
    /// Instantiate a Library Space declaration into a running session (a writer process).
    Instantiate {
        /// Declaration name (`robosim lib list` shows them).
        declaration: String,
        /// Instance name (default: the declaration's).
        #[arg(long = "as")]
        name: Option<String>,
        /// Parameter values, NAME=EXPR (e.g. `upper_arm=0.5 m`).
        #[arg(long = "set")]
        set: Vec<String>,
    },
    /// Change parameters of an instance: it alone is re-instantiated, only what differs is written.
    Set {
        /// The instance (its name in the session, e.g. `station`).
        instance: String,
        /// NAME=EXPR pairs.
        #[arg(required = true)]
        params: Vec<String>,
    },
    /// Draw a library scene or robot to PNG, with no session or other process (`--play`: one
    /// frame per trajectory sample).
    Render(cli::display::RenderArgs),
    /// Attach to a session and draw it on every change: a window, or headless PNG frames with
    /// per-frame upload counters (frames.jsonl).
    Display(cli::display::DisplayArgs),
    /// A headless session that does real work and says what it did.
    Demo,
    /// The seed's case studies end to end, written to --out DIR (docs/studies.md).
    Study {
        #[command(subcommand)]
        cmd: cli::studies::StudyCmd,
    },
    /// A parameter study over worker processes: every combination of the --param values is
    /// one job; jobs go to N headless workers, results to one CSV; a worker that dies has its
    /// job redone (docs/studies.md, "Sweeps").
    Sweep(cli::studies::SweepArgs),
    /// (internal) a sweep's worker: job lines on stdin, result lines on stdout.
    #[command(hide = true)]
    SweepWorker,
    /// Runs sweep workers here for `robosim sweep --remote ENDPOINT` on other machines, over
    /// Zenoh (docs/studies.md, "Sweeps on other machines"); until stopped.
    SweepHost(cli::bridge::HostArgs),
    /// The Library Space: list, show and check declarations.
    Lib {
        #[command(subcommand)]
        cmd: cli::hl_interface::LibCmd,
    },
    /// Hierarchical fault models and diagnosis (seed §3.4, §4.3).
    Diag {
        #[command(subcommand)]
        cmd: cli::hl_interface::DiagCmd,
    },
    /// The query protocol over JSON lines: one request per stdin line, one answer per stdout
    /// line. With --session, also the simulation-library ops on that session's Instance Space
    /// (MOVEJ, MOVEJI, KINV, JACOB, CHECK, USE, C_SWITCH, PRE/POST TRANSLATE/ROTATE, …).
    Query {
        #[command(flatten)]
        args: cli::hl_interface::QueryArgs,
    },
    /// Build a scene's effect pipeline, print it, optionally run it headless.
    Sim(cli::hl_interface::SimArgs),
    /// Read a journal file (a session's `data/journal-*.log`, or a cut that recovery kept under
    /// `data/lost/`): every readable record with its version and operations, and the damage.
    Journal {
        #[command(subcommand)]
        cmd: JournalCmd,
    },
    /// What accuracy costs in time: regenerate a report (CSV, markdown table, PNG plot).
    Report {
        #[command(subcommand)]
        which: reports::Which,
    },
    /// Save the session's whole model (every object, every aspect, its Library Space
    /// additions) at one version to FILE (binary with a checksum; JSON for .json).
    Save {
        #[command(flatten)]
        args: cli::file_io::SaveArgs,
    },
    /// Load a model file into the session as one transaction (replace by default, or --merge).
    Load {
        #[command(flatten)]
        args: cli::file_io::LoadArgs,
    },
    /// The session's (or a model file's) version, object counts and model digest.
    Info {
        #[command(flatten)]
        args: cli::file_io::InfoArgs,
    },
    /// Export for other tools: glTF 2.0 binary (.glb), binary STL, the logged joint trajectory
    /// (CSV), of a session or (--scene) a library scene.
    Export {
        #[command(flatten)]
        args: cli::file_io::ExportArgs,
    },
    /// Import into a session: `mesh FILE --as NAME --at x,y,z[,r,p,y]` (STL or OBJ).
    Import {
        #[command(subcommand)]
        cmd: cli::file_io::ImportCmd,
    },
    /// Benchmarks: figures as ratios against a baseline measured in the same run.
    /// Carry this session's space to other machines over Zenoh (--listen, beside the keeper),
    /// or keep this session a replica of one (--connect): docs/bridge.md.
    Bridge(cli::bridge::BridgeArgs),
    Bench {
        #[command(subcommand)]
        which: bench::Which,
    },
    /// The ROBOSIM language (seed Table 1): run a program into link files, load link files as
    /// a robot (docs/editor.md).
    Lang {
        #[command(subcommand)]
        cmd: LangCmd,
    },
    /// The structure editor (R2): a prompt with line editing, history and completion, or a
    /// script; every edit is one transaction of the session (docs/editor.md).
    Edit {
        /// The robot being designed (its links are ROBOT.LOC, ROBOT.L1, …); resumed when the
        /// session holds it.
        #[arg(long, default_value = "C")]
        robot: String,
        /// Run the commands of FILE instead of prompting.
        #[arg(long)]
        script: Option<std::path::PathBuf>,
    },
    /// Print a shell completion script: `robosim completions bash > ~/.local/share/bash-completion/completions/robosim`.
    Completions {
        /// The shell to complete for.
        shell: clap_complete::Shell,
    },
}

/// The component names `up --with` accepts (only what this build has).
fn component_names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        robosim_launcher::COMPONENTS.iter().map(|(name, _)| *name),
    )
}

/// `--session`'s help line, with the values that hold on this machine now.
fn session_help() -> String {
    format!(
        "The session to start, join or read [default: {}, one per user]. A session's files live \
         in $ROBOSIM_HOME/<session>/ (now {})",
        robosim_instance_space::default_session_name(),
        robosim_instance_space::home().display()
    )
}

#[derive(Subcommand)]
enum LangCmd {
    /// Run PROGRAM: every STORE-LINK writes a link file (Table 2) into DIR; with --as NAME the
    /// links become robot NAME in the session (--session) at once. A program with an error
    /// writes nothing and changes nothing.
    Run {
        /// The ROBOSIM program (Table 1's language; lengths in cm unless a UNITS line says).
        program: std::path::PathBuf,
        /// The folder the link files are written to (created if missing); optional with --as.
        #[arg(long, required_unless_present = "name")]
        out: Option<std::path::PathBuf>,
        /// Load the program's links into the session as this robot (one transaction).
        #[arg(long = "as")]
        name: Option<String>,
    },
    /// Load the link files in DIR (ROBOT.LOC first, then ROBOT.L1, …) as robot NAME into the
    /// session.
    Load {
        /// The folder holding the link files (ROBOT.LOC, ROBOT.L1, …).
        dir: std::path::PathBuf,
        /// The robot's name in the Instance Space.
        #[arg(long = "as")]
        name: String,
        /// Which robot's files, when DIR holds several (the part before the dot).
        #[arg(long)]
        robot: Option<String>,
    },
}

#[derive(Subcommand)]
enum JournalCmd {
    /// One line per record: byte offset, version, size and operations; damaged bytes named.
    Inspect {
        /// The journal file.
        path: std::path::PathBuf,
    },
}

fn main() -> ExitCode {
    // SAFETY: the first statement of main: no other thread exists yet (the function's contract).
    // Mesa's device-select layer would otherwise print "error: XDG_RUNTIME_DIR is invalid" on
    // successful renders without XDG_RUNTIME_DIR (docs/display.md, "Requirements and noise").
    unsafe { robosim_display::quiet_vulkan_probe() };
    // A reader that closes our standard output early (`robosim up … | head -1`) ends the
    // command quietly, as Unix tools do, instead of a panic message: printing to a closed pipe
    // panics in Rust's print macros; that panic is recognised, not reported, and caught here.
    let report_panic = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !is_broken_pipe(info.payload()) {
            report_panic(info)
        }
    }));
    match std::panic::catch_unwind(run) {
        Ok(code) => code,
        Err(payload) if is_broken_pipe(&*payload) => ExitCode::SUCCESS,
        Err(payload) => std::panic::resume_unwind(payload),
    }
}

/// True for the panic of `print!`/`eprint!` on a closed pipe.
fn is_broken_pipe(payload: &(dyn std::any::Any + Send)) -> bool {
    let msg = payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied());
    msg.is_some_and(|m| m.starts_with("failed printing to std") && m.contains("Broken pipe"))
}

fn run() -> ExitCode {
    let help = session_help();
    let matches = <Cli as clap::CommandFactory>::command()
        .mut_arg("session", |a| a.help(help))
        .get_matches();
    let cli = match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    if std::env::var_os("IOX2_LOG_LEVEL").is_none() {
        iceoryx2_log_level(cli.quiet, cli.verbose);
    }
    robosim_report::progress::set_quiet(cli.quiet);
    match dispatch(cli.command, cli.session.as_deref()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("robosim: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A session that must already exist (for the commands that read or join one): a missing one is
/// an error naming the sessions that run, and nothing is created.
fn existing(session: Option<&str>) -> Result<robosim_instance_space::Session> {
    Ok(robosim_instance_space::Session::existing(session)?)
}

fn dispatch(command: Command, session: Option<&str>) -> Result<()> {
    match command {
        Command::Space {
            load: Some(file),
            library,
            no_sync,
            journal_copies,
            ..
        } => robosim_launcher::space_load(&file, session, &library, !no_sync, journal_copies)
            .map_err(CliError::from),
        Command::Space {
            scene,
            load: None,
            library,
            no_sync,
            journal_copies,
        } => robosim_launcher::run_space(
            session,
            scene.as_deref(),
            &library,
            !no_sync,
            journal_copies,
        )
        .map_err(CliError::from),
        Command::Up {
            load: Some(file),
            with,
            library,
            ..
        } => robosim_launcher::up_load(&file, &with, session, &library).map_err(CliError::from),
        Command::Up {
            scene,
            load: None,
            with,
            library,
            fresh,
        } => robosim_launcher::up_with_library(
            scene.as_deref().unwrap_or_default(),
            &with,
            session,
            &library,
            fresh,
        )
        .map_err(CliError::from),
        Command::Save { args } => {
            existing(session)?;
            robosim_file_io::cli::save(&args.into(), session).map_err(CliError::from)
        }
        Command::Load { args } => {
            existing(session)?;
            robosim_file_io::cli::load(&args.into(), session).map_err(CliError::from)
        }
        Command::Info { args } => {
            if args.file.is_none() {
                existing(session)?;
            }
            robosim_file_io::cli::info(&args.into(), session).map_err(CliError::from)
        }
        Command::Export { args } => {
            if args.scene.is_none() {
                existing(session)?;
            }
            robosim_file_io::cli::export(&args.into(), session).map_err(CliError::from)
        }
        Command::Import { cmd } => {
            existing(session)?;
            robosim_file_io::cli::import(&cmd.into(), session).map_err(CliError::from)
        }
        Command::Ps { json } => robosim_launcher::ps(session, json).map_err(CliError::from),
        Command::Down => robosim_launcher::down(session).map_err(CliError::from),
        Command::Simulator {
            mode,
            effects,
            publish_hz,
            record,
        } => {
            existing(session)?;
            let opts = robosim_simulator_daemon::Options {
                mode,
                effects,
                publish_hz,
                record,
            };
            robosim_simulator_daemon::run(session, &opts)
                .map(drop)
                .map_err(CliError::from)
        }
        Command::Rules {
            file,
            watch,
            time_limit,
            max_depth,
            max_memory,
        } => {
            existing(session)?;
            let time = std::time::Duration::try_from_secs_f64(time_limit)
                .ok()
                .filter(|t| !t.is_zero())
                .ok_or_else(|| {
                    CliError(format!(
                        "--time-limit {time_limit}: not a positive number of seconds"
                    ))
                })?;
            let limits = robosim_rules::clips::Limits {
                time,
                depth: max_depth,
                memory: max_memory.saturating_mul(1 << 20),
            };
            robosim_rules::run(&file, session, &watch, &limits).map_err(|e| CliError(e.to_string()))
        }
        Command::Automation { model, time_scale } => {
            existing(session)?;
            robosim_hl_interface::plant::run(session, &model, time_scale)
                .map_err(|e| CliError(e.to_string()))
        }
        Command::Simctl { commands } => {
            existing(session)?;
            robosim_simulator_daemon::ctl(session, &commands).map_err(CliError::from)
        }
        Command::Instantiate {
            declaration,
            name,
            set,
        } => cli_instantiate(&declaration, name.as_deref(), &set, session),
        Command::Set { instance, params } => cli_set(&instance, &params, session),
        Command::Demo => robosim_studies::surgical::run(session, &mut std::io::stdout().lock())
            .map_err(|e| CliError(e.0)),
        Command::Study { cmd } => {
            robosim_studies::cli::run(&cmd.into(), &mut std::io::stdout().lock())
                .map_err(|e| CliError(e.0))
        }
        Command::Sweep(args) => robosim_studies::sweep::cli::run(
            &args.into(),
            &std::env::current_exe()?,
            &mut sweep_remote::connect,
            &mut std::io::stdout().lock(),
        )
        .map_err(CliError::from),
        Command::SweepHost(args) => {
            let exe = std::env::current_exe()?;
            let spawn = || {
                let mut c = std::process::Command::new(&exe);
                c.arg("sweep-worker");
                c
            };
            robosim_bridge::sweep_link::host(&args.into(), &spawn, &mut |line| eprintln!("{line}"))
                .map_err(|e| CliError(e.to_string()))
        }
        Command::SweepWorker => robosim_studies::sweep::cli::worker().map_err(CliError::from),
        Command::Bench { which } => bench::run(which, session),
        Command::Bridge(args) => {
            robosim_bridge::run(session, &args.into()).map_err(CliError::from)
        }
        Command::Lib { cmd } => match session {
            None => robosim_hl_interface::cli::lib::run(cmd.into()).map_err(CliError),
            Some(_) => session_library(session)
                .and_then(|lib| {
                    robosim_hl_interface::cli::lib::render_with(cmd.into(), Some(&lib))
                        .map_err(CliError)
                })
                .map(|text| print!("{text}")),
        },
        Command::Diag { cmd } => robosim_hl_interface::cli::diag::run(cmd.into()).map_err(CliError),
        Command::Query { args } => match session {
            None => robosim_hl_interface::cli::run(&args.into()).map_err(CliError),
            Some(s) => query_session(s, &args.into()),
        },
        Command::Sim(args) => {
            robosim_hl_interface::cli::sim::run(&args.into(), &robosim_library::standard_robot)
                .map_err(CliError)
        }
        Command::Journal {
            cmd: JournalCmd::Inspect { path },
        } => robosim_instance_space::journal::inspect(&path, &mut std::io::stdout().lock())
            .map_err(CliError::from),
        Command::Report { which } => reports::run(which),
        Command::Render(args) => render(&args.into()),
        Command::Display(args) => {
            existing(session)?;
            let mut args = robosim_display::app::DisplayArgs::from(args);
            args.session = session.map(str::to_owned);
            robosim_display::app::cmd_display(&args).map_err(|e| CliError(e.0))
        }
        Command::Lang {
            cmd: LangCmd::Run { program, out, name },
        } => match (name, out) {
            (Some(name), out) => {
                let s = existing(session)?;
                robosim_editor::cli::lang_run_into(&program, out.as_deref(), &name, &s)
                    .map(|m| println!("{m}"))
                    .map_err(CliError)
            }
            (None, Some(out)) => robosim_editor::cli::lang_run(&program, &out)
                .map(|s| print!("{s}"))
                .map_err(CliError),
            (None, None) => Err(CliError("lang run: give --out DIR or --as NAME".into())),
        },
        Command::Lang {
            cmd: LangCmd::Load { dir, name, robot },
        } => {
            let s = existing(session)?;
            robosim_editor::cli::lang_load(&dir, &name, robot.as_deref(), &s)
                .map(|m| println!("{m}"))
                .map_err(CliError)
        }
        Command::Edit { robot, script } => {
            let s = existing(session)?;
            robosim_editor::cli::edit(&s, &robot, script.as_deref()).map_err(CliError)
        }
        Command::Completions { shell } => {
            // Generated into memory, then written once: clap_complete panics on a failed write
            // (`completions bash | head -1` closes the pipe), a write here is an error we
            // read — a reader that stopped early ends the command quietly, as Unix tools do.
            let mut cmd = <Cli as clap::CommandFactory>::command();
            let mut script = Vec::new();
            clap_complete::generate(shell, &mut cmd, "robosim", &mut script);
            let mut out = std::io::stdout().lock();
            match std::io::Write::write_all(&mut out, &script)
                .and_then(|()| std::io::Write::flush(&mut out))
            {
                Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(CliError(format!(
                    "writing the completion script to standard output: {e}"
                ))),
                _ => Ok(()),
            }
        }
    }
}

/// `robosim render SCENE|FILE.urdf …`: a URDF file is imported by the file interface into a
/// local model (robot, visuals and collision solids, as `robosim import urdf` does), the rest
/// comes from the library.
fn render(args: &robosim_display::app::RenderArgs) -> Result<()> {
    let path = std::path::Path::new(&args.scene);
    let urdf = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    let out = if urdf {
        let store =
            robosim_file_io::urdf_session::urdf_store(path).map_err(|e| CliError(e.to_string()))?;
        robosim_display::app::cmd_render_store(args, store)
    } else {
        robosim_display::app::cmd_render(args)
    };
    out.map_err(|e| CliError(e.0))
}

fn query_session(session: &str, args: &robosim_hl_interface::cli::QueryArgs) -> Result<()> {
    let s = existing(Some(session))?;
    let out = std::io::stdout();
    let served = match args.input.as_deref() {
        Some(p) if p.as_os_str() != "-" => session::serve(
            &s,
            std::io::BufReader::new(std::fs::File::open(p)?),
            out.lock(),
        ),
        _ => session::serve(&s, std::io::stdin().lock(), out.lock()),
    };
    match served {
        Ok(_) => Ok(()),
        Err(session::ServeError::Io(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(e.into()),
    }
}

/// A running session's Library Space.
fn session_library(session: Option<&str>) -> Result<robosim_library::Library> {
    let s = existing(session)?;
    let mut reader = robosim_instance_space::Reader::attach(&s, "library")?;
    Ok(robosim_scene::session_library(&mut reader)?)
}

/// `robosim instantiate DECL [--as NAME] [--set K=V]…`
fn cli_instantiate(
    declaration: &str,
    name: Option<&str>,
    set: &[String],
    session: Option<&str>,
) -> Result<()> {
    let s = existing(session)?;
    let origin = robosim_scene::Origin {
        declaration: declaration.to_owned(),
        params: robosim_scene::parse_params(set)?,
    };
    let name = name.unwrap_or(declaration);
    let lib = session_library(session)?;
    let tx = robosim_scene::instantiate(&lib, &origin, name)?;
    let mut c = robosim_instance_space::Client::connect(&s, "instantiate")?;
    let a = c.transact(&tx)?;
    println!(
        "instantiated {declaration} as {name}: {} objects, version {}",
        a.created.len(),
        a.version
    );
    Ok(())
}

/// `robosim set INSTANCE K=V…`: only what the new values change is written.
fn cli_set(instance: &str, pairs: &[String], session: Option<&str>) -> Result<()> {
    let s = existing(session)?;
    let reader = robosim_instance_space::Reader::attach(&s, "set")?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| CliError("no snapshot".into()))?;
    let (_, mut origin) = robosim_scene::find_instance(&snap, instance)?;
    origin.params.extend(robosim_scene::parse_params(pairs)?);
    let lib = session_library(session)?;
    let tx = robosim_scene::reinstantiate(&lib, &snap, instance, &origin)?;
    let mut c = robosim_instance_space::Client::connect(&s, "set")?;
    let a = c.transact(&tx)?;
    let aspects: Vec<&str> = robosim_instance_space::aspect::names(a.aspects());
    println!(
        "re-instantiated {instance}: {} objects changed ({}), version {}",
        a.changes.len(),
        aspects.join(", "),
        a.version
    );
    Ok(())
}

/// iceoryx2 prints a start-up notice at Info level; keep the terminal for our own output unless
/// asked for more (-v) or less (-q).
fn iceoryx2_log_level(quiet: bool, verbose: u8) {
    use iceoryx2::prelude::LogLevel;
    let level = match (quiet, verbose) {
        (true, _) => LogLevel::Fatal,
        (false, 0) => LogLevel::Error,
        (false, 1) => LogLevel::Warn,
        (false, 2) => LogLevel::Info,
        (false, _) => LogLevel::Debug,
    };
    iceoryx2::prelude::set_log_level(level);
}

/// Errors of the command-line layer: a message that says what failed and where.
#[derive(Debug)]
pub struct CliError(pub String);

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError(e.to_string())
    }
}

pub type Result<T> = std::result::Result<T, CliError>;

#[macro_export]
macro_rules! bail {
    ($($t:tt)*) => { return Err($crate::CliError(format!($($t)*))) };
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Every argument of every subcommand, as `command path: --arg`, that has no help line.
    fn undocumented(cmd: &clap::Command, path: &str, out: &mut Vec<String>) {
        for a in cmd.get_arguments() {
            let builtin = matches!(a.get_id().as_str(), "help" | "version");
            if !builtin && !a.is_hide_set() && a.get_help().is_none() {
                out.push(format!("{path}: {}", a.get_id()));
            }
        }
        for sub in cmd.get_subcommands() {
            if !sub.is_hide_set() {
                undocumented(sub, &format!("{path} {}", sub.get_name()), out);
            }
        }
    }

    /// Issue #19 item 12: `--help` explains every argument, and clap's own checks of the
    /// command tree (unique names, globals, groups) hold.
    #[test]
    fn every_argument_has_a_help_line() {
        let cmd = Cli::command();
        cmd.clone().debug_assert();
        let mut missing = Vec::new();
        undocumented(&cmd, "robosim", &mut missing);
        assert!(missing.is_empty(), "arguments without help: {missing:#?}");
    }
}
