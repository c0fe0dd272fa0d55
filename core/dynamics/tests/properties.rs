//! Properties over random states of every fixture robot, with friction and motor inertia on:
//! RNEA(q, q̇, ABA(q, q̇, τ)) = τ; ABA = CRBA + Cholesky; M symmetric positive definite;
//! kinetic energy = ½ q̇ᵀ M q̇; gravity torque = ∂V/∂q; energy drift of each integrator shrinks
//! with the step as its order says.

use crate::common;

use proptest::prelude::*;
use robosim_dynamics::{
    Data, Integrator, IntegratorConfig, Model, aba, crba, energy, fd_cholesky, gravity,
    kinetic_gradient, rnea, simulate,
};
use robosim_kinematics::Robot;

fn with_drive(mut robot: Robot, scale: f64) -> Robot {
    for (j, joint) in robot.joints.iter_mut().enumerate() {
        joint.motor_inertia = scale * 0.01 * (j + 1) as f64;
        joint.viscous = scale * 0.5;
        joint.coulomb = scale * 0.2;
    }
    robot
}

fn robots() -> Vec<Model> {
    common::FIXTURES
        .iter()
        .flat_map(|n| {
            let r = common::fixture(n);
            [
                Model::new(&r).expect("valid"),
                Model::new(&with_drive(r, 1.0)).expect("valid"),
            ]
        })
        .collect()
}

fn inf_norm(x: &[f64]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

// A fixed seed: the same cases on every run, so CI never meets a new random case (a random
// run failed CI once on a pose numeric IK cannot reach, core/kinematics/tests/properties.rs).
// Look for more by changing the seed or the case count.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0xD1_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn rnea_inverts_aba_and_mass_matrix_is_spd(
        which in 0usize..10,
        raw in proptest::collection::vec(-1.0f64..1.0, 28),
    ) {
        let models = robots();
        let model = &models[which];
        let n = model.dof();
        let mut data = Data::new(model);
        let q: Vec<f64> = model.robot().joints.iter().zip(&raw).map(|(j, r)| {
            let [lo, hi] = j.qlim;
            lo + (hi - lo) * (r + 1.0) / 2.0
        }).collect();
        let qd: Vec<f64> = raw[7..7 + n].iter().map(|r| 3.0 * r).collect();
        let tau: Vec<f64> = raw[14..14 + n].iter().map(|r| 50.0 * r).collect();

        let qdd = aba(model, &mut data, &q, &qd, &tau).expect("aba").as_slice().to_vec();
        let back = rnea(model, &mut data, &q, &qd, &qdd).expect("rnea").as_slice().to_vec();
        let scale = inf_norm(&tau).max(1.0);
        for j in 0..n {
            prop_assert!((back[j] - tau[j]).abs() <= 1e-9 * scale, "joint {j}: {} vs {}", back[j], tau[j]);
        }
        let chol = fd_cholesky(model, &mut data, &q, &qd, &tau).expect("fd").as_slice().to_vec();
        let qscale = inf_norm(&qdd).max(1.0);
        for j in 0..n {
            prop_assert!((chol[j] - qdd[j]).abs() <= 1e-9 * qscale, "joint {j}: Cholesky {} vs ABA {}", chol[j], qdd[j]);
        }
        let m = crba(model, &mut data, &q).expect("crba").clone();
        prop_assert_eq!(m.clone(), m.transpose());
        let eig = m.clone().symmetric_eigenvalues();
        prop_assert!(eig.min() > 0.0, "M not positive definite: {eig}");

        // ½ q̇ᵀ M q̇ is the kinetic energy the energy function computes link by link
        let qdv = nalgebra::DVector::from_column_slice(&qd);
        let ke = 0.5 * qdv.dot(&(&m * &qdv));
        let e = energy(model, &mut data, &q, &qd).expect("energy");
        prop_assert!((e.kinetic - ke).abs() <= 1e-10 * ke.max(1.0), "kinetic {} vs ½q̇ᵀMq̇ {}", e.kinetic, ke);

        // ∂T/∂q at fixed q̇ (the symplectic step's force) against central differences of T
        let dtdq = kinetic_gradient(model, &mut data, &q, &qd).expect("gradient").as_slice().to_vec();
        for j in 0..n {
            let h = 1e-6;
            let mut qp = q.clone();
            qp[j] += h;
            let mut qm = q.clone();
            qm[j] -= h;
            let tp = energy(model, &mut data, &qp, &qd).expect("energy").kinetic;
            let tm = energy(model, &mut data, &qm, &qd).expect("energy").kinetic;
            let fd = (tp - tm) / (2.0 * h);
            prop_assert!((fd - dtdq[j]).abs() <= 1e-6 * inf_norm(&dtdq).max(1.0), "joint {j}: ∂T/∂q {} vs finite difference {fd}", dtdq[j]);
        }

        // the gravity torque is the gradient of the potential energy (central differences)
        let g = gravity(model, &mut data, &q).expect("gravity").as_slice().to_vec();
        let h = 1e-6;
        for j in 0..n {
            let mut qp = q.clone();
            qp[j] += h;
            let mut qm = q.clone();
            qm[j] -= h;
            let vp = energy(model, &mut data, &qp, &qd).expect("energy").potential;
            let vm = energy(model, &mut data, &qm, &qd).expect("energy").potential;
            let dv = (vp - vm) / (2.0 * h);
            prop_assert!((dv - g[j]).abs() <= 1e-6 * inf_norm(&g).max(1.0), "joint {j}: ∂V/∂q {dv} vs g {}", g[j]);
        }
    }
}

/// Energy error of a free-falling PUMA 560 (no friction, no motor inertia) after 0.5 s, at step
/// h and h/2: the ratio approaches 2^order.
#[test]
fn energy_drift_shrinks_with_the_integrators_order() {
    let model = Model::new(&common::fixture("puma560")).expect("valid");
    let q0 = [0.0, 0.3, -0.5, 0.2, 0.6, 0.0];
    let drift = |integrator, dt| {
        let (s, _) = simulate(
            &model,
            IntegratorConfig::fixed(integrator, dt),
            &q0,
            &[0.0; 6],
            &[0.0; 6],
            &[0.0, 0.5],
        )
        .expect("runs");
        (s[1].energy - s[0].energy).abs()
    };
    for (integrator, dt) in [
        (Integrator::Euler, 1e-4),
        (Integrator::SemiImplicitEuler, 1e-4),
        (Integrator::Rk4, 4e-3),
        (Integrator::Dopri5, 1e-2),
    ] {
        let (coarse, fine) = (drift(integrator, dt), drift(integrator, dt / 2.0));
        let ratio = coarse / fine;
        let expected = 2f64.powi(integrator.order() as i32);
        eprintln!(
            "{integrator:?}: |ΔE| {coarse:.3e} J at h = {dt}, {fine:.3e} J at h/2, ratio {ratio:.2} (2^p = {expected})"
        );
        prop_assert_in(ratio, 0.6 * expected, 1.6 * expected, integrator);
    }
}

fn prop_assert_in(ratio: f64, lo: f64, hi: f64, integrator: Integrator) {
    assert!(
        ratio >= lo && ratio <= hi,
        "{integrator:?}: drift ratio {ratio} outside [{lo}, {hi}]"
    );
}

/// Dormand–Prince with step control: the error at t = 1 s of a falling PUMA 560 against an RK4
/// run at 0.1 ms follows the tolerance down, and stays within a small multiple of it.
#[test]
fn dopri5_error_follows_the_tolerance() {
    let model = Model::new(&common::fixture("puma560")).expect("valid");
    let q0 = [0.0, 0.3, -0.5, 0.2, 0.6, 0.0];
    let run = |config| {
        let (s, stats) = simulate(&model, config, &q0, &[0.0; 6], &[0.0; 6], &[1.0]).expect("runs");
        (s[0].q.clone(), stats)
    };
    let (reference, _) = run(IntegratorConfig::fixed(Integrator::Rk4, 1e-4));
    let mut last = f64::INFINITY;
    for tol in [1e-4, 1e-6, 1e-8] {
        let (q, stats) = run(IntegratorConfig::adaptive(tol, tol));
        let err = q
            .iter()
            .zip(&reference)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        eprintln!(
            "dopri5 rtol = atol = {tol:e}: error {err:.2e} rad, {} steps ({} rejected)",
            stats.accepted, stats.rejected
        );
        assert!(err < 100.0 * tol, "error {err} for tolerance {tol}");
        assert!(err < last, "error must fall with the tolerance");
        last = err;
    }
}
