//! MJCF import against MuJoCo (issue 36 item 5): the MJCF files MuJoCo itself wrote from
//! example-robot-data URDFs (ur5, panda, xarm7, z1, kinova) and a hand-written file with the
//! features robot models use (defaults, degrees, euler sequences, anchors, two joints in one
//! body, inertia from geoms, armature), imported by robosim; every body's pose and the mass
//! matrix at MuJoCo's 10 random q agree with MuJoCo's to 1e-10 (testdata/mjcf/
//! make_mjcf_reference.py, MuJoCo 4.0).

use crate::reference::{floats, matrix, testdata};
use nalgebra::{Matrix3, Matrix4, Quaternion, UnitQuaternion, Vector3};
use robosim_file_io::mjcf::{MjcfErrorKind, import_mjcf, import_mjcf_str, import_mjcf_tree};
use robosim_file_io::urdf_import::UrdfRobot;
use robosim_kinematics::fk;
use std::path::Path;

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(testdata().join("mjcf/mujoco_reference.json"))
        .expect("testdata/mjcf/mujoco_reference.json");
    serde_json::from_str(&text).expect("reference JSON")
}

/// Each named body's world pose: its robosim link frame times the body frame in it.
fn body_pose(r: &UrdfRobot, frames: &[Matrix4<f64>], body: &str) -> Matrix4<f64> {
    let g = &r.geometry.links[body];
    frames[g.body] * g.in_body
}

/// Largest pose error of every body and the mass matrix's relative error, over the samples.
fn compare(r: &UrdfRobot, entry: &serde_json::Value) -> (f64, f64) {
    let bodies: Vec<&str> = entry["bodies"]
        .as_array()
        .expect("bodies")
        .iter()
        .map(|b| b.as_str().expect("name"))
        .collect();
    let model = robosim_dynamics::Model::new(&r.robot).expect("dynamics model");
    let mut data = robosim_dynamics::Data::new(&model);
    let (mut pose_err, mut m_err) = (0.0f64, 0.0f64);
    for s in entry["samples"].as_array().expect("samples") {
        let q = floats(&s["q"]);
        let frames = fk::link_frames(&r.robot, &q);
        for (i, name) in bodies.iter().enumerate().skip(1) {
            let x = body_pose(r, &frames, name);
            let p = floats(&s["xpos"][i]);
            let w = floats(&s["xquat"][i]);
            let rot: Matrix3<f64> =
                UnitQuaternion::from_quaternion(Quaternion::new(w[0], w[1], w[2], w[3]))
                    .to_rotation_matrix()
                    .into_inner();
            let dp = (x.fixed_view::<3, 1>(0, 3) - Vector3::new(p[0], p[1], p[2])).amax();
            let dr = (x.fixed_view::<3, 3>(0, 0) - rot).amax();
            pose_err = pose_err.max(dp).max(dr);
        }
        let theirs = matrix(&s["mass_matrix"]);
        let ours = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
        let scale = theirs.amax().max(1.0);
        m_err = m_err.max((ours - &theirs).amax() / scale);
    }
    (pose_err, m_err)
}

#[test]
fn mujoco_made_mjcf_has_mujocos_fk_and_mass_matrix() {
    let reference = reference();
    let robots = reference["robots"].as_array().expect("robots");
    assert_eq!(robots.len(), 6, "five converted robots and features.xml");
    for entry in robots {
        let name = entry["name"].as_str().expect("name");
        let path = testdata()
            .join("mjcf")
            .join(entry["file"].as_str().expect("file"));
        let r = import_mjcf_tree(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            r.robot.dof() as u64,
            entry["nq"].as_u64().expect("nq"),
            "{name}: one coordinate per MuJoCo qpos"
        );
        let (pose, m) = compare(&r, entry);
        eprintln!("{name}: pose {pose:.1e}, M {m:.1e}");
        assert!(
            pose < 1e-10,
            "{name}: body poses differ from MuJoCo's by {pose:e}"
        );
        assert!(
            m < 1e-10,
            "{name}: M differs from MuJoCo's by {m:e} (relative)"
        );
    }
}

/// What features.xml has that robosim does not read is listed, not dropped.
#[test]
fn what_is_not_read_is_listed() {
    let r = import_mjcf_tree(&testdata().join("mjcf/features.xml")).expect("imports");
    let all = r.notes.join("\n");
    for what in [
        "<actuator> (1 element)",
        "<sensor> (1 element)",
        "<option> timestep",
        "<worldbody>",
    ] {
        assert!(all.contains(what), "{what:?} not in the notes:\n{all}");
    }
    // j6 is unlimited: a continuous joint; j3 a slide with its range in metres (not degrees).
    let j6 = r.joints.iter().position(|j| j.name == "j6").expect("j6");
    assert!(r.joints[j6].continuous);
    let j3 = r.joints.iter().position(|j| j.name == "j3").expect("j3");
    assert_eq!(r.robot.joints[j3].qlim, [-0.1, 0.2]);
    // Damping from the main default, armature from class arm.
    assert_eq!(r.robot.joints[j3].viscous, 0.5);
    assert_eq!(r.robot.joints[j3].motor_inertia, 0.01);
    // The collision capsule is held by a cylinder of length 2h + 2r.
    let link1 = &r.geometry.links["link1"];
    assert_eq!(link1.collision.len(), 1);
}

/// The chain form (the query protocol's `{"mjcf": PATH, "tip"}`): q is the path's joints, the
/// tool is the tip body's frame, and its pose agrees with the tree's.
#[test]
fn a_chain_to_a_tip_body_is_the_trees_path() {
    let path = testdata().join("mjcf/features.xml");
    let tree = import_mjcf_tree(&path).expect("tree");
    let chain = import_mjcf(&path, Some("tool")).expect("chain");
    let names: Vec<&str> = chain.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["j1", "j2", "j3", "j4"]);
    assert_eq!(chain.held, ["j5", "j6"]);
    let q_tree = [0.3, -0.4, 0.05, 0.7, 0.0, 0.0];
    let frames = fk::link_frames(&tree.robot, &q_tree);
    let want = body_pose(&tree, &frames, "tool");
    let got = fk::forward(&chain.robot, &q_tree[..4]);
    assert!((want - got).amax() < 1e-12, "{want} vs {got}");
    let e = import_mjcf(&path, None).expect_err("three leaves");
    assert!(matches!(e.kind, MjcfErrorKind::AmbiguousTip(3, _)), "{e}");
    let e = import_mjcf(&path, Some("nope")).expect_err("no such body");
    assert_eq!(e.kind, MjcfErrorKind::TipNotABody("nope".into()));
}

fn refused(text: &str) -> (u32, String, MjcfErrorKind) {
    let e = import_mjcf_str(text, Path::new("t.xml"), None).expect_err("refused");
    assert!(e.to_string().starts_with("t.xml:"), "{e}");
    (e.line, e.element, e.kind)
}

#[test]
fn ball_free_and_bad_input_are_refused_by_name() {
    // a free joint is the floating base only on the worldbody's first body (issue 36 item 2)
    let (line, element, kind) = refused(
        "<mujoco>\n<worldbody>\n<body name='torso'>\n<body name='leg'>\n<freejoint name='root'/>\n</body></body></worldbody></mujoco>",
    );
    assert_eq!(line, 4);
    assert_eq!(element, r#"<body name="leg">"#);
    assert_eq!(
        kind,
        MjcfErrorKind::UnsupportedJoint {
            joint: "root".into(),
            kind: "free".into()
        }
    );
    // a ball joint is a spherical joint (4 q, 3 v); its range, a cone limit, is noted
    let ball = import_mjcf_str(
        "<mujoco><worldbody><body name='b'><joint name='s' type='ball' range='0 60'/><geom type='sphere' size='0.1'/></body></worldbody></mujoco>",
        Path::new("t.xml"),
        None,
    )
    .expect("a ball joint imports");
    assert!(ball.robot.joints[0].spherical);
    assert_eq!((ball.robot.nq(), ball.robot.nv()), (4, 3));
    // URDF has no ball joint and may not write it as a hinge (it would load as another robot):
    // refused by name (the MJCF export writes it: mjcf_export.rs)
    let e = robosim_file_io::urdf::to_urdf(&ball.robot).expect_err("no ball joint in URDF");
    assert!(e.contains("joint 0 is a ball (spherical) joint"), "{e}");
    assert!(
        ball.notes.iter().any(|n| n.contains("\"s\"")
            && n.contains("cone limit of 1.047")
            && n.contains("not enforced")),
        "{:?}",
        ball.notes
    );
    let (_, _, kind) = refused(
        "<mujoco><worldbody><body name='b'><joint pos='0 nan 0'/></body></worldbody></mujoco>",
    );
    assert!(matches!(kind, MjcfErrorKind::BadValue { ref attribute, .. } if attribute == "pos"));
    let (_, _, kind) = refused(
        "<mujoco><worldbody><body name='b'><joint class='nope'/></body></worldbody></mujoco>",
    );
    assert_eq!(kind, MjcfErrorKind::UnknownClass("nope".into()));
    let (_, _, kind) = refused("<robot name='x'/>");
    assert_eq!(kind, MjcfErrorKind::NotMujoco("robot".into()));
    let (_, _, kind) = refused(
        "<mujoco><asset><mesh name='m' file='m.stl'/></asset><worldbody><body name='b'><joint/><geom type='mesh' mesh='m'/></body></worldbody></mujoco>",
    );
    assert!(matches!(kind, MjcfErrorKind::MeshInertia { .. }), "{kind}");
    let (_, _, kind) = refused("<mujoco><include file='robot.xml'/></mujoco>");
    assert!(matches!(kind, MjcfErrorKind::Unsupported(_)));
    let e = import_mjcf_tree(Path::new("/nonexistent/robot.xml")).expect_err("no file");
    assert!(matches!(e.kind, MjcfErrorKind::Io(_)));
}

/// `<equality><joint>` is MuJoCo's mimic joint (issue 36 items 1 and 5):
/// `y − y₀ = a₀ + a₁ (x − x₀)` with y₀, x₀ the joints' `ref`, read into the coupling as URDF's
/// `<mimic>` is; a polynomial and an inactive one are noted, not imposed; `<connect>` is listed
/// as not read; a joint name that is no joint is refused at its element.
#[test]
fn an_equality_joint_is_a_mimic_coupling() {
    let text = |eq: &str| {
        format!(
            r#"<mujoco model="eq">
  <compiler angle="radian"/>
  <worldbody>
    <body name="a"><joint name="j1" axis="0 0 1"/><geom type="sphere" size="0.1" mass="1"/>
      <body name="b" pos="0.5 0 0"><joint name="j2" axis="0 1 0" ref="0.2"/>
        <geom type="sphere" size="0.1" mass="1"/>
        <body name="c" pos="0.5 0 0"><joint name="j3" axis="0 1 0" ref="0.3"/>
          <geom type="sphere" size="0.1" mass="1"/>
          <body name="d" pos="0.5 0 0"><joint name="j4" axis="1 0 0"/>
            <geom type="sphere" size="0.1" mass="1"/></body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>{eq}</equality>
</mujoco>"#
        )
    };
    let eq = r#"<joint joint1="j3" joint2="j2" polycoef="0.1 -2 0 0 0"/>
    <joint joint1="j4" joint2="j1" polycoef="0 1 0.5 0 0"/>
    <joint joint1="j1" joint2="j2" active="false"/>
    <connect body1="a" body2="d" anchor="0 0 0"/>"#;
    let r = import_mjcf_str(&text(eq), Path::new("eq.xml"), None).expect("imports");
    let c = r.coupling.as_ref().expect("a coupling");
    assert_eq!((c.full_dof(), c.reduced_dof()), (4, 3));
    assert_eq!(r.mimics.len(), 1);
    let all = r.notes.join("\n");
    for what in ["polynomial", "inactive", "<equality><connect> (1 element)"] {
        assert!(all.contains(what), "{what:?} not in the notes:\n{all}");
    }
    // q3 = y0 + a0 + a1 (q2 − x0) = 0.3 + 0.1 − 2 (q2 − 0.2)
    let qr = [0.4, -0.3, 0.7];
    let q = c.expand_q(&qr).expect("q");
    let q3 = 0.3 + 0.1 - 2.0 * (-0.3 - 0.2);
    assert!((q[2] - q3).abs() < 1e-15, "{q:?}");
    assert_eq!([q[0], q[1], q[3]], qr);
    let got = robosim_kinematics::mimic::forward(&r.robot, c, &qr).expect("fk");
    assert_eq!(got, fk::forward(&r.robot, &q));
    // a joint that is not one
    let bad = r#"<joint joint1="j3" joint2="nope"/>"#;
    let (line, element, kind) = refused(&text(bad));
    assert_eq!(kind, MjcfErrorKind::UnknownJoint("nope".into()));
    assert_eq!((line, element.as_str()), (15, "<equality>/<joint>"));
}
