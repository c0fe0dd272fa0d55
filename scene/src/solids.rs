//! Instance Space geometry as the collision core's solids: each object's polygons become a
//! convex hull when they bound a convex body, else a mesh; a link's solids (every object under
//! it that is not itself under another link) become one compound in the link's frame.

use crate::pose;
use nalgebra::{Isometry3, Point3};
use robosim_collision::Solid;
use robosim_collision::robot::LinkSolid;
use robosim_instance_space::{Id, Kind, Snapshot};
use std::collections::HashSet;
use std::sync::Arc;

/// The collision solid of object `i`'s geometry (convex hull when every vertex lies on or
/// behind every polygon's plane, else a mesh), or `None` when it has no geometry or the
/// geometry makes no solid.
pub fn solid_of(snap: &Snapshot, i: usize) -> Option<Solid> {
    let g = snap.geometry(i)?;
    let pts: Vec<Point3<f64>> = g
        .vertices
        .iter()
        .map(|v| Point3::new(v[0], v[1], v[2]))
        .collect();
    let convex = g.polygons.iter().all(|p| {
        pts.iter()
            .all(|v| p.plane[0] * v.x + p.plane[1] * v.y + p.plane[2] * v.z + p.plane[3] <= 1e-9)
    });
    if convex {
        Solid::convex(&pts).ok()
    } else {
        let polys: Vec<Vec<u32>> = g
            .polygons
            .iter()
            .map(|p| g.indices[p.start as usize..(p.start + p.len) as usize].to_vec())
            .collect();
        Solid::mesh(pts, &polys).ok()
    }
}

/// The solids under object `id` (recursively), posed relative to `id`'s frame; with
/// `skip_links`, links and what hangs from them are left out (a robot's base).
pub fn solids_under(snap: &Snapshot, id: Id, skip_links: bool) -> Vec<(Isometry3<f64>, Solid)> {
    let mut out = Vec::new();
    let mut stack: Vec<(usize, Isometry3<f64>)> = snap
        .children(id)
        .map(|k| (k, Isometry3::identity()))
        .collect();
    while let Some((k, parent)) = stack.pop() {
        let o = snap.object(k);
        if skip_links && o.kind() == Some(Kind::Link) {
            continue;
        }
        let here = parent * pose::to_isometry(&o.pose.pose);
        if let Some(s) = solid_of(snap, k) {
            out.push((here, s));
        }
        stack.extend(snap.children(o.rec.id).map(|c| (c, here)));
    }
    out
}

/// One link's solid: nothing, its one solid with its offset, or a compound of several.
pub fn link_solid(parts: Vec<(Isometry3<f64>, Solid)>) -> Option<LinkSolid> {
    match parts.len() {
        0 => None,
        1 => parts.into_iter().next().map(|(offset, s)| LinkSolid {
            solid: Arc::new(s),
            offset,
        }),
        _ => Solid::compound(parts).ok().map(|s| LinkSolid {
            solid: Arc::new(s),
            offset: Isometry3::identity(),
        }),
    }
}

/// `top` and every object below it.
pub fn subtree(snap: &Snapshot, top: Id) -> HashSet<Id> {
    let mut set = HashSet::from([top]);
    let mut stack = vec![top];
    while let Some(id) = stack.pop() {
        for k in snap.children(id) {
            let c = snap.objects()[k].id;
            if set.insert(c) {
                stack.push(c);
            }
        }
    }
    set
}

/// Objects with geometry under `top` (itself included), not descending into links below it.
pub fn bodies_under(snap: &Snapshot, top: Id) -> Vec<Id> {
    let mut out = Vec::new();
    let mut stack = vec![top];
    while let Some(id) = stack.pop() {
        if let Some(i) = snap.index_of(id)
            && snap.geometry(i).is_some()
        {
            out.push(id);
        }
        for k in snap.children(id) {
            if snap.object(k).kind() != Some(Kind::Link) {
                stack.push(snap.objects()[k].id);
            }
        }
    }
    out
}
