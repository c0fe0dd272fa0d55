//! `robosim sweep STUDY --param name=range … --workers N`: a parameter study split over
//! headless worker processes, gathered into one CSV (docs/studies.md, "Sweeps").
//!
//! * [`spec`] — `--param` parsing and the cartesian product of points (jobs, stable indices);
//! * [`study`] — the studies a sweep runs, their parameters and result columns;
//! * [`protocol`] — the JSON-lines protocol between coordinator and workers;
//! * [`worker`] — `robosim sweep-worker`, the process that runs jobs;
//! * [`transport`] — how workers are started and reached ([`transport::Launcher`],
//!   [`transport::WorkerLink`]; local processes now, other machines later);
//! * [`coordinator`] — hands out jobs, redoes a dead worker's job, gathers the results;
//! * [`cli`] — the command and its CSV; [`bench`] — `robosim bench sweep`.
//!
//! Entry points: [`cli::run`], [`worker::serve`], [`coordinator::run`], [`SweepError`].

pub mod bench;
pub mod cli;
pub mod coordinator;
mod params;
pub mod protocol;
pub mod remote;
pub mod spec;
pub mod study;
pub mod transport;
pub mod worker;

/// Why a sweep did not run (a job that fails is not one: it is a row with its error).
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The study named on the command line is not one a sweep runs.
    #[error("unknown study {name:?}: a sweep runs {known}")]
    UnknownStudy { name: String, known: String },
    /// A `--param` argument is malformed, names no parameter of the study, or gives a value
    /// the parameter cannot take (NaN, a word for a number, a count of 0 …).
    #[error("--param {arg:?}: {why}")]
    Param { arg: String, why: String },
    /// The study refuses one of the points (a value outside its range); checked for every
    /// point before any worker starts.
    #[error("point {index} ({point}): {source}")]
    Point {
        index: usize,
        point: String,
        #[source]
        source: crate::StudyError,
    },
    /// The product of the parameters' values is too large.
    #[error("{axes} is more than {max} jobs")]
    TooMany { max: usize, axes: String },
    /// `--workers 0` and no other worker.
    #[error("no workers: give --workers N with N ≥ 1, or --remote ENDPOINT")]
    NoWorkers,
    /// A `--remote` host could not be reached or refused.
    #[error("--remote {endpoint}: {why}")]
    Remote { endpoint: String, why: String },
    /// Every worker died or could not start, with jobs left.
    #[error("no worker left with {remaining} jobs to run (last: {last})")]
    NoWorkersLeft { remaining: usize, last: String },
    /// Reading or writing a file.
    #[error("{path}: {err}")]
    Io {
        path: std::path::PathBuf,
        err: std::io::Error,
    },
}
