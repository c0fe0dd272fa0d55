//! Between the Instance Space's flat records and the simulator's plain `Robot` model.

use robosim_instance_space::{Id, Kind, Snapshot, layout::flags};
use robosim_kinematics::{Convention, Joint, JointType, Robot};

/// A robot found in a snapshot: its kinematic model and its link ids in chain order.
#[derive(Clone)]
pub struct SpaceRobot {
    pub robot: Robot,
    pub links: Vec<Id>,
    pub q: Vec<f64>,
}

/// Every robot of the snapshot whose links all carry joint data.
pub fn robots(snap: &Snapshot) -> Vec<SpaceRobot> {
    let objs = snap.objects();
    let mut out = Vec::new();
    for (i, r) in objs.iter().enumerate() {
        if Kind::from_u32(r.kind) != Some(Kind::Robot) {
            continue;
        }
        let convention = if r.kin_tag == flags::KIN_ROBOT && r.convention == 1 {
            Convention::Modified
        } else {
            Convention::Standard
        };
        let mut links: Vec<(u32, usize)> = objs
            .iter()
            .enumerate()
            .filter(|(_, o)| {
                o.parent == r.id
                    && Kind::from_u32(o.kind) == Some(Kind::Link)
                    && o.kin_tag == flags::KIN_JOINT
            })
            .map(|(k, o)| (o.index_or_family, k))
            .collect();
        links.sort_unstable();
        let mut robot = Robot {
            name: snap.name(i).to_owned(),
            convention,
            ..Robot::default()
        };
        let mut q = Vec::new();
        for &(_, k) in &links {
            let o = &objs[k];
            robot.joints.push(Joint {
                joint_type: if o.joint_kind == 2 {
                    JointType::Prismatic
                } else {
                    JointType::Revolute
                },
                a: o.dh[0],
                d: o.dh[1],
                alpha: o.dh[2],
                theta: o.dh[3],
                offset: o.dh[4],
                qlim: [o.dh[5], o.dh[6]],
                mass: o.mass,
                com: nalgebra::Vector3::from(o.com),
                inertia: {
                    let i = o.inertia;
                    nalgebra::Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2])
                },
                ..Joint::default()
            });
            q.push(snap.poses()[k].joint);
        }
        out.push(SpaceRobot {
            robot,
            links: links.iter().map(|&(_, k)| objs[k].id).collect(),
            q,
        });
    }
    out
}

/// The link poses (relative to the robot) at `q`, 3×4 row-major, one per joint.
pub fn link_poses(robot: &Robot, q: &[f64]) -> Vec<[f64; 12]> {
    let base = Robot {
        base: nalgebra::Matrix4::identity(),
        tool: nalgebra::Matrix4::identity(),
        ..robot.clone()
    };
    robosim_kinematics::fk::link_frames(&base, q)[1..=robot.dof()]
        .iter()
        .map(crate::instantiate::pose)
        .collect()
}

/// The transaction that puts `robot`'s links (ids `links`, chain order) at `q`: each link's
/// joint value and its pose relative to the robot.
pub fn joint_tx(
    robot: &Robot,
    links: &[robosim_instance_space::Id],
    q: &[f64],
) -> robosim_instance_space::Transaction {
    let mut tx = robosim_instance_space::Transaction::new();
    for ((id, qj), pose) in links.iter().zip(q).zip(link_poses(robot, q)) {
        tx.set_joint(*id, *qj).set_pose(*id, pose);
    }
    tx
}
