//! Mimic joints through the exports (issue 36 items 1 and 4): a robot imported with `<mimic>`
//! joints, exported to URDF (`<mimic joint multiplier offset>`) and MJCF (`<equality><joint
//! joint1 joint2 polycoef>`) with its coupling, and read back by robosim's importers, has the
//! same coupling (the same map φ from reduced to full q, the same G) and the same FK of every
//! link at random reduced q. Without the coupling the export would be another robot (every
//! follower a free joint): `to_urdf` of the bare robot writes no `<mimic>`, which the test
//! also checks, so a dropped coupling fails here. tools/peers/check_exports.py loads the same
//! exports in MuJoCo and Pinocchio (`mimic=True`).

use crate::reference::testdata;
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use robosim_file_io::mjcf::import_mjcf_tree_str;
use robosim_file_io::mjcf_export::to_mjcf_with_geometry;
use robosim_file_io::urdf::{mimic_relations, to_urdf, to_urdf_with_geometry};
use robosim_file_io::urdf_import::{ImportedRobot, import_urdf_tree, import_urdf_tree_str};
use robosim_kinematics::mimic::{Coupling, Mimic};
use robosim_kinematics::{Robot, fk};
use std::path::Path;

/// The largest difference of φ(q_r), of G and of every link frame at φ(q_r) between `a` and
/// `b`, at 20 random reduced q (uniform in the free joints' limits, [−π, π] when unbounded).
fn same_robot(what: &str, a: (&Robot, &Coupling), b: (&Robot, &Coupling)) -> (f64, f64, f64) {
    let ((ra, ca), (rb, cb)) = (a, b);
    assert_eq!(
        (ca.full_dof(), ca.reduced_dof(), ca.free()),
        (cb.full_dof(), cb.reduced_dof(), cb.free()),
        "{what}: a different set of free joints"
    );
    let eg = (ca.matrix() - cb.matrix()).amax();
    let mut rng = rand::rngs::StdRng::seed_from_u64(3604);
    let (mut eq, mut ex) = (0.0f64, 0.0f64);
    for _ in 0..20 {
        let qr: Vec<f64> = ca
            .free()
            .iter()
            .map(|&j| {
                let [lo, hi] = ra.joints[j].qlim;
                if lo.is_finite() && hi.is_finite() && lo < hi {
                    rng.random_range(lo..hi)
                } else {
                    rng.random_range(-std::f64::consts::PI..std::f64::consts::PI)
                }
            })
            .collect();
        let qa = ca.expand_q(&qr).expect("expands");
        let qb = cb.expand_q(&qr).expect("expands");
        eq = eq.max(
            qa.iter()
                .zip(&qb)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max),
        );
        let fa = fk::link_frames(ra, &qa);
        let fb = fk::link_frames(rb, &qb);
        assert_eq!(fa.len(), fb.len(), "{what}: link frames");
        for (x, y) in fa.iter().zip(&fb) {
            ex = ex.max((x - y).amax());
        }
        let ta = robosim_kinematics::mimic::forward(ra, ca, &qr).expect("fk");
        let tb = robosim_kinematics::mimic::forward(rb, cb, &qr).expect("fk");
        ex = ex.max((ta - tb).amax());
    }
    (eq, eg, ex)
}

fn imported(file: &str) -> ImportedRobot {
    let path = testdata().join(file);
    let mut u = import_urdf_tree(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
    u.robot.name = "m".into();
    u
}

/// Exports `u` with its coupling to URDF and MJCF, reads both back and compares.
fn round_trip(file: &str, followers: usize) {
    let u = imported(file);
    let c = u.coupling.as_ref().expect("a mimic robot");
    assert_eq!(
        c.full_dof() - c.reduced_dof(),
        followers,
        "{file}: followers"
    );
    let (urdf, _, _) = to_urdf_with_geometry(&u.robot, Some(c), None, "")
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    assert_eq!(urdf.matches("<mimic ").count(), followers, "{file}");
    let back = import_urdf_tree_str(&urdf, Path::new("m.urdf"))
        .unwrap_or_else(|e| panic!("{file}: robosim does not read its URDF export: {e}"));
    let cb = back
        .coupling
        .as_ref()
        .expect("the URDF export has the coupling");
    let (eq, eg, ex) = same_robot(file, (&u.robot, c), (&back.robot, cb));
    eprintln!("{file} URDF: q {eq:.1e}, G {eg:.1e}, frames {ex:.1e}");
    assert!(
        eq < 1e-12 && eg == 0.0 && ex < 1e-12,
        "{file} URDF: q {eq:e}, G {eg:e}, frames {ex:e}"
    );

    let (mjcf, _, _) = to_mjcf_with_geometry(&u.robot, Some(c), None, "")
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    assert_eq!(mjcf.matches("polycoef=").count(), followers, "{file}");
    let back = import_mjcf_tree_str(&mjcf, Path::new("m.xml"))
        .unwrap_or_else(|e| panic!("{file}: robosim does not read its MJCF export: {e}"));
    let cb = back
        .coupling
        .as_ref()
        .expect("the MJCF export has the coupling");
    let (eq, eg, ex) = same_robot(file, (&u.robot, c), (&back.robot, cb));
    eprintln!("{file} MJCF: q {eq:.1e}, G {eg:.1e}, frames {ex:.1e}");
    assert!(
        eq < 1e-12 && eg == 0.0 && ex < 1e-12,
        "{file} MJCF: q {eq:e}, G {eg:e}, frames {ex:e}"
    );

    // the robot without its coupling is exported without <mimic>: the coupling is what says it
    assert!(!to_urdf(&u.robot).expect("exports").contains("<mimic"));
}

#[test]
fn panda_fingers_keep_their_mimic_through_both_exports() {
    round_trip("urdf/panda.urdf", 1);
}

/// PR2: ten followers in two grippers, multipliers 1 and −1, leaders on other branches.
#[test]
fn pr2_grippers_keep_their_mimics_through_both_exports() {
    round_trip("urdf_corpus/robots/pr2_description/pr2.urdf", 10);
}

/// A follower fixed at its offset (its leader not part of the robot): URDF names a free joint
/// as its leader with multiplier 0 (and says so), MJCF writes an equality without `joint2`;
/// both read back as the same map. A coupling over another number of joints is refused.
#[test]
fn a_fixed_follower_and_a_wrong_coupling() {
    let u = imported("urdf/panda.urdf");
    let n = u.robot.dof();
    let c = Coupling::new(
        n,
        &[
            Mimic {
                follower: n - 1,
                leader: None,
                multiplier: 1.0,
                offset: 0.01,
            },
            Mimic {
                follower: 2,
                leader: Some(0),
                multiplier: -0.5,
                offset: 0.25,
            },
        ],
    )
    .expect("a coupling");
    let relations = mimic_relations(&u.robot, &c).expect("relations");
    assert_eq!(relations.len(), 2);
    assert_eq!(
        (
            relations[0].follower,
            relations[0].leader,
            relations[0].multiplier,
            relations[0].offset
        ),
        (2, Some(0), -0.5, 0.25)
    );
    assert_eq!(
        (
            relations[1].follower,
            relations[1].leader,
            relations[1].offset
        ),
        (n - 1, None, 0.01)
    );
    let (urdf, notes, _) = to_urdf_with_geometry(&u.robot, Some(&c), None, "").expect("exports");
    assert!(
        notes
            .iter()
            .any(|s| s.contains(&format!("joint {n}: fixed at 0.01"))),
        "{notes:?}"
    );
    let back = import_urdf_tree_str(&urdf, Path::new("m.urdf")).expect("reads back");
    let cb = back.coupling.as_ref().expect("coupling");
    let qr: Vec<f64> = (0..c.reduced_nq()).map(|i| 0.1 * i as f64 - 0.2).collect();
    assert_eq!(c.expand_q(&qr).expect("q"), cb.expand_q(&qr).expect("q"));
    let (mjcf, _, _) = to_mjcf_with_geometry(&u.robot, Some(&c), None, "").expect("exports");
    assert!(mjcf.contains(&format!(
        "joint1=\"m_joint{n}\" polycoef=\"0.01 0.0 0 0 0\""
    )));
    let back = import_mjcf_tree_str(&mjcf, Path::new("m.xml")).expect("reads back");
    let cb = back.coupling.as_ref().expect("coupling");
    assert_eq!(c.expand_q(&qr).expect("q"), cb.expand_q(&qr).expect("q"));
    let g: DMatrix<f64> = c.matrix();
    assert_eq!(g, cb.matrix());

    let wrong = Coupling::identity(n - 1);
    for e in [
        to_urdf_with_geometry(&u.robot, Some(&wrong), None, "").map(|_| ()),
        to_mjcf_with_geometry(&u.robot, Some(&wrong), None, "").map(|_| ()),
    ] {
        let e = e.expect_err("a coupling of another robot");
        assert!(e.contains(&format!("over {} joints", n - 1)), "{e}");
    }
}

/// `robosim export` (the file-io command, `--scene` of a `from_urdf` declaration): the
/// declaration's file is read again for its coupling, so the whole Panda's URDF and MJCF carry
/// the finger's mimic; `--mesh-paths` names the mesh files absolute (URDF's default: Pinocchio
/// and MuJoCo open it with no flags), relative (MJCF's default) or as `file://` URIs (URDF
/// only), and every named file exists where it is named.
#[test]
fn the_export_command_writes_the_coupling_and_names_meshes_as_asked() {
    let dir = tempfile::tempdir().expect("tempdir");
    let lib = dir.path().join("lib.rsl");
    let panda = testdata().join("urdf/panda.urdf");
    std::fs::write(
        &lib,
        format!("robot pm from_urdf \"{}\"\n", panda.display()),
    )
    .expect("library written");
    let export = |file: &str, mesh_paths: Option<&str>| {
        let out = dir.path().join(file);
        let args = robosim_file_io::cli::ExportArgs {
            what: vec![out.display().to_string()],
            scene: Some("pm".into()),
            library: vec![lib.clone()],
            body: None,
            robot: None,
            log: None,
            dt: None,
            mesh_paths: mesh_paths.map(str::to_string),
        };
        robosim_file_io::cli::export(&args, None)
            .map(|()| std::fs::read_to_string(&out).expect("written"))
    };
    let mesh_names = |text: &str, attr: &str| -> Vec<String> {
        text.split(attr)
            .skip(1)
            .filter_map(|t| t.split('"').nth(1).map(str::to_string))
            .filter(|n| n.ends_with(".stl"))
            .collect()
    };
    let urdf = export("a.urdf", None).expect("exports");
    assert_eq!(urdf.matches("<mimic joint=\"pm_joint8\"").count(), 1);
    let names = mesh_names(&urdf, "filename=");
    assert!(!names.is_empty());
    for n in &names {
        assert!(Path::new(n).is_absolute() && Path::new(n).is_file(), "{n}");
    }
    let urdf = export("r.urdf", Some("relative")).expect("exports");
    for n in mesh_names(&urdf, "filename=") {
        assert!(!n.contains('/') && dir.path().join(&n).is_file(), "{n}");
    }
    let urdf = export("u.urdf", Some("file-uri")).expect("exports");
    for n in mesh_names(&urdf, "filename=") {
        let path = n.strip_prefix("file://").unwrap_or_else(|| panic!("{n}"));
        assert!(
            Path::new(path).is_absolute() && Path::new(path).is_file(),
            "{n}"
        );
    }
    let mjcf = export("m.xml", None).expect("exports");
    assert!(mjcf.contains("joint1=\"pm_joint9\" joint2=\"pm_joint8\" polycoef=\"0.0 1.0 0 0 0\""));
    for n in mesh_names(&mjcf, "file=") {
        assert!(!n.contains('/') && dir.path().join(&n).is_file(), "{n}");
    }
    let e = export("x.xml", Some("file-uri")).expect_err("MuJoCo opens no file:// name");
    assert!(e.to_string().contains("file-uri is for URDF"), "{e}");
    let e = export("y.urdf", Some("nope")).expect_err("an unknown mode");
    assert!(
        e.to_string().contains("absolute, relative or file-uri"),
        "{e}"
    );
}
