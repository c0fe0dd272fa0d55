//! URDF geometry (issue #14): visual and collision elements, package:// meshes, the Panda's
//! collision solids against a reference distance from coal (hpp-fcl), and the bad inputs
//! (a missing mesh, an unknown package, a malformed mesh) failing only where geometry is needed;
//! the Panda's Collada visual meshes against figures computed independently
//! (testdata/urdf/panda_visual_meshes.py, ElementTree + numpy).

use nalgebra::{Isometry3, Matrix4, Translation3, UnitQuaternion, Vector3};
use robosim_collision::exact::{ExactOptions, collide};
use robosim_collision::robot::{
    CheckResult, CollisionSettings, Scene, check_robot, isometry_from_matrix,
};
use robosim_collision::{PairResult, Solid};
use robosim_file_io::package::ResolveError;
use robosim_file_io::urdf_geometry::{Geometry, MeshProblem};
use robosim_file_io::urdf_import::{UrdfErrorKind, import_urdf, rpy_matrix};
use robosim_kinematics::fk;
use std::path::{Path, PathBuf};

/// The imported robot's collision solids, built from its model's geometry
/// (`robosim_model::Model::from_imported`, `robosim_model::geometry::link_solids`).
fn link_solids(
    r: &robosim_file_io::urdf_import::ImportedRobot,
) -> Result<robosim_collision::robot::LinkSolids, robosim_model::GeometryError> {
    robosim_model::Model::from(r).collision_solids()
}

fn testdata() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf")
}

fn v3(j: &serde_json::Value) -> Vector3<f64> {
    Vector3::new(
        j[0].as_f64().expect("number"),
        j[1].as_f64().expect("number"),
        j[2].as_f64().expect("number"),
    )
}

#[test]
fn panda_geometry_is_read_and_placed_by_link() {
    let r = import_urdf(&testdata().join("panda.urdf"), Some("panda_hand")).expect("imports");
    let g = &r.geometry;
    assert_eq!(g.links.len(), 13);
    // 12 visuals (10 DAE meshes … see panda.urdf), 17 collisions: 9 STL meshes and 8 finger boxes.
    let (visual, collision, _) = g.counts();
    assert_eq!(collision, 17);
    assert!(visual >= 11, "{visual}");
    // Bodies: link j on the chain is body j; the hand (behind the fixed joint panda_joint8 and
    // panda_hand_joint) is lumped into body 7 with the folded placement; the fingers (held at 0)
    // too.
    for j in 0..=7 {
        let l = &g.links[&format!("panda_link{j}")];
        assert_eq!(l.body, j);
        assert_eq!(l.in_body, Matrix4::identity());
    }
    let hand = &g.links["panda_hand"];
    assert_eq!(hand.body, 7);
    // panda_joint8: xyz 0 0 0.107; panda_hand_joint: rpy 0 0 -π/4.
    let expected_hand = {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&rpy_matrix(&Vector3::new(
                0.0,
                0.0,
                -std::f64::consts::FRAC_PI_4,
            )));
        m[(2, 3)] = 0.107;
        m
    };
    assert!(
        (hand.in_body - expected_hand).abs().max() < 1e-15,
        "{}",
        hand.in_body
    );
    assert_eq!(g.links["panda_leftfinger"].body, 7);
    match &g.links["panda_link4"].collision[0].geometry {
        Geometry::Mesh(m) => {
            assert!(m.uri.ends_with("collision/link4.stl"));
            assert!(m.path().expect("resolves").is_file());
        }
        other => panic!("{other:?}"),
    }
    let ls = link_solids(&r).expect("collision solids");
    assert_eq!(ls.links.len(), 8);
    assert!(ls.links.iter().all(Option::is_some));
}

#[test]
fn panda_link4_against_a_box_matches_coal() {
    let text = std::fs::read_to_string(testdata().join("panda_link4_box_distance.json"))
        .expect("reference");
    let reference: serde_json::Value = serde_json::from_str(&text).expect("json");
    let r = import_urdf(&testdata().join("panda.urdf"), Some("panda_hand")).expect("imports");
    let ls = link_solids(&r).expect("collision solids");
    let link4 = ls.links[4].as_ref().expect("link4 has a solid");
    // A pose of the arm away from zero (within the limits): FK places the link, the box is
    // placed relative to it, so the distance is the reference's (computed in link4's frame).
    let q = [0.3, -0.4, 0.5, -1.6, 0.2, 1.1, -0.7];
    let frames = fk::link_frames(&r.robot, &q);
    let link_pose = isometry_from_matrix(&frames[4]);
    let cases = reference["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), 3);
    let mut worst: f64 = 0.0;
    for c in cases {
        let size = v3(&c["size"]);
        let rpy = v3(&c["rpy"]);
        let xyz = v3(&c["xyz"]);
        let want = c["distance"].as_f64().expect("distance");
        let b = Solid::cuboid(size).expect("box");
        let rel = Isometry3::from_parts(
            Translation3::from(xyz),
            UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(
                rpy_matrix(&rpy),
            )),
        );
        let got = match collide(
            &link4.solid,
            &(link_pose * link4.offset),
            &b,
            &(link_pose * rel),
            ExactOptions::default(),
        ) {
            PairResult::Clear {
                distance: Some(d), ..
            } => d,
            other => panic!("expected apart: {other:?}"),
        };
        worst = worst.max((got - want).abs());
        assert!(
            (got - want).abs() <= 1e-9,
            "box {size:?} at {xyz:?}: robosim {got} coal {want}"
        );
    }
    eprintln!("panda link4 vs box: worst |robosim - coal| = {worst:e} m");

    // The same link through the robot check: a box overlapping link4 is a contact on link 4.
    let mut scene = Scene::new();
    let on_hull = link4.solid.interior_point();
    scene.add(
        "block",
        std::sync::Arc::new(Solid::cuboid(Vector3::new(0.02, 0.02, 0.02)).expect("box")),
        link_pose * link4.offset * Isometry3::translation(on_hull.x, on_hull.y, on_hull.z),
    );
    let settings = CollisionSettings {
        self_collision: false,
        ..Default::default()
    };
    match check_robot(&r.robot, &ls, &q, &scene, &settings).expect("check") {
        CheckResult::Contact(c) => assert!(
            c.iter()
                .any(|c| matches!(c.a, robosim_collision::robot::Body::Link(4)))
        ),
        other => panic!("{other:?}"),
    }
}

const SMALL: &str = r#"<?xml version="1.0"?>
<robot name="small">
  <material name="blue"><color rgba="0 0 1 1"/></material>
  <link name="base">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
  </link>
  <link name="arm">
    <visual><geometry><cylinder radius="0.05" length="0.5"/></geometry><material name="blue"/></visual>
    <collision><origin xyz="0 0 0.25"/><geometry><cylinder radius="0.05" length="0.5"/></geometry></collision>
  </link>
  <link name="tool">
    <collision><origin xyz="0 0.2 0"/><geometry><sphere radius="0.03"/></geometry></collision>
    <collision><geometry>MESH</geometry></collision>
  </link>
  <joint name="j1" type="continuous">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="fixed_tool" type="fixed">
    <parent link="arm"/><child link="tool"/><origin xyz="0 0 0.6" rpy="0 1.5707963267948966 0"/>
  </joint>
</robot>"#;

fn write_robot(dir: &Path, mesh: &str) -> PathBuf {
    let p = dir.join("small.urdf");
    std::fs::write(&p, SMALL.replace("MESH", mesh)).expect("write");
    p
}

/// A tetrahedron as ASCII STL, corner at the origin, edges 0.02 m.
const TETRA: &str = "solid t
facet normal 0 0 0
outer loop
vertex 0 0 0
vertex 0.02 0 0
vertex 0 0.02 0
endloop
endfacet
facet normal 0 0 0
outer loop
vertex 0 0 0
vertex 0 0 0.02
vertex 0.02 0 0
endloop
endfacet
facet normal 0 0 0
outer loop
vertex 0 0 0
vertex 0 0.02 0
vertex 0 0 0.02
endloop
endfacet
facet normal 0 0 0
outer loop
vertex 0.02 0 0
vertex 0 0 0.02
vertex 0 0.02 0
endloop
endfacet
endsolid t
";

#[test]
fn primitives_meshes_and_materials_are_placed_in_their_bodies() {
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::create_dir_all(tmp.path().join("my_pkg/meshes")).expect("mkdir");
    std::fs::write(tmp.path().join("my_pkg/meshes/t.stl"), TETRA).expect("write");
    let urdf = write_robot(
        tmp.path(),
        r#"<mesh filename="package://my_pkg/meshes/t.stl" scale="2 1 1"/>"#,
    );
    let r = import_urdf(&urdf, None).expect("imports");
    assert_eq!(r.robot.dof(), 1);
    let arm = &r.geometry.links["arm"];
    let m = arm.visual[0].material.as_ref().expect("material");
    assert_eq!(m.rgba, Some([0.0, 0.0, 1.0, 1.0]));
    let ls = link_solids(&r).expect("solids");
    assert_eq!(ls.links.len(), 2);
    // Body 0: the base box at z = 0.05.
    let base = ls.links[0].as_ref().expect("base");
    assert!((base.offset.translation.vector - Vector3::new(0.0, 0.0, 0.05)).norm() < 1e-15);
    // Body 1: the arm's cylinder, the tool's sphere and the (scaled) tetrahedron, compound.
    let arm = ls.links[1].as_ref().expect("arm");
    assert_eq!(arm.solid.kind, robosim_collision::SolidKind::Compound);
    // The tool frame is at arm z = 0.6 (world z = 0.7 with joint 1 at z = 0.1), turned +90°
    // about y (tool x = arm −z, tool z = arm x): the tetrahedron's top face is the plane
    // z = 0.7 and its corner (0, 0, 0) sits on the joint axis; the sphere (tool y = 0.2) is at
    // arm (0, 0.2, 0.6), i.e. world (−0.2 sin q, 0.2 cos q, 0.7).
    let q = [0.7];
    let pose = isometry_from_matrix(&fk::link_frames(&r.robot, &q)[1]) * arm.offset;
    let probe = Solid::sphere(0.001, None).expect("probe");
    let dist = |p: Vector3<f64>| match collide(
        &arm.solid,
        &pose,
        &probe,
        &Isometry3::translation(p.x, p.y, p.z),
        ExactOptions::default(),
    ) {
        PairResult::Clear {
            distance: Some(d), ..
        } => d,
        PairResult::Contact { .. } => 0.0,
        other => panic!("{other:?}"),
    };
    // Above the tetrahedron's corner on the axis (probe radius 0.001).
    let above = dist(Vector3::new(0.0, 0.0, 0.75));
    assert!((above - (0.75 - 0.7 - 0.001)).abs() < 1e-9, "{above}");
    // Above the sphere: rotated with joint 1.
    let c = Vector3::new(-0.2 * q[0].sin(), 0.2 * q[0].cos(), 0.7);
    let over = dist(c + Vector3::new(0.0, 0.0, 0.1));
    assert!((over - (0.1 - 0.03 - 0.001)).abs() < 1e-9, "{over}");
    assert!(dist(c) < 1e-12);
}

#[test]
fn missing_unknown_and_malformed_meshes_fail_only_where_geometry_is_needed() {
    let tmp = tempfile::tempdir().expect("tmp");
    let cases: [(&str, fn(&UrdfErrorKind) -> bool); 4] = [
        (r#"<mesh filename="meshes/missing.stl"/>"#, |k| {
            matches!(k, UrdfErrorKind::Mesh(MeshProblem::NotFound(_)))
        }),
        (
            r#"<mesh filename="package://no_such_pkg_s27b/m.stl"/>"#,
            |k| {
                matches!(
                    k,
                    UrdfErrorKind::Mesh(MeshProblem::Resolve(ResolveError::UnknownPackage { .. }))
                )
            },
        ),
        (r#"<mesh filename="bad.stl"/>"#, |k| {
            matches!(k, UrdfErrorKind::Mesh(MeshProblem::File(_)))
        }),
        (r#"<mesh filename="flat.obj"/>"#, |k| {
            matches!(k, UrdfErrorKind::Mesh(MeshProblem::Parts(_)))
        }),
    ];
    std::fs::write(tmp.path().join("bad.stl"), b"this is not a mesh\x00\xff").expect("write");
    std::fs::write(
        tmp.path().join("flat.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n",
    )
    .expect("write");
    for (mesh, is) in cases {
        let urdf = write_robot(tmp.path(), mesh);
        // FK and dynamics need no mesh: the import works.
        let r = import_urdf(&urdf, None).expect("imports without loading meshes");
        let t = fk::forward(&r.robot, &[0.0]);
        assert!((t[(2, 3)] - 0.7).abs() < 1e-15);
        let e = link_solids(&r).expect_err("the mesh is needed now");
        let e = e.mesh().expect("the mesh's own error");
        assert!(is(&e.kind), "{mesh}: {e}");
        assert_eq!(e.file, urdf);
        assert_eq!(e.line, 13, "{e}");
        assert!(e.element.contains(r#"<link name="tool">"#), "{e}");
        assert!(e.to_string().contains("small.urdf:13"), "{e}");
    }
    // A malformed geometry element is an import error (it is URDF syntax, not a mesh).
    let urdf = write_robot(tmp.path(), r#"<sphere radius="-1"/>"#);
    let e = import_urdf(&urdf, None).expect_err("negative radius");
    assert!(
        matches!(
            e.kind,
            UrdfErrorKind::BadNumber {
                attribute: "radius",
                ..
            }
        ),
        "{e}"
    );
    let urdf = write_robot(tmp.path(), r#"<capsule radius="1" length="2"/>"#);
    let e = import_urdf(&urdf, None).expect_err("not a URDF geometry");
    assert!(matches!(e.kind, UrdfErrorKind::MissingElement(_)), "{e}");
}

fn bounds(tris: &[[[f64; 3]; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for v in tris.iter().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    (lo, hi)
}

/// Every visual mesh panda.urdf names is a Collada file, and each loads with the triangle count
/// and bounding box that an independent reader (testdata/urdf/panda_visual_meshes.py: Python's
/// ElementTree and numpy, node matrices and units applied) computed from the same file; and
/// the visual box agrees with the collision STL's to a few centimetres (a wrong unit, up axis or
/// node transform would be off by far more).
#[test]
fn every_panda_visual_dae_loads_as_the_independent_reader_reads_it() {
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(testdata().join("panda_visual_meshes.json")).expect("json"),
    )
    .expect("parses");
    let r = import_urdf(&testdata().join("panda.urdf"), Some("panda_hand")).expect("imports");
    let mut loaded = std::collections::BTreeSet::new();
    let mut visuals = 0;
    for (link, lg) in &r.geometry.links {
        for v in &lg.visual {
            let Geometry::Mesh(m) = &v.geometry else {
                panic!("{link}: the Panda's visuals are meshes")
            };
            visuals += 1;
            assert!(m.uri.ends_with(".dae"), "{}", m.uri);
            let key = m
                .uri
                .strip_prefix("package://example-robot-data/")
                .expect("package uri");
            let want = &reference[key];
            assert!(want.is_object(), "{key} has reference figures");
            let parts = m.load_coloured().unwrap_or_else(|e| panic!("{e}"));
            // Materials with a diffuse colour come through.
            assert!(parts.iter().any(|p| p.rgba.is_some()), "{key}: no colour");
            let tris = m.load().unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(
                tris.len() as u64,
                want["triangles"].as_u64().expect("count"),
                "{key}"
            );
            let (lo, hi) = bounds(&tris);
            let (wlo, whi) = (v3(&want["min"]), v3(&want["max"]));
            for k in 0..3 {
                assert!(
                    (lo[k] - wlo[k]).abs() < 1e-12 && (hi[k] - whi[k]).abs() < 1e-12,
                    "{key} axis {k}: [{}, {}] against [{}, {}]",
                    lo[k],
                    hi[k],
                    wlo[k],
                    whi[k]
                );
            }
            if let Some(c) = lg.collision.first()
                && let Geometry::Mesh(cm) = &c.geometry
            {
                let (clo, chi) = bounds(&cm.load().expect("collision stl"));
                for k in 0..3 {
                    assert!(
                        (lo[k] - clo[k]).abs() < 0.03 && (hi[k] - chi[k]).abs() < 0.03,
                        "{key} axis {k}: visual [{}, {}] collision [{}, {}]",
                        lo[k],
                        hi[k],
                        clo[k],
                        chi[k]
                    );
                }
            }
            loaded.insert(key.to_string());
        }
    }
    assert_eq!(visuals, 11, "link0..7, hand, two fingers");
    assert_eq!(
        loaded.len(),
        reference.as_object().expect("map").len(),
        "every file in the reference loaded: {loaded:?}"
    );
}

/// A malformed Collada file is a typed error naming the URDF's `<mesh>` and the .dae's own
/// line and element; a missing one is `NotFound`.
#[test]
fn malformed_and_missing_dae_are_typed_errors_naming_file_and_element() {
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::write(
        tmp.path().join("bad.dae"),
        concat!(
            "<?xml version=\"1.0\"?>\n<COLLADA>\n<library_geometries>\n<geometry id=\"g\"><mesh>\n",
            "<source id=\"s\"><float_array id=\"a\" count=\"9\">0 0 0 1 0 zero 0 1 0</float_array></source>\n",
            "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#s\"/></vertices>\n",
            "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 2</p></triangles>\n",
            "</mesh></geometry>\n</library_geometries>\n</COLLADA>"
        ),
    )
    .expect("write");
    let urdf = tmp.path().join("d.urdf");
    std::fs::write(
        &urdf,
        r#"<robot name="d"><link name="a">
  <visual><geometry><mesh filename="bad.dae"/></geometry></visual>
  <visual><geometry><mesh filename="gone.dae"/></geometry></visual>
</link></robot>"#,
    )
    .expect("write");
    let r = import_urdf(&urdf, None).expect("meshes are not read at import");
    let lg = &r.geometry.links["a"];
    let Geometry::Mesh(bad) = &lg.visual[0].geometry else {
        panic!("a mesh")
    };
    let e = bad.load().expect_err("malformed");
    let UrdfErrorKind::Mesh(MeshProblem::Dae(d)) = &e.kind else {
        panic!("{e}")
    };
    assert_eq!((d.line, d.element.as_str()), (5, "<float_array id=\"a\">"));
    assert!(d.file.ends_with("bad.dae"));
    assert_eq!((e.file.as_path(), e.line), (urdf.as_path(), 2));
    let text = e.to_string();
    assert!(text.contains("bad.dae:5: <float_array id=\"a\">"), "{text}");
    assert!(text.contains("\"zero\" is not a finite number"), "{text}");
    assert!(text.contains("d.urdf:2"), "{text}");
    let Geometry::Mesh(gone) = &lg.visual[1].geometry else {
        panic!("a mesh")
    };
    let e = gone.load().expect_err("missing");
    assert!(
        matches!(&e.kind, UrdfErrorKind::Mesh(MeshProblem::NotFound(p)) if p.ends_with("gone.dae")),
        "{e}"
    );
    assert_eq!(e.line, 3);
}
