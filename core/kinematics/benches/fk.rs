//! All-frames FK and tool pose + base-frame Jacobian on the PUMA 560 (standard DH) and three
//! URDF arms (UR10, xArm7, Panda: general joints, Pinocchio's placements; fixtures from
//! `tools/peers/kinematics.py`), q cycled through 16 vectors: the compiled model
//! (`KinematicModel`), the `&Robot` functions (compiling joint by joint) and the previous 4×4
//! path (`legacy`), in the same run.
//!
//! `cargo bench -p robosim-kinematics --bench fk`

#[path = "common/mod.rs"]
mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Matrix4;
use robosim_kinematics::jacobian::{Jacobian, fk_and_jacobian_into};
use robosim_kinematics::{KinematicModel, fk};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    for fx in common::fixtures() {
        let robot = &fx.robot;
        let model = KinematicModel::new(robot);
        let n = robot.dof();
        let mut frames = vec![Matrix4::identity(); n + 2];
        let mut jac = Jacobian::zeros(n);
        let mut g = c.benchmark_group(format!("fk_all/{}", fx.name));
        let mut k = 0;
        let mut next = || {
            k = (k + 1) % fx.qs.len();
            black_box(fx.qs[k].as_slice())
        };
        g.bench_function("legacy", |b| {
            b.iter(|| common::legacy_frames(robot, next(), &mut frames))
        });
        g.bench_function("robot", |b| {
            b.iter(|| fk::link_frames_into(robot, next(), &mut frames))
        });
        g.bench_function("model", |b| {
            b.iter(|| model.link_frames_into(next(), &mut frames))
        });
        g.finish();
        let mut g = c.benchmark_group(format!("jacobian/{}", fx.name));
        g.bench_function("legacy", |b| {
            b.iter(|| common::legacy_fk_and_jacobian(robot, next(), &mut jac))
        });
        g.bench_function("robot", |b| {
            b.iter(|| fk_and_jacobian_into(robot, next(), &mut jac))
        });
        g.bench_function("model", |b| {
            b.iter(|| model.fk_and_jacobian_into(next(), &mut jac))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
