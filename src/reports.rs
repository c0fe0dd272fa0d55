//! `robosim report …` (and `robosim plot`, figures of a user's own run): every "what accuracy costs in time" study, each owned by the crate whose
//! knob it measures, written as CSV + markdown + PNG (default into `./robosim-reports/`; the
//! published ones are regenerated with `--out docs/reports`).

use crate::Result;
use robosim_report::cli::Name;
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

/// One report with a spinner, then where its files went.
fn one(name: Name, out: &Path, quick: bool) -> Result<()> {
    let pb = robosim_report::progress::spinner(&format!("report {}", name.as_str()));
    let r = robosim_report::cli::run(name, out, quick);
    pb.finish_and_clear();
    wrote(out, &r.map_err(crate::CliError)?)
}

pub fn run(which: Which) -> Result<()> {
    match which {
        Which::Ik(a) => one(Name::Ik, &a.out, a.quick),
        Which::Collision(a) => one(Name::Collision, &a.out, a.quick),
        Which::Dynamics(c) => one(Name::Dynamics, &c.out, c.quick),
        Which::Effects(c) => one(Name::Effects, &c.out, c.quick),
        Which::Library(c) => one(Name::Library, &c.out, c.quick),
        Which::Diag(c) => one(Name::Diag, &c.out, c.quick),
        Which::All(c) => {
            let pb = robosim_report::progress::bar(Name::ALL.len() as u64, "report all");
            for name in Name::ALL {
                pb.set_message(name.as_str());
                pb.suspend(|| println!("== report {}", name.as_str()));
                one(name, &c.out, c.quick)?;
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
