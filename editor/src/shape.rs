//! The objects R2 and ROBOSIM make (seed §2.3, MAKE OBJECT menu; Table 1's commands): the
//! primitives, the special surfaces and the joint markers, with their parameters in SI units.
//! One [`Shape`] value is both what the editor stores and what the language creates; its
//! polygons come from the Library Space's shape generators (`robosim_geometry::shapes`), so
//! "what is seen in the editor is the same as what will be by ROBOSIM" (§2.3).
//!
//! Facet counts are fixed when an object is made (the size-dependent default of
//! [`robosim_geometry::shapes::default_facets`] at that size): a resize keeps the polygon
//! numbering, so attachments to polygon k stay on polygon k.

use nalgebra::{Matrix4, Point2, Point3, Vector3};
use robosim_file_io::linkfile::LinkJoint;
use robosim_geometry::Polyhedron;
use robosim_geometry::shapes::{self, DEFAULT_CHORD_TOL, ShapeError, default_facets};
use serde::{Deserialize, Serialize};

/// What an object is, with its dimensions (m, rad).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Shape {
    Box {
        x: f64,
        y: f64,
        z: f64,
    },
    Cylinder {
        r: f64,
        h: f64,
        n: usize,
    },
    Cone {
        r: f64,
        h: f64,
        n: usize,
    },
    /// `upper` radius at +h/2, `lower` at −h/2.
    TruncatedCone {
        upper: f64,
        lower: f64,
        h: f64,
        n: usize,
    },
    Sphere {
        r: f64,
        n: usize,
    },
    /// A polygon in the XY plane extruded by `h` symmetrically about z = 0; the polygon keeps
    /// its XY placement (Table 1's custom object sits on its cylinder only this way).
    Extrude {
        profile: Vec<[f64; 2]>,
        h: f64,
    },
    /// A (ρ, z) profile revolved about z by `angle`, `n` segments; it keeps its z placement.
    Revolve {
        profile: Vec<[f64; 2]>,
        angle: f64,
        n: usize,
    },
    /// A joint marker: the link's input (I) or output (I+1) joint frame, z along the axis.
    Joint {
        kind: LinkJoint,
        output: bool,
    },
}

/// The default facet count of a round shape of radius `r` (m).
pub fn facets_for(r: f64) -> usize {
    if r.is_finite() && r > 0.0 {
        default_facets(r, DEFAULT_CHORD_TOL)
    } else {
        8
    }
}

impl Shape {
    /// The ROBOSIM command that makes it (R2 stored this as the object's name).
    pub fn command(&self) -> String {
        match self {
            Shape::Box { .. } => "BOX".into(),
            Shape::Cylinder { .. } => "CYLINDER".into(),
            Shape::Cone { .. } => "CONE".into(),
            Shape::TruncatedCone { .. } => "TRUNCATED-CONE".into(),
            Shape::Sphere { .. } => "SPHERE".into(),
            Shape::Extrude { .. } => "EXTRUDE-SURFACE".into(),
            Shape::Revolve { .. } => "REV-SURFACE".into(),
            Shape::Joint { kind, output } => {
                format!(
                    "{}-JOINT-{}",
                    kind.letter(),
                    if *output { "I+1" } else { "I" }
                )
            }
        }
    }

    pub fn is_joint(&self) -> bool {
        matches!(self, Shape::Joint { .. })
    }

    /// The solid's polygons in its own frame (None for a joint marker).
    pub fn polyhedron(&self) -> Result<Option<Polyhedron>, ShapeError> {
        Ok(Some(match self {
            Shape::Box { x, y, z } => shapes::cuboid(*x, *y, *z)?,
            Shape::Cylinder { r, h, n } => shapes::cylinder(*r, *h, Some(*n))?,
            Shape::Cone { r, h, n } => shapes::cone(*r, *h, Some(*n))?,
            Shape::TruncatedCone { upper, lower, h, n } => {
                shapes::truncated_cone(*lower, *upper, *h, Some(*n))?
            }
            Shape::Sphere { r, n } => shapes::sphere(*r, Some(*n))?,
            Shape::Extrude { profile, h } => {
                let pts: Vec<Point2<f64>> =
                    profile.iter().map(|p| Point2::new(p[0], p[1])).collect();
                let p = shapes::extrude(&pts, *h)?;
                // The generator centres the solid on its box; put the polygon back where it was.
                let (lo, hi) = bounds(profile.iter().map(|p| [p[0], p[1], 0.0]));
                let c = Vector3::new((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, 0.0);
                shift(p, c)
            }
            Shape::Revolve { profile, angle, n } => {
                let pts: Vec<Point2<f64>> =
                    profile.iter().map(|p| Point2::new(p[0], p[1])).collect();
                let p = shapes::revolve(&pts, *angle, Some(*n))?;
                // Undo the generator's centring: the box of the revolved points as it made them.
                let full = *angle >= std::f64::consts::TAU * (1.0 - 1e-12);
                let ring = if full { *n } else { *n + 1 };
                let pts3 = profile.iter().flat_map(|q| {
                    (0..ring).map(move |k| {
                        let (s, c) = (angle * k as f64 / *n as f64).sin_cos();
                        [q[0] * c, q[0] * s, q[1]]
                    })
                });
                let (lo, hi) = bounds(pts3);
                shift(
                    p,
                    Vector3::new(
                        (lo[0] + hi[0]) / 2.0,
                        (lo[1] + hi[1]) / 2.0,
                        (lo[2] + hi[2]) / 2.0,
                    ),
                )
            }
            Shape::Joint { .. } => return Ok(None),
        }))
    }

    /// Whether polygon `k` of this shape is a planar face of the modelled solid (not a facet
    /// of a curved surface standing in for it): boxes and extrusions have only planar faces;
    /// round solids only their flat caps (and the end caps of a partial revolution).
    pub fn planar_face(&self, poly: &Polyhedron, k: usize) -> bool {
        let n = poly.polygons[k].plane.normal;
        let cap = n.z.abs() > 1.0 - 1e-9;
        match self {
            Shape::Box { .. } | Shape::Extrude { .. } => true,
            Shape::Cylinder { .. } | Shape::Cone { .. } | Shape::TruncatedCone { .. } => cap,
            Shape::Sphere { .. } => false,
            Shape::Revolve { angle, .. } => {
                cap || (*angle < std::f64::consts::TAU * (1.0 - 1e-12) && n.z.abs() < 1e-9 && {
                    // an end cap lies in the plane through the axis at angle 0 or `angle`
                    let (s, c) = angle.sin_cos();
                    let end = Vector3::new(-s, c, 0.0);
                    (n - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-9 || (n - end).norm() < 1e-9
                })
            }
            Shape::Joint { .. } => true,
        }
    }

    /// The shape with new dimensions `dims` (the same list [`Shape::dims`] gives), or why not
    /// (a wrong count, a joint marker). Whether the new dimensions make a solid is the caller's
    /// [`Shape::polyhedron`] (its [`ShapeError`] kept).
    pub fn resized(&self, dims: &[f64]) -> Result<Shape, String> {
        let want = self.dims().len();
        if dims.len() != want {
            return Err(format!(
                "{} takes {want} dimensions ({}), got {}",
                self.command(),
                self.dim_names().join(", "),
                dims.len()
            ));
        }
        let d = |i: usize| dims[i];
        let s = match self {
            Shape::Box { .. } => Shape::Box {
                x: d(0),
                y: d(1),
                z: d(2),
            },
            Shape::Cylinder { n, .. } => Shape::Cylinder {
                r: d(0),
                h: d(1),
                n: *n,
            },
            Shape::Cone { n, .. } => Shape::Cone {
                r: d(0),
                h: d(1),
                n: *n,
            },
            Shape::TruncatedCone { n, .. } => Shape::TruncatedCone {
                upper: d(0),
                lower: d(1),
                h: d(2),
                n: *n,
            },
            Shape::Sphere { n, .. } => Shape::Sphere { r: d(0), n: *n },
            Shape::Extrude { profile, .. } => Shape::Extrude {
                profile: profile.clone(),
                h: d(0),
            },
            Shape::Revolve { profile, n, .. } => Shape::Revolve {
                profile: profile.clone(),
                angle: d(0),
                n: *n,
            },
            Shape::Joint { .. } => return Err("a joint marker has no dimensions".into()),
        };
        Ok(s)
    }

    /// The dimensions a resize takes, in order (m; a revolution's angle in rad).
    pub fn dims(&self) -> Vec<f64> {
        match self {
            Shape::Box { x, y, z } => vec![*x, *y, *z],
            Shape::Cylinder { r, h, .. } | Shape::Cone { r, h, .. } => vec![*r, *h],
            Shape::TruncatedCone {
                upper, lower, h, ..
            } => vec![*upper, *lower, *h],
            Shape::Sphere { r, .. } => vec![*r],
            Shape::Extrude { h, .. } => vec![*h],
            Shape::Revolve { angle, .. } => vec![*angle],
            Shape::Joint { .. } => vec![],
        }
    }

    pub fn dim_names(&self) -> &'static [&'static str] {
        match self {
            Shape::Box { .. } => &["X", "Y", "Z"],
            Shape::Cylinder { .. } | Shape::Cone { .. } => &["R", "H"],
            Shape::TruncatedCone { .. } => &["R1", "R2", "H"],
            Shape::Sphere { .. } => &["R"],
            Shape::Extrude { .. } => &["Z"],
            Shape::Revolve { .. } => &["A"],
            Shape::Joint { .. } => &[],
        }
    }
}

fn bounds(pts: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    (lo, hi)
}

fn shift(mut p: Polyhedron, c: Vector3<f64>) -> Polyhedron {
    if c == Vector3::zeros() {
        return p;
    }
    let iso = nalgebra::Isometry3::translation(c.x, c.y, c.z);
    p = p.transformed(&iso);
    p
}

/// A face's frame (seed §2.3, attach: "the normal direction for each polygon is set to the 'Z'
/// axis. Vectors for the 'X' and 'Y' axes must also be constructed"): origin at the polygon's
/// centre (the mean of its vertices), z along its outward normal, x along the object's own x
/// axis projected into the face — or its y axis when the normal is within 25.8° of ±x
/// (|n·x| > 0.9) — and y = z × x. The rule depends only on the face's plane, not on the
/// generator's vertex order, so a user can predict it: attaching Table 1's custom object to its
/// cylinder gives exactly Table 1's ROTATE X = -90, ROTATE Y = -90.
pub fn face_frame(poly: &Polyhedron, k: usize) -> Matrix4<f64> {
    let idx = poly.polygon_indices(k);
    let v: Vec<Point3<f64>> = idx.iter().map(|&i| poly.vertices[i as usize]).collect();
    let c = v.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / v.len() as f64;
    let n = poly.polygons[k].plane.normal.normalize();
    let e = if n.x.abs() > 0.9 {
        Vector3::y()
    } else {
        Vector3::x()
    };
    let x = (e - n * n.dot(&e)).normalize();
    let y = n.cross(&x);
    frame(&x, &y, &n, &c)
}

/// The attachment face of a joint marker: an input (I) joint's z points into the link (its
/// face normal is +z, turned to oppose the link's face); an output (I+1) joint's z points out
/// of it (face normal −z). So an I joint on a base's bottom face and an I+1 joint on a top face
/// both get z along the chain, as Table 1's F-JOINT-I and R-JOINT-I+1 have it.
pub fn joint_face(output: bool) -> Matrix4<f64> {
    if output {
        frame(
            &Vector3::x(),
            &-Vector3::y(),
            &-Vector3::z(),
            &Vector3::zeros(),
        )
    } else {
        Matrix4::identity()
    }
}

fn frame(x: &Vector3<f64>, y: &Vector3<f64>, z: &Vector3<f64>, o: &Vector3<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    for r in 0..3 {
        m[(r, 0)] = x[r];
        m[(r, 1)] = y[r];
        m[(r, 2)] = z[r];
        m[(r, 3)] = o[r];
    }
    m
}

/// The rigid inverse of a rotation-translation matrix (exact transpose, no general inverse).
pub fn rigid_inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let r = m.fixed_view::<3, 3>(0, 0).transpose();
    let t = -(r * m.fixed_view::<3, 1>(0, 3));
    let mut out = Matrix4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    out.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
    out
}

/// Rotation about a coordinate axis (0 = x, 1 = y, 2 = z) by `a` rad.
pub fn axis_rotation(axis: usize, a: f64) -> Matrix4<f64> {
    let v = match axis {
        0 => Vector3::x(),
        1 => Vector3::y(),
        _ => Vector3::z(),
    };
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(v), a).to_homogeneous()
}

/// Angles (a, b, c) with `R = Rz(c) Ry(b) Rx(a)` — R2's ROTATE X, then Y, then Z about the fixed
/// axes.
pub fn euler_xyz(m: &Matrix4<f64>) -> [f64; 3] {
    let r = m.fixed_view::<3, 3>(0, 0);
    let b = (-r[(2, 0)]).clamp(-1.0, 1.0).asin();
    if r[(2, 0)].abs() < 1.0 - 1e-12 {
        let a = r[(2, 1)].atan2(r[(2, 2)]);
        let c = r[(1, 0)].atan2(r[(0, 0)]);
        [a, b, c]
    } else {
        // gimbal lock: put everything in a (c = 0)
        let a = (-r[(1, 2)]).atan2(r[(1, 1)]);
        [a, b, 0.0]
    }
}
