//! Simple polygons in the plane: validation and convex decomposition.
//!
//! The seed's R2 left concave "special surface" polygons to the user ("AT THIS TIME NO CORRECTION
//! OR DETECTION OF CONCAVE POLYGONS IS MADE", seed §2.3); the collision algorithm (§2.6) needs
//! convex polygons. Here a polygon is checked (at least 3 vertices, finite, no repeated or
//! collinear consecutive vertices, not self-intersecting, non-zero area) and split into convex
//! pieces by ear clipping followed by the Hertel–Mehlhorn merge (Hertel & Mehlhorn, "Fast
//! triangulation of simple polygons", FCT 1983): a diagonal of the triangulation is removed
//! whenever both polygons it separates stay convex. The result has at most 4× the minimum number
//! of convex pieces and uses only the input's vertices (no Steiner points), so the pieces of a
//! cap share edges exactly with the sides of an extruded solid.
//!
//! Entry points:
//! * [`check_simple`] — validate; returns the signed area (positive: counter-clockwise).
//! * [`convex_decomposition`] — validate and split into convex counter-clockwise pieces.
//! * [`signed_area`], [`is_convex`].

use nalgebra::Point2;

/// Why a planar polygon was refused. Indices are positions in the input point list.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolygonError {
    /// Fewer than three points.
    #[error("a polygon needs at least 3 points, got {len}")]
    TooFewPoints { len: usize },
    /// A coordinate is NaN or infinite.
    #[error("point {index} is not finite: ({x}, {y})")]
    NonFinite { index: usize, x: f64, y: f64 },
    /// Two consecutive points coincide (a zero-length side).
    #[error("points {index} and {next} coincide (a zero-length side)")]
    RepeatedPoint { index: usize, next: usize },
    /// A point lies on the straight line through its two neighbours.
    #[error("point {index} lies on the line through its neighbours (collinear points; remove it)")]
    Collinear { index: usize },
    /// Two non-adjacent sides touch or cross.
    #[error(
        "side {a} (point {a} to the next) and side {b} (point {b} to the next) intersect: the polygon is self-intersecting"
    )]
    SelfIntersecting { a: usize, b: usize },
    /// The enclosed area is (nearly) zero.
    #[error("the polygon has (nearly) zero area ({area:e})")]
    ZeroArea { area: f64 },
    /// Ear clipping found no ear (only possible through rounding on nearly degenerate input).
    #[error(
        "could not split the polygon into convex pieces (nearly degenerate input near point {index})"
    )]
    DecompositionFailed { index: usize },
}

/// Twice-free shoelace area: positive for counter-clockwise order.
pub fn signed_area(points: &[Point2<f64>]) -> f64 {
    let n = points.len();
    let mut s = 0.0;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        s += a.x * b.y - b.x * a.y;
    }
    0.5 * s
}

#[inline]
fn cross(o: Point2<f64>, a: Point2<f64>, b: Point2<f64>) -> f64 {
    (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
}

/// True when every corner of the polygon (counter-clockwise) turns left or goes straight.
pub fn is_convex(points: &[Point2<f64>]) -> bool {
    let n = points.len();
    let scale = scale_of(points);
    n >= 3
        && (0..n).all(|i| {
            cross(points[i], points[(i + 1) % n], points[(i + 2) % n]) >= -1e-12 * scale * scale
        })
}

fn scale_of(points: &[Point2<f64>]) -> f64 {
    points
        .iter()
        .fold(0.0_f64, |m, p| m.max(p.x.abs()).max(p.y.abs()))
        .max(f64::MIN_POSITIVE)
}

/// Do closed segments `p1p2` and `q1q2` intersect (touching counts)?
fn segments_intersect(
    p1: Point2<f64>,
    p2: Point2<f64>,
    q1: Point2<f64>,
    q2: Point2<f64>,
    eps: f64,
) -> bool {
    let d1 = cross(q1, q2, p1);
    let d2 = cross(q1, q2, p2);
    let d3 = cross(p1, p2, q1);
    let d4 = cross(p1, p2, q2);
    if ((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps))
        && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps))
    {
        return true;
    }
    let on = |a: Point2<f64>, b: Point2<f64>, p: Point2<f64>, d: f64| {
        d.abs() <= eps
            && p.x >= a.x.min(b.x) - 1e-12
            && p.x <= a.x.max(b.x) + 1e-12
            && p.y >= a.y.min(b.y) - 1e-12
            && p.y <= a.y.max(b.y) + 1e-12
    };
    on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4)
}

/// Validates a simple polygon and returns its signed area (positive: counter-clockwise).
///
/// Refuses, in this order: fewer than 3 points, non-finite points, repeated consecutive points,
/// collinear consecutive triples, self-intersection (any two non-adjacent sides touching), zero
/// area. Tolerances are relative to the polygon's extent (1e-12 of its size squared for
/// orientation tests). O(n²) in the number of points.
pub fn check_simple(points: &[Point2<f64>]) -> Result<f64, PolygonError> {
    let n = points.len();
    if n < 3 {
        return Err(PolygonError::TooFewPoints { len: n });
    }
    for (index, p) in points.iter().enumerate() {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return Err(PolygonError::NonFinite {
                index,
                x: p.x,
                y: p.y,
            });
        }
    }
    let scale = scale_of(points);
    let eps = 1e-12 * scale * scale;
    for i in 0..n {
        let j = (i + 1) % n;
        if (points[j] - points[i]).norm() <= 1e-12 * scale {
            return Err(PolygonError::RepeatedPoint { index: i, next: j });
        }
    }
    for i in 0..n {
        let (a, b, c) = (points[(i + n - 1) % n], points[i], points[(i + 1) % n]);
        let len = (b - a).norm() * (c - b).norm();
        if cross(a, b, c).abs() <= 1e-12 * len {
            return Err(PolygonError::Collinear { index: i });
        }
    }
    for a in 0..n {
        for b in a + 1..n {
            // adjacent sides share a point by construction
            if b == a + 1 || (a == 0 && b == n - 1) {
                continue;
            }
            if segments_intersect(
                points[a],
                points[(a + 1) % n],
                points[b],
                points[(b + 1) % n],
                eps,
            ) {
                return Err(PolygonError::SelfIntersecting { a, b });
            }
        }
    }
    let area = signed_area(points);
    if area.abs() <= 1e-12 * scale * scale {
        return Err(PolygonError::ZeroArea { area });
    }
    Ok(area)
}

/// Splits a simple polygon into convex pieces, each a list of indices into `points` in
/// counter-clockwise order (whatever the input's orientation). A convex input comes back as one
/// piece. The pieces' areas sum to the input's |area|; they use only the input's points.
///
/// Algorithm: ear clipping (O(n³) worst case, fine for the tens of points a modelled profile
/// has), then the Hertel–Mehlhorn merge of adjacent pieces across each diagonal while the union
/// stays convex.
pub fn convex_decomposition(points: &[Point2<f64>]) -> Result<Vec<Vec<usize>>, PolygonError> {
    let area = check_simple(points)?;
    let n = points.len();
    let ccw: Vec<usize> = if area > 0.0 {
        (0..n).collect()
    } else {
        (0..n).rev().collect()
    };
    let pts: Vec<Point2<f64>> = ccw.iter().map(|&i| points[i]).collect();
    if is_convex(&pts) {
        return Ok(vec![ccw]);
    }
    let scale = scale_of(points);
    let eps = 1e-14 * scale * scale;
    // Ear clipping over positions 0..n of `pts`.
    let mut remaining: Vec<usize> = (0..n).collect();
    let mut triangles: Vec<Vec<usize>> = Vec::with_capacity(n - 2);
    while remaining.len() > 3 {
        let m = remaining.len();
        let mut clipped = false;
        for k in 0..m {
            let (ia, ib, ic) = (
                remaining[(k + m - 1) % m],
                remaining[k],
                remaining[(k + 1) % m],
            );
            let (a, b, c) = (pts[ia], pts[ib], pts[ic]);
            if cross(a, b, c) <= eps {
                continue; // reflex (or flat) corner: not an ear
            }
            let blocked = remaining.iter().any(|&ip| {
                if ip == ia || ip == ib || ip == ic {
                    return false;
                }
                let p = pts[ip];
                cross(a, b, p) >= -eps && cross(b, c, p) >= -eps && cross(c, a, p) >= -eps
            });
            if !blocked {
                triangles.push(vec![ia, ib, ic]);
                remaining.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            return Err(PolygonError::DecompositionFailed {
                index: ccw[remaining[0]],
            });
        }
    }
    triangles.push(remaining);
    // Hertel–Mehlhorn: merge two pieces across a shared side while the union is convex.
    let mut pieces = triangles;
    loop {
        let mut merged_any = false;
        'outer: for i in 0..pieces.len() {
            for j in i + 1..pieces.len() {
                if let Some(u) = merge_across_shared_side(&pieces[i], &pieces[j]) {
                    let upts: Vec<Point2<f64>> = u.iter().map(|&k| pts[k]).collect();
                    if is_convex(&upts) {
                        pieces[i] = u;
                        pieces.swap_remove(j);
                        merged_any = true;
                        break 'outer;
                    }
                }
            }
        }
        if !merged_any {
            break;
        }
    }
    Ok(pieces
        .into_iter()
        .map(|p| p.into_iter().map(|k| ccw[k]).collect())
        .collect())
}

/// If `a` has a side u→v and `b` the side v→u, the union polygon (both counter-clockwise).
fn merge_across_shared_side(a: &[usize], b: &[usize]) -> Option<Vec<usize>> {
    let (na, nb) = (a.len(), b.len());
    for i in 0..na {
        let (u, v) = (a[i], a[(i + 1) % na]);
        for j in 0..nb {
            if b[j] == v && b[(j + 1) % nb] == u {
                // a: ... u | v ... (from v round to u), then b's vertices after u up to before v
                let mut out = Vec::with_capacity(na + nb - 2);
                for k in 0..na {
                    out.push(a[(i + 1 + k) % na]); // v ... u
                }
                for k in 2..nb {
                    out.push(b[(j + k) % nb]); // after u, before v
                }
                return Some(out);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(v: &[(f64, f64)]) -> Vec<Point2<f64>> {
        v.iter().map(|&(x, y)| Point2::new(x, y)).collect()
    }

    #[test]
    fn l_shape_splits_into_two_convex_pieces_with_the_same_area() {
        let l = p(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (1.0, 1.0),
            (1.0, 2.0),
            (0.0, 2.0),
        ]);
        let pieces = convex_decomposition(&l).expect("simple");
        assert_eq!(pieces.len(), 2);
        let total: f64 = pieces
            .iter()
            .map(|pc| signed_area(&pc.iter().map(|&i| l[i]).collect::<Vec<_>>()))
            .sum();
        assert!((total - 3.0).abs() < 1e-12);
        for pc in &pieces {
            assert!(is_convex(&pc.iter().map(|&i| l[i]).collect::<Vec<_>>()));
        }
    }

    #[test]
    fn clockwise_input_gives_counter_clockwise_pieces() {
        let sq = p(&[(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]);
        let pieces = convex_decomposition(&sq).expect("simple");
        assert_eq!(pieces, vec![vec![3, 2, 1, 0]]);
    }

    #[test]
    fn bad_polygons_are_refused_with_the_offending_index() {
        assert_eq!(
            check_simple(&p(&[(0.0, 0.0), (1.0, 0.0)])),
            Err(PolygonError::TooFewPoints { len: 2 })
        );
        assert!(matches!(
            check_simple(&p(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (1.0, 1.0)])),
            Err(PolygonError::Collinear { index: 1 })
        ));
        assert!(matches!(
            check_simple(&p(&[(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)])),
            Err(PolygonError::SelfIntersecting { a: 0, b: 2 })
        ));
        assert!(matches!(
            check_simple(&p(&[(0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.0, 1.0)])),
            Err(PolygonError::RepeatedPoint { index: 1, next: 2 })
        ));
        assert!(matches!(
            check_simple(&p(&[(0.0, 0.0), (f64::NAN, 0.0), (0.0, 1.0)])),
            Err(PolygonError::NonFinite { index: 1, .. })
        ));
    }
}
