//! The seed's case studies as runnable programs: each starts (or uses) a session, does the
//! study's work through the real crates, processes and shared memory, and writes what it found
//! to a writer — the `robosim demo` and `robosim study` commands print it.
//!
//! * [`surgical`] — seed §2.7: the kinematic surgical positioner beside the patient's head (IK,
//!   collision, MOVEJI, the encoder study, dynamics, an ECLSS diagnosis), `robosim demo`.
//!
//! * [`welding`] — seed §2.2/§2.7: the downhand welding cell, `robosim study welding`.
//! * [`station`] — seed chapter 4: the Space Station's orbit, sun-tracking arrays, power and
//!   an ORU swap by the servicer, `robosim study station`; [`orbit`] is its orbit model and
//!   `robosim_simulator::power` its arrays, tracking, power and battery (both shared with the
//!   simulator daemon's space stage).
//! * [`operations`] — issue 38 item 7: the operational station as separate processes on one
//!   session (simulator, rules, dataflow, automation), `robosim study operations`.
//! * [`sweep`] — `robosim sweep STUDY --param … --workers N`: a parameter study over worker
//!   processes, gathered into one CSV; a dead worker's job is redone.
//! * [`common`] — bodies, clearances, trajectory files, CSV and frames the two share.
//!
//! Entry points: [`surgical::run`], [`welding::run`], [`station::run`], [`StudyError`].

pub mod cli;
pub mod common;
pub mod operations;
/// The orbit model (the `orbit` effect), shared with the simulator daemon.
pub use robosim_simulator::orbit;
pub mod station;
pub mod surgical;
pub mod sweep;
pub mod welding;

/// Why a study stopped: what failed, in words (every study step names its input).
#[derive(Debug)]
pub struct StudyError(pub String);

impl std::fmt::Display for StudyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<E: std::error::Error> From<E> for StudyError {
    fn from(e: E) -> Self {
        StudyError(e.to_string())
    }
}

pub type Result<T> = std::result::Result<T, StudyError>;

macro_rules! bail {
    ($($t:tt)*) => { return Err($crate::StudyError(format!($($t)*))) };
}
pub(crate) use bail;

/// `writeln!` to a study's report writer; a failed write ends the study.
macro_rules! say {
    ($out:expr) => { writeln!($out).map_err(|e| $crate::StudyError(e.to_string()))? };
    ($out:expr, $($t:tt)*) => { writeln!($out, $($t)*).map_err(|e| $crate::StudyError(e.to_string()))? };
}
pub(crate) use say;
