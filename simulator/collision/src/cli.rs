//! Command-line surface for the `robosim` binary to wire:
//! `robosim report collision [--out DIR] [--quick]`.
//!
//! Entry points: [`ReportCollisionArgs`], [`run_report_collision`].

use std::path::PathBuf;

/// `robosim report collision`: what accuracy costs in time (see [`crate::report`]).
#[derive(Debug, Clone, clap::Args)]
pub struct ReportCollisionArgs {
    /// Directory for collision.csv, collision.md and collision.png.
    #[arg(long, default_value = "docs/reports")]
    pub out: PathBuf,
    /// A tenth of the samples and two broad-phase sizes (a smoke run; rougher figures).
    #[arg(long)]
    pub quick: bool,
}

/// Runs the report and prints the paths written (one per line).
pub fn run_report_collision(args: &ReportCollisionArgs) -> Result<(), String> {
    let paths = crate::report::report_collision(&args.out, args.quick)
        .map_err(|e| format!("report collision: {e}"))?;
    for p in paths {
        println!("{}", p.display());
    }
    Ok(())
}
