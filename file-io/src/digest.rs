//! The model digest: SHA-256 of a canonical encoding of the model, the same for the same model
//! in any process, on any machine, whatever the ids, the creation order or the version.
//!
//! **What is in it** (per object, little-endian, every float by its IEEE bits with −0 read as
//! +0; the order is `robosim_instance_space::record::canonical_object`'s, the one description
//! of the record layout that the Instance Space's encoder and view share): kind (u32); name (u64 length, UTF-8 bytes); local pose (12 × f64, row-major `[R | t]`);
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
use robosim_instance_space::ObjectData;
use robosim_instance_space::record::{FieldSink, canonical_object};
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

/// Every float by its IEEE bits with −0 read as +0.
impl FieldSink for Enc {
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
}

/// The object's own fields, in the order the Instance Space's record layout describes
/// ([`robosim_instance_space::record::canonical_object`]).
fn object_fields(e: &mut Enc, o: &ObjectData) {
    canonical_object(
        o.kind,
        &o.name,
        &o.pose,
        o.joint,
        &o.appearance,
        o.kinematics.as_ref(),
        o.dynamics.as_ref(),
        o.geometry.as_ref(),
        &o.origin,
        e,
    );
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

#[cfg(test)]
mod tests {
    use super::*;
    use robosim_instance_space::{
        Appearance, DhConvention, GeometryInput, JointKind, Kind, Kinematics, MassProps,
    };

    fn object(id: u64, kind: Kind, kinematics: Option<Kinematics>) -> ObjectData {
        ObjectData {
            id,
            kind,
            parent: 0,
            name: format!("o{id}"),
            pose: [
                0.0, -1.0, 0.0, 0.5, 1.0, 0.0, 0.0, -0.25, 0.0, 0.0, 1.0, 2.0,
            ],
            joint: 0.125,
            appearance: Appearance {
                color: [0.1, 0.2, 0.3, 1.0],
                diffuse: 0.75,
                specular: -0.0,
                shininess: 8.0,
            },
            kinematics,
            dynamics: None,
            geometry: None,
            geom_gen: 7,
            origin: String::new(),
        }
    }

    /// One object of every record kind (no kinematics, a DH joint, a robot, a general joint;
    /// with and without mass properties, geometry and an origin), each model's digest as the
    /// encoding had it before the record layout was described once (instance-space's
    /// `record` module): the digest's bytes may not change.
    fn every_kind() -> Vec<(&'static str, ObjectData)> {
        let joint = Kinematics::Joint {
            index: 2,
            joint: JointKind::Prismatic,
            convention: DhConvention::Modified,
            a: 0.1,
            d: -0.2,
            alpha: 1.5,
            theta: -0.0,
            offset: 0.3,
            qlim: [-1.0, 2.0],
        };
        let robot = Kinematics::Robot {
            convention: DhConvention::Standard,
            ik_family: 3,
            tool: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.103],
        };
        let axis = Kinematics::Axis {
            index: 4,
            parent: 3,
            joint: JointKind::Revolute,
            placement: [
                1.0, 0.0, 0.0, 0.01, 0.0, 0.0, -1.0, 0.02, 0.0, 1.0, 0.0, 0.03,
            ],
            axis: [0.0, 0.6, 0.8],
            offset: -0.5,
            qlim: [f64::NEG_INFINITY, f64::INFINITY],
        };
        let mut heavy = object(5, Kind::Link, Some(joint));
        heavy.dynamics = Some(MassProps {
            mass: 2.5,
            com: [0.0, 0.01, -0.02],
            inertia: [0.1, 0.2, 0.3, 0.001, -0.002, 0.0],
        });
        heavy.geometry = Some(GeometryInput {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            polygons: vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]],
        });
        heavy.origin = r#"{"decl":"x"}"#.into();
        vec![
            ("none", object(1, Kind::Item, None)),
            ("joint", object(2, Kind::Link, Some(joint))),
            ("robot", object(3, Kind::Robot, Some(robot))),
            ("axis", object(4, Kind::Link, Some(axis))),
            ("joint+dynamics+geometry+origin", heavy),
        ]
    }

    #[test]
    fn every_record_kind_keeps_its_digest() {
        let want = [
            (
                "none",
                "bdb959905c6bb041140057b3aa61caca5a414548b2da8ec4be06ce865a40fc63",
            ),
            (
                "joint",
                "b8c00b9cf74511703a185fa1ed279b33441a0ebcb4b637f7ed47b9e99a8f005a",
            ),
            (
                "robot",
                "2bb9eaaf9107f48935396e28855596b83fc4f7e600c310087f69fa6a981de8bd",
            ),
            (
                "axis",
                "c7b4c7bca746c20d165cbc749b919721ddad598fdc6d0bd03b2044bfdc3f923c",
            ),
            (
                "joint+dynamics+geometry+origin",
                "da2e2bab1c5aa0f1bef163be4f628a9d8747f4460a8222db660f08cbe5b7bb15",
            ),
        ];
        let mut got = Vec::new();
        for (name, o) in every_kind() {
            let model = SavedModel {
                version: 1,
                objects: vec![o],
                library: Vec::new(),
            };
            got.push((name, digest(&model).expect("valid").to_string()));
        }
        for ((n, d), (wn, wd)) in got.iter().zip(want) {
            assert_eq!((*n, d.as_str()), (wn, wd), "all: {got:#?}");
        }
    }
}
