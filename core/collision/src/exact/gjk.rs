//! Certified separation of two convex support maps: GJK (Gilbert, Johnson & Keerthi 1988, the
//! distance form) run on parry's exact support functions with our own stopping rule, so that
//! the signed distance is bracketed between two certificates at every step:
//!
//! * **lower bound** — for any unit direction u, `ℓ(u) = min_{a∈A} u·a − max_{b∈B} u·b`
//!   (the separating-plane bound: the slab between the two support planes is empty). It holds
//!   for every u, so the best one seen is kept. It also bounds an overlap: the signed distance
//!   `max_u ℓ(u)` is minus the penetration depth when the solids overlap.
//! * **upper bound** — `|a − b|` for a point a of A and b of B: the closest point of the
//!   current simplex is a convex combination of support-point differences, so the same
//!   weights give a ∈ A and b ∈ B.
//!
//! A pair is *apart* when the lower bound exceeds the rounding allowance τ = 8 ε L (ε the f64
//! machine epsilon, L the largest |a| + |b| among the support points evaluated, in A's frame),
//! and *touching or overlapping* when the upper bound is at most max(τ, [`CONTACT_BAND`] =
//! 1e-12 m) (a point of each solid that close; an enclosed origin gives 0). The distance is converged when
//! `upper − lower ≤ tolerance`. Anything else after [`MAX_ITERATIONS`] is undecided, and the
//! caller answers `Unknown`.
//!
//! Frames: everything is in A's frame; `pos12` places B in A's frame (B → A).
//! Entry point: [`separation`].

use nalgebra::{Isometry3, Point3, Vector3};
use parry3d_f64::shape::SupportMap;

/// GJK iterations before the pair is declared undecided. Polytopes end in a few; the curved
/// pairs of the reference set need at most ~40 (touching rims converge linearly).
pub(crate) const MAX_ITERATIONS: usize = 200;

/// Rounding allowance per unit of coordinate magnitude: τ = `ROUNDING` · L.
pub(crate) const ROUNDING: f64 = 8.0 * f64::EPSILON;

/// Touching, metres: a point of A and a point of B this close (or closer than τ) make a
/// contact. Issue #20 allows either answer within 1e-12 m of touching; contact is the safe one.
/// GJK's upper bound converges slowly onto a curved contact (the origin on a curved boundary
/// of A − B), which this band absorbs.
pub const CONTACT_BAND: f64 = 1e-12;

/// What the bounds decide.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Certified apart: lower bound > τ.
    Apart,
    /// Certified touching or overlapping: a point of A and one of B within τ (0 when the origin
    /// is enclosed by a tetrahedron of support-point differences).
    Touching,
    /// Neither after the iteration limit (or a non-finite support point).
    Undecided,
}

/// The bracket GJK ended with. Points in A's frame, metres.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Separation {
    pub verdict: Verdict,
    /// Certified: signed distance ≥ `lower` (minus rounding τ).
    pub lower: f64,
    /// Certified when apart: distance ≤ `upper` = |pa − pb|.
    pub upper: f64,
    /// Closest points found (on A, on B), A's frame.
    pub pa: Point3<f64>,
    pub pb: Point3<f64>,
    /// The direction u of the best lower bound (unit, A's frame, pointing from B towards A).
    pub normal: Vector3<f64>,
    /// Rounding allowance τ used, metres.
    pub tau: f64,
    /// `upper − lower ≤ tolerance` was reached.
    pub converged: bool,
    pub iterations: usize,
}

/// One simplex vertex: a support point of the Minkowski difference A − B and its two parts.
#[derive(Debug, Clone, Copy)]
struct Vertex {
    w: Vector3<f64>,
    a: Point3<f64>,
    b: Point3<f64>,
}

/// The support functions of A (its own frame) and B (placed in A's frame by `pos12`). B's
/// support goes through parry's quaternion `support_point`: a rotation matrix would be cheaper
/// but moves the rounding, and one touching pair at the 100 m scale (`box_cone_0_s100_g0` of
/// the contact references) then stays undecided after 200 iterations.
struct Pair<'a> {
    ma: &'a dyn SupportMap,
    mb: &'a dyn SupportMap,
    pos12: &'a Isometry3<f64>,
}

impl Pair<'_> {
    /// The point of A − B minimising `z·u`, with its parts.
    fn support(&self, u: &Vector3<f64>) -> Vertex {
        let a = self.ma.local_support_point(&-u);
        let b = self.mb.support_point(self.pos12, u);
        Vertex { w: a - b, a, b }
    }
}

/// GJK distance between A (in its frame) and B (placed by `pos12`), starting along `warm`
/// (a direction from B towards A; the centre difference when `None`). With `distance` false it
/// stops as soon as the verdict is certain; otherwise it also runs until
/// `upper − lower ≤ tolerance` (metres).
pub(crate) fn separation(
    pos12: &Isometry3<f64>,
    ma: &dyn SupportMap,
    mb: &dyn SupportMap,
    warm: Option<Vector3<f64>>,
    distance: bool,
    tolerance: f64,
) -> Separation {
    let mut u = warm
        .filter(|w| w.norm() > 0.0 && w.iter().all(|c| c.is_finite()))
        .unwrap_or(-pos12.translation.vector);
    if u.norm().is_nan() || u.norm() <= 0.0 {
        u = Vector3::x();
    }
    u.normalize_mut();
    let pair = Pair { ma, mb, pos12 };
    let first = pair.support(&u);
    let mut scale = first.a.coords.norm() + first.b.coords.norm();
    // At most four vertices and their weights, on the stack (no allocation per pair), reduced
    // in place (no copy of the simplex per iteration).
    let mut simplex = Simplex::one(first);
    let mut best = Separation {
        verdict: Verdict::Undecided,
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        pa: first.a,
        pb: first.b,
        normal: u,
        tau: ROUNDING * scale,
        converged: false,
        iterations: 0,
    };
    for it in 0..MAX_ITERATIONS {
        best.iterations = it;
        // The closest point of the simplex; its parts on A and B only when the upper bound
        // improves.
        let v: Vector3<f64> = simplex
            .vertices()
            .iter()
            .zip(simplex.weights())
            .map(|(s, l)| s.w * *l)
            .sum();
        let upper = v.norm();
        if !upper.is_finite() || !scale.is_finite() {
            return best;
        }
        if upper < best.upper {
            let (mut pa, mut pb) = (Vector3::zeros(), Vector3::zeros());
            for (s, l) in simplex.vertices().iter().zip(simplex.weights()) {
                pa += s.a.coords * *l;
                pb += s.b.coords * *l;
            }
            (best.upper, best.pa, best.pb) = (upper, Point3::from(pa), Point3::from(pb));
        }
        best.tau = ROUNDING * scale;
        // Inside a tetrahedron of support-point differences, or a point of each solid within
        // rounding of each other.
        if simplex.n == 4 || upper <= best.tau.max(CONTACT_BAND) {
            best.upper = best.upper.min(upper);
            best.verdict = Verdict::Touching;
            best.converged = true;
            return best;
        }
        // The search direction. v is a combination of points of size ~L, so its direction is
        // only good to ~ε L / |v| — 1e-7 rad at a 1e-9 m gap, which costs 1e-7 m of lower
        // bound across a flat contact. When the closest point is inside a triangle, v is
        // parallel to the triangle's normal, whose direction is good to ε: use that.
        let mut u = v / upper;
        if simplex.n == 3 {
            let t = simplex.vertices();
            let n = (t[1].w - t[0].w).cross(&(t[2].w - t[0].w));
            let len = n.norm();
            if len > 0.0 && len.is_finite() {
                u = n / len * n.dot(&v).signum();
            }
        }
        let s = pair.support(&u);
        scale = scale.max(s.a.coords.norm() + s.b.coords.norm());
        best.tau = ROUNDING * scale;
        let l = s.w.dot(&u);
        if l > best.lower {
            (best.lower, best.normal) = (l, u);
        }
        best.converged = best.upper - best.lower <= tolerance.max(best.tau);
        if best.lower > best.tau && (best.converged || !distance) {
            best.verdict = Verdict::Apart;
            return best;
        }
        // No direction does better than the current simplex (w adds nothing): the bracket has
        // closed to rounding without a lower bound above τ, so d ≤ upper ≤ lower + τ ≤ 2τ.
        if best.upper - best.lower <= best.tau {
            best.verdict = Verdict::Touching;
            return best;
        }
        simplex.push(s);
        simplex.reduce_to_closest(scale);
    }
    best.iterations = MAX_ITERATIONS;
    if best.lower > best.tau {
        best.verdict = Verdict::Apart;
    }
    best
}

/// Up to four simplex vertices with their barycentric weights (the first `n` are used).
#[derive(Debug, Clone, Copy)]
struct Simplex {
    v: [Vertex; 4],
    w: [f64; 4],
    n: usize,
}

impl Simplex {
    fn one(v: Vertex) -> Self {
        Simplex {
            v: [v; 4],
            w: [1.0, 0.0, 0.0, 0.0],
            n: 1,
        }
    }
    fn vertices(&self) -> &[Vertex] {
        &self.v[..self.n]
    }
    fn weights(&self) -> &[f64] {
        &self.w[..self.n]
    }
    /// Appends a vertex (weight 0 until [`Simplex::reduce_to_closest`] sets the weights).
    /// Called with at most three vertices: four end the search as touching.
    fn push(&mut self, v: Vertex) {
        if self.n < 4 {
            self.v[self.n] = v;
            self.w[self.n] = 0.0;
            self.n += 1;
        }
    }

    /// The closest point of the simplex to the origin: keeps the sub-simplex whose relative
    /// interior holds it, with the barycentric weights there. Four vertices are kept only when
    /// the origin is strictly inside a tetrahedron of non-negligible volume.
    fn reduce_to_closest(&mut self, scale: f64) {
        match self.n {
            1 => self.w[0] = 1.0,
            2 => {
                let l = segment(self.v[0].w, self.v[1].w);
                self.keep(&l);
            }
            3 => {
                let l = triangle(self.v[0].w, self.v[1].w, self.v[2].w);
                self.keep(&l);
            }
            _ => tetrahedron(self, scale),
        }
    }

    /// Keeps the first `l.len()` vertices whose weight in `l` is positive (in order, compacted
    /// in place), the weights normalised to sum 1.
    fn keep(&mut self, l: &[f64]) {
        let mut n = 0;
        let mut sum = 0.0;
        for (i, &x) in l.iter().enumerate() {
            if x > 0.0 {
                self.v[n] = self.v[i];
                self.w[n] = x;
                sum += x;
                n += 1;
            }
        }
        self.n = n;
        let inv = 1.0 / sum;
        self.w[..n].iter_mut().for_each(|x| *x *= inv);
    }
}

fn segment(a: Vector3<f64>, b: Vector3<f64>) -> [f64; 2] {
    let ab = b - a;
    let den = ab.norm_squared();
    if den.is_nan() || den <= 0.0 {
        return [1.0, 0.0];
    }
    let t = (-a.dot(&ab) / den).clamp(0.0, 1.0);
    [1.0 - t, t]
}

/// Closest point of triangle abc to the origin, as barycentric weights (Ericson, *Real-Time
/// Collision Detection*, §5.1.5, with p = 0).
pub(crate) fn triangle(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> [f64; 3] {
    let (ab, ac) = (b - a, c - a);
    let (d1, d2) = (-ab.dot(&a), -ac.dot(&a));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let (d3, d4) = (-ab.dot(&b), -ac.dot(&b));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let (d5, d6) = (-ab.dot(&c), -ac.dot(&c));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let den = va + vb + vc;
    if den.is_nan() || den <= 0.0 {
        // A degenerate (zero-area) triangle that the edge tests did not catch: its longest edge.
        let pairs = [(0, 1), (0, 2), (1, 2)];
        let pts = [a, b, c];
        let mut best = ([1.0, 0.0, 0.0], a.norm_squared());
        for (i, j) in pairs {
            let t = segment(pts[i], pts[j]);
            let p = pts[i] * t[0] + pts[j] * t[1];
            if p.norm_squared() < best.1 {
                let mut l = [0.0; 3];
                l[i] = t[0];
                l[j] = t[1];
                best = (l, p.norm_squared());
            }
        }
        return best.0;
    }
    let (v, w) = (vb / den, vc / den);
    [1.0 - v - w, v, w]
}

/// Tetrahedron: the origin is inside iff it is on the inner side of every face (Ericson
/// §5.1.6); a flat tetrahedron (volume below rounding) is treated as the union of its faces.
/// Reduces `s` (four vertices) in place: to the closest face's sub-simplex, or all four with
/// the origin's weights when inside.
fn tetrahedron(s: &mut Simplex, scale: f64) {
    let p = [s.v[0].w, s.v[1].w, s.v[2].w, s.v[3].w];
    let vol6 = (p[1] - p[0]).dot(&(p[2] - p[0]).cross(&(p[3] - p[0])));
    let flat = vol6.abs() <= 64.0 * f64::EPSILON * scale.powi(3);
    let faces = [(0, 1, 2, 3), (0, 2, 3, 1), (0, 3, 1, 2), (1, 3, 2, 0)];
    let mut best: Option<(f64, [usize; 3], [f64; 3])> = None;
    let mut outside_any = false;
    for (i, j, k, o) in faces {
        let n = (p[j] - p[i]).cross(&(p[k] - p[i]));
        let outside = -p[i].dot(&n) * (p[o] - p[i]).dot(&n) < 0.0;
        outside_any |= outside;
        if !(outside || flat) {
            continue;
        }
        let l = triangle(p[i], p[j], p[k]);
        let q = p[i] * l[0] + p[j] * l[1] + p[k] * l[2];
        let d = q.norm_squared();
        if best.as_ref().is_none_or(|b| d < b.0) {
            best = Some((d, [i, j, k], l));
        }
    }
    let inside = !flat && !outside_any;
    match best {
        Some((_, [i, j, k], l)) if !inside => {
            let tri = [s.v[i], s.v[j], s.v[k]];
            s.v[..3].copy_from_slice(&tri);
            s.n = 3;
            s.keep(&l);
        }
        _ => {
            // Inside: weights of the origin (signed sub-volumes), reported with all four.
            let vol = |a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>, d: Vector3<f64>| {
                (b - a).dot(&(c - a).cross(&(d - a)))
            };
            let z = Vector3::zeros();
            s.w = [
                vol(z, p[1], p[2], p[3]) / vol6,
                vol(p[0], z, p[2], p[3]) / vol6,
                vol(p[0], p[1], z, p[3]) / vol6,
                vol(p[0], p[1], p[2], z) / vol6,
            ];
            s.n = 4;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d_f64::shape::{Ball, Cuboid, Cylinder};

    #[test]
    fn two_balls_bracket_the_closed_form() {
        let (a, b) = (Ball::new(0.5), Ball::new(0.25));
        let pos12 = Isometry3::translation(0.3, 0.4, 1.2);
        let d = (0.3f64 * 0.3 + 0.4 * 0.4 + 1.2 * 1.2).sqrt() - 0.75;
        let s = separation(&pos12, &a, &b, None, true, 1e-12);
        assert_eq!(s.verdict, Verdict::Apart);
        assert!(s.lower <= d + 1e-15 && d <= s.upper + 1e-15, "{s:?} vs {d}");
        assert!(s.upper - s.lower <= 1e-12);
    }

    #[test]
    fn cylinder_on_a_box_touching_and_1e9_apart() {
        // parry's cylinder axis is y; the box top is at y = 0.5.
        let (bx, cyl) = (
            Cuboid::new(Vector3::new(1.0, 0.5, 1.0)),
            Cylinder::new(0.3, 0.2),
        );
        for (gap, verdict) in [(0.0, Verdict::Touching), (1e-9, Verdict::Apart)] {
            let pos12 = Isometry3::translation(0.1, 0.5 + 0.3 + gap, -0.2);
            let s = separation(&pos12, &bx, &cyl, None, true, 1e-12);
            assert_eq!(s.verdict, verdict, "{gap}: {s:?}");
            if gap > 0.0 {
                assert!((s.upper - gap).abs() < 1e-15, "{s:?}");
            }
        }
    }
}
