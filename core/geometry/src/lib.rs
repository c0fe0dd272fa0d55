//! Geometry shared by every component: the seed's polygonal solid (§2.6, appendix 2.1) in the
//! redundant forms the Instance Space keeps (§3.3) — convex planar polygons with their plane
//! `N·P + d = 0`, the per-side penalty planes used for point-in-polygon, the reduced (unique) edge
//! array, and the bounding box as centre + half-diagonal.
//!
//! Entry points:
//! * [`Polyhedron::from_polygons`] — validate and build from vertices and polygon index lists.
//! * [`Aabb`] — centre + half-diagonal boxes.
//! * [`shapes`] — the shape generators (box, cylinder, cone, truncated cone, sphere, extrusion,
//!   revolution) with their size-dependent default facet count.
//! * [`polygon2d`] — simple-polygon validation and convex decomposition.
//! * [`Polyhedron::mass_properties`] ([`mass`]) — volume, centre of mass, inertia.
//! * [`triangulate`] — the fan triangles of the (convex) polygons, for the display and export.
//!
//! Frames and units: metres, in the solid's own frame; polygons are listed counter-clockwise
//! seen from outside, so plane normals point outward.

#![forbid(unsafe_code)]

pub mod mass;
pub mod polygon2d;
mod polyhedron;
pub mod shapes;
pub mod triangulate;

pub use mass::{MassError, MassProperties};
pub use polyhedron::{
    Aabb, GeometryError, PLANARITY_TOL, Plane, Polygon, Polyhedron, check_polygon,
};

/// `x` for a message: plain when it reads well, in exponent form when Display would print
/// hundreds of digits (1e308 is 309 of them) or a long run of zeros (1e-12). Every user-facing
/// message that prints a number from the input goes through this.
pub fn readable(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-6..1e15).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The unit vector along `v` (an axis from user input), computed without overflow or
/// underflow: `v` is first divided by its largest |component|, so `[1e200, 0, 0]` and
/// `[1e-200, 0, 0]` are both the x axis (`v.norm()` would be ∞ and 0). `None` when `v` is zero
/// or not finite — the only axes that name no direction.
pub fn unit_axis(v: nalgebra::Vector3<f64>) -> Option<nalgebra::Unit<nalgebra::Vector3<f64>>> {
    if !v.iter().all(|x| x.is_finite()) {
        return None;
    }
    let largest = v.amax();
    if largest == 0.0 {
        return None;
    }
    // Every component of `v / largest` is in [-1, 1] and one is ±1: its norm is in [1, √3].
    Some(nalgebra::Unit::new_normalize(v / largest))
}

#[cfg(test)]
mod unit_axis_tests {
    use super::unit_axis;
    use nalgebra::Vector3;

    /// An axis scaled near either end of f64's range is still its direction; zero and
    /// non-finite axes are refused. Holds issue 34 item 9 (`postrotate` about `[1e200,0,0]`
    /// committed a no-op, `[1e-200,0,0]` was refused as zero).
    #[test]
    fn huge_and_tiny_axes_keep_their_direction() {
        let x = Vector3::x();
        for s in [1e200, 1e-200, f64::MAX, 5e-324, 1.0, -1e300] {
            let u = unit_axis(x * s).expect("a direction");
            assert_eq!(u.into_inner(), x * s.signum(), "{s}");
        }
        let u = unit_axis(Vector3::new(1e200, 1e200, 0.0)).expect("a direction");
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((u.into_inner() - Vector3::new(h, h, 0.0)).amax() < 1e-15);
        let u = unit_axis(Vector3::new(3e-320, 4e-320, 0.0)).expect("subnormal");
        assert!((u.into_inner() - Vector3::new(0.6, 0.8, 0.0)).amax() < 1e-3);
        for bad in [
            Vector3::zeros(),
            Vector3::new(f64::NAN, 0.0, 0.0),
            Vector3::new(f64::INFINITY, 0.0, 0.0),
            Vector3::new(1.0, f64::NEG_INFINITY, 0.0),
        ] {
            assert!(unit_axis(bad).is_none(), "{bad:?}");
        }
    }
}

#[cfg(test)]
mod readable_tests {
    use super::readable;

    /// Issue 34, messages: a message naming 1e308 printed all 309 digits of it.
    #[test]
    fn messages_print_huge_and_tiny_numbers_in_exponent_form_not_309_digits() {
        assert_eq!(readable(1e308), "1e308");
        assert_eq!(readable(-1.5e300), "-1.5e300");
        assert_eq!(readable(1e-12), "1e-12");
        assert_eq!(readable(0.25), "0.25");
        assert_eq!(readable(-3.0), "-3");
        assert_eq!(readable(0.0), "0");
        assert_eq!(readable(f64::INFINITY), "inf");
        assert!(format!("{}", 1e308).len() > 300, "what Display prints");
    }
}
