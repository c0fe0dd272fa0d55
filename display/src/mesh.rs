//! From an object's polygon model (the Instance Space's geometry segment) to the arrays the GPU
//! draws: triangles with one normal per polygon (flat shading, as the seed's polygon models are
//! drawn), the polygon each triangle came from (for picking), and the edge list as line
//! segments (the edge overlay). Everything stays in the object's own frame; the GPU applies the
//! body's transform.

use robosim_instance_space::GeometryView;

/// One GPU vertex: position and polygon normal in the body frame (f32: the GPU's precision;
/// see docs/display.md on scale).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
}

/// A body's mesh on the CPU side.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CpuMesh {
    /// Three per triangle.
    pub vertices: Vec<Vertex>,
    /// The source polygon of each triangle (index into the geometry's polygons).
    pub tri_polygon: Vec<u32>,
    /// Two per edge.
    pub edge_points: Vec<[f32; 3]>,
}

impl CpuMesh {
    /// Fan-triangulates every polygon (the Instance Space holds convex polygons: the library
    /// splits concave ones before they get here) with the polygon's own plane normal.
    pub fn from_geometry(g: &GeometryView<'_>) -> CpuMesh {
        let v = |i: u32| -> [f32; 3] {
            g.vertices
                .get(i as usize)
                .map_or([0.0; 3], |p| [p[0] as f32, p[1] as f32, p[2] as f32])
        };
        let mut mesh = CpuMesh::default();
        for (pi, poly) in g.polygons.iter().enumerate() {
            let start = poly.start as usize;
            let end = start + poly.len as usize;
            let Some(idx) = g.indices.get(start..end) else {
                continue;
            };
            let normal = [
                poly.plane[0] as f32,
                poly.plane[1] as f32,
                poly.plane[2] as f32,
            ];
            for tri in robosim_geometry::triangulate::fan(idx) {
                for i in tri {
                    mesh.vertices.push(Vertex { pos: v(i), normal });
                }
                mesh.tri_polygon.push(pi as u32);
            }
        }
        for e in g.edges {
            mesh.edge_points.push(v(e[0]));
            mesh.edge_points.push(v(e[1]));
        }
        mesh
    }

    pub fn triangles(&self) -> usize {
        self.tri_polygon.len()
    }

    /// Nearest hit of a ray (body frame) with the mesh: distance along the ray and the source
    /// polygon. Möller–Trumbore, both faces (the display draws both).
    pub fn raycast(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<(f64, u32)> {
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let f = |p: [f32; 3]| [p[0] as f64, p[1] as f64, p[2] as f64];
        let mut best: Option<(f64, u32)> = None;
        for (t, tri) in self.vertices.chunks_exact(3).enumerate() {
            let (a, b, c) = (f(tri[0].pos), f(tri[1].pos), f(tri[2].pos));
            let e1 = sub(b, a);
            let e2 = sub(c, a);
            let p = cross(dir, e2);
            let det = dot(e1, p);
            if det.abs() < 1e-18 {
                continue;
            }
            let inv = 1.0 / det;
            let s = sub(origin, a);
            let u = dot(s, p) * inv;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let q = cross(s, e1);
            let w = dot(dir, q) * inv;
            if w < 0.0 || u + w > 1.0 {
                continue;
            }
            let dist = dot(e2, q) * inv;
            if dist > 0.0 && best.is_none_or(|(d, _)| dist < d) {
                best = Some((dist, self.tri_polygon[t]));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use robosim_instance_space::layout::{GeometryHeader, PolygonRec};

    type Parts = (Vec<[f64; 3]>, Vec<u32>, Vec<PolygonRec>, Vec<[u32; 2]>);

    fn quad_and_triangle() -> Parts {
        let vertices = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let indices = vec![0, 1, 2, 3, 0, 1, 4];
        let polygons = vec![
            PolygonRec {
                start: 0,
                len: 4,
                plane: [0.0, 0.0, -1.0, 0.0],
            },
            PolygonRec {
                start: 4,
                len: 3,
                plane: [0.0, -1.0, 0.0, 0.0],
            },
        ];
        (vertices, indices, polygons, vec![[0, 1], [1, 2]])
    }

    #[test]
    fn fans_polygons_and_keeps_their_normals_and_indices() {
        let (vertices, indices, polygons, edges) = quad_and_triangle();
        let header = GeometryHeader {
            id: 1,
            generation: 1,
            bbox: [0.0; 6],
        };
        let g = GeometryView {
            header: &header,
            vertices: &vertices,
            indices: &indices,
            penalty: &[],
            polygons: &polygons,
            edges: &edges,
        };
        let m = CpuMesh::from_geometry(&g);
        assert_eq!(m.triangles(), 3, "quad → 2 triangles, triangle → 1");
        assert_eq!(m.tri_polygon, vec![0, 0, 1]);
        assert_eq!(m.vertices[6].normal, [0.0, -1.0, 0.0]);
        assert_eq!(m.edge_points.len(), 4);
        // A ray down the z axis through (0.25, 0.75) hits the quad (polygon 0) at distance 2.
        let hit = m.raycast([0.25, 0.75, 2.0], [0.0, 0.0, -1.0]).expect("hit");
        assert!((hit.0 - 2.0).abs() < 1e-12 && hit.1 == 0, "{hit:?}");
        // Through (0.5, -1, 0.25) along +y it hits the triangle's face (polygon 1) at 1.
        let hit = m.raycast([0.2, -1.0, 0.25], [0.0, 1.0, 0.0]).expect("hit");
        assert!((hit.0 - 1.0).abs() < 1e-12 && hit.1 == 1, "{hit:?}");
        // Away from both: no hit; behind the origin does not count.
        assert!(m.raycast([2.0, 2.0, 2.0], [0.0, 0.0, -1.0]).is_none());
        assert!(m.raycast([0.25, 0.75, 2.0], [0.0, 0.0, 1.0]).is_none());
    }
}
