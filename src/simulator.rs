//! `robosim simulator`: the simulator daemon. For now its pipeline is kinematics only: it
//! follows the robots of the Instance Space and publishes their high-rate state (joint
//! values, joint velocities by finite difference, link poses from forward kinematics, time)
//! on the session's `state/simulator` service, each record naming the structure version it
//! applies to. Dynamics and collision join the pipeline when the scene declares them (see the
//! simulator crate).

use crate::{Result, bridge};
use robosim_instance_space::layout::PoseRec;
use robosim_instance_space::state::{JointStateRec, StatePublisher};
use robosim_instance_space::{Reader, Session};
use std::time::{Duration, Instant};

pub fn run(session: Option<&str>, rate_hz: f64) -> Result<()> {
    if !(rate_hz.is_finite() && rate_hz > 0.0 && rate_hz <= 10_000.0) {
        crate::bail!("--rate {rate_hz} Hz is outside (0, 10000]");
    }
    let session = Session::open(session)?;
    let signals = session.node("simulator-signals", true)?;
    let mut reader = Reader::attach(&session, "simulator")?;
    let mut state = StatePublisher::create(&session, "simulator")?;
    let _reg = session.register(
        "simulator",
        &[
            "space/objects",
            "space/poses",
            "space/changes",
            "state/simulator (owner)",
        ],
    )?;
    let dt = 1.0 / rate_hz;
    let mut t = 0.0;
    let mut last_q: std::collections::HashMap<u64, f64> = Default::default();
    let start = Instant::now();
    let mut tick: u64 = 0;
    while signals.wait(Duration::ZERO).is_ok() {
        reader.refresh()?;
        let Some(snap) = reader.snapshot() else {
            continue;
        };
        let mut joints = Vec::new();
        let mut bodies = Vec::new();
        for r in bridge::robots(&snap) {
            let poses = bridge::link_poses(&r.robot, &r.q);
            for ((id, q), pose) in r.links.iter().zip(&r.q).zip(poses) {
                let qd = last_q.get(id).map_or(0.0, |prev| (q - prev) / dt);
                last_q.insert(*id, *q);
                joints.push(JointStateRec {
                    id: *id,
                    q: *q,
                    qd,
                    effort: 0.0,
                });
                bodies.push(PoseRec {
                    id: *id,
                    pose,
                    joint: *q,
                });
            }
        }
        state.publish(snap.version(), t, &joints, &bodies)?;
        tick += 1;
        t = tick as f64 * dt;
        // Real-time pacing against the start instant (no drift accumulation).
        let next = start + Duration::from_secs_f64(t);
        let now = Instant::now();
        if next > now {
            let _ = reader.wait_change(next - now);
        }
    }
    eprintln!("simulator: stopped at t = {t:.3} s after {tick} steps");
    Ok(())
}
