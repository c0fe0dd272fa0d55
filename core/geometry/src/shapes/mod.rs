//! Shape generators: the seed's builder.h (§3.3) — box, cylinder, cone, truncated cone, sphere,
//! extruded polygon ("special surface", R2 §2.3) and revolved polygon — returning validated
//! [`Polyhedron`]s.
//!
//! Conventions (DESIGN.md, "Shapes"; builder.h notes 2–3):
//! * every solid is centred on its bounding box (the seed centred on the centre of mass; mass
//!   properties report that separately, see [`crate::mass`]);
//! * round solids have their axis along z; a cone's base disc is at z = −h/2, its apex at +h/2;
//!   a truncated cone has its `bottom` radius at −h/2 and its `top` radius at +h/2;
//! * polygons (extrude profiles) are given in the XY plane, revolve profiles as (ρ, z) points;
//! * every face is a convex planar polygon listed counter-clockwise seen from outside (outward
//!   normals); concave profiles are split into convex pieces ([`crate::polygon2d`]);
//! * lengths in metres, angles in radians.
//!
//! **Default facet count** (builder.h note 3, "if numfaces = 0 is given a default internal (size
//! dependent?)"): a circle of radius r replaced by the inscribed regular n-gon deviates from it by
//! at most the sagitta (chord error) `s(r, n) = r (1 − cos(π/n))`. We pick the smallest n with
//! `s ≤ ε`, `ε = DEFAULT_CHORD_TOL` = 1 mm:
//!
//! ```text
//! n(r) = clamp( ceil(π / acos(1 − ε/r)), 8, 256 )   rounded up to a multiple of 4
//! ```
//!
//! (≈ π·sqrt(r / 2ε) for r ≫ ε: 24 facets at r = 0.1 m, 72 at 1 m, 224 at 10 m). The multiple of
//! 4 keeps vertices on ±x and ±y, so the bounding box is exactly ±r and a cylinder's axis passes
//! through the origin. Because an inscribed n-gon contains the circle of radius r·cos(π/n), a
//! round solid's volume satisfies `cos²(π/n) ≤ V / V_exact ≤ 1` (cylinder, cones) and
//! `cos⁶(π/n) ≤ V / V_exact ≤ 1` for the sphere (see [`volume_error_bound`]); the golden tests
//! check exactly these bounds.
//!
//! Entry points: [`cuboid`], [`cylinder`], [`cone`], [`truncated_cone`], [`sphere`], [`extrude`],
//! [`revolve`]; [`default_facets`], [`chord_error`], [`volume_error_bound`].

mod sweep;

pub use sweep::{extrude, revolve};

use crate::polygon2d::PolygonError;
use crate::{GeometryError, Polyhedron};
use nalgebra::{Point2, Point3, Vector3};

/// The default chord-error tolerance, metres (see the module docs).
pub const DEFAULT_CHORD_TOL: f64 = 1e-3;
/// Bounds on the default facet count of a full circle.
pub const MIN_FACETS: usize = 8;
pub const MAX_FACETS: usize = 256;
/// The most facets a caller may ask for around a full circle (memory guard).
pub const FACET_LIMIT: usize = 16384;
/// The most facets (meridians) of a sphere, whose face count grows as n²/2 (memory guard).
pub const SPHERE_FACET_LIMIT: usize = 1024;

/// Why a shape could not be generated. Every variant names the shape and the parameter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A length that must be positive is zero, negative or not finite.
    #[error("{shape}: `{field}` must be a positive finite length in metres, got {value}")]
    NonPositive {
        shape: &'static str,
        field: &'static str,
        value: f64,
    },
    /// A length that may be zero is negative or not finite.
    #[error("{shape}: `{field}` must be zero or positive and finite, got {value}")]
    Negative {
        shape: &'static str,
        field: &'static str,
        value: f64,
    },
    /// The facet count is outside `[min, FACET_LIMIT]`.
    #[error("{shape}: facet count {facets} is out of range [{min}, {max}]")]
    FacetsOutOfRange {
        shape: &'static str,
        facets: usize,
        min: usize,
        max: usize,
    },
    /// A revolution angle outside (0, 2π].
    #[error("{shape}: revolution angle {angle} rad is out of range (0, 2π]")]
    AngleOutOfRange { shape: &'static str, angle: f64 },
    /// The profile polygon is not simple (see [`PolygonError`]).
    #[error("{shape}: profile: {source}")]
    Profile {
        shape: &'static str,
        source: PolygonError,
    },
    /// A revolve profile point lies at negative ρ (on the other side of the axis).
    #[error(
        "{shape}: profile point {index} has ρ = {rho} < 0: a revolve profile must lie on one side of the z axis (ρ ≥ 0)"
    )]
    ProfileCrossesAxis {
        shape: &'static str,
        index: usize,
        rho: f64,
    },
    /// A revolve profile touches the axis in two separate places (the solid would pinch).
    #[error(
        "{shape}: profile touches the z axis at points {first} and {second}, which are not adjacent: the revolved solid would pinch to a point"
    )]
    ProfileTouchesAxisTwice {
        shape: &'static str,
        first: usize,
        second: usize,
    },
    /// The generated faces failed validation (a bug or extreme input; names the face).
    #[error("{shape}: generated solid is invalid: {source}")]
    Geometry {
        shape: &'static str,
        source: GeometryError,
    },
}

/// The sagitta (chord error) of a regular n-gon inscribed in a circle of radius r, metres:
/// `r (1 − cos(π/n))`.
pub fn chord_error(radius: f64, facets: usize) -> f64 {
    radius * (1.0 - (std::f64::consts::PI / facets as f64).cos())
}

/// The default number of facets around a full circle of radius `radius` for chord tolerance
/// `tol` (both metres): the smallest n with `chord_error(r, n) ≤ tol`, clamped to
/// [`MIN_FACETS`, `MAX_FACETS`] and rounded up to a multiple of 4.
pub fn default_facets(radius: f64, tol: f64) -> usize {
    let n = if radius.is_nan() || tol.is_nan() || radius <= tol || tol <= 0.0 {
        MIN_FACETS
    } else {
        let step = (1.0 - tol / radius).acos();
        (std::f64::consts::PI / step).ceil() as usize
    };
    let n = n.clamp(MIN_FACETS, MAX_FACETS);
    n.div_ceil(4) * 4
}

/// The largest relative volume deficit `1 − V/V_exact` of a round primitive built with `facets`
/// around the axis: `1 − cos²(π/n)` for cylinders and cones (the polygon contains the circle of
/// radius r·cos(π/n)), `1 − cos⁶(π/n)` for a sphere (each face lies at least r·cos²(π/n) from
/// the centre). The faceted solid is inscribed, so it is never larger than the exact one.
pub fn volume_error_bound(sphere: bool, facets: usize) -> f64 {
    let c = (std::f64::consts::PI / facets as f64).cos();
    if sphere { 1.0 - c.powi(6) } else { 1.0 - c * c }
}

fn positive(shape: &'static str, field: &'static str, value: f64) -> Result<f64, ShapeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::NonPositive {
            shape,
            field,
            value,
        })
    }
}

fn non_negative(shape: &'static str, field: &'static str, value: f64) -> Result<f64, ShapeError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::Negative {
            shape,
            field,
            value,
        })
    }
}

fn facets_or_default(
    shape: &'static str,
    facets: Option<usize>,
    radius: f64,
    min: usize,
) -> Result<usize, ShapeError> {
    match facets {
        None => Ok(default_facets(radius, DEFAULT_CHORD_TOL).max(min)),
        Some(n) if (min..=FACET_LIMIT).contains(&n) => Ok(n),
        Some(n) => Err(ShapeError::FacetsOutOfRange {
            shape,
            facets: n,
            min,
            max: FACET_LIMIT,
        }),
    }
}

/// Drops vertices no face uses, translates the rest so their bounding box is centred on the
/// origin, then validates.
fn finish(
    shape: &'static str,
    all: Vec<Point3<f64>>,
    faces: &[Vec<u32>],
) -> Result<Polyhedron, ShapeError> {
    let mut remap = vec![u32::MAX; all.len()];
    let mut vertices = Vec::with_capacity(all.len());
    let mut faces: Vec<Vec<u32>> = faces.to_vec();
    for f in &mut faces {
        for i in f.iter_mut() {
            if let Some(slot) = remap.get_mut(*i as usize) {
                if *slot == u32::MAX {
                    *slot = vertices.len() as u32;
                    vertices.push(all[*i as usize]);
                }
                *i = *slot;
            }
        }
    }
    let faces = &faces[..];
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for f in faces {
        for &i in f {
            if let Some(v) = vertices.get(i as usize) {
                lo = lo.inf(&v.coords);
                hi = hi.sup(&v.coords);
            }
        }
    }
    if lo.iter().all(|c| c.is_finite()) {
        let c = (lo + hi) * 0.5;
        for v in &mut vertices {
            *v -= c;
        }
    }
    Polyhedron::from_polygons(vertices, faces)
        .map_err(|source| ShapeError::Geometry { shape, source })
}

/// A box with full side lengths `x`, `y`, `z` (metres), centred at the origin, faces normal to
/// the axes: 8 vertices, 6 faces.
pub fn cuboid(x: f64, y: f64, z: f64) -> Result<Polyhedron, ShapeError> {
    let h = Vector3::new(
        positive("box", "x", x)?,
        positive("box", "y", y)?,
        positive("box", "z", z)?,
    ) * 0.5;
    let v: Vec<Point3<f64>> = (0..8)
        .map(|i| {
            let s = |bit: usize| if (i >> bit) & 1 == 1 { 1.0 } else { -1.0 };
            Point3::new(s(0) * h.x, s(1) * h.y, s(2) * h.z)
        })
        .collect();
    let f = vec![
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ];
    finish("box", v, &f)
}

/// A right circular cylinder of `radius` and `height` (metres), axis z, approximated by the
/// inscribed prism with `facets` sides (default: [`default_facets`]): 2n vertices, n + 2 faces.
pub fn cylinder(radius: f64, height: f64, facets: Option<usize>) -> Result<Polyhedron, ShapeError> {
    truncated_cone_named("cylinder", radius, radius, height, facets)
}

/// A right circular cone: base disc of `radius` at z = −h/2, apex at z = +h/2; n + 1 vertices,
/// n + 1 faces.
pub fn cone(radius: f64, height: f64, facets: Option<usize>) -> Result<Polyhedron, ShapeError> {
    positive("cone", "radius", radius)?;
    truncated_cone_named("cone", radius, 0.0, height, facets)
}

/// A truncated cone (frustum): `bottom` radius at z = −h/2, `top` radius at z = +h/2. One
/// radius may be zero (a cone, pointing up or down); not both.
pub fn truncated_cone(
    bottom: f64,
    top: f64,
    height: f64,
    facets: Option<usize>,
) -> Result<Polyhedron, ShapeError> {
    truncated_cone_named("truncated cone", bottom, top, height, facets)
}

fn truncated_cone_named(
    shape: &'static str,
    bottom: f64,
    top: f64,
    height: f64,
    facets: Option<usize>,
) -> Result<Polyhedron, ShapeError> {
    let rb = non_negative(shape, "bottom radius", bottom)?;
    let rt = non_negative(shape, "top radius", top)?;
    let h = positive(shape, "height", height)?;
    if rb == 0.0 && rt == 0.0 {
        return Err(ShapeError::NonPositive {
            shape,
            field: "radius",
            value: 0.0,
        });
    }
    let n = facets_or_default(shape, facets, rb.max(rt), 3)?;
    let mut profile = vec![Point2::new(0.0, -h / 2.0)];
    if rb > 0.0 {
        profile.push(Point2::new(rb, -h / 2.0));
    }
    if rt > 0.0 {
        profile.push(Point2::new(rt, h / 2.0));
    }
    profile.push(Point2::new(0.0, h / 2.0));
    sweep::revolve_named(shape, &profile, std::f64::consts::TAU, Some(n))
}

/// A sphere of `radius` (metres): `facets` meridians (default: [`default_facets`], even) and
/// facets/2 latitude bands; triangles at the poles, planar trapezoids elsewhere. Vertices lie on
/// the sphere; n(n/2 − 1) + 2 vertices, n²/2 faces.
pub fn sphere(radius: f64, facets: Option<usize>) -> Result<Polyhedron, ShapeError> {
    let r = positive("sphere", "radius", radius)?;
    let n = facets_or_default("sphere", facets, r, 4)?;
    if n > SPHERE_FACET_LIMIT {
        return Err(ShapeError::FacetsOutOfRange {
            shape: "sphere",
            facets: n,
            min: 4,
            max: SPHERE_FACET_LIMIT,
        });
    }
    let bands = n.div_ceil(2).max(2); // latitude step π/bands ≤ 2π/n
    let mut profile = vec![Point2::new(0.0, -r)];
    for j in 1..bands {
        let phi = -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * j as f64 / bands as f64;
        let (s, c) = phi.sin_cos();
        profile.push(Point2::new(r * c, r * s));
    }
    profile.push(Point2::new(0.0, r));
    sweep::revolve_named("sphere", &profile, std::f64::consts::TAU, Some(n))
}
