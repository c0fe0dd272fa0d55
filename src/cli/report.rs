//! `robosim report ik|collision`: their clap arguments (the other reports take `reports::Common`).

use std::path::PathBuf;

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
