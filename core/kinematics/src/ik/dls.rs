//! Damped least squares (Levenberg–Marquardt) with error-adaptive damping, joint limits,
//! seeded random restarts and per-axis tolerances.
//!
//! Step: `(Jᵀ W J + λ I) Δq = Jᵀ W e` with λ = μ·E + λ̄, E = ½ eᵀ W e (Sugihara, "Solvability-
//! unconcerned inverse kinematics by the Levenberg–Marquardt method", IEEE T-RO 27(5), 2011):
//! the damping grows with the error, so steps stay short far from the target and near
//! singularities (where J loses rank and the undamped step explodes), and vanish as the error
//! does, keeping Newton's fast final convergence. μ adapts: ×10 after a rejected step, ÷10 after
//! an accepted one; a step is shortened to at most 0.5 rad (max-norm). e and J are in the target frame's axes, positions divided by the arm's
//! length scale (sum of |a| and |d|) so the method is unit-free; W zeroes axes whose tolerance
//! is infinite. Iterates are clamped into the joint limits when `respect_limits`.
//! A start ends on convergence, on `max_iterations`, or on stagnation; the next start is drawn
//! uniformly within the limits by a ChaCha8 generator seeded with `options.seed`. With
//! `options.all`, every start runs and each distinct converged configuration is returned (a
//! sample of the solution set — for a redundant arm it is a continuum — not a complete list).
//!
//! Entry point: [`Dls`].

use super::{IkError, IkOptions, IkResult, IkSolution, IkSolver, Method, finish};
use crate::jacobian::Jacobian;
use crate::kinematic_model::KinematicModel;
use crate::model::{JointType, Robot};
use crate::pose::{pose_error, rotation, to_target_frame};
use nalgebra::{Matrix3, Matrix4, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Joint-space distance (max-norm, revolute joints modulo 2π) below which two answers of an
/// `all` solve count as one.
pub const DISTINCT: f64 = 1e-6;

/// Floor of the damping, λ̄.
pub const LAMBDA_FLOOR: f64 = 1e-9;

/// The damped-least-squares solver and its tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dls {
    /// Initial multiplier μ of the error-proportional damping λ = μ·E + λ̄.
    pub mu0: f64,
    /// μ is divided by this after an accepted step.
    pub mu_down: f64,
    /// μ is multiplied by this after a rejected step.
    pub mu_up: f64,
    /// Consecutive rejected or negligible steps before the start is abandoned.
    pub max_stalls: usize,
    /// Largest joint change per step (max-norm, rad or m); longer steps are scaled down.
    pub max_step: f64,
}

impl Default for Dls {
    /// Tuned on 500 random Panda, PUMA 560 and Stanford poses at 1e-6 (iterations to converge):
    /// small initial damping, short steps, early restarts.
    fn default() -> Self {
        Dls {
            mu0: 1e-3,
            mu_down: 10.0,
            mu_up: 10.0,
            max_stalls: 3,
            max_step: 0.5,
        }
    }
}

/// The arm's length scale used to make position errors unit-free.
pub(crate) fn length_scale(robot: &Robot) -> f64 {
    let s: f64 = robot.joints.iter().map(|j| j.length()).sum();
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
            // No room in the sampled window (lo = hi, or limits outside it): sit at the lower
            // limit (clamped to the window when that limit is infinite).
            let (lo, hi) = if lo < hi {
                (lo, hi)
            } else {
                (lo.min(hi), lo.min(hi))
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

/// Solves `A x = b` in place for symmetric positive-definite `A` (n × n, row-major; its lower
/// triangle is overwritten by the Cholesky factor, `b` by x). False if A is not positive
/// definite.
fn cholesky_solve(a: &mut [f64], n: usize, b: &mut [f64]) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= a[i * n + k] * b[k];
        }
        b[i] = s / a[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= a[k * n + i] * b[k];
        }
        b[i] = s / a[i * n + i];
    }
    true
}

/// One evaluated iterate: scaled, weighted target-frame error and Jacobian, raw error.
struct Eval {
    jac: Jacobian,
    e: Vector6<f64>,
    e_raw: Vector6<f64>,
    energy: f64,
}

impl Eval {
    fn zeros(n: usize) -> Eval {
        Eval {
            jac: Jacobian::zeros(n),
            e: Vector6::zeros(),
            e_raw: Vector6::zeros(),
            energy: 0.0,
        }
    }
}

/// What every iterate of a solve is measured against: the compiled model, the target and the
/// per-axis weights W.
struct Objective<'a> {
    /// Compiled once for the solve: every iteration of every start evaluates on it.
    model: KinematicModel,
    target: &'a Matrix4<f64>,
    /// The target's rotation, transposed: world axes to the target frame's.
    rt: Matrix3<f64>,
    weights: [f64; 6],
}

impl<'a> Objective<'a> {
    fn new(robot: &Robot, target: &'a Matrix4<f64>, options: &IkOptions, scale: f64) -> Self {
        let tol = options.tolerances.as_array();
        let mut weights = [0.0; 6];
        for i in 0..6 {
            let unit = if i < 3 { 1.0 / scale } else { 1.0 };
            weights[i] = if tol[i].is_finite() { unit } else { 0.0 };
        }
        Objective {
            rt: rotation(target).transpose(),
            model: KinematicModel::new(robot),
            target,
            weights,
        }
    }

    /// Fills `ev` for q (no allocation).
    fn evaluate(&self, q: &[f64], ev: &mut Eval) {
        let (rt, weights, target) = (self.rt, &self.weights, self.target);
        let t = self.model.fk_and_jacobian_into(q, &mut ev.jac);
        ev.e_raw = to_target_frame(&pose_error(&t, target), target);
        for mut col in ev.jac.column_iter_mut() {
            let v = rt * col.fixed_rows::<3>(0);
            let w = rt * col.fixed_rows::<3>(3);
            for i in 0..3 {
                col[i] = v[i] * weights[i];
                col[i + 3] = w[i] * weights[i + 3];
            }
        }
        ev.e = Vector6::from_fn(|i, _| ev.e_raw[i] * weights[i]);
        ev.energy = 0.5 * ev.e.norm_squared();
    }
}

/// The buffers of one solve, reused by every iteration of every start.
struct Work {
    /// The current iterate's evaluation.
    cur: Eval,
    /// The trial step's evaluation.
    next: Eval,
    /// Jᵀ W J + λ I (n × n, row-major), then its Cholesky factor.
    a: Vec<f64>,
    /// Jᵀ W e, then the step Δq.
    dq: Vec<f64>,
    /// q + Δq (shortened, clamped).
    trial: Vec<f64>,
}

impl Work {
    fn new(n: usize) -> Work {
        Work {
            cur: Eval::zeros(n),
            next: Eval::zeros(n),
            a: vec![0.0; n * n],
            dq: vec![0.0; n],
            trial: vec![0.0; n],
        }
    }

    /// Fills `a` with Jᵀ W J + λ I and `dq` with Jᵀ W e of the current iterate.
    fn normal_equations(&mut self, n: usize, lambda: f64) {
        let (cur, a, dq) = (&self.cur, &mut self.a, &mut self.dq);
        for i in 0..n {
            for j in 0..=i {
                let v = cur.jac.column(i).dot(&cur.jac.column(j));
                a[i * n + j] = v;
                a[j * n + i] = v;
            }
            a[i * n + i] += lambda;
            dq[i] = cur.jac.column(i).dot(&cur.e);
        }
    }
}

/// Whether `q` is farther than [`DISTINCT`] from every answer in `found`.
fn distinct_from(robot: &Robot, found: &[IkSolution], q: &[f64]) -> bool {
    found.iter().all(|o: &IkSolution| {
        robot
            .joints
            .iter()
            .zip(o.q.iter().zip(q))
            .any(|(j, (a, b))| {
                let d = if j.joint_type == JointType::Revolute {
                    super::wrap(a - b)
                } else {
                    a - b
                };
                d.abs() > DISTINCT
            })
    })
}

impl Dls {
    /// One start from `q`: damped steps until convergence, `max_iterations` or a stall. `q`
    /// ends at the last accepted iterate, `work.cur` holds its evaluation.
    fn descend(
        &self,
        robot: &Robot,
        objective: &Objective<'_>,
        options: &IkOptions,
        q: &mut [f64],
        work: &mut Work,
        total_iterations: &mut usize,
    ) {
        let n = robot.dof();
        objective.evaluate(q, &mut work.cur);
        let mut mu = self.mu0;
        let mut stalls = 0;
        for _ in 0..options.max_iterations {
            if options.tolerances.accept(&work.cur.e_raw) {
                break;
            }
            *total_iterations += 1;
            let lambda = mu * work.cur.energy + LAMBDA_FLOOR;
            work.normal_equations(n, lambda);
            if !cholesky_solve(&mut work.a, n, &mut work.dq) {
                break;
            }
            let longest = work.dq.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            let shrink = if longest > self.max_step {
                self.max_step / longest
            } else {
                1.0
            };
            for ((t, qj), d) in work.trial.iter_mut().zip(q.iter()).zip(&work.dq) {
                *t = qj + shrink * d;
            }
            if options.respect_limits {
                clamp(robot, &mut work.trial);
            }
            objective.evaluate(&work.trial, &mut work.next);
            if work.next.energy < work.cur.energy {
                let gain =
                    (work.cur.energy - work.next.energy) / work.cur.energy.max(f64::MIN_POSITIVE);
                q.copy_from_slice(&work.trial);
                std::mem::swap(&mut work.cur, &mut work.next);
                mu = (mu / self.mu_down).max(1e-6);
                stalls = if gain < 1e-6 { stalls + 1 } else { 0 };
            } else {
                mu *= self.mu_up;
                stalls += 1;
            }
            // A local minimum (or a limit the iterate is pressed against): try elsewhere.
            if stalls >= self.max_stalls || mu > 1e12 {
                break;
            }
        }
    }
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
        let scale = length_scale(robot);
        let objective = Objective::new(robot, target, options, scale);
        let model = &objective.model;
        let mut work = Work::new(n);
        let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
        let mut best: Option<(f64, Vec<f64>, usize)> = None;
        let mut total_iterations = 0;
        let mut found: Vec<IkSolution> = Vec::new();
        let starts = options.restarts + 1;
        for start in 0..starts {
            let mut q = match (&options.q0, start) {
                (Some(q0), 0) => q0.clone(),
                _ => random_q(robot, &mut rng, scale),
            };
            if options.respect_limits {
                clamp(robot, &mut q);
            }
            self.descend(
                robot,
                &objective,
                options,
                &mut q,
                &mut work,
                &mut total_iterations,
            );
            let cur = &work.cur;
            let accepted = options.tolerances.accept(&cur.e_raw);
            if accepted {
                let sol = finish(
                    robot,
                    model,
                    target,
                    options,
                    q.clone(),
                    None,
                    total_iterations,
                    Vec::new(),
                );
                if sol.converged && !options.all {
                    return Ok(IkResult {
                        method: Method::Dls,
                        solutions: vec![sol],
                    });
                }
                // With `all`, every start runs and each distinct converged answer is kept.
                let distinct = distinct_from(robot, &found, &sol.q);
                if sol.converged && distinct {
                    found.push(sol);
                }
            }
            if best.as_ref().is_none_or(|b| cur.energy < b.0) {
                best = Some((cur.energy, q, total_iterations));
            }
        }
        if !found.is_empty() {
            return Ok(IkResult {
                method: Method::Dls,
                solutions: found,
            });
        }
        let (_, q, _) = best.unwrap_or((0.0, vec![0.0; n], 0));
        let sol: IkSolution = finish(
            robot,
            model,
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
