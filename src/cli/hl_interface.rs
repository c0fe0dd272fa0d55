//! `robosim lib`, `diag`, `query` and `sim`: the clap arguments of robosim-hl-interface's
//! commands (`robosim_hl_interface::cli`), each converted to the library's plain argument type.

use std::path::PathBuf;

#[derive(Debug, Clone, clap::Subcommand)]
pub enum LibCmd {
    /// List every declaration with its kind (the standard library, or FILE with --file).
    List {
        /// A library file to list instead of the standard library (it may `include "std"`).
        #[arg(long)]
        file: Option<PathBuf>,
    },
    /// Show a declaration: kind, description, parameters with defaults and units.
    Show {
        /// The declaration (`robosim lib list` names them).
        name: String,
        /// Look NAME up in this library file instead of the standard library.
        #[arg(long)]
        file: Option<PathBuf>,
    },
    /// Check a library file (any name): parse, resolve, evaluate every declaration at its
    /// defaults. Exit status non-zero with file:line:col on the first error.
    Check {
        /// The library file to check.
        file: PathBuf,
    },
    /// Evaluate a declaration and print it as JSON (the `lib_evaluate` query answer).
    Eval {
        /// The declaration to evaluate.
        name: String,
        /// A parameter value as NAME=EXPR, e.g. `--param "upper_arm=30 cm"`; repeatable.
        #[arg(long = "param", value_name = "NAME=EXPR")]
        params: Vec<String>,
        /// Force this facet count on every round primitive.
        #[arg(long)]
        facets: Option<usize>,
        /// Include every solid's vertices and polygons.
        #[arg(long)]
        geometry: bool,
        /// Look NAME up in this library file instead of the standard library.
        #[arg(long)]
        file: Option<PathBuf>,
    },
}

impl From<LibCmd> for robosim_hl_interface::cli::lib::LibCmd {
    fn from(a: LibCmd) -> Self {
        match a {
            LibCmd::List { file } => robosim_hl_interface::cli::lib::LibCmd::List { file: file },
            LibCmd::Show { name, file } => robosim_hl_interface::cli::lib::LibCmd::Show {
                name: name,
                file: file,
            },
            LibCmd::Check { file } => robosim_hl_interface::cli::lib::LibCmd::Check { file: file },
            LibCmd::Eval {
                name,
                params,
                facets,
                geometry,
                file,
            } => robosim_hl_interface::cli::lib::LibCmd::Eval {
                name: name,
                params: params,
                facets: facets,
                geometry: geometry,
                file: file,
            },
        }
    }
}
/// `robosim diag …`
#[derive(Debug, Clone, clap::Subcommand)]
pub enum DiagCmd {
    /// Load a hierarchical process/fault model and run its consistency checks.
    Check {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// Also write the process/fault model as Graphviz DOT to this file.
        #[arg(long)]
        dot: Option<PathBuf>,
    },
    /// Inject faults and print the timed alarm sequence (the format `diag run` reads).
    Simulate {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// Failure mode to inject, as NAME or NAME@SECONDS (repeat for multiple faults).
        #[arg(long = "fault", required = true)]
        faults: Vec<String>,
        /// Seed of the propagation-time (and probability) sampling.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Sample edge probabilities (default: every edge fires, the complete alarm sequence).
        #[arg(long)]
        sample: bool,
        /// Alarms the sensor allocation lacks (filtered out), by name.
        #[arg(long = "drop")]
        drop: Vec<String>,
    },
    /// Diagnose an alarm sequence file (lines `SECONDS ALARM`) with FSPI, FSCI and ILM.
    Run {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// The alarm sequence: lines `SECONDS ALARM` (what `diag simulate` prints).
        #[arg(long)]
        alarms: PathBuf,
        /// Judge the diagnosis at this time (seconds; default: the last alarm).
        #[arg(long)]
        until: Option<f64>,
        /// Alarms not in the sensor allocation, by name (they count as absent, not normal).
        #[arg(long = "drop")]
        drop: Vec<String>,
    },
    /// Diagnosability: every single fault through simulator and diagnoser; resolution per
    /// sensor allocation; with --sensors N, the advisor's choice of N alarms.
    Analyze {
        /// Model file, or a shipped model name (eclss).
        model: String,
        /// Sensor budget: how many alarms to keep.
        #[arg(long)]
        sensors: Option<usize>,
        /// Simulated scenarios per fault (propagation sampled).
        #[arg(long, default_value_t = 3)]
        trials: usize,
        /// Seed of the scenario sampling.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

impl From<DiagCmd> for robosim_hl_interface::cli::diag::DiagCmd {
    fn from(a: DiagCmd) -> Self {
        match a {
            DiagCmd::Check { model, dot } => robosim_hl_interface::cli::diag::DiagCmd::Check {
                model: model,
                dot: dot,
            },
            DiagCmd::Simulate {
                model,
                faults,
                seed,
                sample,
                drop,
            } => robosim_hl_interface::cli::diag::DiagCmd::Simulate {
                model: model,
                faults: faults,
                seed: seed,
                sample: sample,
                drop: drop,
            },
            DiagCmd::Run {
                model,
                alarms,
                until,
                drop,
            } => robosim_hl_interface::cli::diag::DiagCmd::Run {
                model: model,
                alarms: alarms,
                until: until,
                drop: drop,
            },
            DiagCmd::Analyze {
                model,
                sensors,
                trials,
                seed,
            } => robosim_hl_interface::cli::diag::DiagCmd::Analyze {
                model: model,
                sensors: sensors,
                trials: trials,
                seed: seed,
            },
        }
    }
}
/// Arguments of `robosim query`.
#[derive(Debug, Clone, clap::Args)]
pub struct QueryArgs {
    /// Read requests from this file instead of standard input ("-" is standard input).
    #[arg(long, value_name = "FILE")]
    pub input: Option<PathBuf>,
    /// At the end, print the counts (lines, ok, errors) to standard error.
    #[arg(long)]
    pub stats: bool,
}

impl From<QueryArgs> for robosim_hl_interface::cli::query::QueryArgs {
    fn from(a: QueryArgs) -> Self {
        robosim_hl_interface::cli::query::QueryArgs {
            input: a.input,
            stats: a.stats,
        }
    }
}
/// `robosim sim`: build a scene's effect pipeline, print it, optionally run it.
#[derive(Debug, Clone, clap::Args)]
pub struct SimArgs {
    /// A library robot name (puma560, stanford, panda, …) or a robot JSON file (inline format).
    #[arg(long, default_value = "puma560")]
    pub robot: String,
    /// The scene's effect declaration: a JSON file, or JSON text starting with `{`.
    /// Default: kinematics only.
    #[arg(long)]
    pub effects: Option<String>,
    /// Initial joint values (rad or m), comma-separated; default all zero.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub q0: Option<Vec<f64>>,
    /// Steps to run headless after printing the pipeline (0: print only).
    #[arg(long, default_value_t = 0)]
    pub steps: u64,
}

impl From<SimArgs> for robosim_hl_interface::cli::sim::SimArgs {
    fn from(a: SimArgs) -> Self {
        robosim_hl_interface::cli::sim::SimArgs {
            robot: a.robot,
            effects: a.effects,
            q0: a.q0,
            steps: a.steps,
        }
    }
}
