//! One simulation step on the PUMA 560 and the Panda (`Pipeline::step`), with the kinematics
//! effect (kinematic motion towards a target, then every link frame) and with collision added
//! (link solids of the declared radius against two boxes, self-collision on, the default exact
//! mode), beside a baseline that no robosim code runs (a 6×6 LU solve in nalgebra) so runs of
//! different builds on this shared machine compare as ratios to it (issue 37 item 1: the
//! link-frames and collision stages read a `KinematicModel` compiled with the pipeline, where
//! they compiled each joint on every step).
//!
//! `cargo bench -p robosim-simulator --bench step -- --quick`

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{DVector, Isometry3, Matrix6, Vector3, Vector6};
use robosim_collision::Solid;
use robosim_collision::robot::Scene;
use robosim_kinematics::builtin_robot;
use robosim_simulator::{CollisionEffect, Command, Pipeline, SceneEffects, SceneGeometry};
use std::hint::black_box;
use std::sync::Arc;

fn obstacles() -> Scene {
    let mut scene = Scene::default();
    for (name, x) in [("left", 1.5), ("right", -1.5)] {
        let solid = Solid::cuboid(Vector3::new(0.2, 0.2, 0.2)).expect("a box");
        scene.add(name, Arc::new(solid), Isometry3::translation(x, 0.0, 0.3));
    }
    scene
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("baseline");
    let a = Matrix6::from_fn(|i, j| {
        if i == j {
            4.0
        } else {
            1.0 / (1.0 + (i + j) as f64)
        }
    });
    let b = Vector6::from_fn(|i, _| i as f64 - 2.5);
    g.bench_function("lu6", |bn| {
        bn.iter(|| black_box(black_box(a).lu().solve(&b)))
    });
    g.finish();
    for name in ["puma560", "panda"] {
        let robot = builtin_robot(name).expect("builtin robot");
        // Start in the middle of every joint's range; the goals at 30 % and 70 % of it.
        let at = |f: f64| -> Vec<f64> {
            robot
                .joints
                .iter()
                .map(|j| {
                    let [lo, hi] = [j.qlim[0].max(-3.0), j.qlim[1].min(3.0)];
                    lo + f * (hi - lo)
                })
                .collect()
        };
        let q0 = at(0.5);
        let goals = [at(0.3), at(0.7)];
        let mut g = c.benchmark_group(format!("step/{name}"));
        let kinematics = SceneEffects {
            kinematics: true,
            max_speed: 1.0,
            ..SceneEffects::default()
        };
        let collision = SceneEffects {
            collision: Some(CollisionEffect {
                self_collision: true,
                ..CollisionEffect::default()
            }),
            ..kinematics.clone()
        };
        for (label, effects, geometry) in [
            ("kinematics", &kinematics, SceneGeometry::default()),
            (
                "kinematics+collision",
                &collision,
                SceneGeometry {
                    obstacles: obstacles(),
                    link_solids: None,
                },
            ),
        ] {
            let mut p = Pipeline::build(&robot, &q0, effects, geometry).expect("pipeline");
            let mut k = 0usize;
            g.bench_function(label, |bn| {
                bn.iter(|| {
                    // A new goal every 256 steps, so q keeps changing.
                    if k % 256 == 0 {
                        let goal = &goals[(k / 256) % 2];
                        p.set_command(Command::Target(DVector::from_column_slice(goal)))
                            .expect("goal within limits");
                    }
                    k += 1;
                    p.step().expect("step")
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
