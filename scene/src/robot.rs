//! An Instance Space robot as the kinematics core's [`Robot`] model, and back: the joint
//! transaction that puts a robot's links at new joint values.

use crate::SceneError;
use crate::pose;
use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_instance_space::{
    DhConvention, FloatingBase, Id, JointKind, RobotView, Snapshot, Transaction,
};
use robosim_kinematics::mimic::{Coupling, Mimic};
use robosim_kinematics::{Convention, Joint, JointType, Origin, Robot, RootJoint, RootKind};

/// The kinematic and dynamic model of robot `view`, placed where it stands: base = the robot
/// object's world pose, tool = its tool record. Joints in q order. A robot's joints are all DH
/// rows (`Kinematics::Joint`: a chain read by the robot's convention) or all general joints
/// (`Kinematics::Axis`: placement and axis, a chain or a tree by their parents); a mix is
/// refused, and so is a link that carries a fixed joint record (never read as a revolute one).
///
/// A floating robot (`Kinematics::FloatingRobot`) gets its root joint (`Robot::root`, the
/// base link's inertial from the robot object's mass properties): the robot object is the
/// base link, so `base` is still the object's world pose and the root's coordinates in the
/// session's q are the identity (`Robot::neutral_q`'s root part). A pure op given another q
/// (`{"op": "fk", "robot": NAME, "q": [x y z qx qy qz qw, …]}`) moves the base from there.
pub fn robot_model(snap: &Snapshot, view: &RobotView<'_>) -> Result<Robot, SceneError> {
    if view.joints.is_empty() {
        return Err(SceneError::NoJoints(view.name.to_owned()));
    }
    let general = view.joints[0].origin.is_some();
    let mut joints = Vec::with_capacity(view.joints.len());
    let mut parents = Vec::with_capacity(view.joints.len());
    for (k, j) in view.joints.iter().enumerate() {
        let joint_type = match j.kind {
            JointKind::Revolute => JointType::Revolute,
            JointKind::Prismatic => JointType::Prismatic,
            JointKind::Fixed => {
                return Err(SceneError::FixedJoint {
                    robot: view.name.to_owned(),
                    link: snap.name(j.index).to_owned(),
                    id: j.id,
                });
            }
        };
        if j.origin.is_some() != general {
            return Err(SceneError::BadRobot {
                robot: view.name.to_owned(),
                reason: format!(
                    "link {} (object {}) is a {} joint and link {} a {} one; a robot's joints are all DH rows or all general (placement and axis)",
                    snap.name(view.joints[0].index),
                    view.joints[0].id,
                    if general { "general" } else { "DH" },
                    snap.name(j.index),
                    if general { "DH" } else { "general" },
                ),
            });
        }
        let m = j.mass.unwrap_or(robosim_instance_space::MassProps {
            mass: 0.0,
            com: [0.0; 3],
            inertia: [0.0; 6],
        });
        let i = m.inertia;
        let origin = j.origin.map(|o| {
            parents.push(o.parent as usize);
            Origin {
                placement: pose::to_matrix(&o.placement),
                axis: Vector3::from(o.axis),
            }
        });
        if origin.is_some() && parents[k] > k {
            return Err(SceneError::BadRobot {
                robot: view.name.to_owned(),
                reason: format!(
                    "link {} (joint {k}) hangs from link frame {}, which is not before it",
                    snap.name(j.index),
                    parents[k]
                ),
            });
        }
        joints.push(Joint {
            joint_type,
            a: j.a,
            d: j.d,
            alpha: j.alpha,
            theta: j.theta,
            offset: j.offset,
            qlim: j.qlim,
            mass: m.mass,
            com: Vector3::from(m.com),
            inertia: Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2]),
            origin,
            ..Joint::default()
        });
    }
    // A chain (every joint on the previous one's link) is `parents` empty, the chain fast path.
    if parents.iter().enumerate().all(|(k, p)| *p == k) {
        parents.clear();
    }
    let robot = Robot {
        name: view.name.to_owned(),
        convention: match view.convention {
            DhConvention::Standard => Convention::Standard,
            DhConvention::Modified => Convention::Modified,
        },
        joints,
        parents,
        base: pose::to_matrix(&snap.world_pose(view.index)),
        tool: pose::to_matrix(&view.tool),
        root: view.root.map(|kind| {
            let m = view.base_mass.unwrap_or(robosim_instance_space::MassProps {
                mass: 0.0,
                com: [0.0; 3],
                inertia: [0.0; 6],
            });
            let i = m.inertia;
            RootJoint {
                kind: match kind {
                    FloatingBase::FreeFlyer => RootKind::FreeFlyer,
                    FloatingBase::Planar => RootKind::Planar,
                },
                mass: m.mass,
                com: Vector3::from(m.com),
                inertia: Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2]),
            }
        }),
        ..Robot::default()
    };
    robot.validate().map_err(|e| SceneError::BadRobot {
        robot: view.name.to_owned(),
        reason: e.to_string(),
    })?;
    Ok(robot)
}

/// The coupling of robot `view`'s mimic joints (`Kinematics::Mimic` records: a URDF's
/// `<mimic>` followers, `robosim import urdf`) over `robot` (its [`robot_model`]), a floating
/// root's coordinates first; `None` when no joint follows another. A session robot's
/// coordinates are then the reduced ones. Refused (`BadRobot`): relations that make a cycle,
/// or a joint following two.
pub fn robot_coupling(view: &RobotView<'_>, robot: &Robot) -> Result<Option<Coupling>, SceneError> {
    let relations: Vec<Mimic> = (view.joints.iter().enumerate())
        .filter_map(|(k, j)| {
            let m = j.mimic?;
            Some(Mimic {
                follower: k,
                leader: m.leader.map(|l| l as usize),
                multiplier: m.multiplier,
                offset: m.offset,
            })
        })
        .collect();
    if relations.is_empty() {
        return Ok(None);
    }
    let c = Coupling::new(robot.dof(), &relations).map_err(|e| SceneError::BadRobot {
        robot: view.name.to_owned(),
        reason: format!("its mimic joints: {e}"),
    })?;
    Ok(Some(c.with_root(robot.root_nq(), robot.root_nv())))
}

/// The link poses relative to the robot object at `q` (3×4 row-major, one per joint): what
/// the Instance Space holds for the links of a robot standing at `q`. `q` has `robot.nq()`
/// values; a floating robot's links are placed relative to its base link (the robot object),
/// whatever the root's coordinates in `q`.
pub fn link_poses(robot: &Robot, q: &[f64]) -> Vec<[f64; 12]> {
    let local = Robot {
        base: Matrix4::identity(),
        tool: Matrix4::identity(),
        ..robot.clone()
    };
    let frames = robosim_kinematics::fk::link_frames(&local, q);
    let base_link = robot
        .root
        .as_ref()
        .and_then(|_| frames.first()?.try_inverse());
    frames[1..=robot.dof()]
        .iter()
        .map(|f| match &base_link {
            Some(inv) => pose::from_matrix(&(inv * f)),
            None => pose::from_matrix(f),
        })
        .collect()
}

/// The transaction that puts `robot`'s links (ids `links`, chain order) at `q`: each link's
/// joint value and its pose relative to the robot. A joint-only change: it keeps the
/// structure version, so compiled models are updated in place, not rebuilt.
pub fn joint_tx(robot: &Robot, links: &[Id], q: &[f64]) -> Transaction {
    let mut tx = Transaction::new();
    let joints = q.get(robot.root_nq()..).unwrap_or_default();
    for ((id, qj), p) in links.iter().zip(joints).zip(link_poses(robot, q)) {
        tx.set_joint(*id, *qj).set_pose(*id, p);
    }
    tx
}
