//! Geometry in the URDF and MJCF exports (issue 36 item 4): every standard-library robot and two
//! URDF-imported robots (UR5, the Panda's arm) exported with their shapes, the files (and the
//! STL meshes written beside them) read back by robosim's own URDF and MJCF importers, and at
//! several q each shape's world pose compared with the original's: primitives (same kind and
//! size, pose to 1e-12) and meshes (the world box of their vertices, to 1e-6 m: STL stores f32).
//! Which geometry an original robot has: its robot model's (`robosim_model::GeometryModel`), written
//! as [`robosim_file_io::export_geometry`] says.

use nalgebra::Matrix4;
use robosim_file_io::export_geometry::{ExportShapes, ShapeKind};
use robosim_file_io::urdf_geometry::Geometry;
use robosim_file_io::urdf_import::UrdfRobot;
use robosim_kinematics::{Robot, fk};
use std::path::Path;

/// A shape of the re-imported file in the world at q.
struct Found {
    name: String,
    visual: bool,
    world: Matrix4<f64>,
    geometry: Geometry,
}

/// Every `<visual>`/`<collision>` (URDF) or geom (MJCF, names `<shape>_visual` /
/// `<shape>_collision`) of `u` at q (`u`'s own joint order). robosim's MJCF import draws a
/// colliding geom too (it is in both lists): those are taken as collision shapes only.
fn found(u: &UrdfRobot, q: &[f64]) -> Vec<Found> {
    let frames = fk::link_frames(&u.robot, q);
    let mut out = Vec::new();
    for lg in u.geometry.links.values() {
        for (visual, list) in [(true, &lg.visual), (false, &lg.collision)] {
            for s in list {
                let full = s.name.clone().unwrap_or_default();
                let name = match (
                    full.strip_suffix("_visual"),
                    full.strip_suffix("_collision"),
                ) {
                    (Some(n), _) if visual => n.to_string(),
                    (_, Some(_)) if visual => continue,
                    (_, Some(n)) => n.to_string(),
                    _ => full,
                };
                out.push(Found {
                    name,
                    visual,
                    world: frames[lg.body] * lg.in_body * s.origin,
                    geometry: s.geometry.clone(),
                });
            }
        }
    }
    out
}

fn world_box(tris: &[[[f64; 3]; 3]], at: &Matrix4<f64>) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for t in tris {
        for v in t {
            let p = at * nalgebra::Vector4::new(v[0], v[1], v[2], 1.0);
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
    }
    (lo, hi)
}

/// q for the sample `k`: spread over each joint's range ([-π, π] when unbounded).
fn sample_q(robot: &Robot, k: usize) -> Vec<f64> {
    robot
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let [lo, hi] = if j.qlim[0].is_finite() && j.qlim[1].is_finite() {
                j.qlim
            } else {
                [-std::f64::consts::PI, std::f64::consts::PI]
            };
            let t = ((k * 7 + i * 3 + 1) as f64 * 0.618_033_988_749_895).fract();
            lo + (hi - lo) * t
        })
        .collect()
}

/// Compares the re-import `u` of `robot` exported with `geometry` at a few q; returns the count
/// of (shape, role) pairs compared. `joint`: the exported joint name of robosim's joint i
/// (0-based) — the re-import's q order is found through it.
fn compare(what: &str, robot: &Robot, geometry: &ExportShapes<'_>, u: &UrdfRobot) -> usize {
    assert_eq!(u.robot.dof(), robot.dof(), "{what}: joints");
    // u's joint k is robosim's joint `order[k]`.
    let order: Vec<usize> = u
        .joints
        .iter()
        .map(|j| {
            let i: usize = j
                .name
                .rsplit_once("_joint")
                .and_then(|(_, i)| i.parse().ok())
                .unwrap_or_else(|| panic!("{what}: joint name {:?}", j.name));
            i - 1
        })
        .collect();
    let mut compared = 0;
    for k in 0..3 {
        let q = sample_q(robot, k);
        let q_u: Vec<f64> = order.iter().map(|&i| q[i]).collect();
        let frames = fk::link_frames(robot, &q);
        let theirs = found(u, &q_u);
        compared = 0;
        for s in &geometry.shapes {
            let want = frames[s.object.frame] * s.object.placement;
            for (visual, on) in [(true, s.visual), (false, s.collision)] {
                if !on {
                    continue;
                }
                let hits: Vec<&Found> = theirs
                    .iter()
                    .filter(|f| f.name == s.name && f.visual == visual)
                    .collect();
                assert_eq!(
                    hits.len(),
                    1,
                    "{what}: shape {} (visual {visual}) found {} times",
                    s.name,
                    hits.len()
                );
                let f = hits[0];
                let scale = 1.0 + want.fixed_view::<3, 1>(0, 3).amax();
                match (&s.kind, &f.geometry) {
                    (ShapeKind::Box { size }, Geometry::Box { size: got }) => {
                        let d = (0..3).map(|i| (size[i] - got[i]).abs()).fold(0.0, f64::max);
                        assert!(d < 1e-14, "{what}: {} box size {got:?} vs {size:?}", s.name);
                    }
                    (
                        ShapeKind::Cylinder { radius, length },
                        Geometry::Cylinder {
                            radius: r,
                            length: l,
                        },
                    ) => {
                        assert!(
                            (radius - r).abs() < 1e-14 && (length - l).abs() < 1e-14,
                            "{what}: {} cylinder {r} {l} vs {radius} {length}",
                            s.name
                        );
                    }
                    (ShapeKind::Sphere { radius }, Geometry::Sphere { radius: r }) => {
                        assert!((radius - r).abs() < 1e-14, "{what}: {} sphere", s.name);
                    }
                    (ShapeKind::Mesh { triangles }, Geometry::Mesh(m)) => {
                        let got = m
                            .load()
                            .unwrap_or_else(|e| panic!("{what}: {} mesh: {e}", s.name));
                        assert_eq!(got.len(), triangles.len(), "{what}: {} triangles", s.name);
                        let (a, b) = (world_box(triangles, &want), world_box(&got, &f.world));
                        for i in 0..3 {
                            assert!(
                                (a.0[i] - b.0[i]).abs() < 1e-6 && (a.1[i] - b.1[i]).abs() < 1e-6,
                                "{what}: {} mesh box {b:?} vs {a:?}",
                                s.name
                            );
                        }
                        compared += 1;
                        continue;
                    }
                    (k, g) => panic!("{what}: {} written as {k:?}, read as {g:?}", s.name),
                }
                let d = (f.world - want).amax();
                assert!(
                    d < 1e-12 * scale,
                    "{what}: {} pose differs by {d:e} at q = {q:?}:\n{}\nvs\n{}",
                    s.name,
                    f.world,
                    want
                );
                compared += 1;
            }
        }
        // Nothing else in the file.
        assert_eq!(theirs.len(), compared, "{what}: shapes in the file");
    }
    compared
}

fn export_both(name: &str, library: &[std::path::PathBuf], dir: &Path) -> usize {
    let models = robosim_file_io::export_robot_models(name, library)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let (robot, geometry) = (&models[0].robot, &models[0].geometry);
    let model = geometry.as_ref().expect("a library robot has geometry");
    let geometry = &ExportShapes::of(model);
    // Only a visual mesh missing from testdata (the UR5's Collada files) may be left out.
    assert!(models[0].notes.is_empty(), "{name}: {:?}", models[0].notes);
    for n in &geometry.notes {
        assert!(
            n.contains("visual mesh") && n.contains("does not exist"),
            "{name}: {n}"
        );
    }
    let mut n = 0;
    // URDF
    let (text, _, meshes) =
        robosim_file_io::urdf::to_urdf_with_geometry(robot, None, Some(model), &format!("{name}_"))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    for m in &meshes {
        std::fs::write(dir.join(&m.file), &m.bytes).expect("mesh written");
    }
    let path = dir.join(format!("{name}.urdf"));
    std::fs::write(&path, &text).expect("URDF written");
    let u = robosim_file_io::urdf_import::import_urdf_tree(&path)
        .unwrap_or_else(|e| panic!("{name}: robosim does not read its URDF export: {e}"));
    n += compare(&format!("{name} URDF"), robot, geometry, &u);
    // MJCF
    let (text, _, meshes) = robosim_file_io::mjcf_export::to_mjcf_with_geometry(
        robot,
        None,
        Some(model),
        &format!("{name}_"),
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    for m in &meshes {
        std::fs::write(dir.join(&m.file), &m.bytes).expect("mesh written");
    }
    let path = dir.join(format!("{name}.xml"));
    std::fs::write(&path, &text).expect("MJCF written");
    let u = robosim_file_io::mjcf::import_mjcf_tree(&path)
        .unwrap_or_else(|e| panic!("{name}: robosim does not read its MJCF export: {e}"));
    n += compare(&format!("{name} MJCF"), robot, geometry, &u);
    n
}

/// Every standard-library robot (the ten robot declarations of library-space/stdlib) with its
/// solids: primitives stay primitives (the PUMA and the
/// Stanford arm are boxes, cylinders and spheres), the rest (cones, revolutions, extrusions)
/// become meshes; all in place in both formats.
#[test]
fn library_robots_geometry_round_trips_in_place() {
    let dir = tempfile::tempdir().expect("temp dir");
    for name in [
        "puma560",
        "stanford",
        "weld_positioner",
        "panda",
        "weld_arm",
        "weld_study_positioner",
        "surgical_positioner",
        "station_servicer",
        "station_solar_structure",
        "station_outboard_assembly",
    ] {
        let n = export_both(name, &[], dir.path());
        eprintln!("{name}: {n} shapes compared");
        assert!(n > 0, "{name}: no geometry exported");
    }
    // The PUMA's solids are primitives: no mesh written for it.
    let models = robosim_file_io::export_robot_models("puma560", &[]).expect("puma560");
    let g = ExportShapes::of(models[0].geometry.as_ref().expect("geometry"));
    assert!(
        g.shapes
            .iter()
            .all(|s| !matches!(s.kind, ShapeKind::Mesh { .. }))
    );
    assert!(
        g.shapes
            .iter()
            .any(|s| matches!(s.kind, ShapeKind::Sphere { .. }))
    );
}

/// A robot whose solids are no URDF primitive (a cone, an extrusion, a revolution, on the base
/// and on a link behind a DH `a`/`α`): written as STL meshes, in place.
#[test]
fn solids_that_are_no_primitive_become_meshes_in_place() {
    let dir = tempfile::tempdir().expect("temp dir");
    let lib = dir.path().join("shapes.rsl");
    std::fs::write(
        &lib,
        "robot shapes_arm {\n    convention: standard\n    base: translate(0.1 m, 0.2 m, 0.3 m) * rotate_x(30 deg)\n    part foot = cone(radius: 0.2 m, height: 0.3 m) at translate(0, 0, 0.15 m)\n    link one {\n        joint: revolute\n        a: 0.4 m\n        alpha: 90 deg\n        d: 0.1 m\n        limits: [-90 deg, 90 deg]\n        part fin = extrude(points: [[0, 0], [0.2 m, 0], [0.1 m, 0.15 m]], height: 0.05 m) at translate(-0.2 m, 0, 0) * rotate_y(20 deg)\n        part knob = revolve(points: [[0, 0], [0.05 m, 0], [0.03 m, 0.08 m], [0, 0.1 m]]) at translate(0, 0.1 m, 0)\n        part rod = cylinder(radius: 0.02 m, height: 0.4 m) at rotate_y(90 deg) * translate(0, 0, -0.2 m)\n    }\n    link two {\n        joint: prismatic\n        theta: 30 deg\n        limits: [0, 0.3 m]\n        part truncated_cone(bottom: 0.05 m, top: 0.03 m, height: 0.2 m)\n    }\n}\n",
    )
    .expect("library written");
    let models = robosim_file_io::export_robot_models("shapes_arm", std::slice::from_ref(&lib))
        .expect("exports");
    let g = ExportShapes::of(models[0].geometry.as_ref().expect("geometry"));
    let meshes = g
        .shapes
        .iter()
        .filter(|s| matches!(s.kind, ShapeKind::Mesh { .. }))
        .count();
    assert_eq!(meshes, 4, "cone, extrusion, revolution, truncated cone");
    let n = export_both("shapes_arm", std::slice::from_ref(&lib), dir.path());
    // 5 shapes, each visual and collision, in 2 formats
    assert_eq!(n, 20);
}

/// URDF robots imported through the library (`from_urdf`): the file's own visuals (the UR5's
/// and Panda's Collada meshes) and collisions (STL meshes), written as STL, in place.
#[test]
fn imported_robots_geometry_round_trips_in_place() {
    let dir = tempfile::tempdir().expect("temp dir");
    let testdata = crate::reference::testdata();
    let lib = dir.path().join("robots.rsl");
    std::fs::write(
        &lib,
        format!(
            "robot ur5 from_urdf \"{}\" {{ tip: \"tool0\" }}\nrobot panda_arm from_urdf \"{}\" {{ tip: \"panda_hand\" }}\n",
            testdata.join("urdf/ur5_robot.urdf").display(),
            testdata.join("urdf/panda.urdf").display()
        ),
    )
    .expect("library written");
    for name in ["ur5", "panda_arm"] {
        let models = robosim_file_io::export_robot_models(name, std::slice::from_ref(&lib))
            .expect("exports");
        let g = ExportShapes::of(models[0].geometry.as_ref().expect("geometry"));
        // the file's collisions (and visuals where their meshes are in testdata: the Panda's),
        // not the library's hulls
        assert!(g.shapes.iter().any(|s| s.collision && !s.visual));
        if name == "panda_arm" {
            assert!(g.shapes.iter().any(|s| s.visual && !s.collision));
            assert!(g.notes.is_empty(), "{:?}", g.notes);
        }
        let n = export_both(name, std::slice::from_ref(&lib), dir.path());
        eprintln!("{name}: {n} shapes compared");
    }
}

/// A solid labelled a box whose polyhedron is not that box (a `from_urdf` mesh hull carries its
/// bounding box as its primitive) is written as its mesh, not as the box: the robot model has
/// it as polygons (`RobotModel::model`), which the export writes as their triangles; a box
/// stays a box.
#[test]
fn a_hull_labelled_a_box_is_written_as_a_mesh() {
    let hull = robosim_geometry::Polyhedron::from_polygons(
        vec![
            nalgebra::Point3::new(0.0, 0.0, 0.0),
            nalgebra::Point3::new(1.0, 0.0, 0.0),
            nalgebra::Point3::new(0.0, 1.0, 0.0),
            nalgebra::Point3::new(0.0, 0.0, 1.0),
        ],
        &[vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]],
    )
    .expect("tetrahedron");
    let solid = |primitive, polyhedron| robosim_library::PlacedSolid {
        name: "part".into(),
        primitive,
        polyhedron,
        transform: Matrix4::identity(),
        colour: None,
        surface: None,
    };
    let mut r = match robosim_scene::build_library(&[])
        .expect("standard library")
        .evaluate("puma560", &robosim_library::Params::new())
    {
        Ok(robosim_library::Evaluated::Robot(r)) => r,
        _ => panic!("puma560 is a robot"),
    };
    for f in &mut r.frames {
        f.clear();
    }
    r.frames[0] = vec![
        solid(robosim_library::Primitive::Box { size: [1.0; 3] }, hull),
        solid(
            robosim_library::Primitive::Box {
                size: [1.0, 2.0, 3.0],
            },
            robosim_geometry::shapes::cuboid(1.0, 2.0, 3.0).expect("box"),
        ),
    ];
    let model = robosim_file_io::library_geometry(&r);
    let g = ExportShapes::of(&model);
    assert!(matches!(&g.shapes[0].kind, ShapeKind::Mesh { triangles } if triangles.len() == 4));
    assert_eq!(
        g.shapes[1].kind,
        ShapeKind::Box {
            size: [1.0, 2.0, 3.0]
        }
    );
    // Both drawn and collided (the library draws what it collides), named after their link.
    assert!(g.shapes.iter().all(|s| s.visual && s.collision));
    assert_eq!(g.shapes[0].name, "link0_part");
    assert_eq!(g.shapes[1].name, "link0_part_2");
}

/// A robot read `from_mjcf` (issue 36 item 5): its export takes the MJCF's own geoms (the MJCF
/// reader gives the same imported robot), not the library's solids with a "could not be
/// matched" note; a box and a sphere stay primitives, in place in both formats.
#[test]
fn a_from_mjcf_robot_exports_the_files_own_geoms() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(
        dir.path().join("small.xml"),
        r#"<mujoco model="small">
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper" pos="0 0 0.3">
      <joint name="shoulder" axis="0 0 1" range="-3 3"/>
      <inertial pos="0.2 0 0" mass="2" diaginertia="0.01 0.02 0.03"/>
      <geom type="box" size="0.2 0.05 0.05" pos="0.2 0 0"/>
      <body name="fore" pos="0.4 0 0">
        <joint name="elbow" axis="0 1 0" range="-2 2"/>
        <inertial pos="0.15 0 0" mass="1" diaginertia="0.004 0.005 0.006"/>
        <geom type="sphere" size="0.05" pos="0.3 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"#,
    )
    .expect("MJCF written");
    let lib = dir.path().join("robots.rsl");
    std::fs::write(
        &lib,
        "robot small from_mjcf \"small.xml\" { tip: \"fore\" }\n",
    )
    .expect("library written");
    let models =
        robosim_file_io::export_robot_models("small", std::slice::from_ref(&lib)).expect("exports");
    assert!(models[0].notes.is_empty(), "{:?}", models[0].notes);
    let g = ExportShapes::of(models[0].geometry.as_ref().expect("geometry"));
    assert!(g.notes.is_empty(), "{:?}", g.notes);
    assert!(
        g.shapes
            .iter()
            .any(|s| matches!(s.kind, ShapeKind::Box { .. }))
    );
    assert!(
        g.shapes
            .iter()
            .any(|s| matches!(s.kind, ShapeKind::Sphere { .. }))
    );
    let n = export_both("small", std::slice::from_ref(&lib), dir.path());
    assert!(n >= 4, "{n} shapes compared");
}

/// A session's robots (here a model built in-process as the keeper would hold it): the
/// Instance Space carries no friction or shapes, so the export takes them from the library
/// declaration the robot — or the scene instance holding it — was made from.
#[test]
fn a_session_robot_exports_its_declarations_friction_and_geometry() {
    let lib = robosim_scene::build_library(&[]).expect("standard library");
    for (instance, robot_name, declaration) in [
        ("puma560", "puma560", "puma560"),
        ("downhand_welding_cell", "positioner", "weld_positioner"),
        ("downhand_welding_cell", "arm", "weld_arm"),
    ] {
        let mut store = robosim_instance_space::Store::new();
        for tx in robosim_scene::load_from(&lib, instance).expect("instantiates") {
            store.apply(&tx).expect("applies");
        }
        let snap = robosim_instance_space::Snapshot::from_store(&store);
        // without the session's models the joint record has no friction
        let plain = robosim_file_io::robots_of(&snap);
        let models = robosim_file_io::session_robot_models(&snap, &lib.sources());
        assert_eq!(models.len(), plain.len());
        let found = models
            .iter()
            .find(|r| r.robot.name == robot_name)
            .unwrap_or_else(|| panic!("{instance}: robot {robot_name}"));
        let (robot, geometry) = (&found.robot, &found.geometry);
        let declared = robosim_file_io::export_robot_models(declaration, &[]).expect("declared");
        let (want, want_geometry) = (&declared[0].robot, &declared[0].geometry);
        for (k, (j, w)) in robot.joints.iter().zip(&want.joints).enumerate() {
            assert_eq!(
                (j.viscous, j.coulomb, j.motor_inertia),
                (w.viscous, w.coulomb, w.motor_inertia),
                "{instance}: joint {k}"
            );
        }
        assert!(
            robot
                .joints
                .iter()
                .any(|j| j.viscous != 0.0 || j.motor_inertia != 0.0)
                || robot_name != "puma560",
            "{instance}: the PUMA declares friction"
        );
        let g = geometry.as_ref().expect("geometry from the declaration");
        assert_eq!(g, want_geometry.as_ref().expect("declared geometry"));
        // and it is written where the declaration's is: the URDF text equals the library
        // export's but for the base placement (the scene places the robot)
        let (text, _, _) = robosim_file_io::urdf::to_urdf_with_geometry(robot, None, Some(g), "m_")
            .expect("exports");
        assert_eq!(
            text.matches("<collision").count(),
            g.of(robosim_model::Role::Collision).count()
        );
    }
}
