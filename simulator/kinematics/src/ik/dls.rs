//! Damped least squares (Levenberg–Marquardt) with error-adaptive damping, joint limits,
//! seeded random restarts and per-axis tolerances.
//!
//! Step: `(Jᵀ W J + λ I) Δq = Jᵀ W e` with λ = μ·E + λ̄, E = ½ eᵀ W e (Sugihara, "Solvability-
//! unconcerned inverse kinematics by the Levenberg–Marquardt method", IEEE T-RO 27(5), 2011):
//! the damping grows with the error, so steps stay short far from the target and near
//! singularities (where J loses rank and the undamped step explodes), and vanish as the error
//! does, keeping Newton's fast final convergence. μ adapts: ×10 after a rejected step, ÷2 after
//! an accepted one. e and J are in the target frame's axes, positions divided by the arm's
//! length scale (sum of |a| and |d|) so the method is unit-free; W zeroes axes whose tolerance
//! is infinite. Iterates are clamped into the joint limits when `respect_limits`.
//! A start ends on convergence, on `max_iterations`, or on stagnation; the next start is drawn
//! uniformly within the limits by a ChaCha8 generator seeded with `options.seed`.
//!
//! Entry point: [`Dls`].

use super::{IkError, IkOptions, IkResult, IkSolution, IkSolver, Method, finish};
use crate::jacobian::{Jacobian, fk_and_jacobian};
use crate::model::{JointType, Robot};
use crate::pose::{pose_error, rotation, to_target_frame};
use nalgebra::{DMatrix, DVector, Matrix4, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Floor of the damping, λ̄.
pub const LAMBDA_FLOOR: f64 = 1e-9;

/// The damped-least-squares solver.
#[derive(Debug, Clone, Copy, Default)]
pub struct Dls;

/// The arm's length scale used to make position errors unit-free.
pub(crate) fn length_scale(robot: &Robot) -> f64 {
    let s: f64 = robot.joints.iter().map(|j| j.a.abs() + j.d.abs()).sum();
    let prismatic: f64 = robot
        .joints
        .iter()
        .filter(|j| j.joint_type == JointType::Prismatic)
        .map(|j| (j.qlim[1] - j.qlim[0]).abs())
        .filter(|x| x.is_finite())
        .sum();
    let s = s + prismatic;
    if s > 0.0 && s.is_finite() { s } else { 1.0 }
}

/// A uniform random configuration within the limits ([−π, π] or ±scale where unlimited).
pub(crate) fn random_q(robot: &Robot, rng: &mut ChaCha8Rng, scale: f64) -> Vec<f64> {
    robot
        .joints
        .iter()
        .map(|j| {
            let (lo, hi) = match j.joint_type {
                JointType::Revolute => (j.qlim[0].max(-PI), j.qlim[1].min(PI)),
                JointType::Prismatic => (j.qlim[0].max(-scale), j.qlim[1].min(scale)),
            };
            let (lo, hi) = if lo < hi {
                (lo, hi)
            } else {
                (j.qlim[0].max(-PI), j.qlim[0].max(-PI))
            };
            lo + (hi - lo) * rng.random::<f64>()
        })
        .collect()
}

fn clamp(robot: &Robot, q: &mut [f64]) {
    for (j, qj) in robot.joints.iter().zip(q.iter_mut()) {
        *qj = qj.clamp(j.qlim[0], j.qlim[1]);
    }
}

struct Eval {
    /// Scaled, weighted target-frame error.
    e: Vector6<f64>,
    /// Unscaled target-frame error (for the tolerance test).
    e_raw: Vector6<f64>,
    jac: Jacobian,
    energy: f64,
}

impl IkSolver for Dls {
    fn method(&self) -> Method {
        Method::Dls
    }

    fn solve(
        &self,
        robot: &Robot,
        target: &Matrix4<f64>,
        options: &IkOptions,
    ) -> Result<IkResult, IkError> {
        let n = robot.dof();
        if n == 0 {
            return Err(IkError::NotApplicable {
                method: "dls",
                reason: "the robot has no joints".into(),
            });
        }
        let tol = options.tolerances.as_array();
        let scale = length_scale(robot);
        let mut weights = [0.0; 6];
        for i in 0..6 {
            let unit = if i < 3 { 1.0 / scale } else { 1.0 };
            weights[i] = if tol[i].is_finite() { unit } else { 0.0 };
        }
        let rt = rotation(target).transpose();
        let evaluate = |q: &[f64]| -> Eval {
            let (t, jac0) = fk_and_jacobian(robot, q);
            let e_raw = to_target_frame(&pose_error(&t, target), target);
            let mut jac = jac0;
            for mut col in jac.column_iter_mut() {
                let v = rt * col.fixed_rows::<3>(0);
                let w = rt * col.fixed_rows::<3>(3);
                for i in 0..3 {
                    col[i] = v[i] * weights[i];
                    col[i + 3] = w[i] * weights[i + 3];
                }
            }
            let e = Vector6::from_fn(|i, _| e_raw[i] * weights[i]);
            let energy = 0.5 * e.norm_squared();
            Eval {
                e,
                e_raw,
                jac,
                energy,
            }
        };
        let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
        let mut best: Option<(f64, Vec<f64>, usize)> = None;
        let mut total_iterations = 0;
        let starts = options.restarts + 1;
        for start in 0..starts {
            let mut q = match (&options.q0, start) {
                (Some(q0), 0) => q0.clone(),
                _ => random_q(robot, &mut rng, scale),
            };
            if options.respect_limits {
                clamp(robot, &mut q);
            }
            let mut cur = evaluate(&q);
            let mut mu = 1.0;
            let mut stalls = 0;
            for _ in 0..options.max_iterations {
                if options.tolerances.accept(&cur.e_raw) {
                    break;
                }
                total_iterations += 1;
                let jt = cur.jac.transpose();
                let mut a: DMatrix<f64> = &jt * &cur.jac;
                let lambda = mu * cur.energy + LAMBDA_FLOOR;
                for i in 0..n {
                    a[(i, i)] += lambda;
                }
                let g: DVector<f64> = &jt * cur.e;
                let Some(chol) = a.cholesky() else { break };
                let dq = chol.solve(&g);
                let mut trial: Vec<f64> = q.iter().zip(dq.iter()).map(|(a, b)| a + b).collect();
                if options.respect_limits {
                    clamp(robot, &mut trial);
                }
                let next = evaluate(&trial);
                if next.energy < cur.energy {
                    let gain = (cur.energy - next.energy) / cur.energy.max(f64::MIN_POSITIVE);
                    q = trial;
                    cur = next;
                    mu = (mu * 0.5).max(1e-6);
                    stalls = if gain < 1e-6 { stalls + 1 } else { 0 };
                } else {
                    mu *= 10.0;
                    stalls += 1;
                }
                // A local minimum (or a limit the iterate is pressed against): try elsewhere.
                if stalls >= 8 || mu > 1e12 {
                    break;
                }
            }
            let accepted = options.tolerances.accept(&cur.e_raw);
            if accepted {
                let sol = finish(
                    robot,
                    target,
                    options,
                    q.clone(),
                    None,
                    total_iterations,
                    Vec::new(),
                );
                if sol.converged {
                    return Ok(IkResult {
                        method: Method::Dls,
                        solutions: vec![sol],
                    });
                }
            }
            if best.as_ref().is_none_or(|b| cur.energy < b.0) {
                best = Some((cur.energy, q, total_iterations));
            }
        }
        let (_, q, _) = best.unwrap_or((0.0, vec![0.0; n], 0));
        let sol: IkSolution = finish(
            robot,
            target,
            options,
            q,
            None,
            total_iterations,
            Vec::new(),
        );
        Err(IkError::NotConverged {
            method: "dls",
            starts,
            best: Box::new(sol),
        })
    }
}
