//! [`Model`]: one robot as every reader produces it (Pinocchio's `Model` + `GeometryModel`):
//! the joint tree in the one joint model ([`Robot`]: joints, constant placements, inertias,
//! limits, friction, a floating root), the names of its joints and links, the mimic coupling
//! beside it, its geometry ([`GeometryModel`]) and the analytic IK family it declares.
//!
//! Who fills it: the URDF/MJCF importer ([`Model::from_imported`], geometry converted once
//! from the reader's shapes), the Library Space (`robosim_library::RobotModel::model`, its
//! placed solids as shapes) and the scene compiler (`robosim_scene::CompiledRobot::model`, the
//! robot's Instance Space records). Its collision solids come from one function,
//! [`crate::geometry::link_solids`] ([`Model::collision_solids`]).

use crate::geometry::{GeometryError, GeometryModel, GeometryObject, MeshFile, Role, Shape};
use robosim_collision::robot::LinkSolids;
use robosim_kinematics::Robot;
use robosim_kinematics::mimic::Coupling;
use robosim_urdf::urdf_geometry::{Geometry, Shape as UrdfShape};
use robosim_urdf::urdf_import::ImportedRobot;

/// One robot: kinematics and dynamics, names, coupling, geometry (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// The joint tree, validated by whoever built it.
    pub robot: Robot,
    /// One name per joint (coordinate) of `robot`, in q order.
    pub joint_names: Vec<String>,
    /// One name per joint: the link the joint moves (link frame j), in q order.
    pub link_names: Vec<String>,
    /// The mimic relations over `robot`'s coordinates (`None`: no joint mimics another).
    pub coupling: Option<Coupling>,
    pub geometry: GeometryModel,
    /// The analytic inverse-kinematics family (`puma`, `stanford`, …), if any.
    pub ik: Option<String>,
}

impl Model {
    /// A model without geometry, names `joint1…`, `link1…` (for a bare [`Robot`]).
    pub fn bare(robot: Robot) -> Self {
        let n = robot.dof();
        Model {
            joint_names: (1..=n).map(|j| format!("joint{j}")).collect(),
            link_names: (1..=n).map(|j| format!("link{j}")).collect(),
            robot,
            coupling: None,
            geometry: GeometryModel::default(),
            ik: None,
        }
    }

    /// Joints (coordinates) of the robot.
    pub fn dof(&self) -> usize {
        self.robot.dof()
    }

    /// The name of frame `frame`: `base` for 0, else the link name of joint `frame`.
    pub fn frame_name(&self, frame: usize) -> Option<&str> {
        match frame {
            0 => Some("base"),
            j => self.link_names.get(j - 1).map(String::as_str),
        }
    }

    /// The robot's collision solids (base first), built from its geometry by
    /// [`crate::geometry::link_solids`]; mesh files are read now.
    pub fn collision_solids(&self) -> Result<LinkSolids, GeometryError> {
        crate::geometry::link_solids(&self.geometry, self.robot.dof())
    }

    /// The analytic IK family `robot` matches, for a chain (`None` for a tree, or a chain no
    /// closed form solves).
    pub fn recognised_ik(robot: &Robot) -> Option<String> {
        if !robot.parents.is_empty() {
            return None;
        }
        match robosim_kinematics::ik::family::recognise(robot) {
            robosim_kinematics::ik::family::Family::General(_) => None,
            f => Some(f.name().to_string()),
        }
    }

    /// The model of a URDF or MJCF import: its robot, joint and link names, coupling, and its
    /// links' `<collision>` and `<visual>` shapes as geometry objects — named
    /// `link/collisionK` and `link/visualK` (K the shape's index among the link's shapes of
    /// that role), on the body the link is rigid with, placed at the link's place in that body
    /// times the shape's origin; meshes by name (read when solids are built); a visual's
    /// material colour as its `rgba`. Objects come frame by frame (base first, as the
    /// Library Space lists its solids); within a frame, links in name order, each link's
    /// shapes in file order (the order `robosim_urdf` reads them in).
    pub fn from_imported(u: &ImportedRobot) -> Self {
        let mut objects = Vec::new();
        for (link, g) in &u.geometry.links {
            for (role, shapes, what) in [
                (Role::Collision, &g.collision, "collision"),
                (Role::Visual, &g.visual, "visual"),
            ] {
                for (k, s) in shapes.iter().enumerate() {
                    objects.push(GeometryObject {
                        name: format!("{link}/{what}{k}"),
                        frame: g.body,
                        placement: g.in_body * s.origin,
                        shape: shape_of(s),
                        role,
                        rgba: s.material.as_ref().and_then(|m| m.rgba),
                    });
                }
            }
        }
        // Stable: the order within a frame (a compound's part order) is kept.
        objects.sort_by_key(|o| o.frame);
        Model {
            robot: u.robot.clone(),
            joint_names: u.joints.iter().map(|j| j.name.clone()).collect(),
            link_names: u.joints.iter().map(|j| j.link.clone()).collect(),
            coupling: u.coupling.clone(),
            geometry: GeometryModel { objects },
            ik: Self::recognised_ik(&u.robot),
        }
    }
}

impl From<&ImportedRobot> for Model {
    fn from(u: &ImportedRobot) -> Self {
        Model::from_imported(u)
    }
}

/// A reader's `<geometry>` as a shape: primitives as they are (round ones at the collision
/// crate's default facets, as the reader gives none), a mesh by its name.
fn shape_of(s: &UrdfShape) -> Shape {
    match &s.geometry {
        Geometry::Box { size } => Shape::Box {
            size: [size.x, size.y, size.z],
        },
        Geometry::Cylinder { radius, length } => Shape::Cylinder {
            radius: *radius,
            length: *length,
            facets: None,
        },
        Geometry::Sphere { radius } => Shape::Sphere {
            radius: *radius,
            facets: None,
        },
        Geometry::Mesh(m) => Shape::Mesh(MeshFile {
            uri: m.uri.clone(),
            scale: [m.scale.x, m.scale.y, m.scale.z],
            source: m.urdf.clone(),
            line: m.line,
            element: m.element.clone(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use robosim_collision::SolidKind;
    use std::path::Path;

    const URDF: &str = r#"<robot name="small">
  <link name="base">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
  </link>
  <link name="arm">
    <visual><geometry><cylinder radius="0.03" length="0.6"/></geometry>
      <material name="blue"><color rgba="0 0 1 1"/></material></visual>
    <collision><origin xyz="0 0 0.3"/><geometry><cylinder radius="0.03" length="0.6"/></geometry></collision>
  </link>
  <link name="tool">
    <collision><origin xyz="0 0.2 0"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="fix" type="fixed"><parent link="arm"/><child link="tool"/>
    <origin xyz="0 0 0.6"/></joint>
</robot>"#;

    #[test]
    fn an_import_becomes_one_model_with_its_shapes_on_their_bodies() {
        let u = robosim_urdf::urdf_import::import_urdf_str(URDF, Path::new("small.urdf"), None)
            .expect("imports");
        let m = Model::from(&u);
        assert_eq!(m.joint_names, ["j1"]);
        assert_eq!(m.link_names, ["arm"]);
        assert_eq!(m.frame_name(1), Some("arm"));
        assert!(m.coupling.is_none());
        let names: Vec<(&str, usize, Role)> = (m.geometry.objects.iter())
            .map(|o| (o.name.as_str(), o.frame, o.role))
            .collect();
        // Frame by frame; within a frame, links in name order (arm, tool), collisions before
        // visuals within a link.
        assert_eq!(
            names,
            [
                ("base/collision0", 0, Role::Collision),
                ("arm/collision0", 1, Role::Collision),
                ("arm/visual0", 1, Role::Visual),
                ("tool/collision0", 1, Role::Collision),
            ]
        );
        assert_eq!(m.geometry.objects[2].rgba, Some([0.0, 0.0, 1.0, 1.0]));
        // The tool is lumped into the arm's body: its sphere sits at the fixed joint's origin
        // (arm z = 0.6) times its own (y = 0.2).
        let tool = &m.geometry.objects[3];
        let t = tool.placement.fixed_view::<3, 1>(0, 3).into_owned();
        assert!((t - Vector3::new(0.0, 0.2, 0.6)).norm() < 1e-15, "{t}");
        assert_eq!(
            tool.shape,
            Shape::Sphere {
                radius: 0.05,
                facets: None
            }
        );
        let ls = m.collision_solids().expect("solids");
        assert_eq!(ls.links.len(), 2);
        let base = ls.links[0].as_ref().expect("base");
        assert_eq!(base.solid.kind, SolidKind::Cuboid);
        assert!((base.offset.translation.vector - Vector3::new(0.0, 0.0, 0.05)).norm() < 1e-15);
        // The arm's cylinder and the tool's sphere: one compound (the visual is not collided).
        let arm = ls.links[1].as_ref().expect("arm");
        assert_eq!(arm.solid.kind, SolidKind::Compound);
        assert!(
            (arm.solid.bbox.maxs().y - 0.25).abs() < 1e-9,
            "{:?}",
            arm.solid.bbox
        );
    }

    #[test]
    fn a_bare_robot_has_names_and_no_geometry() {
        let u = robosim_urdf::urdf_import::import_urdf_str(URDF, Path::new("small.urdf"), None)
            .expect("imports");
        let m = Model::bare(u.robot.clone());
        assert_eq!(m.joint_names, ["joint1"]);
        assert_eq!(m.frame_name(2), None);
        let ls = m.collision_solids().expect("no solids");
        assert!(ls.links.iter().all(Option::is_none));
    }
}
