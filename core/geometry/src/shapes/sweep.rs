//! Swept solids: extrusion of a planar polygon along z and revolution of a (ρ, z) profile about
//! the z axis (R2's "special surface", seed §2.3; builder.h `gen_extrude`, `gen_revsurface`).

use super::{ShapeError, facets_or_default, finish, non_negative, positive};
use crate::Polyhedron;
use crate::polygon2d::{check_simple, convex_decomposition};
use nalgebra::{Point2, Point3};

/// Extrudes the simple polygon `polygon` (XY plane, either orientation, concave allowed) by
/// `height` metres along z. The solid is centred on its bounding box, so the polygon's own
/// placement in XY is not kept. Caps are split into convex pieces; each side is a rectangle.
/// n-gon input: 2n vertices, n side faces plus the cap pieces.
pub fn extrude(polygon: &[Point2<f64>], height: f64) -> Result<Polyhedron, ShapeError> {
    const SHAPE: &str = "extrusion";
    let h = positive(SHAPE, "height", height)?;
    let area = check_simple(polygon).map_err(|source| ShapeError::Profile {
        shape: SHAPE,
        source,
    })?;
    let pieces = convex_decomposition(polygon).map_err(|source| ShapeError::Profile {
        shape: SHAPE,
        source,
    })?;
    let n = polygon.len();
    // ccw order of the input
    let order: Vec<usize> = if area > 0.0 {
        (0..n).collect()
    } else {
        (0..n).rev().collect()
    };
    let mut vertices = Vec::with_capacity(2 * n);
    for p in polygon {
        vertices.push(Point3::new(p.x, p.y, -h / 2.0));
    }
    for p in polygon {
        vertices.push(Point3::new(p.x, p.y, h / 2.0));
    }
    let mut faces: Vec<Vec<u32>> = Vec::with_capacity(n + 2 * pieces.len());
    for piece in &pieces {
        faces.push(piece.iter().map(|&i| (i + n) as u32).collect()); // top: ccw from +z
        faces.push(piece.iter().rev().map(|&i| i as u32).collect()); // bottom: reversed
    }
    for k in 0..n {
        let (a, b) = (order[k], order[(k + 1) % n]);
        faces.push(vec![a as u32, b as u32, (b + n) as u32, (a + n) as u32]);
    }
    finish(SHAPE, vertices, &faces)
}

/// Revolves the simple polygon `profile`, given as (ρ, z) points with ρ ≥ 0 (either
/// orientation, concave allowed), about the z axis by `angle` radians in (0, 2π], starting in
/// the XZ half-plane (θ = 0, towards +x) and turning towards +y. `facets` segments span `angle`
/// (default: [`super::default_facets`] of the largest ρ, scaled by angle/2π).
///
/// Profile points on the axis (ρ = 0) become a single vertex; they must be adjacent (one point
/// or one side on the axis). In a full revolution a side perpendicular to the axis that touches
/// it becomes one n-gon disc; other sides become trapezoids or, touching the axis, triangles.
/// A partial revolution gets two end caps (the profile, split into convex pieces).
pub fn revolve(
    profile: &[Point2<f64>],
    angle: f64,
    facets: Option<usize>,
) -> Result<Polyhedron, ShapeError> {
    revolve_named("revolution", profile, angle, facets)
}

pub(super) fn revolve_named(
    shape: &'static str,
    profile: &[Point2<f64>],
    angle: f64,
    facets: Option<usize>,
) -> Result<Polyhedron, ShapeError> {
    let tau = std::f64::consts::TAU;
    if !(angle > 0.0 && angle <= tau * (1.0 + 1e-12)) {
        return Err(ShapeError::AngleOutOfRange { shape, angle });
    }
    let full = angle >= tau * (1.0 - 1e-12);
    let area = check_simple(profile).map_err(|source| ShapeError::Profile { shape, source })?;
    let m = profile.len();
    let mut rmax: f64 = 0.0;
    for (index, p) in profile.iter().enumerate() {
        non_negative(shape, "profile ρ", p.x).map_err(|_| ShapeError::ProfileCrossesAxis {
            shape,
            index,
            rho: p.x,
        })?;
        rmax = rmax.max(p.x);
    }
    // The axis points must form one run (cyclically): count starts of runs.
    let on_axis = |i: usize| profile[i % m].x == 0.0;
    let run_starts: Vec<usize> = (0..m)
        .filter(|&i| on_axis(i) && !on_axis(i + m - 1))
        .collect();
    if run_starts.len() > 1 {
        return Err(ShapeError::ProfileTouchesAxisTwice {
            shape,
            first: run_starts[0],
            second: run_starts[1],
        });
    }
    let n = match facets {
        Some(_) => facets_or_default(shape, facets, rmax, if full { 3 } else { 1 })?,
        None => {
            let full_n = facets_or_default(shape, None, rmax, 3)?;
            ((full_n as f64 * angle / tau).ceil() as usize).max(1)
        }
    };
    let ring = if full { n } else { n + 1 }; // vertices per off-axis profile point
    let order: Vec<usize> = if area > 0.0 {
        (0..m).collect()
    } else {
        (0..m).rev().collect()
    };
    // Vertex index of profile point i at segment boundary k.
    let mut base = vec![0u32; m];
    let mut vertices: Vec<Point3<f64>> = Vec::new();
    let angles: Vec<(f64, f64)> = (0..ring)
        .map(|k| (angle * k as f64 / n as f64).sin_cos())
        .collect();
    for i in 0..m {
        base[i] = vertices.len() as u32;
        let p = profile[i];
        if p.x == 0.0 {
            vertices.push(Point3::new(0.0, 0.0, p.y));
        } else {
            for &(s, c) in &angles {
                vertices.push(Point3::new(p.x * c, p.x * s, p.y));
            }
        }
    }
    let vid = |i: usize, k: usize| -> u32 {
        if profile[i].x == 0.0 {
            base[i]
        } else {
            base[i] + (k % ring) as u32
        }
    };
    let mut faces: Vec<Vec<u32>> = Vec::new();
    for e in 0..m {
        let (a, b) = (order[e], order[(e + 1) % m]);
        let (pa, pb) = (profile[a], profile[b]);
        match (pa.x == 0.0, pb.x == 0.0) {
            (true, true) => {} // a side on the axis sweeps nothing
            (true, false) | (false, true) if full && pa.y == pb.y => {
                // a disc: from the axis outwards (interior above: bottom cap, seen from −z) or inwards
                let rim = if pa.x == 0.0 { b } else { a };
                let disc: Vec<u32> = if pa.x == 0.0 {
                    (0..n).rev().map(|k| vid(rim, k)).collect()
                } else {
                    (0..n).map(|k| vid(rim, k)).collect()
                };
                faces.push(disc);
            }
            _ => {
                for k in 0..n {
                    // A_k, A_{k+1}, B_{k+1}, B_k is counter-clockwise seen from outside
                    let mut f = vec![vid(a, k), vid(a, k + 1), vid(b, k + 1), vid(b, k)];
                    f.dedup();
                    faces.push(f);
                }
            }
        }
    }
    if !full {
        let pieces = convex_decomposition(profile)
            .map_err(|source| ShapeError::Profile { shape, source })?;
        for piece in &pieces {
            faces.push(piece.iter().map(|&i| vid(i, 0)).collect());
            faces.push(piece.iter().rev().map(|&i| vid(i, n)).collect());
        }
    }
    finish(shape, vertices, &faces)
}
