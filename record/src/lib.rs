//! Runs recorded to **MCAP** (<https://mcap.dev>), the log format Foxglove and other robotics
//! tools open: a simulator run (`robosim simulator --record FILE`) or a trajectory playback
//! ([`playback::record_playback`]).
//!
//! Channels (schema encoding `jsonschema`, message encoding `json`; schemas in [`schema`]):
//!
//! | topic | schema | one message |
//! |---|---|---|
//! | `/<robot>/joint_states` | `sensor_msgs/msg/JointState` | per robot per sample: names, position (rad or m), velocity (rad/s or m/s), effort (N·m or N) |
//! | `/tf` | `foxglove.FrameTransforms` | per sample: `world → <robot>` (its base) and `<robot> → <robot>/<link>` for every link |
//! | `/contacts` | `robosim.Contacts` | per sample, when some robot's pipeline checks collisions |
//! | `/simulator/log` | `foxglove.Log` | per event (command, refusal, reset, contact begins/ends, step failure) |
//!
//! **Time.** Every message's `log_time` and `publish_time` (and the stamp inside it) is the
//! *simulation* time in ns that the writer passes in, never the wall clock; a writer passes a
//! non-decreasing clock (the daemon: steps × dt since it started).
//!
//! **Closing.** [`Recorder::finish`] (also run when a `Recorder` is dropped) writes the summary
//! section (schemas, channels, statistics, chunk indexes) and the footer. A process killed
//! before that leaves a file without summary: readers that stream it (e.g.
//! `mcap::MessageStream`) still read every message of the chunks completed before the kill,
//! and [`Recorder::flush`] completes a chunk on demand (the daemon calls it whenever it is idle
//! and at least once a second of wall time).
//!
//! Entry points: [`Recorder`], [`RobotSample`], [`Level`], [`playback::record_playback`], and
//! for reading a run back as time series, [`read::read_run`].

#![forbid(unsafe_code)]

pub mod playback;
pub mod read;
pub mod schema;

use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion};
use serde_json::{Value, json};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Why a recording failed: the file and what went wrong.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("recording {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("recording {path}: MCAP: {source}")]
    Mcap {
        path: PathBuf,
        source: mcap::McapError,
    },
    #[error("recording {path}: {what}")]
    Sample { path: PathBuf, what: String },
}

impl RecordError {
    /// `source` on `path`: an I/O error as [`RecordError::Io`], so its message is the
    /// system's (`No space left on device`), not the MCAP crate's summary of it.
    fn from_mcap(path: &Path, source: mcap::McapError) -> RecordError {
        match source {
            mcap::McapError::Io(source) => RecordError::Io {
                path: path.to_owned(),
                source,
            },
            source => RecordError::Mcap {
                path: path.to_owned(),
                source,
            },
        }
    }
}

type Result<T> = std::result::Result<T, RecordError>;

/// The first bytes of every MCAP file (how `robosim plot` tells a recording from a CSV log).
pub const MCAP_MAGIC: &[u8] = mcap::MAGIC;

/// One robot at one instant.
#[derive(Debug, Clone, Copy)]
pub struct RobotSample<'a> {
    /// Instance name; frames are `<name>` and `<name>/<link>`.
    pub name: &'a str,
    /// Link (joint) names, chain order.
    pub joint_names: &'a [String],
    /// Joint positions, rad (revolute) or m (prismatic).
    pub q: &'a [f64],
    /// Joint velocities, rad/s or m/s; empty when not known.
    pub qd: &'a [f64],
    /// Joint efforts, N·m or N; empty when not known.
    pub effort: &'a [f64],
    /// The robot's world pose (its base frame), homogeneous, m.
    pub base: &'a Matrix4<f64>,
    /// Every link's frame relative to the robot's frame, row-major `[R | t]` (3×4, m), chain
    /// order (what `robosim_scene::link_poses` returns).
    pub links: &'a [[f64; 12]],
}

/// One robot's collision verdict at one instant.
#[derive(Debug, Clone, Copy)]
pub struct ContactSample<'a> {
    pub robot: &'a str,
    /// The last check found a contact (or could not certify clearance).
    pub contact: bool,
    /// Steps with a contact since the robot's pipeline was built.
    pub contact_steps: u64,
}

/// Severity of a log message (`foxglove.Log` levels).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    Info = 2,
    Warning = 3,
    Error = 4,
}

struct Schemas {
    joint_state: u16,
    frames: u16,
    contacts: u16,
    log: u16,
}

/// An open MCAP recording (see the module docs for its channels and clock).
pub struct Recorder {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    schemas: Schemas,
    /// topic → (channel id, next sequence number)
    channels: HashMap<String, (u16, u32)>,
    counts: BTreeMap<String, u64>,
}

/// A 3×4 row-major `[R | t]` as a Foxglove translation and rotation.
fn transform(rows: &[f64; 12]) -> (Value, Value) {
    let r = Matrix3::new(
        rows[0], rows[1], rows[2], rows[4], rows[5], rows[6], rows[8], rows[9], rows[10],
    );
    // Shepperd's closed form (`Rotation3::from_matrix` iterates from the identity and returns
    // it for a half-turn), renormalised: the stored rotation is orthonormal to rounding.
    let q = UnitQuaternion::from_quaternion(
        *UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)).quaternion(),
    );
    (
        json!({"x": rows[3], "y": rows[7], "z": rows[11]}),
        json!({"x": q.i, "y": q.j, "z": q.k, "w": q.w}),
    )
}

fn rows(m: &Matrix4<f64>) -> [f64; 12] {
    let mut r = [0.0; 12];
    for i in 0..3 {
        for j in 0..4 {
            r[i * 4 + j] = m[(i, j)];
        }
    }
    r
}

impl Recorder {
    /// Creates `path` (private to the user, 0600; an existing file is replaced) and writes the
    /// header, the schemas and a `robosim` metadata record naming `source` (what is recorded).
    pub fn create(path: &Path, source: &str) -> Result<Recorder> {
        use std::os::unix::fs::OpenOptionsExt;
        let io = |source| RecordError::Io {
            path: path.to_owned(),
            source,
        };
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .mode(0o600)
            .open(path)
            .map_err(io)?;
        let mcap_err = |source| RecordError::from_mcap(path, source);
        let mut writer = mcap::WriteOptions::new()
            .profile("")
            .library(concat!("robosim-record ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .map_err(mcap_err)?;
        let mut add = |name: &str, schema: Value| {
            writer.add_schema(name, schema::SCHEMA_ENCODING, schema.to_string().as_bytes())
        };
        let schemas = Schemas {
            joint_state: add(schema::JOINT_STATE, schema::joint_state()).map_err(mcap_err)?,
            frames: add(schema::FRAME_TRANSFORMS, schema::frame_transforms()).map_err(mcap_err)?,
            contacts: add(schema::CONTACTS, schema::contacts()).map_err(mcap_err)?,
            log: add(schema::LOG, schema::log()).map_err(mcap_err)?,
        };
        writer
            .write_metadata(&mcap::records::Metadata {
                name: "robosim".into(),
                metadata: BTreeMap::from([
                    ("source".to_owned(), source.to_owned()),
                    (
                        "clock".to_owned(),
                        "log_time = publish_time = simulation time, ns".to_owned(),
                    ),
                ]),
            })
            .map_err(mcap_err)?;
        Ok(Recorder {
            path: path.to_owned(),
            writer,
            schemas,
            channels: HashMap::new(),
            counts: BTreeMap::new(),
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Messages written so far, per topic.
    pub fn counts(&self) -> &BTreeMap<String, u64> {
        &self.counts
    }

    fn mcap_err(&self) -> impl FnOnce(mcap::McapError) -> RecordError + use<> {
        let path = self.path.clone();
        move |source| RecordError::from_mcap(&path, source)
    }

    fn write(&mut self, topic: &str, schema: u16, t_ns: u64, message: &Value) -> Result<()> {
        let (channel_id, sequence) = match self.channels.get(topic) {
            Some(c) => *c,
            None => {
                let id = self
                    .writer
                    .add_channel(schema, topic, schema::MESSAGE_ENCODING, &BTreeMap::new())
                    .map_err(self.mcap_err())?;
                (id, 0)
            }
        };
        self.channels
            .insert(topic.to_owned(), (channel_id, sequence.wrapping_add(1)));
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence,
            log_time: t_ns,
            publish_time: t_ns,
        };
        let e = self.mcap_err();
        self.writer
            .write_to_known_channel(&header, message.to_string().as_bytes())
            .map_err(e)?;
        *self.counts.entry(topic.to_owned()).or_default() += 1;
        Ok(())
    }

    fn bad(&self, what: String) -> RecordError {
        RecordError::Sample {
            path: self.path.clone(),
            what,
        }
    }

    /// Records the robots at simulation time `t_ns`: one joint-state message per robot on
    /// `/<robot>/joint_states` and one `/tf` message with all their frames. Refused (nothing
    /// written) when a sample's arrays disagree in length.
    pub fn robots(&mut self, t_ns: u64, robots: &[RobotSample<'_>]) -> Result<()> {
        for r in robots {
            let n = r.q.len();
            let ok = |len: usize, optional: bool| len == n || (optional && len == 0);
            if !(ok(r.joint_names.len(), false)
                && ok(r.links.len(), false)
                && ok(r.qd.len(), true)
                && ok(r.effort.len(), true))
            {
                return Err(self.bad(format!(
                    "robot {}: {} joint values, {} names, {} link poses, {} velocities, {} efforts (velocities and efforts may be empty)",
                    r.name,
                    n,
                    r.joint_names.len(),
                    r.links.len(),
                    r.qd.len(),
                    r.effort.len()
                )));
            }
            if let Some(j) =
                r.q.iter()
                    .chain(r.qd)
                    .chain(r.effort)
                    .position(|v| !v.is_finite())
            {
                return Err(self.bad(format!("robot {}: value {j} is not finite", r.name)));
            }
        }
        let stamp = schema::stamp(t_ns);
        let mut transforms = Vec::new();
        for r in robots {
            let msg = json!({
                "header": {"stamp": stamp, "frame_id": r.name},
                "name": r.joint_names,
                "position": r.q,
                "velocity": r.qd,
                "effort": r.effort,
            });
            self.write(
                &format!("/{}/joint_states", r.name),
                self.schemas.joint_state,
                t_ns,
                &msg,
            )?;
            let mut frame = |parent: &str, child: String, pose: &[f64; 12]| {
                let (translation, rotation) = transform(pose);
                transforms.push(json!({
                    "timestamp": stamp, "parent_frame_id": parent, "child_frame_id": child,
                    "translation": translation, "rotation": rotation,
                }));
            };
            frame("world", r.name.to_owned(), &rows(r.base));
            for (link, pose) in r.joint_names.iter().zip(r.links) {
                frame(r.name, format!("{}/{link}", r.name), pose);
            }
        }
        self.write(
            "/tf",
            self.schemas.frames,
            t_ns,
            &json!({"transforms": transforms}),
        )
    }

    /// Records the collision verdicts at `t_ns` on `/contacts` (nothing when `robots` is
    /// empty: no pipeline checks collisions).
    pub fn contacts(&mut self, t_ns: u64, robots: &[ContactSample<'_>]) -> Result<()> {
        if robots.is_empty() {
            return Ok(());
        }
        let list: Vec<Value> = robots
            .iter()
            .map(|c| json!({"robot": c.robot, "contact": c.contact, "contact_steps": c.contact_steps}))
            .collect();
        self.write(
            "/contacts",
            self.schemas.contacts,
            t_ns,
            &json!({"timestamp": schema::stamp(t_ns), "robots": list}),
        )
    }

    /// Records an event at `t_ns` on `/simulator/log`; `name` says who (a robot, `simulator`).
    pub fn log(&mut self, t_ns: u64, level: Level, name: &str, message: &str) -> Result<()> {
        self.write(
            "/simulator/log",
            self.schemas.log,
            t_ns,
            &json!({
                "timestamp": schema::stamp(t_ns), "level": level as u8,
                "message": message, "name": name, "file": "", "line": 0,
            }),
        )
    }

    /// Completes the open chunk and flushes the file, so that a reader streaming it — even
    /// after this process is killed — sees every message written so far.
    pub fn flush(&mut self) -> Result<()> {
        let e = self.mcap_err();
        self.writer.flush().map_err(e)
    }

    /// Writes the summary section and the footer and closes the file; returns the messages
    /// written per topic.
    pub fn finish(mut self) -> Result<BTreeMap<String, u64>> {
        let e = self.mcap_err();
        self.writer.finish().map_err(e)?;
        Ok(std::mem::take(&mut self.counts))
    }
}

/// Simulation time `k · dt` in ns, rounded (exact for any dt that is a whole number of ns).
pub fn time_ns(k: u64, dt_s: f64) -> u64 {
    (k as f64 * dt_s * 1e9).round() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_rows_become_a_unit_quaternion_and_translation() {
        // 90° about z: x → y.
        let rows = [0.0, -1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 3.0];
        let (t, q) = transform(&rows);
        assert_eq!(t, json!({"x": 1.0, "y": 2.0, "z": 3.0}));
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (k, want) in [("x", 0.0), ("y", 0.0), ("z", h), ("w", h)] {
            let got = q[k].as_f64().expect("number");
            assert!((got - want).abs() < 1e-12, "{k}: {got} vs {want}");
        }
    }

    #[test]
    fn a_half_turn_is_a_half_turn() {
        // 180° about x (nalgebra's iterative Rotation3::from_matrix gave the identity).
        let rows = [1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0];
        let (_, q) = transform(&rows);
        let x = q["x"].as_f64().expect("number").abs();
        assert!((x - 1.0).abs() < 1e-15, "{q}");
    }

    #[test]
    fn mismatched_sample_lengths_are_refused_by_name_and_write_nothing() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("bad.mcap");
        let mut r = Recorder::create(&path, "test").expect("create");
        let names = vec!["a".to_owned(), "b".to_owned()];
        let base = Matrix4::identity();
        let e = r
            .robots(
                0,
                &[RobotSample {
                    name: "arm",
                    joint_names: &names,
                    q: &[0.0],
                    qd: &[],
                    effort: &[],
                    base: &base,
                    links: &[[0.0; 12]],
                }],
            )
            .expect_err("refused");
        assert!(
            e.to_string().contains("robot arm: 1 joint values, 2 names"),
            "{e}"
        );
        assert!(r.counts().is_empty());
        assert!(r.finish().expect("finish").is_empty());
    }
}
