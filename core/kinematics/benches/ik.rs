//! IK solve time on the PUMA 560 (standard DH) and the Panda (URDF, general joints) at the
//! 16 peer-fixture poses (`testdata/kinematics/peers/`), per method, beside a baseline that no
//! robosim code runs (a 6×6 LU solve in nalgebra) so runs of different builds on this shared
//! machine can be compared as ratios to it (issue 37 item 1: the solvers on a `KinematicModel`
//! compiled once per solve, where they compiled each joint on every FK and Jacobian).
//!
//! `cargo bench -p robosim-kinematics --bench ik -- --quick`

#[path = "common/mod.rs"]
mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix4, Matrix6, Vector6};
use robosim_kinematics::fk;
use robosim_kinematics::ik::{self, IkOptions, Method};
use std::hint::black_box;

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
    for fx in common::fixtures()
        .into_iter()
        .filter(|f| f.name == "puma560" || f.name == "panda")
    {
        let robot = &fx.robot;
        let targets: Vec<Matrix4<f64>> = fx.qs.iter().map(|q| fk::forward(robot, q)).collect();
        // Newton starts 0.1 rad from the answer (it has no restarts); DLS from its seeded
        // random starts (the protocol's default: no q0).
        let near: Vec<Vec<f64>> = fx
            .qs
            .iter()
            .map(|q| q.iter().map(|x| x + 0.1).collect())
            .collect();
        let mut methods = vec![Method::Dls, Method::Newton];
        if fx.name == "puma560" {
            methods.push(Method::Analytic);
        }
        let mut g = c.benchmark_group(format!("ik/{}", fx.name));
        for method in methods {
            let mut k = 0;
            g.bench_function(method.name(), |bn| {
                bn.iter(|| {
                    k = (k + 1) % targets.len();
                    let options = IkOptions {
                        q0: (method == Method::Newton).then(|| near[k].clone()),
                        ..IkOptions::default()
                    };
                    black_box(ik::solve(robot, &targets[k], method, &options)).is_ok()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
