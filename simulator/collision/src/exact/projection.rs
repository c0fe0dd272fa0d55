//! Alternating exact projections (von Neumann) to tighten GJK's *upper* bound where it
//! converges slowly: curved contacts between boxes, cylinders and cones. From GJK's closest
//! points (a ∈ A, b ∈ B) it repeats b ← P_B(a), a ← P_A(b), with P the closed-form point
//! projections of parry 0.25.3 (`Cuboid`, `Cylinder`, `Cone`; see [`super::sphere`]). Every
//! pair (a, b) so produced is a point of each solid up to rounding, so `|a − b|` is an upper
//! bound of the distance exactly like GJK's; the best one replaces GJK's when smaller, and the
//! verdict is re-taken with GJK's rules ([`super::gjk`]): touching when the upper bound is at
//! most max(τ, CONTACT_BAND), apart-and-converged when the lower bound (unchanged, GJK's
//! separating plane) exceeds τ and the bracket is within the tolerance. Nothing else is
//! decided here; hulls (`ConvexPolyhedron`, whose projection is iterative) are left alone.
//!
//! Entry point: [`refine`].

use super::gjk::{CONTACT_BAND, Separation, Verdict};
use nalgebra::{Isometry3, Point3};
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::Shape;

/// Alternations tried (each two projections, closed form).
pub(crate) const MAX_ALTERNATIONS: usize = 400;

/// Closed-form projection (solid: a point inside projects to itself), shape frame.
fn project(s: &dyn Shape, p: &Point3<f64>) -> Option<Point3<f64>> {
    if let Some(b) = s.as_cuboid() {
        Some(b.project_local_point(p, true).point)
    } else if let Some(c) = s.as_cylinder() {
        Some(c.project_local_point(p, true).point)
    } else {
        s.as_cone().map(|k| k.project_local_point(p, true).point)
    }
}

/// Tightens `s` (A's frame; `pos12` places B in A's frame) by alternating projections when
/// both shapes have closed-form projections; re-takes the verdict. No-op otherwise.
pub(crate) fn refine(
    s: &mut Separation,
    pos12: &Isometry3<f64>,
    sa: &dyn Shape,
    sb: &dyn Shape,
    distance: bool,
    tolerance: f64,
) {
    if project(sa, &Point3::origin()).is_none() || project(sb, &Point3::origin()).is_none() {
        return;
    }
    let mut a = s.pa;
    let mut previous = f64::INFINITY;
    for _ in 0..MAX_ALTERNATIONS {
        let Some(bl) = project(sb, &pos12.inverse_transform_point(&a)) else {
            return;
        };
        let b = pos12 * bl;
        let Some(a2) = project(sa, &b) else {
            return;
        };
        a = a2;
        let upper = (a - b).norm();
        if !upper.is_finite() {
            return;
        }
        if upper < s.upper {
            (s.upper, s.pa, s.pb) = (upper, a, b);
        }
        // No progress (a fixed point, up to rounding): stop.
        if upper.is_nan() || upper >= previous {
            break;
        }
        previous = upper;
        if s.upper <= s.tau.max(CONTACT_BAND) {
            break;
        }
        if s.lower > s.tau && s.upper - s.lower <= tolerance.max(s.tau) {
            break;
        }
    }
    if s.upper <= s.tau.max(CONTACT_BAND) {
        s.verdict = Verdict::Touching;
        s.converged = true;
    } else if s.lower > s.tau {
        s.converged = s.upper - s.lower <= tolerance.max(s.tau);
        if s.converged || !distance {
            s.verdict = Verdict::Apart;
        }
    }
}
