//! "What accuracy costs in time" for inverse kinematics (issue 4): `robosim report ik`.
//!
//! On random reachable poses (FK of joint vectors drawn uniformly within the limits, ChaCha8
//! seed 2026) for the PUMA 560, the 7-DOF Franka Panda (and the Stanford arm's closed form), per method: success rate, mean and
//! p99 wall time per solve, mean residual, mean iterations; the numeric methods at tolerances
//! 1e-3 … 1e-12 (m and rad, every axis). Times are also given as ratios to the closed-form
//! PUMA solve measured in the same run, since the machine is shared and absolute times drift.
//!
//! Entry points: [`report_ik`] (writes CSV, markdown and PNG through `robosim-report`),
//! [`measure_ik`] (the rows, for tests and benches).

use crate::plot::{Plot, Report, ReportError, Series, Table, percentile, write_report};
use nalgebra::Matrix4;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_kinematics::fk::forward;
use robosim_kinematics::ik::analytic::SphericalSolver;
use robosim_kinematics::ik::{self, IkError, IkOptions, Method};
use robosim_kinematics::pose::{Residual, Tolerances};
use robosim_kinematics::{Robot, builtin_robot};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The numeric tolerances swept (m for position, rad for orientation, every axis).
pub const TOLERANCES: [f64; 4] = [1e-3, 1e-6, 1e-9, 1e-12];

/// One measured configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct IkRow {
    pub robot: String,
    /// e.g. `analytic (raw, all 8)`, `dls (cold)`.
    pub method: String,
    /// Tolerance in m and rad (None for the closed forms, judged at 1e-10).
    pub tolerance: Option<f64>,
    pub poses: usize,
    /// Fraction of poses solved (see the report notes for each method's criterion).
    pub success: f64,
    pub mean_us: f64,
    pub median_us: f64,
    pub p99_us: f64,
    /// Means over solved poses.
    pub mean_position_residual: f64,
    pub mean_orientation_residual: f64,
    pub mean_iterations: f64,
    pub solutions_per_pose: f64,
}

fn poses(robot: &Robot, n: usize, rng: &mut ChaCha8Rng) -> Vec<(Vec<f64>, Matrix4<f64>)> {
    (0..n)
        .map(|_| {
            let q: Vec<f64> = robot
                .joints
                .iter()
                .map(|j| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * rng.random::<f64>())
                .collect();
            let t = forward(robot, &q);
            (q, t)
        })
        .collect()
}

fn same_angles(a: &[f64], b: &[f64], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| {
        let d = (x - y).rem_euclid(2.0 * std::f64::consts::PI);
        d.min(2.0 * std::f64::consts::PI - d) < tol
    })
}

#[derive(Default)]
struct Acc {
    times: Vec<f64>,
    ok: usize,
    pos: f64,
    ori: f64,
    iters: f64,
    sols: f64,
}

impl Acc {
    /// An all-solutions answer counts as a success when every solution reproduces the pose
    /// (residual < 1e-10) and one of them is the joint vector the pose came from; residuals
    /// and iterations are averaged over its solutions.
    fn score_all_solutions(&mut self, r: &ik::IkResult, q: &[f64]) {
        let good = r
            .solutions
            .iter()
            .all(|s| s.residual.position < 1e-10 && s.residual.orientation < 1e-10);
        if good && r.solutions.iter().any(|s| same_angles(&s.q, q, 1e-7)) {
            self.ok += 1;
            let k = r.solutions.len() as f64;
            self.pos += r.solutions.iter().map(|s| s.residual.position).sum::<f64>() / k;
            self.ori += r
                .solutions
                .iter()
                .map(|s| s.residual.orientation)
                .sum::<f64>()
                / k;
            self.iters += r.solutions.iter().map(|s| s.iterations as f64).sum::<f64>() / k;
        }
        self.sols += r.solutions.len() as f64;
    }

    fn row(mut self, robot: &str, method: &str, tolerance: Option<f64>) -> IkRow {
        let n = self.times.len();
        let mean = self.times.iter().sum::<f64>() / n.max(1) as f64;
        let ok = self.ok.max(1) as f64;
        IkRow {
            robot: robot.to_owned(),
            method: method.to_owned(),
            tolerance,
            poses: n,
            success: self.ok as f64 / n.max(1) as f64,
            mean_us: mean * 1e6,
            median_us: percentile(&mut self.times, 50.0) * 1e6,
            p99_us: percentile(&mut self.times, 99.0) * 1e6,
            mean_position_residual: self.pos / ok,
            mean_orientation_residual: self.ori / ok,
            mean_iterations: self.iters / ok,
            solutions_per_pose: self.sols / n.max(1) as f64,
        }
    }
}

/// Measures every method on `n` poses per robot (10,000 for the published report). Returns the
/// rows; the first is the baseline (PUMA, closed form, raw).
pub fn measure_ik(n: usize) -> Vec<IkRow> {
    let mut rows = Vec::new();
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    // Invariant: the shipped robots parse (tested in `builtin`).
    let (Some(puma), Some(panda)) = (builtin_robot("puma560"), builtin_robot("panda")) else {
        return rows;
    };
    let puma_poses = poses(&puma, n, &mut rng);
    let panda_poses = poses(&panda, n, &mut rng);
    rows.extend(closed_form_raw(&puma, &puma_poses));
    rows.extend(public_solver(&puma, &puma_poses));
    rows.push(hybrid_with_wrist_offsets(&puma, n, &mut rng));
    rows.extend(stanford_closed_form(n, &mut rng));
    // Numeric methods over the tolerance sweep.
    for (robot, name, set) in [
        (&puma, "puma560", &puma_poses),
        (&panda, "panda", &panda_poses),
    ] {
        rows.extend(numeric_sweep(robot, name, set));
    }
    rows
}

/// Closed form, raw: all eight solutions, no validation, no FK check (that is done after).
/// `None` when the PUMA does not have the spherical wrist the solver needs.
fn closed_form_raw(puma: &Robot, puma_poses: &[(Vec<f64>, Matrix4<f64>)]) -> Option<IkRow> {
    let solver = SphericalSolver::new(puma).ok()?;
    let mut acc = Acc::default();
    for (q, t) in puma_poses {
        let start = Instant::now();
        let (sols, _) = solver.solve_raw(black_box(t), &[0.0; 6]);
        let dt = start.elapsed().as_secs_f64();
        black_box(&sols);
        acc.times.push(dt);
        let found: Vec<_> = sols.iter().flatten().collect();
        let res: Vec<Residual> = found
            .iter()
            .map(|s| Residual::between(&forward(puma, &s.q), t))
            .collect();
        let all_good = found.len() == 8
            && res
                .iter()
                .all(|r| r.position < 1e-10 && r.orientation < 1e-10);
        if all_good && found.iter().any(|s| same_angles(&s.q, q, 1e-7)) {
            acc.ok += 1;
            acc.pos += res.iter().map(|r| r.position).sum::<f64>() / 8.0;
            acc.ori += res.iter().map(|r| r.orientation).sum::<f64>() / 8.0;
        }
        acc.sols += found.len() as f64;
    }
    Some(acc.row("puma560", "analytic (raw, all 8)", None))
}

/// Through the public solver: validation, FK residual and limits per solution.
fn public_solver(puma: &Robot, puma_poses: &[(Vec<f64>, Matrix4<f64>)]) -> Vec<IkRow> {
    let mut rows = Vec::new();
    for (method, name) in [
        (Method::Analytic, "analytic (ik::solve, all)"),
        (Method::Hybrid, "hybrid (ik::solve, all)"),
    ] {
        let options = IkOptions {
            all: true,
            ..IkOptions::default()
        };
        let mut acc = Acc::default();
        for (q, t) in puma_poses {
            let start = Instant::now();
            let r = ik::solve(puma, black_box(t), method, &options);
            acc.times.push(start.elapsed().as_secs_f64());
            if let Ok(r) = r {
                acc.score_all_solutions(&r, q);
            }
        }
        rows.push(acc.row("puma560", name, None));
    }
    rows
}

/// The hybrid where the closed form does not apply: the PUMA with wrist offsets
/// (a5 = 20 mm, d5 = 10 mm, a6 = 15 mm), on `n` poses drawn from `rng`.
fn hybrid_with_wrist_offsets(puma: &Robot, n: usize, rng: &mut ChaCha8Rng) -> IkRow {
    let mut offset = puma.clone();
    offset.joints[4].a = 0.02;
    offset.joints[4].d = 0.01;
    offset.joints[5].a = 0.015;
    let set = poses(&offset, n, rng);
    let options = IkOptions {
        all: true,
        ..IkOptions::default()
    };
    let mut acc = Acc::default();
    for (q, t) in &set {
        let start = Instant::now();
        let r = ik::solve(&offset, black_box(t), Method::Hybrid, &options);
        acc.times.push(start.elapsed().as_secs_f64());
        if let Ok(r) = r {
            acc.score_all_solutions(&r, q);
        }
    }
    acc.row("puma560 + wrist offsets", "hybrid (ik::solve, all)", None)
}

/// The RRP closed form on the Stanford arm (half its branches reverse the boom, outside the
/// prismatic limits; all must still reproduce the pose), on `n` poses drawn from `rng`.
fn stanford_closed_form(n: usize, rng: &mut ChaCha8Rng) -> Option<IkRow> {
    let stanford = builtin_robot("stanford")?;
    let set = poses(&stanford, n, rng);
    let options = IkOptions {
        all: true,
        ..IkOptions::default()
    };
    let mut acc = Acc::default();
    for (q, t) in &set {
        let start = Instant::now();
        let r = ik::solve(&stanford, black_box(t), Method::Analytic, &options);
        acc.times.push(start.elapsed().as_secs_f64());
        if let Ok(r) = r {
            let good = r
                .solutions
                .iter()
                .all(|s| s.residual.position < 1e-10 && s.residual.orientation < 1e-10);
            if good
                && r.solutions
                    .iter()
                    .any(|s| s.q.iter().zip(q).all(|(a, b)| (a - b).abs() < 1e-7))
            {
                acc.ok += 1;
                let k = r.solutions.len() as f64;
                acc.pos += r.solutions.iter().map(|s| s.residual.position).sum::<f64>() / k;
                acc.ori += r
                    .solutions
                    .iter()
                    .map(|s| s.residual.orientation)
                    .sum::<f64>()
                    / k;
            }
            acc.sols += r.solutions.len() as f64;
        }
    }
    Some(acc.row("stanford", "analytic (ik::solve, all)", None))
}

/// Newton and DLS (warm and cold starts) on `set` at every tolerance of [`TOLERANCES`].
fn numeric_sweep(robot: &Robot, name: &str, set: &[(Vec<f64>, Matrix4<f64>)]) -> Vec<IkRow> {
    let mut rows = Vec::new();
    for &tol in &TOLERANCES {
        for (method, label, warm) in [
            (Method::Newton, "newton (warm ±0.2 rad)", true),
            (Method::Dls, "dls (warm ±0.2 rad)", true),
            (Method::Dls, "dls (cold, random restarts)", false),
        ] {
            let mut acc = Acc::default();
            let mut start_rng = ChaCha8Rng::seed_from_u64(7);
            for (k, (q, t)) in set.iter().enumerate() {
                let q0 = warm.then(|| {
                    q.iter()
                        .map(|x| x + start_rng.random_range(-0.2..0.2))
                        .collect::<Vec<f64>>()
                });
                let options = IkOptions {
                    tolerances: Tolerances::uniform(tol, tol),
                    q0,
                    seed: k as u64,
                    ..IkOptions::default()
                };
                let start = Instant::now();
                let r = ik::solve(robot, black_box(t), method, &options);
                acc.times.push(start.elapsed().as_secs_f64());
                match r {
                    Ok(r) if r.solutions[0].converged => {
                        let s = &r.solutions[0];
                        acc.ok += 1;
                        acc.pos += s.residual.position;
                        acc.ori += s.residual.orientation;
                        acc.iters += s.iterations as f64;
                        acc.sols += 1.0;
                    }
                    Ok(_) | Err(IkError::NotConverged { .. }) => {}
                    Err(_) => {}
                }
            }
            rows.push(acc.row(name, label, Some(tol)));
        }
    }
    rows
}

fn sci(x: f64) -> String {
    format!("{x:.2e}")
}

/// Runs [`measure_ik`] (10,000 poses per robot, or 200 with `quick`) and writes
/// `ik.csv`, `ik.md` and `ik.png` into `out_dir`. Returns the paths written.
pub fn report_ik(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, ReportError> {
    let n = if quick { 200 } else { 10_000 };
    let rows = measure_ik(n);
    let base = rows.first().map_or(f64::NAN, |r| r.median_us);
    let columns = [
        "robot",
        "method",
        "tolerance",
        "poses",
        "success_pct",
        "mean_us",
        "median_us",
        "p99_us",
        "time_ratio",
        "mean_position_residual_m",
        "mean_orientation_residual_rad",
        "mean_iterations",
        "solutions_per_pose",
    ];
    let table = Table {
        columns: columns.iter().map(|s| s.to_string()).collect(),
        rows: rows
            .iter()
            .map(|r| {
                vec![
                    r.robot.clone(),
                    r.method.clone(),
                    r.tolerance.map_or("closed form (1e-10)".into(), sci),
                    r.poses.to_string(),
                    format!("{:.2}", 100.0 * r.success),
                    format!("{:.3}", r.mean_us),
                    format!("{:.3}", r.median_us),
                    format!("{:.3}", r.p99_us),
                    format!("{:.1}", r.median_us / base),
                    sci(r.mean_position_residual),
                    sci(r.mean_orientation_residual),
                    format!("{:.1}", r.mean_iterations),
                    format!("{:.2}", r.solutions_per_pose),
                ]
            })
            .collect(),
    };
    let mut time_series = Vec::new();
    let mut success_series = Vec::new();
    for r in rows.iter().filter(|r| r.tolerance.is_none()) {
        time_series.push(Series {
            label: format!("{} {}", r.robot, r.method),
            points: vec![(1e-12, r.median_us), (1e-3, r.median_us)],
        });
    }
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in rows.iter().filter(|r| r.tolerance.is_some()) {
        let k = (r.robot.clone(), r.method.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (robot, method) in keys {
        let pts = |f: &dyn Fn(&IkRow) -> f64| -> Vec<(f64, f64)> {
            rows.iter()
                .filter(|r| r.robot == robot && r.method == method)
                .filter_map(|r| r.tolerance.map(|t| (t, f(r))))
                .collect()
        };
        time_series.push(Series {
            label: format!("{robot} {method}"),
            points: pts(&|r| r.median_us),
        });
        success_series.push(Series {
            label: format!("{robot} {method}"),
            points: pts(&|r| 100.0 * r.success),
        });
    }
    let report = Report {
        name: "ik".into(),
        title: "Inverse kinematics: what accuracy costs in time".into(),
        notes: vec![
            format!(
                "{n} random reachable poses per robot: FK of joint vectors drawn uniformly within the joint limits (ChaCha8, seed 2026). \
                 PUMA 560 (standard DH, 6R spherical wrist), Franka Panda (modified DH, 7 DOF), and the Stanford arm's RRP closed form."
            ),
            "Closed forms (analytic, hybrid): success = all solutions found with position and orientation residual < 1e-10 and the \
             generating configuration among them; `raw` times SphericalSolver::solve_raw alone (all 8 branches, no allocation), \
             `ik::solve` adds validation, an FK residual and a limits check per solution."
                .into(),
            "Numeric methods: success = converged within the tolerance on every axis (m and rad). `warm` starts from the generating \
             configuration plus uniform noise of ±0.2 rad per joint (the seed's Newton starts from the current joints); `cold` \
             starts from q = random within limits and restarts up to 200 times (seed = pose index), at most 30 iterations per start. \
             Residual and iteration means are over solved poses."
                .into(),
            "Times are wall-clock per solve on a shared 2-core machine, single thread, release build; they drift from run to run. \
             A preempted solve inflates the mean (it can exceed p99); the median is the robust figure. \
             `time_ratio` divides the median by the raw closed-form PUMA solve's median measured in the same run."
                .into(),
        ],
        table,
        plots: vec![
            Plot {
                title: "Median time per solve".into(),
                x_label: "tolerance (m, rad)".into(),
                y_label: "µs".into(),
                log_x: true,
                log_y: true,
                series: time_series,
            },
            Plot {
                title: "Success rate".into(),
                x_label: "tolerance (m, rad)".into(),
                y_label: "% of poses".into(),
                log_x: true,
                log_y: false,
                series: success_series,
            },
        ],
    };
    write_report(out_dir, &report)
}
