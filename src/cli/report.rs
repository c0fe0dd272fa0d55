//! `robosim report …`: its clap arguments (`ik` and `collision` have their own; the other reports
//! take [`Common`]); src/reports.rs dispatches them to `robosim_report::cli`.

use std::path::PathBuf;

/// Where reports and benches go without `--out`: a directory named for us in the working
/// directory, never into a path that happens to exist there (`docs/` of whatever repository the
/// user stands in).
pub const DEFAULT_OUT: &str = "robosim-reports";

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
    Ik(ReportIkArgs),
    /// Collision modes, broad phase and tessellation: time against false negatives/positives.
    Collision(ReportCollisionArgs),
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

/// `robosim report ik`: the IK accuracy-against-time report (see [`crate::ik`]).
#[derive(Debug, Clone, clap::Args)]
pub struct ReportIkArgs {
    /// Directory for ik.csv, ik.md and ik.png.
    #[arg(long, default_value = "robosim-reports")]
    pub out: PathBuf,
    /// 200 poses per robot instead of 10,000.
    #[arg(long)]
    pub quick: bool,
}

/// `robosim report collision`: what accuracy costs in time (see [`crate::collision`]).
#[derive(Debug, Clone, clap::Args)]
pub struct ReportCollisionArgs {
    /// Directory for collision.csv, collision.md and collision.png.
    #[arg(long, default_value = "robosim-reports")]
    pub out: PathBuf,
    /// A tenth of the samples and two broad-phase sizes (a smoke run; rougher figures).
    #[arg(long)]
    pub quick: bool,
}
