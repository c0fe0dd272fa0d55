//! Mimic joints (issue 36 item 1): the corpus robots with movable `<mimic>` joints (Panda,
//! Baxter, PR2, TIAGo Pro, Romeo, TALOS full v2) imported as trees, leader and follower one
//! coordinate through [`UrdfRobot::coupling`], and their FK, frame Jacobians, RNEA, gravity,
//! CRBA and forward dynamics over the reduced coordinates compared with Pinocchio 4.1's mimic
//! model (`buildModel(…, mimic=True)`) — or, where Pinocchio refuses that model (Romeo, TALOS:
//! a follower before its leader in its traversal), with Pinocchio's full model and the relation
//! in closed form (`τ_r = Gᵀ τ`, `M_r = Gᵀ M G`, `J_r = J G`): testdata/urdf_corpus/
//! mimic_reference.json, written by make_mimic_reference.py beside it. Poses and Jacobians to
//! 1e-12, dynamics to 1e-10, relative to the largest reference entry (or 1), as the corpus test.
//! Pinocchio 4.1's ABA refuses mimic joints: the reference q̈ is `M_r⁻¹ (τ_r − b_r)` from its
//! CRBA and RNEA.

use crate::common::{floats, matrix, rel_err};
use nalgebra::{DMatrix, Matrix4};
use robosim_dynamics::mimic::{aba_mimic, crba_mimic, gravity_mimic, rnea_mimic};
use robosim_dynamics::{Data, Model, rnea};
use robosim_kinematics::fk::link_pose;
use robosim_kinematics::jacobian::Frame;
use robosim_kinematics::mimic::link_jacobian;
use robosim_urdf::urdf_import::{
    import_urdf, import_urdf_str, import_urdf_tree_str, import_urdf_with_followers,
};
use serde_json::Value;
use std::path::PathBuf;

const POSE_TOL: f64 = 1e-12;
const DYN_TOL: f64 = 1e-10;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/urdf_corpus")
}

fn flat(m: &DMatrix<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

fn flat4(m: &Matrix4<f64>) -> Vec<f64> {
    (0..4)
        .flat_map(|i| (0..4).map(move |j| m[(i, j)]))
        .collect()
}

#[test]
fn mimic_robots_match_pinocchios_mimic_model() {
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("mimic_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let robots = reference["robots"].as_array().expect("robots");
    assert_eq!(robots.len(), 6);
    let mut failures = Vec::new();
    let mut worst = [0.0_f64; 6];
    let mut check = |name: &str, what: usize, got: &[f64], want: &[f64], tol: f64| {
        const WHAT: [&str; 6] = ["pose", "jacobian", "rnea", "gravity", "M", "aba"];
        let e = rel_err(got, want);
        worst[what] = worst[what].max(e);
        if e.is_nan() || e > tol {
            failures.push(format!("{name}: {} differs by {e:e}", WHAT[what]));
        }
    };
    for rob in robots {
        let name = rob["file"].as_str().expect("file");
        let path = dir().join("robots").join(name);
        let text = std::fs::read_to_string(&path).expect("URDF");
        let tree = import_urdf_tree_str(&text, &path).expect("imports");
        let coupling = tree.coupling.as_ref().expect("the robot has mimic joints");
        let followers = rob["followers"].as_object().expect("followers");
        assert_eq!(tree.mimics.len(), followers.len(), "{name}");
        // the reduced coordinates by name, Pinocchio's order → robosim's
        let free: Vec<&str> = coupling
            .free()
            .iter()
            .map(|&i| tree.joints[i].name.as_str())
            .collect();
        let perm: Vec<usize> = rob["free"]
            .as_array()
            .expect("free")
            .iter()
            .map(|n| {
                let n = n.as_str().expect("name");
                free.iter()
                    .position(|f| *f == n)
                    .unwrap_or_else(|| panic!("{name}: {n} is not a free coordinate"))
            })
            .collect();
        assert_eq!(perm.len(), free.len(), "{name}: reduced coordinates");
        let ours = |x: &[f64]| {
            let mut out = vec![0.0; x.len()];
            for (k, &i) in perm.iter().enumerate() {
                out[i] = x[k];
            }
            out
        };
        let model = Model::new(&tree.robot).expect("dynamics model");
        let mut data = Data::new(&model);
        for s in rob["samples"].as_array().expect("samples") {
            let [q, v, a, tau] = ["q", "v", "a", "tau"].map(|k| ours(&floats(&s[k])));
            let want = |k: &str| ours(&floats(&s[k]));
            let t = rnea_mimic(&model, &mut data, coupling, &q, &v, &a).expect("rnea");
            check(name, 2, t.as_slice(), &want("rnea"), DYN_TOL);
            let g = gravity_mimic(&model, &mut data, coupling, &q).expect("gravity");
            check(name, 3, g.as_slice(), &want("gravity"), DYN_TOL);
            let m = crba_mimic(&model, &mut data, coupling, &q).expect("crba");
            let mr = matrix(&s["M"]);
            let m_want = DMatrix::from_fn(mr.nrows(), mr.ncols(), |i, j| {
                let (pi, pj) = (
                    perm.iter().position(|&x| x == i).expect("perm"),
                    perm.iter().position(|&x| x == j).expect("perm"),
                );
                mr[(pi, pj)]
            });
            check(name, 4, &flat(&m), &flat(&m_want), DYN_TOL);
            if !s["aba"].is_null() {
                let qdd = aba_mimic(&model, &mut data, coupling, &q, &v, &tau).expect("aba");
                check(name, 5, qdd.as_slice(), &want("aba"), DYN_TOL);
            }
            for (link, fr) in s["frames"].as_object().expect("frames") {
                let k = tree
                    .joints
                    .iter()
                    .position(|j| &j.link == link)
                    .expect("a movable joint's child link");
                let (pose, jac) =
                    link_jacobian(&tree.robot, coupling, &q, k + 1, Frame::Base).expect("J");
                check(
                    name,
                    0,
                    &flat4(&pose),
                    &flat(&matrix(&fr["pose"])),
                    POSE_TOL,
                );
                let jr = matrix(&fr["jacobian"]);
                let j_want = DMatrix::from_fn(6, jr.ncols(), |r, c| {
                    jr[(r, perm.iter().position(|&x| x == c).expect("perm"))]
                });
                check(name, 1, &flat(&jac), &flat(&j_want), POSE_TOL);
            }
        }
    }
    eprintln!(
        "mimic robots: worst relative errors pose {:e}, jacobian {:e}, rnea {:e}, gravity {:e}, M {:e}, aba {:e}",
        worst[0], worst[1], worst[2], worst[3], worst[4], worst[5]
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Followers off a chain (issue 36 item 1): a chain import to a gripper finger with the
/// followers of its joints that hang off it moving
/// ([`robosim_urdf::urdf_import::import_urdf_with_followers`]: PR2's right gripper, TIAGo Pro's
/// left gripper, Baxter's left gripper) against Pinocchio 4.1 — its full model with the other
/// joints locked at 0 (`buildReducedModel`) and the relations in closed form, cross-checked
/// there with its own mimic model: testdata/urdf_corpus/mimic_chain_reference.json, written by
/// make_mimic_chain_reference.py beside it. The reduced coordinates are the chain's free
/// joints; the followers' link frames move with their leaders and their mass moves in RNEA,
/// CRBA and the forward dynamics (the plain chain import holds them at 0, lumped: their link
/// poses differ, checked).
#[test]
fn off_chain_followers_move_with_their_leaders_on_the_chain() {
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("mimic_chain_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let robots = reference["robots"].as_array().expect("robots");
    assert_eq!(robots.len(), 3);
    let mut failures = Vec::new();
    let mut check = |what: String, got: &[f64], want: &[f64], tol: f64| {
        let e = rel_err(got, want);
        if e.is_nan() || e > tol {
            failures.push(format!("{what} differs by {e:e}"));
        }
    };
    let mut moved = 0;
    for rob in robots {
        let name = rob["file"].as_str().expect("file");
        let tip = rob["tip"].as_str().expect("tip");
        let path = dir().join("robots").join(name);
        let imported = import_urdf_with_followers(&path, Some(tip)).expect("imports");
        let plain = import_urdf(&path, Some(tip)).expect("imports");
        let coupling = imported.coupling.as_ref().expect("a coupling");
        let names: Vec<&str> = imported.joints.iter().map(|j| j.name.as_str()).collect();
        for f in rob["moving_followers"].as_array().expect("moving") {
            let f = f.as_str().expect("name");
            assert!(names.contains(&f), "{name}: {f} is not a joint: {names:?}");
            assert!(!imported.held.iter().any(|h| h == f), "{name}: {f} held");
            assert!(
                plain.held.iter().any(|h| h == f),
                "{name}: {f} not held by the chain"
            );
        }
        let free: Vec<&str> = coupling.free().iter().map(|&i| names[i]).collect();
        let want_free: Vec<&str> = rob["free"]
            .as_array()
            .expect("free")
            .iter()
            .map(|n| n.as_str().expect("name"))
            .collect();
        // the reduced coordinates are the chain's free joints, in chain order
        assert_eq!(free, want_free, "{name}");
        let plain_free: Vec<&str> = match &plain.coupling {
            Some(c) => c
                .free()
                .iter()
                .map(|&i| plain.joints[i].name.as_str())
                .collect(),
            None => plain.joints.iter().map(|j| j.name.as_str()).collect(),
        };
        assert_eq!(
            free, plain_free,
            "{name}: the same q as the plain chain import"
        );
        let model = Model::new(&imported.robot).expect("dynamics model");
        let mut data = Data::new(&model);
        for s in rob["samples"].as_array().expect("samples") {
            let [q, v, a, tau] = ["q", "v", "a", "tau"].map(|k| floats(&s[k]));
            let t = rnea_mimic(&model, &mut data, coupling, &q, &v, &a).expect("rnea");
            check(
                format!("{name}: rnea"),
                t.as_slice(),
                &floats(&s["rnea"]),
                DYN_TOL,
            );
            let g = gravity_mimic(&model, &mut data, coupling, &q).expect("gravity");
            check(
                format!("{name}: gravity"),
                g.as_slice(),
                &floats(&s["gravity"]),
                DYN_TOL,
            );
            let m = crba_mimic(&model, &mut data, coupling, &q).expect("crba");
            check(
                format!("{name}: M"),
                &flat(&m),
                &flat(&matrix(&s["M"])),
                DYN_TOL,
            );
            let qdd = aba_mimic(&model, &mut data, coupling, &q, &v, &tau).expect("aba");
            check(
                format!("{name}: aba"),
                qdd.as_slice(),
                &floats(&s["aba"]),
                DYN_TOL,
            );
            let plain_q = match &plain.coupling {
                Some(c) => c.expand_q(&q).expect("q"),
                None => q.clone(),
            };
            for (link, fr) in s["frames"].as_object().expect("frames") {
                // the tip: the tool frame (a fixed joint's child on Baxter); a follower's
                // link: its joint's link frame
                let k = imported.joints.iter().position(|j| &j.link == link);
                let (pose, jac) = match k {
                    _ if link == tip => (
                        robosim_kinematics::mimic::forward(&imported.robot, coupling, &q)
                            .expect("fk"),
                        robosim_kinematics::mimic::jacobian(
                            &imported.robot,
                            coupling,
                            &q,
                            Frame::Base,
                        )
                        .expect("J"),
                    ),
                    Some(k) => {
                        link_jacobian(&imported.robot, coupling, &q, k + 1, Frame::Base).expect("J")
                    }
                    None => panic!("{name}: {link} is neither the tip nor a joint's link"),
                };
                let want = flat(&matrix(&fr["pose"]));
                check(
                    format!("{name}: pose of {link}"),
                    &flat4(&pose),
                    &want,
                    POSE_TOL,
                );
                check(
                    format!("{name}: jacobian of {link}"),
                    &flat(&jac),
                    &flat(&matrix(&fr["jacobian"])),
                    POSE_TOL,
                );
                if link != tip {
                    // held at 0, as the plain chain holds it, this link would be elsewhere
                    assert!(
                        plain.joints.iter().all(|j| &j.link != link),
                        "{name}: {link}"
                    );
                    let mut held_q = coupling.expand_q(&q).expect("q");
                    for i in 0..held_q.len() {
                        if !plain.joints.iter().any(|j| j.name == names[i]) {
                            held_q[i] = 0.0;
                        }
                    }
                    let k = k.expect("a follower's link");
                    let held = link_pose(&imported.robot, &held_q, k + 1);
                    assert!(
                        rel_err(&flat4(&held), &want) > 1e-6,
                        "{name}: {link} held at 0 is where the reference puts it"
                    );
                    moved += 1;
                }
            }
            let tool =
                robosim_kinematics::mimic::forward(&imported.robot, coupling, &q).expect("fk");
            let plain_tool = robosim_kinematics::fk::forward(&plain.robot, &plain_q);
            check(
                format!("{name}: tool vs the plain chain's"),
                &flat4(&tool),
                &flat4(&plain_tool),
                POSE_TOL,
            );
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(moved >= 6, "follower links checked: {moved}");
}

/// A chain to the Panda's right finger: the follower (`panda_finger_joint2`) is on the chain,
/// its leader off it and held at 0, so the follower is fixed at its offset (0): 7 reduced
/// coordinates. FK is the tree's at the same arm angles with both fingers at 0, and RNEA over
/// the reduced coordinates is the tree's on the arm joints with the fingers still.
#[test]
fn a_follower_on_the_chain_with_its_leader_held_is_fixed_at_its_offset() {
    let path = dir().join("robots/panda_description/panda.urdf");
    let text = std::fs::read_to_string(&path).expect("URDF");
    let chain = import_urdf_str(&text, &path, Some("panda_rightfinger")).expect("imports");
    let c = chain.coupling.as_ref().expect("coupling");
    assert_eq!((c.full_dof(), c.reduced_dof()), (8, 7));
    assert_eq!(chain.mimics[0].mimicked_index, None);
    assert!(
        chain.notes.iter().any(|n| n.contains("fixed at 0")),
        "{:?}",
        chain.notes
    );
    let tree = import_urdf_tree_str(&text, &path).expect("tree");
    let qr = [0.3, -0.5, 0.2, -1.9, 0.4, 1.6, -0.7];
    let (v, a) = ([0.2, -0.1, 0.3, 0.1, -0.4, 0.5, 0.2], [0.1; 7]);
    let full = |x: &[f64]| {
        let mut f = x.to_vec();
        f.extend([0.0, 0.0]);
        f
    };
    let finger = tree
        .joints
        .iter()
        .position(|j| j.link == "panda_rightfinger")
        .expect("finger");
    let want_pose = link_pose(&tree.robot, &full(&qr), finger + 1);
    let got = robosim_kinematics::mimic::forward(&chain.robot, c, &qr).expect("fk");
    assert!(
        (got - want_pose).abs().max() < 1e-14,
        "{got} vs {want_pose}"
    );
    let cm = Model::new(&chain.robot).expect("model");
    let tm = Model::new(&tree.robot).expect("model");
    let (mut cd, mut td) = (Data::new(&cm), Data::new(&tm));
    let got = rnea_mimic(&cm, &mut cd, c, &qr, &v, &a).expect("rnea");
    let want = rnea(&tm, &mut td, &full(&qr), &full(&v), &full(&a)).expect("rnea");
    assert!(rel_err(got.as_slice(), &want.as_slice()[..7]) < 1e-12);
    // wrong lengths are typed errors, not panics
    assert!(rnea_mimic(&cm, &mut cd, c, &qr[..6], &v, &a).is_err());
    assert!(crba_mimic(&tm, &mut td, c, &qr).is_err());
}

/// The Panda tree on a free-flyer base (issue 36 item 2 with item 1): the root's 7 q / 6 v come
/// first in the reduced vectors and pass through; the reduced dynamics is the full one with
/// `G = diag(I₆, G_joints)` — checked against the explicit matrix.
#[test]
fn a_floating_base_passes_through_the_coupling() {
    let path = dir().join("robots/panda_description/panda.urdf");
    let text = std::fs::read_to_string(&path).expect("URDF");
    let tree = robosim_urdf::urdf_import::import_urdf_tree_floating_str(
        &text,
        &path,
        robosim_kinematics::RootKind::FreeFlyer,
    )
    .expect("imports");
    let c = tree.coupling.as_ref().expect("coupling");
    assert_eq!((c.reduced_nq(), c.reduced_nv()), (7 + 8, 6 + 8));
    let model = Model::new(&tree.robot).expect("model");
    let mut data = Data::new(&model);
    let s = 0.5_f64.sqrt();
    let mut qr = vec![0.1, -0.2, 0.3, 0.0, s, 0.0, s];
    qr.extend([0.3, -0.5, 0.2, -1.9, 0.4, 1.6, -0.7, 0.02]);
    let vr: Vec<f64> = (0..14).map(|k| (k as f64 * 0.7).sin()).collect();
    let ar: Vec<f64> = (0..14).map(|k| (k as f64 * 1.3).cos()).collect();
    let g = c.matrix();
    let q = c.expand_q(&qr).expect("q");
    assert_eq!(&q[..7], &qr[..7]);
    let v = &g * nalgebra::DVector::from_row_slice(&vr);
    let a = &g * nalgebra::DVector::from_row_slice(&ar);
    let full = rnea(&model, &mut data, &q, v.as_slice(), a.as_slice()).expect("rnea");
    let want = g.transpose() * full;
    let got = rnea_mimic(&model, &mut data, c, &qr, &vr, &ar).expect("rnea_mimic");
    assert!(rel_err(got.as_slice(), want.as_slice()) < 1e-13);
    let m = crba_mimic(&model, &mut data, c, &qr).expect("crba");
    let tau = &m * nalgebra::DVector::from_row_slice(&ar)
        + rnea_mimic(&model, &mut data, c, &qr, &vr, &[0.0; 14]).expect("bias");
    let qdd = aba_mimic(&model, &mut data, c, &qr, &vr, tau.as_slice()).expect("aba");
    assert!(rel_err(qdd.as_slice(), &ar) < 1e-9, "{qdd} vs {ar:?}");
    let (pose, jac) = link_jacobian(&tree.robot, c, &qr, 9, Frame::Base).expect("J");
    assert_eq!(jac.ncols(), 14);
    assert_eq!(pose, link_pose(&tree.robot, &q, 9));
}
