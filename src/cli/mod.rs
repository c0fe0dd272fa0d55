//! The command line: clap lives here and nowhere else in the workspace (issue 35; the binary's
//! own tools, `bench` and `report`, too: [`bench`], [`report`]). [`Cli`] is the
//! whole command tree; one module per library crate holds that crate's commands as clap types,
//! converted (`From`) to the plain argument types the crate's functions take; `main.rs`
//! dispatches what [`parse`] returns.

pub mod bench;
pub mod bridge;
pub mod display;
pub mod editor;
pub mod file_io;
pub mod hl_interface;
pub mod report;
pub mod studies;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "robosim",
    version,
    about = "Robot and structure simulation over a shared Instance Space (after NASA-CR-185444)"
)]
pub(crate) struct Cli {
    /// The session to start, join or read (its help line, with the default, is set at run time:
    /// see `session_help`).
    #[arg(long, global = true, env = "ROBOSIM_SESSION", value_name = "NAME")]
    pub(crate) session: Option<String>,
    /// Print less: no progress bars; iceoryx2 prints nothing. Results and errors still print.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub(crate) quiet: bool,
    /// Print more: -v iceoryx2's warnings, -vv its info, -vvv its debug messages.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub(crate) verbose: u8,
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
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
        /// The library scene or robot to load (`robosim lib list`). Without it (and without
        /// --load) the session's saved model is resumed: `robosim up --session lab`.
        scene: Option<String>,
        /// Start the session from this model file (`robosim save`) instead of a scene.
        #[arg(long, conflicts_with = "scene")]
        load: Option<std::path::PathBuf>,
        /// Comma-separated components to start beside the keeper: simulator, display,
        /// automation, dataflow=GRAPH (a dataflow graph file, docs/dataflow.md), rules=FILE.clp
        /// (a rule base, or a shipped one by name: rules=joint_guard; repeatable, docs/rules.md).
        #[arg(long, value_delimiter = ',', value_parser = component_names())]
        with: Vec<String>,
        /// Library files to add to the session's Library Space.
        #[arg(long)]
        library: Vec<std::path::PathBuf>,
        /// Start SCENE in an empty model: a stopped session's saved model is moved aside to
        /// `<session>/previous-<time>/` (nothing is deleted).
        #[arg(long)]
        fresh: bool,
        /// The mode of the simulator started with `--with simulator`: realtime (default), fast,
        /// or lockstep (steps only on command: `simctl step`, Python's `s.sim.step(n)`).
        #[arg(long)]
        sim_mode: Option<robosim_simulator_daemon::Mode>,
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
    /// Run a dataflow graph (MULTIGRAPH, seed §3.4) on a session: sources read from the Instance
    /// Space, the simulator and the plant's alarms; sinks written back as transactions; the
    /// file reloaded and the graph rewired live when it changes (docs/dataflow.md).
    Dataflow {
        /// The graph file, e.g. automation/graphs/carriage_servo.flow
        graph: std::path::PathBuf,
        /// Run passes at this rate, Hz (default: the file's `rate` line, else on every change).
        #[arg(long)]
        rate: Option<f64>,
        /// A sink value this close to the committed one is not written (m or rad).
        #[arg(long, default_value_t = 1e-9)]
        tolerance: f64,
        /// The process's role and command channel (state/NAME/commands), for several graphs on
        /// one session.
        #[arg(long, default_value = "dataflow")]
        name: String,
        /// Stop after N passes (scripts); without it, until SIGTERM.
        #[arg(long)]
        passes: Option<u64>,
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
    Render(display::RenderArgs),
    /// Attach to a session and draw it on every change: a window, or headless PNG frames with
    /// per-frame upload counters (frames.jsonl).
    Display(display::DisplayArgs),
    /// A headless session that does real work and says what it did.
    Demo,
    /// The seed's case studies end to end, written to --out DIR (docs/studies.md).
    Study {
        #[command(subcommand)]
        cmd: studies::StudyCmd,
    },
    /// A parameter study over worker processes: every combination of the --param values is
    /// one job; jobs go to N headless workers, results to one CSV; a worker that dies has its
    /// job redone (docs/studies.md, "Sweeps").
    Sweep(studies::SweepArgs),
    /// (internal) a sweep's worker: job lines on stdin, result lines on stdout.
    #[command(hide = true)]
    SweepWorker,
    /// Runs sweep workers here for `robosim sweep --remote ENDPOINT` on other machines, over
    /// Zenoh (docs/studies.md, "Sweeps on other machines"); until stopped.
    SweepHost(bridge::HostArgs),
    /// The Library Space: list, show and check declarations.
    Lib {
        #[command(subcommand)]
        cmd: hl_interface::LibCmd,
    },
    /// Hierarchical fault models and diagnosis (seed §3.4, §4.3).
    Diag {
        #[command(subcommand)]
        cmd: hl_interface::DiagCmd,
    },
    /// The query protocol over JSON lines: one request per stdin line, one answer per stdout
    /// line. With --session, also the simulation-library ops on that session's Instance Space
    /// (MOVEJ, MOVEJI, KINV, JACOB, CHECK, USE, C_SWITCH, PRE/POST TRANSLATE/ROTATE, …).
    Query {
        #[command(flatten)]
        args: hl_interface::QueryArgs,
    },
    /// Build a scene's effect pipeline, print it, optionally run it headless.
    Sim(hl_interface::SimArgs),
    /// Read a journal file (a session's `data/journal-*.log`, or a cut that recovery kept under
    /// `data/lost/`): every readable record with its version and operations, and the damage.
    Journal {
        #[command(subcommand)]
        cmd: JournalCmd,
    },
    /// What accuracy costs in time: regenerate a report (CSV, markdown table, PNG plot).
    Report {
        #[command(subcommand)]
        which: report::Which,
    },
    /// Figures of a run: a recording (`simulator --record RUN.mcap`) or the simulator's signal
    /// log (`run/simulator-ROBOT.csv`) as PNGs in --out — joint positions, velocities, efforts
    /// and actuator work per robot, contacts, the run's events marked — and plot.json saying
    /// what each figure holds.
    Plot {
        /// The run: an MCAP recording or a simulator signal log (CSV).
        run: std::path::PathBuf,
        /// Directory for the PNGs and plot.json.
        #[arg(long, default_value = "robosim-plots")]
        out: std::path::PathBuf,
    },
    /// Save the session's whole model (every object, every aspect, its Library Space
    /// additions) at one version to FILE (binary with a checksum; JSON for .json).
    Save {
        #[command(flatten)]
        args: file_io::SaveArgs,
    },
    /// Load a model file into the session as one transaction (replace by default, or --merge).
    Load {
        #[command(flatten)]
        args: file_io::LoadArgs,
    },
    /// The session's (or a model file's) version, object counts and model digest.
    Info {
        #[command(flatten)]
        args: file_io::InfoArgs,
    },
    /// Export for other tools: glTF 2.0 binary (.glb), binary STL, the logged joint trajectory
    /// (CSV), of a session or (--scene) a library scene.
    Export {
        #[command(flatten)]
        args: file_io::ExportArgs,
    },
    /// Import into a session: `mesh FILE --as NAME --at x,y,z[,r,p,y]` (STL or OBJ).
    Import {
        #[command(subcommand)]
        cmd: file_io::ImportCmd,
    },
    /// Carry this session's space to other machines over Zenoh (--listen, beside the keeper),
    /// or keep this session a replica of one (--connect): docs/bridge.md.
    Bridge(bridge::BridgeArgs),
    /// Benchmarks: figures as ratios against a baseline measured in the same run.
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

/// The components `up --with` accepts (only what this build has): a name, `dataflow=GRAPH` or
/// `rules=FILE` (the launcher checks the file).
fn component_names() -> clap::builder::ValueParser {
    clap::builder::ValueParser::new(|c: &str| -> Result<String, String> {
        let name = c.split_once('=').map_or(c, |(n, _)| n);
        let names: Vec<&str> = robosim_launcher::COMPONENTS
            .iter()
            .map(|(n, _)| *n)
            .collect();
        if names.contains(&name) {
            Ok(c.to_owned())
        } else {
            Err(format!(
                "unknown component {name:?} (possible: {}; dataflow=GRAPH names its graph file, rules=FILE.clp its rule base)",
                names.join(", ")
            ))
        }
    })
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
pub(crate) enum LangCmd {
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
pub(crate) enum JournalCmd {
    /// One line per record: byte offset, version, size and operations; damaged bytes named.
    Inspect {
        /// The journal file.
        path: std::path::PathBuf,
    },
}

/// The command line of this process, parsed (`--session`'s help says the values that hold now);
/// a usage error, `--help` or `--version` prints and exits here, as clap does.
pub(crate) fn parse() -> Cli {
    let help = session_help();
    let matches = <Cli as clap::CommandFactory>::command()
        .mut_arg("session", |a| a.help(help))
        .get_matches();
    match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    }
}

/// The completion script of the whole command tree for `shell`, in memory (clap_complete
/// panics on a failed write; the caller writes it and reads the error).
pub(crate) fn completion_script(shell: clap_complete::Shell) -> Vec<u8> {
    let mut cmd = <Cli as clap::CommandFactory>::command();
    let mut script = Vec::new();
    clap_complete::generate(shell, &mut cmd, "robosim", &mut script);
    script
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
