//! Alternating exact projections (von Neumann) to tighten GJK's *upper* bound where it
//! converges slowly: curved contacts between boxes, cylinders and cones. From GJK's closest
//! points (a ∈ A, b ∈ B) it repeats b ← P_B(a), a ← P_A(b), with P the closed-form point
//! projections of parry 0.25.3 (`Cuboid`, `Cylinder`, `Cone`; see [`super::sphere`]). Every
//! pair (a, b) so produced is a point of each solid up to rounding, so `|a − b|` is an upper
//! bound of the distance exactly like GJK's; the best one replaces GJK's when smaller, and the
//! verdict is re-taken with GJK's rules ([`super::gjk`]): touching when the upper bound is at
//! most max(τ, CONTACT_BAND), apart-and-converged when the lower bound (unchanged, GJK's
//! separating plane) exceeds τ and the bracket is within the tolerance. Nothing else is
//! decided here. Hulls (`ConvexPolyhedron`, whose parry projection is iterative) are projected
//! exactly by enumerating their faces' fan triangles ([`project_hull`]). A closest point on the
//! rim of a cylinder or a cone's base is refined by a golden-section search over the rim angle
//! ([`rim`]), where alternating projections stall (curved tangency on both sides).
//!
//! Entry point: [`refine`].

use super::gjk::{CONTACT_BAND, Separation, Verdict, triangle};
use nalgebra::{Isometry3, Point3};
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{ConvexPolyhedron, Shape};

/// Alternations tried (each two projections, closed form).
pub(crate) const MAX_ALTERNATIONS: usize = 400;

/// Exact projection onto a convex hull (solid): `p` itself when inside every face plane,
/// otherwise the closest point over the fan triangles of its faces (Ericson's closest point on
/// a triangle, [`super::gjk::triangle`]) — faces, edges and vertices enumerated, no iteration.
/// Every point returned is a convex combination of hull vertices (in the hull to rounding).
fn project_hull(h: &ConvexPolyhedron, p: &Point3<f64>) -> Point3<f64> {
    let (pts, adj) = (h.points(), h.vertices_adj_to_face());
    let face = |first: u32, n: u32| &adj[first as usize..(first + n) as usize];
    let inside = h.faces().iter().all(|f| {
        let v = pts[face(f.first_vertex_or_edge, f.num_vertices_or_edges)[0] as usize];
        f.normal.dot(&(*p - v)) <= 0.0
    });
    if inside {
        return *p;
    }
    let mut best = (f64::INFINITY, *p);
    for f in h.faces() {
        let ids = face(f.first_vertex_or_edge, f.num_vertices_or_edges);
        for k in 1..ids.len().saturating_sub(1) {
            let (a, b, c) = (
                pts[ids[0] as usize],
                pts[ids[k] as usize],
                pts[ids[k + 1] as usize],
            );
            let l = triangle(a - p, b - p, c - p);
            let q = Point3::from(a.coords * l[0] + b.coords * l[1] + c.coords * l[2]);
            let d = (q - p).norm_squared();
            if d < best.0 {
                best = (d, q);
            }
        }
    }
    best.1
}

/// Closed-form projection (solid: a point inside projects to itself), shape frame; hulls by
/// face enumeration ([`project_hull`]).
fn project(s: &dyn Shape, p: &Point3<f64>) -> Option<Point3<f64>> {
    if let Some(h) = s.as_convex_polyhedron() {
        return Some(project_hull(h, p));
    }
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
    rim(s, pos12, sa, sb, false);
    rim(s, pos12, sb, sa, true);
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

/// A closest point on the rim of a cylinder or a cone's base converges slowly under alternating
/// projections (the tangency is curved on both sides). When `s`'s closest point on the rim
/// shape is on its rim, minimise |c(φ) − P_other(c(φ))| over the rim angle φ by golden-section
/// search in ±1e-3 rad around it; every pair evaluated is a point of each solid, so the best
/// one is an upper bound like the others. `swapped`: the rim shape is B (`sr` = sb).
fn rim(s: &mut Separation, pos12: &Isometry3<f64>, sr: &dyn Shape, so: &dyn Shape, swapped: bool) {
    // Rim point in the rim shape's frame; the other shape's frame map.
    let p = if swapped {
        pos12.inverse_transform_point(&s.pb)
    } else {
        s.pa
    };
    if super::lower::kink_tangent(sr, &p).is_none() || sr.as_cuboid().is_some() {
        return;
    }
    let (r, y) = if let Some(c) = sr.as_cylinder() {
        (
            c.radius,
            if p.y >= 0.0 {
                c.half_height
            } else {
                -c.half_height
            },
        )
    } else if let Some(k) = sr.as_cone() {
        (k.radius, -k.half_height)
    } else {
        return;
    };
    // rim shape frame → other shape frame
    let to_other = if swapped { *pos12 } else { pos12.inverse() };
    let mut f = |phi: f64| -> f64 {
        let c = Point3::new(r * phi.cos(), y, r * phi.sin());
        let Some(q) = project(so, &(to_other * c)) else {
            return f64::INFINITY;
        };
        let q = to_other.inverse_transform_point(&q);
        let d = (c - q).norm();
        if d.is_finite() && d < s.upper {
            let (ca, cb) = if swapped {
                (pos12 * q, pos12 * c)
            } else {
                (c, q)
            };
            (s.upper, s.pa, s.pb) = (d, ca, cb);
        }
        d
    };
    let phi0 = p.z.atan2(p.x);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (phi0 - 1e-3, phi0 + 1e-3);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..90 {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
}
