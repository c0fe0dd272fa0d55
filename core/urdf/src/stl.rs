//! STL reading (binary or ASCII) for mesh import and URDF meshes. The binary writer, which
//! needs a saved model, is `robosim_file_io::stl::to_stl`.

use std::path::{Path, PathBuf};

/// A mesh file that cannot be read: the file, the 1-based line (0 when the problem is not on
/// one line) and what was wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}:{line}: {reason}", path.display())]
pub struct MeshFileError {
    pub path: PathBuf,
    pub line: usize,
    pub reason: String,
}

/// Triangles as read from a mesh file (m, the file's frame), before welding.
pub type Triangles = Vec<[[f64; 3]; 3]>;

/// Reads binary or ASCII STL. Binary is recognised by its size (84 + 50 × the count in its
/// header); otherwise the file must be ASCII, starting with `solid`.
pub fn read_stl(bytes: &[u8], path: &Path) -> Result<Triangles, MeshFileError> {
    let err = |line: usize, reason: String| MeshFileError {
        path: path.to_owned(),
        line,
        reason,
    };
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        if 84 + 50 * n == bytes.len() as u64 {
            let f = |k: usize| {
                f32::from_le_bytes([bytes[k], bytes[k + 1], bytes[k + 2], bytes[k + 3]]) as f64
            };
            let mut out = Vec::with_capacity(n as usize);
            for t in 0..n as usize {
                let base = 84 + 50 * t + 12;
                let v = |j: usize| [f(base + 12 * j), f(base + 12 * j + 4), f(base + 12 * j + 8)];
                out.push([v(0), v(1), v(2)]);
            }
            return Ok(out);
        }
    }
    let text = std::str::from_utf8(bytes).map_err(|_| {
        err(
            0,
            format!(
                "neither binary STL (a binary STL of {} bytes would announce {} triangles) nor ASCII text",
                bytes.len(),
                (bytes.len().saturating_sub(84)) as f64 / 50.0
            ),
        )
    })?;
    if !text.trim_start().starts_with("solid") {
        return Err(err(1, "neither binary STL (its size is not 84 + 50 × its triangle count) nor ASCII STL (it does not start with \"solid\")".into()));
    }
    let mut out = Vec::new();
    let mut facet: Vec<[f64; 3]> = Vec::new();
    let mut facet_line = 0;
    for (k, line) in text.lines().enumerate() {
        let line_no = k + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("facet") => {
                facet.clear();
                facet_line = line_no;
            }
            Some("vertex") => {
                let mut v = [0.0; 3];
                for c in &mut v {
                    let w = words
                        .next()
                        .ok_or_else(|| err(line_no, "a vertex needs three coordinates".into()))?;
                    *c = w
                        .parse()
                        .map_err(|_| err(line_no, format!("{w:?} is not a number")))?;
                }
                facet.push(v);
            }
            Some("endfacet") => {
                if facet.len() != 3 {
                    return Err(err(
                        facet_line,
                        format!("a facet has {} vertices; STL facets have 3", facet.len()),
                    ));
                }
                out.push([facet[0], facet[1], facet[2]]);
                facet.clear();
            }
            _ => {}
        }
    }
    Ok(out)
}
