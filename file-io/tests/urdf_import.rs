//! URDF import against Pinocchio on real robots (testdata/urdf/: the UR5 and the Panda of
//! example-robot-data, read by `pinocchio_reference.py`), and against robosim's own DH robots
//! through the URDF exporter (DH → URDF → general joints must be the same robot).

use crate::reference;

use nalgebra::DMatrix;
use reference::{floats, matrix, rel};
use robosim_file_io::urdf_import::{UrdfRobot, import_urdf, import_urdf_str, import_urdf_tree};
use robosim_kinematics::jacobian::{Frame, jacobian, link_jacobian};
use robosim_kinematics::{Robot, fk};
use std::path::Path;

fn dir() -> std::path::PathBuf {
    reference::testdata()
}

/// Pose, Jacobians (base = Pinocchio LOCAL_WORLD_ALIGNED, tool = LOCAL), RNEA, CRBA and ABA of
/// the imported UR5 and Panda against Pinocchio 4.1 at 20 random states each. The vendored
/// URDFs name meshes that are not all there (the UR5's visuals): FK and dynamics must not need them.
#[test]
fn imported_urdfs_match_pinocchio() {
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("urdf/pinocchio_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let mut worst = [0.0_f64; 5];
    for name in ["ur5", "panda"] {
        let r = &reference["robots"][name];
        let file = dir().join("urdf").join(r["file"].as_str().expect("file"));
        let imported: UrdfRobot =
            import_urdf(&file, Some(r["tip"].as_str().expect("tip"))).expect("imports");
        let names: Vec<&str> = imported.joints.iter().map(|j| j.name.as_str()).collect();
        let expected: Vec<&str> = r["joints"]
            .as_array()
            .expect("joints")
            .iter()
            .map(|j| j.as_str().expect("name"))
            .collect();
        assert_eq!(names, expected, "{name}: q order");
        // The geometry is read but no mesh is loaded (the UR5's visual meshes are not vendored), and
        // its FK and dynamics below need none.
        let (_, collision, meshes) = imported.geometry.counts();
        assert!(collision > 0 && meshes > 0, "{name}: geometry read");
        // Pinocchio's RNEA/ABA have no joint friction; the Panda's URDF has damping.
        let mut robot: Robot = imported.robot.clone();
        for j in &mut robot.joints {
            j.viscous = 0.0;
            j.coulomb = 0.0;
        }
        let model = robosim_dynamics::Model::new(&robot).expect("dynamics model");
        let mut data = robosim_dynamics::Data::new(&model);
        let samples = r["samples"].as_array().expect("samples");
        assert_eq!(samples.len(), 20);
        for s in samples {
            let q = floats(&s["q"]);
            let tip = matrix(&s["tip"]);
            let ours = fk::forward(&robot, &q);
            let e_fk = (DMatrix::from_column_slice(4, 4, ours.as_slice()) - &tip)
                .abs()
                .max();
            assert!(e_fk <= 1e-12, "{name} FK at {q:?}: {e_fk:e}");
            let mut e_j: f64 = 0.0;
            for (frame, key) in [(Frame::Base, "jacobian"), (Frame::Tool, "jacobian_tool")] {
                let j = jacobian(&robot, &q, frame);
                let theirs = matrix(&s[key]);
                let ours = DMatrix::from_column_slice(6, q.len(), j.as_slice());
                e_j = e_j.max((ours - theirs).abs().max());
            }
            assert!(e_j <= 1e-12, "{name} Jacobian at {q:?}: {e_j:e}");
            let (qd, qdd, tau) = (floats(&s["qd"]), floats(&s["qdd"]), floats(&s["tau"]));
            let t = robosim_dynamics::rnea(&model, &mut data, &q, &qd, &qdd).expect("rnea");
            let e_rnea = rel(t.as_slice(), &floats(&s["rnea"]));
            let m = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
            let theirs = matrix(&s["mass_matrix"]);
            let e_m = rel(m.as_slice(), theirs.transpose().as_slice());
            let a = robosim_dynamics::aba(&model, &mut data, &q, &qd, &tau).expect("aba");
            let e_aba = rel(a.as_slice(), &floats(&s["aba"]));
            assert!(
                e_rnea <= 1e-10 && e_m <= 1e-10 && e_aba <= 1e-10,
                "{name} dynamics at {q:?}: rnea {e_rnea:e}, M {e_m:e}, aba {e_aba:e}"
            );
            for (w, e) in worst.iter_mut().zip([e_fk, e_j, e_rnea, e_m, e_aba]) {
                *w = w.max(e);
            }
        }
    }
    eprintln!(
        "worst vs Pinocchio: FK {:.1e}, Jacobian {:.1e}, RNEA {:.1e} rel, M {:.1e} rel, ABA {:.1e} rel",
        worst[0], worst[1], worst[2], worst[3], worst[4]
    );
}

/// The whole Panda URDF as a kinematic tree (7 arm joints and both finger joints, the second a
/// `<mimic>` imported as an independent coordinate, as Pinocchio's default model has it):
/// every link frame's pose and Jacobian (base and local axes), RNEA, CRBA, ABA and gravity
/// against Pinocchio 4.1's full model at 10 random states.
#[test]
fn the_panda_tree_matches_pinocchio() {
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("urdf/pinocchio_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let r = &reference["trees"]["panda"];
    let imported = import_urdf_tree(&dir().join("urdf").join(r["file"].as_str().expect("file")))
        .expect("imports");
    let strings = |v: &serde_json::Value| -> Vec<String> {
        v.as_array()
            .expect("array")
            .iter()
            .map(|x| x.as_str().expect("string").to_string())
            .collect()
    };
    let names: Vec<String> = imported.joints.iter().map(|j| j.name.clone()).collect();
    assert_eq!(names, strings(&r["joints"]), "q order");
    let links: Vec<String> = imported.joints.iter().map(|j| j.link.clone()).collect();
    assert_eq!(links, strings(&r["links"]));
    // Pinocchio's parents (joint numbers, 0 = universe) are robosim's link-frame numbers.
    let parents: Vec<usize> = floats(&r["parents"]).iter().map(|&p| p as usize).collect();
    assert_eq!(imported.robot.parents, parents);
    assert!(!imported.robot.is_chain());
    assert_eq!(imported.mimics.len(), 1, "{:?}", imported.mimics);
    assert_eq!(imported.mimics[0].joint, "panda_finger_joint2");
    assert_eq!(imported.mimics[0].mimicked, "panda_finger_joint1");
    assert_eq!(imported.mimics[0].index, 8);
    assert_eq!(imported.tip, "panda_rightfinger");
    let mut robot: Robot = imported.robot.clone();
    for j in &mut robot.joints {
        j.viscous = 0.0;
        j.coulomb = 0.0;
    }
    let n = robot.dof();
    assert_eq!(n, 9);
    let model = robosim_dynamics::Model::new(&robot).expect("dynamics model");
    let mut data = robosim_dynamics::Data::new(&model);
    let samples = r["samples"].as_array().expect("samples");
    assert_eq!(samples.len(), 10);
    let mut worst = [0.0_f64; 6];
    for s in samples {
        let q = floats(&s["q"]);
        let frames = fk::link_frames(&robot, &q);
        let (mut e_fk, mut e_j) = (0.0_f64, 0.0_f64);
        for (k, l) in s["links"].as_array().expect("links").iter().enumerate() {
            let theirs = matrix(&l["pose"]);
            let ours = DMatrix::from_column_slice(4, 4, frames[k + 1].as_slice());
            e_fk = e_fk.max((&ours - &theirs).abs().max());
            let pose = fk::link_pose(&robot, &q, k + 1);
            e_fk = e_fk.max(
                (DMatrix::from_column_slice(4, 4, pose.as_slice()) - &theirs)
                    .abs()
                    .max(),
            );
            for (frame, key) in [(Frame::Base, "jacobian"), (Frame::Tool, "jacobian_tool")] {
                let (_, j) = link_jacobian(&robot, &q, k + 1, frame);
                let ours = DMatrix::from_column_slice(6, n, j.as_slice());
                e_j = e_j.max((ours - matrix(&l[key])).abs().max());
            }
        }
        assert!(e_fk <= 1e-12, "tree FK at {q:?}: {e_fk:e}");
        assert!(e_j <= 1e-12, "tree Jacobians at {q:?}: {e_j:e}");
        // The tool (identity on the last joint's link) and its Jacobian are link n's.
        let tool = fk::forward(&robot, &q);
        assert!((tool - frames[n]).abs().max() <= 1e-15);
        let jt = jacobian(&robot, &q, Frame::Base);
        assert_eq!(jt, link_jacobian(&robot, &q, n, Frame::Base).1);
        let (qd, qdd, tau) = (floats(&s["qd"]), floats(&s["qdd"]), floats(&s["tau"]));
        let t = robosim_dynamics::rnea(&model, &mut data, &q, &qd, &qdd).expect("rnea");
        let e_rnea = rel(t.as_slice(), &floats(&s["rnea"]));
        let m = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
        let theirs = matrix(&s["mass_matrix"]);
        let e_m = rel(m.as_slice(), theirs.transpose().as_slice());
        let a = robosim_dynamics::aba(&model, &mut data, &q, &qd, &tau).expect("aba");
        let e_aba = rel(a.as_slice(), &floats(&s["aba"]));
        let g = robosim_dynamics::gravity(&model, &mut data, &q).expect("gravity");
        let e_g = rel(g.as_slice(), &floats(&s["gravity"]));
        assert!(
            e_rnea <= 1e-10 && e_m <= 1e-10 && e_aba <= 1e-10 && e_g <= 1e-10,
            "tree dynamics at {q:?}: rnea {e_rnea:e}, M {e_m:e}, aba {e_aba:e}, g {e_g:e}"
        );
        // ABA and the Cholesky path agree on the tree too.
        let chol = robosim_dynamics::fd_cholesky(&model, &mut data, &q, &qd, &tau)
            .expect("fd_cholesky")
            .clone();
        assert!(rel(chol.as_slice(), &floats(&s["aba"])) <= 1e-10);
        for (w, e) in worst.iter_mut().zip([e_fk, e_j, e_rnea, e_m, e_aba, e_g]) {
            *w = w.max(e);
        }
    }
    eprintln!(
        "Panda tree vs Pinocchio: FK {:.1e}, Jacobians {:.1e}, RNEA {:.1e} rel, M {:.1e} rel, ABA {:.1e} rel, gravity {:.1e} rel",
        worst[0], worst[1], worst[2], worst[3], worst[4], worst[5]
    );
}

/// robosim's DH robots, exported to URDF (testdata/file-io/urdf/, with a base placement and a
/// tool) and imported back as general joints: the same FK, Jacobian and dynamics.
#[test]
fn dh_robots_through_urdf_are_the_same_robots() {
    for name in ["puma560", "stanford", "panda"] {
        let mut dh = robosim_file_io::scene_robots(name, &[])
            .expect("scene")
            .pop()
            .expect("one robot");
        // URDF has no motor (rotor) inertia: left out here. The exporter writes every link's
        // inertial as other tools accept it (a tiny mass for a massless link, A + B ≥ C: the
        // PUMA's links 1 and 3): the robot compared is the one it says it writes.
        for j in &mut dh.joints {
            j.motor_inertia = 0.0;
            (j.mass, j.inertia) = robosim_file_io::inertial::loadable_inertial(
                j.mass,
                &j.inertia,
                "",
                &mut Vec::new(),
            );
        }
        let text = robosim_file_io::urdf::to_urdf(&dh).expect("exports");
        let tip = format!("{name}_tool");
        let general = import_urdf_str(&text, Path::new(&format!("{name}.urdf")), Some(&tip))
            .expect("imports")
            .robot;
        assert_eq!(general.dof(), dh.dof());
        assert!(general.joints.iter().all(|j| j.is_general()));
        let dm = robosim_dynamics::Model::new(&dh).expect("dh model");
        let gm = robosim_dynamics::Model::new(&general).expect("general model");
        let (mut dd, mut gd) = (
            robosim_dynamics::Data::new(&dm),
            robosim_dynamics::Data::new(&gm),
        );
        for k in 0..10 {
            let q: Vec<f64> = (0..dh.dof())
                .map(|j| {
                    let [lo, hi] = dh.joints[j].qlim;
                    lo + (hi - lo) * ((k * 7 + j * 3) % 11) as f64 / 10.0
                })
                .collect();
            let qd: Vec<f64> = (0..dh.dof()).map(|j| 0.3 - 0.1 * j as f64).collect();
            let e = (fk::forward(&dh, &q) - fk::forward(&general, &q))
                .abs()
                .max();
            assert!(e < 1e-12, "{name} FK {e:e}");
            let e = (jacobian(&dh, &q, Frame::Base) - jacobian(&general, &q, Frame::Base))
                .abs()
                .max();
            assert!(e < 1e-12, "{name} Jacobian {e:e}");
            let a = robosim_dynamics::rnea(&dm, &mut dd, &q, &qd, &qd)
                .expect("rnea")
                .clone();
            let b = robosim_dynamics::rnea(&gm, &mut gd, &q, &qd, &qd).expect("rnea");
            assert!(
                rel(b.as_slice(), a.as_slice()) < 1e-12,
                "{name} rnea {a} {b}"
            );
            let a = robosim_dynamics::crba(&dm, &mut dd, &q)
                .expect("crba")
                .clone();
            let b = robosim_dynamics::crba(&gm, &mut gd, &q).expect("crba");
            assert!(rel(b.as_slice(), a.as_slice()) < 1e-12, "{name} M");
            let tau = vec![0.5; dh.dof()];
            let a = robosim_dynamics::aba(&dm, &mut dd, &q, &qd, &tau)
                .expect("aba")
                .clone();
            let b = robosim_dynamics::aba(&gm, &mut gd, &q, &qd, &tau).expect("aba");
            assert!(
                rel(b.as_slice(), a.as_slice()) < 1e-10,
                "{name} aba {a} {b}"
            );
        }
    }
}

/// The general joint model and trees written back (issue #14 item 4): the Panda imported as a
/// tree (fingers as coordinates) and the UR5 imported as a chain to `tool0`, each exported with
/// `to_urdf`, read back, and compared at random states: every link pose, the Jacobians of every
/// link frame in base and local axes (and the tool's), RNEA and the mass matrix (relative), and
/// ABA — all ≤ 1e-12.
#[test]
fn general_models_and_trees_survive_export_and_reimport() {
    use rand::{Rng, SeedableRng};
    let tmp = tempfile::tempdir().expect("tmp");
    let panda = import_urdf_tree(&dir().join("urdf/panda.urdf")).expect("panda tree");
    let ur5 = import_urdf(&dir().join("urdf/ur5_robot.urdf"), Some("tool0")).expect("ur5");
    assert!(!panda.robot.is_chain() && ur5.robot.is_chain());
    let mut rng = rand::rngs::StdRng::seed_from_u64(1414);
    let mut worst = [0.0_f64; 5];
    for (label, orig, tree) in [("panda", &panda.robot, true), ("ur5", &ur5.robot, false)] {
        assert!(orig.joints.iter().all(|j| j.is_general()));
        let text = robosim_file_io::urdf::to_urdf(orig).unwrap_or_else(|e| panic!("{e}"));
        let file = tmp.path().join(format!("{label}.urdf"));
        std::fs::write(&file, &text).expect("write");
        let back = if tree {
            import_urdf_tree(&file)
        } else {
            import_urdf(&file, Some(&format!("{}_tool", orig.name)))
        }
        .unwrap_or_else(|e| panic!("{label}: {e}"))
        .robot;
        assert_eq!(back.dof(), orig.dof(), "{label}");
        assert_eq!(
            (0..orig.dof()).map(|j| back.parent(j)).collect::<Vec<_>>(),
            (0..orig.dof()).map(|j| orig.parent(j)).collect::<Vec<_>>(),
            "{label}: the tree"
        );
        for (a, b) in orig.joints.iter().zip(&back.joints) {
            assert_eq!((a.joint_type, a.qlim), (b.joint_type, b.qlim), "{label}");
            assert_eq!(a.mass, b.mass, "{label}");
            assert_eq!((a.viscous, a.coulomb), (b.viscous, b.coulomb), "{label}");
        }
        let om = robosim_dynamics::Model::new(orig).expect("model");
        let bm = robosim_dynamics::Model::new(&back).expect("model");
        let (mut od, mut bd) = (
            robosim_dynamics::Data::new(&om),
            robosim_dynamics::Data::new(&bm),
        );
        for _ in 0..10 {
            let q: Vec<f64> = orig
                .joints
                .iter()
                .map(|j| {
                    let [lo, hi] = j.qlim;
                    if lo.is_finite() {
                        rng.random_range(lo..=hi)
                    } else {
                        rng.random_range(-3.0..=3.0)
                    }
                })
                .collect();
            let qd: Vec<f64> = (0..orig.dof())
                .map(|_| rng.random_range(-2.0..=2.0))
                .collect();
            let qdd: Vec<f64> = (0..orig.dof())
                .map(|_| rng.random_range(-5.0..=5.0))
                .collect();
            for link in 0..=orig.dof() {
                let e = (fk::link_pose(orig, &q, link) - fk::link_pose(&back, &q, link))
                    .abs()
                    .max();
                worst[0] = worst[0].max(e);
                assert!(e <= 1e-12, "{label} link {link} pose {e:e}");
                for frame in [Frame::Base, Frame::Tool] {
                    let (_, a) = link_jacobian(orig, &q, link, frame);
                    let (_, b) = link_jacobian(&back, &q, link, frame);
                    let e = (a - b).abs().max();
                    worst[1] = worst[1].max(e);
                    assert!(e <= 1e-12, "{label} link {link} {frame:?} Jacobian {e:e}");
                }
            }
            let e = (fk::forward(orig, &q) - fk::forward(&back, &q)).abs().max();
            assert!(e <= 1e-12, "{label} tool {e:e}");
            for frame in [Frame::Base, Frame::Tool] {
                let e = (jacobian(orig, &q, frame) - jacobian(&back, &q, frame))
                    .abs()
                    .max();
                assert!(e <= 1e-12, "{label} tool {frame:?} Jacobian {e:e}");
            }
            let a = robosim_dynamics::rnea(&om, &mut od, &q, &qd, &qdd)
                .expect("rnea")
                .clone();
            let b = robosim_dynamics::rnea(&bm, &mut bd, &q, &qd, &qdd).expect("rnea");
            let e = rel(b.as_slice(), a.as_slice());
            worst[2] = worst[2].max(e);
            assert!(e <= 1e-12, "{label} rnea {e:e}");
            let a = robosim_dynamics::crba(&om, &mut od, &q)
                .expect("crba")
                .clone();
            let b = robosim_dynamics::crba(&bm, &mut bd, &q).expect("crba");
            let e = rel(b.as_slice(), a.as_slice());
            worst[3] = worst[3].max(e);
            assert!(e <= 1e-12, "{label} M {e:e}");
            let a = robosim_dynamics::aba(&om, &mut od, &q, &qd, &qdd)
                .expect("aba")
                .clone();
            let b = robosim_dynamics::aba(&bm, &mut bd, &q, &qd, &qdd).expect("aba");
            let e = rel(b.as_slice(), a.as_slice());
            worst[4] = worst[4].max(e);
            assert!(e <= 1e-12, "{label} aba {e:e}");
        }
    }
    eprintln!(
        "export→import worst: pose {:e}, Jacobian {:e}, rnea {:e}, M {:e}, aba {:e}",
        worst[0], worst[1], worst[2], worst[3], worst[4]
    );
}
