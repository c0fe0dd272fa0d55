//! Reports that publish "what accuracy costs in time" for each part of robosim, and the
//! table/plot writer they share. This crate sits above the numeric cores (kinematics,
//! dynamics, collision, the effect pipeline, the library, automation) and times their plain
//! functions; none of them depends on it.
//!
//! Entry points:
//! * [`plot`] — [`write_report`] (CSV + markdown + PNG), [`percentile`], [`Report`], [`Table`],
//!   [`Plot`], [`Series`];
//! * [`ik::report_ik`] — `robosim report ik`: IK solvers, accuracy against time;
//! * [`dynamics::report_dynamics`] — `robosim report dynamics`: integrator error against time;
//! * [`collision::report_collision`] — `robosim report collision`: modes and broad phases;
//! * [`effects::report_effects`] — `robosim report effects`: cost per pipeline step by effect;
//! * [`library::report_library`] — `robosim report library`: parse + evaluate time;
//! * [`automation::report_diag`] — `robosim report diag`: diagnosis time and resolution;
//! * [`ipc`] — `robosim bench ipc`: the Instance Space's costs (snapshot access, pose
//!   transactions, notification latency, journaled throughput), across real processes;
//! * [`scale`] — `robosim bench scale`: what a one-body change costs at 10²…10⁵ objects;
//! * [`journal`] — `robosim bench journal`: what the journal's second copy costs;
//! * [`cli`] — the reports by name and the one call that runs one (`robosim report NAME`);
//! * [`run_plot::plot_file`] — `robosim plot RUN.mcap|RUN.csv`: figures of a user's own run;
//! * [`font`] — the bundled font plots and the display's status line are drawn with;
//! * [`written`] — a run's spinner and where its files went (`robosim report|bench`).

#![forbid(unsafe_code)]

pub mod automation;
pub mod bridge;
pub mod cli;
pub mod collision;
pub mod dynamics;
pub mod effects;
pub mod font;
pub mod ik;
pub mod ipc;
pub mod journal;
pub mod library;
pub mod plot;
pub mod progress;
pub mod run_plot;
pub mod scale;
pub mod written;

pub use plot::{Plot, Report, ReportError, Series, Table, percentile, write_report};
