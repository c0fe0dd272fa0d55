//! Tightens GJK's *lower* bound, the weak side of the bracket at 1e-9 m gaps on curved and
//! large pairs: GJK's search direction is v/|v| with v a combination of support points of size
//! ~L, so at a gap g its direction is only good to ~ε L / g (1e-5 rad at 100 m, 1e-9 m), and
//! across a flat or long contact the separating-plane bound loses ~L × that.
//!
//! The bound itself is unchanged: for any unit u, `ℓ(u) = min_{a∈A} u·a − max_{b∈B} u·b`
//! (u from B towards A, as in [`super::gjk`]) is a certified lower bound of the signed
//! distance, up to the rounding allowance τ. Here ℓ is maximised over the sphere of
//! directions: candidates (GJK's best u, the direction between the closest points found, the
//! face normals of boxes and hulls, the axes of cylinders and cones, the side normal of a
//! cylinder or cone at its closest point, both signs; each also made orthogonal to the *kink
//! tangents* at the closest points — rim tangent, box or hull edge — since the best u lies in
//! the normal cone there, and the cross product of two such tangents), a 1-D search on the
//! great circle orthogonal to a single kink tangent (the ridge of ℓ), then a compass search on the sphere (eight tangent directions, rotated by the golden angle at
//! every step so a ridge of the piecewise-smooth ℓ is not followed forever, step halved on
//! failure down to 1e-17 rad). Only the value of the best u found is used, so the search needs
//! no convergence proof to be sound. The verdict is then re-taken with GJK's rules.
//!
//! Entry point: [`refine`].

use super::gjk::{CONTACT_BAND, ROUNDING, Separation, Verdict};
use nalgebra::{Isometry3, Vector3};
use parry3d_f64::shape::{Shape, SupportMap};

/// Compass-search steps per refinement (eight support-function pairs each).
const MAX_STEPS: usize = 500;

/// ℓ(u) and the coordinate magnitude |a| + |b| of the two support points (for τ).
fn ell(
    pos12: &Isometry3<f64>,
    ma: &dyn SupportMap,
    mb: &dyn SupportMap,
    u: &Vector3<f64>,
) -> (f64, f64) {
    let a = ma.local_support_point(&-u);
    let b = mb.support_point(pos12, u);
    ((a - b).dot(u), a.coords.norm() + b.coords.norm())
}

/// Face normals and axes of `s` in its own frame (both signs are tried by the caller).
fn special_directions(s: &dyn Shape, out: &mut Vec<Vector3<f64>>) {
    if s.as_cuboid().is_some() {
        out.extend([Vector3::x(), Vector3::y(), Vector3::z()]);
    } else if s.as_cylinder().is_some() || s.as_cone().is_some() {
        out.push(Vector3::y());
    } else if let Some(h) = s.as_convex_polyhedron() {
        out.extend(h.faces().iter().map(|f| f.normal.into_inner()));
    }
}

/// The outward normal of a cylinder's or cone's side at `p` (shape frame; p on or near the
/// side), computed from p's radial direction, which is accurate to ε even where the two
/// closest points are 1e-9 m apart at 100 m (their difference is not). Both signs are tried by
/// the caller, so the orientation is irrelevant.
fn side_normal(s: &dyn Shape, p: &nalgebra::Point3<f64>) -> Option<Vector3<f64>> {
    let radial = Vector3::new(p.x, 0.0, p.z);
    let rho = radial.norm();
    if !(rho.is_finite() && rho > 0.0) {
        return None;
    }
    let d = radial / rho;
    if s.as_cylinder().is_some() {
        Some(d)
    } else {
        // parry's cone: apex at y = +h, base radius r at y = −h; side ρ = r (h − y) / 2h.
        s.as_cone()
            .map(|k| d * (2.0 * k.half_height) + Vector3::y() * k.radius)
    }
}

/// Directions along which ℓ has a kink at the closest point `p` of `s` (shape frame): the
/// tangent of a cylinder's rim or a cone's base rim, the direction of a box edge or a hull
/// edge. The best u is orthogonal to each (it lies in the normal cone there), which the
/// difference of the closest points cannot give to better than ~1e-5 rad at 100 m, 1e-9 m.
/// A generous tolerance (1e-6 of the size) only adds candidates, never unsoundness.
pub(crate) fn kink_tangent(s: &dyn Shape, p: &nalgebra::Point3<f64>) -> Option<Vector3<f64>> {
    let rim = |r: f64, y_rim: f64| -> Option<Vector3<f64>> {
        let rho = (p.x * p.x + p.z * p.z).sqrt();
        let tol = 1e-6 * (r + y_rim.abs());
        ((rho - r).abs() <= tol && (p.y - y_rim).abs() <= tol && rho > 0.0)
            .then(|| Vector3::new(-p.z, 0.0, p.x) / rho)
    };
    if let Some(c) = s.as_cylinder() {
        return rim(c.radius, c.half_height).or_else(|| rim(c.radius, -c.half_height));
    }
    if let Some(k) = s.as_cone() {
        return rim(k.radius, -k.half_height);
    }
    if let Some(b) = s.as_cuboid() {
        let he = b.half_extents;
        let tol = 1e-6 * he.norm();
        let free: Vec<usize> = (0..3)
            .filter(|&i| (p[i].abs() - he[i]).abs() > tol)
            .collect();
        return (free.len() == 1).then(|| {
            let mut e = Vector3::zeros();
            e[free[0]] = 1.0;
            e
        });
    }
    if let Some(h) = s.as_convex_polyhedron() {
        let pts = h.points();
        let size = pts.iter().map(|q| q.coords.norm()).fold(0.0, f64::max);
        let tol = 1e-6 * size;
        let on: Vec<Vector3<f64>> = h
            .faces()
            .iter()
            .filter(|f| {
                let v = pts[h.vertices_adj_to_face()[f.first_vertex_or_edge as usize] as usize];
                (f.normal.dot(&(p - v))).abs() <= tol
            })
            .map(|f| f.normal.into_inner())
            .collect();
        if on.len() == 2 {
            let e = on[0].cross(&on[1]);
            let n = e.norm();
            return (n > 0.0 && n.is_finite()).then(|| e / n);
        }
    }
    None
}

/// Maximises ℓ from the bracket `s` (A's frame; `pos12` places B in A's frame); raises
/// `s.lower` (and `s.normal`, `s.tau`) when it finds better, and re-takes the verdict.
#[allow(clippy::too_many_arguments)]
pub(crate) fn refine(
    s: &mut Separation,
    pos12: &Isometry3<f64>,
    ma: &dyn SupportMap,
    mb: &dyn SupportMap,
    sa: &dyn Shape,
    sb: &dyn Shape,
    distance: bool,
    tolerance: f64,
) {
    let mut scale = s.tau / ROUNDING;
    let eval = |u: &Vector3<f64>, scale: &mut f64| -> Option<f64> {
        let n = u.norm();
        if !(n.is_finite() && n > 0.0) {
            return None;
        }
        let (l, m) = ell(pos12, ma, mb, &(u / n));
        if !(l.is_finite() && m.is_finite()) {
            return None;
        }
        *scale = scale.max(m);
        Some(l)
    };
    // Candidates.
    let mut cands = vec![s.normal, s.pa - s.pb];
    let mut own = Vec::new();
    special_directions(sa, &mut own);
    cands.extend(own.iter().copied());
    own.clear();
    special_directions(sb, &mut own);
    cands.extend(own.iter().map(|n| pos12.rotation * n));
    cands.extend(side_normal(sa, &s.pa));
    cands
        .extend(side_normal(sb, &pos12.inverse_transform_point(&s.pb)).map(|n| pos12.rotation * n));
    let mut kinks = Vec::new();
    kinks.extend(kink_tangent(sa, &s.pa));
    kinks.extend(
        kink_tangent(sb, &pos12.inverse_transform_point(&s.pb)).map(|t| pos12.rotation * t),
    );
    let base = cands.clone();
    for t in &kinks {
        cands.extend(base.iter().map(|c| c - t * t.dot(c)));
    }
    if kinks.len() == 2 {
        cands.push(kinks[0].cross(&kinks[1]));
    }
    let (mut best_u, mut best_l) = (s.normal, s.lower);
    for c in cands {
        for u in [c, -c] {
            if let Some(l) = eval(&u, &mut scale).filter(|&l| l > best_l) {
                (best_u, best_l) = (u.normalize(), l);
            }
        }
    }
    // One kink: search the great circle orthogonal to it (the ridge of ℓ), golden-angle free.
    if let [t] = kinks[..] {
        let mut u = best_u - t * t.dot(&best_u);
        if u.norm() > 0.0 && u.norm().is_finite() && t.dot(&best_u).abs() < 1e-3 {
            u.normalize_mut();
            let mut step = 1e-3f64;
            let mut steps = 0;
            while step > 1e-17 && steps < MAX_STEPS {
                steps += 1;
                let e = t.cross(&u);
                let mut moved = None;
                for sign in [1.0, -1.0] {
                    let cand = (u + e * (sign * step)).normalize();
                    if let Some(l) = eval(&cand, &mut scale).filter(|&l| l > best_l) {
                        best_l = l;
                        moved = Some(cand);
                    }
                }
                match moved {
                    Some(c) => {
                        (u, best_u) = (c, c);
                        step *= 2.0;
                    }
                    None => step *= 0.5,
                }
            }
        }
    }
    // Compass search on the sphere.
    if best_u.norm().is_finite() && best_u.norm() > 0.0 {
        let mut u = best_u.normalize();
        let mut step = 1e-3f64;
        let mut phase = 0.0f64;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut steps = 0;
        while step > 1e-17 && steps < MAX_STEPS {
            steps += 1;
            let e1 = if u.x.abs() < 0.6 {
                Vector3::x().cross(&u).normalize()
            } else {
                Vector3::y().cross(&u).normalize()
            };
            let e2 = u.cross(&e1);
            let mut moved = None;
            for k in 0..8 {
                let t = phase + k as f64 * std::f64::consts::FRAC_PI_4;
                let cand = (u + (e1 * t.cos() + e2 * t.sin()) * step).normalize();
                if let Some(l) = eval(&cand, &mut scale).filter(|&l| l > best_l) {
                    best_l = l;
                    moved = Some(cand);
                }
            }
            phase += golden;
            match moved {
                Some(c) => {
                    u = c;
                    best_u = c;
                    step *= 2.0;
                }
                None => step *= 0.5,
            }
        }
    }
    s.tau = s.tau.max(ROUNDING * scale);
    if best_l > s.lower {
        (s.lower, s.normal) = (best_l, best_u);
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
