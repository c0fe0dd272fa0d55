//! Agreement with Pinocchio (testdata/dynamics/README.md): τ = RNEA, M = CRBA, g, and q̈ = ABA for
//! the PUMA 560, Stanford arm, Panda (modified DH) and two synthetic arms with prismatic joints and
//! a tilted base, at 40 random states each, to 1e-9 relative (per vector: |x − ref|∞ ≤ 1e-9 ·
//! max(|ref|∞, 1)). Forward dynamics is checked twice: by ABA and by CRBA + Cholesky.

use robosim_dynamics::{
    Coulomb, Data, JointFriction, Model, aba, aba_with_friction, crba, fd_cholesky, gravity,
    passive_torque, rnea,
};
use robosim_kinematics::json::robot_from_json;
use serde_json::Value;
use std::path::PathBuf;

fn testdata() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/dynamics")
}

fn load(path: &PathBuf) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn vec_of(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn rel_err(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    got.iter()
        .zip(want)
        .fold(0.0_f64, |m, (g, w)| m.max((g - w).abs()))
        / scale
}

#[test]
fn rnea_crba_gravity_aba_match_pinocchio() {
    let reference = load(&testdata().join("reference.json"));
    let robots = reference["robots"].as_object().expect("robots object");
    assert!(robots.len() >= 5);
    for (name, cases) in robots {
        let robot = robot_from_json(&load(
            &testdata().join("robots").join(format!("{name}.json")),
        ))
        .expect("fixture parses");
        let model = Model::new(&robot).expect("fixture is valid");
        let mut data = Data::new(&model);
        let cases = cases.as_array().expect("cases");
        assert!(cases.len() >= 40, "{name}: too few cases");
        let mut worst = [0.0_f64; 5];
        for (i, c) in cases.iter().enumerate() {
            let (q, qd, qdd) = (vec_of(&c["q"]), vec_of(&c["qd"]), vec_of(&c["qdd"]));
            let tau = rnea(&model, &mut data, &q, &qd, &qdd)
                .expect("rnea")
                .as_slice()
                .to_vec();
            worst[0] = worst[0].max(rel_err(&tau, &vec_of(&c["tau"])));
            let m = crba(&model, &mut data, &q).expect("crba").clone();
            let m_ref: Vec<f64> = c["mass_matrix"]
                .as_array()
                .expect("rows")
                .iter()
                .flat_map(vec_of)
                .collect();
            let m_got: Vec<f64> = (0..model.dof())
                .flat_map(|r| (0..model.dof()).map(move |k| (r, k)))
                .map(|(r, k)| m[(r, k)])
                .collect();
            worst[1] = worst[1].max(rel_err(&m_got, &m_ref));
            let g = gravity(&model, &mut data, &q)
                .expect("gravity")
                .as_slice()
                .to_vec();
            worst[2] = worst[2].max(rel_err(&g, &vec_of(&c["gravity"])));
            let tau_fd = vec_of(&c["tau_fd"]);
            let qdd_ref = vec_of(&c["qdd_fd"]);
            let a = aba(&model, &mut data, &q, &qd, &tau_fd)
                .expect("aba")
                .as_slice()
                .to_vec();
            worst[3] = worst[3].max(rel_err(&a, &qdd_ref));
            let b = fd_cholesky(&model, &mut data, &q, &qd, &tau_fd)
                .expect("fd")
                .as_slice()
                .to_vec();
            worst[4] = worst[4].max(rel_err(&b, &qdd_ref));
            for (k, what) in ["tau", "M", "g", "qdd (ABA)", "qdd (Cholesky)"]
                .iter()
                .enumerate()
            {
                assert!(
                    worst[k] <= 1e-9,
                    "{name} case {i}: {what} relative error {:e}",
                    worst[k]
                );
            }
        }
        eprintln!(
            "{name}: worst relative errors tau {:.1e}, M {:.1e}, g {:.1e}, qdd ABA {:.1e}, qdd Cholesky {:.1e}",
            worst[0], worst[1], worst[2], worst[3], worst[4]
        );
    }
}

/// Motor inertia and friction against roboticstoolbox-python's `rne` and `accel`, which model
/// them on the DH links (motor side, gear ratio G): the PUMA 560 with G² Jm, G² B and |G| Tc
/// reflected to the joints (testdata/dynamics/README.md).
#[test]
fn motor_inertia_and_friction_match_roboticstoolbox() {
    let reference = load(&testdata().join("reference_drive.json"));
    let robot = robot_from_json(&load(&testdata().join("robots/puma560_drive.json")))
        .expect("fixture parses");
    assert!(
        robot
            .joints
            .iter()
            .all(|j| j.motor_inertia > 0.0 && j.viscous > 0.0 && j.coulomb > 0.0)
    );
    let model = Model::new(&robot).expect("valid");
    let mut data = Data::new(&model);
    let cases = reference["robots"]["puma560_drive"]
        .as_array()
        .expect("cases");
    assert!(cases.len() >= 40);
    let (mut worst_tau, mut worst_qdd) = (0.0_f64, 0.0_f64);
    // RTB's model: viscous + c sign(q̇), no sticking band
    let rtb_friction = JointFriction {
        viscous: true,
        coulomb: Coulomb::StickSlip { velocity: 0.0 },
    };
    for (i, c) in cases.iter().enumerate() {
        let (q, qd, qdd) = (vec_of(&c["q"]), vec_of(&c["qd"]), vec_of(&c["qdd"]));
        // issue 36: RTB's rne adds friction; ours is rigid-body, friction apart: the motor
        // torque is τ_rigid − τ_passive (sign(q̇) Coulomb; RTB's cases move every joint)
        let mut tau = rnea(&model, &mut data, &q, &qd, &qdd)
            .expect("rnea")
            .as_slice()
            .to_vec();
        let mut passive = vec![0.0; q.len()];
        passive_torque(&model, &qd, &rtb_friction, &mut passive).expect("passive");
        for (t, p) in tau.iter_mut().zip(&passive) {
            *t -= p;
        }
        worst_tau = worst_tau.max(rel_err(&tau, &vec_of(&c["tau"])));
        let a = aba_with_friction(
            &model,
            &mut data,
            &q,
            &qd,
            &vec_of(&c["tau_fd"]),
            &rtb_friction,
        )
        .expect("aba")
        .as_slice()
        .to_vec();
        worst_qdd = worst_qdd.max(rel_err(&a, &vec_of(&c["qdd_fd"])));
        assert!(
            worst_tau <= 1e-9 && worst_qdd <= 1e-9,
            "case {i}: tau {worst_tau:e}, qdd {worst_qdd:e}"
        );
    }
    eprintln!("puma560_drive: worst relative errors tau {worst_tau:.1e}, qdd {worst_qdd:.1e}");
}
