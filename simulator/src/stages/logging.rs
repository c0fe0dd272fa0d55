//! Signal logging: every `every`-th step, one row of the declared signals — to a CSV file (header
//! first, flushed by `Pipeline::flush_log` and when the pipeline is dropped) or to memory.
//! Depends on everything before it. The sink is output, not state: it is not in `Data`
//! (a rewound simulation logs its steps again).
//! The first column is always the simulation time `t_s`; every column name carries its unit
//! (`q1_rad`, `q3_m`, `qd1_rad_s`, `tau1_Nm`).

use crate::model::{Model, StepError};
use robosim_kinematics::JointType;
use robosim_model::{Data, LoggingEffect, OptionsError, Signal};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

enum Sink {
    Memory(Arc<Mutex<Vec<Vec<f64>>>>),
    Csv(BufWriter<File>, PathBuf),
}

pub const NAME: &str = "logging";
pub const DEPENDS_ON: &str = "all of the above";

/// The logging stage's sink: where rows go, and the row being written (workspace).
pub struct Logging {
    signals: Vec<Signal>,
    every: u64,
    sink: Sink,
    row: Vec<f64>,
}

/// Read access to an in-memory log.
#[derive(Clone)]
pub struct LogHandle {
    rows: Option<Arc<Mutex<Vec<Vec<f64>>>>>,
    header: Vec<String>,
}

impl LogHandle {
    pub fn rows(&self) -> Vec<Vec<f64>> {
        // a poisoned lock means a stage panicked mid-push; the rows written before are intact
        self.rows
            .as_ref()
            .map(|r| {
                r.lock()
                    .map_or_else(|p| p.into_inner().clone(), |g| g.clone())
            })
            .unwrap_or_default()
    }
    pub fn header(&self) -> Vec<String> {
        self.header.clone()
    }
}

/// The column names, each with its unit: `t_s` first (always: the time at the end of the
/// logged step), then per declared signal one column per joint, `<signal><j>_<unit>` with
/// j from 1 — rad, rad/s, rad/s², N·m for a revolute joint; m, m/s, m/s², N for a prismatic
/// one — and `contact` (1 = the step's check found a contact, 0 = clear).
fn header(signals: &[Signal], joints: &[JointType]) -> Vec<String> {
    let mut h = vec!["t_s".to_string()];
    for s in signals {
        let unit = |j: JointType| {
            let revolute = j == JointType::Revolute;
            match s {
                Signal::Q | Signal::QMeasured => {
                    if revolute {
                        "rad"
                    } else {
                        "m"
                    }
                }
                Signal::Qd => {
                    if revolute {
                        "rad_s"
                    } else {
                        "m_s"
                    }
                }
                Signal::Qdd => {
                    if revolute {
                        "rad_s2"
                    } else {
                        "m_s2"
                    }
                }
                Signal::Tau => {
                    if revolute {
                        "Nm"
                    } else {
                        "N"
                    }
                }
                Signal::T | Signal::Contact => "",
            }
        };
        match s {
            Signal::T => {}
            Signal::Contact => h.push(s.name().to_string()),
            _ => h.extend(
                joints
                    .iter()
                    .enumerate()
                    .map(|(j, t)| format!("{}{}_{}", s.name(), j + 1, unit(*t))),
            ),
        }
    }
    h
}

impl Logging {
    /// The logging stage of a robot whose joints are `joints` (chain order).
    pub fn new(
        joints: &[JointType],
        l: &LoggingEffect,
        has_encoder: bool,
        has_collision: bool,
    ) -> Result<(Self, LogHandle), OptionsError> {
        let bad = |field: &str, reason: String| OptionsError {
            field: format!("logging.{field}"),
            reason,
        };
        if l.signals.is_empty() {
            return Err(bad("signals", "declare at least one signal".into()));
        }
        if l.every == 0 {
            return Err(bad("every", "must be at least 1".into()));
        }
        if l.signals.contains(&Signal::QMeasured) && !has_encoder {
            return Err(bad("signals", "q_measured needs the encoder effect".into()));
        }
        if l.signals.contains(&Signal::Contact) && !has_collision {
            return Err(bad("signals", "contact needs the collision effect".into()));
        }
        let h = header(&l.signals, joints);
        let (sink, rows) = match &l.path {
            None => {
                let rows = Arc::new(Mutex::new(Vec::new()));
                (Sink::Memory(rows.clone()), Some(rows))
            }
            Some(path) => {
                // Signal logs are private to the user, like everything else of a session.
                use std::os::unix::fs::OpenOptionsExt;
                let mut f = BufWriter::new(
                    std::fs::OpenOptions::new()
                        .write(true)
                        .create(true)
                        .truncate(true)
                        .mode(0o600)
                        .open(path)
                        .map_err(|e| bad("path", format!("{}: {e}", path.display())))?,
                );
                writeln!(f, "{}", h.join(","))
                    .map_err(|e| bad("path", format!("{}: {e}", path.display())))?;
                (Sink::Csv(f, path.clone()), None)
            }
        };
        let width = h.len();
        Ok((
            Logging {
                signals: l.signals.clone(),
                every: u64::from(l.every),
                sink,
                row: Vec::with_capacity(width),
            },
            LogHandle { rows, header: h },
        ))
    }
}

impl Logging {
    pub fn describe(&self) -> String {
        let names: Vec<&str> = self.signals.iter().map(|s| s.name()).collect();
        let to = match &self.sink {
            Sink::Memory(_) => "memory".to_string(),
            Sink::Csv(_, p) => format!("CSV {}", p.display()),
        };
        format!("{} every {} step(s) to {to}", names.join(", "), self.every)
    }
    /// Writes out what the sink buffers (a CSV file's rows).
    pub fn flush(&mut self) -> Result<(), StepError> {
        match &mut self.sink {
            Sink::Memory(_) => Ok(()),
            Sink::Csv(f, path) => f.flush().map_err(|source| StepError::Logging {
                path: path.clone(),
                source,
            }),
        }
    }
    /// Every `every`-th step, the declared signals of `d` as one row.
    pub fn run(&mut self, m: &Model, d: &Data) -> Result<(), StepError> {
        if !(d.step + 1).is_multiple_of(self.every) {
            return Ok(());
        }
        self.row.clear();
        // t_s: the time at the end of this step (the pipeline's clock after it)
        self.row.push((d.step + 1) as f64 * m.dt);
        // the columns are the joints': a floating robot's root coordinates are left out
        let (rq, rv) = (m.robot.root_nq(), m.robot.root_nv());
        for s in &self.signals {
            match s {
                Signal::T => {}
                Signal::Q => self.row.extend(d.state.q.iter().skip(rq)),
                Signal::Qd => self.row.extend(d.state.qd.iter().skip(rv)),
                Signal::Qdd => self.row.extend(d.state.qdd.iter().skip(rv)),
                Signal::Tau => self.row.extend(d.tau.iter().skip(rv)),
                Signal::QMeasured => self.row.extend(d.q_measured.iter().flat_map(|m| m.iter())),
                Signal::Contact => self
                    .row
                    .push(if d.contact == Some(true) { 1.0 } else { 0.0 }),
            }
        }
        match &mut self.sink {
            Sink::Memory(rows) => rows
                .lock()
                .map_err(|_| StepError::LogBufferPoisoned)?
                .push(self.row.clone()),
            Sink::Csv(f, path) => {
                let mut first = true;
                for v in &self.row {
                    if !first {
                        f.write_all(b",").map_err(io_at(path))?;
                    }
                    first = false;
                    write!(f, "{v}").map_err(io_at(path))?;
                }
                f.write_all(b"\n").map_err(io_at(path))?;
            }
        }
        Ok(())
    }
}

/// The logging stage's refusal for an I/O error on its CSV file at `path`.
fn io_at(path: &Path) -> impl Fn(std::io::Error) -> StepError + '_ {
    move |source| StepError::Logging {
        path: path.to_owned(),
        source,
    }
}
