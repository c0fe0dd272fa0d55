//! `robosim report …`: every "what accuracy costs in time" study, each owned by the crate whose
//! knob it measures, written as CSV + markdown + PNG (default into `docs/reports/`).

use crate::Result;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug, Clone)]
pub struct Common {
    /// Output directory.
    #[arg(long, default_value = "docs/reports")]
    pub out: PathBuf,
    /// Fewer samples (a smoke run; the published reports use the full run).
    #[arg(long)]
    pub quick: bool,
}

#[derive(clap::Subcommand)]
pub enum Which {
    /// IK methods and tolerances: success, time, residual (PUMA 560, 7-DOF arm), with peer solvers.
    Ik(robosim_report::cli::ReportIkArgs),
    /// Collision modes, broad phase and tessellation: time against false negatives/positives.
    Collision(robosim_report::cli::ReportCollisionArgs),
    /// Integrators and steps: error at t = 2 s of a falling PUMA 560 against wall time.
    Dynamics(Common),
    /// Time per step with each effect declared, and the cost of undeclared effects (none).
    Effects(Common),
    /// Parse + instantiate the Space Station against facet count.
    Library(Common),
    /// Diagnosis update time per alarm against fault-model size; ECLSS resolution by sensor set.
    Diag(Common),
    /// Every report above.
    All(Common),
}

fn paths(r: std::result::Result<Vec<PathBuf>, String>) -> Result<()> {
    for p in r.map_err(crate::CliError)? {
        println!("wrote {}", p.display());
    }
    Ok(())
}

fn one(which: &str, out: &Path, quick: bool) -> Result<()> {
    match which {
        "ik" => robosim_report::cli::run_report_ik(&robosim_report::cli::ReportIkArgs {
            out: out.to_owned(),
            quick,
        })
        .map_err(crate::CliError),
        "collision" => {
            robosim_report::cli::run_report_collision(&robosim_report::cli::ReportCollisionArgs {
                out: out.to_owned(),
                quick,
            })
            .map_err(crate::CliError)
        }
        "dynamics" => paths(robosim_report::dynamics::report_dynamics(out, quick)),
        "effects" => paths(robosim_report::effects::report_effects(out, quick)),
        "library" => paths(robosim_report::library::report_library(out, quick)),
        "diag" => paths(robosim_report::automation::report_diag(out, quick)),
        other => Err(crate::CliError(format!("no report {other:?}"))),
    }
}

pub fn run(which: Which) -> Result<()> {
    match which {
        Which::Ik(a) => robosim_report::cli::run_report_ik(&a).map_err(crate::CliError),
        Which::Collision(a) => {
            robosim_report::cli::run_report_collision(&a).map_err(crate::CliError)
        }
        Which::Dynamics(c) => one("dynamics", &c.out, c.quick),
        Which::Effects(c) => one("effects", &c.out, c.quick),
        Which::Library(c) => one("library", &c.out, c.quick),
        Which::Diag(c) => one("diag", &c.out, c.quick),
        Which::All(c) => {
            for w in ["ik", "collision", "dynamics", "effects", "library", "diag"] {
                println!("== report {w}");
                one(w, &c.out, c.quick)?;
            }
            Ok(())
        }
    }
}
