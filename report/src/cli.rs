//! The reports by name, for the `robosim` binary to wire (`robosim report NAME|all`): which
//! reports there are, in the order `all` runs them, and the one call that runs one of them.
//! The binary parses the arguments and prints what was written; nothing here prints.
//!
//! Entry points: [`Name`], [`Name::ALL`], [`run`] and its [`ReportFailed`] (the report's [`RunError`] as source).

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

/// Why report `name` failed: the report's own error, named by the report.
#[derive(Debug, thiserror::Error)]
#[error("report {}: {source}", name.as_str())]
pub struct ReportFailed {
    pub name: Name,
    #[source]
    pub source: RunError,
}

/// Runs report `name` into `out` (`quick`: fewer samples, a smoke run); the paths written, or
/// what went wrong, named by the report.
pub fn run(name: Name, out: &Path, quick: bool) -> Result<Vec<PathBuf>, ReportFailed> {
    let report = match name {
        Name::Ik => crate::ik::report_ik(out, quick).map_err(RunError::from),
        Name::Collision => crate::collision::report_collision(out, quick),
        Name::Dynamics => crate::dynamics::report_dynamics(out, quick),
        Name::Effects => crate::effects::report_effects(out, quick),
        Name::Library => crate::library::report_library(out, quick),
        Name::Diag => crate::automation::report_diag(out, quick),
    };
    report.map_err(|source| ReportFailed { name, source })
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
