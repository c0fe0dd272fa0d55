//! robosim-automation: the automation layer of ROBOSIM (seed §3.4 and §4.3).
//!
//! * [`model`] — Hierarchical Process and Fault Models in a declarative text form, consistency
//!   checks, the shipped ECLSS model.
//! * [`diag`] — FSPI (incremental, single and multiple faults), FSCI and ILM.
pub mod model;
pub mod diag;
pub mod sim;
pub mod analysis;
pub mod kernel;
pub mod reconfig;
pub mod bench;
