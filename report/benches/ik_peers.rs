//! Peer comparison for the closed-form IK (issue 4): our spherical-wrist solver against
//! `rs-opw-kinematics` (Brandstötter et al.'s OPW closed form, a Rust crate) on the same poses
//! in the same run. Writes `docs/reports/ik_peers.{csv,md,png}` (or the directory given as the
//! first non-flag argument).
//!
//! `cargo bench -p robosim-kinematics --bench ik_peers`
//!
//! Each OPW robot is also built as a standard-DH [`Robot`] (the mapping is derived in
//! `opw_as_dh`); the bench first checks that both forward kinematics agree to 1e-12 on random
//! joint vectors and refuses to report otherwise, so "the same poses" is checked, not assumed.

use nalgebra::{Matrix3, Matrix4};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_kinematics::ik::analytic::SphericalSolver;
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::pose::Residual;
use robosim_kinematics::{Joint, Robot, fk};
use robosim_report::{Plot, Report, Series, Table, percentile, write_report};
use rs_opw_kinematics::glam::{DMat3, DQuat, DVec3};
use rs_opw_kinematics::kinematic_traits::Kinematics;
use rs_opw_kinematics::kinematics_impl::OPWKinematics;
use rs_opw_kinematics::parameters::opw_kinematics::Parameters;
use rs_opw_kinematics::pose::Pose;
use std::f64::consts::{FRAC_PI_2, PI};
use std::hint::black_box;
use std::time::Instant;

/// OPW geometry (offsets 0, signs +1 on the OPW side) as standard DH, joint values identical:
/// 1: a1, −π/2, d = c1 · 2: a = c2, d = b, offset −π/2 · 3: a = −a2, −π/2, offset −π/2 ·
/// 4: d = c3, +π/2 · 5: −π/2 · 6: d = c4, offset π. OPW's own joint offsets o_j enter as −o_j.
fn opw_as_dh(p: &Parameters) -> Robot {
    let rows = [
        (p.a1, -FRAC_PI_2, p.c1, 0.0),
        (p.c2, 0.0, p.b, -FRAC_PI_2),
        (-p.a2, -FRAC_PI_2, 0.0, -FRAC_PI_2),
        (0.0, FRAC_PI_2, p.c3, 0.0),
        (0.0, -FRAC_PI_2, 0.0, 0.0),
        (0.0, 0.0, p.c4, PI),
    ];
    let joints = rows
        .iter()
        .zip(p.offsets)
        .map(|(&(a, alpha, d, offset), o)| Joint {
            a,
            alpha,
            d,
            offset: offset - o,
            qlim: [-2.0 * PI, 2.0 * PI],
            ..Joint::default()
        })
        .collect();
    Robot {
        name: "opw".into(),
        joints,
        ..Robot::default()
    }
}

fn to_pose(t: &Matrix4<f64>) -> Pose {
    let m = DMat3::from_cols(
        DVec3::new(t[(0, 0)], t[(1, 0)], t[(2, 0)]),
        DVec3::new(t[(0, 1)], t[(1, 1)], t[(2, 1)]),
        DVec3::new(t[(0, 2)], t[(1, 2)], t[(2, 2)]),
    );
    Pose::from_parts(
        DVec3::new(t[(0, 3)], t[(1, 3)], t[(2, 3)]),
        DQuat::from_mat3(&m),
    )
}

fn from_pose(p: &Pose) -> Matrix4<f64> {
    let m = DMat3::from_quat(p.rotation);
    let r = Matrix3::from_fn(|i, j| m.col(j)[i]);
    let mut t = Matrix4::identity();
    t.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    t[(0, 3)] = p.translation.x;
    t[(1, 3)] = p.translation.y;
    t[(2, 3)] = p.translation.z;
    t
}

struct Stats {
    times: Vec<f64>,
    solutions: usize,
    worst_residual: f64,
}

impl Stats {
    fn mean_us(&self) -> f64 {
        1e6 * self.times.iter().sum::<f64>() / self.times.len().max(1) as f64
    }

    fn median_us(&mut self) -> f64 {
        1e6 * percentile(&mut self.times, 50.0)
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let out = args
        .first()
        .cloned()
        .unwrap_or_else(|| format!("{}/../../docs/reports", env!("CARGO_MANIFEST_DIR")));
    let n = 10_000;
    let puma_like = Parameters {
        a1: 0.0,
        a2: -0.0203,
        b: 0.15005,
        c1: 0.67183,
        c2: 0.4318,
        c3: 0.4318,
        c4: 0.0,
        offsets: [0.0; 6],
        sign_corrections: [1; 6],
        dof: 6,
    };
    let robots = [
        ("PUMA 560 geometry (OPW form)", puma_like),
        (
            "ABB IRB 2400/10 (rs-opw parameters)",
            Parameters::irb2400_10(),
        ),
    ];
    let mut rows = Vec::new();
    let mut bars = Vec::new();
    for (name, params) in robots {
        let robot = opw_as_dh(&params);
        let opw = OPWKinematics::new(params);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let qs: Vec<[f64; 6]> = (0..n)
            .map(|_| std::array::from_fn(|_| rng.random_range(-PI..PI)))
            .collect();
        // Same forward kinematics, or no report.
        let fk_gap = qs
            .iter()
            .take(500)
            .map(|q| {
                (fk::forward(&robot, q) - from_pose(&opw.forward(q)))
                    .abs()
                    .max()
            })
            .fold(0.0, f64::max);
        assert!(
            fk_gap < 1e-12,
            "{name}: the DH rewrite disagrees with rs-opw-kinematics' FK by {fk_gap}"
        );
        let poses: Vec<Matrix4<f64>> = qs.iter().map(|q| fk::forward(&robot, q)).collect();
        let opw_poses: Vec<Pose> = poses.iter().map(to_pose).collect();

        let solver = SphericalSolver::new(&robot).expect("OPW robots are spherical-wrist 6R");
        let mut ours_raw = Stats {
            times: Vec::with_capacity(n),
            solutions: 0,
            worst_residual: 0.0,
        };
        for t in &poses {
            let start = Instant::now();
            let (sols, _) = solver.solve_raw(black_box(t), &[0.0; 6]);
            ours_raw.times.push(start.elapsed().as_secs_f64());
            for s in sols.iter().flatten() {
                ours_raw.solutions += 1;
                let r = Residual::between(&fk::forward(&robot, &s.q), t);
                ours_raw.worst_residual =
                    ours_raw.worst_residual.max(r.position.max(r.orientation));
            }
        }
        let options = IkOptions {
            all: true,
            ..IkOptions::default()
        };
        let mut ours_api = Stats {
            times: Vec::with_capacity(n),
            solutions: 0,
            worst_residual: 0.0,
        };
        for t in &poses {
            let start = Instant::now();
            let r = ik::solve(&robot, black_box(t), Method::Analytic, &options);
            ours_api.times.push(start.elapsed().as_secs_f64());
            if let Ok(r) = r {
                for s in &r.solutions {
                    ours_api.solutions += 1;
                    ours_api.worst_residual = ours_api
                        .worst_residual
                        .max(s.residual.position.max(s.residual.orientation));
                }
            }
        }
        let mut peer = Stats {
            times: Vec::with_capacity(n),
            solutions: 0,
            worst_residual: 0.0,
        };
        for (t, p) in poses.iter().zip(&opw_poses) {
            let start = Instant::now();
            let sols = opw.inverse(black_box(p));
            peer.times.push(start.elapsed().as_secs_f64());
            for s in &sols {
                peer.solutions += 1;
                let r = Residual::between(&fk::forward(&robot, s), t);
                peer.worst_residual = peer.worst_residual.max(r.position.max(r.orientation));
            }
        }
        let base = peer.median_us();
        for (label, s) in [
            ("robosim SphericalSolver::solve_raw", &mut ours_raw),
            ("robosim ik::solve(analytic, all)", &mut ours_api),
            ("rs-opw-kinematics 3.0 inverse", &mut peer),
        ] {
            let mean = s.mean_us();
            let median = s.median_us();
            rows.push(vec![
                name.to_string(),
                label.to_string(),
                n.to_string(),
                format!("{:.3}", mean),
                format!("{:.3}", median),
                format!("{:.3}", 1e6 * percentile(&mut s.times, 99.0)),
                format!("{:.2}", median / base),
                format!("{:.3}", s.solutions as f64 / n as f64),
                format!("{:.1e}", s.worst_residual),
            ]);
            bars.push(Series {
                label: format!("{name}: {label}"),
                points: vec![(1.0, mean)],
            });
        }
    }
    let report = Report {
        name: "ik_peers".into(),
        title: "Closed-form IK against a peer Rust solver (rs-opw-kinematics)".into(),
        notes: vec![
            format!("{n} poses per robot: FK of joint vectors uniform in [−π, π)⁶ (ChaCha8, seed 11); the same poses go to both solvers. \
                     Each OPW robot is rewritten in standard DH and the two forward kinematics are checked to agree to 1e-12 first."),
            "`time_ratio` is the median time divided by rs-opw-kinematics' median time in the same run (a preempted solve inflates the mean, which can exceed p99) (shared 2-core machine, single \
             thread, release build: absolute times drift, ratios less). rs-opw's `inverse` returns only solutions it validated and \
             normalised, sorted by closeness; `solve_raw` returns all eight branches unchecked (its residual is checked here, \
             outside the timing); `ik::solve` adds validation, an FK residual and limits per solution."
                .into(),
            "The numeric peer (the `k` crate) is compared by the standalone program `tools/ik-peers-numeric/` (outside the \
             workspace: `k` depends on nalgebra 0.30 and urdf-rs): [ik_peers_numeric.md](ik_peers_numeric.md)."
                .into(),
        ],
        table: Table {
            columns: ["robot", "solver", "poses", "mean_us", "median_us", "p99_us", "time_ratio", "solutions_per_pose", "worst_residual"].iter().map(|s| s.to_string()).collect(),
            rows,
        },
        plots: vec![Plot { title: "Median time per pose (all solutions)".into(), x_label: "".into(), y_label: "µs".into(), log_x: false, log_y: false, series: bars }],
    };
    match write_report(std::path::Path::new(&out), &report) {
        Ok(paths) => paths.iter().for_each(|p| println!("{}", p.display())),
        Err(e) => {
            eprintln!("ik_peers: {e}");
            std::process::exit(1);
        }
    }
}
