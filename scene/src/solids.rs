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

/// The collision solid of object `i`'s geometry: its convex hull when every vertex lies on or
/// behind every polygon's plane and the hull has volume, else the polygons as a mesh (a closed
/// non-convex solid, or an open surface such as a single plate, which collides as a surface).
/// `Ok(None)`: no geometry, or a [`Kind::Visual`] (drawn, never collided). `Err`: the geometry
/// makes no collision solid at all (the reason names why) — never silently no body.
pub fn solid_of(snap: &Snapshot, i: usize) -> Result<Option<Solid>, String> {
    if snap.object(i).kind() == Some(Kind::Visual) {
        return Ok(None);
    }
    let Some(g) = snap.geometry(i) else {
        return Ok(None);
    };
    let pts: Vec<Point3<f64>> = g
        .vertices
        .iter()
        .map(|v| Point3::new(v[0], v[1], v[2]))
        .collect();
    let convex = g.polygons.iter().all(|p| {
        pts.iter()
            .all(|v| p.plane[0] * v.x + p.plane[1] * v.y + p.plane[2] * v.z + p.plane[3] <= 1e-9)
    });
    if convex && let Ok(s) = Solid::convex(&pts) {
        return Ok(Some(s));
    }
    let polys: Vec<Vec<u32>> = g
        .polygons
        .iter()
        .map(|p| g.indices[p.start as usize..(p.start + p.len) as usize].to_vec())
        .collect();
    Solid::mesh(pts, &polys).map(Some).map_err(|e| {
        format!(
            "{}: its geometry makes no collision solid: {e}",
            snap.path(i)
        )
    })
}

/// The solids under object `id` (recursively), posed relative to `id`'s frame; with
/// `skip_links`, links and what hangs from them are left out (a robot's base).
pub fn solids_under(
    snap: &Snapshot,
    id: Id,
    skip_links: bool,
) -> Result<Vec<(Isometry3<f64>, Solid)>, String> {
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
        if let Some(s) = solid_of(snap, k)? {
            out.push((here, s));
        }
        stack.extend(snap.children(o.rec.id).map(|c| (c, here)));
    }
    Ok(out)
}

/// One link's solid: nothing, its one solid with its offset, or a compound of several
/// (`Err` names why the parts make no compound, e.g. a part that is not convex).
pub fn link_solid(parts: Vec<(Isometry3<f64>, Solid)>) -> Result<Option<LinkSolid>, String> {
    Ok(match parts.len() {
        0 => None,
        1 => parts.into_iter().next().map(|(offset, s)| LinkSolid {
            solid: Arc::new(s),
            offset,
        }),
        _ => Some(
            Solid::compound(parts)
                .map(|s| LinkSolid {
                    solid: Arc::new(s),
                    offset: Isometry3::identity(),
                })
                .map_err(|e| e.to_string())?,
        ),
    })
}

/// `top` and every object below it.
pub fn subtree(snap: &Snapshot, top: Id) -> HashSet<Id> {
    let mut set = HashSet::from([top]);
    let mut stack = vec![top];
    while let Some(id) = stack.pop() {
        for k in snap.children(id) {
            let c = snap.rec(k).id;
            if set.insert(c) {
                stack.push(c);
            }
        }
    }
    set
}

/// Objects with collision geometry under `top` (itself included; visuals are not bodies), not
/// descending into links below it.
pub fn bodies_under(snap: &Snapshot, top: Id) -> Vec<Id> {
    let mut out = Vec::new();
    let mut stack = vec![top];
    while let Some(id) = stack.pop() {
        if let Some(i) = snap.index_of(id)
            && snap.geometry(i).is_some()
            && snap.object(i).kind() != Some(Kind::Visual)
        {
            out.push(id);
        }
        for k in snap.children(id) {
            if snap.object(k).kind() != Some(Kind::Link) {
                stack.push(snap.rec(k).id);
            }
        }
    }
    out
}
