//! The bounding-box mode and the box arithmetic every mode starts with (seed §2.6, Eq. 6–9):
//! boxes are centre + half-diagonal in a body's own frame, carried into another frame with the
//! dilation product `D₁,₂ = D₁ @ T₁T₂⁻¹` (the product with absolute values), and two boxes
//! overlap only if *both* "B₁ in frame 2 meets B₂" and "B₂ in frame 1 meets B₁" hold.
//!
//! Entry points: [`box_in_frame`], [`overlap_two_way`], [`world_box`], [`collide`].

use crate::outcome::PairResult;
use crate::solid::Solid;
use nalgebra::Isometry3;
use robosim_geometry::Aabb;

/// Box `b` of a body posed by `t1` (body → world), expressed in the frame of a body posed by
/// `t2`: seed Eq. 8 for the centre, Eq. 9 (dilation product) for the half-diagonal.
#[inline]
pub fn box_in_frame(b: &Aabb, t1: &Isometry3<f64>, t2: &Isometry3<f64>) -> Aabb {
    b.transformed(&t2.inv_mul(t1))
}

/// The seed's two-way overlap test: true only if each box, carried into the other's frame,
/// overlaps it. Touching counts as overlapping.
#[inline]
pub fn overlap_two_way(b1: &Aabb, t1: &Isometry3<f64>, b2: &Aabb, t2: &Isometry3<f64>) -> bool {
    box_in_frame(b1, t1, t2).overlaps(b2) && box_in_frame(b2, t2, t1).overlaps(b1)
}

/// The world-aligned box of a body's box under `pose` (dilation product); used by the broad
/// phase and for the robot box (seed: "a bounding box around all these bounding boxes").
#[inline]
pub fn world_box(b: &Aabb, pose: &Isometry3<f64>) -> Aabb {
    b.transformed(pose)
}

/// A box that holds the *exact* solid: the faceted form's box (`Solid::bbox`) widened by the
/// tessellation error. A round primitive whose facet count is not a multiple of 4 has a
/// faceted box smaller than the true solid (a hexagonal prism is 0.87 r wide across its flats),
/// so the exact mode's culling starts from this one.
#[inline]
pub fn exact_box(s: &Solid) -> Aabb {
    Aabb {
        center: s.bbox.center,
        half: s.bbox.half.add_scalar(s.tessellation_error),
    }
}

/// The bbox mode: contact iff the solids' boxes pass the two-way test. Conservative — it never
/// misses a contact of the faceted solids, and says contact for many pairs that are clear.
pub fn collide(a: &Solid, pa: &Isometry3<f64>, b: &Solid, pb: &Isometry3<f64>) -> PairResult {
    if overlap_two_way(&a.bbox, pa, &b.bbox, pb) {
        PairResult::Contact {
            signed_distance: None,
            witness: None,
        }
    } else {
        PairResult::Clear {
            distance: None,
            witness: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};

    #[test]
    fn two_way_test_is_tighter_than_either_one_way_test() {
        // A long thin box rotated 45° about z next to a small box: its dilated box in the small
        // box's frame overlaps, but the small box carried into the long box's frame does not.
        let long = Aabb {
            center: Point3::origin(),
            half: Vector3::new(1.0, 0.01, 0.01),
        };
        let small = Aabb {
            center: Point3::origin(),
            half: Vector3::new(0.05, 0.05, 0.05),
        };
        let t1 = Isometry3::new(
            Vector3::zeros(),
            Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_4),
        );
        let t2 = Isometry3::translation(0.5, -0.3, 0.0);
        assert!(box_in_frame(&long, &t1, &t2).overlaps(&small));
        assert!(!box_in_frame(&small, &t2, &t1).overlaps(&long));
        assert!(!overlap_two_way(&long, &t1, &small, &t2));
    }
}
