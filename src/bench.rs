//! `robosim bench …`: each bench run by the crate that owns it — `robosim_report::ipc`,
//! `robosim_report::scale`, `robosim_report::bridge`, `robosim_report::journal`,
//! `robosim_display::bench`, `robosim_simulator_daemon::bench`, `robosim_file_io::bench`,
//! `robosim_file_io::bench_urdf`, `robosim_editor::bench`, `robosim_studies::sweep::bench` —
//! under a spinner, then where its files went (the arguments: src/cli/bench.rs).

use crate::cli::bench::Which;
use crate::{CliError, Result};
use robosim_report::written::{spun as spinner, wrote};
use std::path::{Path, PathBuf};

/// A report's boxed error as the command's: its message and its causes
/// ([`robosim_instance_space::error_chain`]).
fn boxed(e: Box<dyn std::error::Error>) -> CliError {
    CliError(robosim_instance_space::error_chain(&*e))
}

/// Runs bench `name` under a spinner, then prints where its files went (its paths, or `out`).
fn spun(name: &str, out: &Path, bench: impl FnOnce() -> Result<Vec<PathBuf>>) -> Result<()> {
    print!("{}", wrote(out, &spinner(&format!("bench {name}"), bench)?));
    Ok(())
}

pub fn run(which: Which, session: Option<&str>) -> Result<()> {
    let none = |()| Vec::new();
    match which {
        Which::Ipc { out, quick } => spun("ipc", &out, || {
            robosim_report::ipc::run(&out, quick)
                .map(none)
                .map_err(boxed)
        }),
        Which::Scale { out, quick } => spun("scale", &out, || {
            robosim_report::scale::run(&out, quick)
                .map(none)
                .map_err(boxed)
        }),
        Which::Bridge { out, quick } => spun("bridge", &out, || {
            robosim_report::bridge::run(&out, quick)
                .map(none)
                .map_err(boxed)
        }),
        Which::Journal { out, quick } => spun("journal", &out, || {
            robosim_report::journal::run(&out, quick).map_err(CliError)
        }),
        Which::Display { out, quick } => spun("display", &out, || {
            robosim_display::bench::run(&out, quick)
                .map(none)
                .map_err(|e| CliError(e.0))
        }),
        Which::Reaction { out, quick, before } => {
            let me = std::env::current_exe()?;
            spun("reaction", &out, || {
                robosim_simulator_daemon::bench::run(&out, quick, &me, before.as_deref())
                    .map_err(CliError)
            })
        }
        Which::IpcReader { count, out, bare } => {
            let session = session.ok_or_else(|| CliError("ipc-reader needs --session".into()))?;
            match bare {
                Some(tag) => robosim_report::ipc::bare_listener(session, &tag, count, &out),
                None => robosim_report::ipc::latency_reader(session, count, &out),
            }
            .map_err(boxed)
        }
        Which::Editor { out, quick } => {
            let me = std::env::current_exe()?;
            spun("editor", &out, || {
                robosim_editor::bench::run(&out, quick, &me).map_err(CliError::from)
            })
        }
        Which::Urdf { out, quick, urdf } => {
            let me = std::env::current_exe()?;
            spun("urdf", &out, || {
                robosim_file_io::bench_urdf::run(&out, quick, &me, &urdf).map_err(CliError)
            })
        }
        Which::Sweep { out, quick } => {
            let me = std::env::current_exe()?;
            let paths = robosim_studies::sweep::bench::run(
                &out,
                quick,
                &me,
                &mut robosim_studies::sweep::remote::connect,
            )
            .map_err(CliError)?;
            print!("{}", wrote(&out, &paths));
            Ok(())
        }
        Which::Files { out, quick } => spun("files", &out, || {
            robosim_file_io::bench::run(&out, quick).map_err(CliError)
        }),
    }
}
