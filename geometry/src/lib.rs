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

pub mod mass;
pub mod polygon2d;
mod polyhedron;
pub mod shapes;
pub mod triangulate;

pub use mass::{MassError, MassProperties};
pub use polyhedron::{Aabb, GeometryError, PLANARITY_TOL, Plane, Polygon, Polyhedron};
