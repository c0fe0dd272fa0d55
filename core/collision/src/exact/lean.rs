//! GJK at a user tolerance ([`super::Tolerance::Gjk`]): the same bracket, the same verdict
//! rules and the same certificates as [`super::gjk`] (lower bound: a separating plane of two
//! support points; upper bound: |v| for v a point of the simplex of support-point differences;
//! apart when lower > τ, touching when upper ≤ max(τ, [`CONTACT_BAND`]), converged when
//! upper − lower ≤ tolerance), in a kernel built for speed:
//!
//! * supports specialised per shape with B placed by a rotation matrix ([`super::support`]);
//! * the simplex's vertices stay in four slots and the sub-simplex is a list of slot indices
//!   (nothing copied when the simplex shrinks or grows);
//! * the sub-simplex solver uses the newest-vertex rule: the closest point of a tetrahedron is
//!   looked for on the three faces through the vertex just added (the face opposite it is the
//!   previous triangle, whose closest point the search came from; it is taken only when none of
//!   the three is a candidate, so an origin outside it is never taken for inside);
//! * the direction v/|v| is replaced by a triangle's normal only where v's rounding
//!   (~ε L / |v| rad, ~ε L² / |v| m of lower bound) is worth the tolerance.
//!
//! None of these touches the bounds' validity: any point of the simplex bounds the distance
//! from above, any direction's separating plane from below. What moves is the rounding of the
//! support points, so a pair the certified kernel decides can stay undecided here at the 100 m
//! scale (`box_cone_0_s100_g0` of the contact references did with a rotation matrix): the
//! caller then runs [`super::gjk::separation`] (see `collide_support_maps`).
//!
//! Entry point: [`separation`].

use super::gjk::{CONTACT_BAND, MAX_ITERATIONS, ROUNDING, Separation, Verdict, triangle};
use super::support::Placed;
use nalgebra::{Isometry3, Point3, Vector3};

type V3 = Vector3<f64>;

/// The closest point of a (sub-)simplex to the origin: the point `v` (from the barycentric
/// weights, so that it is the difference of the points of A and B with those weights) and
/// `dir`, a positive multiple of v made without a division (the next search direction: the
/// supports depend on its direction only, so the divisions of the weights run beside them).
#[derive(Clone, Copy)]
struct Closest {
    v: V3,
    dir: V3,
}

/// The vertices in four slots; `act[..n]` the active ones (the newest last), `lam` their
/// barycentric weights.
struct Simplex {
    w: [V3; 4],
    a: [V3; 4],
    b: [V3; 4],
    act: [usize; 4],
    lam: [f64; 4],
    n: usize,
}

/// An active set and its weights (the simplex that gave the best upper bound).
type Held = ([usize; 4], [f64; 4], usize);

impl Simplex {
    /// The support-point difference of active vertex `k` (slot indices are < 4: the mask
    /// only spares the bounds check).
    #[inline(always)]
    fn wk(&self, k: usize) -> V3 {
        self.w[self.act[k & 3] & 3]
    }

    /// The points of A and of B with the weights of `held` (an active set whose slots have
    /// not been overwritten since).
    fn parts(&self, held: &Held) -> (Point3<f64>, Point3<f64>) {
        let (act, lam, n) = held;
        let (mut pa, mut pb) = (V3::zeros(), V3::zeros());
        for k in 0..(*n).min(4) {
            let (s, l) = (act[k] & 3, lam[k]);
            pa += self.a[s] * l;
            pb += self.b[s] * l;
        }
        (Point3::from(pa), Point3::from(pb))
    }

    fn held(&self) -> Held {
        (self.act, self.lam, self.n)
    }

    /// Puts `(w, a, b)` in a free slot and makes it the newest active vertex (n < 4).
    #[inline(always)]
    fn push(&mut self, w: V3, a: V3, b: V3) {
        let mut used = [false; 4];
        for &s in &self.act[..self.n] {
            used[s & 3] = true;
        }
        let slot = used.iter().position(|u| !u).unwrap_or(3);
        (self.w[slot], self.a[slot], self.b[slot]) = (w, a, b);
        self.act[self.n & 3] = slot;
        self.n += 1;
    }

    /// Keeps the active vertices `ids` (positions in `act`) whose weight in `l` is positive.
    #[inline(always)]
    fn keep<const K: usize>(&mut self, ids: [usize; K], l: [f64; K]) {
        let old = self.act;
        let mut n = 0;
        let mut sum = 0.0;
        for (&i, &x) in ids.iter().zip(&l) {
            if x > 0.0 {
                self.act[n & 3] = old[i & 3];
                self.lam[n & 3] = x;
                sum += x;
                n += 1;
            }
        }
        self.n = n;
        // The solvers' weights sum to 1 already unless one was dropped.
        if n < K {
            let inv = 1.0 / sum;
            self.lam[..n].iter_mut().for_each(|x| *x *= inv);
        }
    }

    /// The point of the active vertices with the current weights.
    fn point(&self) -> V3 {
        let mut v = self.wk(0) * self.lam[0];
        for k in 1..self.n.min(4) {
            v += self.wk(k) * self.lam[k];
        }
        v
    }

    /// Adds the support point `(w, a, b)` as the newest vertex, reduces to the sub-simplex
    /// holding the closest point to the origin and returns that point; `None` when the origin
    /// is inside a tetrahedron of non-negligible volume (all four kept). The new `w` is used
    /// as passed (not read back from its slot: a store and a reload of a 24-byte vector cost a
    /// failed store forwarding on the critical path).
    #[inline(always)]
    fn add(&mut self, w: V3, a: V3, b: V3, scale: f64) -> Option<Closest> {
        self.push(w, a, b);
        match self.n {
            2 => {
                // the newest vertex q (position 1); p's region is kept for rounding's sake
                let (p, q) = (self.wk(0), w);
                let d = q - p;
                let den = d.norm_squared();
                let num = -p.dot(&d);
                if !(den > 0.0) || num <= 0.0 {
                    self.keep([0], [1.0]);
                    return Some(Closest { v: p, dir: p });
                }
                if num >= den {
                    self.keep([1], [1.0]);
                    return Some(Closest { v: q, dir: q });
                }
                let t = num / den;
                self.lam[..2].copy_from_slice(&[1.0 - t, t]);
                Some(Closest {
                    v: p * (1.0 - t) + q * t,
                    dir: p * den + d * num,
                })
            }
            3 => {
                // the newest vertex (position 2) first
                let (a, b, c) = (w, self.wk(0), self.wk(1));
                let (l, dir) = triangle_newest(a, b, c);
                self.keep([2, 0, 1], l);
                Some(Closest {
                    v: self.point(),
                    dir,
                })
            }
            4 => self.tetrahedron(w, scale),
            _ => {
                self.lam[0] = 1.0;
                Some(Closest { v: w, dir: w })
            }
        }
    }

    fn tetrahedron(&mut self, newest: V3, scale: f64) -> Option<Closest> {
        let p = [self.wk(0), self.wk(1), self.wk(2), newest];
        let vol6 = (p[1] - p[0]).dot(&(p[2] - p[0]).cross(&(p[3] - p[0])));
        let flat = vol6.abs() <= 64.0 * f64::EPSILON * scale.powi(3);
        if flat {
            // The union of the four faces (no rule about the newest vertex holds).
            let mut best: Option<(f64, [usize; 3], [f64; 3])> = None;
            for (i, j, k) in [(0, 1, 2), (0, 1, 3), (1, 2, 3), (2, 0, 3)] {
                let l = triangle(p[i], p[j], p[k]);
                let d = (p[i] * l[0] + p[j] * l[1] + p[k] * l[2]).norm_squared();
                if best.as_ref().is_none_or(|b| d < b.0) {
                    best = Some((d, [i, j, k], l));
                }
            }
            if let Some((_, ids, l)) = best {
                self.keep(ids, l);
            }
            let v = self.point();
            return Some(Closest { v, dir: v });
        }
        // Faces through the newest vertex 3 (A): the origin is outside face f when the outward
        // normal n_f has n_f·(0 − A) > 0. With n = AB×AC, AC×AD, AD×AB (B, C, D = 0, 1, 2),
        // each points towards the opposite vertex when vol6 > 0, so outward is −sign(vol6) n.
        let a = p[3];
        let (ab, ac, ad) = (p[0] - a, p[1] - a, p[2] - a);
        // (vol6 above is ordered p0, p1, p2, p3: an odd permutation of A, B, C, D)
        let sign = ab.dot(&ac.cross(&ad)).signum();
        let faces = [
            (0, 1, ab.cross(&ac)),
            (1, 2, ac.cross(&ad)),
            (2, 0, ad.cross(&ab)),
        ];
        let mut best: Option<(f64, [usize; 3], [f64; 3], V3)> = None;
        for (j, k, n) in faces {
            if sign * n.dot(&a) <= 0.0 {
                continue;
            }
            let (l, dir) = triangle_newest_with(a, p[j], p[k], n);
            let d = (a * l[0] + p[j] * l[1] + p[k] * l[2]).norm_squared();
            if best.as_ref().is_none_or(|b| d < b.0) {
                best = Some((d, [3, j, k], l, dir));
            }
        }
        if let Some((_, ids, l, dir)) = best {
            self.keep(ids, l);
            return Some(Closest {
                v: self.point(),
                dir,
            });
        }
        // Outside none of them: inside, unless (rounding) outside the previous triangle too.
        let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
        if -p[0].dot(&n) * (p[3] - p[0]).dot(&n) < 0.0 {
            self.keep([0, 1, 2], triangle(p[0], p[1], p[2]));
            let v = self.point();
            return Some(Closest { v, dir: v });
        }
        // Inside: the origin's weights (signed sub-volumes), all four kept.
        let vol = |a: V3, b: V3, c: V3, d: V3| (b - a).dot(&(c - a).cross(&(d - a)));
        let z = V3::zeros();
        self.lam = [
            vol(z, p[1], p[2], p[3]) / vol6,
            vol(p[0], z, p[2], p[3]) / vol6,
            vol(p[0], p[1], z, p[3]) / vol6,
            vol(p[0], p[1], p[2], z) / vol6,
        ];
        None
    }
}

/// Closest point of triangle abc to the origin as barycentric weights, `a` the vertex just
/// added, and a positive multiple of that point made without a division: by the newest-vertex
/// rule the origin projects into the regions of a, ab, ac or the face (not b, c or bc, the
/// previous segment), so only those are told apart — by the sides of the in-plane edge
/// normals (n × ac, ab × n), with n = ab × ac. A degenerate triangle goes to [`triangle`]
/// (Ericson's, every region).
fn triangle_newest(a: V3, b: V3, c: V3) -> ([f64; 3], V3) {
    triangle_newest_with(a, b, c, (b - a).cross(&(c - a)))
}

/// [`triangle_newest`] with the face normal `n` = (b − a) × (c − a) already computed.
#[inline(always)]
fn triangle_newest_with(a: V3, b: V3, c: V3, n: V3) -> ([f64; 3], V3) {
    let (ab, ac) = (b - a, c - a);
    let nn = n.norm_squared();
    if !(nn > 0.0 && nn.is_finite()) {
        let l = triangle(a, b, c);
        return (l, a * l[0] + b * l[1] + c * l[2]);
    }
    let ao = -a;
    // The closest point of the edge a + t e, t ∈ (0, 1], when it is beyond a; its direction
    // a |e|² + e (e·ao) = |e|² (a + t e) needs no division.
    let edge = |e: V3| -> Option<(f64, V3)> {
        let t = e.dot(&ao);
        if t <= 0.0 {
            return None;
        }
        let ee = e.norm_squared();
        Some(if t >= ee {
            (1.0, a + e)
        } else {
            (t / ee, a * ee + e * t)
        })
    };
    if n.cross(&ac).dot(&ao) > 0.0 {
        // beyond edge ac
        if let Some((t, dir)) = edge(ac) {
            return ([1.0 - t, 0.0, t], dir);
        }
        return match edge(ab) {
            Some((t, dir)) => ([1.0 - t, t, 0.0], dir),
            None => ([1.0, 0.0, 0.0], a),
        };
    }
    if ab.cross(&n).dot(&ao) > 0.0 {
        // beyond edge ab
        return match edge(ab) {
            Some((t, dir)) => ([1.0 - t, t, 0.0], dir),
            None => ([1.0, 0.0, 0.0], a),
        };
    }
    // the face: weights of the origin's projection (its normal component drops out); the
    // projection is n (n·a) / |n|², along n to ε whatever |v| (v's own direction is only good
    // to ~ε L / |v|, 1e-7 rad at a 1e-9 m gap)
    let inv = 1.0 / nn;
    let lb = n.dot(&ao.cross(&ac)) * inv;
    let lc = n.dot(&ab.cross(&ao)) * inv;
    ([1.0 - lb - lc, lb, lc], n * n.dot(&a))
}

/// GJK distance between A (its frame) and B (placed in A's frame by `pos12`) on the
/// specialised supports `pair`; the same contract as [`super::gjk::separation`] (no warm
/// start: the centre difference is the first direction).
pub(crate) fn separation(
    pair: &Placed,
    pos12: &Isometry3<f64>,
    distance: bool,
    tolerance: f64,
) -> Separation {
    let mut u = -pos12.translation.vector;
    let len = u.norm();
    u = if len > 0.0 && len.is_finite() {
        u / len
    } else {
        Vector3::x()
    };
    let (a, b) = pair.parts(&u);
    // L of the rounding allowance: the pair's reach bound where it has one (no square root
    // per support point), else the largest |a| + |b| seen.
    let reach = pair.reach();
    let mut scale = reach.unwrap_or_else(|| a.norm() + b.norm());
    let w0 = a - b;
    let mut s = Simplex {
        w: [w0; 4],
        a: [a; 4],
        b: [b; 4],
        act: [0, 1, 2, 3],
        lam: [1.0, 0.0, 0.0, 0.0],
        n: 1,
    };
    let mut best = Separation {
        verdict: Verdict::Undecided,
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        pa: Point3::from(a),
        pb: Point3::from(b),
        normal: u,
        tau: ROUNDING * scale,
        converged: false,
        iterations: 0,
    };
    let mut at = Some(Closest { v: w0, dir: w0 });
    let mut held: Option<Held> = None;
    for it in 0..MAX_ITERATIONS {
        best.iterations = it;
        let Some(Closest { v, dir }) = at else {
            // inside a tetrahedron of support-point differences
            best.upper = 0.0;
            best.verdict = Verdict::Touching;
            best.converged = true;
            return finish(best, &s, Some(s.held()));
        };
        // The next support points first (along `dir`: their direction only counts); the
        // square roots of |v| and |dir| and the checks on the upper bound run beside them.
        let len = dir.norm();
        let (dir, len) = if len > 0.0 && len.is_finite() {
            (dir, len)
        } else {
            (v, v.norm())
        };
        let (a, b) = pair.parts(&dir);
        let upper = v.norm();
        if !upper.is_finite() || !scale.is_finite() {
            return finish(best, &s, held);
        }
        // The best simplex's points on A and B: kept as weights while the upper bound
        // improves, made when it stops (before the next push can reuse one of its slots).
        if upper < best.upper {
            best.upper = upper;
            held = Some(s.held());
        } else if let Some(h) = held.take() {
            (best.pa, best.pb) = s.parts(&h);
        }
        best.tau = ROUNDING * scale;
        if upper <= best.tau.max(CONTACT_BAND) {
            best.verdict = Verdict::Touching;
            best.converged = true;
            return finish(best, &s, held);
        }
        // The new upper bound may close the bracket on the lower bound already found (the
        // support points just taken are then not needed).
        best.converged = best.upper - best.lower <= tolerance.max(best.tau);
        if best.converged && best.lower > best.tau {
            best.verdict = Verdict::Apart;
            return finish(best, &s, held);
        }
        u = dir * len.recip();
        let w = a - b;
        if reach.is_none() {
            scale = scale.max(a.norm() + b.norm());
            best.tau = ROUNDING * scale;
        }
        let l = w.dot(&u);
        if l > best.lower {
            (best.lower, best.normal) = (l, u);
        }
        best.converged = best.upper - best.lower <= tolerance.max(best.tau);
        if best.lower > best.tau && (best.converged || !distance) {
            best.verdict = Verdict::Apart;
            return finish(best, &s, held);
        }
        if best.upper - best.lower <= best.tau {
            best.verdict = Verdict::Touching;
            return finish(best, &s, held);
        }
        at = s.add(w, a, b, scale);
    }
    best.iterations = MAX_ITERATIONS;
    if best.lower > best.tau {
        best.verdict = Verdict::Apart;
    }
    finish(best, &s, held)
}

/// `best` with the closest points of the simplex `held` (its points on A and on B are made
/// only once, at the end, or when a later simplex does not improve on it).
fn finish(mut best: Separation, s: &Simplex, held: Option<Held>) -> Separation {
    if let Some(h) = held {
        (best.pa, best.pb) = s.parts(&h);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Solid;
    use crate::exact::gjk;
    use crate::exact::support::Kind;

    fn point(w: [f64; 3], a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> Vector3<f64> {
        a * w[0] + b * w[1] + c * w[2]
    }

    /// Wherever the origin's closest point involves the newest vertex a (its region, an edge
    /// through it or the face), the newest-vertex solver finds Ericson's point.
    #[test]
    fn newest_vertex_triangle_finds_ericsons_closest_point() {
        let mut checked = [0usize; 3]; // vertex a, an edge through a, the face
        for k in 0..20000 {
            let x = k as f64;
            let v = |s: f64| {
                Vector3::new(
                    (s * x).sin(),
                    (1.7 * s * x).cos(),
                    (0.3 * s * x).sin() - 0.2,
                )
            };
            let (a, b, c) = (v(1.1), v(2.3), v(3.7));
            let full = triangle(a, b, c);
            if full[0] <= 0.0 {
                continue; // a region the rule excludes (b, c or bc)
            }
            let (lean, _) = triangle_newest(a, b, c);
            let (p, q) = (point(full, a, b, c), point(lean, a, b, c));
            assert!((p - q).norm() <= 1e-12, "{k}: {full:?} vs {lean:?}");
            checked[full.iter().filter(|w| **w > 0.0).count() - 1] += 1;
        }
        assert!(checked.iter().all(|n| *n >= 50), "{checked:?}");
    }

    /// The lean kernel against the certified one on every pair of support maps (box, cylinder,
    /// cone, ball, convex hull), at 1 m and 100 m: the same verdict wherever both decide,
    /// brackets that overlap (both are certificates), a converged bracket within the
    /// tolerance, and closest points whose distance is the upper bound.
    #[test]
    fn lean_kernel_agrees_with_the_certified_one_on_every_support_pair() {
        let (mut apart, mut touching, mut undecided) = (0, 0, 0);
        for scale in [1.0, 100.0] {
            let hull: Vec<Point3<f64>> = (0..12)
                .map(|k| {
                    let x = k as f64;
                    Point3::new(
                        (1.7 * x).sin() * 0.3,
                        (0.9 * x).cos() * 0.25,
                        (2.3 * x).sin() * 0.2,
                    ) * scale
                })
                .collect();
            let solids = [
                Solid::cuboid(Vector3::new(0.4, 0.3, 0.2) * scale).expect("box"),
                Solid::cylinder(0.2 * scale, 0.5 * scale, None).expect("cylinder"),
                Solid::cone(0.15 * scale, 0.4 * scale, None).expect("cone"),
                Solid::sphere(0.2 * scale, None).expect("ball"),
                Solid::convex(&hull).expect("hull"),
            ];
            for k in 0..500 {
                let x = k as f64;
                let (a, b) = (&solids[k % 5], &solids[(k / 5) % 5]);
                let pa =
                    Isometry3::new(Vector3::zeros(), Vector3::new(0.3 * x.sin(), 0.2, 0.1 * x));
                let pb = Isometry3::new(
                    Vector3::new(
                        0.2 + 0.5 * (0.37 * x).sin().abs(),
                        0.1 * (0.7 * x).cos(),
                        0.05,
                    ) * scale,
                    Vector3::new(0.5 * x.cos(), 0.3 * x, -0.2),
                );
                let (ga, gb) = (pa * a.exact_offset, pb * b.exact_offset);
                let pos12 = ga.inv_mul(&gb);
                let (sa, sb) = (a.exact.as_ref(), b.exact.as_ref());
                let (Some(ma), Some(mb)) = (sa.as_support_map(), sb.as_support_map()) else {
                    panic!("{k}: not support maps");
                };
                let cert = gjk::separation(&pos12, ma, mb, None, true, 1e-11);
                let placed = Placed::new(
                    Kind::of(sa).expect("kind a"),
                    Kind::of(sb).expect("kind b"),
                    &pos12,
                );
                let tol = 1e-9 * scale;
                let lean = separation(&placed, &pos12, true, tol);
                if lean.verdict == Verdict::Undecided || cert.verdict == Verdict::Undecided {
                    undecided += 1;
                    continue;
                }
                assert_eq!(lean.verdict, cert.verdict, "{scale} {k}: {lean:?} {cert:?}");
                let tau = lean.tau.max(cert.tau);
                assert!(
                    lean.lower <= cert.upper + tau && cert.lower <= lean.upper + tau,
                    "{scale} {k}: {lean:?} {cert:?}"
                );
                if lean.verdict == Verdict::Apart {
                    apart += 1;
                    assert!(lean.converged && lean.upper - lean.lower <= tol.max(lean.tau));
                    let d = (lean.pa - lean.pb).norm();
                    assert!(
                        (d - lean.upper).abs() <= 1e-12 * scale,
                        "{scale} {k}: {d} vs {lean:?}"
                    );
                } else {
                    touching += 1;
                }
            }
        }
        assert!(
            apart >= 300 && touching >= 200 && undecided <= 10,
            "{apart} {touching} {undecided}"
        );
    }

    /// What a tolerance means, on the pairs of the tolerance study and the convex meshes
    /// (`testdata/collision/tolerance_pairs.csv`, `tolerance_hull_pairs.csv`: 200 separated
    /// pairs): at a GJK tolerance t the distance `collide` reports is a true distance (never
    /// below the certified one, whose bracket is 1e-11 m) at most t above it. A looser stopping
    /// rule (coal's relative one, or the lower end of the bracket reported) fails here.
    #[test]
    fn reported_distance_is_within_the_tolerance_of_the_certified_one() {
        use crate::exact::{ExactOptions, Tolerance, collide, pair_file};
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/collision/");
        let mut pairs = Vec::new();
        for name in ["tolerance_pairs.csv", "tolerance_hull_pairs.csv"] {
            let path = format!("{dir}{name}");
            let text = std::fs::read_to_string(&path).expect("pairs file");
            pairs.extend(pair_file::parse(&text, &path).expect("pairs"));
        }
        assert_eq!(pairs.len(), 200);
        let certified: Vec<f64> = pairs
            .iter()
            .map(|p| {
                collide(&p.a, &p.pa, &p.b, &p.pb, ExactOptions::default())
                    .signed_distance()
                    .expect("a distance")
            })
            .collect();
        for t in [1e-3, 1e-6, 1e-9] {
            let opts = ExactOptions {
                tolerance: Tolerance::Gjk(t),
                ..ExactOptions::default()
            };
            let mut worst: f64 = 0.0;
            for (p, dc) in pairs.iter().zip(&certified) {
                let d = collide(&p.a, &p.pa, &p.b, &p.pb, opts)
                    .signed_distance()
                    .expect("a distance");
                assert!(
                    d >= dc - 1e-11 && d <= dc + t + 1e-11,
                    "{} at {t:e}: {d} vs certified {dc}",
                    p.class
                );
                worst = worst.max(d - dc);
            }
            // the tolerance is used, not a certified answer in disguise
            assert!(worst > t * 1e-3, "at {t:e} the worst error is {worst:e}");
        }
    }
}
