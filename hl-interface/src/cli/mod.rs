//! The command-line surface of the interface side, wired into the `robosim` binary:
//!
//! * [`query`] — `robosim query` (the JSON-lines transport); [`QueryArgs`] and [`run`] are
//!   re-exported here;
//! * [`lib`] — `robosim lib list|show|check` ([`lib::LibCmd`], [`lib::run`], [`lib::render_with`]);
//! * [`diag`] — `robosim diag check|simulate|run|analyze` ([`diag::DiagCmd`], [`diag::run`],
//!   [`diag::execute`]);
//! * [`sim`] — `robosim sim` ([`sim::SimArgs`], [`sim::run`]).

pub mod diag;
pub mod lib;
pub mod query;
pub mod sim;

pub use query::{QueryArgs, run};
