//! The polygon mode: the seed's polygon collision algorithm (POCODA after Walter, seed §2.6),
//! with the seed's own improvement, on the faceted solids.
//!
//! For two polyhedra j and k (steps as numbered in the seed's summary):
//! 1. two-way bounding-box test ([`crate::bbox::overlap_two_way`]);
//! 2. carry j's vertices into k's frame (Eq. 8) — the object (j,k) — and take its box;
//! 3. build the *reduced edge array*: the seed's improvement first drops every polygon of j whose
//!    plane misses k's box ([`plane_meets_box`]) together with all its sides, then keeps each
//!    remaining edge that meets k's box ([`segment_meets_box`]);
//! 4. for each polygon of k whose plane meets the box of (j,k), test every reduced edge: the
//!    plane residues of its ends (Eq. 1) say whether it crosses the plane
//!    ([`segment_crosses_plane`]), and the crossing point is tested against the polygon's
//!    penalty planes (Eq. 2–4, [`point_in_polygon`]);
//! 5. exchange j and k and repeat once.
//!
//! The seed admits two misses: a body entirely inside another, and passing through between
//! steps. [`PolygonOptions::containment`] (on by default) adds one point-in-solid test per
//! direction, which closes the first; the second is the job of [`crate::ccd`].
//!
//! Touching counts as contact: every test is closed (`≤ 0`), with no tolerance.
//!
//! Entry points: [`collide`], [`collide_pieces`], and the sub-algorithms above.

use crate::bbox::overlap_two_way;
use crate::outcome::PairResult;
use crate::solid::{Piece, Solid};
use nalgebra::{Isometry3, Point3, Vector3};
use robosim_geometry::{Aabb, Plane};

/// Options of the polygon mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PolygonOptions {
    /// Also test one vertex of each body for being inside the other (closes the seed's
    /// "completely inside" miss). `false` is the seed's algorithm exactly.
    pub containment: bool,
}

impl Default for PolygonOptions {
    fn default() -> Self {
        PolygonOptions { containment: true }
    }
}

/// Does the plane cross (or touch) the box? `|N·C + d| ≤ Σ|Nᵢ| Dᵢ`.
#[inline]
pub fn plane_meets_box(plane: &Plane, b: &Aabb) -> bool {
    let r = plane.normal.abs().dot(&b.half);
    plane.signed_distance(&b.center).abs() <= r
}

/// Does the segment p→q meet the closed box? (slab test)
#[inline]
pub fn segment_meets_box(p: &Point3<f64>, q: &Point3<f64>, b: &Aabb) -> bool {
    let (lo, hi) = (b.mins(), b.maxs());
    let d = q - p;
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for i in 0..3 {
        if d[i] == 0.0 {
            if p[i] < lo[i] || p[i] > hi[i] {
                return false;
            }
        } else {
            let inv = 1.0 / d[i];
            let (mut a, mut c) = ((lo[i] - p[i]) * inv, (hi[i] - p[i]) * inv);
            if a > c {
                std::mem::swap(&mut a, &mut c);
            }
            t0 = t0.max(a);
            t1 = t1.min(c);
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

/// Where the segment p→q crosses the plane, from the plane residues of its ends (seed: "if the
/// residues have different signs…"): `None` if both ends are strictly on one side, or if the
/// segment lies in the plane (see [`segment_in_plane_meets_polygon`]).
#[inline]
pub fn segment_crosses_plane(
    p: &Point3<f64>,
    q: &Point3<f64>,
    rp: f64,
    rq: f64,
) -> Option<Point3<f64>> {
    if (rp > 0.0 && rq > 0.0) || (rp < 0.0 && rq < 0.0) || (rp == 0.0 && rq == 0.0) {
        return None;
    }
    let t = rp / (rp - rq);
    Some(p + (q - p) * t)
}

/// Point in convex polygon: inside (or on the boundary) iff every penalty residue is ≤ 0
/// (seed Eq. 2–4). The point is assumed to lie in the polygon's plane.
#[inline]
pub fn point_in_polygon(p: &Point3<f64>, penalties: &[Plane]) -> bool {
    penalties.iter().all(|pen| pen.signed_distance(p) <= 0.0)
}

/// A segment lying in a polygon's plane meets the polygon iff the part of it on the inner side
/// of every penalty plane is non-empty (Cyrus–Beck clipping). Returns a point of the overlap.
pub fn segment_in_plane_meets_polygon(
    p: &Point3<f64>,
    q: &Point3<f64>,
    penalties: &[Plane],
) -> Option<Point3<f64>> {
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for pen in penalties {
        let (a, b) = (pen.signed_distance(p), pen.signed_distance(q));
        if a > 0.0 && b > 0.0 {
            return None;
        }
        if a > 0.0 {
            t0 = t0.max(a / (a - b));
        } else if b > 0.0 {
            t1 = t1.min(a / (a - b));
        }
        if t0 > t1 {
            return None;
        }
    }
    Some(p + (q - p) * ((t0 + t1) * 0.5))
}

/// Point in solid for a piece, in the piece's frame: plane residues for a convex piece, ray
/// parity (the seed's segment-crossing and point-in-polygon tests along a ray) for a closed
/// non-convex one. `None` when the piece is open and the question has no answer.
pub fn point_in_piece(p: &Point3<f64>, piece: &Piece) -> Option<bool> {
    let poly = &piece.poly;
    if piece.convex {
        return Some(
            poly.polygons
                .iter()
                .all(|pg| pg.plane.signed_distance(p) <= 0.0),
        );
    }
    if !piece.closed {
        return None;
    }
    // A ray in a direction unlikely to graze an edge of modelled geometry.
    let dir = Vector3::new(1.0 + 2.1e-3, 1.0 - 4.7e-4, 1.0 + 5.3e-5).normalize();
    let far = p + dir * (4.0 * (poly.bbox.half.norm() + (p - poly.bbox.center).norm()) + 1.0);
    let mut crossings = 0usize;
    for i in 0..poly.polygons.len() {
        let pl = &poly.polygons[i].plane;
        let (rp, rq) = (pl.signed_distance(p), pl.signed_distance(&far));
        if rp == 0.0 && point_in_polygon(p, poly.polygon_penalties(i)) {
            return Some(true); // on the surface
        }
        if let Some(x) = segment_crosses_plane(p, &far, rp, rq)
            && point_in_polygon(&x, poly.polygon_penalties(i))
        {
            crossings += 1;
        }
    }
    Some(crossings % 2 == 1)
}

/// One direction of POCODA (steps 2–4): edges of `src` (whose vertices, carried into `dst`'s
/// frame, are `src_v`, and whose frame maps into dst's by `t`) against polygons of `dst`.
/// Returns the piercing point in dst's frame.
fn one_way(
    src: &Piece,
    src_v: &[Point3<f64>],
    t: &Isometry3<f64>,
    dst: &Piece,
    scratch: &mut Vec<u32>,
) -> Option<Point3<f64>> {
    let dst_box = &dst.poly.bbox;
    // Step 3 with the seed's improvement: polygon planes of src first, then its edges.
    let ne = src.poly.edges.len();
    scratch.clear();
    scratch.resize(ne, 0); // 0 unseen, 1 excluded (its polygon's plane misses the box), 2 kept
    for pg in &src.poly.polygons {
        if !plane_meets_box(&pg.plane.transformed(t), dst_box) {
            let start = pg.start as usize;
            for k in 0..pg.len as usize {
                scratch[src.side_edge[start + k] as usize] = 1;
            }
        }
    }
    let mut reduced: Vec<[u32; 2]> = Vec::new();
    for (e, flag) in src.poly.edges.iter().zip(scratch.iter()) {
        if *flag == 0 && segment_meets_box(&src_v[e[0] as usize], &src_v[e[1] as usize], dst_box) {
            reduced.push(*e);
        }
    }
    if reduced.is_empty() {
        return None;
    }
    // Box of (src, dst): the box of the reduced edges' ends is enough and tighter.
    let src_box = Aabb::from_points(
        reduced
            .iter()
            .flat_map(|e| [&src_v[e[0] as usize], &src_v[e[1] as usize]]),
    )?;
    // Step 4.
    for i in 0..dst.poly.polygons.len() {
        let pl = &dst.poly.polygons[i].plane;
        if !plane_meets_box(pl, &src_box) {
            continue;
        }
        let pens = dst.poly.polygon_penalties(i);
        for e in &reduced {
            let (p, q) = (&src_v[e[0] as usize], &src_v[e[1] as usize]);
            let (rp, rq) = (pl.signed_distance(p), pl.signed_distance(q));
            if rp == 0.0 && rq == 0.0 {
                if let Some(x) = segment_in_plane_meets_polygon(p, q, pens) {
                    return Some(x);
                }
            } else if let Some(x) = segment_crosses_plane(p, q, rp, rq)
                && point_in_polygon(&x, pens)
            {
                return Some(x);
            }
        }
    }
    None
}

/// POCODA between two pieces posed by `ta`, `tb` (piece → world). Returns a world point of
/// contact, or `None` (clear), or `Err` when containment could not be decided for an open piece.
pub fn collide_pieces(
    a: &Piece,
    ta: &Isometry3<f64>,
    b: &Piece,
    tb: &Isometry3<f64>,
    opts: PolygonOptions,
) -> Result<Option<Point3<f64>>, String> {
    if !overlap_two_way(&a.poly.bbox, ta, &b.poly.bbox, tb) {
        return Ok(None);
    }
    let mut scratch = Vec::new();
    let t_ab = tb.inv_mul(ta); // a's frame → b's frame
    let a_in_b: Vec<Point3<f64>> = a.poly.vertices.iter().map(|v| t_ab * v).collect();
    if let Some(x) = one_way(a, &a_in_b, &t_ab, b, &mut scratch) {
        return Ok(Some(tb * x));
    }
    let t_ba = t_ab.inverse();
    let b_in_a: Vec<Point3<f64>> = b.poly.vertices.iter().map(|v| t_ba * v).collect();
    if let Some(x) = one_way(b, &b_in_a, &t_ba, a, &mut scratch) {
        return Ok(Some(ta * x));
    }
    if opts.containment {
        // No edge pierces a polygon either way: the surfaces do not cross, so either one solid
        // holds the other entirely or they are apart; one vertex of each decides.
        let va = a_in_b[a.poly.indices[0] as usize];
        match point_in_piece(&va, b) {
            Some(true) => return Ok(Some(tb * va)),
            Some(false) => {}
            None => {
                return Err(
                    "containment undecidable: the piece of b is not a closed surface".into(),
                );
            }
        }
        let vb = b_in_a[b.poly.indices[0] as usize];
        match point_in_piece(&vb, a) {
            Some(true) => return Ok(Some(ta * vb)),
            Some(false) => {}
            None => {
                return Err(
                    "containment undecidable: the piece of a is not a closed surface".into(),
                );
            }
        }
    }
    Ok(None)
}

/// The polygon mode for two solids posed by `pa`, `pb` (solid → world): POCODA over every pair
/// of faceted pieces. The witness is the point where an edge pierces a polygon (both entries).
pub fn collide(
    a: &Solid,
    pa: &Isometry3<f64>,
    b: &Solid,
    pb: &Isometry3<f64>,
    opts: PolygonOptions,
) -> PairResult {
    if !overlap_two_way(&a.bbox, pa, &b.bbox, pb) {
        return PairResult::Clear {
            distance: None,
            witness: None,
        };
    }
    let mut doubt = None;
    for pa_piece in &a.pieces {
        for pb_piece in &b.pieces {
            match collide_pieces(pa_piece, pa, pb_piece, pb, opts) {
                Ok(Some(x)) => {
                    return PairResult::Contact {
                        signed_distance: None,
                        witness: Some([x, x]),
                    };
                }
                Ok(None) => {}
                Err(reason) => doubt = Some(reason),
            }
        }
    }
    match doubt {
        Some(reason) => PairResult::Unknown { reason },
        None => PairResult::Clear {
            distance: None,
            witness: None,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_penalties() -> Vec<Plane> {
        // unit square in z = 0, CCW from +z: sides' outward normals −y, +x, +y, −x
        vec![
            Plane {
                normal: -Vector3::y(),
                d: 0.0,
            },
            Plane {
                normal: Vector3::x(),
                d: -1.0,
            },
            Plane {
                normal: Vector3::y(),
                d: -1.0,
            },
            Plane {
                normal: -Vector3::x(),
                d: 0.0,
            },
        ]
    }

    #[test]
    fn point_in_polygon_is_closed() {
        let pens = square_penalties();
        assert!(point_in_polygon(&Point3::new(0.5, 0.5, 0.0), &pens));
        assert!(point_in_polygon(&Point3::new(1.0, 0.5, 0.0), &pens));
        assert!(!point_in_polygon(
            &Point3::new(1.0 + 1e-12, 0.5, 0.0),
            &pens
        ));
    }

    #[test]
    fn crossing_point_from_residues() {
        let (p, q) = (Point3::new(0.0, 0.0, -1.0), Point3::new(0.0, 0.0, 3.0));
        let x = segment_crosses_plane(&p, &q, -1.0, 3.0).expect("crosses");
        assert!((x - Point3::origin()).norm() < 1e-15);
        assert!(segment_crosses_plane(&p, &q, 1.0, 3.0).is_none());
        assert!(segment_crosses_plane(&p, &q, 0.0, 0.0).is_none());
    }

    #[test]
    fn coplanar_segment_clipped_by_penalties() {
        let pens = square_penalties();
        assert!(
            segment_in_plane_meets_polygon(
                &Point3::new(-1.0, 0.5, 0.0),
                &Point3::new(2.0, 0.5, 0.0),
                &pens
            )
            .is_some()
        );
        assert!(
            segment_in_plane_meets_polygon(
                &Point3::new(-1.0, 1.5, 0.0),
                &Point3::new(2.0, 1.5, 0.0),
                &pens
            )
            .is_none()
        );
    }

    #[test]
    fn plane_and_segment_box_tests() {
        let b = Aabb {
            center: Point3::origin(),
            half: Vector3::new(1.0, 1.0, 1.0),
        };
        assert!(plane_meets_box(
            &Plane {
                normal: Vector3::new(1.0, 1.0, 1.0).normalize(),
                d: -3f64.sqrt()
            },
            &b
        ));
        assert!(!plane_meets_box(
            &Plane {
                normal: Vector3::new(1.0, 1.0, 1.0).normalize(),
                d: -1.8
            },
            &b
        ));
        assert!(segment_meets_box(
            &Point3::new(-5.0, 0.0, 0.0),
            &Point3::new(5.0, 0.0, 0.0),
            &b
        ));
        assert!(!segment_meets_box(
            &Point3::new(-5.0, 1.5, 0.0),
            &Point3::new(5.0, 1.5, 0.0),
            &b
        ));
        assert!(segment_meets_box(
            &Point3::new(1.0, 1.0, 1.0),
            &Point3::new(5.0, 5.0, 5.0),
            &b
        ));
    }
}
