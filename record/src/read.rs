//! Reading a recorded run back: the joint states, contact verdicts and events of an MCAP file
//! written by [`crate::Recorder`] (a simulator run or a playback), as time series — what
//! `robosim plot` draws.
//!
//! A file cut short (the recording process killed before [`crate::Recorder::finish`]) is read
//! up to the last complete record and the run says so ([`Run::truncated`]); a message that is
//! not what its channel's schema says is an error naming the topic and the message's place.
//! Channels this reader does not know (`/tf`: the link poses follow from the joint states)
//! are counted in [`Run::skipped`], not silently lost.
//!
//! Entry points: [`read_run`], [`Run`].

use crate::{Level, RecordError};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// One robot's joint states over time. Velocities and efforts are empty when the recording
/// did not have them (a playback).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RobotTrack {
    pub name: String,
    /// Joint (link) names, chain order.
    pub joints: Vec<String>,
    /// Simulation time of each sample, s.
    pub t: Vec<f64>,
    /// Per sample: joint positions, rad or m.
    pub position: Vec<Vec<f64>>,
    /// Per sample: joint velocities, rad/s or m/s (empty rows: not recorded).
    pub velocity: Vec<Vec<f64>>,
    /// Per sample: joint efforts, N·m or N (empty rows: not recorded).
    pub effort: Vec<Vec<f64>>,
}

/// One robot's collision verdicts over time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactTrack {
    pub robot: String,
    /// Simulation time of each verdict, s.
    pub t: Vec<f64>,
    /// The step's check found a contact.
    pub contact: Vec<bool>,
}

/// One event of the run's log.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// Simulation time, s.
    pub t: f64,
    pub level: Option<Level>,
    /// Who: a robot, `simulator`.
    pub name: String,
    pub message: String,
}

/// A recorded run as time series.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Run {
    /// Robots in the order their first sample appears.
    pub robots: Vec<RobotTrack>,
    pub contacts: Vec<ContactTrack>,
    pub events: Vec<Event>,
    /// Messages per topic this reader does not turn into series (e.g. `/tf`).
    pub skipped: BTreeMap<String, u64>,
    /// The file ends inside a record (the writer was stopped before it finished): everything
    /// before the cut was read.
    pub truncated: bool,
}

impl Run {
    /// The time span of every series in the run, s (`None`: nothing recorded).
    pub fn time_span(&self) -> Option<(f64, f64)> {
        let ts = self
            .robots
            .iter()
            .flat_map(|r| r.t.iter())
            .chain(self.contacts.iter().flat_map(|c| c.t.iter()))
            .chain(self.events.iter().map(|e| &e.t));
        ts.fold(None, |acc, &t| match acc {
            None => Some((t, t)),
            Some((lo, hi)) => Some((f64::min(lo, t), f64::max(hi, t))),
        })
    }
}

fn seconds(t_ns: u64) -> f64 {
    t_ns as f64 * 1e-9
}

/// Reads the run recorded in `path`; `progress(done, total)` is called every few thousand
/// messages (`total` from the file's summary, 0 when it has none: a cut file).
pub fn read_run(path: &Path, progress: &mut dyn FnMut(u64, u64)) -> Result<Run, RecordError> {
    let bytes = std::fs::read(path).map_err(|source| RecordError::Io {
        path: path.to_owned(),
        source,
    })?;
    read_bytes(path, &bytes, progress)
}

/// [`read_run`] of bytes already read (`path` names them in errors).
pub fn read_bytes(
    path: &Path,
    bytes: &[u8],
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Run, RecordError> {
    if !bytes.starts_with(crate::MCAP_MAGIC) {
        return Err(RecordError::Sample {
            path: path.to_owned(),
            what: "not an MCAP file (it does not begin with the MCAP magic)".into(),
        });
    }
    let total = mcap::Summary::read(bytes)
        .ok()
        .flatten()
        .and_then(|s| s.stats.map(|st| st.message_count))
        .unwrap_or(0);
    let stream = mcap::MessageStream::new(bytes).map_err(|e| RecordError::from_mcap(path, e))?;
    let mut run = Run::default();
    let mut robot_index: BTreeMap<String, usize> = BTreeMap::new();
    let mut contact_index: BTreeMap<String, usize> = BTreeMap::new();
    let mut done = 0u64;
    for message in stream {
        let m = match message {
            Ok(m) => m,
            Err(_) => {
                // A cut file: MessageStream stops at the first record it cannot read.
                run.truncated = true;
                break;
            }
        };
        done += 1;
        if done % 4096 == 0 {
            progress(done, total);
        }
        let topic = m.channel.topic.as_str();
        let bad = |what: String| RecordError::Sample {
            path: path.to_owned(),
            what: format!("{topic}, message {done}: {what}"),
        };
        let known = topic == "/contacts"
            || topic == "/simulator/log"
            || (topic.starts_with('/') && topic.ends_with("/joint_states"));
        if !known {
            *run.skipped.entry(topic.to_owned()).or_default() += 1;
            continue;
        }
        let v: Value =
            serde_json::from_slice(&m.data).map_err(|e| bad(format!("not JSON: {e}")))?;
        let t = seconds(m.log_time);
        if topic == "/contacts" {
            let list = v["robots"]
                .as_array()
                .ok_or_else(|| bad("no `robots` array".into()))?;
            for c in list {
                let robot = c["robot"]
                    .as_str()
                    .ok_or_else(|| bad("a verdict without `robot`".into()))?;
                let contact = c["contact"]
                    .as_bool()
                    .ok_or_else(|| bad(format!("robot {robot}: `contact` is not a boolean")))?;
                let k = *contact_index.entry(robot.to_owned()).or_insert_with(|| {
                    run.contacts.push(ContactTrack {
                        robot: robot.to_owned(),
                        ..ContactTrack::default()
                    });
                    run.contacts.len() - 1
                });
                run.contacts[k].t.push(t);
                run.contacts[k].contact.push(contact);
            }
        } else if topic == "/simulator/log" {
            let level = match v["level"].as_u64() {
                Some(2) => Some(Level::Info),
                Some(3) => Some(Level::Warning),
                Some(4) => Some(Level::Error),
                _ => None,
            };
            run.events.push(Event {
                t,
                level,
                name: v["name"].as_str().unwrap_or_default().to_owned(),
                message: v["message"].as_str().unwrap_or_default().to_owned(),
            });
        } else {
            let name = &topic[1..topic.len() - "/joint_states".len()];
            let names: Vec<String> = v["name"]
                .as_array()
                .ok_or_else(|| bad("no `name` array".into()))?
                .iter()
                .map(|n| n.as_str().map(str::to_owned))
                .collect::<Option<_>>()
                .ok_or_else(|| bad("a joint name is not a string".into()))?;
            let numbers = |field: &str| -> Result<Vec<f64>, RecordError> {
                match &v[field] {
                    Value::Null => Ok(Vec::new()),
                    Value::Array(a) => a
                        .iter()
                        .map(Value::as_f64)
                        .collect::<Option<Vec<f64>>>()
                        .ok_or_else(|| {
                            bad(format!("`{field}` holds a value that is not a number"))
                        }),
                    _ => Err(bad(format!("`{field}` is not an array"))),
                }
            };
            let (q, qd, effort) = (
                numbers("position")?,
                numbers("velocity")?,
                numbers("effort")?,
            );
            if q.len() != names.len()
                || !(qd.is_empty() || qd.len() == q.len())
                || !(effort.is_empty() || effort.len() == q.len())
            {
                return Err(bad(format!(
                    "{} names, {} positions, {} velocities, {} efforts",
                    names.len(),
                    q.len(),
                    qd.len(),
                    effort.len()
                )));
            }
            let k = *robot_index.entry(name.to_owned()).or_insert_with(|| {
                run.robots.push(RobotTrack {
                    name: name.to_owned(),
                    joints: names.clone(),
                    ..RobotTrack::default()
                });
                run.robots.len() - 1
            });
            let track = &mut run.robots[k];
            if track.joints != names {
                return Err(bad(format!(
                    "the joints changed from {:?} to {:?}",
                    track.joints, names
                )));
            }
            track.t.push(t);
            track.position.push(q);
            track.velocity.push(qd);
            track.effort.push(effort);
        }
    }
    progress(done, total.max(done));
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ContactSample, Recorder, RobotSample};
    use nalgebra::Matrix4;

    fn record(path: &Path, samples: usize) {
        let mut rec = Recorder::create(path, "test").expect("recorder");
        let names = vec!["j1".to_string(), "j2".to_string()];
        let links = [[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]; 2];
        let base = Matrix4::identity();
        for k in 0..samples {
            let x = k as f64 * 0.1;
            let q = [x, -x];
            let qd = [1.0, -1.0];
            let tau = [2.0 * x, 0.5];
            let t = crate::time_ns(k as u64, 0.01);
            rec.robots(
                t,
                &[RobotSample {
                    name: "arm",
                    joint_names: &names,
                    q: &q,
                    qd: &qd,
                    effort: &tau,
                    base: &base,
                    links: &links,
                }],
            )
            .expect("robots");
            rec.contacts(
                t,
                &[ContactSample {
                    robot: "arm",
                    contact: k >= 3,
                    contact_steps: k.saturating_sub(2) as u64,
                }],
            )
            .expect("contacts");
            if k == 3 {
                rec.log(t, Level::Warning, "arm", "contact begins")
                    .expect("log");
            }
        }
        rec.finish().expect("finish");
    }

    #[test]
    fn a_recording_reads_back_as_the_series_written() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("run.mcap");
        record(&path, 5);
        let mut calls = Vec::new();
        let run = read_run(&path, &mut |d, t| calls.push((d, t))).expect("read");
        assert!(!run.truncated);
        assert_eq!(run.robots.len(), 1);
        let arm = &run.robots[0];
        assert_eq!(arm.name, "arm");
        assert_eq!(arm.joints, ["j1", "j2"]);
        assert_eq!(arm.t.len(), 5);
        assert!((arm.t[4] - 0.04).abs() < 1e-15);
        assert_eq!(arm.position[2], vec![0.2, -0.2]);
        assert_eq!(arm.effort[4], vec![0.8, 0.5]);
        assert_eq!(run.contacts[0].contact, [false, false, false, true, true]);
        assert_eq!(run.events.len(), 1);
        assert_eq!(run.events[0].message, "contact begins");
        assert_eq!(run.events[0].level, Some(Level::Warning));
        assert!((run.events[0].t - 0.03).abs() < 1e-15);
        assert_eq!(run.skipped.get("/tf"), Some(&5));
        // The last call reports every message: 5 joint states, 5 /tf, 5 contacts, 1 log.
        assert_eq!(calls.last(), Some(&(16, 16)));
        assert_eq!(run.time_span(), Some((0.0, 0.04)));
    }

    #[test]
    fn a_cut_file_reads_up_to_the_cut_and_says_so() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("run.mcap");
        record(&path, 2000);
        let bytes = std::fs::read(&path).expect("bytes");
        let cut = &bytes[..bytes.len() / 2];
        let run = read_bytes(&path, cut, &mut |_, _| {}).expect("read");
        assert!(run.truncated);
        let n = run.robots[0].t.len();
        assert!(n > 0 && n < 2000, "{n} samples before the cut");
        // Every sample read is whole.
        assert!(run.robots[0].position.iter().all(|q| q.len() == 2));
    }

    #[test]
    fn a_file_that_is_not_mcap_is_refused_by_path() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("run.mcap");
        std::fs::write(&path, "t_s,q1_rad\n0,1\n").expect("write");
        let e = read_run(&path, &mut |_, _| {}).expect_err("refused");
        assert!(e.to_string().contains("run.mcap"), "{e}");
    }
}
