//! robosim-automation: the automation layer of ROBOSIM (seed §3.4 and §4.3).
//!
//! * [`kernel`] — a macro-dataflow kernel in the spirit of the Multigraph Execution
//!   Environment: actor and data nodes, ifall/ifany, data- and demand-driven operation, a
//!   thread-pool scheduler, live rewiring of a running graph, a tracer and DOT export.
//! * [`dataflow`] — graphs declared in a file (actors from a registry of built-in kinds, data
//!   nodes, sources and sinks naming session aspects), run by passes and rewired on reload
//!   (`robosim dataflow`, docs/dataflow.md).
//! * [`reconfig`] — the reconfigurable controller of pictures 6–7 (P → PID, rewired by a
//!   Checker actor while the arm runs).
//! * [`model`] — Hierarchical Process and Fault Models in a declarative text form, consistency
//!   checks as graph properties, the shipped ECLSS model (`eclss`).
//! * [`diag`] — FSPI (incremental, the four constraints, single and multiple faults), FSCI and
//!   ILM.
//! * [`sim`] — the alarm pattern simulator, sensor-allocation filters, alarm files.
//! * [`analysis`] — diagnosability (resolution per sensor allocation) and the sensor advisor.
//!
//! The model format, the algorithms and the measured curves are documented in
//! `docs/automation.md`.

#![forbid(unsafe_code)]

pub mod analysis;
pub mod dataflow;
pub mod diag;
pub mod kernel;
pub mod model;
pub mod reconfig;
pub mod sim;
