//! URDF export of a robot (issue #15 item 3, issue #14 item 4): a DH chain, or a robot of the
//! general joint model (imported from URDF, or edited) and kinematic trees, written as URDF
//! joint origins and axes with its inertials, limits and friction, so that other tools
//! (Pinocchio, MoveIt, MuJoCo's URDF loader) read the robot we built.
//!
//! Frames. URDF moves a child link by `origin · motion(q)` with the motion about (revolute) or
//! along (prismatic) the joint's axis, here always z. A DH link transform splits the same way:
//! standard DH `A(q) = Rz(θ) Tz(d) · Tx(a) Rx(α)`, whose first part is a motion about/along z
//! after a constant part; modified DH `A(q) = Rx(α) Tx(a) Rz(θ) Tz(d)`, all before the motion
//! (Rz and Tz commute). With `P_j = Tx(a_j) Rx(α_j)` (standard) or `I` (modified), URDF link `j`
//! is the DH frame `j` without its trailing constant part, `L_j = F_j · P_j⁻¹`, and
//!
//! ```text
//! origin_j = P_{j-1} · A_j(0) · P_j⁻¹        motion: Rz(q) or Tz(q)
//! ```
//!
//! (`P_0 = I`). A **general** joint (`Joint::origin`, `A_j = P_j · M_j(q + offset)`) has no
//! trailing part: its `P_j` (above) is the identity, its URDF origin is `P_j · M_j(offset)`
//! written in the URDF link of its parent, and its axis is its own (`<axis xyz>`, each number
//! in its shortest exact form; a DH joint's axis is `0 0 1`). A **tree** ([`Robot::parents`]):
//! joint j's parent link is the link of frame `parents[j]`, and `P_{j-1}` above becomes the
//! trailing part of that frame; joints are written in robosim's order, so a robot whose joints
//! are in depth-first order (as `import_urdf_tree` numbers them) is re-imported with the same
//! q. A revolute joint with limits `[−∞, ∞]` is written `continuous`; a revolute or prismatic
//! joint with only one infinite limit is refused (URDF cannot say it). The robot's base placement is a fixed joint from a root link `world`; the tool
//! is a fixed joint to a link `tool` with origin `P_n · tool`. Each link's inertial is its DH
//! link's centre of mass and inertia, placed by `P_j` (the inertia tensor is written in the DH
//! frame's axes, which the inertial origin's rpy names).
//!
//! Every moving link has an `<inertial>`: a massless one gets
//! [`crate::inertial::TINY_MASS`] (MuJoCo's URDF loader refuses a moving link without mass;
//! Pinocchio does not care), and an inertia breaking A + B ≥ C is made physical
//! ([`crate::inertial::physical_inertia`]); [`to_urdf_with_notes`] says which link and what.
//!
//! Not in URDF, so not written: gravity, the motor (rotor) inertia (Pinocchio's "armature";
//! noted in a comment per joint when non-zero), velocity and effort limits (robosim does not
//! model them: written as 0, which URDF readers take as "unknown").
//!
//! A **floating** robot ([`Robot::root`]) is written as ROS and Pinocchio write one: the base
//! link `<robot>_link0` is the file's root link, with the root's inertial, and there is no
//! `world` link nor a joint to it (URDF's `floating` joint type is not read by urdfdom's users
//! as a root joint; Pinocchio adds one with `buildModelFromUrdf(path, JointModelFreeFlyer())`).
//! The base placement is then not written: the root's coordinates are the base link's pose in
//! the file's world (a note says so when the robot's base is not the identity).
//!
//! Geometry ([`to_urdf_with_geometry`], [`crate::export_geometry`]): each link's `<visual>` and
//! `<collision>` elements, a shape's placement in robosim's link frame j moved into URDF link j
//! by `P_j`; primitives as URDF primitives, anything else a binary STL beside the file.
//!
//! Mimic joints ([`to_urdf_with_geometry`]'s coupling, [`mimic_relations`]): the [`Robot`] has
//! every joint a coordinate; the coupling beside it says which follow which, and each follower
//! gets `<mimic joint multiplier offset>` naming its (resolved, free) leader. URDF's q is
//! robosim's (the offset is in the origin), so the numbers are the coupling's. Without the
//! coupling the file would be another robot (every follower free): the export API takes it.
//! A ball (spherical) joint is refused by name: URDF has no ball joint.

use crate::export_geometry::{
    ExportShapes, Exported, MeshFile, ShapeKind, exported_frames, mesh_file, post, rigid_inverse,
};
use crate::inertial::loadable_inertial;
use nalgebra::{Matrix3, Matrix4, Rotation3};
use robosim_kinematics::mimic::{Coupling, Mimic};
use robosim_kinematics::{Convention, Joint, JointType, Robot, fk::link_transform};
use std::fmt::Write as _;

/// The mimic relations a coupling imposes on `robot`'s joints, one per follower in joint
/// order, each resolved to a free coordinate (`q_f = multiplier · q_leader + offset`, a
/// follower of a follower composed; `leader: None` — fixed at `offset`, its leader not part of
/// the robot), read from the coupling's public map: the multiplier from `G`'s row, the offset
/// from `φ(0)`. Refused: a coupling that is not this robot's (its number of joints, q or v).
pub fn mimic_relations(robot: &Robot, coupling: &Coupling) -> Result<Vec<Mimic>, String> {
    let (root_nq, root_nv) = (robot.root_nq(), robot.root_nv());
    if coupling.full_dof() != robot.dof()
        || coupling.full_nq() != robot.nq()
        || coupling.full_nv() != robot.nv()
    {
        return Err(format!(
            "robot {}: the mimic coupling is over {} joints ({} q, {} v), the robot has {} ({} q, {} v)",
            robot.name,
            coupling.full_dof(),
            coupling.full_nq(),
            coupling.full_nv(),
            robot.dof(),
            robot.nq(),
            robot.nv()
        ));
    }
    let g = coupling.matrix();
    let q0 = coupling
        .expand_q(&vec![0.0; coupling.reduced_nq()])
        .map_err(|e| format!("robot {}: mimic coupling: {e}", robot.name))?;
    let free = coupling.free();
    Ok((0..robot.dof())
        .filter(|&i| coupling.is_follower(i))
        .map(|i| {
            let row = root_nv + i;
            // one non-zero per follower's row (none: fixed, or a zero multiplier)
            let leader = (0..free.len()).find(|&k| g[(row, root_nv + k)] != 0.0);
            Mimic {
                follower: i,
                leader: leader.map(|k| free[k]),
                multiplier: leader.map_or(0.0, |k| g[(row, root_nv + k)]),
                offset: q0[root_nq + i],
            }
        })
        .collect())
}

/// `xyz="…" rpy="…"` of a rigid transform, URDF's fixed-axis roll, pitch, yaw
/// (`R = Rz(yaw) Ry(pitch) Rx(roll)`), every number in its shortest exact form. `rpy` chooses
/// how the angles are found: nalgebra's `euler_angles` (the DH files, unchanged since they were
/// checked against Pinocchio) or [`rpy_stable`] (the general model).
fn origin_attrs_with(m: &Matrix4<f64>, rpy: fn(&Matrix3<f64>) -> [f64; 3]) -> String {
    let [roll, pitch, yaw] = rpy(&m.fixed_view::<3, 3>(0, 0).into_owned());
    format!(
        "xyz=\"{:?} {:?} {:?}\" rpy=\"{roll:?} {pitch:?} {yaw:?}\"",
        m[(0, 3)],
        m[(1, 3)],
        m[(2, 3)]
    )
}

fn rpy_nalgebra(r: &Matrix3<f64>) -> [f64; 3] {
    let (roll, pitch, yaw) = Rotation3::from_matrix_unchecked(*r).euler_angles();
    [roll, pitch, yaw]
}

/// Roll, pitch, yaw of a rotation such that `Rz(yaw) Ry(pitch) Rx(roll)` gives it back to a few
/// ulps **also near pitch = ±π/2** (the UR arms' `rpy="0 1.570796325 0"`), where reading the
/// angles from single entries (`asin`) loses up to half the digits: yaw from the first column,
/// then roll and pitch from `Rz(yaw)ᵀ R = Ry(pitch) Rx(roll)`, whose second row `(0, cos roll,
/// −sin roll)` is not scaled by `cos pitch`.
pub fn rpy_stable(r: &Matrix3<f64>) -> [f64; 3] {
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    let (sy, cy) = yaw.sin_cos();
    // Rows of Rz(yaw)ᵀ R: row0 = cy·r0 + sy·r1, row1 = −sy·r0 + cy·r1, row2 = r2.
    let row0_0 = cy * r[(0, 0)] + sy * r[(1, 0)];
    let row1_1 = -sy * r[(0, 1)] + cy * r[(1, 1)];
    let row1_2 = -sy * r[(0, 2)] + cy * r[(1, 2)];
    let roll = (-row1_2).atan2(row1_1);
    let pitch = (-r[(2, 0)]).atan2(row0_0);
    [roll, pitch, yaw]
}

fn origin_attrs(m: &Matrix4<f64>) -> String {
    origin_attrs_with(m, rpy_nalgebra)
}

/// XML text of a name (robot and link names are library identifiers, but say it safely).
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The link names of the URDF: `world`, `<robot>_link0` … `<robot>_link<n>`, `<robot>_tool`.
pub fn link_name(robot: &Robot, j: usize) -> String {
    format!("{}_link{j}", robot.name)
}

/// The robot as URDF text (see the module docs). Refused: a model that does not validate
/// (non-finite fields, reversed limits), with the model's own message, and a revolute or
/// prismatic joint with a half-infinite range (or an infinite prismatic one).
pub fn to_urdf(robot: &Robot) -> Result<String, String> {
    to_urdf_with_notes(robot).map(|(text, _)| text)
}

/// [`to_urdf`] and what was changed to make the file loadable by MuJoCo too (inertias made
/// physical, massless links given a tiny mass; [`crate::inertial::physical_inertia`]).
pub fn to_urdf_with_notes(robot: &Robot) -> Result<(String, Vec<String>), String> {
    to_urdf_with_geometry(robot, None, None, "").map(|(text, notes, _)| (text, notes))
}

/// The `<visual>` and `<collision>` elements of link frame `frame` (see
/// [`crate::export_geometry`]): each shape's placement `x · origin` in the URDF link (`x` the
/// frame's [`crate::export_geometry::exported_frames`] entry), primitives as URDF primitives,
/// meshes as files `<prefix><shape>.stl` beside the URDF (added to `meshes`).
fn link_geometry(
    geometry: Option<&ExportShapes<'_>>,
    frame: usize,
    x: &Matrix4<f64>,
    prefix: &str,
    meshes: &mut Vec<MeshFile>,
) -> String {
    let mut out = String::new();
    let Some(g) = geometry else {
        return out;
    };
    for s in g.on(frame) {
        let origin = origin_attrs_with(&(x * s.object.placement), rpy_stable);
        let geom = match &s.kind {
            ShapeKind::Box { size } => {
                format!("<box size=\"{:?} {:?} {:?}\"/>", size[0], size[1], size[2])
            }
            ShapeKind::Cylinder { radius, length } => {
                format!("<cylinder radius=\"{radius:?}\" length=\"{length:?}\"/>")
            }
            ShapeKind::Sphere { radius } => format!("<sphere radius=\"{radius:?}\"/>"),
            ShapeKind::Mesh { .. } => format!(
                "<mesh filename=\"{}\"/>",
                xml(&mesh_file(s, prefix, meshes).unwrap_or_default())
            ),
        };
        let name = xml(&s.name);
        if s.visual {
            let material = match s.object.rgba {
                Some([r, g, b, a]) => format!(
                    "\n      <material name=\"{name}_material\"><color rgba=\"{r:?} {g:?} {b:?} {a:?}\"/></material>"
                ),
                None => String::new(),
            };
            let _ = writeln!(
                out,
                "    <visual name=\"{name}\">\n      <origin {origin}/>\n      <geometry>{geom}</geometry>{material}\n    </visual>"
            );
        }
        if s.collision {
            let _ = writeln!(
                out,
                "    <collision name=\"{name}\">\n      <origin {origin}/>\n      <geometry>{geom}</geometry>\n    </collision>"
            );
        }
    }
    out
}

/// [`to_urdf_with_notes`] with the robot's mimic coupling and geometry
/// ([`crate::export_geometry`]): each follower joint's `<mimic joint multiplier offset>`
/// ([`mimic_relations`]; a follower fixed at its offset, its leader not part of the robot, as a
/// mimic of the first free joint with multiplier 0, noted), each link's `<visual>` and
/// `<collision>` elements, and the mesh files to write beside the URDF (names
/// `<mesh_prefix><shape>.stl`: relative to the URDF's folder, or absolute when the prefix is).
/// Without coupling and geometry the file is byte for byte [`to_urdf`]'s.
///
/// Steps: refuse what URDF cannot say ([`refuse_unwritable`]), each follower's `<mimic>`
/// ([`urdf_mimics`]), then the file from the top down — header, base link and its joint to
/// `world` ([`UrdfWriter::base`]), per joint its link and joint ([`UrdfWriter::joint`]), the
/// tool ([`UrdfWriter::tool`]).
pub fn to_urdf_with_geometry(
    robot: &Robot,
    coupling: Option<&Coupling>,
    geometry: Option<&robosim_model::GeometryModel>,
    mesh_prefix: &str,
) -> Result<(String, Vec<String>, Vec<MeshFile>), String> {
    to_urdf_with_shapes(robot, coupling, geometry.map(ExportShapes::of), mesh_prefix)
}

/// [`to_urdf_with_geometry`] with the geometry already made into the shapes the file writes (their mesh
/// files read once): for a caller that also counts them.
pub fn to_urdf_with_shapes(
    robot: &Robot,
    coupling: Option<&Coupling>,
    shapes: Option<ExportShapes<'_>>,
    mesh_prefix: &str,
) -> Result<(String, Vec<String>, Vec<MeshFile>), String> {
    let mut notes = Vec::new();
    let mimics = refuse_unwritable(robot, coupling, &mut notes)?;
    let mut w = UrdfWriter {
        robot,
        general: !robot.is_chain() || robot.joints.iter().any(|j| j.is_general()),
        name: xml(&robot.name),
        out: String::new(),
        notes,
        meshes: Vec::new(),
        shapes,
        xs: exported_frames(robot, Exported::Urdf),
        prefix: mesh_prefix,
    };
    w.header();
    w.base();
    // posts[k]: the trailing part of link frame k (P_k above; the identity for the base and
    // for a general joint).
    let mut posts: Vec<Option<Matrix4<f64>>> = vec![None; robot.dof() + 1];
    for (k, j) in robot.joints.iter().enumerate() {
        posts[k + 1] = w.joint(k, j, &posts, mimics[k]);
    }
    w.tool(&posts);
    let UrdfWriter {
        out,
        mut notes,
        meshes,
        shapes,
        ..
    } = w;
    if let Some(g) = shapes {
        notes.extend(g.notes);
    }
    Ok((out, notes, meshes))
}

/// What URDF cannot say, refused with the robot's name: a ball joint, a model that does not
/// validate, a coupling that is not the robot's ([`urdf_mimics`]), a revolute or prismatic
/// joint with a half-infinite range (or an infinite prismatic one). Returns each joint's
/// `<mimic>` (leader, multiplier, offset).
fn refuse_unwritable(
    robot: &Robot,
    coupling: Option<&Coupling>,
    notes: &mut Vec<String>,
) -> Result<Vec<Option<(usize, f64, f64)>>, String> {
    if let Some(k) = robot.joints.iter().position(|j| j.spherical) {
        // written as a hinge it would load as a different robot: refused by name instead
        return Err(format!(
            "robot {}: joint {k} is a ball (spherical) joint; URDF has no ball joint",
            robot.name
        ));
    }
    robot
        .validate()
        .map_err(|e| format!("robot {}: {e}", robot.name))?;
    let mimics = urdf_mimics(robot, coupling, notes)?;
    for (k, j) in robot.joints.iter().enumerate() {
        let [lo, hi] = j.qlim;
        let continuous =
            j.joint_type == JointType::Revolute && lo == f64::NEG_INFINITY && hi == f64::INFINITY;
        if !(continuous || lo.is_finite() && hi.is_finite()) {
            return Err(format!(
                "robot {}: joint {k} has limits [{lo}, {hi}]; URDF has no half-bounded or unbounded {} joint",
                robot.name,
                match j.joint_type {
                    JointType::Revolute => "revolute",
                    JointType::Prismatic => "prismatic",
                }
            ));
        }
    }
    Ok(mimics)
}

/// Each joint's `<mimic>` (leader, multiplier, offset) from the coupling ([`mimic_relations`]):
/// a follower fixed at its offset (its leader not part of the robot) follows the first free
/// joint with multiplier 0, noted; refused when no joint is free.
fn urdf_mimics(
    robot: &Robot,
    coupling: Option<&Coupling>,
    notes: &mut Vec<String>,
) -> Result<Vec<Option<(usize, f64, f64)>>, String> {
    let mut mimics: Vec<Option<(usize, f64, f64)>> = vec![None; robot.dof()];
    let Some(c) = coupling else {
        return Ok(mimics);
    };
    for m in mimic_relations(robot, c)? {
        let leader = match m.leader {
            Some(l) => l,
            None => {
                // URDF's <mimic> needs a leader: a fixed follower follows a free joint ×0
                let Some(&l) = c.free().first() else {
                    return Err(format!(
                        "robot {}: joint {} is fixed at {} by a mimic of a joint that is not part of the robot, and no joint is free to name as its leader (URDF's <mimic> needs one)",
                        robot.name, m.follower, m.offset
                    ));
                };
                notes.push(format!(
                    "joint {}: fixed at {} by a mimic of a joint that is not part of the robot; written as a mimic of joint {} with multiplier 0",
                    m.follower + 1,
                    m.offset,
                    l + 1
                ));
                l
            }
        };
        mimics[m.follower] = Some((leader, m.multiplier, m.offset));
    }
    Ok(mimics)
}

/// The URDF text being written, with what the writing collects (notes, mesh files).
struct UrdfWriter<'a> {
    robot: &'a Robot,
    /// Written as origins and axes (a tree, or a joint of the general model), not DH.
    general: bool,
    /// The robot's name, XML-escaped.
    name: String,
    out: String,
    notes: Vec<String>,
    meshes: Vec<MeshFile>,
    shapes: Option<ExportShapes<'a>>,
    /// Per robosim link frame, its placement in the URDF link ([`exported_frames`]).
    xs: Vec<Matrix4<f64>>,
    prefix: &'a str,
}

impl UrdfWriter<'_> {
    /// An `<origin>`'s attributes (the stable rpy for a general robot, so a DH chain's file is
    /// unchanged byte for byte).
    /// A link's `<inertial>` element (mass and inertia made loadable by
    /// [`loadable_inertial`]'s rules, each change noted; `frame` the inertial frame in the link).
    fn inertial(
        &mut self,
        mass: f64,
        inertia: &Matrix3<f64>,
        what: &str,
        frame: &Matrix4<f64>,
    ) -> String {
        let (mass, m) = loadable_inertial(mass, inertia, what, &mut self.notes);
        format!(
            "    <inertial>\n      <origin {}/>\n      <mass value=\"{mass:?}\"/>\n      <inertia ixx=\"{:?}\" ixy=\"{:?}\" ixz=\"{:?}\" iyy=\"{:?}\" iyz=\"{:?}\" izz=\"{:?}\"/>\n    </inertial>\n",
            self.oa(frame),
            m[(0, 0)],
            m[(0, 1)],
            m[(0, 2)],
            m[(1, 1)],
            m[(1, 2)],
            m[(2, 2)]
        )
    }

    fn oa(&self, m: &Matrix4<f64>) -> String {
        if self.general {
            origin_attrs_with(m, rpy_stable)
        } else {
            origin_attrs(m)
        }
    }

    /// The `<visual>`/`<collision>` elements of link frame `frame` ([`link_geometry`]).
    fn geometry(&mut self, frame: usize) -> String {
        link_geometry(
            self.shapes.as_ref(),
            frame,
            &self.xs[frame],
            self.prefix,
            &mut self.meshes,
        )
    }

    /// The XML declaration, the comment saying what the file was written from, `<robot>`.
    fn header(&mut self) {
        let (robot, name, out) = (self.robot, &self.name, &mut self.out);
        let _ = writeln!(out, "<?xml version=\"1.0\"?>");
        if self.general {
            let _ = writeln!(
                out,
                "<!-- Written by robosim from the joint model (origins and axes{}) of {name} (docs/file-io.md, \"URDF\"). -->",
                if robot.is_chain() { "" } else { ", a tree" }
            );
        } else {
            let _ = writeln!(
                out,
                "<!-- Written by robosim from the {} DH model of {name} (docs/file-io.md, \"URDF\"). -->",
                match robot.convention {
                    Convention::Standard => "standard",
                    Convention::Modified => "modified",
                }
            );
        }
        let _ = writeln!(out, "<robot name=\"{name}\">");
    }

    /// The base link with its geometry: a floating robot's root link with the root's inertial
    /// (see the module docs), else `world` and the base link fixed to it at the base placement.
    fn base(&mut self) {
        let robot = self.robot;
        let base_geometry = self.geometry(0);
        let base = xml(&link_name(robot, 0));
        if let Some(root) = &robot.root {
            self.floating_base(root, &base, &base_geometry);
            return;
        }
        let _ = writeln!(self.out, "  <link name=\"world\"/>");
        if base_geometry.is_empty() {
            let _ = writeln!(self.out, "  <link name=\"{base}\"/>");
        } else {
            let _ = write!(
                self.out,
                "  <link name=\"{base}\">\n{base_geometry}  </link>\n"
            );
        }
        let origin = self.oa(&robot.base);
        let _ = writeln!(
            self.out,
            "  <joint name=\"{}_base_joint\" type=\"fixed\">\n    <parent link=\"world\"/>\n    <child link=\"{base}\"/>\n    <origin {origin}/>\n  </joint>",
            self.name
        );
    }

    /// A floating base as ROS and Pinocchio write one: the base link is the file's root link
    /// (no `world`, no joint to it) with its inertial; the loader adds the root joint.
    fn floating_base(
        &mut self,
        root: &robosim_kinematics::RootJoint,
        base: &str,
        base_geometry: &str,
    ) {
        let robot = self.robot;
        let pin_joint = match root.kind {
            robosim_kinematics::RootKind::FreeFlyer => "JointModelFreeFlyer",
            robosim_kinematics::RootKind::Planar => "JointModelPlanar",
        };
        let _ = writeln!(
            self.out,
            "  <!-- Floating base ({}): {base} is the root link; load with a {} root joint (Pinocchio: buildModelFromUrdf(path, pin.{pin_joint}())). -->",
            root.kind.name(),
            root.kind.name(),
        );
        self.notes.push(format!(
            "floating base ({}): written as ROS and Pinocchio write one, {} the root link with no `world` link and no joint to it; load it with a {} root joint (Pinocchio: buildModelFromUrdf(path, pin.{pin_joint}()))",
            root.kind.name(),
            link_name(robot, 0),
            root.kind.name()
        ));
        if robot.base != Matrix4::identity() {
            self.notes.push(
                "floating base: the robot's base placement is not written (the root joint's coordinates are the base link's pose in the file's world); robosim's q with root q_r is the file's with root base · M(q_r)"
                    .to_string(),
            );
        }
        let inertial = self.inertial(
            root.mass,
            &root.inertia,
            "link 0",
            &Matrix4::new_translation(&root.com),
        );
        let _ = write!(
            self.out,
            "  <link name=\"{base}\">\n{inertial}{base_geometry}  </link>\n"
        );
    }

    /// Joint `k` (`j`): its child link (inertial, geometry) and the joint element with its
    /// `<mimic>`; `posts` the trailing parts written so far. Returns the trailing part of its
    /// link frame (`None`: the identity, a general joint).
    fn joint(
        &mut self,
        k: usize,
        j: &Joint,
        posts: &[Option<Matrix4<f64>>],
        mimic: Option<(usize, f64, f64)>,
    ) -> Option<Matrix4<f64>> {
        let robot = self.robot;
        let i = k + 1;
        let parent = robot.parent(k);
        let p = (!j.is_general()).then(|| post(robot.convention, j));
        let a0 = link_transform(robot.convention, j, 0.0);
        // (The DH path multiplies as it always has, identities included, so a DH chain's file
        // is unchanged byte for byte; a general joint skips the identity factors.)
        let origin = match (&posts[parent], &p) {
            (pp, Some(p)) => pp.unwrap_or_else(Matrix4::identity) * a0 * rigid_inverse(p),
            (Some(pp), None) => pp * a0,
            (None, None) => a0,
        };
        let child = xml(&link_name(robot, i));
        self.link(i, j, &child, p.as_ref());
        let continuous = j.joint_type == JointType::Revolute && j.qlim[0] == f64::NEG_INFINITY;
        let kind = match j.joint_type {
            JointType::Revolute if continuous => "continuous",
            JointType::Revolute => "revolute",
            JointType::Prismatic => "prismatic",
        };
        let axis = match &j.origin {
            Some(o) => format!("{:?} {:?} {:?}", o.axis.x, o.axis.y, o.axis.z),
            None => "0 0 1".to_string(),
        };
        let limit = if continuous {
            "<limit effort=\"0\" velocity=\"0\"/>".to_string()
        } else {
            format!(
                "<limit lower=\"{:?}\" upper=\"{:?}\" effort=\"0\" velocity=\"0\"/>",
                j.qlim[0], j.qlim[1]
            )
        };
        let (name, origin) = (&self.name, self.oa(&origin));
        let out = &mut self.out;
        let _ = writeln!(
            out,
            "  <joint name=\"{name}_joint{i}\" type=\"{kind}\">\n    <parent link=\"{}\"/>\n    <child link=\"{child}\"/>\n    <origin {origin}/>\n    <axis xyz=\"{axis}\"/>\n    {limit}\n    <dynamics damping=\"{:?}\" friction=\"{:?}\"/>",
            xml(&link_name(robot, parent)),
            j.viscous,
            j.coulomb
        );
        if let Some((leader, multiplier, offset)) = mimic {
            let _ = writeln!(
                out,
                "    <mimic joint=\"{name}_joint{}\" multiplier=\"{multiplier:?}\" offset=\"{offset:?}\"/>",
                leader + 1
            );
        }
        if j.motor_inertia != 0.0 {
            let _ = writeln!(
                out,
                "    <!-- motor inertia reflected to the joint: {:?} kg m^2 (no URDF element) -->",
                j.motor_inertia
            );
        }
        let _ = writeln!(out, "  </joint>");
        p
    }

    /// Link `i` (`child`, moved by joint `j`): its `<inertial>` — centre of mass and inertia
    /// seen from `L_i = F_i · P_i⁻¹` (`p`: `P_i`, `None` the identity), made loadable by
    /// another tool (crate::inertial's rules: physical moments, a tiny mass for a massless
    /// link, each change noted) — and its geometry.
    fn link(&mut self, i: usize, j: &Joint, child: &str, p: Option<&Matrix4<f64>>) {
        let inertial_frame = match p {
            Some(p) => {
                let com = p * j.com.push(1.0);
                let mut f = *p;
                f.fixed_view_mut::<3, 1>(0, 3).copy_from(&com.xyz());
                f
            }
            None => Matrix4::new_translation(&j.com),
        };
        let inertial = self.inertial(j.mass, &j.inertia, &format!("link {i}"), &inertial_frame);
        let _ = write!(self.out, "  <link name=\"{child}\">\n{inertial}");
        let geometry = self.geometry(i);
        self.out += &geometry;
        let _ = writeln!(self.out, "  </link>");
    }

    /// The tool: a link `<robot>_tool` fixed to the last link at `P_n · tool`, and `</robot>`.
    fn tool(&mut self, posts: &[Option<Matrix4<f64>>]) {
        let robot = self.robot;
        let tool_origin = match &posts[robot.dof()] {
            Some(p) => p * robot.tool,
            None => robot.tool,
        };
        let tool = xml(&format!("{}_tool", robot.name));
        let origin = self.oa(&tool_origin);
        let _ = writeln!(self.out, "  <link name=\"{tool}\"/>");
        let _ = writeln!(
            self.out,
            "  <joint name=\"{}_tool_joint\" type=\"fixed\">\n    <parent link=\"{}\"/>\n    <child link=\"{tool}\"/>\n    <origin {origin}/>\n  </joint>",
            self.name,
            xml(&link_name(robot, robot.dof())),
        );
        let _ = writeln!(self.out, "</robot>");
    }
}
