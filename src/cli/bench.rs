//! `robosim bench ipc|scale|bridge|journal|display|reaction|files|urdf|editor|sweep`: their
//! clap arguments (src/bench.rs dispatches each to the crate that owns the bench).

use std::path::PathBuf;

#[derive(clap::Subcommand)]
pub enum Which {
    /// Instance Space costs: snapshot access, pose transactions, notification latency,
    /// journaled throughput.
    Ipc {
        /// Where to write ipc.md and ipc.csv.
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// What a one-body change costs at 10², 10³, 10⁴ and 10⁵ objects: pose transaction, a
    /// reader following it, notification latency, late-joiner attach.
    Scale {
        /// Where to write scale.md and scale.csv.
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// The space over Zenoh: a pose transaction written on a replica against the primary,
    /// the replica's lag and a late joiner's start, at 10² to 10⁵ bodies (docs/bridge.md).
    Bridge {
        /// Where to write bridge.md and bridge.csv.
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// The journal's second copy: group-commit latency, throughput and recovery time with one
    /// and two copies, in one run.
    Journal {
        /// Where to write journal.md and journal.csv.
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
        out: PathBuf,
        /// Fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// Display costs: frame time (Space Station, 1280×1024) and bytes uploaded per pose update
    /// against scene size.
    Display {
        /// Where to write display_frames.* and display_uploads.*.
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
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
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
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
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
        out: PathBuf,
        /// A 10⁵-vertex model and fewer repetitions (for a smoke run).
        #[arg(long)]
        quick: bool,
    },
    /// URDF import: the Panda (meshes and all) parsed, made a transaction, applied, and
    /// `robosim import urdf` into a running session end to end, against `import mesh` of a cube.
    Urdf {
        /// Where to write urdf.md and urdf.csv.
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
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
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
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
        #[arg(long, default_value = super::report::DEFAULT_OUT)]
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
