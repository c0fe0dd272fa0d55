//! `robosim bench ipc|journal|display|reaction|files`: the subcommands and where each bench lives
//! (`robosim_report::ipc`, `robosim_report::journal`, `robosim_display::bench`, `robosim_simulator_daemon::bench`,
//! `robosim_file_io::bench`).

use crate::{CliError, Result};
use std::path::PathBuf;

#[derive(clap::Subcommand)]
pub enum Which {
    /// Instance Space costs: snapshot access, pose transactions, notification latency,
    /// journaled throughput.
    Ipc {
        /// Where to write ipc.md and ipc.csv.
        #[arg(long, default_value = "docs/bench")]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// The journal's second copy: group-commit latency, throughput and recovery time with one
    /// and two copies, in one run.
    Journal {
        /// Where to write journal.md and journal.csv.
        #[arg(long, default_value = "docs/bench")]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// Display costs: frame time (Space Station, 1280×1024) and bytes uploaded per pose update
    /// against scene size.
    Display {
        /// Where to write display_frames.* and display_uploads.*.
        #[arg(long, default_value = "docs/bench")]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// What a change costs the simulator daemon: keeper → state reaction to a one-joint
    /// change and the daemon's CPU during a 30-step MOVEJI, per scene size; with --before, the
    /// same for an older robosim binary, in the same run.
    Reaction {
        /// Where to write reaction.md and reaction.csv.
        #[arg(long, default_value = "docs/bench")]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
        /// A robosim binary built from an older commit, measured beside this one.
        #[arg(long)]
        before: Option<PathBuf>,
    },
    /// Model files: save and load of a 10⁶-vertex model against `cp` of the same bytes.
    Files {
        /// Where to write files.md and files.csv.
        #[arg(long, default_value = "docs/bench")]
        out: PathBuf,
        /// A 10⁵-vertex model and fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// (internal) the reader process of the latency measurement.
    #[command(hide = true)]
    IpcReader {
        #[arg(long)]
        session: String,
        #[arg(long)]
        count: usize,
        #[arg(long)]
        out: PathBuf,
    },
}

pub fn run(which: Which) -> Result<()> {
    match which {
        Which::Ipc { out, quick } => {
            robosim_report::ipc::run(&out, quick).map_err(|e| CliError(e.to_string()))
        }
        Which::Journal { out, quick } => {
            for p in robosim_report::journal::run(&out, quick).map_err(CliError)? {
                println!("{}", p.display());
            }
            Ok(())
        }
        Which::Display { out, quick } => {
            robosim_display::bench::run(&out, quick).map_err(|e| crate::CliError(e.0))
        }
        Which::Reaction { out, quick, before } => {
            let me = std::env::current_exe()?;
            for p in robosim_simulator_daemon::bench::run(&out, quick, &me, before.as_deref())
                .map_err(crate::CliError)?
            {
                println!("{}", p.display());
            }
            Ok(())
        }
        Which::Files { out, quick } => {
            for p in robosim_file_io::bench::run(&out, quick).map_err(CliError)? {
                println!("{}", p.display());
            }
            Ok(())
        }
        Which::IpcReader {
            session,
            count,
            out,
        } => robosim_report::ipc::latency_reader(&session, count, &out)
            .map_err(|e| CliError(e.to_string())),
    }
}
