//! `robosim demo`: a headless session that does real work and reports what it did. Every
//! step below runs through the real processes and shared memory; nothing is simulated in
//! this function itself.

use crate::{Result, bridge, launcher};
use robosim_instance_space::state::StateSubscriber;
use robosim_instance_space::{Client, Reader, Session, Transaction, aspect};
use std::time::{Duration, Instant};

struct SessionGuard {
    name: String,
    remove_dir: bool,
}

impl Drop for SessionGuard {
    fn drop(&mut self) {
        let _ = launcher::down(Some(&self.name));
        if self.remove_dir {
            if let Ok(s) = Session::open(Some(&self.name)) {
                let _ = std::fs::remove_dir_all(s.dir());
            }
        }
    }
}

pub fn run(session: Option<&str>) -> Result<()> {
    let name = session
        .map(str::to_owned)
        .unwrap_or_else(|| format!("demo{}", std::process::id()));
    let _guard = SessionGuard {
        name: name.clone(),
        remove_dir: session.is_none(),
    };
    println!("== 1. start a session: keeper + simulator, each its own process");
    launcher::up("demo", &["simulator".to_owned()], Some(&name))?;
    let s = Session::open(Some(&name))?;

    println!("\n== 2. attach a reader: the model is mapped from shared memory, not copied");
    let mut reader = Reader::attach(&s, "demo-reader")?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| crate::CliError("no snapshot".into()))?;
    let polygons: usize = (0..snap.len())
        .filter_map(|i| snap.geometry(i))
        .map(|g| g.polygons.len())
        .sum();
    println!(
        "model version {}: {} objects, {} vertices, {} convex polygons",
        snap.version(),
        snap.len(),
        snap.vertex_count(),
        polygons
    );
    for i in 0..snap.len() {
        let o = snap.object(i);
        let w = snap.world_pose(i);
        println!(
            "  {:<6} {:<14} at ({:+.3}, {:+.3}, {:+.3})",
            o.kind().map_or("?", |k| k.name()),
            o.name,
            w[3],
            w[7],
            w[11]
        );
    }

    println!(
        "\n== 3. this process, as a writer, moves the arm (MOVEJI: 20 interpolated steps, each a transaction)"
    );
    let robots = bridge::robots(&snap);
    let arm = robots
        .first()
        .ok_or_else(|| crate::CliError("the demo scene has no robot".into()))?;
    let mut client = Client::connect(&s, "demo-writer")?;
    let q0 = arm.q.clone();
    let q1: Vec<f64> = q0
        .iter()
        .enumerate()
        .map(|(j, q)| q + if j == 0 { 0.9 } else { -1.2 })
        .collect();
    let steps = 20;
    let t0 = Instant::now();
    let mut last_version = 0;
    let mut seen = Vec::new();
    for k in 1..=steps {
        let f = k as f64 / steps as f64;
        let q: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| a + f * (b - a)).collect();
        let mut tx = Transaction::new();
        for ((id, qj), pose) in arm
            .links
            .iter()
            .zip(&q)
            .zip(bridge::link_poses(&arm.robot, &q))
        {
            tx.set_joint(*id, *qj).set_pose(*id, pose);
        }
        let c = client.transact(&tx)?;
        last_version = c.version;
        // The reader is told what changed: exactly the two links, pose aspect only.
        while seen.last().is_none_or(|v: &u64| *v < c.version) {
            for ch in reader.wait_change(Duration::from_secs(5))? {
                if ch.ids != arm.links || ch.aspects != aspect::POSE {
                    crate::bail!(
                        "change {} named {:?} / {:?}, expected the arm's links / pose",
                        ch.version,
                        ch.ids,
                        aspect::names(ch.aspects)
                    );
                }
                seen.push(ch.version);
            }
        }
    }
    let elapsed = t0.elapsed();
    println!(
        "{steps} journaled transactions in {:.1} ms ({:.0} µs each, fsync included); the reader saw versions {}..={} in order, each naming only the 2 links (pose)",
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_secs_f64() * 1e6 / steps as f64,
        seen[0],
        seen[seen.len() - 1]
    );
    let snap = reader
        .snapshot()
        .ok_or_else(|| crate::CliError("no snapshot".into()))?;
    let tip = snap
        .index_of(*arm.links.last().unwrap_or(&0))
        .map(|i| snap.world_pose(i));
    if let Some(w) = tip {
        println!(
            "arm tip now at ({:+.4}, {:+.4}, {:+.4}) m, q = [{:.3}, {:.3}] rad",
            w[3], w[7], w[11], q1[0], q1[1]
        );
    }

    println!(
        "\n== 4. the simulator daemon publishes high-rate state for the new structure version"
    );
    let mut state = StateSubscriber::open(&s, "simulator", "demo-state")?;
    let deadline = Instant::now() + Duration::from_secs(10);
    let rec = loop {
        let recs = state.wait(Duration::from_millis(200))?;
        if let Some(r) = recs
            .into_iter()
            .rev()
            .find(|r| r.header.structure_version >= last_version)
        {
            break r;
        }
        if Instant::now() > deadline {
            crate::bail!("the simulator published no state for version {last_version} within 10 s");
        }
    };
    println!(
        "state #{} at t = {:.2} s for version {}: q = {:?}",
        rec.header.seq,
        rec.header.t,
        rec.header.structure_version,
        rec.joints
            .iter()
            .map(|j| (j.q * 1e3).round() / 1e3)
            .collect::<Vec<_>>()
    );

    println!("\n== 5. bad input is refused whole, with the object and field named");
    let mut tx = Transaction::new();
    let mut pose = robosim_instance_space::IDENTITY;
    pose[3] = f64::NAN;
    tx.set_joint(arm.links[0], 0.0).set_pose(arm.links[0], pose);
    match client.transact(&tx) {
        Err(e) => println!("refused: {e}"),
        Ok(c) => crate::bail!("a NaN pose was accepted as version {}", c.version),
    }
    let v = reader.snapshot().map_or(0, |s| s.version());
    println!("model still at version {v}");

    println!("\n== 6. stop the session");
    Ok(())
}
