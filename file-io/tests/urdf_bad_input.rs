//! Bad URDF input (issue #14, "What must be shown"): malformed XML, a joint whose parent link is
//! missing, a cycle, two roots, negative mass, an inertia that is not positive semi-definite,
//! NaN in an origin, a tip that is not a link, a missing mesh. Each is a typed
//! [`UrdfError`] naming the file, the line and the element — through both importers (chain and
//! tree) — and never a panic; a missing mesh is an error only where geometry is needed (FK and
//! dynamics of that robot still work).

use robosim_file_io::urdf_geometry::MeshProblem;
use robosim_file_io::urdf_import::{UrdfError, UrdfErrorKind, import_urdf, import_urdf_tree};
use robosim_kinematics::fk;
use std::path::{Path, PathBuf};

/// The imported robot's collision solids, built from its model's geometry
/// (`robosim_model::Model::from_imported`, `robosim_model::geometry::link_solids`).
fn link_solids(
    r: &robosim_file_io::urdf_import::ImportedRobot,
) -> Result<robosim_collision::robot::LinkSolids, robosim_model::GeometryError> {
    robosim_model::Model::from(r).collision_solids()
}

/// A valid two-joint robot; each case edits one line of it. Line numbers are 1-based.
const GOOD: &str = r#"<?xml version="1.0"?>
<robot name="bad">
  <link name="base"/>
  <link name="l1">
    <inertial><mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
  </link>
  <link name="l2">
    <inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0.4 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/>
  </joint>
</robot>
"#;

/// `GOOD` with `from` (which must occur exactly once) replaced by `to`, written to `dir`.
fn write(dir: &Path, from: &str, to: &str) -> PathBuf {
    assert_eq!(GOOD.matches(from).count(), 1, "{from:?} must occur once");
    let path = dir.join("bad.urdf");
    std::fs::write(&path, GOOD.replace(from, to)).expect("write");
    path
}

/// The error names the file, the line and the element, in its fields and in its message.
fn names_where(e: &UrdfError, file: &Path, line: u32, element: &str) {
    assert_eq!(e.file, file, "{e}");
    assert_eq!(e.line, line, "{e}");
    assert_eq!(e.element, element, "{e}");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("{}:{line}: {element}: ", file.display())),
        "{text}"
    );
}

/// Both importers refuse the file with the same error.
fn refused(path: &Path) -> UrdfError {
    let chain = import_urdf(path, Some("l2")).expect_err("the chain importer refuses it");
    let tree = import_urdf_tree(path).expect_err("the tree importer refuses it");
    assert_eq!(chain, tree);
    chain
}

#[test]
fn the_good_file_imports() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(tmp.path(), "<robot name=\"bad\">", "<robot name=\"bad\">");
    let r = import_urdf(&path, Some("l2")).expect("imports");
    assert_eq!(r.robot.dof(), 2);
    assert_eq!(import_urdf_tree(&path).expect("imports").robot.dof(), 2);
}

#[test]
fn malformed_xml_names_the_line_column_and_tag() {
    let tmp = tempfile::tempdir().expect("tmp");
    // An unclosed <child> on line 16: the parser finds the mismatch at </joint>, line 19.
    let path = write(
        tmp.path(),
        r#"<parent link="l1"/><child link="l2"/>"#,
        r#"<parent link="l1"/><child link="l2">"#,
    );
    let e = refused(&path);
    let UrdfErrorKind::Xml(msg) = &e.kind else {
        panic!("{e}")
    };
    assert!(msg.contains("child") && msg.contains("joint"), "{msg}");
    names_where(&e, &path, 19, "</joint> (column 3)");
    // A file cut short inside <robot>: reported at its last line, not at 1:1.
    let cut = &GOOD[..GOOD.find("  <joint name=\"j2\"").expect("j2")];
    std::fs::write(&path, cut).expect("write");
    let e = refused(&path);
    assert!(matches!(e.kind, UrdfErrorKind::Xml(_)), "{e}");
    names_where(&e, &path, 14, "end of file");
    // Not XML at all.
    std::fs::write(&path, "robot name=bad\n").expect("write");
    let e = refused(&path);
    assert!(matches!(e.kind, UrdfErrorKind::Xml(_)), "{e}");
    names_where(&e, &path, 1, "column 1");
}

#[test]
fn a_joint_whose_parent_link_is_missing() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(
        tmp.path(),
        r#"<parent link="l1"/><child link="l2"/>"#,
        r#"<parent link="l9"/><child link="l2"/>"#,
    );
    let e = refused(&path);
    assert_eq!(
        e.kind,
        UrdfErrorKind::MissingLink {
            role: "parent",
            link: "l9".into()
        }
    );
    names_where(&e, &path, 15, r#"<joint name="j2">"#);
}

#[test]
fn a_cycle_and_a_robot_without_a_root() {
    let tmp = tempfile::tempdir().expect("tmp");
    // l2 and l3 move each other (j2: l3 → l2, j3: l2 → l3); the root `base` cannot reach them.
    let path = write(
        tmp.path(),
        "  </joint>\n</robot>",
        "  </joint>\n  <link name=\"l3\"/>\n  <joint name=\"j3\" type=\"continuous\"><parent link=\"l2\"/><child link=\"l3\"/></joint>\n</robot>",
    );
    let text = std::fs::read_to_string(&path).expect("read").replace(
        r#"<parent link="l1"/><child link="l2"/>"#,
        r#"<parent link="l3"/><child link="l2"/>"#,
    );
    std::fs::write(&path, text).expect("write");
    let e = refused(&path);
    assert_eq!(e.kind, UrdfErrorKind::Cycle("l2".into()));
    names_where(&e, &path, 15, r#"<joint name="j2">"#);
    // Every link moved by a joint: no root at all (j1 moved back onto base by j0).
    let path = write(
        tmp.path(),
        "  </joint>\n</robot>",
        "  </joint>\n  <joint name=\"j0\" type=\"fixed\"><parent link=\"l2\"/><child link=\"base\"/></joint>\n</robot>",
    );
    let e = refused(&path);
    assert_eq!(e.kind, UrdfErrorKind::NoRoot);
    names_where(&e, &path, 2, r#"<robot name="bad">"#);
}

#[test]
fn two_roots() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(
        tmp.path(),
        "  </joint>\n</robot>",
        "  </joint>\n  <link name=\"stray\"/>\n</robot>",
    );
    let e = refused(&path);
    assert_eq!(
        e.kind,
        UrdfErrorKind::TwoRoots("base".into(), "stray".into())
    );
    names_where(&e, &path, 20, r#"<link name="stray">"#);
}

#[test]
fn negative_mass() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(
        tmp.path(),
        r#"<mass value="0.5"/>"#,
        r#"<mass value="-0.5"/>"#,
    );
    let e = refused(&path);
    assert_eq!(e.kind, UrdfErrorKind::NegativeMass(-0.5));
    names_where(&e, &path, 8, r#"<link name="l2">/<inertial>/<mass>"#);
}

#[test]
fn an_inertia_that_is_not_positive_semi_definite() {
    let tmp = tempfile::tempdir().expect("tmp");
    // Eigenvalues of [[.01 .05 0] [.05 .01 0] [0 0 .01]]: −0.04, 0.01, 0.06.
    let path = write(
        tmp.path(),
        r#"<mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/>"#,
        r#"<mass value="1.0"/><inertia ixx="0.01" ixy="0.05" iyy="0.01" izz="0.01"/>"#,
    );
    let e = refused(&path);
    let UrdfErrorKind::InertiaNotPsd(min) = e.kind else {
        panic!("{e}")
    };
    assert!((min + 0.04).abs() < 1e-12, "{min}");
    names_where(&e, &path, 5, r#"<link name="l1">/<inertial>/<inertia>"#);
}

#[test]
fn nan_in_an_origin() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(tmp.path(), r#"xyz="0.4 0 0""#, r#"xyz="0.4 NaN 0""#);
    let e = refused(&path);
    assert_eq!(
        e.kind,
        UrdfErrorKind::BadNumber {
            attribute: "xyz",
            value: "0.4 NaN 0".into(),
            reason: "not finite"
        }
    );
    names_where(&e, &path, 17, r#"<joint name="j2">/<origin>"#);
    // In an inertial origin too, and in rpy.
    let path = write(
        tmp.path(),
        r#"<inertial><mass value="0.5"/>"#,
        r#"<inertial><origin rpy="0 nan 0"/><mass value="0.5"/>"#,
    );
    let e = refused(&path);
    assert!(
        matches!(
            e.kind,
            UrdfErrorKind::BadNumber {
                attribute: "rpy",
                ..
            }
        ),
        "{e}"
    );
    names_where(&e, &path, 8, r#"<link name="l2">/<inertial>/<origin>"#);
}

#[test]
fn a_tip_that_is_not_a_link() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(tmp.path(), "<robot name=\"bad\">", "<robot name=\"bad\">");
    for tip in ["l7", "j2"] {
        let e = import_urdf(&path, Some(tip)).expect_err("not a link");
        assert_eq!(e.kind, UrdfErrorKind::TipNotALink(tip.into()));
        names_where(&e, &path, 2, r#"<robot name="bad">"#);
    }
}

/// A mesh that is not there: the import, FK and dynamics work; the collision solids (which
/// need it) fail naming the URDF file, the `<mesh>`'s line and element, and the path looked at.
#[test]
fn a_missing_mesh_fails_only_where_geometry_is_needed() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = write(
        tmp.path(),
        r#"<inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>"#,
        r#"<inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial><collision><geometry><mesh filename="meshes/none.stl"/></geometry></collision>"#,
    );
    for r in [
        import_urdf(&path, Some("l2")).expect("imports"),
        import_urdf_tree(&path).expect("imports"),
    ] {
        let q = [0.3, -0.7];
        let t = fk::forward(&r.robot, &q);
        // Tip: up 0.3, then 0.4 along x rotated by q1 about z (j2 about y does not move l2's origin).
        assert!((t[(0, 3)] - 0.4 * 0.3f64.cos()).abs() < 1e-15, "{t}");
        assert!((t[(2, 3)] - 0.3).abs() < 1e-15, "{t}");
        let model = robosim_dynamics::Model::new(&r.robot).expect("model");
        let mut data = robosim_dynamics::Data::new(&model);
        let m = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
        // M[0][0]: l1 and l2 about z (0.01 each) plus l2's 0.5 kg at 0.4 m: 0.02 + 0.08.
        assert!((m[(0, 0)] - 0.1).abs() < 1e-12, "{m}");
        let qdd =
            robosim_dynamics::aba(&model, &mut data, &q, &[0.0; 2], &[1.0, 0.0]).expect("aba");
        assert!((qdd[0] - 10.0).abs() < 1e-9, "{qdd}");
        let e = link_solids(&r).expect_err("the mesh is needed now");
        let e = e.mesh().expect("the mesh's own error");
        let UrdfErrorKind::Mesh(MeshProblem::NotFound(missing)) = &e.kind else {
            panic!("{e}")
        };
        assert!(missing.ends_with("meshes/none.stl"), "{e}");
        names_where(
            &e,
            &path,
            8,
            r#"<link name="l2">/<collision>[1]/<geometry>/<mesh>"#,
        );
    }
}
