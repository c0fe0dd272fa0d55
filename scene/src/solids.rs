//! Instance Space geometry as the robot model's descriptions ([`robosim_model::GeometryObject`]):
//! each object's polygons are a [`Shape::Polygons`], said to bound a convex body when every
//! vertex lies on or behind every polygon's plane. `robosim_model::geometry` builds the
//! solids from them (a hull when convex and with volume, else a mesh; a link's objects — every
//! object under it that is not itself under another link — one compound in the link's frame).

use crate::pose;
use nalgebra::{Matrix4, Point3};
use robosim_collision::Solid;
use robosim_instance_space::{Id, Kind, Snapshot};
use robosim_model::{GeometryObject, Role, Shape};
use std::collections::HashSet;

/// Object `i`'s geometry as a collision object on frame `frame` at `placement` (in that
/// frame), named by its path. `None`: no geometry, or a [`Kind::Visual`] (drawn, never
/// collided).
pub fn geometry_object(
    snap: &Snapshot,
    i: usize,
    frame: usize,
    placement: Matrix4<f64>,
) -> Option<GeometryObject> {
    if snap.object(i).kind() == Some(Kind::Visual) {
        return None;
    }
    let g = snap.geometry(i)?;
    let vertices: Vec<Point3<f64>> = g
        .vertices
        .iter()
        .map(|v| Point3::new(v[0], v[1], v[2]))
        .collect();
    let convex = g.polygons.iter().all(|p| {
        vertices
            .iter()
            .all(|v| p.plane[0] * v.x + p.plane[1] * v.y + p.plane[2] * v.z + p.plane[3] <= 1e-9)
    });
    let polygons = g
        .polygons
        .iter()
        .map(|p| g.indices[p.start as usize..(p.start + p.len) as usize].to_vec())
        .collect();
    Some(GeometryObject {
        name: snap.path(i),
        frame,
        placement,
        shape: Shape::Polygons {
            vertices,
            polygons,
            convex,
        },
        role: Role::Collision,
        rgba: None,
    })
}

/// The collision solid of object `i`'s geometry in its own frame (built by
/// [`GeometryObject::collision_parts`]: its convex hull when it bounds a convex body with
/// volume, else the polygons as a mesh — a closed non-convex solid, or an open surface such as
/// a single plate, which collides as a surface). `Ok(None)`: no geometry, or a visual. `Err`:
/// the geometry makes no collision solid at all (the reason names why) — never silently no
/// body.
pub fn solid_of(snap: &Snapshot, i: usize) -> Result<Option<Solid>, String> {
    let Some(o) = geometry_object(snap, i, 0, Matrix4::identity()) else {
        return Ok(None);
    };
    let parts = o.collision_parts().map_err(|e| {
        format!(
            "{}: its geometry makes no collision solid: {e}",
            snap.path(i)
        )
    })?;
    // Polygons make one solid.
    Ok(parts.into_iter().next())
}

/// The collision objects under object `id` (recursively) on frame `frame`, placed relative to
/// `id`'s frame, in the order a compound of them keeps; with `skip_links`, links and what
/// hangs from them are left out (a robot's base).
pub fn geometry_under(
    snap: &Snapshot,
    id: Id,
    frame: usize,
    skip_links: bool,
) -> Vec<GeometryObject> {
    let mut out = Vec::new();
    // (object, the placement of its parent in `id`'s frame; `None`: `id` itself)
    let mut stack: Vec<(usize, Option<Matrix4<f64>>)> =
        snap.children(id).map(|k| (k, None)).collect();
    while let Some((k, parent)) = stack.pop() {
        let o = snap.object(k);
        if skip_links && o.kind() == Some(Kind::Link) {
            continue;
        }
        let pose = pose::to_matrix(&o.pose.pose);
        let here = parent.map_or(pose, |p| p * pose);
        out.extend(geometry_object(snap, k, frame, here));
        stack.extend(snap.children(o.rec.id).map(|c| (c, Some(here))));
    }
    out
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
