//! The model digest: SHA-256 of a canonical encoding of the model, the same for the same model
//! in any process, on any machine, whatever the ids, the creation order or the version.
//!
//! **What is in it** (per object, little-endian, every float by its IEEE bits with −0 read as
//! +0): kind (u32); name (u64 length, UTF-8 bytes); local pose (12 × f64, row-major `[R | t]`);
//! joint value (f64); appearance (colour 4 × f32, diffuse, specular, shininess f32);
//! kinematics (tag u8: 0 none, 1 joint — index u32, joint type u32, convention u32, a, d,
//! alpha, theta, offset, qlim[2] f64; 2 robot — convention u32, IK family u32, tool 12 × f64;
//! 3 general joint — index u32, parent u32, joint type u32, placement 12 × f64, axis 3 × f64,
//! offset, qlim[2] f64);
//! dynamics (tag u8, then mass, com[3], inertia[6] f64); geometry (tag u8, then vertex count u64,
//! vertices 3 × f64 each, polygon count u64, each polygon's length u64 and u32 indices, in the
//! stored order); origin (u64 length, bytes); then the number of children (u64) and their
//! digests, sorted. An object's digest is SHA-256 of that; the model's is SHA-256 of
//! `"robosim-model-digest-1"`, the number of roots (u64) and the root digests, sorted.
//!
//! **What is not:** object ids and parent ids (a load creates new ones; the tree is what counts),
//! the version, geometry generations, the session's selection (the display's pick: where a
//! person is pointing, not what the model is — a model file does not carry it either), and
//! the Library Space (a model's instances name their
//! declarations in `origin`, which is in).
//!
//! Sorting the children's digests makes the digest independent of sibling order; two models
//! that differ only in which of two siblings was created first have the same digest.

use crate::model::SavedModel;
use robosim_instance_space::{Kinematics, ObjectData};
use sha2::{Digest, Sha256};

/// A 32-byte digest, shown as 64 lowercase hex digits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ModelDigest(pub [u8; 32]);

impl std::fmt::Display for ModelDigest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

const DOMAIN: &[u8] = b"robosim-model-digest-1";

struct Enc(Sha256);

impl Enc {
    fn u8(&mut self, v: u8) {
        self.0.update([v]);
    }
    fn u32(&mut self, v: u32) {
        self.0.update(v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.update(v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        let v = if v == 0.0 { 0.0 } else { v };
        self.0.update(v.to_bits().to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        let v = if v == 0.0 { 0.0 } else { v };
        self.0.update(v.to_bits().to_le_bytes());
    }
    fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.update(b);
    }
    fn f64s(&mut self, v: &[f64]) {
        for x in v {
            self.f64(*x);
        }
    }
}

fn object_fields(e: &mut Enc, o: &ObjectData) {
    e.u32(o.kind as u32);
    e.bytes(o.name.as_bytes());
    e.f64s(&o.pose);
    e.f64(o.joint);
    let a = &o.appearance;
    for c in a.color {
        e.f32(c);
    }
    e.f32(a.diffuse);
    e.f32(a.specular);
    e.f32(a.shininess);
    match o.kinematics {
        None => e.u8(0),
        Some(Kinematics::Joint {
            index,
            joint,
            convention,
            a,
            d,
            alpha,
            theta,
            offset,
            qlim,
        }) => {
            e.u8(1);
            e.u32(index);
            e.u32(joint as u32);
            e.u32(convention as u32);
            e.f64s(&[a, d, alpha, theta, offset, qlim[0], qlim[1]]);
        }
        Some(Kinematics::Robot {
            convention,
            ik_family,
            tool,
        }) => {
            e.u8(2);
            e.u32(convention as u32);
            e.u32(ik_family);
            e.f64s(&tool);
        }
        Some(Kinematics::Axis {
            index,
            parent,
            joint,
            placement,
            axis,
            offset,
            qlim,
        }) => {
            e.u8(3);
            e.u32(index);
            e.u32(parent);
            e.u32(joint as u32);
            e.f64s(&placement);
            e.f64s(&axis);
            e.f64s(&[offset, qlim[0], qlim[1]]);
        }
    }
    match o.dynamics {
        None => e.u8(0),
        Some(m) => {
            e.u8(1);
            e.f64(m.mass);
            e.f64s(&m.com);
            e.f64s(&m.inertia);
        }
    }
    match &o.geometry {
        None => e.u8(0),
        Some(g) => {
            e.u8(1);
            e.u64(g.vertices.len() as u64);
            for v in &g.vertices {
                e.f64s(v);
            }
            e.u64(g.polygons.len() as u64);
            for p in &g.polygons {
                e.u64(p.len() as u64);
                for i in p {
                    e.u32(*i);
                }
            }
        }
    }
    e.bytes(o.origin.as_bytes());
}

/// The digest of `model`'s objects. `None` when its structure is invalid
/// ([`SavedModel::plan`] says why).
pub fn digest(model: &SavedModel) -> Option<ModelDigest> {
    let order = model.plan().ok()?;
    let index: std::collections::HashMap<u64, usize> = model
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| (o.id, i))
        .collect();
    let mut kids: Vec<Vec<[u8; 32]>> = vec![Vec::new(); model.objects.len()];
    let mut roots = Vec::new();
    // Parents come before children in `order`: walking it backwards finishes every child
    // before its parent.
    for &i in order.iter().rev() {
        let o = &model.objects[i];
        let mut e = Enc(Sha256::new());
        object_fields(&mut e, o);
        let mut children = std::mem::take(&mut kids[i]);
        children.sort_unstable();
        e.u64(children.len() as u64);
        for c in &children {
            e.0.update(c);
        }
        let h: [u8; 32] = e.0.finalize().into();
        match index.get(&o.parent) {
            Some(&p) if o.parent != 0 => kids[p].push(h),
            _ => roots.push(h),
        }
    }
    roots.sort_unstable();
    let mut e = Enc(Sha256::new());
    e.0.update(DOMAIN);
    e.u64(roots.len() as u64);
    for r in &roots {
        e.0.update(r);
    }
    Some(ModelDigest(e.0.finalize().into()))
}
