//! A `from_urdf` robot keeps its file's `<mimic>` relations (issue 36): `RobotModel::mimics`,
//! and the one robot model (`RobotModel::model`) carries their coupling — the Panda of the
//! corpus (testdata/urdf_corpus, example-robot-data, BSD), whose second finger mimics the
//! first, against Pinocchio 4.1's `buildModel(…, mimic=True)` (mimic_reference.json, made by
//! make_mimic_reference.py beside it): the link poses and world-aligned Jacobians of both
//! fingers over the reduced coordinates at the reference's q.

use nalgebra::DMatrix;
use robosim_kinematics::jacobian::Frame;
use robosim_library::{Evaluated, Library, MimicJoint, Params, RobotModel};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf_corpus")
}

fn nums(v: &Value) -> Vec<f64> {
    (v.as_array().expect("numbers").iter())
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn rows(v: &Value) -> DMatrix<f64> {
    let r: Vec<Vec<f64>> = v.as_array().expect("rows").iter().map(nums).collect();
    DMatrix::from_fn(r.len(), r[0].len(), |i, j| r[i][j])
}

fn panda(whole: &str) -> RobotModel {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = corpus().join("robots/panda_description/panda.urdf");
    let src = format!("robot panda from_urdf {:?} {{ {whole} }}\n", file.display());
    let rsl = dir.path().join("panda.rsl");
    std::fs::write(&rsl, src).expect("write");
    let lib = Library::load(&rsl).expect("loads");
    match lib.evaluate("panda", &Params::new()).expect("evaluates") {
        Evaluated::Robot(r) => r,
        other => panic!("not a robot: {other:?}"),
    }
}

#[test]
fn a_from_urdf_robot_keeps_its_mimic_coupling_in_the_model() {
    let r = panda("");
    let n = r.robot.dof();
    assert_eq!(n, 9, "the whole tree: 7 arm joints and both fingers");
    // panda_finger_joint2 (the right finger's link) follows panda_finger_joint1, ×1 + 0
    let left = r.link_names.iter().position(|l| l == "panda_leftfinger");
    let right = r.link_names.iter().position(|l| l == "panda_rightfinger");
    let (left, right) = (left.expect("left finger"), right.expect("right finger"));
    assert_eq!(
        r.mimics,
        [MimicJoint {
            follower: right,
            leader: Some(left),
            multiplier: 1.0,
            offset: 0.0
        }]
    );
    let model = r.model();
    let c = model
        .coupling
        .as_ref()
        .expect("the model carries the coupling");
    assert_eq!((c.full_nq(), c.reduced_nq()), (9, 8));
    assert!(c.is_follower(right) && !c.is_follower(left));
    // the relations survive a JSON round trip, and a robot written before the field existed
    // (no `mimics`) reads back with none
    let text = serde_json::to_string(&r).expect("json");
    let back: RobotModel = serde_json::from_str(&text).expect("reads");
    assert_eq!(back, r);
    let mut old: Value = serde_json::from_str(&text).expect("json");
    old.as_object_mut().expect("object").remove("mimics");
    let old: RobotModel = serde_json::from_value(old).expect("an older robot reads");
    assert!(old.mimics.is_empty() && old.model().coupling.is_none());

    // Pinocchio's mimic model at its q: poses and Jacobians of both fingers
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(corpus().join("mimic_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let rob = (reference["robots"].as_array().expect("robots").iter())
        .find(|x| x["file"] == "panda_description/panda.urdf")
        .expect("the Panda");
    // Pinocchio's reduced order (by joint name) → ours: joint k is link_names[k]'s joint,
    // and the reduced coordinates are the free joints in q order
    let tree = robosim_urdf::urdf_import::import_urdf_tree(
        &corpus().join("robots/panda_description/panda.urdf"),
    )
    .expect("imports");
    let free: Vec<&str> = (c.free().iter())
        .map(|&i| tree.joints[i].name.as_str())
        .collect();
    let perm: Vec<usize> = (rob["free"].as_array().expect("free").iter())
        .map(|n| {
            let n = n.as_str().expect("a name");
            free.iter().position(|f| *f == n).expect("a free joint")
        })
        .collect();
    let mut checked = 0;
    for s in rob["samples"].as_array().expect("samples") {
        let q_pin = nums(&s["q"]);
        let mut qr = vec![0.0; q_pin.len()];
        for (k, &i) in perm.iter().enumerate() {
            qr[i] = q_pin[k];
        }
        for (link, fr) in s["frames"].as_object().expect("frames") {
            let j = model
                .link_names
                .iter()
                .position(|l| l == link)
                .expect("link");
            let (pose, jac) =
                robosim_kinematics::mimic::link_jacobian(&model.robot, c, &qr, j + 1, Frame::Base)
                    .expect("coupled Jacobian");
            let want = rows(&fr["pose"]);
            let e = (0..4)
                .flat_map(|a| (0..4).map(move |b| (a, b)))
                .fold(0.0_f64, |m, (a, b)| {
                    m.max((pose[(a, b)] - want[(a, b)]).abs())
                });
            assert!(e < 1e-12, "{link}: pose differs by {e:e}");
            let jw = rows(&fr["jacobian"]);
            assert_eq!(jac.ncols(), 8, "{link}: one column per reduced coordinate");
            let e = (0..6)
                .flat_map(|a| (0..8).map(move |b| (a, b)))
                .fold(0.0_f64, |m, (a, b)| {
                    m.max((jac[(a, perm[b])] - jw[(a, b)]).abs())
                });
            assert!(e < 1e-12, "{link}: Jacobian differs by {e:e}");
            checked += 1;
        }
    }
    assert!(checked >= 4, "{checked} finger frames checked");
}

/// A robot without `<mimic>` (the chain to the hand) has no relations and no coupling; a
/// library robot (DH links) neither.
#[test]
fn a_robot_without_mimic_joints_has_no_coupling() {
    let r = panda("tip: \"panda_hand\"");
    assert!(r.mimics.is_empty());
    assert!(r.model().coupling.is_none());
}
