//! A trajectory playback (the display's `--play ROBOT=FILE`, MD's file mode) recorded to MCAP:
//! the same channels as a simulator run, with joint positions only (velocities and efforts
//! are not known to a playback and are left empty, as ROS does), sample `k` at `k · dt`.
//!
//! Entry points: [`Track`], [`record_playback`], [`link_frames`].

use crate::{RecordError, Recorder, RobotSample, time_ns};
use robosim_kinematics::Robot;
use std::collections::BTreeMap;
use std::path::Path;

/// One robot's trajectory.
#[derive(Debug, Clone, Copy)]
pub struct Track<'a> {
    /// Instance name.
    pub name: &'a str,
    /// The robot; `base` is its world pose.
    pub robot: &'a Robot,
    /// Link (joint) names, chain order.
    pub joint_names: &'a [String],
    /// Samples in SI units (rad or m), one value per joint; a track that ends before the
    /// others holds its last sample.
    pub samples: &'a [Vec<f64>],
}

/// Every link's frame relative to the robot's frame (base and tool left out), row-major
/// `[R | t]`, m — the link poses the Instance Space stores for a robot at `q`.
pub fn link_frames(robot: &Robot, q: &[f64]) -> Vec<[f64; 12]> {
    let local = Robot {
        base: nalgebra::Matrix4::identity(),
        tool: nalgebra::Matrix4::identity(),
        ..robot.clone()
    };
    robosim_kinematics::fk::link_frames(&local, q)[1..=robot.dof()]
        .iter()
        .map(crate::rows)
        .collect()
}

/// Records `tracks` to `path`: sample `k` (every `every`-th, from 0) at `k · dt_s` seconds.
/// Refused before anything is written when `dt_s` is not a positive number of seconds, `every`
/// is 0, a track is empty, or a sample's length is not the robot's joint count (named by
/// track and sample, 1-based). Returns the messages written per topic.
pub fn record_playback(
    path: &Path,
    tracks: &[Track<'_>],
    dt_s: f64,
    every: usize,
) -> Result<BTreeMap<String, u64>, RecordError> {
    let bad = |what: String| RecordError::Sample {
        path: path.to_owned(),
        what,
    };
    if !(dt_s.is_finite() && dt_s > 0.0 && time_ns(1, dt_s) > 0) {
        return Err(bad(format!(
            "dt {dt_s} s: must be a positive number of seconds (at least 1 ns)"
        )));
    }
    if every == 0 {
        return Err(bad("every must be at least 1".into()));
    }
    for t in tracks {
        if t.samples.is_empty() {
            return Err(bad(format!("track {}: no samples", t.name)));
        }
        if t.joint_names.len() != t.robot.dof() {
            return Err(bad(format!(
                "track {}: {} joint names for {} joints",
                t.name,
                t.joint_names.len(),
                t.robot.dof()
            )));
        }
        if let Some(k) = t.samples.iter().position(|s| s.len() != t.robot.dof()) {
            return Err(bad(format!(
                "track {}: sample {} has {} values, the robot has {} joints",
                t.name,
                k + 1,
                t.samples[k].len(),
                t.robot.dof()
            )));
        }
    }
    let len = tracks.iter().map(|t| t.samples.len()).max().unwrap_or(0);
    let names: Vec<&str> = tracks.iter().map(|t| t.name).collect();
    let mut rec = Recorder::create(path, &format!("playback of {}", names.join(", ")))?;
    for k in (0..len).step_by(every) {
        let qs: Vec<&Vec<f64>> = tracks
            .iter()
            .map(|t| &t.samples[k.min(t.samples.len() - 1)])
            .collect();
        let links: Vec<Vec<[f64; 12]>> = tracks
            .iter()
            .zip(&qs)
            .map(|(t, q)| link_frames(t.robot, q))
            .collect();
        let samples: Vec<RobotSample<'_>> = tracks
            .iter()
            .zip(&qs)
            .zip(&links)
            .map(|((t, q), l)| RobotSample {
                name: t.name,
                joint_names: t.joint_names,
                q,
                qd: &[],
                effort: &[],
                base: &t.robot.base,
                links: l,
            })
            .collect();
        rec.robots(time_ns(k as u64, dt_s), &samples)?;
    }
    rec.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stanford() -> Robot {
        robosim_kinematics::builtin_robot("stanford").expect("builtin")
    }

    #[test]
    fn a_playback_reads_back_with_one_message_per_sample_at_k_dt() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("play.mcap");
        let robot = stanford();
        let names: Vec<String> = (1..=robot.dof()).map(|j| format!("link{j}")).collect();
        let samples: Vec<Vec<f64>> = (0..5)
            .map(|k| {
                let mut q = vec![0.1 * k as f64; robot.dof()];
                q[2] = 0.5; // the prismatic joint, m, inside its limits
                q
            })
            .collect();
        let track = Track {
            name: "arm",
            robot: &robot,
            joint_names: &names,
            samples: &samples,
        };
        let counts = record_playback(&path, &[track], 0.02, 2).expect("recorded");
        assert_eq!(counts["/arm/joint_states"], 3, "samples 0, 2, 4");
        let bytes = std::fs::read(&path).expect("read");
        let summary = mcap::Summary::read(&bytes)
            .expect("summary")
            .expect("summary present");
        assert_eq!(summary.stats.as_ref().map(|s| s.message_count), Some(6));
        let times: Vec<u64> = mcap::MessageStream::new(&bytes)
            .expect("stream")
            .map(|m| m.expect("message"))
            .filter(|m| m.channel.topic == "/arm/joint_states")
            .map(|m| m.log_time)
            .collect();
        assert_eq!(times, vec![0, 40_000_000, 80_000_000]);
        let q_link3: Vec<f64> = mcap::MessageStream::new(&bytes)
            .expect("stream")
            .map(|m| m.expect("message"))
            .filter(|m| m.channel.topic == "/tf")
            .map(|m| {
                let v: serde_json::Value = serde_json::from_slice(&m.data).expect("json");
                let t = &v["transforms"][3]; // world→arm, then arm/link1..
                assert_eq!(t["child_frame_id"], "arm/link3");
                t["translation"]["z"].as_f64().expect("z")
            })
            .collect();
        let fk = link_frames(&robot, &samples[4])[2][11];
        assert!((q_link3[2] - fk).abs() < 1e-12);
    }

    #[test]
    fn a_bad_track_is_refused_by_name_before_the_file_is_created() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("play.mcap");
        let robot = stanford();
        let names: Vec<String> = (1..=robot.dof()).map(|j| format!("link{j}")).collect();
        let samples = vec![vec![0.0; robot.dof()], vec![0.0; 2]];
        let track = Track {
            name: "arm",
            robot: &robot,
            joint_names: &names,
            samples: &samples,
        };
        let e = record_playback(&path, &[track], 0.02, 1).expect_err("refused");
        assert!(
            e.to_string().contains("track arm: sample 2 has 2 values"),
            "{e}"
        );
        assert!(!path.exists());
        let e = record_playback(&path, &[], 0.0, 1).expect_err("dt");
        assert!(e.to_string().contains("dt 0 s"), "{e}");
    }
}
