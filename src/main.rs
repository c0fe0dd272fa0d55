//! `robosim`: one binary, one subcommand per process role and tool (DESIGN.md, "Layout").
//!
//! Processes: `space` (the keeper), `simulator`; launcher: `up`, `ps`, `down`; tools: `demo`,
//! `bench`.

mod bench;
mod reports;

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
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the space keeper of a session (normally started by `robosim up`).
    Space {
        #[arg(long)]
        session: Option<String>,
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
    /// Start a session: the keeper with SCENE, and only the components named with --with.
    Up {
        #[arg(required_unless_present = "load")]
        scene: Option<String>,
        /// Start the session from this model file (`robosim save`) instead of a scene.
        #[arg(long, conflicts_with = "scene")]
        load: Option<std::path::PathBuf>,
        /// Comma-separated components: simulator, display, editor, file, hl.
        #[arg(long, value_delimiter = ',')]
        with: Vec<String>,
        #[arg(long)]
        session: Option<String>,
        /// Library files to add to the session's Library Space.
        #[arg(long)]
        library: Vec<std::path::PathBuf>,
    },
    /// List a session's processes: role, pid, what each is attached to.
    Ps {
        #[arg(long)]
        session: Option<String>,
    },
    /// Stop a session's processes cleanly (components first, the keeper last).
    Down {
        #[arg(long)]
        session: Option<String>,
    },
    /// Run the simulator daemon of a session (normally started by `robosim up … --with simulator`).
    Simulator {
        #[arg(long)]
        session: Option<String>,
        /// realtime (one step per dt of wall time), fast, or lockstep (steps on command).
        #[arg(long, default_value = "realtime")]
        mode: robosim_simulator_daemon::Mode,
        /// The effects to simulate (the simulator's JSON form); default: the scene's declaration.
        #[arg(long)]
        effects: Option<String>,
        /// State publication rate, Hz (lockstep publishes every step).
        #[arg(long, default_value_t = 100.0)]
        publish_hz: f64,
    },
    /// Send commands (JSON) to a session's simulator: target, torque, pause, resume, step, reset.
    Simctl {
        #[arg(long)]
        session: Option<String>,
        /// e.g. '{"cmd": "target", "robot": "puma560", "q": [0, 0.5, 0, 0, 0, 0]}'
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
        #[arg(long)]
        session: Option<String>,
    },
    /// Change parameters of an instance: it alone is re-instantiated, only what differs is written.
    Set {
        instance: String,
        /// NAME=EXPR pairs.
        #[arg(required = true)]
        params: Vec<String>,
        #[arg(long)]
        session: Option<String>,
    },
    /// Draw a library scene or robot to PNG, with no session or other process (`--play`: one
    /// frame per trajectory sample).
    Render(robosim_display::app::RenderArgs),
    /// Attach to a session and draw it on every change: a window, or headless PNG frames with
    /// per-frame upload counters (frames.jsonl).
    Display(robosim_display::app::DisplayArgs),
    /// A headless session that does real work and says what it did.
    Demo {
        #[arg(long)]
        session: Option<String>,
    },
    /// The Library Space: list, show and check declarations.
    Lib {
        /// Read the Library Space of this running session (from shared memory) instead of the
        /// standard library.
        #[arg(long, global = true)]
        session: Option<String>,
        #[command(subcommand)]
        cmd: robosim_hl_interface::cli::lib::LibCmd,
    },
    /// Hierarchical fault models and diagnosis (seed §3.4, §4.3).
    Diag {
        #[command(subcommand)]
        cmd: robosim_hl_interface::cli::diag::DiagCmd,
    },
    /// The query protocol over JSON lines: one request per stdin line, one answer per stdout
    /// line. With --session, also the simulation-library ops on that session's Instance Space
    /// (MOVEJ, MOVEJI, KINV, JACOB, CHECK, USE, C_SWITCH, PRE/POST TRANSLATE/ROTATE, …).
    Query {
        #[arg(long)]
        session: Option<String>,
        #[command(flatten)]
        args: robosim_hl_interface::cli::QueryArgs,
    },
    /// Build a scene's effect pipeline, print it, optionally run it headless.
    Sim(robosim_hl_interface::cli::sim::SimArgs),
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
        args: robosim_file_io::cli::SaveArgs,
        #[arg(long)]
        session: Option<String>,
    },
    /// Load a model file into the session as one transaction (replace by default, or --merge).
    Load {
        #[command(flatten)]
        args: robosim_file_io::cli::LoadArgs,
        #[arg(long)]
        session: Option<String>,
    },
    /// The session's (or a model file's) version, object counts and model digest.
    Info {
        #[command(flatten)]
        args: robosim_file_io::cli::InfoArgs,
        #[arg(long)]
        session: Option<String>,
    },
    /// Export for other tools: glTF 2.0 binary (.glb), binary STL, the logged joint trajectory
    /// (CSV), of a session or (--scene) a library scene.
    Export {
        #[command(flatten)]
        args: robosim_file_io::cli::ExportArgs,
        #[arg(long)]
        session: Option<String>,
    },
    /// Import into a session: `mesh FILE --as NAME --at x,y,z[,r,p,y]` (STL or OBJ).
    Import {
        #[command(subcommand)]
        cmd: robosim_file_io::cli::ImportCmd,
        #[arg(long, global = true)]
        session: Option<String>,
    },
    /// Benchmarks that write their figures into docs/.
    Bench {
        #[command(subcommand)]
        which: bench::Which,
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
    if std::env::var_os("IOX2_LOG_LEVEL").is_none() {
        iceoryx2_quiet();
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Space {
            session,
            load: Some(file),
            library,
            no_sync,
            journal_copies,
            ..
        } => robosim_file_io::cli::space_load(
            &file,
            session.as_deref(),
            &library,
            !no_sync,
            journal_copies,
        )
        .map_err(CliError::from),
        Command::Space {
            session,
            scene,
            load: None,
            library,
            no_sync,
            journal_copies,
        } => robosim_scene::launch::run_space(
            session.as_deref(),
            scene.as_deref(),
            &library,
            !no_sync,
            journal_copies,
        )
        .map_err(CliError::from),
        Command::Up {
            load: Some(file),
            with,
            session,
            library,
            ..
        } => robosim_file_io::cli::up_load(&file, &with, session.as_deref(), &library)
            .map_err(CliError::from),
        Command::Up {
            scene,
            load: None,
            with,
            session,
            library,
        } => robosim_scene::launch::up_with_library(
            scene.as_deref().unwrap_or_default(),
            &with,
            session.as_deref(),
            &library,
        )
        .map_err(CliError::from),
        Command::Save { args, session } => {
            robosim_file_io::cli::save(&args, session.as_deref()).map_err(CliError::from)
        }
        Command::Load { args, session } => {
            robosim_file_io::cli::load(&args, session.as_deref()).map_err(CliError::from)
        }
        Command::Info { args, session } => {
            robosim_file_io::cli::info(&args, session.as_deref()).map_err(CliError::from)
        }
        Command::Export { args, session } => {
            robosim_file_io::cli::export(&args, session.as_deref()).map_err(CliError::from)
        }
        Command::Import { cmd, session } => {
            robosim_file_io::cli::import(&cmd, session.as_deref()).map_err(CliError::from)
        }
        Command::Ps { session } => {
            robosim_scene::launch::ps(session.as_deref()).map_err(CliError::from)
        }
        Command::Down { session } => {
            robosim_scene::launch::down(session.as_deref()).map_err(CliError::from)
        }
        Command::Simulator {
            session,
            mode,
            effects,
            publish_hz,
        } => {
            robosim_simulator_daemon::run(session.as_deref(), mode, effects.as_deref(), publish_hz)
                .map(drop)
                .map_err(CliError::from)
        }
        Command::Simctl { session, commands } => {
            robosim_simulator_daemon::ctl(session.as_deref(), &commands).map_err(CliError::from)
        }
        Command::Instantiate {
            declaration,
            name,
            set,
            session,
        } => cli_instantiate(&declaration, name.as_deref(), &set, session.as_deref()),
        Command::Set {
            instance,
            params,
            session,
        } => cli_set(&instance, &params, session.as_deref()),
        Command::Demo { session } => {
            robosim_studies::surgical::run(session.as_deref(), &mut std::io::stdout().lock())
                .map_err(|e| CliError(e.0))
        }
        Command::Bench { which } => bench::run(which),
        Command::Lib { session: None, cmd } => {
            robosim_hl_interface::cli::lib::run(cmd).map_err(CliError)
        }
        Command::Lib {
            session: Some(s),
            cmd,
        } => session_library(Some(&s))
            .and_then(|lib| {
                robosim_hl_interface::cli::lib::render_with(cmd, Some(&lib)).map_err(CliError)
            })
            .map(|text| print!("{text}")),
        Command::Diag { cmd } => robosim_hl_interface::cli::diag::run(cmd).map_err(CliError),
        Command::Query {
            session: None,
            args,
        } => robosim_hl_interface::cli::run(&args).map_err(CliError),
        Command::Query {
            session: Some(s),
            args,
        } => query_session(&s, &args),
        Command::Sim(args) => {
            robosim_hl_interface::cli::sim::run(&args, &robosim_library::standard_robot)
                .map_err(CliError)
        }
        Command::Journal {
            cmd: JournalCmd::Inspect { path },
        } => robosim_instance_space::journal::inspect(&path, &mut std::io::stdout().lock())
            .map_err(CliError::from),
        Command::Report { which } => reports::run(which),
        Command::Render(args) => robosim_display::app::cmd_render(&args).map_err(|e| CliError(e.0)),
        Command::Display(args) => {
            robosim_display::app::cmd_display(&args).map_err(|e| CliError(e.0))
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("robosim: {e}");
            ExitCode::FAILURE
        }
    }
}

fn query_session(session: &str, args: &robosim_hl_interface::cli::QueryArgs) -> Result<()> {
    let s = robosim_instance_space::Session::open(Some(session))?;
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
    let s = robosim_instance_space::Session::open(session)?;
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
    let s = robosim_instance_space::Session::open(session)?;
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
    let s = robosim_instance_space::Session::open(session)?;
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

/// iceoryx2 prints a start-up notice at Info level; keep the terminal for our own output.
fn iceoryx2_quiet() {
    iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
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
