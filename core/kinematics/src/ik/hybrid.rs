//! The seed's hybrid method (§2.5, "solving for five of the six joint angles analytically and
//! using the Newton–Raphson method on one joint"): for 6R arms of the PUMA family whose wrist is
//! only nearly spherical (offsets a5, d5, a6, any α5 — see [`super::family`]).
//!
//! For a trial θ6 the pose of frame 5 is known, hence the point where axes 4 and 5 meet
//! (frame 4's origin, since A5's translation does not depend on θ5). The arm's four branches
//! follow in closed form from that point, then θ4 and θ5 from the direction of axis 5 — which
//! must lie in the plane normal to axis 4: f(θ6) = M₂₂ = 0 is the one scalar equation left.
//! Each root is polished by Brent's method (a safeguarded secant, more robust than the bare
//! Newton step the seed names, with the same one-unknown structure). Finding every root:
//! * the arm is evaluated on its clamped extension, so f is defined and continuous for every θ6;
//!   only roots where the arm truly reaches are kept;
//! * f is scanned on [`SAMPLES`] points per branch for sign changes;
//! * where the arm's reach ends inside a scan interval, the edge is found by bisection and the
//!   reachable part sampled uniformly in √(distance to the edge) ([`EDGE_SAMPLES`] points):
//!   there the elbow branches merge, f behaves like a square root, and roots crowd in pairs;
//! * where f keeps its sign over an interval but heads towards zero at one end and away at the
//!   other (slopes by forward differences), a golden-section search looks for a dip through
//!   zero and brackets both roots.
//!
//! What can still be missed: a tangent (double) root, and a root pair inside a scan interval
//! that also contains a narrow hole in the arm's reach (1 generating configuration in 2,000
//! random poses of an offset-wrist PUMA).
//!
//! Entry point: [`Hybrid`].

use super::analytic::{ArmSolver, pick, rz_rx};
use super::closed_form::{CLAMP_SLACK, Flags};
use super::family::{ArmGeometry, Family, recognise};
use super::{
    Branch, IkError, IkOptions, IkResult, IkSolution, IkSolver, Method, Wrist, finish, wrap,
};
use crate::kinematic_model::KinematicModel;
use crate::model::Robot;
use crate::pose::{rigid_inverse, rot_x, rot_z, trans};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};
use std::f64::consts::PI;

/// Extra samples (uniform in √distance) between a scan point and the edge of the arm's reach.
pub const EDGE_SAMPLES: usize = 24;

/// f(θ6) and "really reaches" for the four arm branches (None: no arm solution at all).
type BranchValues = [Option<(f64, bool)>; 4];

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
        self.constraints_reach(t6, theta1_ref)
            .map(|c| c.map(|(f, _)| f))
    }

    /// f(θ6) of the four branches on the extended arm, each with whether the branch truly
    /// reaches (clamp excess within [`CLAMP_SLACK`]).
    fn constraints_reach(&self, t6: f64, theta1_ref: f64) -> BranchValues {
        let w = self.g * rot_z(-t6);
        let p4 = w * self.c5;
        let (arms, _) = self
            .arm
            .solve_ext(&Vector3::new(p4.x, p4.y, p4.z), theta1_ref, true);
        // f = M[2][2] = z3 · (R05 Rx(α5)ᵀ) e_z, with z3 = R03 e_z.
        let r05: Matrix3<f64> = w.fixed_view::<3, 3>(0, 0).into_owned();
        let u = r05 * rz_rx(0.0, self.alpha5).transpose().column(2);
        arms.map(|a| {
            a.map(|a| {
                let excess = a
                    .flags
                    .elbow_clamped
                    .unwrap_or(0.0)
                    .max(a.flags.shoulder_clamped.unwrap_or(0.0));
                (
                    self.arm.r03(&a.theta).column(2).dot(&u),
                    excess <= CLAMP_SLACK,
                )
            })
        })
    }

    fn trial(&self, t6: f64, branch_index: usize, theta1_ref: f64) -> Option<Trial> {
        let w = self.g * rot_z(-t6);
        let p4 = w * self.c5;
        let (arms, _) = self
            .arm
            .solve_ext(&Vector3::new(p4.x, p4.y, p4.z), theta1_ref, true);
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
        Family::ThreeParallel(_) => {
            return Err(IkError::NotApplicable {
                method: "hybrid",
                reason: "a UR-type arm (three parallel axes): solved by the analytic method".into(),
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

/// Forward-difference step of the slopes that spot dips between two samples of one sign.
const SLOPE_STEP: f64 = 1e-7;

/// The scan grid: f(θ6) and reach of the four branches at `SAMPLES` + 1 points over [−π, π].
fn scan(s: &Setup, theta1_ref: f64) -> Vec<(f64, BranchValues)> {
    (0..=SAMPLES)
        .map(|k| {
            let t = -PI + 2.0 * PI * k as f64 / SAMPLES as f64;
            (t, s.constraints_reach(t, theta1_ref))
        })
        .collect()
}

/// Slopes by a forward difference at every scan point, to spot dips between two samples of
/// one sign.
fn slopes(s: &Setup, theta1_ref: f64, table: &[(f64, BranchValues)]) -> Vec<[Option<f64>; 4]> {
    table
        .iter()
        .map(|(t, c)| {
            let ahead = s.constraints(t + SLOPE_STEP, theta1_ref);
            std::array::from_fn(|b| match (c[b], ahead[b]) {
                (Some((f0, _)), Some(f1)) => Some((f1 - f0) / SLOPE_STEP),
                _ => None,
            })
        })
        .collect()
}

/// One arm branch of the scan: its f(θ6) and reach, and the root searches over the grid.
#[derive(Clone, Copy)]
struct BranchScan<'a> {
    s: &'a Setup,
    theta1_ref: f64,
    bi: usize,
}

impl BranchScan<'_> {
    fn f(&self, t: f64) -> Option<f64> {
        self.s.constraints(t, self.theta1_ref)[self.bi]
    }

    fn reach(&self, t: f64) -> bool {
        self.s.constraints_reach(t, self.theta1_ref)[self.bi].is_some_and(|(_, r)| r)
    }

    /// Roots bracketed by a sign change between two scan points, and those near the reach
    /// edge ([`Self::edge_roots`]). Returns whether any scan interval was within reach.
    fn sign_change_roots(
        &self,
        table: &[(f64, BranchValues)],
        roots: &mut Vec<(f64, usize)>,
    ) -> bool {
        let bi = self.bi;
        let f = |t: f64| self.f(t);
        let mut any_reachable = false;
        for win in table.windows(2) {
            let (ta, ca, tb, cb) = (win[0].0, win[0].1[bi], win[1].0, win[1].1[bi]);
            let (Some((fa, ra)), Some((fb, rb))) = (ca, cb) else {
                continue;
            };
            // Only the reachable part of the interval can hold a solution. Where reach
            // ends inside it, bisect to the edge: true roots near the workspace boundary
            // sit close to spurious ones of the clamped extension beyond it.
            let (ta, fa, tb, fb) = match (ra, rb) {
                (true, true) => (ta, fa, tb, fb),
                (false, false) => continue,
                (true, false) | (false, true) => {
                    any_reachable = true;
                    self.edge_roots(ta, ra, tb, roots);
                    continue;
                }
            };
            any_reachable = true;
            if fa == 0.0 {
                roots.push((ta, 0));
            } else if fb == 0.0 && !rb {
                roots.push((tb, 0));
            } else if (fa > 0.0) != (fb > 0.0)
                && fb != 0.0
                && let Some(r) = brent(f, ta, tb, fa, fb)
            {
                roots.push(r);
            }
        }
        any_reachable
    }

    /// The roots of a scan interval [ta, tb] where reach ends inside it (`ra`: ta is the
    /// reachable end).
    fn edge_roots(&self, ta: f64, ra: bool, tb: f64, roots: &mut Vec<(f64, usize)>) {
        let f = |t: f64| self.f(t);
        let (mut inside, mut outside) = if ra { (ta, tb) } else { (tb, ta) };
        for _ in 0..60 {
            let mid = 0.5 * (inside + outside);
            if self.reach(mid) {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        // At the reach edge the elbow branches merge and f(θ6) behaves like
        // √(distance to the edge): sample uniformly in that square root, where f
        // is smooth, to separate roots crowding the edge.
        let far = if ra { ta } else { tb };
        let pts: Vec<(f64, f64)> = (0..=EDGE_SAMPLES)
            .filter_map(|i| {
                let u = i as f64 / EDGE_SAMPLES as f64;
                let t = inside + (far - inside) * u * u;
                f(t).map(|v| (t, v))
            })
            .collect();
        for w in pts.windows(2) {
            let ((t0, f0), (t1, f1)) = (w[0], w[1]);
            if f0 == 0.0 {
                roots.push((t0, 0));
            } else if (f0 > 0.0) != (f1 > 0.0)
                && f1 != 0.0
                && let Some(r) = brent(f, t0, t1, f0, f1)
            {
                roots.push(r);
            }
        }
    }

    /// A pair of roots closer than the scan step leaves no sign change. Where f keeps
    /// its sign over an interval but heads towards zero at the start and away at the
    /// end, a golden-section search finds the dip; if it crosses zero, both roots are
    /// bracketed.
    fn dip_roots(
        &self,
        table: &[(f64, BranchValues)],
        slopes: &[[Option<f64>; 4]],
        roots: &mut Vec<(f64, usize)>,
    ) {
        let bi = self.bi;
        let f = |t: f64| self.f(t);
        for k in 0..table.len() - 1 {
            let c = |i: usize| table[i].1[bi].filter(|(_, r)| *r).map(|(f, _)| f);
            let (Some(f0), Some(f2)) = (c(k), c(k + 1)) else {
                continue;
            };
            let (Some(d0), Some(d2)) = (slopes[k][bi], slopes[k + 1][bi]) else {
                continue;
            };
            let sign = f0.signum();
            if f2.signum() != sign || sign * d0 >= 0.0 || sign * d2 <= 0.0 {
                continue;
            }
            let (tl, tr) = (table[k].0, table[k + 1].0);
            let (mut a, mut b) = (tl, tr);
            let g = 0.5 * (5f64.sqrt() - 1.0);
            let h = |t: f64| f(t).map_or(f64::INFINITY, |v| sign * v);
            let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
            let (mut h1, mut h2) = (h(x1), h(x2));
            for _ in 0..50 {
                if h1.min(h2) < 0.0 {
                    break;
                }
                if h1 < h2 {
                    b = x2;
                    x2 = x1;
                    h2 = h1;
                    x1 = b - g * (b - a);
                    h1 = h(x1);
                } else {
                    a = x1;
                    x1 = x2;
                    h1 = h2;
                    x2 = a + g * (b - a);
                    h2 = h(x2);
                }
            }
            let (tm, hm) = if h1 < h2 { (x1, h1) } else { (x2, h2) };
            if hm < 0.0 && self.reach(tm) {
                let fm = sign * hm;
                for (lo, flo, hi, fhi) in [(tl, f0, tm, fm), (tm, fm, tr, f2)] {
                    if let Some(r) = brent(f, lo, hi, flo, fhi) {
                        roots.push(r);
                    }
                }
            }
        }
    }

    /// The solutions of the roots found on this branch, within the arm's reach and not
    /// found already, appended to `solutions`.
    fn add_solutions(
        &self,
        roots: Vec<(f64, usize)>,
        robot: &Robot,
        model: &KinematicModel,
        target: &Matrix4<f64>,
        options: &IkOptions,
        solutions: &mut Vec<IkSolution>,
    ) {
        let s = self.s;
        for (t6, iterations) in roots {
            let Some(tr) = s.trial(t6, self.bi, self.theta1_ref) else {
                continue;
            };
            // A root of the extension outside the arm's reach is no solution.
            let excess = tr
                .flags
                .elbow_clamped
                .unwrap_or(0.0)
                .max(tr.flags.shoulder_clamped.unwrap_or(0.0));
            if excess > CLAMP_SLACK {
                continue;
            }
            let q: Vec<f64> = (0..6).map(|k| wrap(tr.theta[k] - s.offsets[k])).collect();
            // The grid's last point equals its first (θ6 = ±π): skip a root found twice.
            let dup = solutions.iter().any(|o: &IkSolution| {
                o.branch == tr.branch && o.q.iter().zip(&q).all(|(a, b)| wrap(a - b).abs() < 1e-9)
            });
            if !dup {
                solutions.push(finish(
                    robot,
                    model,
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
        // Compiled once for every root's residual.
        let model = KinematicModel::new(robot);
        let theta1_ref = options
            .q0
            .as_ref()
            .and_then(|q| q.first())
            .copied()
            .unwrap_or(0.0)
            + s.offsets[0];
        let mut solutions = Vec::new();
        let mut any_reachable = false;
        let table = scan(&s, theta1_ref);
        let slopes = slopes(&s, theta1_ref, &table);
        for bi in 0..4 {
            let branch = BranchScan {
                s: &s,
                theta1_ref,
                bi,
            };
            let mut roots: Vec<(f64, usize)> = Vec::new();
            let reached = branch.sign_change_roots(&table, &mut roots);
            any_reachable |= reached;
            branch.dip_roots(&table, &slopes, &mut roots);
            branch.add_solutions(roots, robot, &model, target, options, &mut solutions);
        }
        if solutions.is_empty() {
            let reason = if any_reachable {
                format!(
                    "no θ6 on a {SAMPLES}-point scan puts the wrist point within the arm's reach and satisfies the wrist constraint"
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
