//! Typed views of a snapshot's flat records: the one place that turns the raw tags of
//! [`ObjectRec`] (`kin_tag`, `joint_kind`, `convention`, `flags`) back into the model's enums
//! (which field holds what is described once, in [`crate::record`]).
//! Everyone else — the scene compiler, the file interface, the display, the session ops — reads
//! robots, joints and mass properties through these, never through bare numbers.
//!
//! Entry points: [`ObjectRec::kinematics`], [`ObjectRec::dynamics`], [`ObjectRec::appearance`],
//! [`Snapshot::robots`], [`Snapshot::robot`], [`Snapshot::children`], [`Snapshot::path`],
//! [`Snapshot::structure_version`].

use crate::layout::{ObjectRec, flags};
use crate::reader::Snapshot;
use crate::record::{self, KinematicsFields};
use crate::store::{
    Appearance, DhConvention, FloatingBase, Id, JointKind, Kind, Kinematics, MassProps, Pose,
};

impl FloatingBase {
    /// The root a robot record's `joint_kind` field encodes (`None`: 0, a fixed base, or a
    /// value this build does not know).
    pub fn from_u32(v: u32) -> Option<FloatingBase> {
        [FloatingBase::FreeFlyer, FloatingBase::Planar]
            .into_iter()
            .find(|k| *k as u32 == v)
    }
}

impl JointKind {
    /// The kind a record's `joint_kind` field encodes (`None`: not a known kind).
    pub fn from_u32(v: u32) -> Option<JointKind> {
        [JointKind::Fixed, JointKind::Revolute, JointKind::Prismatic]
            .into_iter()
            .find(|k| *k as u32 == v)
    }
}

impl DhConvention {
    /// The convention a record's `convention` field encodes (`None`: not a known one).
    pub fn from_u32(v: u32) -> Option<DhConvention> {
        [DhConvention::Standard, DhConvention::Modified]
            .into_iter()
            .find(|c| *c as u32 == v)
    }
}

impl ObjectRec {
    /// The object's kind (`None`: a tag this build does not know).
    pub fn kind(&self) -> Option<Kind> {
        Kind::from_u32(self.kind)
    }

    /// The kinematics aspect as written by the transaction that set it, or `None` when the
    /// object has none. A record whose tags this build does not know reads as `None` too (the
    /// keeper validated every record it published, so that only happens across versions).
    pub fn kinematics(&self) -> Option<Kinematics> {
        KinematicsFields::from_rec(self).kinematics()
    }

    /// Mass, centre of mass and inertia (about the centre of mass, link frame), if set.
    pub fn dynamics(&self) -> Option<MassProps> {
        record::read_dynamics(self)
    }

    /// Colour and surface.
    pub fn appearance(&self) -> Appearance {
        record::appearance(self.color, self.surface)
    }

    pub fn has_geometry(&self) -> bool {
        self.flags & flags::HAS_GEOMETRY != 0
    }
}

/// One joint of a robot as the Instance Space holds it: the link object that carries it and
/// its DH row (m, rad) in the robot's declared convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointView {
    /// Index of the link object in the snapshot.
    pub index: usize,
    pub id: Id,
    pub kind: JointKind,
    pub a: f64,
    pub d: f64,
    pub alpha: f64,
    pub theta: f64,
    pub offset: f64,
    /// [lo, hi] (rad or m).
    pub qlim: [f64; 2],
    /// The committed joint value (rad or m).
    pub q: f64,
    /// The link's mass properties, if set.
    pub mass: Option<MassProps>,
    /// A general joint's placement, axis and parent link frame (`Kinematics::Axis`); `None`
    /// for a DH row (`a`, `d`, `alpha`, `theta` then hold it, and are 0 here otherwise).
    pub origin: Option<JointOrigin>,
    /// The relation of a joint that follows another (`Kinematics::Mimic`, a general joint);
    /// `None` for an independent joint.
    pub mimic: Option<JointMimic>,
}

/// A mimic joint's relation as the Instance Space holds it: `q = multiplier · q[leader] +
/// offset` (`Kinematics::Mimic`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMimic {
    /// The index in q of the joint it follows (`None`: not a joint of the robot; fixed at
    /// `offset`).
    pub leader: Option<u32>,
    pub multiplier: f64,
    pub offset: f64,
}

/// A general joint's geometry as the Instance Space holds it (`Kinematics::Axis`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointOrigin {
    /// The link frame the joint hangs from (0: the robot's base; k: the link of joint k − 1).
    pub parent: u32,
    /// Parent link frame → joint frame, 3×4 row-major (m).
    pub placement: Pose,
    /// Unit axis in the joint frame.
    pub axis: [f64; 3],
}

/// A robot of a snapshot: the robot object and its joints in chain order.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotView<'a> {
    /// Index of the robot object in the snapshot.
    pub index: usize,
    pub id: Id,
    pub name: &'a str,
    pub convention: DhConvention,
    /// The analytic IK family code (0: numeric only).
    pub ik_family: u32,
    /// Tool transform (3×4 row-major), relative to the last link frame.
    pub tool: Pose,
    /// A floating robot's root joint (`Kinematics::FloatingRobot`); `None` for a fixed base.
    pub root: Option<FloatingBase>,
    /// The robot object's mass properties: a floating robot's base link inertial.
    pub base_mass: Option<MassProps>,
    /// Links that carry a joint record, sorted by their index in the chain.
    pub joints: Vec<JointView>,
}

impl Snapshot {
    /// The structure version: the version at which the objects (structure, geometry
    /// references, kinematics, dynamics, appearance) last changed. Equal for two snapshots exactly when only poses and
    /// joint values differ between them — the key of every compiled-model cache.
    pub fn structure_version(&self) -> u64 {
        self.objects_header().version
    }

    /// Indices of the children of object `id`, in id order.
    pub fn children(&self, id: Id) -> impl Iterator<Item = usize> + '_ {
        self.objects()
            .iter()
            .enumerate()
            .filter(move |(_, o)| o.parent == id && o.id != id)
            .map(|(k, _)| k)
    }

    /// The object's path from its top object, `scene/robot/link`.
    pub fn path(&self, i: usize) -> String {
        let mut path = self.name(i).to_owned();
        let mut parent = self.objects()[i].parent;
        let mut guard = self.len();
        while let Some(k) = (parent != 0 && guard > 0)
            .then(|| self.index_of(parent))
            .flatten()
        {
            path = format!("{}/{path}", self.name(k));
            parent = self.objects()[k].parent;
            guard -= 1;
        }
        path
    }

    /// The robot at object index `i`, or `None` if `i` is not a robot.
    pub fn robot_at(&self, i: usize) -> Option<RobotView<'_>> {
        let r = self.objects().get(i)?;
        if r.kind() != Some(Kind::Robot) {
            return None;
        }
        let kinematics = r.kinematics();
        let (convention, ik_family, tool) = kinematics
            .as_ref()
            .and_then(Kinematics::robot_fields)
            .unwrap_or((DhConvention::Standard, 0, crate::IDENTITY));
        let root = match kinematics {
            Some(Kinematics::FloatingRobot { root, .. }) => Some(root),
            _ => None,
        };
        let mut joints: Vec<(u32, JointView)> = self
            .children(r.id)
            .filter_map(|k| {
                let o = &self.objects()[k];
                if o.kind() != Some(Kind::Link) {
                    return None;
                }
                let kinematics = o.kinematics()?;
                let (kinematics, mimic) = match kinematics.mimic_parts() {
                    Some((axis, leader, multiplier, offset)) => (
                        axis,
                        Some(JointMimic {
                            leader,
                            multiplier,
                            offset,
                        }),
                    ),
                    None => (kinematics, None),
                };
                match kinematics {
                    Kinematics::Joint {
                        index,
                        joint,
                        a,
                        d,
                        alpha,
                        theta,
                        offset,
                        qlim,
                        ..
                    } => Some((
                        index,
                        JointView {
                            index: k,
                            id: o.id,
                            kind: joint,
                            a,
                            d,
                            alpha,
                            theta,
                            offset,
                            qlim,
                            q: self.pose(k).joint,
                            mass: o.dynamics(),
                            origin: None,
                            mimic,
                        },
                    )),
                    Kinematics::Axis {
                        index,
                        parent,
                        joint,
                        placement,
                        axis,
                        offset,
                        qlim,
                    } => Some((
                        index,
                        JointView {
                            index: k,
                            id: o.id,
                            kind: joint,
                            a: 0.0,
                            d: 0.0,
                            alpha: 0.0,
                            theta: 0.0,
                            offset,
                            qlim,
                            q: self.pose(k).joint,
                            mass: o.dynamics(),
                            origin: Some(JointOrigin {
                                parent,
                                placement,
                                axis,
                            }),
                            mimic,
                        },
                    )),
                    Kinematics::Robot { .. }
                    | Kinematics::FloatingRobot { .. }
                    | Kinematics::Mimic { .. } => None,
                }
            })
            .collect();
        joints.sort_by_key(|(index, j)| (*index, j.id));
        Some(RobotView {
            index: i,
            id: r.id,
            name: self.name(i),
            convention,
            ik_family,
            tool,
            root,
            base_mass: r.dynamics(),
            joints: joints.into_iter().map(|(_, j)| j).collect(),
        })
    }

    /// Every robot of the snapshot, in id order.
    pub fn robots(&self) -> Vec<RobotView<'_>> {
        (0..self.len()).filter_map(|i| self.robot_at(i)).collect()
    }

    /// The robot called `name`.
    pub fn robot(&self, name: &str) -> Option<RobotView<'_>> {
        (0..self.len())
            .filter(|&i| self.name(i) == name)
            .find_map(|i| self.robot_at(i))
    }
}

#[cfg(test)]
mod tests {
    use crate::{
        DhConvention, JointKind, Kind, Kinematics, MassProps, Snapshot, Store, Transaction,
    };

    /// Every kinematics variant written by a transaction reads back equal through the typed
    /// view (the encoder and this decoder are each other's inverse).
    #[test]
    fn kinematics_round_trip_through_the_records() {
        let mut tx = Transaction::new();
        let robot = tx.create(Kind::Robot, "r", None);
        let tool = [1.0, 0.0, 0.0, 0.1, 0.0, 1.0, 0.0, 0.2, 0.0, 0.0, 1.0, 0.3];
        let rk = Kinematics::Robot {
            convention: DhConvention::Modified,
            ik_family: 2,
            tool,
        };
        tx.set_kinematics(robot, Some(rk));
        let mut joints = Vec::new();
        for (j, kind) in [JointKind::Prismatic, JointKind::Revolute, JointKind::Fixed]
            .into_iter()
            .enumerate()
        {
            let l = tx.create(Kind::Link, &format!("l{j}"), Some(robot));
            let k = Kinematics::Joint {
                // Written out of order: the view sorts by chain index.
                index: 2 - j as u32,
                joint: kind,
                convention: DhConvention::Modified,
                a: 0.1 * j as f64,
                d: 0.2,
                alpha: -0.3,
                theta: 0.4,
                offset: 0.5,
                qlim: [-1.0, 1.5],
            };
            tx.set_kinematics(l, Some(k));
            tx.set_dynamics(
                l,
                Some(MassProps {
                    mass: 1.0 + j as f64,
                    com: [0.0, 0.1, 0.2],
                    inertia: [2.0, 3.0, 4.0, 0.1, 0.2, 0.3],
                }),
            );
            tx.set_joint(l, 0.25 * j as f64);
            joints.push(k);
        }
        let mut m = Store::default();
        m.apply(&tx).expect("valid");
        let snap = Snapshot::from_store(&m);
        let robots = snap.robots();
        assert_eq!(robots.len(), 1);
        let r = &robots[0];
        assert_eq!(r.name, "r");
        assert_eq!(r.convention, DhConvention::Modified);
        assert_eq!(r.ik_family, 2);
        assert_eq!(r.tool, tool);
        assert_eq!(snap.rec(r.index).kinematics(), Some(rk));
        let kinds: Vec<JointKind> = r.joints.iter().map(|j| j.kind).collect();
        assert_eq!(
            kinds,
            [JointKind::Fixed, JointKind::Revolute, JointKind::Prismatic]
        );
        for j in &r.joints {
            let rec = snap.rec(j.index);
            assert!(joints.contains(&rec.kinematics().expect("a joint")));
            assert_eq!(rec.dynamics().map(|m| m.com), Some([0.0, 0.1, 0.2]));
        }
        assert_eq!(r.joints[0].q, 0.5);
        assert_eq!(snap.path(r.joints[0].index), "r/l2");
        assert_eq!(snap.robot("r").map(|v| v.id), Some(r.id));
        assert!(snap.robot("l0").is_none());
    }

    /// Overridden local poses move the object and what hangs from it; nothing else changes,
    /// and the original snapshot is untouched.
    #[test]
    fn with_poses_overrides_local_poses_only() {
        use crate::layout::PoseRec;
        let mut tx = Transaction::new();
        let a = tx.create(Kind::Item, "a", None);
        let b = tx.create(Kind::Solid, "b", Some(a));
        let c = tx.create(Kind::Item, "c", None);
        let mut p = crate::IDENTITY;
        p[3] = 1.0;
        tx.set_pose(b, p);
        tx.set_pose(c, p);
        let mut m = Store::default();
        m.apply(&tx).expect("valid");
        let snap = Snapshot::from_store(&m);
        let (ia, ib, ic) = (
            snap.find("a").expect("a"),
            snap.find("b").expect("b"),
            snap.find("c").expect("c"),
        );
        let mut moved = crate::IDENTITY;
        moved[7] = 2.0;
        let o = snap.with_poses(&[
            PoseRec {
                id: snap.rec(ia).id,
                pose: moved,
                joint: 0.5,
            },
            PoseRec {
                id: 999_999,
                pose: moved,
                joint: 0.0,
            },
        ]);
        assert_eq!(o.world_pose(ib)[3], 1.0);
        assert_eq!(o.world_pose(ib)[7], 2.0);
        assert_eq!(o.poses()[ia].joint, 0.5);
        assert_eq!(o.world_pose(ic), snap.world_pose(ic));
        assert_eq!(snap.world_pose(ib)[7], 0.0);
        assert_eq!(
            (o.version(), o.structure_version()),
            (snap.version(), snap.structure_version())
        );
    }

    /// A snapshot advanced by pose-only changes equals the model's snapshot after them, and
    /// shares every pose chunk they did not touch with the one it came from.
    #[test]
    fn advanced_snapshot_equals_a_rebuild_and_shares_untouched_chunks() {
        use crate::layout::{POSE_CHUNK, PoseRec};
        let mut tx = Transaction::new();
        let n = 2 * POSE_CHUNK + 30;
        for k in 0..n {
            tx.create(Kind::Solid, &format!("s{k}"), None);
        }
        let mut m = Store::default();
        m.apply(&tx).expect("valid");
        let before = Snapshot::from_store(&m);
        let i = POSE_CHUNK + 7;
        let id = before.objects()[i].id;
        let mut p = crate::IDENTITY;
        p[3] = 4.0;
        let mut tx = Transaction::new();
        tx.set_pose(id, p);
        let applied = m.apply(&tx).expect("valid");
        let after = before.advanced(
            applied.version,
            &[PoseRec {
                id,
                pose: p,
                joint: 0.0,
            }],
        );
        let rebuilt = Snapshot::from_store(&m);
        assert_eq!(after.version(), rebuilt.version());
        assert_eq!(after.poses(), rebuilt.poses());
        assert_eq!(after.pose(i).pose[3], 4.0);
        assert_eq!(before.pose(i).pose[3], 0.0, "the old snapshot is untouched");
        assert!(std::ptr::eq(before.pose(0), after.pose(0)));
        assert!(std::ptr::eq(before.pose(n - 1), after.pose(n - 1)));
        assert!(!std::ptr::eq(before.pose(i), after.pose(i)));
    }

    /// A general joint (`Kinematics::Axis`) reads back equal through the records, the view
    /// carries its placement, axis and parent, and a visual is an object like a solid.
    #[test]
    fn general_joints_round_trip_through_the_records() {
        let mut tx = Transaction::new();
        let robot = tx.create(Kind::Robot, "tree", None);
        let c = std::f64::consts::FRAC_1_SQRT_2;
        let placement = [c, -c, 0.0, 0.1, c, c, 0.0, -0.2, 0.0, 0.0, 1.0, 0.333];
        let mut written = Vec::new();
        // Joint 0 on the base, joint 1 on joint 0's link, joint 2 on the base again: a tree.
        for (j, (parent, kind)) in [
            (0, JointKind::Revolute),
            (1, JointKind::Prismatic),
            (0, JointKind::Revolute),
        ]
        .into_iter()
        .enumerate()
        {
            let l = tx.create(Kind::Link, &format!("l{j}"), Some(robot));
            let k = Kinematics::Axis {
                index: j as u32,
                parent,
                joint: kind,
                placement,
                axis: [0.0, 0.6, -0.8],
                offset: 0.25 * j as f64,
                qlim: [f64::NEG_INFINITY, 1.0 + j as f64],
            };
            tx.set_kinematics(l, Some(k));
            let v = tx.create(Kind::Visual, &format!("v{j}"), Some(l));
            tx.set_geometry(
                v,
                Some(crate::GeometryInput {
                    vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                    polygons: vec![vec![0, 1, 2]],
                }),
            );
            written.push(k);
        }
        let mut m = Store::default();
        m.apply(&tx).expect("valid");
        let snap = Snapshot::from_store(&m);
        let r = snap.robot("tree").expect("robot");
        assert_eq!(r.joints.len(), 3);
        for (j, (view, k)) in r.joints.iter().zip(&written).enumerate() {
            assert_eq!(snap.rec(view.index).kinematics(), Some(*k), "joint {j}");
            let o = view.origin.expect("a general joint has an origin");
            assert_eq!(o.placement, placement);
            assert_eq!(o.axis, [0.0, 0.6, -0.8]);
            assert_eq!(o.parent, [0, 1, 0][j]);
            assert_eq!(view.offset, 0.25 * j as f64);
        }
        let v = snap.find("v1").expect("visual");
        assert_eq!(snap.object(v).kind(), Some(Kind::Visual));
        assert!(snap.geometry(v).is_some());
    }

    /// What a general joint must be: a rigid placement, a unit axis, a parent before it.
    #[test]
    fn bad_general_joints_are_refused_by_field() {
        let good = Kinematics::Axis {
            index: 1,
            parent: 1,
            joint: JointKind::Revolute,
            placement: crate::IDENTITY,
            axis: [0.0, 0.0, 1.0],
            offset: 0.0,
            qlim: [-1.0, 1.0],
        };
        let with = |f: &dyn Fn(&mut Kinematics)| {
            let mut k = good;
            f(&mut k);
            k
        };
        let mut skew = crate::IDENTITY;
        skew[1] = 0.5;
        let cases: Vec<(Kinematics, &str)> = vec![
            (
                with(&|k| {
                    if let Kinematics::Axis { axis, .. } = k {
                        *axis = [0.0, 0.0, 2.0]
                    }
                }),
                "axis",
            ),
            (
                with(&|k| {
                    if let Kinematics::Axis { axis, .. } = k {
                        axis[0] = f64::NAN
                    }
                }),
                "axis[0]",
            ),
            (
                with(&|k| {
                    if let Kinematics::Axis { parent, .. } = k {
                        *parent = 2
                    }
                }),
                "parent",
            ),
            (
                with(&|k| {
                    if let Kinematics::Axis { placement, .. } = k {
                        *placement = skew
                    }
                }),
                "placement",
            ),
            (
                with(&|k| {
                    if let Kinematics::Axis { qlim, .. } = k {
                        *qlim = [1.0, -1.0]
                    }
                }),
                "qlim",
            ),
            (
                with(&|k| {
                    if let Kinematics::Axis { offset, .. } = k {
                        *offset = f64::INFINITY
                    }
                }),
                "offset",
            ),
        ];
        for (k, field) in cases {
            let mut tx = Transaction::new();
            let robot = tx.create(Kind::Robot, "r", None);
            let l = tx.create(Kind::Link, "l", Some(robot));
            tx.set_kinematics(l, Some(k));
            let e = Store::default().apply(&tx).expect_err(field);
            assert!(e.to_string().contains(field), "{field}: {e}");
        }
        // On a solid, joint data is refused as for a DH row.
        let mut tx = Transaction::new();
        let s = tx.create(Kind::Solid, "s", None);
        tx.set_kinematics(s, Some(good));
        let e = Store::default().apply(&tx).expect_err("not a link");
        assert!(e.to_string().contains("belongs on a link"), "{e}");
    }

    #[test]
    fn unknown_tags_read_as_none() {
        assert_eq!(JointKind::from_u32(3), None);
        assert_eq!(DhConvention::from_u32(2), None);
        assert_eq!(JointKind::from_u32(2), Some(JointKind::Prismatic));
    }
}
