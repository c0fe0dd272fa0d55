//! Mesh import (STL binary or ASCII, OBJ): a mesh file becomes an item placed in the scene,
//! with one solid holding the geometry, in one transaction.
//!
//! What the Instance Space keeps: the geometry crate requires convex *polygons* (checked), not
//! convex solids, so by default the mesh itself is kept — its triangles, identical vertices
//! welded, degenerate (zero-area) triangles dropped — and the display draws the real shape;
//! the collision core takes a non-convex solid as a mesh (scene/src/solids.rs). With `hull`,
//! the convex hull (parry's) is kept instead: what convex collision wants, at the price of the
//! shape's concavities in the display too.

use crate::error::FileError;
use crate::stl::Triangles;
use robosim_instance_space::{Appearance, GeometryInput, Kind, ObjRef, Pose, Transaction};
use std::collections::HashMap;
use std::path::Path;

/// A mesh made Instance Space geometry, and what was done to get there.
#[derive(Debug, Clone)]
pub struct MeshGeometry {
    pub geometry: GeometryInput,
    /// Triangles in the file.
    pub read: usize,
    /// Zero-area triangles dropped.
    pub dropped: usize,
}

/// Reads a mesh file by its extension (`.stl`, `.obj`, any case), scaled by `scale` (file
/// units → m).
pub fn read_mesh(path: &Path, scale: f64) -> Result<Triangles, FileError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(FileError::Usage(format!(
            "--scale {scale}: must be a positive number (file units to metres)"
        )));
    }
    let bytes = robosim_input::read_file(path, "a mesh file", robosim_input::Limit::MESH)?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut tris = match ext.as_deref() {
        Some("stl") => crate::stl::read_stl(&bytes, path)?,
        Some("obj") => crate::obj::read_obj(&bytes, path)?,
        _ => {
            return Err(FileError::Usage(format!(
                "{}: import reads .stl and .obj meshes",
                path.display()
            )));
        }
    };
    for (k, t) in tris.iter_mut().enumerate() {
        for v in t.iter_mut() {
            for c in v.iter_mut() {
                *c *= scale;
                if !c.is_finite() {
                    return Err(FileError::Mesh {
                        path: path.to_owned(),
                        line: 0,
                        reason: format!("triangle {k} has a coordinate that is not finite"),
                    });
                }
            }
        }
    }
    Ok(tris)
}

/// Degenerate by the geometry crate's own test, with a margin (area ≤ 10⁻¹¹ × the longest
/// side², ten times its limit), so that no triangle kept is refused by the keeper.
fn degenerate(t: &[[f64; 3]; 3]) -> bool {
    let n = crate::world::normal(t[0], t[1], t[2]);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let len = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let (u, v) = (sub(t[1], t[0]), sub(t[2], t[0]));
    let cross = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let area = len(cross) * 0.5;
    let size = len(u).max(len(v)).max(len(sub(t[2], t[1])));
    n == [0.0; 3] || area.is_nan() || area <= size * size * 1e-11
}

/// The triangles as Instance Space geometry: identical vertices welded, degenerate triangles
/// dropped; with `hull`, their convex hull instead.
pub fn mesh_geometry(tris: &Triangles, hull: bool, path: &Path) -> Result<MeshGeometry, FileError> {
    let empty = |what: &str| FileError::Mesh {
        path: path.to_owned(),
        line: 0,
        reason: format!("{what}: nothing to import"),
    };
    if tris.is_empty() {
        return Err(empty("no triangles"));
    }
    if hull {
        let pts: Vec<nalgebra::Point3<f64>> = tris
            .iter()
            .flatten()
            .map(|v| nalgebra::Point3::new(v[0], v[1], v[2]))
            .collect();
        let mut g = hull_geometry(&pts, path)?;
        g.read = tris.len();
        return Ok(g);
    }
    let g = weld(tris);
    if g.geometry.polygons.is_empty() {
        return Err(empty("every triangle has zero area"));
    }
    Ok(g)
}

/// The convex hull of `points` as Instance Space geometry (its triangles, welded); `path` names
/// the mesh in errors.
pub fn hull_geometry(
    points: &[nalgebra::Point3<f64>],
    path: &Path,
) -> Result<MeshGeometry, FileError> {
    let bad = |reason: String| FileError::Mesh {
        path: path.to_owned(),
        line: 0,
        reason,
    };
    let (hv, ht) = parry3d_f64::transformation::try_convex_hull(points)
        .map_err(|e| bad(format!("its convex hull cannot be built: {e:?}")))?;
    let hv: Vec<[f64; 3]> = hv.iter().map(|p| [p.x, p.y, p.z]).collect();
    let hull_tris: Triangles = ht
        .iter()
        .map(|t| [hv[t[0] as usize], hv[t[1] as usize], hv[t[2] as usize]])
        .collect();
    let g = weld(&hull_tris);
    if g.geometry.polygons.is_empty() {
        return Err(bad(
            "a flat hull (all points in one plane): nothing to import".into(),
        ));
    }
    Ok(g)
}

fn weld(tris: &Triangles) -> MeshGeometry {
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut vertices = Vec::new();
    let mut polygons = Vec::with_capacity(tris.len());
    let mut dropped = 0;
    for t in tris {
        if degenerate(t) {
            dropped += 1;
            continue;
        }
        let mut p = Vec::with_capacity(3);
        for v in t {
            let key = v.map(|c| if c == 0.0 { 0 } else { c.to_bits() });
            let k = *index.entry(key).or_insert_with(|| {
                vertices.push(*v);
                (vertices.len() - 1) as u32
            });
            p.push(k);
        }
        if p[0] == p[1] || p[1] == p[2] || p[0] == p[2] {
            dropped += 1;
            continue;
        }
        // The keeper's own polygon check (a sliver can pass the area test above and still
        // have a normal too inexact for the planarity test): what it would refuse is dropped.
        let corners: Vec<nalgebra::Point3<f64>> = p
            .iter()
            .map(|&k| {
                let v = vertices[k as usize];
                nalgebra::Point3::new(v[0], v[1], v[2])
            })
            .collect();
        if robosim_geometry::check_polygon(&corners, 0, &[0, 1, 2]).is_err() {
            dropped += 1;
            continue;
        }
        polygons.push(p);
    }
    MeshGeometry {
        geometry: GeometryInput { vertices, polygons },
        read: tris.len(),
        dropped,
    }
}

/// Where and how the imported item goes.
#[derive(Debug, Clone)]
pub struct Placement {
    /// The item's name; its solid is `NAME-mesh`.
    pub name: String,
    /// The item's pose relative to its parent.
    pub pose: Pose,
    /// The parent (a scene), or `None` for a root item.
    pub parent: Option<u64>,
    pub appearance: Appearance,
}

/// The one transaction that creates the item and its solid.
pub fn import_tx(g: &GeometryInput, place: &Placement) -> Transaction {
    let mut tx = Transaction::new();
    let item = tx.create(Kind::Item, &place.name, place.parent.map(ObjRef::Id));
    tx.set_pose(item, place.pose);
    let solid = tx.create(Kind::Solid, &format!("{}-mesh", place.name), Some(item));
    tx.set_geometry(solid, Some(g.clone()));
    tx.set_appearance(solid, place.appearance);
    tx
}

/// `x,y,z[,roll,pitch,yaw]`: metres and degrees; R = Rz(yaw)·Ry(pitch)·Rx(roll) (fixed axes
/// x, y, z, as URDF's `rpy`).
pub fn parse_at(s: &str) -> Result<Pose, FileError> {
    let v: Vec<f64> = s
        .split(',')
        .map(|w| w.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            FileError::Usage(format!(
                "--at {s:?}: expected x,y,z[,roll,pitch,yaw] (m, deg)"
            ))
        })?;
    if !(v.len() == 3 || v.len() == 6) || v.iter().any(|x| !x.is_finite()) {
        return Err(FileError::Usage(format!(
            "--at {s:?}: expected 3 or 6 finite numbers: x,y,z (m) [,roll,pitch,yaw (deg)]"
        )));
    }
    let (r, p, y) = if v.len() == 6 {
        (v[3].to_radians(), v[4].to_radians(), v[5].to_radians())
    } else {
        (0.0, 0.0, 0.0)
    };
    let m = nalgebra::Rotation3::from_euler_angles(r, p, y);
    let m = m.matrix();
    Ok([
        m[(0, 0)],
        m[(0, 1)],
        m[(0, 2)],
        v[0],
        m[(1, 0)],
        m[(1, 1)],
        m[(1, 2)],
        v[1],
        m[(2, 0)],
        m[(2, 1)],
        m[(2, 2)],
        v[2],
    ])
}

/// `r,g,b[,a]` in [0, 1].
pub fn parse_color(s: &str) -> Result<[f32; 4], FileError> {
    let v: Vec<f32> = s
        .split(',')
        .map(|w| w.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| FileError::Usage(format!("--color {s:?}: expected r,g,b[,a] in 0..1")))?;
    if !(v.len() == 3 || v.len() == 4) || v.iter().any(|c| !(0.0..=1.0).contains(c)) {
        return Err(FileError::Usage(format!(
            "--color {s:?}: expected 3 or 4 numbers in 0..1"
        )));
    }
    Ok([v[0], v[1], v[2], v.get(3).copied().unwrap_or(1.0)])
}
