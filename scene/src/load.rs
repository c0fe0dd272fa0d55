//! Scenes a keeper can start with: any scene, robot, link or solid declaration of the
//! session's Library Space, instantiated with its defaults, and one built-in scene, `demo` (a
//! table and a two-link planar arm with box links) that needs no library. Both go through the
//! same validated transactions as anything else.

use crate::SceneError;
use robosim_instance_space::{
    Appearance, DhConvention, GeometryInput, IDENTITY, JointKind, Kind, Kinematics, MassProps,
    Transaction,
};

/// The transactions that build scene `name`: the built-in `demo`, or any declaration of the
/// session's library (a scene, robot, link or solid), instantiated with its defaults.
pub fn load_from(
    lib: &robosim_library::Library,
    name: &str,
) -> Result<Vec<Transaction>, SceneError> {
    if name == "demo" {
        return Ok(vec![demo()]);
    }
    if lib.kind(name).is_none() {
        let names: Vec<String> = lib
            .declarations()
            .into_iter()
            .filter(|d| matches!(d.kind.as_str(), "scene" | "robot"))
            .map(|d| d.name)
            .collect();
        return Err(SceneError::UnknownScene {
            name: name.to_owned(),
            known: format!("demo, {}", names.join(", ")),
        });
    }
    let origin = crate::instantiate::Origin::defaults(name);
    Ok(vec![crate::instantiate::instantiate(lib, &origin, name)?])
}

/// A box centred on its bounding box (DESIGN.md, Shapes), full side lengths `size` (m).
pub fn box_geometry(size: [f64; 3]) -> GeometryInput {
    let h = [size[0] / 2.0, size[1] / 2.0, size[2] / 2.0];
    let vertices = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { -h[0] } else { h[0] },
                if i & 2 == 0 { -h[1] } else { h[1] },
                if i & 4 == 0 { -h[2] } else { h[2] },
            ]
        })
        .collect();
    GeometryInput {
        vertices,
        polygons: vec![
            vec![0, 2, 3, 1],
            vec![4, 5, 7, 6],
            vec![0, 1, 5, 4],
            vec![2, 6, 7, 3],
            vec![0, 4, 6, 2],
            vec![1, 3, 7, 5],
        ],
    }
}

fn translate(x: f64, y: f64, z: f64) -> [f64; 12] {
    let mut p = IDENTITY;
    p[3] = x;
    p[7] = y;
    p[11] = z;
    p
}

fn demo() -> Transaction {
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "demo", None);
    let table = tx.create(Kind::Item, "table", Some(scene));
    tx.set_pose(table, translate(0.8, 0.0, -0.05));
    let top = tx.create(Kind::Solid, "table-top", Some(table));
    tx.set_geometry(top, Some(box_geometry([0.6, 0.6, 0.1])));
    tx.set_appearance(
        top,
        Appearance {
            color: [0.55, 0.4, 0.25, 1.0],
            ..Appearance::default()
        },
    );
    let robot = tx.create(Kind::Robot, "arm2", Some(scene));
    tx.set_kinematics(
        robot,
        Some(Kinematics::Robot {
            convention: DhConvention::Standard,
            ik_family: 0,
            tool: IDENTITY,
        }),
    );
    let lengths = [0.5, 0.4];
    let mut x = 0.0;
    for (j, &a) in lengths.iter().enumerate() {
        let link = tx.create(Kind::Link, &format!("link{}", j + 1), Some(robot));
        tx.set_kinematics(
            link,
            Some(Kinematics::Joint {
                index: j as u32,
                joint: JointKind::Revolute,
                convention: DhConvention::Standard,
                a,
                d: 0.0,
                alpha: 0.0,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.8, 2.8],
            }),
        );
        tx.set_dynamics(
            link,
            Some(MassProps {
                mass: 2.0 * a,
                com: [-a / 2.0, 0.0, 0.0],
                inertia: [
                    1e-3,
                    2.0 * a * a * a / 12.0,
                    2.0 * a * a * a / 12.0,
                    0.0,
                    0.0,
                    0.0,
                ],
            }),
        );
        let body = tx.create(Kind::Solid, &format!("link{}-body", j + 1), Some(link));
        // The link frame is at the far end of the link (standard DH): the body sits behind it.
        tx.set_pose(body, translate(-a / 2.0, 0.0, 0.0));
        tx.set_geometry(body, Some(box_geometry([a, 0.06, 0.06])));
        tx.set_appearance(
            body,
            Appearance {
                color: [0.2, 0.4, 0.8, 1.0],
                ..Appearance::default()
            },
        );
        // Link frames at q = 0 (standard DH, planar chain along x); whoever moves a joint
        // writes the new link poses in the same transaction.
        x += a;
        tx.set_pose(link, translate(x, 0.0, 0.0));
    }
    tx
}
