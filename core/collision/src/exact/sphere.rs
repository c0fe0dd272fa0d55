//! A ball against a box, a cylinder or a cone in closed form: the signed distance is
//! `|c − P(c)| − r`, c the ball's centre and P the exact projection onto the other solid.
//!
//! parry 0.25.3's `project_local_point` is closed form for these three types (read in
//! `src/query/point/`): `Cuboid` clamps the point to the box (`point_aabb.rs`); `Cylinder`
//! chooses among the top or bottom disc, their rims and the side by the point's height and
//! radial distance (`point_cylinder.rs`); `Cone` projects onto the base disc or onto the
//! generating segment apex → rim in the point's azimuthal half-plane (`point_cone.rs`,
//! through `Segment::project_local_point`). No iteration, so the distance is exact up to
//! rounding. `ConvexPolyhedron`'s projection is parry's GJK (`point_support_map.rs`): hulls
//! are left to the certified GJK ([`super::gjk`]).
//!
//! **Rounding rule.** Every step (the centre into the other's frame, the clamp / normalise /
//! segment projection, the final norm) is a handful of f64 operations on coordinates of size at
//! most L = |c| + |t| + h + r (world centre, other's world translation, other's half-diagonal,
//! radius), each off by at most a few ε L; τ = [`ROUNDING`] · L (16 ε L) bounds the total.
//! So: **apart** when `d − r > max(τ, CONTACT_BAND)` (certified), **touching or overlapping**
//! otherwise (the answer the contact band allows), with signed distance `d − r` (exact to τ)
//! when the centre is outside the other solid. A centre inside the other solid (parry's solid
//! projection reports it) is a contact; its depth is left to the caller's general path.
//!
//! Entry point: [`ball_against`].

use super::gjk::CONTACT_BAND;
use nalgebra::{Isometry3, Point3};
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{Ball, Shape};

/// Rounding allowance per unit of coordinate magnitude: τ = `ROUNDING` · L.
pub(crate) const ROUNDING: f64 = 16.0 * f64::EPSILON;

/// What the closed form found. Points in the world frame.
#[derive(Debug, Clone, Copy)]
pub(crate) enum BallAnswer {
    /// Certified apart: `distance` > max(τ, CONTACT_BAND), exact to τ.
    Apart {
        distance: f64,
        on_ball: Point3<f64>,
        on_other: Point3<f64>,
    },
    /// Centre outside, `d − r ≤ max(τ, CONTACT_BAND)`: touching or overlapping by
    /// `-signed_distance` (exact to τ; clamped to ≤ 0).
    Contact {
        signed_distance: f64,
        on_ball: Point3<f64>,
        on_other: Point3<f64>,
    },
    /// The centre is inside (or on) the other solid: contact; the depth is not computed here.
    CentreInside,
}

/// The closed form, when `other` is a `Cuboid`, `Cylinder` or `Cone`; `None` otherwise (or
/// when a coordinate is not finite), and the caller uses the certified GJK.
/// `gball`, `gother`: parry shape → world.
pub(crate) fn ball_against(
    gball: &Isometry3<f64>,
    ball: &Ball,
    gother: &Isometry3<f64>,
    other: &dyn Shape,
) -> Option<BallAnswer> {
    let c = Point3::from(gball.translation.vector);
    let local = gother.inverse_transform_point(&c);
    let (proj, half_diag) = if let Some(b) = other.as_cuboid() {
        (b.project_local_point(&local, true), b.half_extents.norm())
    } else if let Some(y) = other.as_cylinder() {
        (
            y.project_local_point(&local, true),
            y.half_height.hypot(y.radius),
        )
    } else if let Some(k) = other.as_cone() {
        (
            k.project_local_point(&local, true),
            k.half_height.hypot(k.radius),
        )
    } else {
        return None;
    };
    let r = ball.radius;
    let scale = c.coords.norm() + gother.translation.vector.norm() + half_diag + r;
    if !scale.is_finite() || !proj.point.coords.iter().all(|x| x.is_finite()) {
        return None;
    }
    if proj.is_inside {
        return Some(BallAnswer::CentreInside);
    }
    let tau = ROUNDING * scale;
    let on_other = gother * proj.point;
    let diff = on_other - c;
    let d = diff.norm();
    // d = 0 with "outside" is a centre on the surface within rounding: the depth is r.
    let on_ball = if d > 0.0 { c + diff * (r / d) } else { c };
    let sd = d - r;
    if sd > tau.max(CONTACT_BAND) {
        Some(BallAnswer::Apart {
            distance: sd,
            on_ball,
            on_other,
        })
    } else {
        Some(BallAnswer::Contact {
            signed_distance: sd.min(0.0),
            on_ball,
            on_other,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use parry3d_f64::shape::{Cone, Cuboid, Cylinder};

    #[test]
    fn ball_beside_a_cylinder_side_is_exact() {
        // parry's cylinder axis is y; the side is at radius 0.3.
        let cyl = Cylinder::new(0.5, 0.3);
        let ball = Ball::new(0.2);
        for gap in [1e-9, 0.0, -1e-9, 0.25] {
            let x = 0.3 + 0.2 + gap;
            let gb = Isometry3::translation(x * 0.6, 0.1, x * 0.8);
            match ball_against(&gb, &ball, &Isometry3::identity(), &cyl).expect("closed form") {
                BallAnswer::Apart { distance, .. } => {
                    assert!(
                        gap > 0.0 && (distance - gap).abs() < 1e-15,
                        "{gap} {distance}"
                    );
                }
                BallAnswer::Contact {
                    signed_distance, ..
                } => {
                    assert!(gap <= 0.0 && (signed_distance - gap).abs() < 1e-15, "{gap}");
                }
                BallAnswer::CentreInside => panic!("centre outside"),
            }
        }
    }

    #[test]
    fn ball_at_a_cone_rim_and_inside_a_box() {
        // Cone: apex (0, 0.5, 0), rim radius 0.4 at y = -0.5. A ball below-outside the rim.
        let cone = Cone::new(0.5, 0.4);
        let gb = Isometry3::translation(0.4 + 0.3, -0.5 - 0.4, 0.0);
        match ball_against(&gb, &Ball::new(0.5), &Isometry3::identity(), &cone) {
            Some(BallAnswer::Contact {
                signed_distance, ..
            }) => assert!(signed_distance.abs() < 1e-15),
            other => panic!("{other:?}"),
        }
        let bx = Cuboid::new(Vector3::new(1.0, 1.0, 1.0));
        let gb = Isometry3::translation(0.5, 0.0, 0.0);
        assert!(matches!(
            ball_against(&gb, &Ball::new(0.1), &Isometry3::identity(), &bx),
            Some(BallAnswer::CentreInside)
        ));
    }
}
