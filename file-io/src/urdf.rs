//! URDF export of a robot (issue #15 item 3; the URDF import and the general joint model are
//! issue #14): the DH chain written as URDF joint origins and axes, with its inertials, limits
//! and friction, so that other tools (Pinocchio, MoveIt, MuJoCo's URDF loader) read the robot
//! we built.
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
//! (`P_0 = I`). The robot's base placement is a fixed joint from a root link `world`; the tool
//! is a fixed joint to a link `tool` with origin `P_n · tool`. Each link's inertial is its DH
//! link's centre of mass and inertia, placed by `P_j` (the inertia tensor is written in the DH
//! frame's axes, which the inertial origin's rpy names).
//!
//! Not in URDF, so not written: gravity, the motor (rotor) inertia (Pinocchio's "armature";
//! noted in a comment per joint when non-zero), velocity and effort limits (robosim does not
//! model them: written as 0, which URDF readers take as "unknown"), and the geometry (a link's
//! bodies are not exported as meshes yet).

use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};
use robosim_kinematics::{Convention, JointType, Robot, fk::link_transform};
use std::fmt::Write as _;

/// The constant transform after the motion, `P_j`.
fn post(convention: Convention, j: &robosim_kinematics::Joint) -> Matrix4<f64> {
    match convention {
        Convention::Standard => {
            let mut tx = Matrix4::identity();
            tx[(0, 3)] = j.a;
            let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), j.alpha).to_homogeneous();
            tx * rx
        }
        Convention::Modified => Matrix4::identity(),
    }
}

/// `P⁻¹` of a rigid transform.
fn rigid_inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let t: Vector3<f64> = m.fixed_view::<3, 1>(0, 3).into_owned();
    let mut out = Matrix4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&r.transpose());
    out.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(-(r.transpose() * t)));
    out
}

/// `xyz="…" rpy="…"` of a rigid transform, URDF's fixed-axis roll, pitch, yaw
/// (`R = Rz(yaw) Ry(pitch) Rx(roll)`), every number in its shortest exact form.
fn origin_attrs(m: &Matrix4<f64>) -> String {
    let r = Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
    let (roll, pitch, yaw) = r.euler_angles();
    format!(
        "xyz=\"{:?} {:?} {:?}\" rpy=\"{roll:?} {pitch:?} {yaw:?}\"",
        m[(0, 3)],
        m[(1, 3)],
        m[(2, 3)]
    )
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

/// The robot as URDF text. Refused: a model that does not validate (non-finite fields, reversed
/// limits), with the model's own message.
pub fn to_urdf(robot: &Robot) -> Result<String, String> {
    robot
        .validate()
        .map_err(|e| format!("robot {}: {e}", robot.name))?;
    if let Some(j) = robot.joints.iter().position(|j| j.is_general()) {
        return Err(format!(
            "robot {}: joint {j} is a general (placement and axis) joint; the URDF export writes DH chains only (issue #14)",
            robot.name
        ));
    }
    let name = xml(&robot.name);
    let mut out = String::new();
    let _ = writeln!(out, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        out,
        "<!-- Written by robosim from the {} DH model of {name} (docs/file-io.md, \"URDF\"). -->",
        match robot.convention {
            Convention::Standard => "standard",
            Convention::Modified => "modified",
        }
    );
    let _ = writeln!(out, "<robot name=\"{name}\">");
    let _ = writeln!(out, "  <link name=\"world\"/>");
    let _ = writeln!(out, "  <link name=\"{}\"/>", xml(&link_name(robot, 0)));
    let _ = writeln!(
        out,
        "  <joint name=\"{name}_base_joint\" type=\"fixed\">\n    <parent link=\"world\"/>\n    <child link=\"{}\"/>\n    <origin {}/>\n  </joint>",
        xml(&link_name(robot, 0)),
        origin_attrs(&robot.base)
    );
    let mut prev_post = Matrix4::identity();
    for (k, j) in robot.joints.iter().enumerate() {
        let i = k + 1;
        let p = post(robot.convention, j);
        let origin = prev_post * link_transform(robot.convention, j, 0.0) * rigid_inverse(&p);
        let child = xml(&link_name(robot, i));
        // The inertial: centre of mass and inertia of DH link i, seen from L_i = F_i · P_i⁻¹.
        let com = p * j.com.push(1.0);
        let mut inertial_frame = p;
        inertial_frame
            .fixed_view_mut::<3, 1>(0, 3)
            .copy_from(&com.xyz());
        let _ = writeln!(out, "  <link name=\"{child}\">");
        if j.mass > 0.0 {
            let m = &j.inertia;
            let _ = writeln!(
                out,
                "    <inertial>\n      <origin {}/>\n      <mass value=\"{:?}\"/>\n      <inertia ixx=\"{:?}\" ixy=\"{:?}\" ixz=\"{:?}\" iyy=\"{:?}\" iyz=\"{:?}\" izz=\"{:?}\"/>\n    </inertial>",
                origin_attrs(&inertial_frame),
                j.mass,
                m[(0, 0)],
                m[(0, 1)],
                m[(0, 2)],
                m[(1, 1)],
                m[(1, 2)],
                m[(2, 2)]
            );
        }
        let _ = writeln!(out, "  </link>");
        let kind = match j.joint_type {
            JointType::Revolute => "revolute",
            JointType::Prismatic => "prismatic",
        };
        let _ = writeln!(
            out,
            "  <joint name=\"{name}_joint{i}\" type=\"{kind}\">\n    <parent link=\"{}\"/>\n    <child link=\"{child}\"/>\n    <origin {}/>\n    <axis xyz=\"0 0 1\"/>\n    <limit lower=\"{:?}\" upper=\"{:?}\" effort=\"0\" velocity=\"0\"/>\n    <dynamics damping=\"{:?}\" friction=\"{:?}\"/>",
            xml(&link_name(robot, i - 1)),
            origin_attrs(&origin),
            j.qlim[0],
            j.qlim[1],
            j.viscous,
            j.coulomb
        );
        if j.motor_inertia != 0.0 {
            let _ = writeln!(
                out,
                "    <!-- motor inertia reflected to the joint: {:?} kg m^2 (no URDF element) -->",
                j.motor_inertia
            );
        }
        let _ = writeln!(out, "  </joint>");
        prev_post = p;
    }
    let tool = xml(&format!("{}_tool", robot.name));
    let _ = writeln!(out, "  <link name=\"{tool}\"/>");
    let _ = writeln!(
        out,
        "  <joint name=\"{name}_tool_joint\" type=\"fixed\">\n    <parent link=\"{}\"/>\n    <child link=\"{tool}\"/>\n    <origin {}/>\n  </joint>",
        xml(&link_name(robot, robot.dof())),
        origin_attrs(&(prev_post * robot.tool))
    );
    let _ = writeln!(out, "</robot>");
    Ok(out)
}
