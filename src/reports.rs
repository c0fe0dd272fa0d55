//! `robosim report …` (and `robosim plot`, figures of a user's own run): every "what accuracy costs in time" study, each owned by the crate whose
//! knob it measures, written as CSV + markdown + PNG (default into `./robosim-reports/`; the
//! published ones are regenerated with `--out docs/reports`).

use crate::Result;
use crate::cli::report::Which;
use robosim_report::cli::Name;
use robosim_report::written::{spun, wrote};
use std::path::Path;

/// One report with a spinner, then where its files went.
fn one(name: Name, out: &Path, quick: bool) -> Result<()> {
    let paths = spun(&format!("report {}", name.as_str()), || {
        robosim_report::cli::run(name, out, quick)
    })?;
    print!("{}", wrote(out, &paths));
    Ok(())
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
