//! Wavefront OBJ reading for import: `v x y z [w]` and `f a b c …` (indices 1-based, negative
//! ones relative to the end, `a/t/n` forms accepted; texture and normal indices ignored).
//! Faces of more than three vertices are fan-triangulated, which is exact for convex faces
//! (what exporters write); a concave face would be covered wrongly. Every other statement
//! (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, comments) is ignored.

use crate::stl::{MeshFileError, Triangles};
use std::path::Path;

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
                for t in 1..face.len() - 1 {
                    out.push([face[0], face[t], face[t + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok(out)
}
