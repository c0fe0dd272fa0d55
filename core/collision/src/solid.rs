//! Collision bodies in the two forms the modes need (seed §3.2: "store both representation
//! forms"): the faceted polyhedron the seed's polygon algorithm walks (planes, penalty planes,
//! reduced edge array, box — all from [`robosim_geometry::Polyhedron`]), and the exact shape
//! parry's GJK/EPA works on (the true primitive for box, sphere, cylinder and cone; the convex
//! hull for a convex point set; a triangle mesh with oriented pseudo-normals for a non-convex
//! polyhedron; a compound with a BVH for a body made of many convex parts).
//!
//! Entry points: [`Solid::cuboid`], [`Solid::sphere`], [`Solid::cylinder`], [`Solid::cone`],
//! [`Solid::convex`], [`Solid::mesh`], [`Solid::compound`], [`default_facets`].
//!
//! The faceted primitives come from the geometry library's generators
//! ([`robosim_geometry::shapes`]); the exact ones are parry's `Cuboid`, `Ball`, `Cylinder`, `Cone`.
//!
//! Conventions (DESIGN.md, Shapes): metres; every primitive is centred on its bounding box with
//! its axis along z; a cone's base disc is at z = −h/2 and its apex at z = +h/2. Faceted
//! primitives are *inscribed* (every vertex lies on the true surface), so the faceted solid is
//! inside the true one and [`Solid::tessellation_error`] is the Hausdorff distance between them.

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use parry3d_f64::shape::{SharedShape, TriMeshBuilderError, TriMeshFlags};
use robosim_geometry::{Aabb, GeometryError, Polyhedron, shapes};
use std::f64::consts::{FRAC_PI_2, PI};

/// Chord error the default facet count aims at, metres.
pub const DEFAULT_CHORD_ERROR: f64 = 1e-3;

/// Why a solid could not be built. Each variant names the offending field or part.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A size field is zero, negative or not finite. Fix the field it names.
    #[error("`{field}` must be finite and > 0, got {value}")]
    BadDimension { field: &'static str, value: f64 },
    /// Fewer than 3 facets around a round primitive.
    #[error("`facets` must be at least 3, got {0}")]
    TooFewFacets(usize),
    /// The polygon data was refused by the geometry library (names polygon and vertex).
    #[error("{0}")]
    Geometry(#[from] GeometryError),
    /// The solid is degenerate ([`DEGENERATE_RELATIVE_THICKNESS`]): its thickness 2V/S is at
    /// most 1e-9 of its extent L (flat, a line, a point, or empty). `part` is the compound part
    /// when the solid is one. Fix the points (or the size) it was built from.
    #[error(
        "{}the solid is degenerate: thickness 2V/S = {thickness:e} m for an extent (box \
         diagonal) of {extent:e} m, from {points} points; a solid needs a thickness above \
         1e-9 of its extent",
        part_prefix(*.part)
    )]
    Degenerate {
        part: Option<usize>,
        points: usize,
        thickness: f64,
        extent: f64,
    },
    /// parry refused the triangle mesh of a non-convex polyhedron (its error, kept typed).
    #[error("the triangle mesh was refused: {0}")]
    MeshRefused(#[source] TriMeshBuilderError),
    /// A compound part is itself a non-convex mesh or a compound (parry cannot nest them).
    #[error("compound part {0} is not convex (only convex parts may be combined)")]
    NonConvexPart(usize),
    /// The geometry library's shape generator refused the parameters.
    #[error("{0}")]
    Generator(#[from] shapes::ShapeError),
    /// A compound has no parts.
    #[error("a compound needs at least one part")]
    EmptyCompound,
}

fn part_prefix(part: Option<usize>) -> String {
    part.map_or(String::new(), |i| format!("compound part {i}: "))
}

/// A solid is **degenerate** when its thickness `t = 2V/S` (V its volume, S its surface area)
/// is at most `DEGENERATE_RELATIVE_THICKNESS · L`, L the diagonal of its bounding box — or when
/// it has no hull at all (L = 0, fewer than 4 points off one plane). t is the thickness of a
/// slab (a plate of thickness w has t → w), a third of a cube's side, half a square rod's width,
/// so the test is about flatness relative to the body's own size, at any scale: a 1e-4 m plate
/// 1 m wide passes (t/L ≈ 7e-5), 4 coplanar or coincident points do not. Applied by every
/// constructor ([`Solid::cuboid`] … [`Solid::convex`], closed [`Solid::mesh`]es, each part of a
/// [`Solid::compound`]), so the query protocol and the scene compiler, which build through
/// them, refuse the same solids with the same [`ShapeError::Degenerate`].
pub const DEGENERATE_RELATIVE_THICKNESS: f64 = 1e-9;

/// The degenerate-solid test on a closed triangulated surface (outward or inward, any
/// consistent orientation).
fn check_thickness(
    vertices: &[Point3<f64>],
    triangles: impl Iterator<Item = [u32; 3]>,
    part: Option<usize>,
) -> Result<(), ShapeError> {
    let (mut vol, mut area) = (0.0, 0.0);
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize].coords);
        vol += a.dot(&b.cross(&c)) / 6.0;
        area += (b - a).cross(&(c - a)).norm() / 2.0;
    }
    let extent = Aabb::from_points(vertices).map_or(0.0, |b| 2.0 * b.half.norm());
    let thickness = if area > 0.0 {
        2.0 * vol.abs() / area
    } else {
        0.0
    };
    if extent > 0.0 && thickness > DEGENERATE_RELATIVE_THICKNESS * extent {
        Ok(())
    } else {
        Err(ShapeError::Degenerate {
            part,
            points: vertices.len(),
            thickness,
            extent,
        })
    }
}

/// The test on a primitive's closed-form volume, area and box diagonal (before its generator,
/// which would refuse a flat one with a polygon error instead).
fn check_dimensions(vol: f64, area: f64, extent: f64) -> Result<(), ShapeError> {
    let thickness = 2.0 * vol / area;
    if thickness > DEGENERATE_RELATIVE_THICKNESS * extent {
        Ok(())
    } else {
        Err(ShapeError::Degenerate {
            part: None,
            points: 0,
            thickness,
            extent,
        })
    }
}

/// The test on a validated polyhedron (its polygons fanned into triangles).
fn check_polyhedron(poly: &Polyhedron, part: Option<usize>) -> Result<(), ShapeError> {
    let tris = (0..poly.polygons.len()).flat_map(|i| {
        let ids = poly.polygon_indices(i);
        (1..ids.len() - 1).map(move |k| [ids[0], ids[k], ids[k + 1]])
    });
    check_thickness(&poly.vertices, tris, part)
}

impl ShapeError {
    /// The polygon (index in the input list) a geometry error names, if any.
    pub fn polygon(&self) -> Option<usize> {
        match self {
            ShapeError::Geometry(
                GeometryError::TooFewVertices { polygon, .. }
                | GeometryError::IndexOutOfRange { polygon, .. }
                | GeometryError::Degenerate { polygon, .. }
                | GeometryError::NonPlanar { polygon, .. }
                | GeometryError::Concave { polygon, .. },
            ) => Some(*polygon),
            _ => None,
        }
    }
}

/// What a solid was built from (kept for reports and for the containment logic).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolidKind {
    Cuboid,
    Sphere,
    Cylinder,
    Cone,
    Convex,
    Mesh,
    Compound,
}

/// One polyhedron of a body as the polygon mode uses it: the geometry library's redundant forms
/// plus, per polygon side, the index of its edge in the reduced edge array.
#[derive(Debug, Clone)]
pub struct Piece {
    pub poly: Polyhedron,
    /// Closed, and every vertex is on the inner side of every polygon plane.
    pub convex: bool,
    /// Closed, consistently oriented surface (needed for point-in-solid by ray parity).
    pub closed: bool,
    /// `side_edge[k]` = index into `poly.edges` of the side `poly.indices[k] → next`.
    pub side_edge: Vec<u32>,
}

impl Piece {
    /// Wraps a validated polyhedron; convexity is tested (every vertex on the inner side of
    /// every face plane, within 1e-9 of the size: O(faces × vertices)).
    pub fn new(poly: Polyhedron) -> Self {
        Self::wrap(poly, false)
    }

    /// Wraps a primitive's faceted form (box, sphere, cylinder, cone from the geometry
    /// library's generators), convex by construction: closed ⇒ convex without the
    /// O(faces × vertices) test, which takes seconds for a 256-facet sphere (its 32k faces and
    /// vertices). `primitives_are_closed_convex_and_inscribed` runs the full test on them.
    fn convex_primitive(poly: Polyhedron) -> Self {
        Self::wrap(poly, true)
    }

    fn wrap(poly: Polyhedron, convex_by_construction: bool) -> Self {
        let mut side_edge = Vec::with_capacity(poly.indices.len());
        for i in 0..poly.polygons.len() {
            let ids = poly.polygon_indices(i);
            for k in 0..ids.len() {
                let (a, b) = (ids[k], ids[(k + 1) % ids.len()]);
                let key = [a.min(b), a.max(b)];
                // Every side was inserted into `edges` by `Polyhedron::from_polygons`.
                let e = poly.edges.binary_search(&key).unwrap_or(0);
                side_edge.push(e as u32);
            }
        }
        let size = poly.bbox.half.norm().max(f64::MIN_POSITIVE);
        let closed = poly.is_closed();
        // An open surface is never taken for the solid hull of its vertices.
        let convex = closed
            && (convex_by_construction
                || poly.polygons.iter().all(|pg| {
                    poly.vertices
                        .iter()
                        .all(|v| pg.plane.signed_distance(v) <= 1e-9 * size)
                }));
        Piece {
            poly,
            convex,
            closed,
            side_edge,
        }
    }
}

/// A collision body (see the module docs).
#[derive(Debug, Clone)]
pub struct Solid {
    pub kind: SolidKind,
    /// Faceted form(s) for the polygon mode; several for a compound.
    pub pieces: Vec<Piece>,
    /// The exact shape for parry, in its own frame …
    pub exact: SharedShape,
    /// … placed in the solid's frame by this transform (parry's round shapes have their axis
    /// along y; ours along z).
    pub exact_offset: Isometry3<f64>,
    /// Hausdorff distance between the faceted and the exact solid, metres (0 when the faceted
    /// form *is* the exact one).
    pub tessellation_error: f64,
    /// Box of the faceted pieces in the solid's frame (centre + half-diagonal, seed Eq. 6).
    pub bbox: Aabb,
    /// Volume of the exact solid, m³ (for reports; `None` for meshes and compounds).
    pub exact_volume: Option<f64>,
}

fn positive(field: &'static str, value: f64) -> Result<f64, ShapeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::BadDimension { field, value })
    }
}

/// The default facet count around a round primitive of `radius` (m): the geometry library's
/// size-dependent count for a chord error of [`DEFAULT_CHORD_ERROR`] (a multiple of 4, 8 to 256).
pub fn default_facets(radius: f64) -> usize {
    shapes::default_facets(radius, DEFAULT_CHORD_ERROR)
}

fn facets_checked(facets: Option<usize>, r: f64) -> Result<usize, ShapeError> {
    let n = facets.unwrap_or_else(|| default_facets(r));
    if n < 3 {
        return Err(ShapeError::TooFewFacets(n));
    }
    Ok(n)
}

/// Rotation taking parry's y axis onto our z axis (Rx(+90°)).
fn y_to_z() -> Isometry3<f64> {
    Isometry3::from_parts(
        Default::default(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2),
    )
}

impl Solid {
    fn single(
        kind: SolidKind,
        poly: Polyhedron,
        exact: SharedShape,
        exact_offset: Isometry3<f64>,
        err: f64,
        vol: Option<f64>,
    ) -> Result<Self, ShapeError> {
        check_polyhedron(&poly, None)?;
        let bbox = poly.bbox;
        Ok(Solid {
            kind,
            pieces: vec![if kind == SolidKind::Convex {
                Piece::new(poly)
            } else {
                Piece::convex_primitive(poly)
            }],
            exact,
            exact_offset,
            tessellation_error: err,
            bbox,
            exact_volume: vol,
        })
    }

    /// A box with full side lengths `size` (m), centred at the origin.
    pub fn cuboid(size: Vector3<f64>) -> Result<Self, ShapeError> {
        let (x, y, z) = (
            positive("size[0]", size.x)?,
            positive("size[1]", size.y)?,
            positive("size[2]", size.z)?,
        );
        check_dimensions(
            x * y * z,
            2.0 * (x * y + y * z + z * x),
            (x * x + y * y + z * z).sqrt(),
        )?;
        let poly = shapes::cuboid(x, y, z)?;
        Self::single(
            SolidKind::Cuboid,
            poly,
            SharedShape::cuboid(x / 2.0, y / 2.0, z / 2.0),
            Isometry3::identity(),
            0.0,
            Some(x * y * z),
        )
    }

    /// A sphere of `radius` (m); faceted by the geometry library's generator with `facets`
    /// meridians (default [`default_facets`]) and `facets / 2` latitude bands.
    pub fn sphere(radius: f64, facets: Option<usize>) -> Result<Self, ShapeError> {
        let r = positive("radius", radius)?;
        let n = facets_checked(facets, r)?;
        let poly = shapes::sphere(r, Some(n))?;
        // Every face's nearest point to the centre lies inside the face (the faces are symmetric
        // about their centre ray), so the deepest gap is r − (smallest plane distance).
        let inner = poly
            .polygons
            .iter()
            .map(|p| p.plane.d.abs())
            .fold(f64::INFINITY, f64::min);
        let vol = 4.0 / 3.0 * PI * r.powi(3);
        Self::single(
            SolidKind::Sphere,
            poly,
            SharedShape::ball(r),
            Isometry3::identity(),
            r - inner,
            Some(vol),
        )
    }

    /// A cylinder of `radius` and `height` (m), axis z, centred; `facets` sides (default
    /// [`default_facets`]).
    pub fn cylinder(radius: f64, height: f64, facets: Option<usize>) -> Result<Self, ShapeError> {
        let (r, h) = (positive("radius", radius)?, positive("height", height)?);
        let n = facets_checked(facets, r)?;
        check_dimensions(
            PI * r * r * h,
            2.0 * PI * r * (r + h),
            (8.0 * r * r + h * h).sqrt(),
        )?;
        let poly = shapes::cylinder(r, h, Some(n))?;
        Self::single(
            SolidKind::Cylinder,
            poly,
            SharedShape::cylinder(h / 2.0, r),
            y_to_z(),
            shapes::chord_error(r, n),
            Some(PI * r * r * h),
        )
    }

    /// A cone of base `radius` and `height` (m): base disc at z = −h/2, apex at z = +h/2.
    pub fn cone(radius: f64, height: f64, facets: Option<usize>) -> Result<Self, ShapeError> {
        let (r, h) = (positive("radius", radius)?, positive("height", height)?);
        let n = facets_checked(facets, r)?;
        check_dimensions(
            PI * r * r * h / 3.0,
            PI * r * (r + (r * r + h * h).sqrt()),
            (8.0 * r * r + h * h).sqrt(),
        )?;
        let poly = shapes::cone(r, h, Some(n))?;
        // Hausdorff distance ≤ the base chord's sagitta (the gap shrinks linearly to the apex).
        Self::single(
            SolidKind::Cone,
            poly,
            SharedShape::cone(h / 2.0, r),
            y_to_z(),
            shapes::chord_error(r, n),
            Some(PI * r * r * h / 3.0),
        )
    }

    /// The exact form alone of a cylinder (`cone` false) or a cone of `radius` and `height`
    /// (m), for exact mode, which never reads a round solid's faceted form: the exact shape, the
    /// tessellation error of `facets` sides (default [`default_facets`]) and the volume as
    /// [`Solid::cylinder`] and [`Solid::cone`] give them, and the same inputs refused with the
    /// same errors, without building the faceted polyhedron — `pieces` is empty and `bbox` is
    /// the exact solid's box. Only exact mode may be given it ([`Solid::has_faceted_form`]).
    ///
    /// The faceted form is inscribed in the exact one, so its thickness 2V/S is at least
    /// (n/2π)·sin(2π/n) ≥ 0.41 of the exact one (smaller volume by that factor, smaller surface,
    /// smaller extent): an exact solid more than 3× the degeneracy bound thick has a sound
    /// faceted form. Nearer the bound, or with a facet count the geometry library refuses, the
    /// whole solid is built, so that the verdict and its error are the faceted check's.
    pub fn round_exact(
        cone: bool,
        radius: f64,
        height: f64,
        facets: Option<usize>,
    ) -> Result<Self, ShapeError> {
        let (r, h) = (positive("radius", radius)?, positive("height", height)?);
        let n = facets_checked(facets, r)?;
        let (vol, area) = if cone {
            (PI * r * r * h / 3.0, PI * r * (r + (r * r + h * h).sqrt()))
        } else {
            (PI * r * r * h, 2.0 * PI * r * (r + h))
        };
        let extent = (8.0 * r * r + h * h).sqrt();
        check_dimensions(vol, area, extent)?;
        let whole = || {
            if cone {
                Solid::cone(radius, height, facets)
            } else {
                Solid::cylinder(radius, height, facets)
            }
        };
        if n > shapes::FACET_LIMIT
            || 2.0 * vol / area <= 3.0 * DEGENERATE_RELATIVE_THICKNESS * extent
        {
            return whole();
        }
        let (kind, exact) = if cone {
            (SolidKind::Cone, SharedShape::cone(h / 2.0, r))
        } else {
            (SolidKind::Cylinder, SharedShape::cylinder(h / 2.0, r))
        };
        Ok(Solid {
            kind,
            pieces: Vec::new(),
            exact,
            exact_offset: y_to_z(),
            tessellation_error: shapes::chord_error(r, n),
            bbox: Aabb {
                center: Point3::origin(),
                half: Vector3::new(r, r, h / 2.0),
            },
            exact_volume: Some(vol),
        })
    }

    /// Whether the faceted form was built (every constructor but [`Solid::round_exact`]):
    /// what the bbox and polygon modes and the robot checks read.
    pub fn has_faceted_form(&self) -> bool {
        !self.pieces.is_empty()
    }

    /// The convex hull of `points` (m). The faceted form is parry's hull triangulation, so both
    /// forms are the same solid (tessellation error 0).
    pub fn convex(points: &[Point3<f64>]) -> Result<Self, ShapeError> {
        for (i, p) in points.iter().enumerate() {
            if !p.coords.iter().all(|c| c.is_finite()) {
                return Err(GeometryError::NonFiniteVertex {
                    vertex: i,
                    value: [p.x, p.y, p.z],
                }
                .into());
            }
        }
        let flat = || ShapeError::Degenerate {
            part: None,
            points: points.len(),
            thickness: 0.0,
            extent: Aabb::from_points(points).map_or(0.0, |b| 2.0 * b.half.norm()),
        };
        // Fewer than 4 points never span a volume (and parry's hull wants 4).
        if points.len() < 4 {
            return Err(flat());
        }
        let hull = SharedShape::convex_hull(points).ok_or_else(flat)?;
        let cp = hull.as_convex_polyhedron().ok_or_else(flat)?;
        let (verts, tris) = cp.to_trimesh();
        check_thickness(&verts, tris.iter().copied(), None).map_err(|e| match e {
            ShapeError::Degenerate {
                thickness, extent, ..
            } => ShapeError::Degenerate {
                part: None,
                points: points.len(),
                thickness,
                extent,
            },
            other => other,
        })?;
        let faces: Vec<Vec<u32>> = tris.iter().map(|t| t.to_vec()).collect();
        let poly = Polyhedron::from_polygons(verts, &faces)?;
        Self::single(
            SolidKind::Convex,
            poly,
            hull,
            Isometry3::identity(),
            0.0,
            None,
        )
    }

    /// A polyhedron from `vertices` and convex planar `polygons` (counter-clockwise seen from
    /// outside); degenerate, non-planar or concave polygons are refused (typed error naming the
    /// polygon). If it is convex the exact form is its hull; otherwise an oriented triangle
    /// mesh (surface queries through parry's BVH, containment through pseudo-normals).
    pub fn mesh(vertices: Vec<Point3<f64>>, polygons: &[Vec<u32>]) -> Result<Self, ShapeError> {
        let poly = Polyhedron::from_polygons(vertices, polygons)?;
        let piece = Piece::new(poly);
        // An open surface has no volume: it stays a surface (containment in it is unknown).
        if piece.closed {
            check_polyhedron(&piece.poly, None)?;
        }
        // A convex *closed* polyhedron is its hull; an open surface (a single polygon, a sheet)
        // stays a triangle surface, which parry intersects as such.
        let (exact, kind) = if piece.convex && piece.closed {
            let hull =
                SharedShape::convex_hull(&piece.poly.vertices).ok_or(ShapeError::Degenerate {
                    part: None,
                    points: piece.poly.vertices.len(),
                    thickness: 0.0,
                    extent: 2.0 * piece.poly.bbox.half.norm(),
                })?;
            (hull, SolidKind::Convex)
        } else {
            let mut tris = Vec::new();
            for i in 0..piece.poly.polygons.len() {
                let ids = piece.poly.polygon_indices(i);
                for k in 1..ids.len() - 1 {
                    tris.push([ids[0], ids[k], ids[k + 1]]);
                }
            }
            let flags = if piece.closed {
                TriMeshFlags::ORIENTED
            } else {
                TriMeshFlags::empty()
            };
            let mesh = SharedShape::trimesh_with_flags(piece.poly.vertices.clone(), tris, flags)
                .map_err(ShapeError::MeshRefused)?;
            (mesh, SolidKind::Mesh)
        };
        let bbox = piece.poly.bbox;
        Ok(Solid {
            kind,
            pieces: vec![piece],
            exact,
            exact_offset: Isometry3::identity(),
            tessellation_error: 0.0,
            bbox,
            exact_volume: None,
        })
    }

    /// A body made of convex `parts`, each placed by an isometry in the body's frame. The exact
    /// form is a parry compound (its BVH is the mid-phase); the polygon mode walks each part.
    pub fn compound(parts: Vec<(Isometry3<f64>, Solid)>) -> Result<Self, ShapeError> {
        if parts.is_empty() {
            return Err(ShapeError::EmptyCompound);
        }
        let mut pieces = Vec::new();
        let mut shapes = Vec::new();
        let mut err: f64 = 0.0;
        let mut bbox: Option<Aabb> = None;
        for (i, (iso, s)) in parts.into_iter().enumerate() {
            if matches!(s.kind, SolidKind::Mesh | SolidKind::Compound) {
                return Err(ShapeError::NonConvexPart(i));
            }
            // `Solid`'s fields are public, so a part may not have come through a constructor:
            // the same test again, naming the part.
            for p in &s.pieces {
                check_polyhedron(&p.poly, Some(i))?;
            }
            for p in &s.pieces {
                let moved = Piece::new(p.poly.transformed(&iso));
                bbox = Some(match bbox {
                    None => moved.poly.bbox,
                    Some(b) => b.merged(&moved.poly.bbox),
                });
                pieces.push(moved);
            }
            shapes.push((iso * s.exact_offset, s.exact.clone()));
            err = err.max(s.tessellation_error);
        }
        // `bbox` is set: there was at least one part, and each part has at least one piece.
        let bbox = bbox.ok_or(ShapeError::EmptyCompound)?;
        Ok(Solid {
            kind: SolidKind::Compound,
            pieces,
            exact: SharedShape::compound(shapes),
            exact_offset: Isometry3::identity(),
            tessellation_error: err,
            bbox,
            exact_volume: None,
        })
    }

    /// Total number of polygons over the faceted pieces.
    pub fn polygon_count(&self) -> usize {
        self.pieces.iter().map(|p| p.poly.polygons.len()).sum()
    }

    /// Volume of the faceted form (divergence theorem over its polygons), m³.
    pub fn faceted_volume(&self) -> f64 {
        let mut vol = 0.0;
        for piece in &self.pieces {
            let p = &piece.poly;
            for i in 0..p.polygons.len() {
                let ids = p.polygon_indices(i);
                let a = p.vertices[ids[0] as usize].coords;
                for k in 1..ids.len() - 1 {
                    let (b, c) = (
                        p.vertices[ids[k] as usize].coords,
                        p.vertices[ids[k + 1] as usize].coords,
                    );
                    vol += a.dot(&b.cross(&c)) / 6.0;
                }
            }
        }
        vol
    }

    /// A point surely inside (or on) the solid, in its frame: the first vertex of the first
    /// piece. Used by containment tests.
    pub fn interior_point(&self) -> Point3<f64> {
        self.pieces[0].poly.vertices[self.pieces[0].poly.indices[0] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_closed_convex_and_inscribed() {
        let solids = [
            Solid::cuboid(Vector3::new(1.0, 2.0, 3.0)).expect("box"),
            Solid::sphere(0.5, Some(16)).expect("sphere"),
            Solid::cylinder(0.3, 1.0, Some(12)).expect("cylinder"),
            Solid::cone(0.3, 1.0, Some(12)).expect("cone"),
            Solid::sphere(0.5, None).expect("sphere, default facets"),
            Solid::cylinder(0.3, 1.0, None).expect("cylinder, default facets"),
            Solid::cone(0.3, 1.0, None).expect("cone, default facets"),
        ];
        for s in &solids {
            let p = &s.pieces[0];
            assert!(p.closed && p.convex, "{:?}", s.kind);
            // Convex by construction (`Piece::convex_primitive`): the full test agrees.
            assert!(Piece::new(p.poly.clone()).convex, "{:?}", s.kind);
            assert_eq!(p.poly.euler_characteristic(), 2);
            let v = s.faceted_volume();
            let e = s.exact_volume.expect("primitive volume");
            assert!(
                v <= e * (1.0 + 1e-12) && v > 0.8 * e,
                "{:?}: {v} vs {e}",
                s.kind
            );
        }
    }

    #[test]
    fn bad_dimensions_are_named() {
        assert_eq!(
            Solid::sphere(-1.0, None).err(),
            Some(ShapeError::BadDimension {
                field: "radius",
                value: -1.0
            })
        );
        assert!(matches!(
            Solid::cylinder(1.0, f64::NAN, None),
            Err(ShapeError::BadDimension {
                field: "height",
                ..
            })
        ));
        assert_eq!(
            Solid::cone(1.0, 1.0, Some(2)).err(),
            Some(ShapeError::TooFewFacets(2))
        );
    }

    #[test]
    fn default_facets_meet_the_chord_error() {
        for r in [0.01, 0.1, 1.0] {
            let n = default_facets(r);
            assert!(r * (1.0 - (PI / n as f64).cos()) <= DEFAULT_CHORD_ERROR);
        }
    }
}
