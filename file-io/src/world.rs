//! World poses and triangles of a [`SavedModel`], shared by the exporters.

use crate::model::SavedModel;
use robosim_instance_space::{ObjectData, Pose};
use std::collections::HashMap;

/// `a · b` for 3×4 row-major rigid transforms (the reader's own composition, so exported
/// world poses are the ones every process computes).
pub use robosim_instance_space::compose;

/// `p` applied to the point `v` (m).
pub fn apply(p: &Pose, v: &[f64; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (r, o) in out.iter_mut().enumerate() {
        *o = p[r * 4] * v[0] + p[r * 4 + 1] * v[1] + p[r * 4 + 2] * v[2] + p[r * 4 + 3];
    }
    out
}

/// Every object's world pose (the product of local poses from its root down), by index into
/// `model.objects`. `order` is [`SavedModel::plan`]'s (parents first).
pub fn world_poses(model: &SavedModel, order: &[usize]) -> Vec<Pose> {
    let index: HashMap<u64, usize> = model
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| (o.id, i))
        .collect();
    let mut world = vec![robosim_instance_space::IDENTITY; model.objects.len()];
    for &i in order {
        let o = &model.objects[i];
        world[i] = match index.get(&o.parent) {
            Some(&p) if o.parent != 0 => compose(&world[p], &o.pose),
            _ => o.pose,
        };
    }
    world
}

/// The fan triangles of an object's geometry, as vertex indices (none without geometry).
pub fn triangles(o: &ObjectData) -> Vec<[u32; 3]> {
    o.geometry
        .as_ref()
        .map(|g| {
            g.polygons
                .iter()
                .flat_map(|p| robosim_geometry::triangulate::fan(p))
                .collect()
        })
        .unwrap_or_default()
}

/// The unit normal of a triangle (zero for a degenerate one).
pub fn normal(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if l > 0.0 {
        [n[0] / l, n[1] / l, n[2] / l]
    } else {
        [0.0; 3]
    }
}
