//! All closed-form solutions of 6R arms with a spherical wrist: the PUMA 560 and every arm of
//! its family (any link lengths a1, a2, a3, d1, d4, d6, lateral offset d2 + d3, any signs of the
//! ±π/2 twists, joint offsets, base and tool; modified-DH robots after rewriting).
//! The seed's one implemented exact solution (§2.5, "the PUMA 560 ... in a general form, in
//! which six parameters (the lengths of the links) can vary"), after Paul & Zhang (IJRR 5(2),
//! 1986), decoupled at the wrist centre (Pieper).
//!
//! Entry points: [`Analytic`] (the [`IkSolver`]), [`SphericalSolver`] (precomputed per robot,
//! allocation-free [`SphericalSolver::solve_raw`] for benches).
//!
//! Branch rules (for the PUMA 560 these are Corke's `l/r`, `u/d`, `n/f`):
//! * shoulder `Right`: θ1 = ψ + asin(k), `Left`: θ1 = ψ + π − asin(k), with ψ the azimuth of
//!   the wrist centre and k = sin α1 · (d2 + d3) / ρ, ρ its distance from the waist axis;
//! * elbow `Up` ⇔ σ · sin(θ3 + φ) ≤ 0 with σ = +1 right, −1 left, φ = atan2(−d4 sin α3, a3);
//! * wrist `NoFlip` ⇔ sin α4 · sin θ5 ≤ 0; `Flip` is (θ4 + π, −θ5, θ6 + π).
//!
//! Rounding at the workspace boundary: a sine or cosine that exceeds 1 by at most
//! [`CLAMP_SLACK`] is clamped and the solution carries [`super::Note::ElbowClamped`] /
//! [`super::Note::ShoulderClamped`]; beyond that the branch is unreachable. At the wrist singularity
//! (|sin θ5| < [`WRIST_SINGULAR`]) θ4 is taken from the reference (see [`super::Note::WristSingular`]);
//! never NaN.

pub use super::closed_form::{CLAMP_SLACK, Flags, RawSolution, WRIST_SINGULAR};

use super::family::{ArmGeometry, BoomGeometry, Family, recognise, recognised_from_axes};
use super::parallel::ParallelSolver;
use super::{
    Branch, Elbow, IkError, IkOptions, IkResult, IkSolver, Method, Shoulder, Wrist, finish, wrap,
};
use crate::jacobian::Jacobian;
use crate::kinematic_model::KinematicModel;
use crate::model::Robot;
use crate::pose::pose_error;
use crate::pose::{rigid_inverse, rot_x, trans};
use nalgebra::{Matrix3, Matrix4, Vector3};
use std::f64::consts::PI;

/// |sin θ5| above this: the wrist angles in closed form; below, θ6 from the residual rotation.
const WRIST_DIRECT: f64 = 1e-4;

/// Rotation of a standard DH link: Rz(θ) Rx(α).
pub(crate) fn rz_rx(theta: f64, alpha: f64) -> Matrix3<f64> {
    let (st, ct) = theta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    Matrix3::new(ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca)
}

/// Rz(θ) Rx(α) with (sin α, cos α) given.
pub(crate) fn rz_rx_sc(theta: f64, (sa, ca): (f64, f64)) -> Matrix3<f64> {
    let (st, ct) = theta.sin_cos();
    Matrix3::new(ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca)
}

/// The position part: waist, shoulder, elbow from the wrist point.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ArmSolver {
    pub d1: f64,
    pub a1: f64,
    pub a2: f64,
    pub lateral: f64,
    pub s1: f64,
    /// Forearm as one planar link: length and angle φ.
    pub l2: f64,
    pub phi: f64,
    pub alpha: [f64; 3],
    /// (sin α, cos α) of the first three links.
    pub alpha_sc: [(f64, f64); 3],
    pub scale: f64,
}

/// One arm branch: θ1..θ3 (DH angles, offsets not removed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ArmBranch {
    pub theta: [f64; 3],
    pub shoulder: Shoulder,
    pub elbow: Elbow,
    pub flags: Flags,
}

impl ArmSolver {
    pub fn new(arm: &ArmGeometry) -> ArmSolver {
        let j = &arm.chain.joints;
        let b3 = -j[3].d * arm.s3;
        let scale: f64 = j.iter().map(|j| j.a.abs() + j.d.abs()).sum();
        ArmSolver {
            d1: j[0].d,
            a1: j[0].a,
            a2: j[1].a,
            lateral: arm.lateral,
            s1: arm.s1,
            l2: j[2].a.hypot(b3),
            phi: b3.atan2(j[2].a),
            alpha: [j[0].alpha, j[1].alpha, j[2].alpha],
            alpha_sc: [
                j[0].alpha.sin_cos(),
                j[1].alpha.sin_cos(),
                j[2].alpha.sin_cos(),
            ],
            scale,
        }
    }

    /// The up-to-four arm branches reaching wrist point `p` (prefix frame), in the order
    /// left-up, left-down, right-up, right-down; `None` where a branch cannot reach, with the
    /// reason of the last failure. `theta1_ref` is the free θ1 at the shoulder singularity.
    pub fn solve(
        &self,
        p: &Vector3<f64>,
        theta1_ref: f64,
    ) -> ([Option<ArmBranch>; 4], Option<&'static str>) {
        self.solve_ext(p, theta1_ref, false)
    }

    /// [`Self::solve`]; with `extend`, out-of-reach sines and cosines are clamped instead of
    /// refused (the clamp's excess is in the flags), so the branches are defined, and
    /// continuous, for every wrist point: the hybrid scans that extension and keeps only roots
    /// whose excess is within [`CLAMP_SLACK`].
    pub fn solve_ext(
        &self,
        p: &Vector3<f64>,
        theta1_ref: f64,
        extend: bool,
    ) -> ([Option<ArmBranch>; 4], Option<&'static str>) {
        let mut out = [None; 4];
        let mut why = None;
        let ((right, left), base_flags) =
            match shoulder(p, self.lateral, self.s1, self.scale, theta1_ref, extend) {
                Ok(x) => x,
                Err(reason) => return (out, Some(reason)),
            };
        for (si, (shoulder, t1)) in [(Shoulder::Left, left), (Shoulder::Right, right)]
            .into_iter()
            .enumerate()
        {
            let (s, c) = t1.sin_cos();
            let x1 = p.x * c + p.y * s - self.a1;
            let y1 = (p.z - self.d1) * self.s1;
            let r2 = x1 * x1 + y1 * y1;
            let mut kk = (r2 - self.a2 * self.a2 - self.l2 * self.l2) / (2.0 * self.a2 * self.l2);
            let mut flags = base_flags;
            if kk.abs() > 1.0 + CLAMP_SLACK && !extend {
                why = Some(if kk > 0.0 {
                    "the wrist centre is farther from the shoulder than the stretched arm reaches"
                } else {
                    "the wrist centre is closer to the shoulder than the folded arm reaches"
                });
                continue;
            }
            if !kk.is_finite() {
                continue;
            }
            if kk.abs() > 1.0 {
                flags.elbow_clamped = Some(kk.abs() - 1.0);
                kk = kk.signum();
            }
            let beta = kk.acos();
            let sigma = if shoulder == Shoulder::Right {
                1.0
            } else {
                -1.0
            };
            for (ei, elbow) in [Elbow::Up, Elbow::Down].into_iter().enumerate() {
                // Up ⇔ σ·sin(θ3 + φ) ≤ 0.
                let t3phi = if elbow == Elbow::Up {
                    -sigma * beta
                } else {
                    sigma * beta
                };
                let (s3p, c3p) = t3phi.sin_cos();
                let t3 = t3phi - self.phi;
                let t2 = y1.atan2(x1) - (self.l2 * s3p).atan2(self.a2 + self.l2 * c3p);
                out[2 * si + ei] = Some(ArmBranch {
                    theta: [t1, t2, t3],
                    shoulder,
                    elbow,
                    flags,
                });
            }
        }
        (out, why)
    }

    /// Rotation of frame 3 in the prefix frame for DH angles θ1..θ3.
    pub fn r03(&self, theta: &[f64; 3]) -> Matrix3<f64> {
        let [a1, a2, a3] = self.alpha_sc;
        rz_rx_sc(theta[0], a1) * rz_rx_sc(theta[1], a2) * rz_rx_sc(theta[2], a3)
    }
}

/// The two waist angles (right, left) putting wrist point `p` in the arm's plane, from the
/// lateral-offset equation −u_y·s1 = lateral (u: p rotated by −θ1); shared by both arms.
fn shoulder(
    p: &Vector3<f64>,
    lateral: f64,
    s1: f64,
    scale: f64,
    theta1_ref: f64,
    extend: bool,
) -> Result<((f64, f64), Flags), &'static str> {
    let rho = p.x.hypot(p.y);
    let psi = p.y.atan2(p.x);
    let tiny = 1e-13 * scale;
    let mut flags = Flags::default();
    if rho <= tiny && lateral.abs() <= tiny {
        flags.shoulder_singular = true;
        return Ok(((theta1_ref, theta1_ref + PI), flags));
    }
    let mut k = lateral * s1 / rho;
    if !k.is_finite() || (k.abs() > 1.0 + CLAMP_SLACK && !extend) {
        return Err("the wrist centre is closer to the waist axis than the shoulder offset");
    }
    if k.abs() > 1.0 {
        flags.shoulder_clamped = Some(k.abs() - 1.0);
        k = k.signum();
    }
    let a = k.asin();
    Ok(((psi + a, psi + PI - a), flags))
}

/// The RRP (Stanford) arm: waist, shoulder, prismatic boom along the shoulder frame's z.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BoomSolver {
    d1: f64,
    a1: f64,
    a2: f64,
    s1: f64,
    s2: f64,
    /// Offset of the boom from the shoulder along z1: d2 + a3 sin θ3 · s2.
    lateral: f64,
    /// Offset along the boom's normal: a3 cos θ3.
    u: f64,
    d4: f64,
    theta3: f64,
    alpha_sc: [(f64, f64); 2],
    scale: f64,
}

impl BoomSolver {
    fn new(g: &BoomGeometry) -> BoomSolver {
        let j = &g.chain.joints;
        let (st3, ct3) = j[2].theta.sin_cos();
        BoomSolver {
            d1: j[0].d,
            a1: j[0].a,
            a2: j[1].a,
            s1: g.s1,
            s2: g.s2,
            lateral: j[1].d + j[2].a * st3 * g.s2,
            u: j[2].a * ct3,
            d4: j[3].d,
            theta3: j[2].theta,
            alpha_sc: [j[0].alpha.sin_cos(), j[1].alpha.sin_cos()],
            scale: j.iter().map(|j| j.a.abs() + j.d.abs()).sum::<f64>()
                + (j[2].qlim[1] - j[2].qlim[0]).abs().min(1e300),
        }
    }

    /// Branches in the order left-up, left-down, right-up, right-down, where `Up` is the boom
    /// extended forwards (D = d3 + d4 ≥ 0) and `Down` reversed (D ≤ 0); `theta[2]` is d3.
    fn solve(
        &self,
        p: &Vector3<f64>,
        theta1_ref: f64,
    ) -> ([Option<ArmBranch>; 4], Option<&'static str>) {
        let mut out = [None; 4];
        let mut why = None;
        let ((right, left), base_flags) =
            match shoulder(p, self.lateral, self.s1, self.scale, theta1_ref, false) {
                Ok(x) => x,
                Err(reason) => return (out, Some(reason)),
            };
        for (si, (shoulder, t1)) in [(Shoulder::Left, left), (Shoulder::Right, right)]
            .into_iter()
            .enumerate()
        {
            let (s, c) = t1.sin_cos();
            let x1 = p.x * c + p.y * s - self.a1;
            let y1 = (p.z - self.d1) * self.s1;
            let m = self.a2 + self.u;
            let r2 = x1 * x1 + y1 * y1;
            let mut disc = r2 - m * m;
            let mut flags = base_flags;
            if disc < 0.0 {
                let excess = -disc / (m * m).max(f64::MIN_POSITIVE);
                if excess > CLAMP_SLACK {
                    why = Some(
                        "the wrist centre is closer to the shoulder axis than the boom's offset",
                    );
                    continue;
                }
                flags.elbow_clamped = Some(excess);
                disc = 0.0;
            }
            let root = disc.sqrt();
            for (ei, elbow) in [Elbow::Up, Elbow::Down].into_iter().enumerate() {
                let d = if elbow == Elbow::Up { root } else { -root };
                let t2 = y1.atan2(x1) - (-d * self.s2).atan2(m);
                out[2 * si + ei] = Some(ArmBranch {
                    theta: [t1, t2, d - self.d4],
                    shoulder,
                    elbow,
                    flags,
                });
            }
        }
        (out, why)
    }

    fn r03(&self, theta: &[f64; 3]) -> Matrix3<f64> {
        rz_rx_sc(theta[0], self.alpha_sc[0])
            * rz_rx_sc(theta[1], self.alpha_sc[1])
            * rz_rx_sc(self.theta3, (0.0, 1.0))
    }
}

/// The position part of either family.
#[derive(Debug, Clone, PartialEq)]
enum Arm {
    Elbow(ArmSolver),
    Boom(BoomSolver),
}

impl Arm {
    fn solve(
        &self,
        p: &Vector3<f64>,
        theta1_ref: f64,
    ) -> ([Option<ArmBranch>; 4], Option<&'static str>) {
        match self {
            Arm::Elbow(a) => a.solve(p, theta1_ref),
            Arm::Boom(b) => b.solve(p, theta1_ref),
        }
    }

    fn r03(&self, theta: &[f64; 3]) -> Matrix3<f64> {
        match self {
            Arm::Elbow(a) => a.r03(theta),
            Arm::Boom(b) => b.r03(theta),
        }
    }
}

/// The spherical-wrist solver, precomputed for one robot.
#[derive(Debug, Clone, PartialEq)]
pub struct SphericalSolver {
    arm: Arm,
    /// Joint 3 is the prismatic boom (not wrapped).
    boom: bool,
    prefix_inv: Matrix4<f64>,
    tail_inv: Matrix4<f64>,
    alpha4: f64,
    alpha5: f64,
    s4: f64,
    s5: f64,
    offsets: [f64; 6],
}

impl SphericalSolver {
    /// `NotApplicable` unless the robot is in [`Family::SphericalWrist`] or [`Family::BoomWrist`].
    pub fn new(robot: &Robot) -> Result<SphericalSolver, IkError> {
        SphericalSolver::from_family(recognise(robot))
    }

    /// The solver for a family [`recognise`] returned (`NotApplicable` unless spherical).
    pub fn from_family(family: Family) -> Result<SphericalSolver, IkError> {
        let (chain, s4, arm) = match family {
            Family::SphericalWrist(g) => (g.chain.clone(), g.s4, Arm::Elbow(ArmSolver::new(&g))),
            Family::BoomWrist(g) => (g.chain.clone(), g.s4, Arm::Boom(BoomSolver::new(&g))),
            Family::OffsetWrist(_) => {
                return Err(IkError::NotApplicable {
                    method: "analytic",
                    reason: "the wrist is not spherical (a5, d5 or a6 is not 0, or α5 is not ±π/2); use hybrid".into(),
                });
            }
            Family::ThreeParallel(_) => {
                return Err(IkError::NotApplicable {
                    method: "analytic",
                    reason: "the UR type (three parallel axes): see ik::parallel".into(),
                });
            }
            Family::General(reason) => {
                return Err(IkError::NotApplicable {
                    method: "analytic",
                    reason,
                });
            }
        };
        let j = &chain.joints;
        // A6 = Rz(θ6) · Tz(d6) Rx(α6) (a6 = 0): the constant tail goes with the tool.
        let tail = trans(0.0, 0.0, j[5].d) * rot_x(j[5].alpha) * chain.tool;
        let mut offsets = [0.0; 6];
        for (o, jt) in offsets.iter_mut().zip(j) {
            *o = jt.offset;
        }
        Ok(SphericalSolver {
            boom: matches!(arm, Arm::Boom(_)),
            prefix_inv: rigid_inverse(&chain.prefix),
            tail_inv: rigid_inverse(&tail),
            alpha4: j[3].alpha,
            alpha5: j[4].alpha,
            s4,
            s5: j[4].alpha.sin().signum(),
            offsets,
            arm,
        })
    }

    /// Every solution for `target` (world frame), up to 8, in [`Branch::ALL`] order; `None`
    /// for unreachable branches, with the reason. `reference` gives the free joints at the
    /// singularities (joint values, not DH angles). No allocation.
    pub fn solve_raw(
        &self,
        target: &Matrix4<f64>,
        reference: &[f64; 6],
    ) -> ([Option<RawSolution>; 8], Option<&'static str>) {
        let w = self.prefix_inv * target * self.tail_inv;
        let p = Vector3::new(w[(0, 3)], w[(1, 3)], w[(2, 3)]);
        let rw = w.fixed_view::<3, 3>(0, 0).into_owned();
        let (arms, why) = self.arm.solve(&p, reference[0] + self.offsets[0]);
        let mut out = [None; 8];
        for (ai, arm) in arms.iter().enumerate() {
            let Some(arm) = arm else { continue };
            let r36 = self.arm.r03(&arm.theta).transpose() * rw;
            let (nx, ny, nz) = (r36[(0, 2)], r36[(1, 2)], r36[(2, 2)]);
            let c5 = -nz * self.s4 * self.s5;
            let h = nx.hypot(ny);
            // Away from the singularity, θ4, θ5, θ6 in closed form (row 2 of R36 is
            // s4·(sin θ5 cos θ6, −sin θ5 sin θ6, −cos θ5 s5)) and the flip directly. Near it,
            // θ6 from the residual rotation, which absorbs the noise of θ4 exactly.
            let mut wrists = [[0.0; 3]; 2];
            let mut flags = arm.flags;
            if h > WRIST_DIRECT {
                let s5t = -self.s4 * h; // NoFlip: s4·sin θ5 ≤ 0
                let g = self.s5 * s5t.signum();
                let k = self.s4 * s5t.signum();
                let t4 = (ny * g).atan2(nx * g);
                let t5 = s5t.atan2(c5);
                let t6 = (-r36[(2, 1)] * k).atan2(r36[(2, 0)] * k);
                wrists = [[t4, t5, t6], [t4 + PI, -t5, t6 + PI]];
            } else {
                for (wi, wrist) in [Wrist::NoFlip, Wrist::Flip].into_iter().enumerate() {
                    let s5t = if wrist == Wrist::NoFlip {
                        -self.s4 * h
                    } else {
                        self.s4 * h
                    };
                    let t5 = s5t.atan2(c5);
                    let t4 = if h > WRIST_SINGULAR {
                        let g = self.s5 * s5t.signum();
                        (ny * g).atan2(nx * g)
                    } else {
                        flags.wrist_singular = true;
                        let r4 = reference[3] + self.offsets[3];
                        if wrist == Wrist::NoFlip { r4 } else { r4 + PI }
                    };
                    let partial = rz_rx(t4, self.alpha4) * rz_rx(t5, self.alpha5);
                    let rest = partial.transpose() * r36;
                    wrists[wi] = [t4, t5, rest[(1, 0)].atan2(rest[(0, 0)])];
                }
            }
            for (wi, wrist) in [Wrist::NoFlip, Wrist::Flip].into_iter().enumerate() {
                let [t4, t5, t6] = wrists[wi];
                let theta = [arm.theta[0], arm.theta[1], arm.theta[2], t4, t5, t6];
                let mut q = [0.0; 6];
                for k in 0..6 {
                    let v = theta[k] - self.offsets[k];
                    q[k] = if k == 2 && self.boom { v } else { wrap(v) };
                }
                out[2 * ai + wi] = Some(RawSolution {
                    q,
                    branch: Branch {
                        shoulder: arm.shoulder,
                        elbow: arm.elbow,
                        wrist,
                    },
                    flags,
                });
            }
        }
        (out, why)
    }
}

/// The closed-form solver as an [`IkSolver`]. With `all`, every reachable branch; otherwise the
/// one within limits (and converged) closest to `q0` (or to zero).
#[derive(Debug, Clone, Copy, Default)]
pub struct Analytic;

impl IkSolver for Analytic {
    fn method(&self) -> Method {
        Method::Analytic
    }

    fn solve(
        &self,
        robot: &Robot,
        target: &Matrix4<f64>,
        options: &IkOptions,
    ) -> Result<IkResult, IkError> {
        let mut reference = [0.0; 6];
        // `solve` has checked q0's length; a direct caller's wrong-length q0 is ignored.
        if let Some(q0) = options.q0.as_ref().filter(|q| q.len() == 6) {
            reference.copy_from_slice(q0);
        }
        let (raw, why) = match recognise(robot) {
            Family::ThreeParallel(g) => ParallelSolver::new(&g).solve_raw(target, &reference),
            family => SphericalSolver::from_family(family)?.solve_raw(target, &reference),
        };
        // A family recognised from joint axes (within RECOVERED_TOLERANCE) is solved for the
        // ideal geometry; Newton steps on the true model take the answer the rest of the way.
        let polish_steps = if recognised_from_axes(robot) {
            POLISH_STEPS
        } else {
            0
        };
        // Compiled once for every branch's polish and residual.
        let model = KinematicModel::new(robot);
        let solutions: Vec<_> = raw
            .iter()
            .flatten()
            .map(|s| {
                let mut q = s.q.to_vec();
                let steps = polish(&model, target, &mut q, polish_steps);
                finish(
                    robot,
                    &model,
                    target,
                    options,
                    q,
                    Some(s.branch),
                    steps,
                    s.flags.notes(),
                )
            })
            .collect();
        if solutions.is_empty() {
            return Err(IkError::Unreachable {
                reason: why.unwrap_or("no branch reaches the pose").to_owned(),
            });
        }
        Ok(IkResult {
            method: Method::Analytic,
            solutions: pick(solutions, options),
        })
    }
}

/// At most this many Newton steps polish a closed-form answer of a family recognised from
/// joint axes (the answer is within ~1e-11 of the true one, so one or two suffice).
pub const POLISH_STEPS: usize = 4;

/// Newton steps `J Δq = e` (base-frame Jacobian, LU) on `model` towards `target`, at most
/// `steps`, stopping when a step no longer reduces the pose error; returns the steps taken.
fn polish(model: &KinematicModel, target: &Matrix4<f64>, q: &mut [f64], steps: usize) -> usize {
    if steps == 0 {
        return 0;
    }
    let error = |q: &[f64]| pose_error(&model.forward(q), target);
    let mut e = error(q);
    let mut j = Jacobian::zeros(model.nv());
    for step in 0..steps {
        if e.amax() == 0.0 {
            return step;
        }
        model.fk_and_jacobian_into(q, &mut j);
        let j6 = nalgebra::Matrix6::from_iterator(j.iter().copied());
        let Some(dq) = j6.lu().solve(&e) else {
            return step;
        };
        let trial: Vec<f64> = q.iter().zip(dq.iter()).map(|(a, b)| a + b).collect();
        let e_trial = error(&trial);
        if e_trial.norm() >= e.norm() {
            return step;
        }
        q.copy_from_slice(&trial);
        e = e_trial;
    }
    steps
}

/// All solutions, or the single preferred one: converged and within limits first, then
/// nearest to `q0` (or zero) in the max-norm.
pub(crate) fn pick(
    mut solutions: Vec<super::IkSolution>,
    options: &IkOptions,
) -> Vec<super::IkSolution> {
    if options.all || solutions.len() <= 1 {
        return solutions;
    }
    let reference = options
        .q0
        .clone()
        .unwrap_or_else(|| vec![0.0; solutions[0].q.len()]);
    let key = |s: &super::IkSolution| {
        let d =
            s.q.iter()
                .zip(&reference)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
        (!(s.converged && s.within_limits), d)
    };
    let best = (0..solutions.len())
        .min_by(|&a, &b| {
            key(&solutions[a])
                .partial_cmp(&key(&solutions[b]))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(0);
    vec![solutions.swap_remove(best)]
}
