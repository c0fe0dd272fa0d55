//! Timing program for `tools/peers/kinematics.py time` (one process per interleaved round):
//! for each peer fixture given, ns per call of all-frames FK and tool pose + base-frame Jacobian,
//! through the compiled model (`fk_all`, `jacobian`), through `&Robot` (`*_robot`, compiling
//! joint by joint) and through the previous 4×4 path (`*_legacy`), q cycled through the
//! fixture's 16 vectors. One JSON line per (robot, op).
//!
//! `cargo build --release -p robosim-kinematics --example peer_timing`, then
//! `target/release/examples/peer_timing [--calls N] testdata/kinematics/peers/*.json`

#[path = "../benches/common/mod.rs"]
mod common;

use nalgebra::Matrix4;
use robosim_kinematics::jacobian::{Jacobian, fk_and_jacobian_into};
use robosim_kinematics::{KinematicModel, fk};
use std::hint::black_box;
use std::time::Instant;

fn time(calls: usize, qs: &[Vec<f64>], mut f: impl FnMut(&[f64])) -> f64 {
    // Warm-up, then the timed loop.
    for q in qs.iter().cycle().take(calls / 10) {
        f(black_box(q));
    }
    let start = Instant::now();
    for q in qs.iter().cycle().take(calls) {
        f(black_box(q));
    }
    start.elapsed().as_secs_f64() * 1e9 / calls as f64
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut calls = 1_000_000;
    if let Some(i) = args.iter().position(|a| a == "--calls") {
        calls = args
            .get(i + 1)
            .and_then(|s| s.parse().ok())
            .unwrap_or(calls);
        args.drain(i..(i + 2).min(args.len()));
    }
    for path in &args {
        let fx = common::load(path);
        let robot = &fx.robot;
        let model = KinematicModel::new(robot);
        let n = robot.dof();
        let mut frames = vec![Matrix4::identity(); n + 2];
        let mut jac = Jacobian::zeros(n);
        let ops: [(&str, f64); 6] = [
            (
                "fk_all",
                time(calls, &fx.qs, |q| {
                    model.link_frames_into(q, &mut frames);
                    black_box(&frames);
                }),
            ),
            (
                "fk_all_robot",
                time(calls, &fx.qs, |q| {
                    fk::link_frames_into(robot, q, &mut frames);
                    black_box(&frames);
                }),
            ),
            (
                "fk_all_legacy",
                time(calls, &fx.qs, |q| {
                    common::legacy_frames(robot, q, &mut frames);
                    black_box(&frames);
                }),
            ),
            (
                "jacobian",
                time(calls, &fx.qs, |q| {
                    black_box(model.fk_and_jacobian_into(q, &mut jac));
                    black_box(&jac);
                }),
            ),
            (
                "jacobian_robot",
                time(calls, &fx.qs, |q| {
                    black_box(fk_and_jacobian_into(robot, q, &mut jac));
                    black_box(&jac);
                }),
            ),
            (
                "jacobian_legacy",
                time(calls, &fx.qs, |q| {
                    black_box(common::legacy_fk_and_jacobian(robot, q, &mut jac));
                    black_box(&jac);
                }),
            ),
        ];
        for (op, ns) in ops {
            println!(
                "{{\"robot\": \"{}\", \"op\": \"{op}\", \"ns_per_call\": {ns:.3}}}",
                fx.name
            );
        }
    }
}
