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

use crate::{Result, Sim};
use robosim_record::{ContactSample, Level, Recorder, RobotSample};
use robosim_scene::link_poses;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

/// The most wall time between two flushes of a free-running recording.
const FLUSH_EVERY: Duration = Duration::from_secs(1);

pub(crate) struct Recording {
    rec: Recorder,
    /// Messages written since the last flush.
    dirty: bool,
    last_flush: Instant,
}

impl Recording {
    pub(crate) fn create(path: &Path, source: &str) -> Result<Recording> {
        Ok(Recording {
            rec: Recorder::create(path, source)?,
            dirty: false,
            last_flush: Instant::now(),
        })
    }

    pub(crate) fn path(&self) -> &Path {
        self.rec.path()
    }

    /// Messages written so far, all channels.
    pub(crate) fn messages(&self) -> u64 {
        self.rec.counts().values().sum()
    }

    /// Every robot's state at run time `t_ns`, and an event for each contact that began or
    /// ended since the last sample.
    pub(crate) fn sample(&mut self, t_ns: u64, sims: &mut [Sim]) -> Result<()> {
        let poses: Vec<Vec<[f64; 12]>> = sims
            .iter()
            .map(|s| {
                link_poses(
                    &s.pipeline.model().robot,
                    s.pipeline.data().state.q.as_slice(),
                )
            })
            .collect();
        let robots: Vec<RobotSample<'_>> = sims
            .iter()
            .zip(&poses)
            .map(|(s, links)| {
                let w = s.pipeline.data();
                RobotSample {
                    name: &s.name,
                    joint_names: &s.link_names,
                    q: w.state.q.as_slice(),
                    qd: w.state.qd.as_slice(),
                    effort: w.tau.as_slice(),
                    base: &s.pipeline.model().robot.base,
                    links,
                }
            })
            .collect();
        self.rec.robots(t_ns, &robots)?;
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
        self.rec.contacts(t_ns, &contacts)?;
        for s in sims.iter_mut() {
            let now = s.pipeline.data().contact == Some(true);
            if now != s.contact_was {
                let (level, what) = if now {
                    (Level::Warning, "contact")
                } else {
                    (Level::Info, "clear again")
                };
                self.rec.log(t_ns, level, &s.name, what)?;
                s.contact_was = now;
            }
        }
        self.dirty = true;
        Ok(())
    }

    /// An event of the run at `t_ns`; `name` says who (a robot, or `simulator`).
    pub(crate) fn event(&mut self, t_ns: u64, level: Level, name: &str, what: &str) -> Result<()> {
        self.rec.log(t_ns, level, name, what)?;
        self.dirty = true;
        Ok(())
    }

    /// Completes the chunk on disk when the daemon is `idle` or a second has passed.
    pub(crate) fn maybe_flush(&mut self, idle: bool) -> Result<()> {
        if self.dirty && (idle || self.last_flush.elapsed() >= FLUSH_EVERY) {
            self.rec.flush()?;
            self.dirty = false;
            self.last_flush = Instant::now();
        }
        Ok(())
    }

    /// Writes the summary and closes the file; messages per topic.
    pub(crate) fn finish(self) -> Result<BTreeMap<String, u64>> {
        Ok(self.rec.finish()?)
    }
}
