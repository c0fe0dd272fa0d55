//! All closed-form solutions (up to 8) of the UR type ([`Family::ThreeParallel`]: axes 2, 3 and
//! 4 parallel; see [`super::family`]), after Hawkins, "Analytic Inverse Kinematics for the
//! Universal Robots UR-5/UR-10 Arms" (2013), written for any signs of α1, α4, α5, any a1, a4,
//! d1..d6 and any tail (a6, α6, tool) — in standard DH angles θ, offsets removed at the end.
//!
//! With W = prefix⁻¹ · target · (Tz(d6) Tx(a6) Rx(α6) · tool)⁻¹ = A1 ⋯ A5 · Rz(θ6), p its
//! origin (= frame 5's) and z its z axis (= z5):
//! * θ1 from p · z1(θ1) = d2 + d3 + d4 (everything else of the arm is ⊥ z1): two roots, shoulder
//!   `Right` = ψ + asin k, `Left` = ψ + π − asin k, ψ = atan2(py, px), k = sin α1 (d2+d3+d4)/ρ;
//! * θ5 from z5 · z1 = −sin α4 sin α5 cos θ5: wrist `NoFlip` = +acos, `Flip` = −acos;
//! * θ6 from z1 seen in W (needs sin θ5 ≠ 0; at the wrist singularity θ6 is the reference's,
//!   [`Note::WristSingular`]);
//! * θ2, θ3, θ4 from A2 A3 A4 = A1⁻¹ W Rz(θ6)⁻¹ A5⁻¹, a planar 2-link problem: elbow `Up` =
//!   +acos for θ3, `Down` = −acos.
//!
//! Rounding at the boundary as in [`super::analytic`] ([`CLAMP_SLACK`]).

use super::closed_form::{CLAMP_SLACK, Flags, RawSolution, WRIST_SINGULAR};
use super::family::ParallelGeometry;
use super::{Branch, Elbow, Shoulder, Wrist, wrap};
use crate::pose::{rigid_inverse, rot_x, rot_z, trans};
use nalgebra::Matrix4;
use std::f64::consts::PI;

/// A standard DH link Rz(θ) Tz(d) Tx(a) Rx(α).
fn dh(theta: f64, d: f64, a: f64, alpha: f64) -> Matrix4<f64> {
    rot_z(theta) * trans(a, 0.0, d) * rot_x(alpha)
}

/// `acos`/`asin` argument clamped within [`CLAMP_SLACK`] (the excess reported), `None` beyond.
fn clamp(x: f64) -> Option<(f64, Option<f64>)> {
    if x.abs() <= 1.0 {
        Some((x, None))
    } else if x.abs() <= 1.0 + CLAMP_SLACK {
        Some((x.signum(), Some(x.abs() - 1.0)))
    } else {
        None
    }
}

/// Precomputed per robot (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ParallelSolver {
    prefix_inv: Matrix4<f64>,
    tail_inv: Matrix4<f64>,
    /// (d, a, α) of the six rows.
    rows: [(f64, f64, f64); 6],
    offsets: [f64; 6],
    s1: f64,
    s4: f64,
    s5: f64,
}

impl ParallelSolver {
    pub fn new(g: &ParallelGeometry) -> ParallelSolver {
        let j = &g.chain.joints;
        let tail = trans(j[5].a, 0.0, j[5].d) * rot_x(j[5].alpha) * g.chain.tool;
        let mut rows = [(0.0, 0.0, 0.0); 6];
        let mut offsets = [0.0; 6];
        for ((row, offset), jt) in rows.iter_mut().zip(offsets.iter_mut()).zip(j) {
            *row = (jt.d, jt.a, jt.alpha);
            *offset = jt.offset;
        }
        ParallelSolver {
            prefix_inv: rigid_inverse(&g.chain.prefix),
            tail_inv: rigid_inverse(&tail),
            rows,
            offsets,
            s1: g.s1,
            s4: g.s4,
            s5: g.s5,
        }
    }

    fn link(&self, k: usize, theta: f64) -> Matrix4<f64> {
        let (d, a, alpha) = self.rows[k];
        dh(theta, d, a, alpha)
    }

    /// Every solution for `target`, in the order shoulder (Right, Left) × wrist (NoFlip, Flip)
    /// × elbow (Up, Down); `None` for unreachable branches, with the reason. `reference` (joint
    /// values) gives θ6 at the wrist singularity.
    pub fn solve_raw(
        &self,
        target: &Matrix4<f64>,
        reference: &[f64; 6],
    ) -> ([Option<RawSolution>; 8], Option<&'static str>) {
        let mut out = [None; 8];
        let mut why = None;
        let w = self.prefix_inv * target * self.tail_inv;
        let (px, py) = (w[(0, 3)], w[(1, 3)]);
        let rho = px.hypot(py);
        let lateral = self.rows[1].0 + self.rows[2].0 + self.rows[3].0;
        let Some((k, k_excess)) = clamp(if rho > 0.0 {
            self.s1 * lateral / rho
        } else {
            f64::INFINITY
        }) else {
            return (
                out,
                Some("the wrist point is inside the shoulder-offset cylinder"),
            );
        };
        let psi = py.atan2(px);
        let asin_k = k.asin();
        let (a2, a3, a4) = (self.rows[1].1, self.rows[2].1, self.rows[3].1);
        for (si, (shoulder, t1)) in [
            (Shoulder::Right, psi + asin_k),
            (Shoulder::Left, psi + PI - asin_k),
        ]
        .into_iter()
        .enumerate()
        {
            let (s1t, c1t) = t1.sin_cos();
            // z1 = (sin α1 sin θ1, −sin α1 cos θ1, 0) in frame 0.
            let z1 = nalgebra::Vector3::new(self.s1 * s1t, -self.s1 * c1t, 0.0);
            let rw = w.fixed_view::<3, 3>(0, 0);
            let z5 = rw.column(2);
            // (Beyond ±1 only by rounding: z5 and z1 are unit vectors.)
            let Some((c5, _)) = clamp(-self.s4 * self.s5 * z5.dot(&z1)) else {
                why = Some("the tool axis cannot be reached (|cos θ5| > 1)");
                continue;
            };
            // y4 = sin α4 · z1, in W's axes: (cos θ6 sin θ5, −sin θ6 sin θ5, ·).
            let v = rw.transpose() * (z1 * self.s4);
            let a1_inv = rigid_inverse(&self.link(0, t1));
            for (wi, (wrist, t5)) in [(Wrist::NoFlip, c5.acos()), (Wrist::Flip, -c5.acos())]
                .into_iter()
                .enumerate()
            {
                let mut flags = Flags {
                    shoulder_clamped: k_excess,
                    ..Flags::default()
                };
                let s5t = t5.sin();
                let t6 = if s5t.abs() > WRIST_SINGULAR {
                    (-v.y / s5t).atan2(v.x / s5t)
                } else {
                    flags.wrist_singular = true;
                    reference[5] + self.offsets[5]
                };
                let t14 = a1_inv * w * rot_z(-t6) * rigid_inverse(&self.link(4, t5));
                let t234 = t14[(1, 0)].atan2(t14[(0, 0)]);
                let x = t14[(0, 3)] - a4 * t234.cos();
                let y = t14[(1, 3)] - a4 * t234.sin();
                let Some((c3, c3_excess)) =
                    clamp((x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3))
                else {
                    why = Some("the wrist is out of the arm's reach");
                    continue;
                };
                for (ei, (elbow, t3)) in [(Elbow::Up, c3.acos()), (Elbow::Down, -c3.acos())]
                    .into_iter()
                    .enumerate()
                {
                    let t2 = y.atan2(x) - (a3 * t3.sin()).atan2(a2 + a3 * t3.cos());
                    let t4 = t234 - t2 - t3;
                    let theta = [t1, t2, t3, t4, t5, t6];
                    let mut q = [0.0; 6];
                    for ((qi, t), o) in q.iter_mut().zip(theta).zip(self.offsets) {
                        *qi = wrap(t - o);
                    }
                    let mut flags = flags;
                    if let Some(e) = c3_excess {
                        flags.elbow_clamped = Some(e);
                    }
                    out[4 * si + 2 * wi + ei] = Some(RawSolution {
                        q,
                        branch: Branch {
                            shoulder,
                            elbow,
                            wrist,
                        },
                        flags,
                    });
                }
            }
        }
        (out, why)
    }
}
