//! MJCF export of a robot (issue 36 item 4, `robosim export mjcf`): robosim's joint model
//! written as a MuJoCo body tree that MuJoCo loads without flags and whose FK and mass matrix
//! are robosim's (tools/peers/check_exports.py checks both in MuJoCo 4.0; docs/file-io.md has
//! the table).
//!
//! The robot is first made general ([`robosim_kinematics::chain::to_general`]: every joint an
//! origin and an axis, DH rows included), then each joint j is a `<body>` named
//! `<robot>_link<j+1>` whose `pos`/`quat` are the joint's placement times its motion at the
//! offset (`P_j · M_j(offset)`, so MuJoCo's q is robosim's q, `ref` 0), inside the body of its
//! parent link; `<robot>_link0` is a joint-less body at the world's origin and the robot's base
//! placement is multiplied into the bodies on it (Pinocchio 4.1's MJCF reader drops the pos
//! and quat of a joint-less body on the world); the tool is a body `<robot>_tool` without joint
//! on the last link. A joint is `hinge` or `slide` with its
//! `axis`, `range` (or `limited="false"` when unbounded), `damping` (viscous friction),
//! `frictionloss` (Coulomb) and `armature` (the motor inertia, which MuJoCo adds to M's diagonal
//! as robosim does). Each body's `<inertial>` is its link's mass, centre of mass and
//! `fullinertia` (MuJoCo diagonalises it); `<option gravity>` is the robot's gravity.
//!
//! Inertias MuJoCo refuses are made physical and said ([`crate::inertial`]): a link whose
//! principal moments break A + B ≥ C (the PUMA's link 3 in the library's data) has its two
//! smaller moments raised by half the deficit each (C kept), and a moving link without mass
//! gets [`TINY_MASS`] kg and [`TINY_INERTIA`] kg·m² (MuJoCo refuses a body with joints and no
//! mass; its M then differs from robosim's by that much, far below any physical quantity).
//! Each change is returned as a note and printed by the command.
//!
//! Geometry ([`to_mjcf_with_geometry`], [`crate::export_geometry`]): the `visual` (contype 0,
//! conaffinity 0, group 2) and `collision` (contype/conaffinity 1, group 3) default classes,
//! a geom of each class per shape that is drawn / collided, placed in its body by the general
//! model's frame (the base placement folded into the link-0 body's geoms), primitives as MJCF
//! primitives and anything else an `<asset><mesh file>` written as binary STL beside the file.
//! Quaternions by Shepperd's method (`UnitQuaternion::from_matrix`, iterative from the
//! identity, returned a half-turn rotation unturned).
//!
//! A ball (spherical) joint is `type="ball"` at its placement (no axis, no range: robosim has
//! no cone limit); MuJoCo's qpos holds its quaternion `w x y z`, robosim's q `x y z w`, and both
//! v are the angular velocity in the child frame. Mimic joints ([`to_mjcf_with_geometry`]'s
//! coupling): an `<equality><joint joint1 joint2 polycoef="offset multiplier 0 0 0">` per
//! follower (MuJoCo's `y − y₀ = a₀ + a₁ (x − x₀)` with no `ref`: y₀ = x₀ = 0), which MuJoCo
//! enforces softly when it simulates (its FK and M at a qpos do not depend on it).

use crate::export_geometry::{
    ExportShapes, Exported, MeshFile, ShapeKind, exported_frames, mesh_file,
};
use crate::inertial::{TINY_INERTIA, TINY_MASS, loadable_inertial};
use crate::urdf::{link_name, mimic_relations};
use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3};
use robosim_kinematics::mimic::Coupling;
use robosim_kinematics::{Joint, JointType, Robot, chain::to_general};
use std::fmt::Write as _;

/// A moving body's `<inertial>` line (indented by two spaces), with the mass and inertia
/// [`loadable_inertial`] makes of `mass` and `inertia` (about `com`, in the body's frame).
fn inertial_element(
    com: &Vector3<f64>,
    mass: f64,
    inertia: &Matrix3<f64>,
    what: &str,
    notes: &mut Vec<String>,
) -> String {
    let (mass, i) = loadable_inertial(mass, inertia, what, notes);
    format!(
        "  <inertial pos=\"{}\" mass=\"{mass:?}\" fullinertia=\"{:?} {:?} {:?} {:?} {:?} {:?}\"/>\n",
        v3(com),
        i[(0, 0)],
        i[(1, 1)],
        i[(2, 2)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 2)]
    )
}

fn v3(v: &Vector3<f64>) -> String {
    format!("{:?} {:?} {:?}", v.x, v.y, v.z)
}

/// `pos="…" quat="…"` of a rigid transform.
fn frame_attrs(m: &Matrix4<f64>) -> String {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    // Shepperd's method on the rotation as it is (`from_matrix` iterates from the identity
    // and does not reach a half-turn: a box turned 180° came out at its start)
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let p: Vector3<f64> = m.fixed_view::<3, 1>(0, 3).into_owned();
    format!(
        "pos=\"{}\" quat=\"{:?} {:?} {:?} {:?}\"",
        v3(&p),
        q.w,
        q.i,
        q.j,
        q.k
    )
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The robot as MJCF text (see the module docs) and the notes on what was changed to make it
/// loadable. Refused: a model that does not validate.
pub fn to_mjcf(robot: &Robot) -> Result<(String, Vec<String>), String> {
    to_mjcf_with_geometry(robot, None, None, "").map(|(text, notes, _)| (text, notes))
}

/// The `<geom>`s of link frame `frame` (see [`crate::export_geometry`]), each line indented by
/// two spaces: a shape that is visual gets a geom of class `visual`, one that collides a geom
/// of class `collision` (named `<shape>_visual` / `<shape>_collision`), placed at `x · origin`
/// in the body; a mesh is the asset `<shape>` (added to `assets`, its file to `meshes`).
fn body_geoms(
    geometry: Option<&ExportShapes<'_>>,
    frame: usize,
    x: &Matrix4<f64>,
    prefix: &str,
    assets: &mut String,
    meshes: &mut Vec<MeshFile>,
) -> String {
    let mut out = String::new();
    let Some(g) = geometry else {
        return out;
    };
    for s in g.on(frame) {
        let at = frame_attrs(&(x * s.object.placement));
        let name = xml(&s.name);
        let shape = match &s.kind {
            ShapeKind::Box { size } => format!(
                "type=\"box\" size=\"{:?} {:?} {:?}\"",
                size[0] / 2.0,
                size[1] / 2.0,
                size[2] / 2.0
            ),
            ShapeKind::Cylinder { radius, length } => {
                format!("type=\"cylinder\" size=\"{radius:?} {:?}\"", length / 2.0)
            }
            ShapeKind::Sphere { radius } => format!("type=\"sphere\" size=\"{radius:?}\""),
            ShapeKind::Mesh { .. } => {
                if let Some(file) = mesh_file(s, prefix, meshes) {
                    let _ = writeln!(
                        assets,
                        "    <mesh name=\"{name}\" file=\"{}\"/>",
                        xml(&file)
                    );
                }
                format!("type=\"mesh\" mesh=\"{name}\"")
            }
        };
        if s.visual {
            let rgba = match s.object.rgba {
                Some([r, g, b, a]) => format!(" rgba=\"{r:?} {g:?} {b:?} {a:?}\""),
                None => String::new(),
            };
            let _ = writeln!(
                out,
                "  <geom name=\"{name}_visual\" class=\"visual\" {shape} {at}{rgba}/>"
            );
        }
        if s.collision {
            let _ = writeln!(
                out,
                "  <geom name=\"{name}_collision\" class=\"collision\" {shape} {at}/>"
            );
        }
    }
    out
}

/// [`to_mjcf`] with the robot's mimic coupling and geometry ([`crate::export_geometry`]): each
/// follower an `<equality><joint joint1 joint2 polycoef="offset multiplier 0 0 0">`
/// ([`crate::urdf::mimic_relations`]; a fixed follower without `joint2`, `polycoef="offset 0 0
/// 0 0"`), geoms of the `visual` and `collision` classes in each body, meshes as
/// `<asset><mesh file>` with the files to write beside the MJCF (`<mesh_prefix><shape>.stl`,
/// relative to its folder).
///
/// Steps: the header ([`header`]), the joints' bodies from the last up so each holds its
/// children ([`MjcfWriter::joint_body`]), the link-0 body holding them
/// ([`MjcfWriter::root_body`]), the mimic equalities ([`equality`]), and the assets the bodies
/// named, inserted after the header.
pub fn to_mjcf_with_geometry(
    robot: &Robot,
    coupling: Option<&Coupling>,
    geometry: Option<&robosim_model::GeometryModel>,
    mesh_prefix: &str,
) -> Result<(String, Vec<String>, Vec<MeshFile>), String> {
    to_mjcf_with_shapes(robot, coupling, geometry.map(ExportShapes::of), mesh_prefix)
}

/// [`to_mjcf_with_geometry`] with the geometry already made into the shapes the file writes (their mesh
/// files read once): for a caller that also counts them.
pub fn to_mjcf_with_shapes(
    robot: &Robot,
    coupling: Option<&Coupling>,
    shapes: Option<ExportShapes<'_>>,
    mesh_prefix: &str,
) -> Result<(String, Vec<String>, Vec<MeshFile>), String> {
    robot
        .validate()
        .map_err(|e| format!("robot {}: {e}", robot.name))?;
    let mimics = match coupling {
        Some(c) => mimic_relations(robot, c)?,
        None => Vec::new(),
    };
    let xs = exported_frames(robot, Exported::Mjcf);
    let mut w = MjcfWriter {
        robot,
        g: to_general(robot),
        name: xml(&robot.name),
        notes: Vec::new(),
        meshes: Vec::new(),
        assets: String::new(),
        shapes,
        xs,
        prefix: mesh_prefix,
    };
    let mut out = header(&w.name, robot);
    // The asset section goes here once the bodies have named their meshes.
    let asset_at = out.len();
    let _ = writeln!(out, "  <worldbody>");
    // Bodies as a tree: children of link k are the joints whose parent is k.
    let n = w.g.dof();
    let mut bodies: Vec<String> = vec![String::new(); n + 1];
    for j in (0..n).rev() {
        let children = std::mem::take(&mut bodies[j + 1]);
        let body = w.joint_body(j, &children)?;
        // Prepend: children were visited in reverse, so the file keeps joint order.
        let parent = w.g.parent(j);
        bodies[parent] = body + &bodies[parent];
    }
    let root = w.root_body(&bodies[0]);
    for line in root.lines() {
        let _ = writeln!(out, "    {line}");
    }
    let _ = writeln!(out, "  </worldbody>");
    out += &equality(&w.name, &mimics);
    let _ = writeln!(out, "</mujoco>");
    let MjcfWriter {
        mut notes,
        meshes,
        assets,
        shapes,
        ..
    } = w;
    if !assets.is_empty() {
        out.insert_str(asset_at, &format!("  <asset>\n{assets}  </asset>\n"));
    }
    if let Some(g) = shapes {
        notes.extend(g.notes);
    }
    Ok((out, notes, meshes))
}

/// `<mujoco>` with the comment saying what it was written from, the compiler, the gravity and
/// the `visual` and `collision` default classes.
fn header(name: &str, robot: &Robot) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "<mujoco model=\"{name}\">");
    let _ = writeln!(
        out,
        "  <!-- Written by robosim from the joint model of {name} (docs/file-io.md, \"MJCF export\"). -->"
    );
    let _ = writeln!(out, "  <compiler angle=\"radian\" autolimits=\"true\"/>");
    let _ = writeln!(out, "  <option gravity=\"{}\"/>", v3(&robot.gravity));
    let _ = writeln!(
        out,
        "  <default>\n    <default class=\"visual\">\n      <geom contype=\"0\" conaffinity=\"0\" group=\"2\"/>\n    </default>\n    <default class=\"collision\">\n      <geom contype=\"1\" conaffinity=\"1\" group=\"3\"/>\n    </default>\n  </default>"
    );
    out
}

/// The `<equality>` section: per follower MuJoCo's mimic joint, y − y₀ = a₀ + a₁ (x − x₀),
/// y₀ = x₀ = 0 (no joint has a `ref`: MuJoCo's q is robosim's); empty without followers.
fn equality(name: &str, mimics: &[robosim_kinematics::mimic::Mimic]) -> String {
    let mut out = String::new();
    if mimics.is_empty() {
        return out;
    }
    let _ = writeln!(out, "  <equality>");
    for m in mimics {
        let joint2 = m.leader.map_or(String::new(), |l| {
            format!(" joint2=\"{name}_joint{}\"", l + 1)
        });
        let _ = writeln!(
            out,
            "    <joint name=\"{name}_mimic{}\" joint1=\"{name}_joint{}\"{joint2} polycoef=\"{:?} {:?} 0 0 0\"/>",
            m.follower + 1,
            m.follower + 1,
            m.offset,
            m.multiplier
        );
    }
    let _ = writeln!(out, "  </equality>");
    out
}

/// The MJCF bodies being written, with what the writing collects (notes, assets, mesh files).
struct MjcfWriter<'a> {
    robot: &'a Robot,
    /// The robot in the general joint model ([`to_general`]): the bodies' frames.
    g: Robot,
    /// The robot's name, XML-escaped.
    name: String,
    notes: Vec<String>,
    meshes: Vec<MeshFile>,
    /// The `<asset>` lines of the meshes the geoms name.
    assets: String,
    shapes: Option<ExportShapes<'a>>,
    /// Per robosim link frame, its placement in the body ([`exported_frames`]).
    xs: Vec<Matrix4<f64>>,
    prefix: &'a str,
}

impl MjcfWriter<'_> {
    /// The geoms of link frame `frame` ([`body_geoms`]).
    fn geoms(&mut self, frame: usize) -> String {
        body_geoms(
            self.shapes.as_ref(),
            frame,
            &self.xs[frame],
            self.prefix,
            &mut self.assets,
            &mut self.meshes,
        )
    }

    /// The body of joint `j` (link j + 1) at its placement times its motion at the offset
    /// (the base placement multiplied in for a body on the base), with its joint, inertial,
    /// geoms, the tool body on the last link, and `children` (its child bodies) inside.
    fn joint_body(&mut self, j: usize, children: &str) -> Result<String, String> {
        let (robot, name) = (self.robot, self.name.clone());
        let joint = &self.g.joints[j];
        let Some(origin) = joint.origin else {
            return Err(format!(
                "robot {}: joint {j} has no origin after to_general",
                robot.name
            ));
        };
        // (a ball joint's q = the identity quaternion is its placement alone)
        let at = if joint.spherical {
            origin.placement
        } else {
            origin.placement
                * robosim_kinematics::JointGeometry {
                    joint_type: joint.joint_type,
                    placement: None,
                    axis: origin.axis,
                    offset: joint.offset,
                    trailing: None,
                }
                .motion(0.0)
        };
        // The base placement goes into the bodies on the base: Pinocchio 4.1's MJCF reader
        // drops the pos and quat of a joint-less body on the world.
        // (A floating robot's base placement is its base body's pose instead.)
        let at = if self.g.parent(j) == 0 && robot.root.is_none() {
            self.g.base * at
        } else {
            at
        };
        let link = xml(&link_name(robot, j + 1));
        let mut body = String::new();
        let _ = writeln!(body, "<body name=\"{link}\" {}>", frame_attrs(&at));
        let _ = writeln!(
            body,
            "  <joint name=\"{name}_joint{}\" {}/>",
            j + 1,
            joint_attrs(robot, j, joint, &origin.axis)?
        );
        let (com, mass, inertia) = (joint.com, joint.mass, joint.inertia);
        let last = j + 1 == self.g.dof();
        let tool = frame_attrs(&self.g.tool);
        body += &inertial_element(
            &com,
            mass,
            &inertia,
            &format!("link {}", j + 1),
            &mut self.notes,
        );
        body += &self.geoms(j + 1);
        if last {
            let _ = writeln!(
                body,
                "  <body name=\"{}\" {tool}/>",
                xml(&format!("{}_tool", robot.name)),
            );
        }
        for line in children.lines() {
            let _ = writeln!(body, "  {line}");
        }
        let _ = writeln!(body, "</body>");
        Ok(body)
    }

    /// The link-0 body (at the world's origin, or a floating robot's base placement) with its
    /// root joint and inertial (floating), or a tiny inertial when it has geoms (welded), its
    /// geoms, the tool when the robot has no joint, and `children` (the bodies on the base).
    fn root_body(&mut self, children: &str) -> String {
        let robot = self.robot;
        let name = self.name.clone();
        let mut root = String::new();
        let _ = writeln!(
            root,
            "<body name=\"{}\" {}>",
            xml(&link_name(robot, 0)),
            frame_attrs(&if robot.root.is_some() {
                self.g.base
            } else {
                Matrix4::identity()
            })
        );
        let base_geoms = self.geoms(0);
        if let Some(r) = &robot.root {
            root += &root_joint(&name, r.kind);
            root += &inertial_element(&r.com, r.mass, &r.inertia, "link 0", &mut self.notes);
        } else if !base_geoms.is_empty() {
            // A body with geoms and no <inertial> would have its inertia inferred from them
            // (inertiafromgeom="auto"), which Pinocchio's MJCF reader and robosim's cannot do
            // for meshes; the base is welded to the world, so what it weighs changes nothing.
            let _ = writeln!(
                root,
                "  <inertial pos=\"0 0 0\" mass=\"{TINY_MASS:?}\" diaginertia=\"{TINY_INERTIA:?} {TINY_INERTIA:?} {TINY_INERTIA:?}\"/>"
            );
        }
        root += &base_geoms;
        if self.g.dof() == 0 {
            let _ = writeln!(
                root,
                "  <body name=\"{}\" {}/>",
                xml(&format!("{}_tool", robot.name)),
                frame_attrs(&if robot.root.is_some() {
                    self.g.tool
                } else {
                    self.g.base * self.g.tool
                })
            );
        }
        for line in children.lines() {
            let _ = writeln!(root, "  {line}");
        }
        let _ = writeln!(root, "</body>");
        root
    }
}

/// A `<joint>`'s attributes after its name: type (`ball`, `hinge`, `slide`), axis, range (or
/// `limited="false"`), damping, frictionloss, armature. Refused: a half-bounded range.
fn joint_attrs(
    robot: &Robot,
    j: usize,
    joint: &Joint,
    axis: &Vector3<f64>,
) -> Result<String, String> {
    let kind = match joint.joint_type {
        _ if joint.spherical => "ball",
        JointType::Revolute => "hinge",
        JointType::Prismatic => "slide",
    };
    let [lo, hi] = joint.qlim;
    // a ball joint: no axis, and no range (robosim has no cone limit on it)
    let axis = if joint.spherical {
        String::new()
    } else {
        format!(" axis=\"{}\"", v3(axis))
    };
    let range = if joint.spherical {
        "limited=\"false\"".to_string()
    } else if lo.is_finite() && hi.is_finite() {
        format!("range=\"{lo:?} {hi:?}\"")
    } else if lo == f64::NEG_INFINITY && hi == f64::INFINITY {
        "limited=\"false\"".to_string()
    } else {
        return Err(format!(
            "robot {}: joint {j} has limits [{lo}, {hi}]; MJCF has no half-bounded joint",
            robot.name
        ));
    };
    Ok(format!(
        "type=\"{kind}\"{axis} {range} damping=\"{:?}\" frictionloss=\"{:?}\" armature=\"{:?}\"",
        joint.viscous, joint.coulomb, joint.motor_inertia
    ))
}

/// A floating base's root joint lines: a free joint (MuJoCo's qpos x y z qw qx qy qz with the
/// linear velocity in the world frame; robosim's and Pinocchio's x y z qx qy qz qw with it in
/// the base frame), or a planar root as MuJoCo's x and y slides and a z hinge (qpos x y θ,
/// robosim's x y cos θ sin θ). The body is placed at the robot's base as its qpos0.
fn root_joint(name: &str, kind: robosim_kinematics::RootKind) -> String {
    let mut out = String::new();
    match kind {
        robosim_kinematics::RootKind::FreeFlyer => {
            let _ = writeln!(out, "  <freejoint name=\"{name}_root\"/>");
        }
        robosim_kinematics::RootKind::Planar => {
            for (axis, kind, dir) in [
                ("x", "slide", "1 0 0"),
                ("y", "slide", "0 1 0"),
                ("yaw", "hinge", "0 0 1"),
            ] {
                let _ = writeln!(
                    out,
                    "  <joint name=\"{name}_root_{axis}\" type=\"{kind}\" axis=\"{dir}\" limited=\"false\"/>"
                );
            }
        }
    }
    out
}
