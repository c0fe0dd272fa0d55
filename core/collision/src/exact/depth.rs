//! The certified depth of two overlapping primitives, faster with the same answer (issue 37
//! item 4: what was left per `collide` request).
//!
//! [`super::collide`] answers a certified overlap whose GJK bracket is wider than the tolerance
//! this way: maximise the lower bound over directions (`lower::refine`, some 500 support pairs),
//! then (a) the refined bracket if it is now narrow enough, else (b) EPA's depth when it is
//! *usable* — agrees with the refined bound, or is deeper than −τ — else the refined bound. For
//! a deep overlap the search only decides (a) and whether τ (which it raises) still lets EPA's
//! depth through; [`epa_stands`] decides both without it:
//!
//! * (a) cannot happen when a ball of radius r about some point lies inside both solids: then
//!   every lower bound ℓ(u) = min u·A − max u·B is at most −2r (u·A reaches u·p − r, u·B
//!   reaches u·p + r), and GJK's own lower bound is certified below the true signed distance
//!   (≤ −2r), so the bracket stays wider than 2r − upper. The points tried are the midpoint
//!   of EPA's two witness points and points a fraction of EPA's depth from them towards
//!   either solid's centre (any point is sound; these are where a ball fits); the radius is a closed form per shape (cylinder, cone, box,
//!   ball), less a margin of 1e-9 of the pair's size, far above the rounding of any of these
//!   numbers (~1e-16 of the size).
//! * τ after the search is `ROUNDING × max(|a| + |b|)` over the support pairs it evaluates, at
//!   most `ROUNDING × (R_A + R_B + |t₁₂|)` (the shapes' bounding radii and B's offset); EPA's
//!   depth below minus that is usable whatever the search finds.
//!
//! When both hold the answer is EPA's, as before, bit for bit; otherwise the caller runs the
//! search as before, reusing the EPA it has. EPA itself ([`contact`]) is parry's
//! `contact_support_map_support_map` called on the concrete shapes (cylinder, cone, box) rather
//! than through `dyn SupportMap`: the same code and the same floating-point operations, its
//! support functions inlined. The test `depth_shortcut_answers_as_the_search_does` compares
//! both paths bit for bit.
//!
//! Entry points: [`contact`], [`epa_stands`] (in tests, [`ENABLED`] false runs the path before
//! through both).

use super::gjk::{ROUNDING, Separation};
use nalgebra::{Isometry3, Point3};
use parry3d_f64::query::{self, Contact, Unsupported};
use parry3d_f64::shape::Shape;

#[cfg(test)]
thread_local! {
    /// Tests only: `false` runs the path before this module (parry's dispatcher, the search
    /// always), to compare the answers bit for bit.
    pub(crate) static ENABLED: std::cell::Cell<bool> = const { std::cell::Cell::new(true) };
    /// Tests only: how many answers [`epa_stands`] let through (the shortcut taken).
    pub(crate) static TAKEN: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Whether the shortcuts run (always outside tests).
fn enabled() -> bool {
    #[cfg(test)]
    {
        ENABLED.with(std::cell::Cell::get)
    }
    #[cfg(not(test))]
    {
        true
    }
}

/// parry's `query::contact(ga, sa, gb, sb, 0.0)`, the same result bit for bit, on the concrete
/// support functions where both shapes are cylinders, cones or boxes (parry's dispatcher sends
/// these pairs to `contact_support_map_support_map` through `dyn SupportMap`).
pub(crate) fn contact(
    ga: &Isometry3<f64>,
    sa: &dyn Shape,
    gb: &Isometry3<f64>,
    sb: &dyn Shape,
) -> Result<Option<Contact>, Unsupported> {
    use query::details::contact_support_map_support_map as epa;
    if !enabled() {
        return query::contact(ga, sa, gb, sb, 0.0);
    }
    let pos12 = ga.inv_mul(gb);
    macro_rules! with_b {
        ($a:expr) => {
            if let Some(b) = sb.as_cylinder() {
                epa(&pos12, $a, b, 0.0)
            } else if let Some(b) = sb.as_cone() {
                epa(&pos12, $a, b, 0.0)
            } else if let Some(b) = sb.as_cuboid() {
                epa(&pos12, $a, b, 0.0)
            } else {
                return query::contact(ga, sa, gb, sb, 0.0);
            }
        };
    }
    let mut c = if let Some(a) = sa.as_cylinder() {
        with_b!(a)
    } else if let Some(a) = sa.as_cone() {
        with_b!(a)
    } else if let Some(a) = sa.as_cuboid() {
        with_b!(a)
    } else {
        return query::contact(ga, sa, gb, sb, 0.0);
    };
    if let Some(c) = &mut c {
        c.transform_by_mut(ga, gb);
    }
    Ok(c)
}

/// The radius of a ball about the origin holding `s` (its own frame); `None` for shapes
/// without a closed form here.
fn bounding_radius(s: &dyn Shape) -> Option<f64> {
    if let Some(c) = s.as_cylinder() {
        Some(c.radius.hypot(c.half_height))
    } else if let Some(k) = s.as_cone() {
        // apex at y = +h, base rim at radius r, y = −h
        Some(k.radius.hypot(k.half_height))
    } else if let Some(b) = s.as_cuboid() {
        Some(b.half_extents.norm())
    } else {
        s.as_ball().map(|b| b.radius)
    }
}

/// The radius of the largest ball about `p` (shape frame) inside `s`: negative when `p` is
/// outside; `None` for shapes without a closed form here.
fn inside_radius(s: &dyn Shape, p: &Point3<f64>) -> Option<f64> {
    if let Some(c) = s.as_cylinder() {
        let rho = p.x.hypot(p.z);
        Some((c.radius - rho).min(c.half_height - p.y.abs()))
    } else if let Some(k) = s.as_cone() {
        // parry's cone: the side is the line from (ρ, y) = (r, −h) to (0, h); the solid is
        // the intersection of the half-spaces tangent along each generator, the nearest of
        // which (to p) is the one in p's meridian plane: 2h ρ + r y ≤ r h.
        let (r, h) = (k.radius, k.half_height);
        let rho = p.x.hypot(p.z);
        let side = (r * (h - p.y) - 2.0 * h * rho) / (2.0 * h).hypot(r);
        Some(side.min(p.y + h))
    } else if let Some(b) = s.as_cuboid() {
        let he = b.half_extents;
        Some(
            (he.x - p.x.abs())
                .min(he.y - p.y.abs())
                .min(he.z - p.z.abs()),
        )
    } else {
        s.as_ball().map(|b| b.radius - p.coords.norm())
    }
}

/// Is EPA's answer `c` what the certified path (direction search, then the bracket or EPA)
/// answers, whatever the search finds? `s` is GJK's bracket (A's frame, `pos12` places B
/// there), `tol` the bracket width asked. See the module text for why.
#[allow(clippy::too_many_arguments)]
pub(crate) fn epa_stands(
    c: &Result<Option<Contact>, Unsupported>,
    ga: &Isometry3<f64>,
    sa: &dyn Shape,
    gb: &Isometry3<f64>,
    sb: &dyn Shape,
    pos12: &Isometry3<f64>,
    s: &Separation,
    tol: f64,
) -> bool {
    let Ok(Some(c)) = c else {
        return false;
    };
    if !enabled() {
        return false;
    }
    let (Some(ra), Some(rb)) = (bounding_radius(sa), bounding_radius(sb)) else {
        return false;
    };
    if !(c.dist.is_finite() && s.upper.is_finite() && s.tau.is_finite()) {
        return false;
    }
    let offset = pos12.translation.vector.norm();
    // (b) the largest τ the search can reach; EPA's depth must be below minus it
    let tau_max = s.tau.max(ROUNDING * (ra + rb + offset) * (1.0 + 1e-6));
    if !(c.dist.min(0.0) < -tau_max) {
        return false;
    }
    // (a) a ball inside both solids: about the midpoint of EPA's witness points, or a point a
    // fraction of the depth from a witness point towards its solid's centre (the deepest point
    // is often a cone's apex or a rim, where the midpoint lies on the surface)
    let m = nalgebra::center(&c.point1, &c.point2);
    let (ca, cb) = (ga.translation.vector, gb.translation.vector);
    let depth = -c.dist;
    let towards = |from: &Point3<f64>, to: &nalgebra::Vector3<f64>, k: f64| {
        let d = to - from.coords;
        let n = d.norm();
        if n > 0.0 {
            from + d * (k * depth / n)
        } else {
            *from
        }
    };
    let candidates = [
        m,
        towards(&c.point2, &cb, 0.75),
        towards(&c.point1, &ca, 0.75),
        towards(&c.point2, &cb, 0.5),
        towards(&c.point1, &ca, 0.5),
        towards(&m, &cb, 0.25),
        towards(&m, &ca, 0.25),
    ];
    let mut best = f64::NEG_INFINITY;
    for p in candidates {
        let (Some(in_a), Some(in_b)) = (
            inside_radius(sa, &ga.inverse_transform_point(&p)),
            inside_radius(sb, &gb.inverse_transform_point(&p)),
        ) else {
            return false;
        };
        best = best.max(in_a.min(in_b));
        if best > 1e-6 * (ra + rb) {
            break;
        }
    }
    let size = ra + rb + offset + m.coords.norm() + ca.norm() + cb.norm();
    let r = best - 1e-9 * size;
    let stands = r.is_finite() && 2.0 * r > s.upper + tol + 1e3 * tau_max;
    #[cfg(test)]
    if stands {
        TAKEN.with(|t| t.set(t.get() + 1));
    }
    stands
}

#[cfg(test)]
mod tests {
    use super::{ENABLED, TAKEN};
    use crate::Solid;
    use crate::exact::{ExactOptions, Tolerance, collide};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn pose(rng: &mut ChaCha8Rng, reach: f64) -> Isometry3<f64> {
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let rot = UnitQuaternion::from_scaled_axis(axis * rng.random_range(0.0..3.2));
        let t = Vector3::new(
            rng.random_range(-reach..reach),
            rng.random_range(-reach..reach),
            rng.random_range(-reach..reach),
        );
        Isometry3::from_parts(Translation3::from(t), rot)
    }

    /// The certified (and a GJK-tolerance) `collide` with the shortcuts and without them (the
    /// path before: parry's dispatcher, the direction search always) give the same answer bit
    /// for bit — deep overlaps, shallow ones (1e-12 … 1e-3 m, made by moving a clear pair along
    /// its closest-point direction), and clear pairs; cylinders, cones, boxes and balls at 1 m
    /// and 100 m. The shortcut must be taken on at least 90 % of the deep overlaps (else nothing
    /// is tested).
    #[test]
    fn depth_shortcut_answers_as_the_search_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        let mut compared = 0;
        let mut overlaps = 0;
        TAKEN.with(|t| t.set(0));
        for scale in [1.0, 100.0] {
            let shapes = [
                Solid::cylinder(0.2 * scale, 0.5 * scale, None).expect("cylinder"),
                Solid::cone(0.15 * scale, 0.4 * scale, None).expect("cone"),
                Solid::cuboid(Vector3::new(0.3, 0.2, 0.25) * scale).expect("box"),
                Solid::sphere(0.12 * scale, None).expect("ball"),
                Solid::cylinder(0.02 * scale, 0.9 * scale, None).expect("thin cylinder"),
            ];
            for a in &shapes {
                for b in &shapes {
                    for i in 0..60 {
                        let pa = pose(&mut rng, 0.2 * scale);
                        let mut pb = pose(&mut rng, 0.5 * scale);
                        if i % 3 == 0 {
                            // a shallow overlap: a clear pair moved along its closest points
                            let clear = collide(a, &pa, b, &pb, ExactOptions::default());
                            if let (Some(d), Some(w)) = (clear.signed_distance(), clear.witness())
                                && d > 0.0
                            {
                                let depth = [1e-12, 1e-9, 1e-6, 1e-3][(i / 3) % 4] * scale;
                                let dir = (w[0] - w[1]) / d;
                                pb = Translation3::from(dir * (d + depth)) * pb;
                            }
                        }
                        for tolerance in [Tolerance::Certified, Tolerance::Gjk(1e-6)] {
                            let opts = ExactOptions {
                                tolerance,
                                ..ExactOptions::default()
                            };
                            ENABLED.with(|e| e.set(false));
                            let before = collide(a, &pa, b, &pb, opts);
                            ENABLED.with(|e| e.set(true));
                            let now = collide(a, &pa, b, &pb, opts);
                            assert_eq!(
                                format!("{now:?}"),
                                format!("{before:?}"),
                                "{:?} vs {:?}, {pa:?}, {pb:?}, {tolerance:?}",
                                a.kind,
                                b.kind
                            );
                            compared += 1;
                            if tolerance == Tolerance::Certified
                                && now.signed_distance().is_some_and(|d| d < -1e-3 * scale)
                            {
                                overlaps += 1;
                            }
                        }
                    }
                }
            }
        }
        let taken = TAKEN.with(std::cell::Cell::get);
        eprintln!("{compared} answers compared, {overlaps} deep overlaps, shortcut taken {taken}");
        assert!(compared >= 5000, "{compared}");
        assert!(
            overlaps >= 300 && taken * 10 >= overlaps * 9,
            "shortcut taken {taken} times over {overlaps} deep overlaps"
        );
    }
}
