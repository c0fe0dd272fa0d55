//! The polygonal solid and its validation.

use nalgebra::{Isometry3, Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Relative planarity / convexity tolerance: a vertex may lie this far from its polygon's plane,
/// scaled by the polygon's size (its longest side), before the polygon is refused.
pub const PLANARITY_TOL: f64 = 1e-9;

/// A plane `normal · p + d = 0` with a unit normal. `signed_distance(p) > 0` is the outer side.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    pub normal: Vector3<f64>,
    pub d: f64,
}

impl Plane {
    /// The plane through `point` with unit `normal`.
    pub fn through(point: &Point3<f64>, normal: Vector3<f64>) -> Self {
        Plane {
            normal,
            d: -normal.dot(&point.coords),
        }
    }
    /// The seed's "plane residue": positive outside, negative inside, metres.
    #[inline]
    pub fn signed_distance(&self, p: &Point3<f64>) -> f64 {
        self.normal.dot(&p.coords) + self.d
    }
    /// The same plane expressed in another frame: `iso` maps this plane's frame into that one.
    pub fn transformed(&self, iso: &Isometry3<f64>) -> Self {
        let n = iso.rotation * self.normal;
        Plane {
            normal: n,
            d: self.d - n.dot(&iso.translation.vector),
        }
    }
}

/// Axis-aligned bounding box as centre + half-diagonal (seed §2.6, Eq. 8–9).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub center: Point3<f64>,
    pub half: Vector3<f64>,
}

impl Aabb {
    /// The smallest box around `points`; `None` for an empty set.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Point3<f64>>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?;
        let (mut lo, mut hi) = (first.coords, first.coords);
        for p in it {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        Some(Aabb {
            center: Point3::from((lo + hi) * 0.5),
            half: (hi - lo) * 0.5,
        })
    }
    /// The box of this box after a rigid motion: the seed's dilation product,
    /// `half' = |R| · half` (Eq. 9), `center' = R·center + t`.
    pub fn transformed(&self, iso: &Isometry3<f64>) -> Self {
        let r = iso.rotation.to_rotation_matrix();
        let abs = r.matrix().abs();
        Aabb {
            center: iso * self.center,
            half: abs * self.half,
        }
    }
    /// Two-way overlap test (touching counts as overlapping).
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        let d = (self.center - other.center).abs();
        let s = self.half + other.half;
        d.x <= s.x && d.y <= s.y && d.z <= s.z
    }
    /// The smallest box containing both.
    pub fn merged(&self, other: &Aabb) -> Self {
        let lo = (self.center.coords - self.half).inf(&(other.center.coords - other.half));
        let hi = (self.center.coords + self.half).sup(&(other.center.coords + other.half));
        Aabb {
            center: Point3::from((lo + hi) * 0.5),
            half: (hi - lo) * 0.5,
        }
    }
    pub fn mins(&self) -> Point3<f64> {
        self.center - self.half
    }
    pub fn maxs(&self) -> Point3<f64> {
        self.center + self.half
    }
}

/// One convex planar polygon of a [`Polyhedron`]: `indices[start..start+len]` are its vertices,
/// counter-clockwise seen from outside; `penalty[start + i]` is the penalty plane of the side
/// from vertex `i` to vertex `i+1`: it contains that side, is perpendicular to the polygon and its
/// normal points away from the polygon's interior (seed §2.6: a point is inside the polygon iff
/// every penalty residue is ≤ 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Polygon {
    pub start: u32,
    pub len: u32,
    pub plane: Plane,
}

/// Why a polyhedron was refused. Every variant names the polygon (index into the input list)
/// and, where there is one, the vertex.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("vertex {vertex} is not finite: {value:?}")]
    NonFiniteVertex { vertex: usize, value: [f64; 3] },
    #[error("polygon {polygon} has {len} vertices; a polygon needs at least 3")]
    TooFewVertices { polygon: usize, len: usize },
    #[error("polygon {polygon} refers to vertex {index}, but there are only {count} vertices")]
    IndexOutOfRange {
        polygon: usize,
        index: u32,
        count: usize,
    },
    #[error(
        "polygon {polygon} has (nearly) zero area ({area:e} m²): its vertices are collinear or repeated"
    )]
    Degenerate { polygon: usize, area: f64 },
    #[error("polygon {polygon} is not planar: vertex {vertex} lies {distance:e} m off its plane")]
    NonPlanar {
        polygon: usize,
        vertex: u32,
        distance: f64,
    },
    #[error(
        "polygon {polygon} is not convex at its vertex {vertex} (position {corner} in the polygon)"
    )]
    Concave {
        polygon: usize,
        vertex: u32,
        corner: usize,
    },
    #[error("the solid has no polygons")]
    Empty,
}

/// A polygonal solid in the seed's redundant forms (see the crate docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Polyhedron {
    pub vertices: Vec<Point3<f64>>,
    /// Vertex indices of all polygons, concatenated.
    pub indices: Vec<u32>,
    /// One penalty plane per polygon side, parallel to `indices`.
    pub penalty: Vec<Plane>,
    pub polygons: Vec<Polygon>,
    /// The reduced edge array: each undirected edge once, lower index first.
    pub edges: Vec<[u32; 2]>,
    pub bbox: Aabb,
}

impl Polyhedron {
    /// Validates and builds a solid. Polygons must be convex and planar (within
    /// [`PLANARITY_TOL`] of their size), with non-zero area; vertices finite; indices in range.
    /// Orientation is taken from the vertex order (counter-clockwise seen from outside).
    pub fn from_polygons(
        vertices: Vec<Point3<f64>>,
        faces: &[Vec<u32>],
    ) -> Result<Self, GeometryError> {
        if faces.is_empty() {
            return Err(GeometryError::Empty);
        }
        for (i, v) in vertices.iter().enumerate() {
            if !v.coords.iter().all(|c| c.is_finite()) {
                return Err(GeometryError::NonFiniteVertex {
                    vertex: i,
                    value: [v.x, v.y, v.z],
                });
            }
        }
        let mut indices = Vec::with_capacity(faces.iter().map(Vec::len).sum());
        let mut penalty = Vec::with_capacity(indices.capacity());
        let mut polygons = Vec::with_capacity(faces.len());
        let mut edges = Vec::new();
        for (fi, face) in faces.iter().enumerate() {
            let plane = check_polygon(&vertices, fi, face)?;
            let start = indices.len() as u32;
            for i in 0..face.len() {
                let a = &vertices[face[i] as usize];
                let b = &vertices[face[(i + 1) % face.len()] as usize];
                // side direction × polygon normal points out of the interior for a CCW polygon
                let n = (b - a).cross(&plane.normal).normalize();
                penalty.push(Plane::through(a, n));
                let (lo, hi) = (
                    face[i].min(face[(i + 1) % face.len()]),
                    face[i].max(face[(i + 1) % face.len()]),
                );
                edges.push([lo, hi]);
            }
            indices.extend_from_slice(face);
            polygons.push(Polygon {
                start,
                len: face.len() as u32,
                plane,
            });
        }
        edges.sort_unstable();
        edges.dedup();
        let used: Vec<Point3<f64>> = {
            let mut seen = vec![false; vertices.len()];
            for &i in &indices {
                seen[i as usize] = true;
            }
            vertices
                .iter()
                .zip(seen)
                .filter(|(_, s)| *s)
                .map(|(v, _)| *v)
                .collect()
        };
        // `used` is non-empty: there is at least one polygon with at least 3 valid indices.
        let bbox = Aabb::from_points(&used).ok_or(GeometryError::Empty)?;
        Ok(Polyhedron {
            vertices,
            indices,
            penalty,
            polygons,
            edges,
            bbox,
        })
    }

    /// The vertex indices of polygon `i`.
    pub fn polygon_indices(&self, i: usize) -> &[u32] {
        let p = &self.polygons[i];
        &self.indices[p.start as usize..(p.start + p.len) as usize]
    }

    /// The penalty planes of polygon `i`'s sides.
    pub fn polygon_penalties(&self, i: usize) -> &[Plane] {
        let p = &self.polygons[i];
        &self.penalty[p.start as usize..(p.start + p.len) as usize]
    }

    /// True when every directed side is matched by exactly one opposite side (a closed,
    /// consistently oriented 2-manifold).
    pub fn is_closed(&self) -> bool {
        let mut directed: Vec<(u32, u32)> = Vec::with_capacity(self.indices.len());
        for i in 0..self.polygons.len() {
            let ids = self.polygon_indices(i);
            for k in 0..ids.len() {
                directed.push((ids[k], ids[(k + 1) % ids.len()]));
            }
        }
        directed.sort_unstable();
        if directed.windows(2).any(|w| w[0] == w[1]) {
            return false;
        }
        directed
            .iter()
            .all(|&(a, b)| directed.binary_search(&(b, a)).is_ok())
    }

    /// V − E + F over the used vertices; 2 for a closed solid of genus 0.
    pub fn euler_characteristic(&self) -> i64 {
        let mut used: Vec<u32> = self.indices.clone();
        used.sort_unstable();
        used.dedup();
        used.len() as i64 - self.edges.len() as i64 + self.polygons.len() as i64
    }

    /// A copy moved by `iso` (planes, penalties and box follow).
    pub fn transformed(&self, iso: &Isometry3<f64>) -> Self {
        let vertices: Vec<Point3<f64>> = self.vertices.iter().map(|v| iso * v).collect();
        let polygons = self
            .polygons
            .iter()
            .map(|p| Polygon {
                plane: p.plane.transformed(iso),
                ..*p
            })
            .collect();
        let penalty = self.penalty.iter().map(|p| p.transformed(iso)).collect();
        let bbox = Aabb::from_points(&vertices).unwrap_or(self.bbox.transformed(iso));
        Polyhedron {
            vertices,
            indices: self.indices.clone(),
            penalty,
            polygons,
            edges: self.edges.clone(),
            bbox,
        }
    }
}

/// Newell's normal (area-weighted, robust for nearly degenerate input), then planarity and
/// convexity against it. Public so that readers which drop bad polygons of a mesh (STL/OBJ
/// import) drop exactly those the keeper's validation would refuse.
pub fn check_polygon(
    vertices: &[Point3<f64>],
    fi: usize,
    face: &[u32],
) -> Result<Plane, GeometryError> {
    if face.len() < 3 {
        return Err(GeometryError::TooFewVertices {
            polygon: fi,
            len: face.len(),
        });
    }
    for &i in face {
        if i as usize >= vertices.len() {
            return Err(GeometryError::IndexOutOfRange {
                polygon: fi,
                index: i,
                count: vertices.len(),
            });
        }
    }
    let p = |k: usize| vertices[face[k % face.len()] as usize];
    // Newell's normal about the first vertex, not the origin: the same vector in exact
    // arithmetic, without the cancellation of large cross products for a small polygon far
    // from the origin (a mesh's sliver triangle otherwise came out 3e-12 m "off its plane").
    let o = p(0);
    let mut newell = Vector3::zeros();
    let mut size: f64 = 0.0;
    for k in 0..face.len() {
        let (a, b) = (p(k), p(k + 1));
        newell += (a - o).cross(&(b - o));
        size = size.max((b - a).norm());
    }
    let area = newell.norm() * 0.5;
    if area.is_nan() || area <= (size * size) * 1e-12 || size == 0.0 {
        return Err(GeometryError::Degenerate { polygon: fi, area });
    }
    let normal = newell / (2.0 * area);
    let centroid = face.iter().fold(Vector3::zeros(), |acc, &i| {
        acc + vertices[i as usize].coords
    }) / face.len() as f64;
    let plane = Plane {
        normal,
        d: -normal.dot(&centroid),
    };
    let tol = PLANARITY_TOL * size.max(f64::MIN_POSITIVE);
    for &i in face {
        let dist = plane.signed_distance(&vertices[i as usize]);
        if dist.abs() > tol.max(1e-12 * centroid.norm()) {
            return Err(GeometryError::NonPlanar {
                polygon: fi,
                vertex: i,
                distance: dist,
            });
        }
    }
    // Convex and simple: every corner turns the same way as the normal, and the turning adds up
    // to one full turn (a star-shaped pentagram turns left everywhere but twice around).
    let mut total_angle = 0.0;
    for k in 0..face.len() {
        let (a, b, c) = (p(k), p(k + 1), p(k + 2));
        let (u, v) = (b - a, c - b);
        let turn = u.cross(&v).dot(&normal);
        if turn < -tol * size {
            return Err(GeometryError::Concave {
                polygon: fi,
                vertex: face[(k + 1) % face.len()],
                corner: (k + 1) % face.len(),
            });
        }
        total_angle += turn.atan2(u.dot(&v));
    }
    if (total_angle - std::f64::consts::TAU).abs() > 1e-6 {
        return Err(GeometryError::Concave {
            polygon: fi,
            vertex: face[0],
            corner: 0,
        });
    }
    Ok(plane)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_cube() -> (Vec<Point3<f64>>, Vec<Vec<u32>>) {
        let v: Vec<Point3<f64>> = (0..8)
            .map(|i| {
                Point3::new(
                    (i & 1) as f64 - 0.5,
                    ((i >> 1) & 1) as f64 - 0.5,
                    ((i >> 2) & 1) as f64 - 0.5,
                )
            })
            .collect();
        let f = vec![
            vec![0, 2, 3, 1], // z-
            vec![4, 5, 7, 6], // z+
            vec![0, 1, 5, 4], // y-
            vec![2, 6, 7, 3], // y+
            vec![0, 4, 6, 2], // x-
            vec![1, 3, 7, 5], // x+
        ];
        (v, f)
    }

    #[test]
    fn cube_has_outward_planes_edges_and_euler_2() {
        let (v, f) = unit_cube();
        let p = Polyhedron::from_polygons(v, &f).expect("valid cube");
        assert_eq!(p.edges.len(), 12);
        assert_eq!(p.euler_characteristic(), 2);
        assert!(p.is_closed());
        for poly in &p.polygons {
            assert!((poly.plane.signed_distance(&Point3::origin()) + 0.5).abs() < 1e-15);
        }
        // penalty planes: the face centre is inside every side's penalty plane
        for i in 0..p.polygons.len() {
            let ids = p.polygon_indices(i);
            let c = ids
                .iter()
                .fold(Vector3::zeros(), |a, &k| a + p.vertices[k as usize].coords)
                / 4.0;
            for pen in p.polygon_penalties(i) {
                assert!(pen.signed_distance(&Point3::from(c)) < 0.0);
            }
        }
        assert_eq!(p.bbox.half, Vector3::new(0.5, 0.5, 0.5));
    }

    #[test]
    fn concave_nonplanar_degenerate_and_out_of_range_are_refused() {
        let v = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(1.0, 0.5, 0.0),
            Point3::new(2.0, 2.0, 0.0),
            Point3::new(0.0, 2.0, 0.0),
            Point3::new(1.0, 1.0, 0.3),
            Point3::new(3.0, 0.0, 0.0),
        ];
        assert!(matches!(
            Polyhedron::from_polygons(v.clone(), &[vec![0, 1, 2, 3, 4]]),
            Err(GeometryError::Concave {
                polygon: 0,
                vertex: 2,
                ..
            })
        ));
        assert!(matches!(
            Polyhedron::from_polygons(v.clone(), &[vec![0, 1, 5, 4]]),
            Err(GeometryError::NonPlanar { polygon: 0, .. })
        ));
        assert!(matches!(
            Polyhedron::from_polygons(v.clone(), &[vec![0, 1, 6]]),
            Err(GeometryError::Degenerate { polygon: 0, .. })
        ));
        assert!(matches!(
            Polyhedron::from_polygons(v, &[vec![0, 1, 9]]),
            Err(GeometryError::IndexOutOfRange {
                polygon: 0,
                index: 9,
                ..
            })
        ));
    }

    #[test]
    fn pentagram_is_refused_as_not_convex() {
        let v: Vec<Point3<f64>> = (0..5)
            .map(|k| {
                let a = (k as f64) * 4.0 * std::f64::consts::PI / 5.0;
                Point3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert!(matches!(
            Polyhedron::from_polygons(v, &[vec![0, 1, 2, 3, 4]]),
            Err(GeometryError::Concave { .. })
        ));
    }

    #[test]
    fn dilation_product_bounds_the_rotated_box() {
        let (v, f) = unit_cube();
        let p = Polyhedron::from_polygons(v, &f).expect("valid cube");
        let iso = Isometry3::new(Vector3::new(1.0, 2.0, 3.0), Vector3::new(0.3, -0.7, 0.2));
        let moved = p.transformed(&iso);
        let carried = p.bbox.transformed(&iso);
        for v in &moved.vertices {
            let d = (v - carried.center).abs();
            assert!(
                d.x <= carried.half.x + 1e-12
                    && d.y <= carried.half.y + 1e-12
                    && d.z <= carried.half.z + 1e-12
            );
        }
    }
}
