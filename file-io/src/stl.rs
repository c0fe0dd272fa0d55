//! STL: binary export of one body (and what hangs under it) or the whole model in world
//! coordinates, and (re-exported from `robosim-urdf`) reading binary or ASCII STL for import.
//!
//! Binary STL: an 80-byte header (ours starts `robosim`, never `solid`, which some readers
//! take for ASCII), a u32 triangle count, then per triangle a normal and three vertices (12 ×
//! f32, little-endian) and a u16 attribute (0). Units: metres; STL itself has none.

use crate::model::SavedModel;
use crate::world::{apply, normal, triangles, world_poses};

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

/// The STL reader: `robosim_urdf::stl` (re-exported here under its old path).
pub use robosim_urdf::stl::{MeshFileError, Triangles, read_stl};
