//! Numeric IK peer comparison (issue 4, "What accuracy costs in time"): robosim's damped least
//! squares and Newton–Raphson against the `k` crate's `JacobianIkSolver` on the 7-DOF Franka
//! Panda, on the same random reachable poses, in the same run. Writes
//! `docs/reports/ik_peers_numeric.{csv,md,png}` (or the directory given as the first argument).
//!
//! `cd tools/ik-peers-numeric && CARGO_TARGET_DIR=/work/tgt/ikpeer cargo run --release [-- DIR [N]]`
//!
//! A standalone crate (its own `[workspace]`): `k` 0.32 depends on nalgebra 0.30 and urdf-rs,
//! which the workspace build and CI should not carry.
//!
//! Steps: the Panda (`builtin_robot("panda")`, modified DH) is rebuilt as a `k` chain of nodes
//! ([`k_chain`]); both forward kinematics must agree to 1e-12 on random joint vectors or nothing
//! is timed. Then every solver gets the same poses and the same starts, and every returned
//! configuration is judged by OUR forward kinematics (position error ≤ 1e-6 m and rotation angle
//! ≤ 1e-6 rad, joints within limits), whatever the solver itself claims.

use k::InverseKinematicsSolver;
use k::nalgebra as kna;
use nalgebra::{Matrix4, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_kinematics::fk::forward;
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::pose::{Residual, Tolerances};
use robosim_kinematics::{Convention, JointType, Robot, builtin_robot};
use robosim_report::{Plot, Report, Series, Table, percentile, write_report};
use std::hint::black_box;
use std::time::Instant;

/// Success threshold, checked with our FK on every returned configuration: ‖Δp‖ (m) and the
/// rotation angle (rad).
const TOL: f64 = 1e-6;
/// Random restarts for the cold rows (robosim's `IkOptions::default().restarts`).
const RESTARTS: usize = 200;

fn to_k(m: &Matrix4<f64>) -> kna::Isometry3<f64> {
    let r = kna::Matrix3::from_fn(|i, j| m[(i, j)]);
    let rot = kna::UnitQuaternion::from_rotation_matrix(&kna::Rotation3::from_matrix_unchecked(r));
    kna::Isometry3::from_parts(kna::Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]), rot)
}

fn from_k(iso: &kna::Isometry3<f64>) -> Matrix4<f64> {
    let h = iso.to_homogeneous();
    Matrix4::from_fn(|i, j| h[(i, j)])
}

fn rx(a: f64) -> Matrix4<f64> {
    Rotation3::from_axis_angle(&Vector3::x_axis(), a).to_homogeneous()
}

fn rz(a: f64) -> Matrix4<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), a).to_homogeneous()
}

fn tr(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new_translation(&Vector3::new(x, y, z))
}

/// The robot as a `k` serial chain: one node per joint (axis z of the node frame), then a fixed
/// tool node. A node's world transform is parent · origin · joint(q), so each DH factor that does
/// not depend on q goes into an origin:
/// * modified DH, `A_j = Rx(α_{j−1}) Tx(a_{j−1}) Rz(θ) Tz(d)`: origin_j = Rx(α) Tx(a) Tz(d) Rz(offset)
///   (Rz and Tz commute), the base folded into the first origin, the tool node's origin = tool;
/// * standard DH, `A_j = Rz(θ) Tz(d) Tx(a) Rx(α)`: the trailing Tx(a) Rx(α) of joint j moves into
///   origin_{j+1} (and the tool node's origin).
///
/// Prismatic joints: `k::JointType::Linear` along z, with Rz(θ) Tz(offset) in the origin.
fn k_chain(robot: &Robot) -> k::SerialChain<f64> {
    let mut carry = robot.base;
    let mut nodes: Vec<k::Node<f64>> = Vec::new();
    for (i, j) in robot.joints.iter().enumerate() {
        let fixed = match j.joint_type {
            JointType::Revolute => tr(0.0, 0.0, j.d) * rz(j.offset),
            JointType::Prismatic => rz(j.theta) * tr(0.0, 0.0, j.offset),
        };
        let origin = match robot.convention {
            Convention::Modified => carry * rx(j.alpha) * tr(j.a, 0.0, 0.0) * fixed,
            Convention::Standard => carry * fixed,
        };
        carry = match robot.convention {
            Convention::Modified => Matrix4::identity(),
            Convention::Standard => tr(j.a, 0.0, 0.0) * rx(j.alpha),
        };
        let joint_type = match j.joint_type {
            JointType::Revolute => k::JointType::Rotational {
                axis: kna::Vector3::z_axis(),
            },
            JointType::Prismatic => k::JointType::Linear {
                axis: kna::Vector3::z_axis(),
            },
        };
        nodes.push(
            k::NodeBuilder::new()
                .name(&format!("j{}", i + 1))
                .joint_type(joint_type)
                .limits(Some(k::joint::Range::new(j.qlim[0], j.qlim[1])))
                .origin(to_k(&origin))
                .into_node(),
        );
    }
    nodes.push(
        k::NodeBuilder::new()
            .name("tool")
            .joint_type(k::JointType::Fixed)
            .origin(to_k(&(carry * robot.tool)))
            .into_node(),
    );
    for w in nodes.windows(2) {
        w[1].set_parent(&w[0]);
    }
    // Invariant: `nodes` holds at least the tool node.
    k::SerialChain::from_end(nodes.last().expect("tool node"))
}

fn random_q(robot: &Robot, rng: &mut ChaCha8Rng) -> Vec<f64> {
    robot
        .joints
        .iter()
        .map(|j| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * rng.random::<f64>())
        .collect()
}

fn within_limits(robot: &Robot, q: &[f64]) -> bool {
    robot
        .joints
        .iter()
        .zip(q)
        .all(|(j, &x)| x >= j.qlim[0] - 1e-12 && x <= j.qlim[1] + 1e-12)
}

/// One solver configuration's measurements.
#[derive(Default)]
struct Acc {
    times: Vec<f64>,
    ok: usize,
    claimed: usize,
    /// Reached the pose within TOL but with a joint outside its limits (not a success).
    outside_limits: usize,
    pos: f64,
    ori: f64,
}

impl Acc {
    /// Judges `q` (the configuration the solver returned, if any) with our FK.
    fn judge(&mut self, robot: &Robot, q: Option<&[f64]>, target: &Matrix4<f64>, claimed: bool) {
        self.claimed += usize::from(claimed);
        if let Some(q) = q {
            let r = Residual::between(&forward(robot, q), target);
            let reached = r.position <= TOL && r.orientation <= TOL;
            if reached && !within_limits(robot, q) {
                self.outside_limits += 1;
            } else if reached {
                self.ok += 1;
                self.pos += r.position;
                self.ori += r.orientation;
            }
        }
    }
}

struct Row {
    start: &'static str,
    solver: String,
    settings: String,
    acc: Acc,
}

fn ours(
    robot: &Robot,
    method: Method,
    target: &Matrix4<f64>,
    q0: Option<Vec<f64>>,
    seed: u64,
    acc: &mut Acc,
) {
    // Per-axis tolerance TOL/√3 (target frame), so that convergence implies ‖·‖ ≤ TOL as judged.
    let tol = TOL / 3f64.sqrt();
    let options = IkOptions {
        tolerances: Tolerances::uniform(tol, tol),
        q0,
        seed,
        restarts: RESTARTS,
        ..IkOptions::default()
    };
    let start = Instant::now();
    let r = ik::solve(robot, black_box(target), method, &options);
    acc.times.push(start.elapsed().as_secs_f64());
    match r {
        Ok(r) => {
            let s = &r.solutions[0];
            acc.judge(robot, Some(&s.q), target, s.converged);
        }
        Err(ik::IkError::NotConverged { best, .. }) => {
            acc.judge(robot, Some(&best.q), target, false)
        }
        Err(_) => acc.judge(robot, None, target, false),
    }
}

/// k's solver from each start in turn until it reports success (one start for warm rows).
fn peer(
    robot: &Robot,
    arm: &k::SerialChain<f64>,
    solver: &k::JacobianIkSolver<f64>,
    target: &Matrix4<f64>,
    starts: &[Vec<f64>],
    acc: &mut Acc,
) {
    let goal = to_k(target);
    let start = Instant::now();
    let mut claimed = false;
    for q0 in starts {
        arm.set_joint_positions_clamped(q0);
        if solver.solve(arm, black_box(&goal)).is_ok() {
            claimed = true;
            break;
        }
    }
    let q = arm.joint_positions();
    acc.times.push(start.elapsed().as_secs_f64());
    acc.judge(robot, Some(&q), target, claimed);
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args
        .first()
        .cloned()
        .unwrap_or_else(|| format!("{}/../../docs/reports", env!("CARGO_MANIFEST_DIR")));
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10_000);
    let n_cold_k: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(n);

    // Invariant: the shipped Panda parses (tested in robosim-kinematics).
    let panda = builtin_robot("panda").expect("builtin panda");
    let arm = k_chain(&panda);
    assert_eq!(
        arm.dof(),
        panda.dof(),
        "k chain has the wrong number of joints"
    );

    // Same forward kinematics, or no report.
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let mut fk_gap = 0.0f64;
    for _ in 0..1000 {
        let q = random_q(&panda, &mut rng);
        arm.set_joint_positions_unchecked(&q);
        let gap = (forward(&panda, &q) - from_k(&arm.end_transform()))
            .abs()
            .max();
        fk_gap = fk_gap.max(gap);
    }
    assert!(
        fk_gap < 1e-12,
        "k chain and robosim FK disagree by {fk_gap:e}"
    );
    println!("FK agreement on 1000 random q: max |ΔT| = {fk_gap:.1e}");

    // Poses: FK of q uniform within the limits; warm starts: q ± 0.2 rad, clamped into limits.
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let gen_q: Vec<Vec<f64>> = (0..n).map(|_| random_q(&panda, &mut rng)).collect();
    let targets: Vec<Matrix4<f64>> = gen_q.iter().map(|q| forward(&panda, q)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let warm: Vec<Vec<f64>> = gen_q
        .iter()
        .map(|q| {
            q.iter()
                .zip(&panda.joints)
                .map(|(x, j)| (x + rng.random_range(-0.2..0.2)).clamp(j.qlim[0], j.qlim[1]))
                .collect()
        })
        .collect();

    let k_default = k::JacobianIkSolver::new(TOL, TOL, 0.5, 100);
    let k_full = k::JacobianIkSolver::new(TOL, TOL, 1.0, 30);
    let mut rows: Vec<Row> = Vec::new();

    // Warm: every solver from the same start.
    let mut a = Acc::default();
    for (t, q0) in targets.iter().zip(&warm) {
        ours(&panda, Method::Dls, t, Some(q0.clone()), 0, &mut a);
    }
    rows.push(Row {
        start: "warm",
        solver: "robosim dls".into(),
        settings: format!(
            "per-axis tol {:.2e}, 30 it/start, up to {RESTARTS} restarts",
            TOL / 3f64.sqrt()
        ),
        acc: a,
    });
    let mut a = Acc::default();
    for (t, q0) in targets.iter().zip(&warm) {
        ours(&panda, Method::Newton, t, Some(q0.clone()), 0, &mut a);
    }
    rows.push(Row {
        start: "warm",
        solver: "robosim newton".into(),
        settings: format!("per-axis tol {:.2e}, 30 it, no restarts", TOL / 3f64.sqrt()),
        acc: a,
    });
    for (solver, settings) in [
        (&k_default, "k default step 0.5, 100 it, no restarts"),
        (&k_full, "k full step 1.0, 30 it, no restarts"),
    ] {
        let mut a = Acc::default();
        for (t, q0) in targets.iter().zip(&warm) {
            peer(&panda, &arm, solver, t, std::slice::from_ref(q0), &mut a);
        }
        rows.push(Row {
            start: "warm",
            solver: "k 0.32 JacobianIkSolver".into(),
            settings: format!("{settings}, tol {TOL:.0e} (norms)"),
            acc: a,
        });
    }

    // Cold: ours draws its own restarts; k gets the same number of random starts within the
    // limits (ChaCha8 seeded per pose), tried in turn until k reports success.
    let mut a = Acc::default();
    for (i, t) in targets.iter().enumerate() {
        ours(&panda, Method::Dls, t, None, i as u64, &mut a);
    }
    rows.push(Row {
        start: "cold",
        solver: "robosim dls".into(),
        settings: format!(
            "per-axis tol {:.2e}, 30 it/start, up to {RESTARTS} restarts",
            TOL / 3f64.sqrt()
        ),
        acc: a,
    });
    for (solver, settings) in [
        (&k_full, "k full step 1.0, 30 it/start"),
        (&k_default, "k default step 0.5, 100 it/start"),
    ] {
        let mut a = Acc::default();
        for (i, t) in targets.iter().take(n_cold_k).enumerate() {
            let mut srng = ChaCha8Rng::seed_from_u64(1_000_000 + i as u64);
            let starts: Vec<Vec<f64>> = (0..=RESTARTS)
                .map(|_| random_q(&panda, &mut srng))
                .collect();
            peer(&panda, &arm, solver, t, &starts, &mut a);
        }
        rows.push(Row {
            start: "cold",
            solver: "k 0.32 JacobianIkSolver + restart loop".into(),
            settings: format!("{settings}, up to {RESTARTS} restarts, tol {TOL:.0e} (norms)"),
            acc: a,
        });
    }

    // Table, with ratios against robosim dls from the same kind of start.
    let mut base = std::collections::HashMap::new();
    let mut table_rows = Vec::new();
    let mut bars = Vec::new();
    let mut succ = Vec::new();
    for (idx, r) in rows.iter_mut().enumerate() {
        let m = r.acc.times.len();
        let mean = 1e6 * r.acc.times.iter().sum::<f64>() / m.max(1) as f64;
        let median = 1e6 * percentile(&mut r.acc.times, 50.0);
        let p99 = 1e6 * percentile(&mut r.acc.times, 99.0);
        let (bm, bmed) = *base.entry(r.start).or_insert((mean, median));
        let ok = r.acc.ok.max(1) as f64;
        table_rows.push(vec![
            r.start.to_string(),
            r.solver.clone(),
            r.settings.clone(),
            m.to_string(),
            format!("{:.2}", 100.0 * r.acc.ok as f64 / m.max(1) as f64),
            format!("{:.2}", 100.0 * r.acc.claimed as f64 / m.max(1) as f64),
            r.acc.outside_limits.to_string(),
            format!("{mean:.1}"),
            format!("{median:.1}"),
            format!("{p99:.1}"),
            format!("{:.2}", mean / bm),
            format!("{:.2}", median / bmed),
            format!("{:.2e}", r.acc.pos / ok),
            format!("{:.2e}", r.acc.ori / ok),
        ]);
        println!(
            "{}",
            table_rows.last().map(|v| v.join(" | ")).unwrap_or_default()
        );
        let label = format!(
            "{} {} ({})",
            r.start,
            // Short legend: "k" for the peer rows.
            if r.solver.starts_with("k ") {
                "k"
            } else {
                r.solver.as_str()
            },
            r.settings.split(',').next().unwrap_or("")
        );
        bars.push(Series {
            label: label.clone(),
            points: vec![((idx + 1) as f64, median)],
        });
        succ.push(Series {
            label,
            points: vec![((idx + 1) as f64, 100.0 * r.acc.ok as f64 / m.max(1) as f64)],
        });
    }
    let report = Report {
        name: "ik_peers_numeric".into(),
        title: "Numeric IK on the 7-DOF Panda against a peer Rust solver (k 0.32)".into(),
        notes: vec![
            format!(
                "{n} random reachable poses: FK of joint vectors uniform within the Panda's limits (ChaCha8, seed 2026); warm starts are \
                 the generating q plus uniform ±0.2 rad per joint (ChaCha8 seed 7), clamped into the limits, the same start for every \
                 solver. The Panda (modified DH) is rebuilt as a k node chain and both FKs agree to {fk_gap:.0e} on 1000 random q."
            ),
            format!(
                "success = the returned configuration, judged by robosim's FK, has position error ≤ {TOL:.0e} m and rotation angle ≤ \
                 {TOL:.0e} rad and is within the joint limits; `claimed` = the solver said it converged. Residual means are over \
                 successes; `reached_outside_limits` counts poses reached only with a joint outside its limits (robosim's Newton, like the \
                 seed's, ignores limits). robosim's tolerances are per axis in the target frame, set to {:.2e} so that convergence implies both norms ≤ \
                 {TOL:.0e}; k's are the norms of its own error (position and rotation vector), set to {TOL:.0e}.",
                TOL / 3f64.sqrt()
            ),
            "k's JacobianIkSolver is a Jacobian (pseudo-)inverse iteration: for a 7-DOF arm an SVD solve (singular values below 1e-4 \
             cut), the step scaled by `jacobian_multiplier` (k's default 0.5, i.e. linear convergence; 1.0 is a plain Newton step), \
             joints clamped to the limits, no damping, no restarts of its own. The cold k rows wrap it in our own loop over up to 201 \
             random starts within the limits, stopping at the first start k reports converged (timed as a whole)."
                .into(),
            format!(
                "Times are wall-clock per solve, single thread, release build, on a shared 2-core machine (noisy: absolute times drift \
                 between runs; ratios less). `mean_ratio` and `median_ratio` divide by robosim dls from the same kind of start in the same \
                 run. Cold k rows use the first {n_cold_k} poses."
            ),
        ],
        table: Table {
            columns: [
                "start", "solver", "settings", "poses", "success_pct", "claimed_pct", "reached_outside_limits", "mean_us", "median_us", "p99_us",
                "mean_ratio", "median_ratio", "mean_position_residual_m", "mean_orientation_residual_rad",
            ]
            .iter()
            .map(|s| s.to_string())
            .collect(),
            rows: table_rows,
        },
        plots: vec![
            Plot { title: "Median time per solve (bar = row of the table)".into(), x_label: "row".into(), y_label: "µs".into(), log_x: false, log_y: true, series: bars },
            Plot { title: "Success within 1e-6 (our FK)".into(), x_label: "row".into(), y_label: "% of poses".into(), log_x: false, log_y: false, series: succ },
        ],
    };
    match write_report(std::path::Path::new(&out), &report) {
        Ok(paths) => paths.iter().for_each(|p| println!("{}", p.display())),
        Err(e) => {
            eprintln!("ik-peers-numeric: {e}");
            std::process::exit(1);
        }
    }
}
