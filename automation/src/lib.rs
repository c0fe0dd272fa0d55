//! robosim-automation: the automation layer of ROBOSIM (seed §3.4 and §4.3).
//!
//! * [`model`] — Hierarchical Process and Fault Models in a declarative text form, consistency
//!   checks, the shipped ECLSS model.
pub mod model;
