//! Support functions specialised per shape, for GJK at a user tolerance ([`super::Tolerance::Gjk`]):
//! the closed forms of parry 0.25.3's box, cylinder, cone and ball supports inlined behind one
//! `match` (no `dyn` call per evaluation), and B placed in A's frame by a rotation matrix
//! computed once per pair (no quaternion rotation per evaluation); a convex hull's vertices
//! scanned without a branch ([`hull_support`]). Any other support map goes through parry's
//! `dyn` support on the same matrix.
//!
//! The certified mode does not use these: a rotation matrix rounds differently from parry's
//! quaternion, and at the 100 m scale one touching contact reference (`box_cone_0_s100_g0`)
//! then stays undecided after GJK's iteration limit. A GJK tolerance runs these first (in
//! [`super::lean`]) and, when the verdict is undecided, GJK again on parry's supports
//! ([`super::gjk::separation`]) — so it decides every pair the certified mode decides. The bounds are sound with either: the lower
//! bound is a separating plane of two support points, the upper bound the distance of a point
//! of each solid, both within the rounding allowance τ = 8 ε L of [`super::gjk`].
//!
//! Entry points: [`Kind::of`], [`Placed::new`].

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use parry3d_f64::shape::{Shape, ShapeType, SupportMap};

/// One convex shape's support function, in its own frame.
#[derive(Clone, Copy)]
pub(crate) enum Kind<'a> {
    /// Half extents.
    Cuboid(Vector3<f64>),
    /// parry's cylinder: axis y, centred.
    Cylinder {
        radius: f64,
        half_height: f64,
    },
    /// parry's cone: axis y, apex at +half_height.
    Cone {
        radius: f64,
        half_height: f64,
    },
    Ball(f64),
    /// A convex hull (parry's `ConvexPolyhedron`): its vertices.
    Hull(&'a [Point3<f64>]),
    /// Any other support map.
    Other(&'a dyn SupportMap),
}

impl<'a> Kind<'a> {
    /// The support function of `s`; `None` if `s` is not a support map.
    pub(crate) fn of(s: &'a dyn Shape) -> Option<Self> {
        match s.shape_type() {
            ShapeType::Cuboid => s.as_cuboid().map(|b| Kind::Cuboid(b.half_extents)),
            ShapeType::Cylinder => s.as_cylinder().map(|c| Kind::Cylinder {
                radius: c.radius,
                half_height: c.half_height,
            }),
            ShapeType::Cone => s.as_cone().map(|c| Kind::Cone {
                radius: c.radius,
                half_height: c.half_height,
            }),
            ShapeType::Ball => s.as_ball().map(|b| Kind::Ball(b.radius)),
            ShapeType::ConvexPolyhedron => s
                .as_convex_polyhedron()
                .filter(|c| !c.points().is_empty())
                .map(|c| Kind::Hull(c.points())),
            _ => s.as_support_map().map(Kind::Other),
        }
    }

    /// The largest |p| of a point p of the shape (its frame): a box's half diagonal, the rim of
    /// a cylinder or of a cone's base (a cone's apex, at half_height, is nearer), a ball's
    /// radius, a hull's farthest vertex; `None` for another support map.
    fn reach(&self) -> Option<f64> {
        match *self {
            Kind::Cuboid(h) => Some(h.norm()),
            Kind::Cylinder {
                radius,
                half_height,
            }
            | Kind::Cone {
                radius,
                half_height,
            } => Some((radius * radius + half_height * half_height).sqrt()),
            Kind::Ball(r) => Some(r),
            Kind::Hull(p) => Some(
                p.iter()
                    .map(|q| q.coords.norm_squared())
                    .fold(0.0, f64::max)
                    .sqrt(),
            ),
            Kind::Other(_) => None,
        }
    }

    /// A point of the shape maximising `d·p` (parry's closed forms; `d` need not be unit).
    #[inline(always)]
    fn local(&self, d: &Vector3<f64>) -> Vector3<f64> {
        match *self {
            Kind::Cuboid(h) => {
                Vector3::new(h.x.copysign(d.x), h.y.copysign(d.y), h.z.copysign(d.z))
            }
            Kind::Cylinder {
                radius,
                half_height,
            } => {
                let rho = (d.x * d.x + d.z * d.z).sqrt();
                let y = half_height.copysign(d.y);
                if rho > 0.0 {
                    let k = radius / rho;
                    Vector3::new(d.x * k, y, d.z * k)
                } else {
                    Vector3::new(0.0, y, 0.0)
                }
            }
            Kind::Cone {
                radius,
                half_height,
            } => {
                let rho = (d.x * d.x + d.z * d.z).sqrt();
                if rho > 0.0 {
                    let k = radius / rho;
                    let rim = Vector3::new(d.x * k, -half_height, d.z * k);
                    // The apex when it is further along d than the base's rim point.
                    if d.dot(&rim) < d.y * half_height {
                        Vector3::new(0.0, half_height, 0.0)
                    } else {
                        rim
                    }
                } else {
                    Vector3::new(0.0, half_height.copysign(d.y), 0.0)
                }
            }
            Kind::Ball(r) => {
                let n = d.norm();
                if n > 0.0 {
                    d * (r / n)
                } else {
                    Vector3::zeros()
                }
            }
            Kind::Hull(p) => hull_support(p, d),
            Kind::Other(m) => m.local_support_point(d).coords,
        }
    }
}

/// The vertex of `p` (not empty) maximising `d·p`: four interleaved running maxima without a
/// branch (parry's scan keeps one maximum behind a branch: a chain of dependent compares and
/// a misprediction wherever the maximum moves). Ties may pick another maximal vertex than
/// parry's first one; the support value is the same.
#[inline(always)]
fn hull_support(p: &[Point3<f64>], d: &Vector3<f64>) -> Vector3<f64> {
    let dot = |q: &Point3<f64>| q.x * d.x + q.y * d.y + q.z * d.z;
    let mut best = [f64::NEG_INFINITY; 4];
    let mut at = [0usize; 4];
    let chunks = p.chunks_exact(4);
    let rest = chunks.remainder();
    for (c, q) in chunks.enumerate() {
        for k in 0..4 {
            let s = dot(&q[k]);
            let better = s > best[k];
            best[k] = if better { s } else { best[k] };
            at[k] = if better { 4 * c + k } else { at[k] };
        }
    }
    let base = p.len() - rest.len();
    for (k, q) in rest.iter().enumerate() {
        let s = dot(q);
        if s > best[k] {
            best[k] = s;
            at[k] = base + k;
        }
    }
    let mut i = at[0];
    let mut m = best[0];
    for k in 1..4 {
        if best[k] > m {
            m = best[k];
            i = at[k];
        }
    }
    p.get(i).map_or_else(Vector3::zeros, |q| q.coords)
}

/// A pair of support functions with B placed in A's frame by a rotation matrix and a
/// translation (B → A), both computed once.
pub(crate) struct Placed<'a> {
    a: Kind<'a>,
    b: Kind<'a>,
    /// B's rotation into A's frame, and its transpose (A's directions into B's frame).
    r: Matrix3<f64>,
    rt: Matrix3<f64>,
    t: Vector3<f64>,
    /// A bound on |a| + |b| over every support point a of A and b of B (A's frame): the two
    /// shapes' reaches (the largest |p| of a point of the shape, its own frame) plus |t|;
    /// `None` when one is another support map (its reach is not known).
    reach: Option<f64>,
}

impl<'a> Placed<'a> {
    pub(crate) fn new(a: Kind<'a>, b: Kind<'a>, pos12: &Isometry3<f64>) -> Self {
        let r = pos12.rotation.to_rotation_matrix().into_inner();
        let t = pos12.translation.vector;
        let reach = a.reach().zip(b.reach()).map(|(ra, rb)| ra + rb + t.norm());
        Placed {
            a,
            b,
            r,
            rt: r.transpose(),
            t,
            reach,
        }
    }
}

impl Placed<'_> {
    /// The bound [`Placed::reach`] of `|a| + |b|` over all support points (a constant of the
    /// pair, no square root per support point), `None` with another support map.
    #[inline(always)]
    pub(crate) fn reach(&self) -> Option<f64> {
        self.reach
    }

    /// A's support point toward −u and B's toward u (A's frame): the point of A − B
    /// minimising `z·u` is their difference. `u` need not be unit (only its direction counts).
    #[inline(always)]
    pub(crate) fn parts(&self, u: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let a = self.a.local(&-u);
        let b = self.r * self.b.local(&(self.rt * u)) + self.t;
        (a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;
    use parry3d_f64::shape::{Ball, Cone, ConvexPolyhedron, Cuboid, Cylinder};

    /// The specialised supports are parry's: the same support value (u·p) in every direction,
    /// including the axis directions where the closed forms branch.
    #[test]
    fn specialised_supports_match_parrys() {
        // a hull of 23 points (not a multiple of 4: the scan's remainder is used)
        let hull: Vec<Point3<f64>> = (0..23)
            .map(|k| {
                let x = k as f64;
                Point3::new(
                    (1.3 * x).sin() * 0.3,
                    (0.7 * x).cos() * 0.2,
                    (2.1 * x).sin() * 0.25,
                )
            })
            .collect();
        let shapes: [Box<dyn Shape>; 5] = [
            Box::new(Cuboid::new(Vector3::new(0.3, 0.2, 0.1))),
            Box::new(Cylinder::new(0.25, 0.15)),
            Box::new(Cone::new(0.35, 0.2)),
            Box::new(Ball::new(0.4)),
            Box::new(ConvexPolyhedron::from_convex_hull(&hull).expect("hull")),
        ];
        let pos12 = nalgebra::Isometry3::from_parts(
            Vector3::new(0.5, -0.2, 1.0).into(),
            UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0),
        );
        let mut dirs: Vec<Vector3<f64>> = (0..200)
            .map(|k| {
                let x = k as f64;
                Vector3::new((1.3 * x).sin(), (0.7 * x).cos(), (2.9 * x).sin() - 0.1)
            })
            .collect();
        dirs.extend([Vector3::y(), -Vector3::y(), Vector3::x(), -Vector3::z()]);
        assert!(matches!(Kind::of(shapes[4].as_ref()), Some(Kind::Hull(_))));
        for sa in &shapes {
            for sb in &shapes {
                let pair = Placed::new(
                    Kind::of(sa.as_ref()).expect("support map"),
                    Kind::of(sb.as_ref()).expect("support map"),
                    &pos12,
                );
                let (ma, mb) = (
                    sa.as_support_map().expect("a"),
                    sb.as_support_map().expect("b"),
                );
                for u in &dirs {
                    // any positive multiple of u: only its direction counts
                    let (va, vb) = pair.parts(&(u * 3.7));
                    let a = ma.local_support_point(&-u);
                    let b = mb.support_point(&pos12, u);
                    let tol = 1e-14 * (1.0 + u.norm());
                    assert!((va.dot(u) - a.coords.dot(u)).abs() <= tol, "{u}");
                    assert!((vb.dot(u) - b.coords.dot(u)).abs() <= tol, "{u}");
                }
            }
        }
    }
}
