//! The model's objects and their values: [`Object`] with its aspects ([`Kind`], [`Pose`],
//! [`Appearance`], [`Kinematics`], [`MassProps`]), the [`aspect`] bits a change touches, the
//! [`Selection`] and the size limits. Shared by [`crate::Store`], which holds them, and
//! [`crate::Transaction`], which carries them; neither file imports the other for them.

use robosim_geometry::Polyhedron;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Object identifier; assigned by the keeper, never reused within a session. 0 means "none".
pub type Id = u64;

/// The most elements any one array of a transaction may hold (vertices, polygon indices, ids).
/// Larger requests are refused before anything is allocated for them.
pub const MAX_ELEMENTS: u64 = 1 << 27;
/// The longest name, bytes.
pub const MAX_NAME_BYTES: usize = 4096;
/// The longest origin record, bytes.
pub const MAX_ORIGIN_BYTES: usize = 1 << 16;

/// The kind tag of an object (seed §3.3: objects are dynamically typed).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    bincode::Encode,
    bincode::Decode,
    PartialOrd,
    Ord,
)]
#[repr(u32)]
pub enum Kind {
    Scene = 1,
    Robot = 2,
    Item = 3,
    Link = 4,
    Solid = 5,
    Part = 6,
    /// Geometry that is drawn and nothing else: no collision, no contact, no mass (a URDF
    /// `<visual>`; the link's `<collision>` shapes are its solids). Placed like a solid.
    Visual = 7,
}

impl Kind {
    pub fn from_u32(v: u32) -> Option<Kind> {
        Some(match v {
            1 => Kind::Scene,
            2 => Kind::Robot,
            3 => Kind::Item,
            4 => Kind::Link,
            5 => Kind::Solid,
            6 => Kind::Part,
            7 => Kind::Visual,
            _ => return None,
        })
    }
    pub fn name(self) -> &'static str {
        match self {
            Kind::Scene => "scene",
            Kind::Robot => "robot",
            Kind::Item => "item",
            Kind::Link => "link",
            Kind::Solid => "solid",
            Kind::Part => "part",
            Kind::Visual => "visual",
        }
    }
    /// The kinds this kind may be a child of (`None` = may be a root).
    pub(crate) fn allowed_parents(self) -> (&'static [Kind], bool) {
        match self {
            Kind::Scene => (&[], true),
            Kind::Robot | Kind::Item => (&[Kind::Scene], true),
            Kind::Link => (&[Kind::Robot], false),
            Kind::Solid | Kind::Visual => (
                &[
                    Kind::Scene,
                    Kind::Robot,
                    Kind::Item,
                    Kind::Link,
                    Kind::Solid,
                ],
                true,
            ),
            Kind::Part => (&[Kind::Solid], false),
        }
    }
}

/// The aspects a change can touch (seed §3.2 items 1–6); a bit set in announcements.
pub mod aspect {
    pub const STRUCTURE: u64 = 1;
    pub const GEOMETRY: u64 = 2;
    pub const POSE: u64 = 4;
    pub const APPEARANCE: u64 = 8;
    pub const KINEMATICS: u64 = 16;
    pub const DYNAMICS: u64 = 32;
    /// Every aspect of one object (what a create or a delete touches).
    pub const ALL: u64 = 63;
    /// How many aspects [`ALL`] holds (bits 0 to `COUNT - 1`).
    pub const COUNT: usize = 6;
    /// The session's selection (the display's pick, see [`crate::Selection`]) moved to or away
    /// from the object. Not part of [`ALL`]: it is a session record, not an object aspect.
    pub const SELECTION: u64 = 64;
    /// Names of the bits, for printing.
    pub fn names(mask: u64) -> Vec<&'static str> {
        [
            (STRUCTURE, "structure"),
            (GEOMETRY, "geometry"),
            (POSE, "pose"),
            (APPEARANCE, "appearance"),
            (KINEMATICS, "kinematics"),
            (DYNAMICS, "dynamics"),
            (SELECTION, "selection"),
        ]
        .iter()
        .filter(|(b, _)| mask & b != 0)
        .map(|(_, n)| *n)
        .collect()
    }
}

/// Display data (seed §3.2 item 3): RGBA colour and a Phong-like surface.
#[derive(
    Debug, Clone, Copy, PartialEq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
pub struct Appearance {
    pub color: [f32; 4],
    pub diffuse: f32,
    pub specular: f32,
    pub shininess: f32,
}

impl Default for Appearance {
    fn default() -> Self {
        Appearance {
            color: [0.7, 0.7, 0.7, 1.0],
            diffuse: 0.8,
            specular: 0.2,
            shininess: 16.0,
        }
    }
}

/// Joint type of a link.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
#[repr(u32)]
pub enum JointKind {
    Fixed = 0,
    Revolute = 1,
    Prismatic = 2,
}

/// DH convention (DESIGN.md: standard = distal, modified = Craig).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
#[repr(u32)]
pub enum DhConvention {
    Standard = 0,
    Modified = 1,
}

/// A floating robot's root joint (the joint between the world and its base link), as the
/// robot record holds it: Pinocchio's free-flyer (7 q / 6 v) or planar (4 q / 3 v) joint
/// (`robosim_kinematics::RootKind`). The value is what the robot record's `joint_kind` field
/// holds (0 there: a fixed-base robot).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
#[repr(u32)]
pub enum FloatingBase {
    FreeFlyer = 1,
    Planar = 2,
}

/// Kinematics data (seed §3.2 item 5).
#[derive(
    Debug, Clone, Copy, PartialEq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
pub enum Kinematics {
    /// A link's joint: its place in the chain, type, DH row (m, rad) and limits.
    Joint {
        index: u32,
        joint: JointKind,
        convention: DhConvention,
        a: f64,
        d: f64,
        alpha: f64,
        theta: f64,
        offset: f64,
        qlim: [f64; 2],
    },
    /// A robot: its DH convention, the analytic IK family it uses (0 = numeric only), and its
    /// tool transform (3×4 row-major).
    Robot {
        convention: DhConvention,
        ik_family: u32,
        tool: Pose,
    },
    /// A link's **general** joint (URDF's `<origin>` and `<axis>`; issue 14): the joint frame
    /// placed in the link frame it hangs from, and an axis in the joint frame. DH rows are one
    /// way to fill a joint, this is the other; one robot may mix neither — a robot's joints are
    /// all `Joint` (a DH chain) or all `Axis` (a chain or a tree).
    Axis {
        /// Index of the joint in q (0-based).
        index: u32,
        /// The link frame this joint hangs from, in Pinocchio's numbering: 0 the robot's base
        /// frame, k the link of the joint at index k − 1. At most `index` (parents come first);
        /// `index` itself means "the previous joint's link" in a chain, so a chain is
        /// `parent = index` throughout.
        parent: u32,
        joint: JointKind,
        /// Parent link frame → joint frame, 3×4 row-major (m).
        placement: Pose,
        /// Unit axis in the joint frame: the rotation axis of a revolute joint, the direction
        /// of travel of a prismatic one.
        axis: [f64; 3],
        /// Added to q before the motion (rad or m).
        offset: f64,
        /// [lo, hi] (rad or m; ±∞ for a continuous joint).
        qlim: [f64; 2],
    },
    /// A robot with a floating base (issue 36): [`Kinematics::Robot`]'s fields and its root
    /// joint. The robot object **is** the base link: its pose is the base link's pose, its
    /// dynamics aspect the base link's inertial, and its links' poses are relative to it as
    /// for any robot — so moving the base is moving the object, and the root's coordinates
    /// in a session's q are the identity (see `robosim_scene::robot_model`). Appended after
    /// the other variants, so journals, checkpoints and model files written before it decode
    /// unchanged (serde's variant index of the older ones is kept).
    FloatingRobot {
        convention: DhConvention,
        ik_family: u32,
        tool: Pose,
        root: FloatingBase,
    },
    /// A link's general joint that **follows** another (URDF's `<mimic>`, issue 36): the
    /// fields of [`Kinematics::Axis`] (its own `offset` is 0: a mimic joint moves by its
    /// coordinate alone) and the relation `q = multiplier · q[leader] + offset`. It is still a
    /// joint of the robot with its index and committed value (kept equal to the relation by
    /// whoever writes the robot's joints), but not one of the robot's independent
    /// coordinates: a session robot's q is the reduced one (`robosim_scene::robot_coupling`).
    /// `leader: None` — the joint it follows is not one of the robot's (a fixed joint): fixed
    /// at `offset`. Appended after the other variants (as [`Kinematics::FloatingRobot`]), so
    /// journals, checkpoints and model files written before it decode unchanged.
    Mimic {
        /// Index of the joint in q (0-based), as [`Kinematics::Axis::index`].
        index: u32,
        /// The link frame it hangs from, as [`Kinematics::Axis::parent`].
        parent: u32,
        joint: JointKind,
        /// Parent link frame → joint frame, 3×4 row-major (m).
        placement: Pose,
        /// Unit axis in the joint frame.
        axis: [f64; 3],
        /// [lo, hi] of this joint's own value (rad or m).
        qlim: [f64; 2],
        /// The index in q of the joint it follows (`None`: not a joint of the robot).
        leader: Option<u32>,
        multiplier: f64,
        /// Added to `multiplier · q[leader]` (rad or m).
        offset: f64,
    },
}

impl Kinematics {
    /// The robot aspect's fields (convention, IK family, tool) of a fixed or floating robot;
    /// `None` for a joint.
    pub fn robot_fields(&self) -> Option<(DhConvention, u32, Pose)> {
        match *self {
            Kinematics::Robot {
                convention,
                ik_family,
                tool,
            }
            | Kinematics::FloatingRobot {
                convention,
                ik_family,
                tool,
                ..
            } => Some((convention, ik_family, tool)),
            Kinematics::Joint { .. } | Kinematics::Axis { .. } | Kinematics::Mimic { .. } => None,
        }
    }

    /// A mimic joint as the general joint it moves like ([`Kinematics::Axis`], offset 0) and
    /// its relation (leader, multiplier, offset); `None` for any other aspect.
    pub fn mimic_parts(&self) -> Option<(Kinematics, Option<u32>, f64, f64)> {
        match *self {
            Kinematics::Mimic {
                index,
                parent,
                joint,
                placement,
                axis,
                qlim,
                leader,
                multiplier,
                offset,
            } => Some((
                Kinematics::Axis {
                    index,
                    parent,
                    joint,
                    placement,
                    axis,
                    offset: 0.0,
                    qlim,
                },
                leader,
                multiplier,
                offset,
            )),
            _ => None,
        }
    }
}

/// Dynamics data (seed §3.2 item 6): mass (kg), centre of mass (m, object frame), inertia about
/// the centre of mass (kg·m²) as xx, yy, zz, xy, xz, yz.
#[derive(
    Debug, Clone, Copy, PartialEq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
pub struct MassProps {
    pub mass: f64,
    pub com: [f64; 3],
    pub inertia: [f64; 6],
}

/// The session's selection: the object (and polygon of its geometry, when the pick hit one)
/// that the next editing command acts on. The display writes it when the user picks (clicks);
/// the editor reads it. One per session, a record of the Instance Space beside the objects —
/// not an object aspect — published in the objects head's header
/// (`Snapshot::selection`), journaled like any transaction and kept in checkpoints. A deleted
/// object stops being selected; a polygon the object's new geometry no longer has is dropped.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
pub struct Selection {
    pub object: Id,
    /// Index into the object's geometry polygons; `None`: the object as a whole.
    pub polygon: Option<u32>,
}

/// A rigid transform, 3×4 row-major `[R | t]` (the last row 0 0 0 1 is implied).
pub type Pose = [f64; 12];

/// The identity pose.
pub const IDENTITY: Pose = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// One object of the Instance Space, every aspect in one place.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    pub id: Id,
    pub kind: Kind,
    pub parent: Id,
    pub name: String,
    pub pose: Pose,
    /// The joint value of a link (rad or m); 0 for other kinds.
    pub joint: f64,
    pub appearance: Appearance,
    pub kinematics: Option<Kinematics>,
    pub dynamics: Option<MassProps>,
    /// Shared, immutable geometry: a pose change never touches it.
    pub geometry: Option<Arc<Polyhedron>>,
    /// Bumped on every geometry change; readers match geometry samples by it.
    pub geom_gen: u64,
    /// For an instance of a Library Space declaration: where it came from and with which
    /// parameters (JSON text, see `robosim instantiate`), so a parameter can be changed
    /// later and the instance re-instantiated ("live parameters"). Empty for other objects.
    pub origin: String,
}
