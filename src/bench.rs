//! `robosim bench ipc|scale|journal|display|reaction|files|editor|urdf|sweep`: the subcommands and where each bench
//! lives (`robosim_report::ipc`, `robosim_report::scale`, `robosim_report::journal`, `robosim_display::bench`, `robosim_simulator_daemon::bench`,
//! `robosim_file_io::bench`, `robosim_editor::bench`, `robosim_studies::sweep::bench`).

use crate::{CliError, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum Which {
    /// Instance Space costs: snapshot access, pose transactions, notification latency,
    /// journaled throughput.
    Ipc {
        /// Where to write ipc.md and ipc.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// What a one-body change costs at 10², 10³, 10⁴ and 10⁵ objects: pose transaction, a
    /// reader following it, notification latency, late-joiner attach.
    Scale {
        /// Where to write scale.md and scale.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// The space over Zenoh: a pose transaction written on a replica against the primary,
    /// the replica's lag and a late joiner's start, at 10² to 10⁵ bodies (docs/bridge.md).
    Bridge {
        /// Where to write bridge.md and bridge.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// The journal's second copy: group-commit latency, throughput and recovery time with one
    /// and two copies, in one run.
    Journal {
        /// Where to write journal.md and journal.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// Display costs: frame time (Space Station, 1280×1024) and bytes uploaded per pose update
    /// against scene size.
    Display {
        /// Where to write display_frames.* and display_uploads.*.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
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
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
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
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// A 10⁵-vertex model and fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// URDF import: the Panda (meshes and all) parsed, made a transaction, applied, and
    /// `robosim import urdf` into a running session end to end, against `import mesh` of a cube.
    Urdf {
        /// Where to write urdf.md and urdf.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
        /// The URDF to import.
        #[arg(long, default_value = "testdata/urdf/panda.urdf")]
        urdf: PathBuf,
    },
    /// One editor edit in the Space Station model: keeper time (round trip against an empty
    /// transaction's), announcement and a reader reaching the new version, with the model size.
    Editor {
        /// Where to write editor.md and editor.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// A parameter sweep (surgical: encoder bits × upper arm × forearm) in this process, on 1 and on 2
    /// worker processes, and on 1 and 2 workers of a sweep host over Zenoh: wall time and
    /// speed-up.
    Sweep {
        /// Where to write sweep.md and sweep.csv.
        #[arg(long, default_value = crate::reports::DEFAULT_OUT)]
        out: PathBuf,
        /// A 4-job sweep instead of 108 (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// (internal) the reader process of the latency measurement.
    #[command(hide = true)]
    IpcReader {
        /// Changes to wait for.
        #[arg(long)]
        count: usize,
        /// Where to write the latencies.
        #[arg(long)]
        out: PathBuf,
        /// Listen to the bare iceoryx2 event of this tag in the session instead (the
        /// baseline of `bench scale`), writing wake-up times.
        #[arg(long)]
        bare: Option<String>,
    },
}

/// A report's boxed error as the command's: its message and its causes
/// ([`robosim_instance_space::error_chain`]).
fn boxed(e: Box<dyn std::error::Error>) -> CliError {
    CliError(robosim_instance_space::error_chain(&*e))
}

/// Runs bench `name` under a spinner, then prints where its files went (its paths, or `out`).
fn spun(name: &str, out: &Path, bench: impl FnOnce() -> Result<Vec<PathBuf>>) -> Result<()> {
    let pb = robosim_report::progress::spinner(&format!("bench {name}"));
    let paths = bench();
    pb.finish_and_clear();
    crate::reports::wrote(out, &paths?)
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
                &mut crate::sweep_remote::connect,
            )
            .map_err(CliError)?;
            crate::reports::wrote(&out, &paths)
        }
        Which::Files { out, quick } => spun("files", &out, || {
            robosim_file_io::bench::run(&out, quick).map_err(CliError)
        }),
    }
}
