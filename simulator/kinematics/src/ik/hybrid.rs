//! The seed's hybrid method (§2.5, "solving for five of the six joint angles analytically and
//! using the Newton–Raphson method on one joint"): for 6R arms of the PUMA family whose wrist is
//! only nearly spherical (offsets a5, d5, a6, any α5 — see [`super::family`]).
//!
//! For a trial θ6 the pose of frame 5 is known, hence the point where axes 4 and 5 meet
//! (frame 4's origin, since A5's translation does not depend on θ5). The arm's four branches
//! follow in closed form from that point, then θ4 and θ5 from the direction of axis 5 — which
//! must lie in the plane normal to axis 4: f(θ6) = (R₃₄ᵀ-side) z-component = 0 is the one scalar
//! equation left. It is scanned on [`SAMPLES`] points per branch for sign changes and each root
//! polished by Brent's method (a safeguarded secant, more robust than the bare Newton step the
//! seed names, with the same one-unknown structure), so every solution the scan brackets is
//! found. A tangent (double) root is not bracketed and can be missed.
//!
//! Entry point: [`Hybrid`].

use super::analytic::{ArmSolver, Flags, pick, rz_rx};
use super::family::{ArmGeometry, Family, recognise};
use super::{Branch, IkError, IkOptions, IkResult, IkSolver, Method, Wrist, finish, wrap};
use crate::model::Robot;
use crate::pose::{rigid_inverse, rot_x, rot_z, trans};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};
use std::f64::consts::PI;

/// Scan points per arm branch over θ6 ∈ [−π, π].
pub const SAMPLES: usize = 48;

struct Setup {
    arm: ArmSolver,
    /// prefix⁻¹ · target · tool⁻¹ · C6⁻¹, so that T_05 = g · Rz(−θ6).
    g: Matrix4<f64>,
    /// Frame 4's origin in frame 5 (constant).
    c5: Vector4<f64>,
    alpha4: f64,
    alpha5: f64,
    s4: f64,
    offsets: [f64; 6],
}

/// θ1..θ5 and the wrist constraint for one trial θ6 and arm branch.
struct Trial {
    theta: [f64; 6],
    flags: Flags,
    branch: Option<Branch>,
}

impl Setup {
    /// The wrist constraint f(θ6) for the four arm branches at once (one arm solve).
    fn constraints(&self, t6: f64, theta1_ref: f64) -> [Option<f64>; 4] {
        let w = self.g * rot_z(-t6);
        let p4 = w * self.c5;
        let (arms, _) = self.arm.solve(&Vector3::new(p4.x, p4.y, p4.z), theta1_ref);
        // f = M[2][2] = z3 · (R05 Rx(α5)ᵀ) e_z, with z3 = R03 e_z.
        let r05: Matrix3<f64> = w.fixed_view::<3, 3>(0, 0).into_owned();
        let u = r05 * rz_rx(0.0, self.alpha5).transpose().column(2);
        arms.map(|a| a.map(|a| self.arm.r03(&a.theta).column(2).dot(&u)))
    }

    fn trial(&self, t6: f64, branch_index: usize, theta1_ref: f64) -> Option<Trial> {
        let w = self.g * rot_z(-t6);
        let p4 = w * self.c5;
        let (arms, _) = self.arm.solve(&Vector3::new(p4.x, p4.y, p4.z), theta1_ref);
        let arm = arms[branch_index]?;
        let r05: Matrix3<f64> = w.fixed_view::<3, 3>(0, 0).into_owned();
        let m = self.arm.r03(&arm.theta).transpose() * r05 * rz_rx(0.0, self.alpha5).transpose();
        // M = Rz(θ4) Rx(α4) Rz(θ5): its z column is (s4 sin θ4, −s4 cos θ4, 0).
        let t4 = (self.s4 * m[(0, 2)]).atan2(-self.s4 * m[(1, 2)]);
        let n = rz_rx(t4, self.alpha4).transpose() * m;
        let t5 = n[(1, 0)].atan2(n[(0, 0)]);
        let wrist = if self.s4 * t5.sin() <= 0.0 {
            Wrist::NoFlip
        } else {
            Wrist::Flip
        };
        Some(Trial {
            theta: [arm.theta[0], arm.theta[1], arm.theta[2], t4, t5, t6],
            flags: arm.flags,
            branch: Some(Branch {
                shoulder: arm.shoulder,
                elbow: arm.elbow,
                wrist,
            }),
        })
    }
}

/// The hybrid solver as an [`IkSolver`]; applies to both wrist families.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hybrid;

fn setup(robot: &Robot, target: &Matrix4<f64>) -> Result<Setup, IkError> {
    let arm: ArmGeometry = match recognise(robot) {
        Family::SphericalWrist(a) | Family::OffsetWrist(a) => a,
        Family::BoomWrist(_) => {
            return Err(IkError::NotApplicable {
                method: "hybrid",
                reason: "an RRP arm: solved by the analytic method".into(),
            });
        }
        Family::General(reason) => {
            return Err(IkError::NotApplicable {
                method: "hybrid",
                reason,
            });
        }
    };
    let j = &arm.chain.joints;
    let c6 = trans(0.0, 0.0, j[5].d) * trans(j[5].a, 0.0, 0.0) * rot_x(j[5].alpha);
    let c5 = trans(0.0, 0.0, j[4].d) * trans(j[4].a, 0.0, 0.0) * rot_x(j[4].alpha);
    let mut offsets = [0.0; 6];
    for (o, jt) in offsets.iter_mut().zip(j) {
        *o = jt.offset;
    }
    Ok(Setup {
        g: rigid_inverse(&arm.chain.prefix)
            * target
            * rigid_inverse(&arm.chain.tool)
            * rigid_inverse(&c6),
        c5: rigid_inverse(&c5) * Vector4::new(0.0, 0.0, 0.0, 1.0),
        alpha4: j[3].alpha,
        alpha5: j[4].alpha,
        s4: arm.s4,
        offsets,
        arm: ArmSolver::new(&arm),
    })
}

/// Brent's root finder on [a, b] with f(a)·f(b) < 0 (Brent 1973; as in Numerical Recipes
/// `zbrent`). Returns the root and the iterations used.
fn brent(
    mut f: impl FnMut(f64) -> Option<f64>,
    mut a: f64,
    mut b: f64,
    mut fa: f64,
    mut fb: f64,
) -> Option<(f64, usize)> {
    let (mut c, mut fc) = (b, fb);
    let (mut d, mut e) = (b - a, b - a);
    for it in 1..=100 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + 1e-16;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol || fb == 0.0 {
            return Some((b, it));
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            if 2.0 * p < (3.0 * xm * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol.copysign(xm) };
        fb = f(b)?;
    }
    Some((b, 100))
}

impl IkSolver for Hybrid {
    fn method(&self) -> Method {
        Method::Hybrid
    }

    fn solve(
        &self,
        robot: &Robot,
        target: &Matrix4<f64>,
        options: &IkOptions,
    ) -> Result<IkResult, IkError> {
        let s = setup(robot, target)?;
        let theta1_ref = options
            .q0
            .as_ref()
            .and_then(|q| q.first())
            .copied()
            .unwrap_or(0.0)
            + s.offsets[0];
        let mut solutions = Vec::new();
        let mut any_reachable = false;
        let table: Vec<(f64, [Option<f64>; 4])> = (0..=SAMPLES)
            .map(|k| {
                let t = -PI + 2.0 * PI * k as f64 / SAMPLES as f64;
                (t, s.constraints(t, theta1_ref))
            })
            .collect();
        for bi in 0..4 {
            let grid: Vec<(f64, Option<f64>)> = table.iter().map(|(t, f)| (*t, f[bi])).collect();
            let mut roots: Vec<(f64, usize)> = Vec::new();
            for win in grid.windows(2) {
                let ((ta, fa), (tb, fb)) = (win[0], win[1]);
                let (Some(fa), Some(fb)) = (fa, fb) else {
                    continue;
                };
                any_reachable = true;
                if fa == 0.0 {
                    roots.push((ta, 0));
                } else if (fa > 0.0) != (fb > 0.0) && fb != 0.0 {
                    let f = |t: f64| s.constraints(t, theta1_ref)[bi];
                    if let Some(r) = brent(f, ta, tb, fa, fb) {
                        roots.push(r);
                    }
                }
            }
            for (t6, iterations) in roots {
                let Some(tr) = s.trial(t6, bi, theta1_ref) else {
                    continue;
                };
                let q: Vec<f64> = (0..6).map(|k| wrap(tr.theta[k] - s.offsets[k])).collect();
                // The grid's last point equals its first (θ6 = ±π): skip a root found twice.
                let dup = solutions.iter().any(|o: &super::IkSolution| {
                    o.branch == tr.branch
                        && o.q.iter().zip(&q).all(|(a, b)| wrap(a - b).abs() < 1e-9)
                });
                if !dup {
                    solutions.push(finish(
                        robot,
                        target,
                        options,
                        q,
                        tr.branch,
                        iterations,
                        tr.flags.notes(),
                    ));
                }
            }
        }
        if solutions.is_empty() {
            let reason = if any_reachable {
                format!(
                    "no θ6 on a {SAMPLES}-point scan satisfies the wrist constraint for any arm branch"
                )
            } else {
                "the wrist point is out of the arm's reach for every θ6".to_owned()
            };
            return Err(IkError::Unreachable { reason });
        }
        Ok(IkResult {
            method: Method::Hybrid,
            solutions: pick(solutions, options),
        })
    }
}
