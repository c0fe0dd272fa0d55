//! Collision detection for robosim (seed §2.6, appendix 2.1–2.2): one module per mode behind one
//! dispatcher, the broad phase over the bodies in use, robot checks with self-collision, moves
//! that stop at the last safe step, and continuous checking along joint-space steps.
//!
//! Modes ([`Mode`]):
//! * [`bbox`] — centre + half-diagonal boxes, dilation product, two-way test (Eq. 6–9);
//! * [`polygon`] — the seed's polygon algorithm (POCODA with the seed's improvement);
//! * [`exact`] — parry's GJK/EPA on the true primitives, distances and witness points.
//!
//! Entry points:
//! * [`Solid`] — a body in both forms (faceted polyhedron, exact parry shape).
//! * [`collide`] — one pair, any mode; answers [`PairResult`] (clear / contact / unknown).
//! * [`robot::check_robot`], [`robot::move_checked`] — a robot at q against a [`robot::Scene`];
//!   the seed's CHECK and MOVEJ/MOVEJI with collision on; [`robot::check_robots`] for several
//!   robots (one robot-box test per pair of robots until their boxes meet).
//! * [`ccd::sweep_robot`] — time of impact along a joint-space step (conservative advancement).
//! * [`broad`] — sweep-and-prune and BVH broad phases.
//! * [`decompose::convex_parts`] — a triangle mesh as convex parts: its hull, or V-HACD when the
//!   hull is far from the mesh.
//! * [`json::solid_from_json`], [`json::pose_from_json`] — DESIGN.md's shape and pose JSON form
//!   (the query protocol's, and the checked-in fixtures').

#![forbid(unsafe_code)]

pub mod bbox;
mod bodies;
pub mod broad;
pub mod ccd;
pub mod decompose;
pub mod exact;
pub mod json;
mod outcome;
pub mod polygon;
pub mod robot;
mod solid;

pub use exact::{ExactOptions, Tolerance, ToleranceError};
pub use outcome::{Mode, PairResult};
pub use polygon::PolygonOptions;
pub use solid::{
    DEFAULT_CHORD_ERROR, DEGENERATE_RELATIVE_THICKNESS, Piece, ShapeError, Solid, SolidKind,
    default_facets,
};

use nalgebra::Isometry3;

/// One pair of solids posed by `pa`, `pb` (solid → world) in the given mode, with each mode's
/// default options (polygon: containment check on; exact: distance and depth computed).
/// Symmetric: `collide(b, a)` gives the same verdict with the witness points swapped.
pub fn collide(
    a: &Solid,
    pa: &Isometry3<f64>,
    b: &Solid,
    pb: &Isometry3<f64>,
    mode: Mode,
) -> PairResult {
    match mode {
        Mode::BBox => bbox::collide(a, pa, b, pb),
        Mode::Polygon => polygon::collide(a, pa, b, pb, PolygonOptions::default()),
        Mode::Exact => exact::collide(a, pa, b, pb, ExactOptions::default()),
    }
}
