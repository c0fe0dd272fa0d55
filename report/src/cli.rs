//! Command-line surface for the `robosim` binary to wire: `robosim report ik [--out DIR]
//! [--quick]` and `robosim report collision [--out DIR] [--quick]`.
//!
//! Entry points: [`ReportIkArgs`], [`run_report_ik`], [`ReportCollisionArgs`],
//! [`run_report_collision`].

use std::path::PathBuf;

/// `robosim report ik`: the IK accuracy-against-time report (see [`crate::ik`]).
#[derive(Debug, Clone)]
pub struct ReportIkArgs {
    /// Directory for ik.csv, ik.md and ik.png.
    pub out: PathBuf,
    /// 200 poses per robot instead of 10,000.
    pub quick: bool,
}

/// Runs the report and prints the paths written (one per line).
pub fn run_report_ik(args: &ReportIkArgs) -> Result<(), String> {
    let paths =
        crate::ik::report_ik(&args.out, args.quick).map_err(|e| format!("report ik: {e}"))?;
    for p in paths {
        println!("{}", p.display());
    }
    Ok(())
}

/// `robosim report collision`: what accuracy costs in time (see [`crate::collision`]).
#[derive(Debug, Clone)]
pub struct ReportCollisionArgs {
    /// Directory for collision.csv, collision.md and collision.png.
    pub out: PathBuf,
    /// A tenth of the samples and two broad-phase sizes (a smoke run; rougher figures).
    pub quick: bool,
}

/// Runs the report and prints the paths written (one per line).
pub fn run_report_collision(args: &ReportCollisionArgs) -> Result<(), String> {
    let paths = crate::collision::report_collision(&args.out, args.quick)
        .map_err(|e| format!("report collision: {e}"))?;
    for p in paths {
        println!("{}", p.display());
    }
    Ok(())
}
