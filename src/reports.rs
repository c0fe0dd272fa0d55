//! `robosim report …` (and `robosim plot`, figures of a user's own run): every "what accuracy costs in time" study, each owned by the crate whose
//! knob it measures, written as CSV + markdown + PNG (default into `./robosim-reports/`; the
//! published ones are regenerated with `--out docs/reports`).

use crate::Result;
use std::path::{Path, PathBuf};

/// Where reports and benches go without `--out`: a directory named for us in the working
/// directory, never into a path that happens to exist there (`docs/` of whatever repository the
/// user stands in).
pub const DEFAULT_OUT: &str = "robosim-reports";

/// Prints where the files of a report or bench went: the paths it returned, or else the
/// directory (absolute, so a relative `--out` cannot surprise).
pub fn wrote(out: &Path, paths: &[PathBuf]) -> Result<()> {
    if paths.is_empty() {
        let abs = std::fs::canonicalize(out).unwrap_or_else(|_| out.to_owned());
        println!("wrote into {}", abs.display());
    }
    for p in paths {
        let abs = std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
        println!("wrote {}", abs.display());
    }
    Ok(())
}

#[derive(clap::Args, Debug, Clone)]
pub struct Common {
    /// Output directory (created if missing).
    #[arg(long, default_value = DEFAULT_OUT)]
    pub out: PathBuf,
    /// Fewer samples (a smoke run; the published reports use the full run).
    #[arg(long)]
    pub quick: bool,
}

#[derive(clap::Subcommand)]
pub enum Which {
    /// IK methods and tolerances: success, time, residual (PUMA 560, 7-DOF arm), with peer solvers.
    Ik(crate::cli::report::ReportIkArgs),
    /// Collision modes, broad phase and tessellation: time against false negatives/positives.
    Collision(crate::cli::report::ReportCollisionArgs),
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

fn paths(out: &Path, r: std::result::Result<Vec<PathBuf>, String>) -> Result<()> {
    wrote(out, &r.map_err(crate::CliError)?)
}

fn one(which: &str, out: &Path, quick: bool) -> Result<()> {
    let pb = robosim_report::progress::spinner(&format!("report {which}"));
    let r = one_report(which, out, quick);
    pb.finish_and_clear();
    r
}

fn one_report(which: &str, out: &Path, quick: bool) -> Result<()> {
    match which {
        "ik" => paths(
            out,
            robosim_report::ik::report_ik(out, quick).map_err(|e| format!("report ik: {e}")),
        ),
        "collision" => paths(
            out,
            robosim_report::collision::report_collision(out, quick)
                .map_err(|e| format!("report collision: {e}")),
        ),
        "dynamics" => paths(out, robosim_report::dynamics::report_dynamics(out, quick)),
        "effects" => paths(out, robosim_report::effects::report_effects(out, quick)),
        "library" => paths(out, robosim_report::library::report_library(out, quick)),
        "diag" => paths(out, robosim_report::automation::report_diag(out, quick)),
        other => Err(crate::CliError(format!("no report {other:?}"))),
    }
}

pub fn run(which: Which) -> Result<()> {
    match which {
        Which::Ik(a) => one("ik", &a.out, a.quick),
        Which::Collision(a) => one("collision", &a.out, a.quick),
        Which::Dynamics(c) => one("dynamics", &c.out, c.quick),
        Which::Effects(c) => one("effects", &c.out, c.quick),
        Which::Library(c) => one("library", &c.out, c.quick),
        Which::Diag(c) => one("diag", &c.out, c.quick),
        Which::All(c) => {
            let names = ["ik", "collision", "dynamics", "effects", "library", "diag"];
            let pb = robosim_report::progress::bar(names.len() as u64, "report all");
            for w in names {
                pb.set_message(w);
                pb.suspend(|| println!("== report {w}"));
                one(w, &c.out, c.quick)?;
                pb.inc(1);
            }
            pb.finish_and_clear();
            Ok(())
        }
    }
}

/// `robosim plot RUN --out DIR` (robosim_report::run_plot).
pub fn plot(run: &Path, out: &Path) -> Result<()> {
    robosim_report::run_plot::plot_and_say(run, out)?;
    Ok(())
}
