//! Wavefront OBJ reading for import: `v x y z [w]` and `f a b c …` (indices 1-based, negative
//! ones relative to the end, `a/t/n` forms accepted; texture and normal indices ignored).
//! Faces of more than three vertices are triangulated in their plane: a convex face as a fan, a
//! concave one (exporters write L-shaped n-gons) by ear clipping, so the triangles cover the face
//! and nothing outside it; a face that crosses itself is refused at its line, and a concave face
//! of more than [`MAX_CONCAVE_FACE`] vertices too (ear clipping is quadratic in them). Every other
//! statement (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, comments) is ignored.

use crate::stl::{MeshFileError, Triangles};
use std::path::Path;

/// The most vertices of a concave face that are triangulated (ear clipping takes up to n² ear
/// tests of n points each); a convex face of any size is a fan.
pub const MAX_CONCAVE_FACE: usize = 1024;

pub fn read_obj(bytes: &[u8], path: &Path) -> Result<Triangles, MeshFileError> {
    let err = |line: usize, reason: String| MeshFileError {
        path: path.to_owned(),
        line,
        reason,
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        err(
            0,
            format!("not UTF-8 text (byte {}): not an OBJ file", e.valid_up_to()),
        )
    })?;
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line_no = k + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut v = [0.0; 3];
                for c in &mut v {
                    let w = words
                        .next()
                        .ok_or_else(|| err(line_no, "a vertex needs three coordinates".into()))?;
                    *c = w
                        .parse()
                        .map_err(|_| err(line_no, format!("{w:?} is not a number")))?;
                }
                vertices.push(v);
            }
            Some("f") => {
                let mut face = Vec::new();
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let i: i64 = first
                        .parse()
                        .map_err(|_| err(line_no, format!("{w:?} is not a vertex index")))?;
                    let n = vertices.len() as i64;
                    let idx = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || idx < 0 || idx >= n {
                        return Err(err(
                            line_no,
                            format!(
                                "vertex index {i} is out of range (there are {n} vertices so far)"
                            ),
                        ));
                    }
                    face.push(vertices[idx as usize]);
                }
                if face.len() < 3 {
                    return Err(err(
                        line_no,
                        format!("a face has {} vertices; it needs at least 3", face.len()),
                    ));
                }
                for [a, b, c] in triangulate(&face).map_err(|why| err(line_no, why))? {
                    out.push([face[a], face[b], face[c]]);
                }
            }
            _ => {}
        }
    }
    Ok(out)
}

/// The triangles (indices into `face`) covering a planar polygon: a fan when it is convex (or
/// degenerate: no plane), else ear clipping in the plane of its Newell normal. A polygon that
/// crosses itself leaves no ear and is refused.
fn triangulate(face: &[[f64; 3]]) -> Result<Vec<[usize; 3]>, String> {
    let n = face.len();
    let fan = || (1..n - 1).map(|t| [0, t, t + 1]).collect::<Vec<_>>();
    if n == 3 {
        return Ok(fan());
    }
    let mut normal = [0.0f64; 3];
    for i in 0..n {
        let (a, b) = (face[i], face[(i + 1) % n]);
        normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
        normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
        normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    if !normal.iter().all(|c| c.is_finite()) || normal == [0.0; 3] {
        return Ok(fan()); // no plane: zero-area triangles, dropped by the importers
    }
    // The plane's coordinates: drop the normal's largest axis, keep (u, v, axis) right-handed
    // and flip v when the normal points down that axis, so the polygon runs counter-clockwise.
    let k = (0..3)
        .max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
        .unwrap_or(2);
    let (u, v) = [(1, 2), (2, 0), (0, 1)][k];
    let s = normal[k].signum();
    let p: Vec<[f64; 2]> = face.iter().map(|q| [q[u], q[v] * s]).collect();
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    if (0..n).all(|i| cross(p[(i + n - 1) % n], p[i], p[(i + 1) % n]) >= 0.0) {
        return Ok(fan());
    }
    if n > MAX_CONCAVE_FACE {
        return Err(format!(
            "a concave face of {n} vertices; at most {MAX_CONCAVE_FACE} are triangulated (split it)"
        ));
    }
    // Two edges that are not neighbours and cross properly: no triangulation covers the face.
    let crosses = |a: usize, b: usize, c: usize, d: usize| {
        let (d1, d2) = (cross(p[a], p[b], p[c]), cross(p[a], p[b], p[d]));
        let (d3, d4) = (cross(p[c], p[d], p[a]), cross(p[c], p[d], p[b]));
        d1 * d2 < 0.0 && d3 * d4 < 0.0
    };
    for i in 0..n {
        for j in i + 2..n {
            if (j + 1) % n != i && crosses(i, (i + 1) % n, j, (j + 1) % n) {
                return Err(format!(
                    "a face of {n} vertices crosses itself (its edges {} and {} cross)",
                    i + 1,
                    j + 1
                ));
            }
        }
    }
    let mut idx: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while idx.len() > 3 {
        let m = idx.len();
        let ear = (0..m).find(|&j| {
            let (a, b, c) = (idx[(j + m - 1) % m], idx[j], idx[(j + 1) % m]);
            if cross(p[a], p[b], p[c]) <= 0.0 {
                return false; // reflex or flat: not an ear
            }
            // No other vertex inside or on the triangle (points at its corners are its own).
            idx.iter().all(|&q| {
                q == a
                    || q == b
                    || q == c
                    || p[q] == p[a]
                    || p[q] == p[b]
                    || p[q] == p[c]
                    || cross(p[a], p[b], p[q]) < 0.0
                    || cross(p[b], p[c], p[q]) < 0.0
                    || cross(p[c], p[a], p[q]) < 0.0
            })
        });
        match ear {
            Some(j) => {
                out.push([idx[(j + m - 1) % m], idx[j], idx[(j + 1) % m]]);
                idx.remove(j);
            }
            None => {
                let twice_area: f64 = (0..m)
                    .map(|j| {
                        let (a, b) = (p[idx[j]], p[idx[(j + 1) % m]]);
                        a[0] * b[1] - b[0] * a[1]
                    })
                    .sum();
                if twice_area.abs() <= f64::EPSILON * m as f64 {
                    // What is left has no area: zero-area triangles, dropped by the importers.
                    out.extend((1..m - 1).map(|t| [idx[0], idx[t], idx[t + 1]]));
                    return Ok(out);
                }
                return Err(format!(
                    "a face of {n} vertices crosses itself (no triangulation covers it)"
                ));
            }
        }
    }
    out.push([idx[0], idx[1], idx[2]]);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(t: &[[f64; 3]; 3]) -> f64 {
        let (u, v) = (
            [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]],
            [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]],
        );
        let c = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
    }

    /// Issue 34 (hostile inputs): a concave face was fanned from its first vertex, covering the
    /// notch of an L (area 4 for an L of area 3, triangles outside the face).
    #[test]
    fn concave_obj_face_is_covered_exactly_not_fanned_over_its_notch() {
        // The L, starting at the vertex whose fan crosses the notch; in the xy, yz and zx planes
        // and upside down.
        let l = [
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
            [0.0, 0.0],
            [2.0, 0.0],
        ];
        for plane in 0..3 {
            for flip in [false, true] {
                let mut text = String::new();
                for q in &l {
                    let mut v = [0.0; 3];
                    v[plane] = q[0];
                    v[(plane + 1) % 3] = if flip { -q[1] } else { q[1] };
                    v[(plane + 2) % 3] = 5.0;
                    text.push_str(&format!("v {} {} {}\n", v[0], v[1], v[2]));
                }
                text.push_str("f 1 2 3 4 5 6\n");
                let tris = read_obj(text.as_bytes(), Path::new("l.obj")).expect("reads");
                assert_eq!(tris.len(), 4);
                let total: f64 = tris.iter().map(area).sum();
                assert!(
                    (total - 3.0).abs() < 1e-12,
                    "plane {plane}, flip {flip}: area {total}"
                );
            }
        }
    }

    #[test]
    fn convex_obj_faces_are_still_fans_and_a_self_crossing_face_is_refused_at_its_line() {
        let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        let tris = read_obj(quad.as_bytes(), Path::new("q.obj")).expect("reads");
        assert_eq!(tris.len(), 2);
        assert!((tris.iter().map(area).sum::<f64>() - 1.0).abs() < 1e-15);
        // A bow tie with a fold: 1 2 4 3 crosses itself (its Newell area is zero: a fan of
        // zero-area triangles); 5 vertices crossing with area left are refused.
        let star = "v 0 0 0\nv 4 0 0\nv 0 3 0\nv 4 3 0\nv 2 -1 0\n\nf 1 4 2 3 5\n";
        let e = read_obj(star.as_bytes(), Path::new("s.obj")).expect_err("crosses itself");
        assert_eq!(e.line, 7, "{e}");
        assert!(e.reason.contains("crosses itself"), "{e}");
    }
}
