//! `robosim`: one binary, one subcommand per process role and tool (DESIGN.md, "Layout").
//!
//! Processes: `space` (the keeper), `simulator`; launcher: `up`, `ps`, `down`; tools: `demo`,
//! `bench`.

mod bench;
mod cli;
mod reports;

use cli::{Cli, Command, JournalCmd};
use robosim_hl_interface::session;
use std::process::ExitCode;

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
    let cli: Cli = cli::parse();
    if std::env::var_os("IOX2_LOG_LEVEL").is_none() {
        robosim_instance_space::set_iceoryx2_log_level(cli.quiet, cli.verbose);
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
            scene,
            load,
            library,
            no_sync,
            journal_copies,
        } => robosim_launcher::entry::space(
            session,
            scene.as_deref(),
            load.as_deref(),
            &library,
            !no_sync,
            journal_copies,
        )
        .map_err(CliError::from),
        Command::Up {
            scene,
            load,
            with,
            library,
            fresh,
            sim_mode,
        } => robosim_launcher::entry::up(
            session,
            scene.as_deref(),
            load.as_deref(),
            &with,
            &library,
            fresh,
            sim_mode.map(|m| m.name()),
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
            let args = robosim_rules::cli::Args {
                file: &file,
                watch: &watch,
                time_limit,
                max_depth,
                max_memory,
            };
            robosim_rules::cli::run(&args, session).map_err(CliError::from)
        }
        Command::Dataflow {
            graph,
            rate,
            tolerance,
            name,
            passes,
        } => {
            existing(session)?;
            let opts = robosim_hl_interface::dataflow::Options {
                name,
                rate_hz: rate,
                tolerance,
                passes,
            };
            robosim_hl_interface::dataflow::run(&graph, session, &opts).map_err(CliError::from)
        }
        Command::Automation { model, time_scale } => {
            existing(session)?;
            robosim_hl_interface::plant::run(session, &model, time_scale).map_err(CliError::from)
        }
        Command::Simctl { commands } => {
            existing(session)?;
            robosim_simulator_daemon::ctl(session, &commands).map_err(CliError::from)
        }
        Command::Instantiate {
            declaration,
            name,
            set,
        } => robosim_scene::cli::instantiate(&declaration, name.as_deref(), &set, session)
            .map(|line| println!("{line}"))
            .map_err(CliError::from),
        Command::Set { instance, params } => robosim_scene::cli::set(&instance, &params, session)
            .map(|line| println!("{line}"))
            .map_err(CliError::from),
        Command::Demo => robosim_studies::surgical::run(session, &mut std::io::stdout().lock())
            .map_err(CliError::from),
        Command::Study { cmd } => {
            robosim_studies::cli::run(&cmd.into(), &mut std::io::stdout().lock())
                .map_err(CliError::from)
        }
        Command::Sweep(args) => robosim_studies::sweep::cli::run(
            &args.into(),
            &std::env::current_exe()?,
            &mut robosim_studies::sweep::remote::connect,
            &mut std::io::stdout().lock(),
        )
        .map_err(CliError::from),
        Command::SweepHost(args) => sweep_host(&args.into()),
        Command::SweepWorker => robosim_studies::sweep::cli::worker().map_err(CliError::from),
        Command::Bench { which } => bench::run(which, session),
        Command::Bridge(args) => robosim_bridge::run(session, &args.into()).map_err(CliError::from),
        Command::Lib { cmd } => {
            robosim_hl_interface::cli::lib_session::run(cmd.into(), session).map_err(CliError::from)
        }
        Command::Diag { cmd } => {
            robosim_hl_interface::cli::diag::run(cmd.into()).map_err(CliError::from)
        }
        Command::Query { args } => match session {
            None => robosim_hl_interface::cli::run(&args.into()).map_err(CliError::from),
            Some(s) => query_session(s, &args.into()),
        },
        Command::Sim(args) => {
            robosim_hl_interface::cli::sim::run(&args.into(), &robosim_library::standard_robot)
                .map_err(CliError::from)
        }
        Command::Journal {
            cmd: JournalCmd::Inspect { path },
        } => robosim_instance_space::journal::inspect(&path, &mut std::io::stdout().lock())
            .map_err(CliError::from),
        Command::Report { which } => reports::run(which),
        Command::Plot { run, out } => reports::plot(&run, &out),
        Command::Render(args) => {
            robosim_display::render_urdf::cmd_render_any(&args.into()).map_err(|e| CliError(e.0))
        }
        Command::Display(args) => {
            existing(session)?;
            let mut args = robosim_display::app::DisplayArgs::from(args);
            args.session = session.map(str::to_owned);
            robosim_display::app::cmd_display(&args).map_err(|e| CliError(e.0))
        }
        Command::Lang { cmd } => robosim_editor::lang_cmd::run(cmd.into(), session)
            .map(|text| print!("{text}"))
            .map_err(CliError::from),
        Command::Edit { robot, script } => {
            let s = existing(session)?;
            robosim_editor::cli::edit(&s, &robot, script.as_deref()).map_err(CliError::from)
        }
        Command::Completions { shell } => completions(shell),
    }
}

/// `robosim sweep-host`: sweep workers (this executable, `sweep-worker`) for remote sweeps.
fn sweep_host(args: &robosim_bridge::sweep_link::HostArgs) -> Result<()> {
    let exe = std::env::current_exe()?;
    let spawn = || {
        let mut c = std::process::Command::new(&exe);
        c.arg("sweep-worker");
        c
    };
    robosim_bridge::sweep_link::host(args, &spawn, &mut |line| eprintln!("{line}"))
        .map_err(CliError::from)
}

/// `robosim completions SHELL`. Generated into memory, then written once: clap_complete
/// panics on a failed write (`completions bash | head -1` closes the pipe), a write here is an
/// error we read — a reader that stopped early ends the command quietly, as Unix tools do.
fn completions(shell: clap_complete::Shell) -> Result<()> {
    let script = cli::completion_script(shell);
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

fn query_session(session: &str, args: &robosim_hl_interface::cli::QueryArgs) -> Result<()> {
    let s = existing(Some(session))?;
    Ok(session::serve_stdio(&s, args.input.as_deref())?)
}

/// Errors of the command-line layer: a message that says what failed and where.
#[derive(Debug)]
pub struct CliError(pub String);

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// The error's message and its causes down the `source()` chain, each said once.
impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError(robosim_instance_space::error_chain(&e))
    }
}

pub type Result<T> = std::result::Result<T, CliError>;

#[macro_export]
macro_rules! bail {
    ($($t:tt)*) => { return Err($crate::CliError(format!($($t)*))) };
}
