//! Model-based fault diagnosis on the Hierarchical Fault Model (seed §4.3, "Diagnostic
//! Algorithm", figure 6).
//!
//! * [`FaultGraph`] — the compiled fault propagation digraph;
//! * [`Diagnoser`] — incremental FSPI with the seed's four constraints, single and multiple
//!   faults ([`fspi`]);
//! * [`fsci`] — Fault Source Component Identification;
//! * [`Ilm`] — Inter Level Migration: the level-by-level search with restarts and a best guess
//!   at any moment ([`ilm`]).

pub mod fspi;
mod graph;
pub mod ilm;

pub use fspi::{AlarmError, Candidate, Diagnoser, Verdict};
pub use graph::{Arc, FaultGraph};
pub use ilm::{Guess, Ilm, LevelResult, ProcessVerdict};

use crate::model::{CompId, FmId, Model};

/// FSCI (seed §4.3): the physical components behind source failure modes.
///
/// `multiple == false` (a single fault, any of `sources` may be it): the union of their
/// components. `multiple == true` (they fail together): a component common to all of them if
/// there is one (the likeliest single physical cause), else the union. Sorted, no duplicates.
pub fn fsci(model: &Model, sources: &[FmId], multiple: bool) -> Vec<CompId> {
    let mut union: Vec<CompId> = sources
        .iter()
        .flat_map(|&f| model.failure_modes[f].components.iter().copied())
        .collect();
    union.sort_unstable();
    union.dedup();
    if multiple && !sources.is_empty() {
        let common: Vec<CompId> = union
            .iter()
            .copied()
            .filter(|c| {
                sources
                    .iter()
                    .all(|&f| model.failure_modes[f].components.contains(c))
            })
            .collect();
        if !common.is_empty() {
            return common;
        }
    }
    union
}
