//! `robosim simulator --record FILE.mcap`: the run recorded to MCAP with `robosim-record`
//! (channels and schemas in its docs). What the daemon writes:
//! * at start, and after every step: every robot's joint state and link poses, and the
//!   collision verdicts when some pipeline checks collisions — so a run of N steps holds
//!   N + 1 messages per channel, at k · dt for k = 0..=N;
//! * on `/simulator/log`: every accepted command (info), every refused one (warning), a reset
//!   or a rebuild after a structure change (info), a contact beginning (warning) or ending
//!   (info), a step failure (error).
//!
//! The clock is the daemon's *run* time: steps since it started × dt, in ns. It equals the
//! simulation time until a `reset` or a structure change restarts the pipelines' clocks at 0;
//! the recording's clock does not go back (a log's time must not), so after a reset it runs
//! ahead of the `t_s` that `get` reports.
//!
//! Flushing: the open chunk is completed and written whenever the daemon is idle (lock-step,
//! nothing queued) and at least once per second of wall time, so a `kill -9` loses at most the
//! last second of a free-running recording and nothing of an idle one. `robosim down`
//! (SIGTERM) closes the file with its summary.
//!
//! A write that fails (disk full, I/O error) stops the recording, not the simulator: the
//! daemon says once on stderr which file and why (`simulator: recording to FILE stopped: …;
//! the simulation goes on`), keeps stepping and answering, and `get` reports
//! `"recording": {"path": …, "messages": N, "state": "stopped", "stopped": "why"}` (N: the
//! messages written before the failure; the file keeps the chunks completed before it, which
//! a streaming reader reads, and has no summary).

use crate::{Result, Sim};
use robosim_record::{ContactSample, Level, Recorder, RobotSample};
use robosim_scene::link_poses;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The most wall time between two flushes of a free-running recording.
const FLUSH_EVERY: Duration = Duration::from_secs(1);

pub(crate) struct Recording {
    path: PathBuf,
    /// `None` once a write failed (then `stopped` says why).
    rec: Option<Recorder>,
    stopped: Option<String>,
    /// Messages written when the recording stopped.
    written: u64,
    /// Messages written since the last flush.
    dirty: bool,
    last_flush: Instant,
}

impl Recording {
    pub(crate) fn create(path: &Path, source: &str) -> Result<Recording> {
        Ok(Recording {
            path: path.to_owned(),
            rec: Some(Recorder::create(path, source)?),
            stopped: None,
            written: 0,
            dirty: false,
            last_flush: Instant::now(),
        })
    }

    /// Messages written so far, all channels.
    pub(crate) fn messages(&self) -> u64 {
        match &self.rec {
            Some(r) => r.counts().values().sum(),
            None => self.written,
        }
    }

    /// The `recording` member of the `get` answer (status.rs).
    pub(crate) fn status(&self) -> Value {
        json!({
            "path": self.path.display().to_string(),
            "messages": self.messages(),
            "state": if self.stopped.is_some() { "stopped" } else { "recording" },
            "stopped": self.stopped,
        })
    }

    /// `r`'s error stops the recording (module docs): said once, the writer dropped (its
    /// close writes nothing more that could fail loudly: its errors are ignored).
    fn check(&mut self, r: std::result::Result<(), robosim_record::RecordError>) {
        if let Err(e) = r {
            self.written = self.messages();
            self.rec = None;
            eprintln!("simulator: {e}: the recording stopped; the simulation goes on");
            self.stopped = Some(e.to_string());
        }
    }

    /// Every robot's state at run time `t_ns`, and an event for each contact that began or
    /// ended since the last sample.
    pub(crate) fn sample(&mut self, t_ns: u64, sims: &mut [Sim]) {
        let r = self.write_sample(t_ns, sims);
        self.check(r);
    }

    fn write_sample(
        &mut self,
        t_ns: u64,
        sims: &mut [Sim],
    ) -> std::result::Result<(), robosim_record::RecordError> {
        let Some(rec) = &mut self.rec else {
            return Ok(());
        };
        let poses: Vec<Vec<[f64; 12]>> = sims
            .iter()
            .map(|s| {
                link_poses(
                    &s.pipeline.model().robot,
                    s.pipeline.data().state.q.as_slice(),
                )
            })
            .collect();
        // a floating robot's base where its simulated root put it
        let bases: Vec<_> = sims.iter().map(Sim::base_now).collect();
        let robots: Vec<RobotSample<'_>> = sims
            .iter()
            .zip(&poses)
            .zip(&bases)
            .map(|((s, links), base)| {
                // the joints' part (a floating robot's root is in `base`)
                let (q, qd, tau) = s.pipeline.joint_state();
                RobotSample {
                    name: &s.name,
                    joint_names: &s.link_names,
                    q,
                    qd,
                    // Efforts are known only where dynamics runs; a kinematic run records
                    // none (as a playback), not zeros a plot would draw as torques.
                    effort: if s.pipeline.model().options.dynamics.is_some() {
                        tau
                    } else {
                        &[]
                    },
                    base,
                    links,
                }
            })
            .collect();
        rec.robots(t_ns, &robots)?;
        let contacts: Vec<ContactSample<'_>> = sims
            .iter()
            .filter_map(|s| {
                let w = s.pipeline.data();
                w.contact.map(|contact| ContactSample {
                    robot: &s.name,
                    contact,
                    contact_steps: w.contact_steps,
                })
            })
            .collect();
        rec.contacts(t_ns, &contacts)?;
        for s in sims.iter_mut() {
            let now = s.pipeline.data().contact == Some(true);
            if now != s.contact_was {
                let (level, what) = if now {
                    (Level::Warning, "contact")
                } else {
                    (Level::Info, "clear again")
                };
                rec.log(t_ns, level, &s.name, what)?;
                s.contact_was = now;
            }
        }
        self.dirty = true;
        Ok(())
    }

    /// An event of the run at `t_ns`; `name` says who (a robot, or `simulator`).
    pub(crate) fn event(&mut self, t_ns: u64, level: Level, name: &str, what: &str) {
        if let Some(rec) = &mut self.rec {
            let r = rec.log(t_ns, level, name, what);
            self.dirty = true;
            self.check(r);
        }
    }

    /// Completes the chunk on disk when the daemon is `idle` or a second has passed.
    pub(crate) fn maybe_flush(&mut self, idle: bool) {
        if self.dirty
            && (idle || self.last_flush.elapsed() >= FLUSH_EVERY)
            && let Some(rec) = &mut self.rec
        {
            let r = rec.flush();
            self.dirty = false;
            self.last_flush = Instant::now();
            self.check(r);
        }
    }

    /// Writes the summary and closes the file, and says so on stderr (a recording that
    /// stopped earlier has nothing to close: its reason is said again).
    pub(crate) fn finish(self) -> Result<()> {
        match self.rec {
            Some(rec) => {
                let counts = rec.finish()?;
                eprintln!(
                    "simulator: recorded {} messages to {}",
                    counts.values().sum::<u64>(),
                    self.path.display()
                );
            }
            None => eprintln!(
                "simulator: the recording to {} had stopped after {} messages: {}",
                self.path.display(),
                self.written,
                self.stopped.as_deref().unwrap_or("")
            ),
        }
        Ok(())
    }
}
