//! The reports by name, for the `robosim` binary to wire (`robosim report NAME|all`): which
//! reports there are, in the order `all` runs them, and the one call that runs one of them.
//! The binary parses the arguments and prints what was written; nothing here prints.
//!
//! Entry points: [`Name`], [`Name::ALL`], [`run`] ([`run_typed`] and its [`RunError`]).

use std::path::{Path, PathBuf};

/// One "what accuracy costs in time" report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Name {
    /// [`crate::ik::report_ik`]
    Ik,
    /// [`crate::collision::report_collision`]
    Collision,
    /// [`crate::dynamics::report_dynamics`]
    Dynamics,
    /// [`crate::effects::report_effects`]
    Effects,
    /// [`crate::library::report_library`]
    Library,
    /// [`crate::automation::report_diag`]
    Diag,
}

impl Name {
    /// Every report, in the order `robosim report all` runs them.
    pub const ALL: [Name; 6] = [
        Name::Ik,
        Name::Collision,
        Name::Dynamics,
        Name::Effects,
        Name::Library,
        Name::Diag,
    ];

    /// The command's word for it (`robosim report ik`).
    pub fn as_str(self) -> &'static str {
        match self {
            Name::Ik => "ik",
            Name::Collision => "collision",
            Name::Dynamics => "dynamics",
            Name::Effects => "effects",
            Name::Library => "library",
            Name::Diag => "diag",
        }
    }
}

pub use crate::plot::RunError;

/// Runs report `name` into `out` (`quick`: fewer samples, a smoke run); the paths written, or
/// what went wrong prefixed with the report's name. (The answer is text because the binary's
/// `CliError` takes text for this call; the message holds the whole chain, each variant's
/// Display ending in its source's.)
pub fn run(name: Name, out: &Path, quick: bool) -> Result<Vec<PathBuf>, String> {
    run_typed(name, out, quick).map_err(|e| format!("report {}: {e}", name.as_str()))
}

/// [`run`] with the typed error.
pub fn run_typed(name: Name, out: &Path, quick: bool) -> Result<Vec<PathBuf>, RunError> {
    match name {
        Name::Ik => Ok(crate::ik::report_ik(out, quick)?),
        Name::Collision => crate::collision::report_collision(out, quick),
        Name::Dynamics => crate::dynamics::report_dynamics(out, quick),
        Name::Effects => crate::effects::report_effects(out, quick),
        Name::Library => crate::library::report_library(out, quick),
        Name::Diag => crate::automation::report_diag(out, quick),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_report_has_its_own_word() {
        let words: std::collections::BTreeSet<&str> =
            Name::ALL.iter().map(|n| n.as_str()).collect();
        assert_eq!(words.len(), Name::ALL.len());
    }
}
