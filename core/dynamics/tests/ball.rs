//! Spherical (ball) joints (issue 36 item 5): testdata/ball/ball_tree.xml — three ball joints, a
//! hinge and a slide, one branch — imported from MJCF and checked against Pinocchio 4.1
//! (JointModelSpherical) and MuJoCo 4.0 at random (q, v, a, τ) from testdata/ball/reference.json
//! (made by testdata/ball/make_ball_reference.py): every joint frame's pose and
//! LOCAL_WORLD_ALIGNED Jacobian, RNEA, gravity, CRBA, ABA; the same tree on a free-flyer
//! (RNEA ∘ ABA round trip, M against RNEA's columns); and a free swing under gravity conserving
//! energy as the arms do (docs/dynamics.md's table), each quaternion unit.

use crate::common::{floats, matrix, rel_err};
use nalgebra::DMatrix;
use robosim_dynamics::{
    Data, DynamicsError, Integrator, IntegratorConfig, Model, Stepper, aba, crba, energy,
    fd_cholesky, gravity, rnea, simulate,
};
use robosim_kinematics::jacobian::{Frame, link_jacobian};
use robosim_kinematics::{ModelError, Robot, RootJoint, RootKind, State};
use serde_json::Value;
use std::path::PathBuf;

/// The bound, relative to max(1, max |reference|), for every quantity.
const TOL: f64 = 1e-12;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn ball_tree() -> (Robot, Vec<String>) {
    let imported = robosim_urdf::import_mjcf_tree(&repo().join("testdata/ball/ball_tree.xml"))
        .expect("ball_tree.xml imports");
    let names = imported.joints.iter().map(|j| j.name.clone()).collect();
    (imported.robot, names)
}

fn flat(m: &DMatrix<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

#[test]
fn ball_tree_has_pinocchios_and_mujocos_kinematics_and_dynamics() {
    let text = std::fs::read_to_string(repo().join("testdata/ball/reference.json"))
        .expect("reference.json");
    let reference: Value = serde_json::from_str(&text).expect("JSON");
    let (robot, names) = ball_tree();
    let want: Vec<String> = reference["joints"]
        .as_array()
        .expect("joints")
        .iter()
        .map(|n| n.as_str().expect("name").to_string())
        .collect();
    assert_eq!(names, want, "the joint order is the peers'");
    let spherical: Vec<bool> = robot.joints.iter().map(|j| j.spherical).collect();
    assert_eq!(spherical, [true, false, true, false, true]);
    assert_eq!(
        (robot.nq(), robot.nv()),
        (
            reference["nq"].as_u64().expect("nq") as usize,
            reference["nv"].as_u64().expect("nv") as usize
        )
    );
    let nv = robot.nv();
    let model = Model::new(&robot).expect("valid");
    let mut data = Data::new(&model);
    // worst relative error: pose, Jacobian, RNEA, gravity, ABA, M (Pinocchio), then MuJoCo's
    let mut worst = [0.0_f64; 6];
    let mut worst_mj = 0.0_f64;
    let samples = reference["samples"].as_array().expect("samples");
    assert_eq!(samples.len(), 5);
    for s in samples {
        let (q, v, a, tau) = (
            floats(&s["q"]),
            floats(&s["v"]),
            floats(&s["a"]),
            floats(&s["tau"]),
        );
        // MuJoCo's qpos is the same q with each ball's quaternion w x y z
        let qpos = floats(&s["mujoco"]["qpos"]);
        for (j, joint) in robot.joints.iter().enumerate() {
            let i = robot.q_index(j);
            if joint.spherical {
                assert_eq!(
                    &q[i..i + 4],
                    &[qpos[i + 1], qpos[i + 2], qpos[i + 3], qpos[i]]
                );
            } else {
                assert_eq!(q[i], qpos[i]);
            }
        }
        robot.check_q(&q).expect("unit quaternions");
        for (j, name) in names.iter().enumerate() {
            let frame = &s["frames"][name];
            let (pose, jac) = link_jacobian(&robot, &q, j + 1, Frame::Base);
            let got_pose: Vec<f64> = (0..4)
                .flat_map(|r| (0..4).map(move |c| (r, c)))
                .map(|(r, c)| pose[(r, c)])
                .collect();
            let jac = DMatrix::from_column_slice(6, nv, jac.as_slice());
            for (k, (want_pose, want_jac)) in [
                (flat(&matrix(&frame["pose"])), floats(&frame["jacobian"])),
                (
                    flat(&matrix(&s["mujoco"]["poses"][name])),
                    floats(&s["mujoco"]["jacobians"][name]),
                ),
            ]
            .into_iter()
            .enumerate()
            {
                let (ep, ej) = (
                    rel_err(&got_pose, &want_pose),
                    rel_err(&flat(&jac), &want_jac),
                );
                if k == 0 {
                    worst[0] = worst[0].max(ep);
                    worst[1] = worst[1].max(ej);
                } else {
                    worst_mj = worst_mj.max(ep).max(ej);
                }
            }
        }
        let tau_rnea = rnea(&model, &mut data, &q, &v, &a).expect("rnea").clone();
        worst[2] = worst[2].max(rel_err(tau_rnea.as_slice(), &floats(&s["rnea"])));
        worst_mj = worst_mj.max(rel_err(tau_rnea.as_slice(), &floats(&s["mujoco"]["rnea"])));
        let g = gravity(&model, &mut data, &q).expect("gravity").clone();
        worst[3] = worst[3].max(rel_err(g.as_slice(), &floats(&s["gravity"])));
        let qdd = aba(&model, &mut data, &q, &v, &tau).expect("aba").clone();
        worst[4] = worst[4].max(rel_err(qdd.as_slice(), &floats(&s["aba"])));
        worst_mj = worst_mj.max(rel_err(qdd.as_slice(), &floats(&s["mujoco"]["aba"])));
        let chol = fd_cholesky(&model, &mut data, &q, &v, &tau)
            .expect("fd")
            .clone();
        assert!(rel_err(chol.as_slice(), qdd.as_slice()) < TOL);
        let m = crba(&model, &mut data, &q).expect("crba").clone();
        worst[5] = worst[5].max(rel_err(&flat(&m), &floats(&s["M"])));
        worst_mj = worst_mj.max(rel_err(&flat(&m), &floats(&s["mujoco"]["M"])));
    }
    eprintln!(
        "ball tree vs Pinocchio: pose {:.1e}, Jacobian {:.1e}, RNEA {:.1e}, gravity {:.1e}, ABA {:.1e}, M {:.1e}; vs MuJoCo (all) {worst_mj:.1e}",
        worst[0], worst[1], worst[2], worst[3], worst[4], worst[5]
    );
    for (what, w) in ["pose", "jacobian", "rnea", "gravity", "aba", "M"]
        .iter()
        .zip(worst)
    {
        assert!(w < TOL, "{what}: relative error {w:e}");
    }
    assert!(worst_mj < TOL, "MuJoCo: relative error {worst_mj:e}");
}

/// The tree on a free-flyer root (the torso's ball joint under a floating base): RNEA undoes
/// ABA, CRBA's columns are RNEA's at unit accelerations, M is symmetric positive definite.
#[test]
fn ball_tree_on_a_free_flyer_is_self_consistent() {
    let (mut robot, _) = ball_tree();
    robot.root = Some(RootJoint {
        kind: RootKind::FreeFlyer,
        mass: 2.0,
        com: nalgebra::Vector3::new(0.01, -0.02, 0.03),
        inertia: nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(0.05, 0.04, 0.03)),
    });
    let model = Model::new(&robot).expect("valid");
    let mut data = Data::new(&model);
    let nv = robot.nv();
    let (q, v) = moving_state(&robot);
    let tau: Vec<f64> = (0..nv).map(|i| 0.3 * ((i * 7) % 5) as f64 - 0.6).collect();
    let qdd = aba(&model, &mut data, &q, &v, &tau).expect("aba").clone();
    let back = rnea(&model, &mut data, &q, &v, qdd.as_slice())
        .expect("rnea")
        .clone();
    assert!(rel_err(back.as_slice(), &tau) < 1e-12, "{back} vs {tau:?}");
    let m = crba(&model, &mut data, &q).expect("crba").clone();
    let bias = rnea(&model, &mut data, &q, &vec![0.0; nv], &vec![0.0; nv])
        .expect("rnea")
        .clone();
    for i in 0..nv {
        let mut e = vec![0.0; nv];
        e[i] = 1.0;
        let col = rnea(&model, &mut data, &q, &vec![0.0; nv], &e)
            .expect("rnea")
            .clone()
            - &bias;
        let want: Vec<f64> = m.column(i).iter().copied().collect();
        assert!(rel_err(col.as_slice(), &want) < 1e-12, "column {i}");
    }
    // symmetric to rounding (the root's block is formed entry by entry)
    assert!((&m - m.transpose()).amax() <= 1e-15 * m.amax());
    assert!(m.clone().cholesky().is_some());
}

/// A configuration away from the neutral one and a velocity that moves every coordinate.
fn moving_state(robot: &Robot) -> (Vec<f64>, Vec<f64>) {
    let mut q = robot.neutral_q().as_slice().to_vec();
    for (j, joint) in robot.joints.iter().enumerate() {
        let i = robot.q_index(j);
        if joint.spherical {
            let quat = nalgebra::UnitQuaternion::from_euler_angles(
                0.4 + 0.1 * j as f64,
                -0.3,
                0.2 * j as f64,
            );
            q[i..i + 4].copy_from_slice(&[quat.i, quat.j, quat.k, quat.w]);
        } else {
            q[i] = 0.3 - 0.05 * j as f64;
        }
    }
    let v: Vec<f64> = (0..robot.nv())
        .map(|i| [1.5, -1.0, 2.0, 0.5][i % 4] * if i % 2 == 0 { 1.0 } else { -0.7 })
        .collect();
    (q, v)
}

fn drift(model: &Model, q0: &[f64], v0: &[f64], integrator: Integrator, dt: f64, t: f64) -> f64 {
    let (s, _) = simulate(
        model,
        IntegratorConfig::fixed(integrator, dt),
        q0,
        v0,
        &vec![0.0; model.nv()],
        &[0.0, t],
    )
    .expect("runs");
    let robot = model.robot();
    for (j, joint) in robot.joints.iter().enumerate() {
        if joint.spherical {
            let i = robot.q_index(j);
            let n = s[1].q[i..i + 4].iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!(
                (n - 1.0).abs() < 1e-12,
                "{integrator:?}: joint {j} |quat| {n}"
            );
        }
    }
    assert!(
        s[1].q.iter().chain(&s[1].qd).all(|x| x.is_finite()) && s[1].energy.is_finite(),
        "NaN after {t} s with {integrator:?}"
    );
    (s[1].energy - s[0].energy).abs()
}

/// The ball tree swinging freely under gravity (zero torque, no joint stops) conserves energy
/// as the arms do (urdf_energy.rs's policy): the drift ratio between h and h/2 is 2^order
/// within [0.6, 1.6] (Dormand–Prince [0.6, 8], as for Solo); 1 s of RK4 at 0.1 ms conserves
/// energy to 1e-6 of Σm·g·1 m. The symplectic Euler step refuses a ball joint by name.
#[test]
fn ball_tree_swinging_freely_conserves_energy() {
    let (robot, _) = ball_tree();
    let model = Model::new(&robot).expect("valid");
    let (q0, v0) = moving_state(&robot);
    let scale = robot.joints.iter().map(|j| j.mass).sum::<f64>() * robot.gravity.norm();
    let mut data = Data::new(&model);
    let e0 = energy(&model, &mut data, &q0, &v0).expect("energy");
    assert!(e0.kinetic > 0.1, "a run that moves: T = {}", e0.kinetic);
    for (integrator, dt) in [
        (Integrator::Euler, 1e-4),
        (Integrator::Rk4, 4e-3),
        (Integrator::Dopri5, 1e-2),
    ] {
        let coarse = drift(&model, &q0, &v0, integrator, dt, 0.5);
        let fine = drift(&model, &q0, &v0, integrator, dt / 2.0, 0.5);
        let ratio = coarse / fine;
        let expected = 2f64.powi(integrator.order() as i32);
        let upper = if integrator == Integrator::Dopri5 {
            8.0
        } else {
            1.6
        };
        eprintln!(
            "ball tree {integrator:?}: |ΔE| {coarse:.3e} J at h = {dt}, {fine:.3e} J at h/2 (relative to {scale:.2} J: {:.2e}, {:.2e}), ratio {ratio:.2} (2^p = {expected})",
            coarse / scale,
            fine / scale
        );
        assert!(
            ratio >= 0.6 * expected && ratio <= upper * expected,
            "{integrator:?}: drift ratio {ratio} outside [{}, {}]",
            0.6 * expected,
            upper * expected
        );
    }
    let de = drift(&model, &q0, &v0, Integrator::Rk4, 1e-4, 1.0);
    eprintln!(
        "ball tree RK4 h = 0.1 ms, 1 s: |ΔE| = {de:.3e} J, relative {:.3e}",
        de / scale
    );
    assert!(de < 1e-6 * scale, "|ΔE| {de} J");
    let mut stepper = Stepper::new(
        &model,
        IntegratorConfig::fixed(Integrator::SemiImplicitEuler, 1e-3),
    )
    .expect("stepper");
    let mut state = State {
        q: q0.clone().into(),
        qd: v0.clone().into(),
        qdd: nalgebra::DVector::zeros(robot.nv()),
        t: 0.0,
    };
    let err = stepper
        .step(&model, &mut state, &vec![0.0; robot.nv()], 1e-3)
        .expect_err("refused");
    assert_eq!(
        err,
        DynamicsError::Model(ModelError::SphericalUnsupported {
            joint: 0,
            what: "the symplectic Euler integrator"
        })
    );
}
