//! Joint friction apart from the rigid-body algorithms (issue 36 item 3): with friction off the
//! numbers are Pinocchio's (xArm7, whose URDF has damping 2 to 10 and friction 1 on every joint:
//! τ differed by 11 N·m); the stick–slip model holds a joint at rest under a torque below its
//! Coulomb limit and lets it go above; a robot without friction data steps exactly as without
//! the effect.

use robosim_dynamics::{
    Coulomb, Data, Integrator, IntegratorConfig, JointFriction, Model, Stepper, aba,
    aba_with_friction, fixture_robot, friction_torque, passive_torque, rnea,
};
use robosim_kinematics::{Robot, State};
use robosim_urdf::urdf_import::import_urdf;
use serde_json::Value;
use std::path::PathBuf;

fn corpus() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/urdf_corpus")
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Issue 36: `id` on xArm7 added the URDF's damping and Coulomb friction inside RNEA (11 N·m
/// from Pinocchio). The friction data is kept on the joints; RNEA and ABA are Pinocchio's.
#[test]
fn issue_36_xarm7_keeps_its_friction_data_and_its_dynamics_are_pinocchios() {
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(corpus().join("reference.json")).expect("reference"),
    )
    .expect("JSON");
    let rob = reference["robots"]
        .as_array()
        .expect("robots")
        .iter()
        .find(|r| r["file"] == "xarm_description/xarm7.urdf")
        .expect("xarm7 in the corpus");
    let tip = rob["tip"].as_str().expect("tip");
    let xarm = import_urdf(
        &corpus().join("robots/xarm_description/xarm7.urdf"),
        Some(tip),
    )
    .expect("imports")
    .robot;
    assert!(
        xarm.joints
            .iter()
            .all(|j| j.viscous >= 2.0 && j.coulomb == 1.0),
        "the URDF's <dynamics> is kept as joint data: {:?}",
        xarm.joints
            .iter()
            .map(|j| (j.viscous, j.coulomb))
            .collect::<Vec<_>>()
    );
    let model = Model::new(&xarm).expect("model");
    let mut data = Data::new(&model);
    let friction = JointFriction::default();
    for s in rob["chain"]["samples"].as_array().expect("samples") {
        let [q, v, a, tau] = ["q", "v", "a", "tau"].map(|k| floats(&s[k]));
        let t = rnea(&model, &mut data, &q, &v, &a).expect("rnea").clone();
        let want = floats(&s["rnea"]);
        for (x, y) in t.iter().zip(&want) {
            assert!((x - y).abs() <= 1e-10 * (1.0 + y.abs()), "rnea {x} vs {y}");
        }
        // with friction asked for, the motor torque is τ_rigid − τ_passive: it differs by
        // b q̇ + c sign(q̇), as much as 11 N·m here
        let mut passive = vec![0.0; q.len()];
        passive_torque(&model, &v, &friction, &mut passive).expect("passive");
        for ((p, link_v), j) in passive.iter().zip(&v).zip(&xarm.joints) {
            let want = -j.viscous * link_v - j.coulomb * link_v.signum();
            assert!((p - want).abs() < 1e-12, "{p} vs {want}");
        }
        let qdd = aba(&model, &mut data, &q, &v, &tau).expect("aba").clone();
        let want = floats(&s["aba"]);
        for (x, y) in qdd.iter().zip(&want) {
            assert!((x - y).abs() <= 1e-10 * (1.0 + y.abs()), "aba {x} vs {y}");
        }
        // moving joints: ABA with friction = ABA of τ plus the passive torque
        let with = aba_with_friction(&model, &mut data, &q, &v, &tau, &friction)
            .expect("aba with friction")
            .clone();
        let total: Vec<f64> = tau.iter().zip(&passive).map(|(t, p)| t + p).collect();
        let direct = aba(&model, &mut data, &q, &v, &total).expect("aba").clone();
        assert!((with - direct).amax() < 1e-12);
    }
}

/// The PUMA 560 in zero gravity, every joint with Coulomb friction 5 N·m, at rest.
fn sticky_puma() -> Robot {
    let mut r = fixture_robot("puma560").expect("puma");
    r.gravity = nalgebra::Vector3::zeros();
    for j in &mut r.joints {
        j.coulomb = 5.0;
        j.viscous = 0.0;
    }
    r
}

/// 1 s of RK4 at 1 ms from rest at q0 under constant `tau`; the final state.
fn run(robot: &Robot, friction: Option<JointFriction>, tau: &[f64]) -> State {
    let model = Model::new(robot).expect("model");
    let mut stepper =
        Stepper::new(&model, IntegratorConfig::fixed(Integrator::Rk4, 1e-3)).expect("stepper");
    if let Some(f) = friction {
        stepper = stepper.with_friction(&model, f).expect("friction");
    }
    let n = model.dof();
    let mut state = State::zeros(n);
    state.q = nalgebra::DVector::from_column_slice(&[0.1, -0.4, 0.3, 0.2, 0.5, -0.2]);
    for _ in 0..1000 {
        stepper.step(&model, &mut state, tau, 1e-3).expect("steps");
    }
    state
}

/// The stick–slip model holds a joint at rest under a torque below its Coulomb limit (3 of
/// 5 N·m on the shoulder): q does not move in 1 s, and friction supplies exactly −3 N·m there
/// (the other joints, coupled through M, held by theirs). Above the limit (7 N·m) it moves,
/// with 7 − 5 = 2 N·m net; without the effect 3 N·m moves it too.
#[test]
fn a_joint_below_its_coulomb_limit_is_held_still() {
    let robot = sticky_puma();
    let q0 = [0.1, -0.4, 0.3, 0.2, 0.5, -0.2];
    let stick = JointFriction::default();
    let below = [0.0, 3.0, 0.0, 0.0, 0.0, 0.0];
    let held = run(&robot, Some(stick), &below);
    let moved: f64 = held
        .q
        .iter()
        .zip(&q0)
        .fold(0.0, |m, (a, b)| m.max((a - b).abs()));
    assert!(moved < 1e-12, "held joint moved {moved} rad");
    assert!(held.qd.amax() < 1e-12, "{:?}", held.qd);

    let model = Model::new(&robot).expect("model");
    let mut data = Data::new(&model);
    let f = friction_torque(&model, &mut data, &q0, &[0.0; 6], &below, &stick)
        .expect("friction")
        .clone();
    assert!((f[1] + 3.0).abs() < 1e-12, "{f:?}");
    assert!(f.iter().all(|x| x.abs() <= 5.0), "{f:?}");

    let above = [0.0, 7.0, 0.0, 0.0, 0.0, 0.0];
    let slid = run(&robot, Some(stick), &above);
    assert!(
        slid.q[1] - q0[1] > 1e-3,
        "7 N·m > 5 N·m slips: {}",
        slid.q[1]
    );
    let free = run(&robot, None, &below);
    assert!(free.q[1] - q0[1] > 1e-3, "without friction 3 N·m moves it");
    // the slipping joint feels 5 N·m against it: it moves less than under 7 N·m without friction
    let free7 = run(&robot, None, &above);
    assert!(slid.q[1] < free7.q[1]);

    // the regularised model creeps instead of holding
    let reg = JointFriction {
        viscous: true,
        coulomb: Coulomb::Regularised { velocity: 1e-3 },
    };
    let crept = run(&robot, Some(reg), &below);
    assert!((crept.q[1] - q0[1]).abs() < 1e-2 && crept.q[1] != q0[1]);
}

/// Undeclared, friction costs nothing: a stepper has none unless given, and a robot with no
/// friction data drops it (same state, bit for bit).
#[test]
fn friction_on_a_robot_without_friction_data_is_dropped() {
    let robot = fixture_robot("puma560").expect("puma");
    let model = Model::new(&robot).expect("model");
    let s = Stepper::new(&model, IntegratorConfig::fixed(Integrator::Rk4, 1e-3)).expect("s");
    assert!(s.friction().is_none());
    let s = s
        .with_friction(&model, JointFriction::default())
        .expect("valid");
    assert!(s.friction().is_none(), "nothing to apply");
    let tau = [1.0, -2.0, 0.5, 0.0, 0.1, 0.0];
    let a = run(&robot, None, &tau);
    let b = run(&robot, Some(JointFriction::default()), &tau);
    assert_eq!((a.q, a.qd), (b.q, b.qd));
    let bad = JointFriction {
        viscous: true,
        coulomb: Coulomb::Regularised { velocity: 0.0 },
    };
    assert!(bad.validate().is_err());
}
