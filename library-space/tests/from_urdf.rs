//! `robot NAME from_urdf "FILE" { tip: …, base: … }`: a Library Space robot read from a URDF
//! file. Real files: the Panda of testdata/urdf (referenced by absolute path: its meshes are
//! `package://` names found from the file's own folder) and small URDFs written to a temp dir
//! next to the `.rsl` that declares them (relative names).

use nalgebra::Matrix4;
use rand::{Rng, SeedableRng};
use robosim_kinematics::fk::{forward, link_frames};
use robosim_library::{ErrorKind, Evaluated, Library, Params, Primitive, RobotModel};
use std::path::{Path, PathBuf};

fn panda_urdf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf/panda.urdf")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn robot(lib: &Library, name: &str, params: &Params) -> RobotModel {
    match lib.evaluate(name, params).expect("evaluates") {
        Evaluated::Robot(r) => r,
        other => panic!("{name} is not a robot: {other:?}"),
    }
}

fn max_diff(a: &Matrix4<f64>, b: &Matrix4<f64>) -> f64 {
    (a - b).abs().max()
}

fn translate(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new_translation(&nalgebra::Vector3::new(x, y, z))
}

fn rot_z(a: f64) -> Matrix4<f64> {
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), a).to_homogeneous()
}

#[test]
fn the_panda_chain_with_a_tip_and_a_base_has_the_urdf_readers_kinematics() {
    let tmp = tempfile::tempdir().expect("tmp");
    let rsl = write(
        tmp.path(),
        "arms.rsl",
        &format!(
            "// The Panda, root to its flange.\n\
             robot panda_arm(height = 0.5 m) from_urdf \"{}\" {{\n\
             \x20   tip: \"panda_link8\"\n\
             \x20   base: translate(0.1 m, 0, height) * rotate_z(90 deg)\n\
             }}\n",
            panda_urdf().display()
        ),
    );
    let lib = Library::load(&rsl).expect("loads");
    let m = robot(&lib, "panda_arm", &Params::new());
    let u = robosim_urdf::import_urdf(&panda_urdf(), Some("panda_link8")).expect("imports");
    assert_eq!(m.robot.dof(), 7);
    assert_eq!(m.robot.name, "panda_arm");
    let links: Vec<String> = (1..=7).map(|k| format!("panda_link{k}")).collect();
    assert_eq!(m.link_names, links);
    assert!(
        m.robot.joints.iter().all(|j| j.origin.is_some()),
        "general joints"
    );
    let base = translate(0.1, 0.0, 0.5) * rot_z(std::f64::consts::FRAC_PI_2);
    assert!(max_diff(&m.robot.base, &(base * u.robot.base)) < 1e-15);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(14);
    for _ in 0..50 {
        let q: Vec<f64> = u
            .robot
            .joints
            .iter()
            .map(|j| rng.random_range(j.qlim[0]..=j.qlim[1]))
            .collect();
        let want = base * forward(&u.robot, &q);
        let got = forward(&m.robot, &q);
        assert!(max_diff(&got, &want) <= 1e-12, "q {q:?}: {got} vs {want}");
        // every link frame, not only the tool
        for (a, b) in link_frames(&m.robot, &q)
            .iter()
            .zip(link_frames(&u.robot, &q))
        {
            assert!(max_diff(a, &(base * b)) <= 1e-12);
        }
    }
    // The parameter moves the base, as it does for any declared robot.
    let high = robot(&lib, "panda_arm", &Params::new().expr("height", "1.5 m"));
    assert!((high.robot.base[(2, 3)] - 1.5).abs() < 1e-15);
    // Solids: every body of the chain has its collision mesh's hull (the Panda's links 0-7
    // each have one), closed polyhedra centred on their bounding boxes, in the body's frame;
    // body 7 also carries what is fixed to it or held off the chain: link 8 (no collision),
    // the hand's hull and the fingers' four boxes each.
    assert_eq!(m.frames.len(), 8);
    for (j, f) in m.frames.iter().enumerate() {
        let names: Vec<&str> = f.iter().map(|p| p.name.as_str()).collect();
        if j < 7 {
            assert_eq!(names, [format!("panda_link{j}/collision0")], "body {j}");
        } else {
            assert_eq!(names.len(), 10, "{names:?}");
            assert!(
                names.contains(&"panda_link7/collision0")
                    && names.contains(&"panda_hand/collision0")
            );
            assert_eq!(names.iter().filter(|n| n.contains("finger")).count(), 8);
        }
        for p in f {
            assert!(p.polyhedron.is_closed(), "{} is closed", p.name);
            assert!(matches!(p.primitive, Primitive::Box { .. }));
            assert!(p.polyhedron.bbox.center.coords.norm() < 1e-9, "{}", p.name);
        }
    }
    // The hull holds the mesh: every vertex of the STL is on or inside it (in the link frame).
    let g = &u.geometry.links["panda_link4"];
    let robosim_urdf::urdf_geometry::Geometry::Mesh(mesh) = &g.collision[0].geometry else {
        panic!("link 4's collision is a mesh");
    };
    let tris = mesh.load().expect("mesh loads");
    let hull = &m.frames[4][0];
    // the mesh's vertices are in its geometry frame; the hull's transform maps the hull's
    // own frame into the body's
    let to_hull = hull.transform.try_inverse().expect("rigid") * g.in_body * g.collision[0].origin;
    let mut worst = f64::NEG_INFINITY;
    for v in tris.iter().flatten() {
        let p = to_hull.transform_point(&nalgebra::Point3::new(v[0], v[1], v[2]));
        for poly in &hull.polyhedron.polygons {
            worst = worst.max(poly.plane.signed_distance(&p));
        }
    }
    println!("worst vertex outside the hull of link 4: {worst:e} m");
    assert!(
        worst <= 1e-12,
        "a mesh vertex is {worst} m outside the hull"
    );
    assert!(worst > -1e-9, "some mesh vertex lies on the hull");
}

#[test]
fn the_whole_panda_tree_has_nine_joints_and_the_panda_parents() {
    let tmp = tempfile::tempdir().expect("tmp");
    let rsl = write(
        tmp.path(),
        "tree.rsl",
        &format!(
            "robot panda_tree from_urdf \"{}\"\n",
            panda_urdf().display()
        ),
    );
    let lib = Library::load(&rsl).expect("loads");
    let m = robot(&lib, "panda_tree", &Params::new());
    let u = robosim_urdf::import_urdf_tree(&panda_urdf()).expect("imports");
    assert_eq!(m.robot.dof(), 9);
    assert_eq!(m.robot.parents, vec![0, 1, 2, 3, 4, 5, 6, 7, 7]);
    assert_eq!(m.robot.parents, u.robot.parents);
    assert_eq!(m.link_names[7..], ["panda_leftfinger", "panda_rightfinger"]);
    assert!(m.ik.is_none(), "a tree has no closed-form IK family");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    for _ in 0..20 {
        let q: Vec<f64> = u
            .robot
            .joints
            .iter()
            .map(|j| rng.random_range(j.qlim[0]..=j.qlim[1]))
            .collect();
        for (a, b) in link_frames(&m.robot, &q)
            .iter()
            .zip(link_frames(&u.robot, &q))
        {
            assert!(max_diff(a, &b) <= 1e-12);
        }
    }
    // the hand (fixed to link 7) and both fingers have collision solids
    assert!(
        m.frames[7]
            .iter()
            .any(|p| p.name.starts_with("panda_hand/"))
    );
    assert!(!m.frames[8].is_empty() && !m.frames[9].is_empty());
}

const SMALL: &str = r#"<?xml version="1.0"?>
<robot name="small">
  <material name="orange"><color rgba="1 0.5 0 1"/></material>
  <link name="base">
    <collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision>
  </link>
  <link name="upper">
    <visual><geometry><box size="1 1 1"/></geometry><material name="orange"/></visual>
    <collision><origin xyz="0 0 0.25"/><geometry><cylinder radius="0.05" length="0.5"/></geometry></collision>
  </link>
  <link name="hand">
    <collision><geometry><sphere radius="0.08"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="10" velocity="1"/>
  </joint>
  <joint name="wrist" type="continuous">
    <parent link="upper"/><child link="hand"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
  </joint>
</robot>
"#;

#[test]
fn a_relative_name_is_read_from_the_declaring_files_folder_with_its_shapes_and_colours() {
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::create_dir(tmp.path().join("urdf")).expect("mkdir");
    write(&tmp.path().join("urdf"), "small.urdf", SMALL);
    // the .rsl includes a second file in another folder; its relative name is from *its* folder
    std::fs::create_dir(tmp.path().join("lib")).expect("mkdir");
    write(
        &tmp.path().join("lib"),
        "small.rsl",
        "robot small from_urdf \"../urdf/small.urdf\" { facets: 16 }\n",
    );
    let top = write(tmp.path(), "top.rsl", "include \"lib/small.rsl\"\n");
    let lib = Library::load(&top).expect("loads");
    let m = robot(&lib, "small", &Params::new());
    assert_eq!(m.link_names, ["upper", "hand"]);
    assert_eq!(
        m.robot.parents,
        Vec::<usize>::new(),
        "a chain: the tree has one branch"
    );
    let prims: Vec<Vec<&Primitive>> = m
        .frames
        .iter()
        .map(|f| f.iter().map(|p| &p.primitive).collect())
        .collect();
    assert_eq!(
        prims,
        vec![
            vec![&Primitive::Box {
                size: [0.4, 0.2, 0.1]
            }],
            vec![&Primitive::Cylinder {
                radius: 0.05,
                height: 0.5,
                facets: 16
            }],
            vec![&Primitive::Sphere {
                radius: 0.08,
                facets: 16
            }],
        ]
    );
    assert_eq!(
        m.frames[1][0].colour,
        Some([1.0, 0.5, 0.0]),
        "the visual's material"
    );
    assert_eq!(m.frames[0][0].colour, None);
    assert!(max_diff(&m.frames[1][0].transform, &translate(0.0, 0.0, 0.25)) < 1e-15);
    // at q = (0.3, 0): the cylinder's centre is 0.25 m up the upper arm, turned about y
    let q = [0.3, 0.0];
    let frames = link_frames(&m.robot, &q);
    let c = frames[1] * m.frames[1][0].transform;
    let want = [0.25 * 0.3f64.sin(), 0.0, 0.1 + 0.25 * 0.3f64.cos()];
    for k in 0..3 {
        assert!((c[(k, 3)] - want[k]).abs() < 1e-12, "{c}");
    }
}

fn load_err(text: &str, dir: &Path) -> robosim_library::LibError {
    let rsl = write(dir, "bad.rsl", text);
    match Library::load(&rsl) {
        Err(robosim_library::Error::Source(e)) => e,
        Err(other) => panic!("not a located error: {other}"),
        Ok(_) => panic!("loaded"),
    }
}

#[test]
fn a_missing_file_names_the_rsl_place_and_the_urdf_problem() {
    let tmp = tempfile::tempdir().expect("tmp");
    let e = load_err(
        "// nothing there\nrobot ghost from_urdf \"nowhere/ghost.urdf\" {\n    tip: \"x\"\n}\n",
        tmp.path(),
    );
    assert_eq!(e.kind, ErrorKind::Include);
    assert_eq!((e.location.line, e.location.column), (2, 23), "{e}");
    assert!(e.location.file.ends_with("bad.rsl"));
    let text = e.to_string();
    let missing = tmp.path().join("nowhere/ghost.urdf");
    assert!(
        text.contains(&format!(
            "{}:0: file: cannot read the file",
            missing.display()
        )),
        "{text}"
    );
    assert!(text.contains("bad.rsl:2:23"), "{text}");
}

#[test]
fn a_tip_that_is_not_a_link_names_the_tip_and_the_urdf() {
    let tmp = tempfile::tempdir().expect("tmp");
    write(tmp.path(), "small.urdf", SMALL);
    let e = load_err(
        "robot small from_urdf \"small.urdf\" {\n    tip: \"elbow\"\n}\n",
        tmp.path(),
    );
    assert_eq!(e.kind, ErrorKind::Include);
    assert_eq!((e.location.line, e.location.column), (2, 10), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("tip \"elbow\" is not a <link> of this robot"),
        "{text}"
    );
    assert!(
        text.contains(&format!("{}:", tmp.path().join("small.urdf").display())),
        "{text}"
    );
}

#[test]
fn a_malformed_urdf_names_its_own_line_and_element() {
    let tmp = tempfile::tempdir().expect("tmp");
    let broken = SMALL.replace("radius=\"0.08\"", "radius=\"big\"");
    write(tmp.path(), "broken.urdf", &broken);
    let e = load_err("robot small from_urdf \"broken.urdf\"\n", tmp.path());
    assert_eq!((e.location.line, e.location.column), (1, 23), "{e}");
    let line = broken
        .lines()
        .position(|l| l.contains("radius=\"big\""))
        .expect("the line")
        + 1;
    let text = e.to_string();
    assert!(
        text.contains(&format!("broken.urdf:{line}:")) && text.contains("\"big\""),
        "{text}"
    );
}

#[test]
fn from_urdf_is_only_for_robots_and_takes_only_robot_properties() {
    let tmp = tempfile::tempdir().expect("tmp");
    write(tmp.path(), "small.urdf", SMALL);
    let e = load_err("solid thing from_urdf \"small.urdf\" {}\n", tmp.path());
    assert_eq!(e.kind, ErrorKind::Syntax);
    assert!(
        e.message.contains("a solid cannot be read `from_urdf`"),
        "{e}"
    );
    let e = load_err(
        "robot small from_urdf \"small.urdf\" {\n    link extra { joint: revolute }\n}\n",
        tmp.path(),
    );
    assert_eq!(e.kind, ErrorKind::Syntax);
    assert_eq!(e.location.line, 2);
    let e = load_err(
        "robot small from_urdf \"small.urdf\" {\n    tipp: \"hand\"\n}\n",
        tmp.path(),
    );
    assert_eq!(e.kind, ErrorKind::UnknownProperty);
    assert!(e.message.contains("did you mean `tip`?"), "{e}");
}

#[test]
fn a_library_rebuilt_from_its_sources_reads_relative_names_from_the_recorded_folder() {
    // What a process does with a library it gets as text (Library::sources / from_sources):
    // the file's recorded name gives the folder.
    let tmp = tempfile::tempdir().expect("tmp");
    write(tmp.path(), "small.urdf", SMALL);
    let rsl = write(
        tmp.path(),
        "small.rsl",
        "robot small from_urdf \"small.urdf\"\n",
    );
    let lib = Library::load(&rsl).expect("loads");
    let again = Library::from_sources(&lib.sources()).expect("rebuilds");
    assert_eq!(
        robot(&again, "small", &Params::new()),
        robot(&lib, "small", &Params::new())
    );
    let elsewhere = Library::from_sources(&[(
        "/nonexistent-folder/small.rsl".to_string(),
        "robot small from_urdf \"small.urdf\"\n".to_string(),
    )])
    .expect_err("no such folder");
    assert!(
        elsewhere
            .to_string()
            .contains("/nonexistent-folder/small.urdf:0: file: cannot read the file"),
        "{elsewhere}"
    );
}
