//! Building a [`Robot`] from general joints, fixed joints included — what a URDF reader (or any
//! description with `<origin>`/`<axis>` joints) hands over. Entry points: [`Segment`],
//! [`Inertial`], [`build_chain`].
//!
//! A chain is the list of joints from the root link to the tip link, each with the inertial of
//! the link it carries (its child). Movable joints (revolute, continuous, prismatic) become
//! [`Joint`]s with an [`Origin`]; a fixed joint has no coordinate and is **folded**: its
//! placement is multiplied into the next movable joint's placement (or into the tool when no
//! movable joint follows), and its child's inertial is lumped into the link it hangs from,
//! expressed there. Inertia carried rigidly by the root link (before the first movable joint)
//! cannot move and is dropped. The result's q, M(q), τ and FK are those of the chain with its
//! fixed joints (Pinocchio folds fixed joints the same way in its URDF reader).
//!
//! Frames: the robot's base frame is the root link's frame (`base = 1`), link frame j is the
//! child link frame of movable joint j, and `tool` is the tip link's frame in the last movable
//! link's frame.

use crate::model::{Joint, JointType, Origin, Robot};
use crate::root::{RootJoint, RootKind};
use nalgebra::{Matrix3, Matrix4, Vector3};

/// Mass properties of one link: mass (kg), centre of mass (m) and inertia about the centre of
/// mass (kg·m²), both in the link's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertial {
    pub mass: f64,
    pub com: Vector3<f64>,
    pub inertia: Matrix3<f64>,
}

impl Default for Inertial {
    fn default() -> Self {
        Inertial {
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
        }
    }
}

impl Inertial {
    /// This inertial seen from a frame in which its own frame sits at `x` (rigid 4×4).
    pub fn transformed(&self, x: &Matrix4<f64>) -> Inertial {
        let r = x.fixed_view::<3, 3>(0, 0).into_owned();
        Inertial {
            mass: self.mass,
            com: r * self.com + x.fixed_view::<3, 1>(0, 3),
            inertia: r * self.inertia * r.transpose(),
        }
    }

    /// Lumps `other` (given in the same frame) into `self`: a rigid body made of both. The
    /// inertias are moved to the common centre of mass by the parallel-axis theorem.
    pub fn merge(&mut self, other: &Inertial) {
        let m = self.mass + other.mass;
        if m <= 0.0 {
            return;
        }
        let c = (self.com * self.mass + other.com * other.mass) / m;
        let shift = |d: Vector3<f64>, mass: f64| {
            (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * mass
        };
        let inertia = self.inertia
            + shift(self.com - c, self.mass)
            + other.inertia
            + shift(other.com - c, other.mass);
        *self = Inertial {
            mass: m,
            com: c,
            inertia,
        };
    }
}

/// What a joint does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SegmentKind {
    Revolute,
    /// A revolute joint without limits (q unbounded).
    Continuous,
    Prismatic,
    /// No coordinate: folded (see the module docs).
    Fixed,
    /// A spherical (ball) joint about the joint frame's origin: a [`Joint::spherical`] joint
    /// (4 q, 3 v; axis and limits not read — a cone limit has no place in `qlim`).
    Spherical,
    /// A floating robot's root joint (URDF's `floating` and `planar`): it must be the first
    /// segment and hang from the root link. It becomes [`Robot::root`], its placement the
    /// robot's `base`, its child link link frame 0 (what is rigid with it lumped into the
    /// root's inertial); axis and limits are not read (Pinocchio ignores a planar joint's axis:
    /// the plane is its frame's x–y plane). Elsewhere it is treated as fixed: the caller
    /// refuses that.
    Root(RootKind),
}

/// One joint of a chain and the link it carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    pub kind: SegmentKind,
    /// Parent link frame → joint frame (rigid 4×4, m).
    pub placement: Matrix4<f64>,
    /// Unit axis in the joint frame (ignored for a fixed joint).
    pub axis: Vector3<f64>,
    /// Position limits [lo, hi] (rad or m; ignored for continuous and fixed joints).
    pub qlim: [f64; 2],
    /// Viscous and Coulomb friction (URDF `<dynamics damping friction>`).
    pub viscous: f64,
    pub coulomb: f64,
    /// The child link's mass properties, in the child link frame (the joint frame moved by q),
    /// with everything rigidly attached to it already lumped in.
    pub child: Inertial,
}

/// The robot of a chain (see the module docs), and for each of its joints the index of the
/// segment it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct BuiltChain {
    pub robot: Robot,
    pub segment_of_joint: Vec<usize>,
    /// What is rigid with the root link (or, with a [`SegmentKind::Root`], with link frame 0)
    /// through fixed joints, in its frame: dropped for a fixed base, the base link's inertial
    /// (besides the root link's own) for a floating one.
    pub root_inertial: Inertial,
}

/// Folds `segments` (root to tip) into a robot named `name` (see the module docs). Does not
/// validate: call [`Robot::validate`] on the result.
pub fn build_chain(name: &str, segments: &[Segment]) -> BuiltChain {
    let mut joints: Vec<Joint> = Vec::new();
    let mut segment_of_joint = Vec::new();
    let mut inertials: Vec<Inertial> = Vec::new();
    // The fixed transform from the last movable link frame (or the root) to the current link.
    let mut pending = Matrix4::identity();
    let mut root_inertial = Inertial::default();
    let mut root: Option<(RootKind, Matrix4<f64>)> = None;
    for (k, seg) in segments.iter().enumerate() {
        let (joint_type, qlim) = match seg.kind {
            SegmentKind::Revolute => (JointType::Revolute, seg.qlim),
            SegmentKind::Continuous | SegmentKind::Spherical => {
                (JointType::Revolute, [f64::NEG_INFINITY, f64::INFINITY])
            }
            SegmentKind::Prismatic => (JointType::Prismatic, seg.qlim),
            SegmentKind::Root(kind) if k == 0 => {
                root = Some((kind, seg.placement));
                root_inertial = seg.child;
                continue;
            }
            SegmentKind::Fixed | SegmentKind::Root(_) => {
                pending *= seg.placement;
                match inertials.last_mut() {
                    Some(last) => last.merge(&seg.child.transformed(&pending)),
                    None => root_inertial.merge(&seg.child.transformed(&pending)),
                }
                continue;
            }
        };
        joints.push(Joint {
            joint_type,
            qlim,
            viscous: seg.viscous,
            coulomb: seg.coulomb,
            spherical: seg.kind == SegmentKind::Spherical,
            origin: Some(Origin {
                placement: pending * seg.placement,
                axis: seg.axis,
            }),
            ..Joint::default()
        });
        segment_of_joint.push(k);
        inertials.push(seg.child);
        pending = Matrix4::identity();
    }
    for (joint, inertial) in joints.iter_mut().zip(&inertials) {
        joint.mass = inertial.mass;
        joint.com = inertial.com;
        joint.inertia = inertial.inertia;
    }
    BuiltChain {
        robot: Robot {
            name: name.to_string(),
            joints,
            tool: pending,
            base: root.map_or_else(Matrix4::identity, |r| r.1),
            root: root.map(|(kind, _)| root_joint(kind, &root_inertial)),
            ..Robot::default()
        },
        segment_of_joint,
        root_inertial,
    }
}

/// The root joint of `kind` carrying `inertial`.
pub fn root_joint(kind: RootKind, inertial: &Inertial) -> RootJoint {
    RootJoint {
        kind,
        mass: inertial.mass,
        com: inertial.com,
        inertia: inertial.inertia,
    }
}

/// Folds a **tree** of segments into a robot (see [`Robot::parents`]): `parents[k]` is the
/// segment whose child link segment `k` hangs from (`None`: the root link), and must come
/// before `k`. Movable segments become joints in segment order; a fixed segment is folded as in
/// [`build_chain`] — its transform joins the placements of the movable joints below it and its
/// child's inertial is lumped into the movable link it hangs from (dropped when that is the
/// root). The tool is the identity on the last joint's link frame. A chain (`parents[k] = k−1`)
/// gives [`build_chain`]'s joints, inertials and parents (its tool aside). Does not validate.
/// Panics if `parents` is not as long as `segments` or a parent does not come first.
pub fn build_tree(name: &str, segments: &[Segment], parents: &[Option<usize>]) -> BuiltChain {
    assert_eq!(
        segments.len(),
        parents.len(),
        "build_tree: one parent per segment"
    );
    let mut joints: Vec<Joint> = Vec::new();
    let mut joint_parents: Vec<usize> = Vec::new();
    let mut segment_of_joint = Vec::new();
    let mut inertials: Vec<Inertial> = Vec::new();
    // Per segment: the link frame its child is rigid with (0 = root, k = joint k−1) and the
    // fixed transform from that frame to the child link's frame.
    let mut anchor: Vec<(usize, Matrix4<f64>)> = Vec::with_capacity(segments.len());
    let mut root_inertial = Inertial::default();
    let mut root: Option<(RootKind, Matrix4<f64>)> = None;
    for (k, (seg, parent)) in segments.iter().zip(parents).enumerate() {
        let (frame, pending) = match parent {
            Some(p) => {
                assert!(
                    *p < k,
                    "build_tree: segment {k}'s parent {p} does not come first"
                );
                anchor[*p]
            }
            None => (0, Matrix4::identity()),
        };
        let (joint_type, qlim) = match seg.kind {
            SegmentKind::Revolute => (JointType::Revolute, seg.qlim),
            SegmentKind::Continuous | SegmentKind::Spherical => {
                (JointType::Revolute, [f64::NEG_INFINITY, f64::INFINITY])
            }
            SegmentKind::Prismatic => (JointType::Prismatic, seg.qlim),
            SegmentKind::Root(kind) if k == 0 && parent.is_none() => {
                root = Some((kind, seg.placement));
                root_inertial = seg.child;
                anchor.push((0, Matrix4::identity()));
                continue;
            }
            SegmentKind::Fixed | SegmentKind::Root(_) => {
                let x = pending * seg.placement;
                if frame > 0 {
                    inertials[frame - 1].merge(&seg.child.transformed(&x));
                } else {
                    root_inertial.merge(&seg.child.transformed(&x));
                }
                anchor.push((frame, x));
                continue;
            }
        };
        joints.push(Joint {
            joint_type,
            qlim,
            viscous: seg.viscous,
            coulomb: seg.coulomb,
            spherical: seg.kind == SegmentKind::Spherical,
            origin: Some(Origin {
                placement: pending * seg.placement,
                axis: seg.axis,
            }),
            ..Joint::default()
        });
        joint_parents.push(frame);
        segment_of_joint.push(k);
        inertials.push(seg.child);
        anchor.push((joints.len(), Matrix4::identity()));
    }
    for (joint, inertial) in joints.iter_mut().zip(&inertials) {
        joint.mass = inertial.mass;
        joint.com = inertial.com;
        joint.inertia = inertial.inertia;
    }
    let chain = joint_parents.iter().enumerate().all(|(j, &p)| p == j);
    BuiltChain {
        robot: Robot {
            name: name.to_string(),
            joints,
            parents: if chain { Vec::new() } else { joint_parents },
            base: root.map_or_else(Matrix4::identity, |r| r.1),
            root: root.map(|(kind, _)| root_joint(kind, &root_inertial)),
            ..Robot::default()
        },
        segment_of_joint,
        root_inertial,
    }
}

/// The same robot with every joint general (an [`Origin`] and an axis, no trailing transform):
/// joint j's placement becomes `T_{j−1} · P_j`, link frame j becomes joint frame j moved by q
/// (its inertial is re-expressed there by `T_j`) and the tool becomes `T_n · tool`. FK, the
/// Jacobians and the dynamics are unchanged up to rounding; link frames j move to the joint
/// frames. This is DH → URDF-style origins and axes.
pub fn to_general(robot: &Robot) -> Robot {
    let mut out = robot.clone();
    let mut trailings: Vec<Matrix4<f64>> = vec![Matrix4::identity()];
    let mut last = Matrix4::identity();
    for (j, (joint, orig)) in out.joints.iter_mut().zip(&robot.joints).enumerate() {
        let g = orig.geometry(robot.convention);
        let prev = trailings[robot.parent(j)];
        let placement = match &g.placement {
            Some(p) => prev * p,
            None => prev,
        };
        let trailing = g.trailing.unwrap_or_else(Matrix4::identity);
        let inertial = Inertial {
            mass: orig.mass,
            com: orig.com,
            inertia: orig.inertia,
        }
        .transformed(&trailing);
        joint.com = inertial.com;
        joint.inertia = inertial.inertia;
        joint.origin = Some(Origin {
            placement,
            axis: g.axis,
        });
        trailings.push(trailing);
        last = trailing;
    }
    out.tool = last * robot.tool;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fk::forward;
    use crate::pose::{rot_x, trans};

    #[test]
    fn merged_inertia_equals_the_sum_about_a_common_point() {
        // Two point-ish bodies; inertia about the origin is additive, so compare there.
        let a = Inertial {
            mass: 2.0,
            com: Vector3::new(0.1, 0.0, 0.2),
            inertia: Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.03)),
        };
        let b = Inertial {
            mass: 1.5,
            com: Vector3::new(-0.3, 0.4, 0.0),
            inertia: Matrix3::new(0.02, 0.001, 0.0, 0.001, 0.03, 0.0, 0.0, 0.0, 0.01),
        };
        let about_origin = |x: &Inertial| {
            x.inertia
                + (Matrix3::identity() * x.com.norm_squared() - x.com * x.com.transpose()) * x.mass
        };
        let mut m = a;
        m.merge(&b);
        assert!((m.mass - 3.5).abs() < 1e-15);
        assert!(
            (about_origin(&m) - about_origin(&a) - about_origin(&b))
                .abs()
                .max()
                < 1e-15
        );
    }

    #[test]
    fn builtin_robots_made_general_keep_their_kinematics() {
        for name in crate::BUILTIN_NAMES {
            let dh = crate::builtin_robot(name).expect("builtin");
            let general = to_general(&dh);
            general.validate().expect("valid");
            for k in 0..5 {
                let q: Vec<f64> = (0..dh.dof())
                    .map(|j| 0.4 * k as f64 - 0.3 * j as f64)
                    .collect();
                let e = (forward(&dh, &q) - forward(&general, &q)).abs().max();
                assert!(e < 1e-14, "{name}: {e:e}");
                let jd = crate::jacobian::jacobian(&dh, &q, crate::jacobian::Frame::Tool);
                let jg = crate::jacobian::jacobian(&general, &q, crate::jacobian::Frame::Tool);
                assert!((jd - jg).abs().max() < 1e-14, "{name}");
            }
        }
    }

    #[test]
    fn fixed_joints_fold_into_placements_and_tool() {
        let rev = |placement: Matrix4<f64>| Segment {
            kind: SegmentKind::Revolute,
            placement,
            axis: Vector3::z(),
            qlim: [-1.0, 1.0],
            viscous: 0.0,
            coulomb: 0.0,
            child: Inertial::default(),
        };
        let fixed = |placement: Matrix4<f64>| Segment {
            kind: SegmentKind::Fixed,
            ..rev(placement)
        };
        let (f0, p1, f1, p2, f2) = (
            trans(0.0, 0.0, 0.3),
            rot_x(0.5),
            trans(0.2, 0.0, 0.0),
            trans(0.0, 0.1, 0.0) * rot_x(-0.4),
            trans(0.0, 0.0, 0.05),
        );
        let built = build_chain("t", &[fixed(f0), rev(p1), fixed(f1), rev(p2), fixed(f2)]);
        assert_eq!(built.robot.dof(), 2);
        assert_eq!(built.segment_of_joint, vec![1, 3]);
        let q = [0.7, -0.2];
        let rz = |t: f64| crate::pose::rot_z(t);
        let expected = f0 * p1 * rz(q[0]) * f1 * p2 * rz(q[1]) * f2;
        assert!((forward(&built.robot, &q) - expected).abs().max() < 1e-15);
    }
}
