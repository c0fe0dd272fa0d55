//! glTF 2.0 binary (`.glb`) export: the model's part-whole hierarchy as nodes (one node per
//! Instance Space object, its local pose as the node matrix), each body's polygons as one mesh
//! (fan triangles, flat normals: vertices are not shared between polygons), and each distinct
//! appearance as a material (`pbrMetallicRoughness.baseColorFactor` = the RGBA colour,
//! metallic 0, roughness from the shininess; alpha < 1 blends).
//!
//! glTF is Y-up, the Instance Space Z-up: each root node's matrix is preceded by a −90° turn
//! about x, so the model stands upright in Blender and three.js. Units: metres, as glTF's.
//! Positions are f32 (glTF's only float).

use crate::model::SavedModel;
use crate::world::triangles;
use robosim_instance_space::Appearance;
use serde_json::{Value, json};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// Z-up → Y-up: (x, y, z) ↦ (x, z, −y), 3×4 row-major.
const Z_UP_TO_Y_UP: [f64; 12] = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0];

/// What the export wrote.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GltfStats {
    pub nodes: usize,
    pub meshes: usize,
    pub triangles: usize,
    pub materials: usize,
}

struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Appends `bytes` as a buffer view (4-byte aligned) and returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let offset = self.data.len();
        self.data.extend_from_slice(bytes);
        self.views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        self.views.len() - 1
    }
    fn vec3(&mut self, v: &[[f32; 3]], with_bounds: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        let mut acc =
            json!({"bufferView": view, "componentType": FLOAT, "count": v.len(), "type": "VEC3"});
        if with_bounds {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for p in v {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }
    fn indices(&mut self, idx: &[u32]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        self.accessors.push(json!({"bufferView": view, "componentType": UNSIGNED_INT, "count": idx.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }
}

fn matrix(p: &[f64; 12]) -> Vec<f64> {
    // glTF matrices are column-major 4×4.
    vec![
        p[0], p[4], p[8], 0.0, p[1], p[5], p[9], 0.0, p[2], p[6], p[10], 0.0, p[3], p[7], p[11],
        1.0,
    ]
}

fn material(a: &Appearance) -> Value {
    let roughness = (1.0 - (a.shininess / 128.0).clamp(0.0, 1.0)).clamp(0.05, 1.0);
    let mut m = json!({
        "pbrMetallicRoughness": {
            "baseColorFactor": a.color,
            "metallicFactor": 0.0,
            "roughnessFactor": roughness,
        },
        "doubleSided": true,
    });
    if a.color[3] < 1.0 {
        m["alphaMode"] = json!("BLEND");
    }
    m
}

/// The `.glb` bytes of `model`. `model` must be valid ([`SavedModel::plan`]); an invalid one
/// gives `None`.
pub fn to_glb(model: &SavedModel) -> Option<(Vec<u8>, GltfStats)> {
    let order = model.plan().ok()?;
    let mut node_of = vec![0usize; model.objects.len()];
    for (n, &i) in order.iter().enumerate() {
        node_of[i] = n;
    }
    let index: std::collections::HashMap<u64, usize> = model
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| (o.id, i))
        .collect();
    let mut bin = Bin {
        data: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let mut nodes: Vec<Value> = Vec::with_capacity(order.len());
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); order.len()];
    let mut roots = Vec::new();
    let mut meshes = Vec::new();
    let mut materials: Vec<Value> = Vec::new();
    let mut material_keys: Vec<[u32; 7]> = Vec::new();
    let mut stats = GltfStats::default();
    for &i in &order {
        let o = &model.objects[i];
        let local = match index.get(&o.parent) {
            Some(&p) if o.parent != 0 => {
                children[node_of[p]].push(node_of[i]);
                o.pose
            }
            _ => {
                roots.push(node_of[i]);
                crate::world::compose(&Z_UP_TO_Y_UP, &o.pose)
            }
        };
        let mut node = json!({"name": o.name, "matrix": matrix(&local)});
        if let Some(g) = &o.geometry {
            let mut pos = Vec::new();
            let mut nrm = Vec::new();
            let mut idx = Vec::new();
            let v = |k: u32| g.vertices.get(k as usize).copied().unwrap_or([0.0; 3]);
            for poly in &g.polygons {
                // One flat normal per polygon (Newell's, robust for any convex polygon).
                let mut n = [0.0f64; 3];
                for k in 0..poly.len() {
                    let (a, b) = (v(poly[k]), v(poly[(k + 1) % poly.len()]));
                    n[0] += (a[1] - b[1]) * (a[2] + b[2]);
                    n[1] += (a[2] - b[2]) * (a[0] + b[0]);
                    n[2] += (a[0] - b[0]) * (a[1] + b[1]);
                }
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
                    .sqrt()
                    .max(f64::MIN_POSITIVE);
                let n = [(n[0] / l) as f32, (n[1] / l) as f32, (n[2] / l) as f32];
                let base = pos.len() as u32;
                for &k in poly {
                    let p = v(k);
                    pos.push([p[0] as f32, p[1] as f32, p[2] as f32]);
                    nrm.push(n);
                }
                let local: Vec<u32> = (0..poly.len() as u32).map(|k| base + k).collect();
                for t in robosim_geometry::triangulate::fan(&local) {
                    idx.extend_from_slice(&t);
                }
            }
            let a = &o.appearance;
            let key = [
                a.color[0].to_bits(),
                a.color[1].to_bits(),
                a.color[2].to_bits(),
                a.color[3].to_bits(),
                a.diffuse.to_bits(),
                a.specular.to_bits(),
                a.shininess.to_bits(),
            ];
            let mat = match material_keys.iter().position(|k| *k == key) {
                Some(m) => m,
                None => {
                    material_keys.push(key);
                    materials.push(material(a));
                    materials.len() - 1
                }
            };
            let p = bin.vec3(&pos, true);
            let n = bin.vec3(&nrm, false);
            let ix = bin.indices(&idx);
            stats.triangles += idx.len() / 3;
            debug_assert_eq!(idx.len() / 3, triangles(o).len());
            meshes.push(json!({
                "name": o.name,
                "primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": ix, "material": mat, "mode": 4}],
            }));
            node["mesh"] = json!(meshes.len() - 1);
        }
        nodes.push(node);
    }
    for (n, kids) in children.into_iter().enumerate() {
        if !kids.is_empty() {
            nodes[n]["children"] = json!(kids);
        }
    }
    stats.nodes = nodes.len();
    stats.meshes = meshes.len();
    stats.materials = materials.len();
    while !bin.data.len().is_multiple_of(4) {
        bin.data.push(0);
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("robosim ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
    });
    if !meshes.is_empty() {
        doc["meshes"] = json!(meshes);
        doc["materials"] = json!(materials);
        doc["accessors"] = json!(bin.accessors);
        doc["bufferViews"] = json!(bin.views);
        doc["buffers"] = json!([{"byteLength": bin.data.len()}]);
    }
    // A Value of strings and numbers always serialises.
    let mut text = serde_json::to_vec(&doc).unwrap_or_default();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let has_bin = !bin.data.is_empty();
    let total = 12 + 8 + text.len() + if has_bin { 8 + bin.data.len() } else { 0 };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    if has_bin {
        out.extend_from_slice(&(bin.data.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin.data);
    }
    Some((out, stats))
}
