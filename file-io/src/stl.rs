//! STL: binary export of one body (and what hangs under it) or the whole model in world
//! coordinates, and reading binary or ASCII STL for import.
//!
//! Binary STL: an 80-byte header (ours starts `robosim`, never `solid`, which some readers
//! take for ASCII), a u32 triangle count, then per triangle a normal and three vertices (12 ×
//! f32, little-endian) and a u16 attribute (0). Units: metres; STL itself has none.

use crate::error::FileError;
use crate::model::SavedModel;
use crate::world::{apply, normal, triangles, world_poses};
use std::path::Path;

/// The binary STL of every body under (and including) the objects `roots` (all objects when
/// `None`), in world coordinates. Returns the bytes and the triangle count; `None` when the
/// model is invalid.
pub fn to_stl(model: &SavedModel, roots: Option<&[u64]>, what: &str) -> Option<(Vec<u8>, usize)> {
    let order = model.plan().ok()?;
    let world = world_poses(model, &order);
    let index: std::collections::HashMap<u64, usize> = model
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| (o.id, i))
        .collect();
    // Inclusion follows the creation order: a parent is decided before its children.
    let mut included = vec![roots.is_none(); model.objects.len()];
    if let Some(r) = roots {
        for &i in &order {
            let o = &model.objects[i];
            included[i] = r.contains(&o.id)
                || index
                    .get(&o.parent)
                    .is_some_and(|&p| o.parent != 0 && included[p]);
        }
    }
    let mut tris: Vec<[[f64; 3]; 3]> = Vec::new();
    for &i in &order {
        if !included[i] {
            continue;
        }
        let o = &model.objects[i];
        let Some(g) = &o.geometry else { continue };
        for t in triangles(o) {
            let p = |k: u32| {
                apply(
                    &world[i],
                    &g.vertices.get(k as usize).copied().unwrap_or([0.0; 3]),
                )
            };
            tris.push([p(t[0]), p(t[1]), p(t[2])]);
        }
    }
    let mut out = Vec::with_capacity(84 + 50 * tris.len());
    let mut header = format!("robosim STL export: {what}; metres, world frame").into_bytes();
    header.resize(80, b' ');
    out.extend_from_slice(&header[..80]);
    out.extend_from_slice(&(tris.len() as u32).to_le_bytes());
    for [a, b, c] in &tris {
        for v in [normal(*a, *b, *c), *a, *b, *c] {
            for x in v {
                out.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
        out.extend_from_slice(&0u16.to_le_bytes());
    }
    Some((out, tris.len()))
}

/// Triangles as read from a mesh file (m, the file's frame), before welding.
pub type Triangles = Vec<[[f64; 3]; 3]>;

/// Reads binary or ASCII STL. Binary is recognised by its size (84 + 50 × the count in its
/// header); otherwise the file must be ASCII, starting with `solid`.
pub fn read_stl(bytes: &[u8], path: &Path) -> Result<Triangles, FileError> {
    let err = |line: usize, reason: String| FileError::Mesh {
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
