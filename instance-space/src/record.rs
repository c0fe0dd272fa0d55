//! One description of how an object's aspects lie flat, shared by the three places that write
//! or read them: the encoder ([`crate::encode`], aspects → [`ObjectRec`] in shared memory), the
//! view ([`ObjectRec::kinematics`], [`ObjectRec::dynamics`], [`ObjectRec::appearance`]: the
//! record → aspects) and the model digest (`robosim_file_io::digest`, the aspects in canonical
//! order through a [`FieldSink`]).
//!
//! * [`KinematicsFields`] — the kinematics aspect as the record's `kin_tag`, `joint_kind`,
//!   `convention`, `index_or_family`, `dh` and `tool` fields: which field of which variant goes
//!   where (a general joint's parent lies in `convention`, its axis in `dh[0..3]`, its
//!   placement in `tool`), both ways, and the variant's canonical field order.
//! * [`canonical_object`] — an object's aspects in the digest's order.
//!
//! The byte layout itself is the `#[repr(C)]` [`ObjectRec`] (`crate::layout`); nothing here
//! changes a byte of it, of a journal or of a digest (`record::tests` and file-io's
//! `digest::tests::every_record_kind_keeps_its_digest` hold them).

use crate::layout::{ObjectRec, flags};
use crate::store::{
    Appearance, DhConvention, FloatingBase, JointKind, Kind, Kinematics, MassProps, Pose,
};
use crate::transaction::GeometryInput;

/// The writer of a canonical (digest) encoding: little-endian integers; floats by their IEEE
/// bits (the sink decides about −0); `bytes` is a u64 length then the bytes.
pub trait FieldSink {
    fn u8(&mut self, v: u8);
    fn u32(&mut self, v: u32);
    fn u64(&mut self, v: u64);
    fn f32(&mut self, v: f32);
    fn f64(&mut self, v: f64);
    fn bytes(&mut self, b: &[u8]);
    fn f64s(&mut self, v: &[f64]) {
        for x in v {
            self.f64(*x);
        }
    }
}

/// The kinematics aspect in the record's fields (all zero, `tag` 0, for none).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KinematicsFields {
    /// 0 (none), [`flags::KIN_JOINT`], [`flags::KIN_ROBOT`] or [`flags::KIN_AXIS`].
    pub tag: u32,
    /// Joint and general joint: [`JointKind`] as u32; robot: its [`FloatingBase`] as u32, 0 for
    /// a fixed base.
    pub joint_kind: u32,
    /// Joint and robot: [`DhConvention`] as u32; general joint: the parent link frame.
    pub convention: u32,
    /// Joint and general joint: index in q; robot: IK family.
    pub index_or_family: u32,
    /// Joint: a, d, alpha, theta, offset, qlo, qhi. General joint: axis x, y, z, 0, offset,
    /// qlo, qhi. Robot: zeros.
    pub dh: [f64; 7],
    /// Robot: tool; general joint: placement (3×4 row-major). Joint: zeros.
    pub tool: Pose,
}

impl KinematicsFields {
    /// The fields of `k` (none: all zero).
    pub fn of(k: Option<&Kinematics>) -> Self {
        let mut f = KinematicsFields::default();
        match k {
            None => {}
            Some(&Kinematics::Joint {
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
                f.tag = flags::KIN_JOINT;
                f.joint_kind = joint as u32;
                f.convention = convention as u32;
                f.index_or_family = index;
                f.dh = [a, d, alpha, theta, offset, qlim[0], qlim[1]];
            }
            Some(&Kinematics::Axis {
                index,
                parent,
                joint,
                placement,
                axis,
                offset,
                qlim,
            }) => {
                f.tag = flags::KIN_AXIS;
                f.joint_kind = joint as u32;
                f.convention = parent;
                f.index_or_family = index;
                f.dh = [axis[0], axis[1], axis[2], 0.0, offset, qlim[0], qlim[1]];
                f.tool = placement;
            }
            Some(&Kinematics::Robot {
                convention,
                ik_family,
                tool,
            }) => {
                f.tag = flags::KIN_ROBOT;
                f.convention = convention as u32;
                f.index_or_family = ik_family;
                f.tool = tool;
            }
            Some(&Kinematics::FloatingRobot {
                convention,
                ik_family,
                tool,
                root,
            }) => {
                f.tag = flags::KIN_ROBOT;
                f.joint_kind = root as u32;
                f.convention = convention as u32;
                f.index_or_family = ik_family;
                f.tool = tool;
            }
            Some(&Kinematics::Mimic {
                index,
                parent,
                joint,
                placement,
                axis,
                qlim,
                leader,
                multiplier,
                offset,
            }) => {
                f.tag = flags::KIN_MIMIC;
                f.joint_kind = joint as u32 | leader.map_or(0, |l| l.saturating_add(1) << 8);
                f.convention = parent;
                f.index_or_family = index;
                f.dh = [
                    axis[0], axis[1], axis[2], multiplier, offset, qlim[0], qlim[1],
                ];
                f.tool = placement;
            }
        }
        f
    }

    /// The fields as a record holds them (`tag` 0 when its `HAS_KINEMATICS` flag is clear).
    pub fn from_rec(rec: &ObjectRec) -> Self {
        KinematicsFields {
            tag: if rec.flags & flags::HAS_KINEMATICS == 0 {
                0
            } else {
                rec.kin_tag
            },
            joint_kind: rec.joint_kind,
            convention: rec.convention,
            index_or_family: rec.index_or_family,
            dh: rec.dh,
            tool: rec.tool,
        }
    }

    /// Writes the fields into `rec`, setting its `HAS_KINEMATICS` flag unless `tag` is 0.
    pub fn write(&self, rec: &mut ObjectRec) {
        if self.tag == 0 {
            return;
        }
        rec.flags |= flags::HAS_KINEMATICS;
        rec.kin_tag = self.tag;
        rec.joint_kind = self.joint_kind;
        rec.convention = self.convention;
        rec.index_or_family = self.index_or_family;
        rec.dh = self.dh;
        rec.tool = self.tool;
    }

    /// The aspect back ([`KinematicsFields::of`]'s inverse). `None` for tag 0 and for tags or
    /// kinds this build does not know (the keeper validated every record it published, so that
    /// only happens across versions).
    pub fn kinematics(&self) -> Option<Kinematics> {
        let joint = || JointKind::from_u32(self.joint_kind);
        match self.tag {
            flags::KIN_AXIS => Some(Kinematics::Axis {
                index: self.index_or_family,
                parent: self.convention,
                joint: joint()?,
                placement: self.tool,
                axis: [self.dh[0], self.dh[1], self.dh[2]],
                offset: self.dh[4],
                qlim: [self.dh[5], self.dh[6]],
            }),
            flags::KIN_JOINT => Some(Kinematics::Joint {
                index: self.index_or_family,
                joint: joint()?,
                convention: DhConvention::from_u32(self.convention)?,
                a: self.dh[0],
                d: self.dh[1],
                alpha: self.dh[2],
                theta: self.dh[3],
                offset: self.dh[4],
                qlim: [self.dh[5], self.dh[6]],
            }),
            flags::KIN_ROBOT if self.joint_kind == 0 => Some(Kinematics::Robot {
                convention: DhConvention::from_u32(self.convention)?,
                ik_family: self.index_or_family,
                tool: self.tool,
            }),
            flags::KIN_ROBOT => Some(Kinematics::FloatingRobot {
                convention: DhConvention::from_u32(self.convention)?,
                ik_family: self.index_or_family,
                tool: self.tool,
                root: FloatingBase::from_u32(self.joint_kind)?,
            }),
            flags::KIN_MIMIC => Some(Kinematics::Mimic {
                index: self.index_or_family,
                parent: self.convention,
                joint: JointKind::from_u32(self.joint_kind & 0xff)?,
                placement: self.tool,
                axis: [self.dh[0], self.dh[1], self.dh[2]],
                qlim: [self.dh[5], self.dh[6]],
                leader: (self.joint_kind >> 8).checked_sub(1),
                multiplier: self.dh[3],
                offset: self.dh[4],
            }),
            _ => None,
        }
    }

    /// The canonical (digest) order: the tag as u8, then for a joint index, kind, convention
    /// and the 7 `dh` values; for a robot convention, IK family and the 12 of `tool` (then, for a
    /// floating robot only, its [`FloatingBase`] as u32: a fixed robot's digest is unchanged); for a
    /// general joint index, parent, kind, placement (12), axis (3), offset, qlo, qhi; for a mimic
    /// joint index, parent, kind (with the leader), placement (12), then the 7 of `dh`.
    pub fn canonical(&self, s: &mut impl FieldSink) {
        // The tags are 0..=4 (the flags constants), so the u8 is lossless.
        s.u8(self.tag as u8);
        match self.tag {
            flags::KIN_JOINT => {
                s.u32(self.index_or_family);
                s.u32(self.joint_kind);
                s.u32(self.convention);
                s.f64s(&self.dh);
            }
            flags::KIN_ROBOT => {
                s.u32(self.convention);
                s.u32(self.index_or_family);
                s.f64s(&self.tool);
                if self.joint_kind != 0 {
                    s.u32(self.joint_kind);
                }
            }
            flags::KIN_AXIS => {
                s.u32(self.index_or_family);
                s.u32(self.convention);
                s.u32(self.joint_kind);
                s.f64s(&self.tool);
                s.f64s(&self.dh[0..3]);
                s.f64s(&self.dh[4..7]);
            }
            flags::KIN_MIMIC => {
                s.u32(self.index_or_family);
                s.u32(self.convention);
                s.u32(self.joint_kind);
                s.f64s(&self.tool);
                s.f64s(&self.dh);
            }
            _ => {}
        }
    }
}

/// Mass properties into a record (setting `HAS_DYNAMICS`), `None` leaving it clear.
pub fn write_dynamics(m: Option<&MassProps>, rec: &mut ObjectRec) {
    if let Some(m) = m {
        rec.flags |= flags::HAS_DYNAMICS;
        rec.mass = m.mass;
        rec.com = m.com;
        rec.inertia = m.inertia;
    }
}

/// Mass properties from a record, if its `HAS_DYNAMICS` flag is set.
pub fn read_dynamics(rec: &ObjectRec) -> Option<MassProps> {
    (rec.flags & flags::HAS_DYNAMICS != 0).then_some(MassProps {
        mass: rec.mass,
        com: rec.com,
        inertia: rec.inertia,
    })
}

/// The record's `surface`: diffuse, specular, shininess, 0.
pub fn surface(a: &Appearance) -> [f32; 4] {
    [a.diffuse, a.specular, a.shininess, 0.0]
}

/// An appearance from a record's `color` and `surface`.
pub fn appearance(color: [f32; 4], surface: [f32; 4]) -> Appearance {
    Appearance {
        color,
        diffuse: surface[0],
        specular: surface[1],
        shininess: surface[2],
    }
}

/// An object's aspects as the model digest reads them, in its canonical order: kind (u32);
/// name; local pose (12 × f64); joint value (f64); appearance (colour 4 × f32, diffuse,
/// specular, shininess f32); kinematics ([`KinematicsFields::canonical`]); dynamics (u8 tag
/// 0/1, then mass, com[3], inertia[6]); geometry (u8 tag 0/1, then the vertex count u64,
/// vertices 3 × f64, the polygon count u64, each polygon's length u64 and u32 indices);
/// origin (bytes).
#[expect(
    clippy::too_many_arguments,
    reason = "one argument per aspect, in the canonical order, so the order is read off the call"
)]
pub fn canonical_object(
    kind: Kind,
    name: &str,
    pose: &Pose,
    joint: f64,
    appearance: &Appearance,
    kinematics: Option<&Kinematics>,
    dynamics: Option<&MassProps>,
    geometry: Option<&GeometryInput>,
    origin: &str,
    s: &mut impl FieldSink,
) {
    s.u32(kind as u32);
    s.bytes(name.as_bytes());
    s.f64s(pose);
    s.f64(joint);
    for c in appearance.color {
        s.f32(c);
    }
    s.f32(appearance.diffuse);
    s.f32(appearance.specular);
    s.f32(appearance.shininess);
    KinematicsFields::of(kinematics).canonical(s);
    match dynamics {
        None => s.u8(0),
        Some(m) => {
            s.u8(1);
            s.f64(m.mass);
            s.f64s(&m.com);
            s.f64s(&m.inertia);
        }
    }
    match geometry {
        None => s.u8(0),
        Some(g) => {
            s.u8(1);
            s.u64(g.vertices.len() as u64);
            for v in &g.vertices {
                s.f64s(v);
            }
            s.u64(g.polygons.len() as u64);
            for p in &g.polygons {
                s.u64(p.len() as u64);
                for i in p {
                    s.u32(*i);
                }
            }
        }
    }
    s.bytes(origin.as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Snapshot;
    use crate::store::Store;
    use crate::transaction::Transaction;

    /// The canonical bytes, as a digest would hash them (−0 as +0).
    #[derive(Default)]
    struct Bytes(Vec<u8>);

    impl FieldSink for Bytes {
        fn u8(&mut self, v: u8) {
            self.0.push(v);
        }
        fn u32(&mut self, v: u32) {
            self.0.extend_from_slice(&v.to_le_bytes());
        }
        fn u64(&mut self, v: u64) {
            self.0.extend_from_slice(&v.to_le_bytes());
        }
        fn f32(&mut self, v: f32) {
            let v = if v == 0.0 { 0.0 } else { v };
            self.0.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        fn f64(&mut self, v: f64) {
            let v = if v == 0.0 { 0.0 } else { v };
            self.0.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        fn bytes(&mut self, b: &[u8]) {
            self.u64(b.len() as u64);
            self.0.extend_from_slice(b);
        }
    }

    fn every_kinematics() -> Vec<Option<Kinematics>> {
        vec![
            None,
            Some(Kinematics::Joint {
                index: 0,
                joint: JointKind::Prismatic,
                convention: DhConvention::Modified,
                a: 0.1,
                d: -0.2,
                alpha: 1.5,
                theta: 0.25,
                offset: 0.3,
                qlim: [-1.0, 2.0],
            }),
            Some(Kinematics::Robot {
                convention: DhConvention::Standard,
                ik_family: 3,
                tool: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.103],
            }),
            Some(Kinematics::FloatingRobot {
                convention: DhConvention::Standard,
                ik_family: 0,
                tool: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.25],
                root: FloatingBase::Planar,
            }),
            Some(Kinematics::Axis {
                index: 0,
                parent: 0,
                joint: JointKind::Revolute,
                placement: [
                    1.0, 0.0, 0.0, 0.01, 0.0, 0.0, -1.0, 0.02, 0.0, 1.0, 0.0, 0.03,
                ],
                axis: [0.0, 0.6, 0.8],
                offset: -0.5,
                qlim: [f64::NEG_INFINITY, f64::INFINITY],
            }),
            Some(Kinematics::Mimic {
                index: 0,
                parent: 0,
                joint: JointKind::Prismatic,
                placement: [
                    1.0, 0.0, 0.0, 0.01, 0.0, 0.0, -1.0, 0.02, 0.0, 1.0, 0.0, 0.03,
                ],
                axis: [0.0, 0.0, 1.0],
                qlim: [0.0, 0.04],
                leader: None,
                multiplier: -1.5,
                offset: 0.02,
            }),
        ]
    }

    /// A mimic joint's leader and relation lie in the record's fields and come back: the
    /// leader's index + 1 above the joint kind's 8 bits (0: none), multiplier and offset in
    /// `dh[3]`, `dh[4]`; an Axis record's fields keep their meaning.
    #[test]
    fn a_mimic_joint_keeps_its_leader_and_relation_in_the_record() {
        for leader in [None, Some(0), Some(41), Some(0xff_fffe)] {
            let k = Kinematics::Mimic {
                index: 42,
                parent: 3,
                joint: JointKind::Revolute,
                placement: crate::IDENTITY,
                axis: [1.0, 0.0, 0.0],
                qlim: [-0.5, 0.5],
                leader,
                multiplier: 2.0,
                offset: -0.125,
            };
            let f = KinematicsFields::of(Some(&k));
            assert_eq!(f.tag, flags::KIN_MIMIC);
            assert_eq!(f.joint_kind & 0xff, JointKind::Revolute as u32);
            assert_eq!(f.joint_kind >> 8, leader.map_or(0, |l| l + 1));
            assert_eq!((f.index_or_family, f.convention), (42, 3));
            assert_eq!(f.dh, [1.0, 0.0, 0.0, 2.0, -0.125, -0.5, 0.5]);
            assert_eq!(f.kinematics(), Some(k), "{leader:?}");
            let (axis, l, m, c) = k.mimic_parts().expect("a mimic joint");
            assert_eq!((l, m, c), (leader, 2.0, -0.125));
            assert!(matches!(axis, Kinematics::Axis { index: 42, offset, .. } if offset == 0.0));
        }
    }

    /// Every record kind (no kinematics, a DH joint, a robot, a general joint; with and without
    /// mass properties) goes through the encoder into an [`ObjectRec`] and back out through the
    /// view unchanged, and the digest's canonical bytes of what the view reads equal those of
    /// what was written.
    #[test]
    fn every_record_kind_round_trips_through_encoder_and_view_and_digests_alike() {
        let mass = MassProps {
            mass: 2.5,
            com: [0.0, 0.01, -0.02],
            inertia: [0.1, 0.2, 0.3, 0.001, -0.002, 0.0],
        };
        let mut n = 0;
        for k in every_kinematics() {
            for m in [None, Some(mass)] {
                let kind = match k {
                    Some(Kinematics::Robot { .. } | Kinematics::FloatingRobot { .. }) => {
                        Kind::Robot
                    }
                    Some(_) => Kind::Link,
                    None => Kind::Item,
                };
                let mut model = Store::new();
                let mut tx = Transaction::new();
                let parent = (kind == Kind::Link).then(|| tx.create(Kind::Robot, "r", None));
                let o = tx.create(kind, "o", parent);
                tx.set_pose(
                    o,
                    [
                        0.0, -1.0, 0.0, 0.5, 1.0, 0.0, 0.0, -0.25, 0.0, 0.0, 1.0, 2.0,
                    ],
                );
                if let Some(k) = k {
                    tx.set_kinematics(o, Some(k));
                }
                tx.set_dynamics(o, m);
                model
                    .apply(&tx)
                    .unwrap_or_else(|e| panic!("{k:?} {m:?}: {e}"));
                let object = model.objects().find(|x| x.name == "o").expect("o");
                // The encoder, then the record read back by the view.
                let mut names = Vec::new();
                let rec = crate::encode::object_rec(object, &mut names);
                assert_eq!(rec.kinematics(), object.kinematics, "{k:?}");
                assert_eq!(rec.dynamics(), object.dynamics, "{m:?}");
                assert_eq!(rec.appearance(), object.appearance);
                assert_eq!(
                    KinematicsFields::from_rec(&rec),
                    KinematicsFields::of(k.as_ref())
                );
                // And through a whole snapshot (the encoder's segments, the reader's records).
                let snap = Snapshot::from_store(&model);
                let i = snap.find("o").expect("o in the snapshot");
                let read = snap.rec(i);
                assert_eq!(read.kinematics(), object.kinematics);
                assert_eq!(read.dynamics(), object.dynamics);
                let digest_of = |kin: Option<Kinematics>, dynamics: Option<MassProps>, a| {
                    let mut b = Bytes::default();
                    canonical_object(
                        kind,
                        "o",
                        &object.pose,
                        object.joint,
                        &a,
                        kin.as_ref(),
                        dynamics.as_ref(),
                        None,
                        "",
                        &mut b,
                    );
                    b.0
                };
                assert_eq!(
                    digest_of(read.kinematics(), read.dynamics(), read.appearance()),
                    digest_of(object.kinematics, object.dynamics, object.appearance),
                    "{k:?} {m:?}"
                );
                n += 1;
            }
        }
        assert_eq!(n, 12);
    }

    /// The canonical order of each kind, byte for byte (what the model digest hashed before the
    /// layout was described here): a field moved or dropped changes these.
    #[test]
    fn the_canonical_kinematics_bytes_are_the_digests() {
        let ks = every_kinematics();
        let bytes = |k: &Option<Kinematics>| {
            let mut b = Bytes::default();
            KinematicsFields::of(k.as_ref()).canonical(&mut b);
            b.0
        };
        assert_eq!(bytes(&ks[0]), vec![0]);
        let joint = bytes(&ks[1]);
        assert_eq!(joint.len(), 1 + 3 * 4 + 7 * 8);
        assert_eq!(&joint[..13], &[1, 0, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(&joint[13..21], &0.1f64.to_le_bytes());
        let robot = bytes(&ks[2]);
        assert_eq!(robot.len(), 1 + 2 * 4 + 12 * 8);
        assert_eq!(&robot[..9], &[2, 0, 0, 0, 0, 3, 0, 0, 0]);
        assert_eq!(&robot[robot.len() - 8..], &0.103f64.to_le_bytes());
        // a floating robot: a fixed robot's bytes, then its root (planar = 2)
        let floating = bytes(&ks[3]);
        assert_eq!(floating.len(), 1 + 3 * 4 + 12 * 8);
        assert_eq!(&floating[floating.len() - 4..], &[2, 0, 0, 0]);
        let axis = bytes(&ks[4]);
        assert_eq!(axis.len(), 1 + 3 * 4 + (12 + 3 + 3) * 8);
        assert_eq!(&axis[..13], &[3, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0]);
        // placement first, then the axis, then offset and the limits
        assert_eq!(&axis[13 + 3 * 8..13 + 4 * 8], &0.01f64.to_le_bytes());
        assert_eq!(&axis[13 + 13 * 8..13 + 14 * 8], &0.6f64.to_le_bytes());
        assert_eq!(&axis[13 + 15 * 8..13 + 16 * 8], &(-0.5f64).to_le_bytes());
        // a mimic joint: tag 4, index, parent, kind (prismatic, no leader), placement, the 7
        // of dh (axis, multiplier, offset, limits)
        let mimic = bytes(&ks[5]);
        assert_eq!(mimic.len(), 1 + 3 * 4 + (12 + 7) * 8);
        assert_eq!(&mimic[..13], &[4, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(&mimic[13 + 15 * 8..13 + 16 * 8], &(-1.5f64).to_le_bytes());
    }
}
