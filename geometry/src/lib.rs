//! Geometry shared by every component: the seed's polygonal solid (§2.6, appendix 2.1) in the
//! redundant forms the Instance Space keeps (§3.3) — convex planar polygons with their plane
//! `N·P + d = 0`, the per-side penalty planes used for point-in-polygon, the reduced (unique) edge
//! array, and the bounding box as centre + half-diagonal.
//!
//! Entry points:
//! * [`Polyhedron::from_polygons`] — validate and build from vertices and polygon index lists.
//! * [`Aabb`] — centre + half-diagonal boxes.
//!
//! Frames and units: metres, in the solid's own frame; polygons are listed counter-clockwise
//! seen from outside, so plane normals point outward.

mod polyhedron;

pub use polyhedron::{Aabb, GeometryError, Plane, Polygon, Polyhedron, PLANARITY_TOL};
