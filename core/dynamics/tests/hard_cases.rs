//! Named hard cases: a 1e-6 kg link beside 100 kg ones; one hour at 1 kHz with the symplectic
//! integrator; a prismatic joint at its limit; bit-identical fixed-step runs.

use crate::common;

use nalgebra::{DVector, Matrix3, Vector3};
use robosim_dynamics::{
    Data, Integrator, IntegratorConfig, Model, Stepper, aba, crba, energy, fd_cholesky, rnea,
    simulate, state_hash,
};
use robosim_kinematics::{Joint, JointType, Robot, State};

fn box_inertia(m: f64, x: f64, y: f64, z: f64) -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(y * y + z * z, x * x + z * z, x * x + y * y)) * (m / 12.0)
}

fn link(mass: f64, a: f64, alpha: f64) -> Joint {
    Joint {
        a,
        alpha,
        mass,
        com: Vector3::new(-a / 2.0, 0.0, 0.0),
        inertia: box_inertia(mass, a.abs().max(0.05), 0.05, 0.05),
        ..Joint::default()
    }
}

#[test]
fn tiny_link_beside_heavy_links_keeps_rnea_aba_consistent() {
    // 100 kg, 1e-6 kg, 100 kg, 1e-6 kg: mass ratio 1e8 along the chain.
    let robot = Robot {
        joints: vec![
            link(100.0, 0.5, 1.2),
            link(1e-6, 0.3, -0.7),
            link(100.0, 0.4, 0.4),
            link(1e-6, 0.2, 0.9),
        ],
        ..Robot::default()
    };
    let model = Model::new(&robot).expect("valid");
    let mut data = Data::new(&model);
    // The bounds differ per joint and state: keep the error that came closest to its own bound,
    // with that bound, for the `measured:` lines.
    let (mut rnea_worst, mut aba_worst) = ((0.0_f64, 1.0_f64), (0.0_f64, 1.0_f64));
    for k in 0..50 {
        let s = k as f64;
        let q = [
            0.3 * s.sin(),
            1.1 * (0.7 * s).cos(),
            -0.4 + 0.01 * s,
            2.0 * (1.3 * s).sin(),
        ];
        let qd = [0.5 * s.cos(), -1.0, 0.2 * s.sin(), 3.0];
        let tau = [10.0 * s.sin(), 1e-5 * s.cos(), -20.0, 1e-6];
        let qdd = aba(&model, &mut data, &q, &qd, &tau).expect("aba").clone();
        assert!(qdd.iter().all(|x| x.is_finite()));
        let qdd_chol = fd_cholesky(&model, &mut data, &q, &qd, &tau)
            .expect("M is positive definite")
            .clone();
        let back = rnea(&model, &mut data, &q, &qd, qdd.as_slice())
            .expect("rnea")
            .clone();
        for j in 0..4 {
            // tiny joints carry tiny torques: relative to each joint's own torque, plus round-off
            // of the heavy links' forces (~1e3 N·m · 1e-14)
            let (err, bound) = ((back[j] - tau[j]).abs(), 1e-9 * tau[j].abs() + 1e-11);
            if err / bound > rnea_worst.0 / rnea_worst.1 {
                rnea_worst = (err, bound);
            }
            assert!(
                (back[j] - tau[j]).abs() <= 1e-9 * tau[j].abs() + 1e-11,
                "case {k} joint {j}: {} vs {}",
                back[j],
                tau[j]
            );
            let qscale = qdd.amax().max(1.0);
            let (err, bound) = ((qdd[j] - qdd_chol[j]).abs(), 1e-6 * qscale);
            if err / bound > aba_worst.0 / aba_worst.1 {
                aba_worst = (err, bound);
            }
            assert!(
                (qdd[j] - qdd_chol[j]).abs() <= 1e-6 * qscale,
                "case {k} joint {j}: ABA {} vs Cholesky {}",
                qdd[j],
                qdd_chol[j]
            );
        }
        let m = crba(&model, &mut data, &q).expect("crba");
        assert!(
            m.clone().cholesky().is_some(),
            "M positive definite despite the 1e8 mass ratio"
        );
    }
    // and it integrates: 1 s of free fall with RK4 at 0.1 ms, energy conserved
    let (samples, _) = simulate(
        &model,
        IntegratorConfig::fixed(Integrator::Rk4, 1e-4),
        &[0.1, 0.2, 0.3, 0.4],
        &[0.0; 4],
        &[0.0; 4],
        &[0.0, 1.0],
    )
    .expect("simulates");
    let scale = 100.0 * 9.81;
    assert!(
        (samples[1].energy - samples[0].energy).abs() < 1e-6 * scale,
        "energy {} -> {}",
        samples[0].energy,
        samples[1].energy
    );
    let test = "tiny_link_beside_heavy_links_keeps_rnea_aba_consistent";
    eprintln!(
        "measured: {test}: |RNEA(ABA(τ)) − τ| nearest its bound = {:.3e} N·m (bound {:.3e})",
        rnea_worst.0, rnea_worst.1
    );
    eprintln!(
        "measured: {test}: |ABA − Cholesky| nearest its bound = {:.3e} rad/s² (bound {:.3e})",
        aba_worst.0, aba_worst.1
    );
    eprintln!(
        "measured: {test}: |ΔE| over 1 s RK4 = {:.3e} J (bound {:.3e})",
        (samples[1].energy - samples[0].energy).abs(),
        1e-6 * scale
    );
}

/// 3.6 million semi-implicit Euler steps of a double pendulum (chaotic) at 1 kHz: no NaN and
/// no secular energy growth — the error over the whole hour stays within a small multiple of its
/// error over the first minute.
#[test]
fn one_hour_at_1khz_symplectic_euler_energy_bounded() {
    let robot = Robot {
        joints: vec![link(1.0, 0.5, 0.0), link(1.0, 0.5, 0.0)],
        gravity: Vector3::new(-9.81, 0.0, 0.0),
        ..Robot::default()
    };
    let model = Model::new(&robot).expect("valid");
    let mut data = Data::new(&model);
    let mut stepper = Stepper::new(
        &model,
        IntegratorConfig::fixed(Integrator::SemiImplicitEuler, 1e-3),
    )
    .expect("config");
    let mut state = State {
        q: DVector::from_vec(vec![1.0, -0.5]),
        qd: DVector::zeros(2),
        qdd: DVector::zeros(2),
        t: 0.0,
    };
    let e0 = energy(&model, &mut data, state.q.as_slice(), state.qd.as_slice())
        .expect("energy")
        .total();
    let tau = [0.0, 0.0];
    let (mut first_minute, mut whole, mut last_ten_minutes) = (0.0_f64, 0.0_f64, 0.0_f64);
    for step in 1..=3_600_000u32 {
        stepper
            .step(&model, &mut state, &tau, 1e-3)
            .expect("no NaN, no error");
        if step % 100 == 0 {
            let e = energy(&model, &mut data, state.q.as_slice(), state.qd.as_slice())
                .expect("energy")
                .total();
            let de = (e - e0).abs();
            whole = whole.max(de);
            if step <= 60_000 {
                first_minute = first_minute.max(de);
            }
            if step > 3_000_000 {
                last_ten_minutes = last_ten_minutes.max(de);
            }
        }
    }
    assert!((state.t - 3600.0).abs() < 1e-6, "t = {}", state.t);
    let scale = 2.0 * 9.81 * 1.0; // m g L of the pendulum, J
    eprintln!(
        "symplectic Euler, 1 h at 1 kHz: max |ΔE| first minute {first_minute:.3e} J, whole hour {whole:.3e} J, last 10 min {last_ten_minutes:.3e} J"
    );
    assert!(
        whole < 0.05 * scale,
        "energy error {whole} J is not small against {scale} J"
    );
    assert!(
        whole < 3.0 * first_minute,
        "energy error grows: {first_minute} J in the first minute, {whole} J over the hour"
    );
}

/// A vertical prismatic joint falls onto its lower limit and stays there (inelastic stop: q = lo,
/// q̇ = 0); pushed up hard enough it leaves the limit and stops at the upper one. Without stops it
/// falls through.
#[test]
fn prismatic_joint_at_its_limit_stops_inelastically() {
    let slider = Joint {
        joint_type: JointType::Prismatic,
        qlim: [0.0, 1.0],
        mass: 2.0,
        inertia: box_inertia(2.0, 0.1, 0.1, 0.1),
        ..Joint::default()
    };
    let robot = Robot {
        joints: vec![slider],
        ..Robot::default()
    };
    let model = Model::new(&robot).expect("valid");
    for integrator in Integrator::ALL {
        let mut config = IntegratorConfig::fixed(integrator, 1e-3);
        config.joint_stops = true;
        let (s, _) =
            simulate(&model, config, &[0.5], &[0.0], &[0.0], &[0.2, 1.0, 2.0]).expect("runs");
        assert!(
            s[0].q[0] > 0.0 && s[0].qd[0] < 0.0,
            "{integrator:?}: still falling at 0.2 s"
        );
        assert_eq!(
            (s[1].q[0], s[1].qd[0]),
            (0.0, 0.0),
            "{integrator:?}: resting on the stop at 1 s"
        );
        assert_eq!(
            (s[2].q[0], s[2].qd[0]),
            (0.0, 0.0),
            "{integrator:?}: still resting at 2 s"
        );
        assert!(
            s[1].energy < s[0].energy - 1.0,
            "{integrator:?}: the stop dissipates the impact energy"
        );
        // 3 m g upward: net 2 g up, reaches the top (1 m) in ~0.32 s and rests there
        let up = [3.0 * 2.0 * 9.81];
        let (s, _) = simulate(&model, config, &[0.0], &[0.0], &up, &[0.1, 1.0]).expect("runs");
        assert!(
            s[0].q[0] > 0.0 && s[0].qd[0] > 0.0,
            "{integrator:?}: leaves the lower limit"
        );
        assert_eq!(
            (s[1].q[0], s[1].qd[0]),
            (1.0, 0.0),
            "{integrator:?}: on the upper stop"
        );
        config.joint_stops = false;
        let (s, _) = simulate(&model, config, &[0.5], &[0.0], &[0.0], &[1.0]).expect("runs");
        assert!(
            s[0].q[0] < -3.0,
            "{integrator:?}: without stops it falls through ({})",
            s[0].q[0]
        );
    }
    // the adaptive integrator honours the stop too
    let mut config = IntegratorConfig::adaptive(1e-8, 1e-10);
    config.joint_stops = true;
    let (s, _) = simulate(&model, config, &[0.5], &[0.0], &[0.0], &[1.0]).expect("runs");
    assert_eq!((s[0].q[0], s[0].qd[0]), (0.0, 0.0));
}

fn run_hash(integrator: Integrator, tau0: f64) -> u64 {
    let robot = common::fixture("puma560");
    let model = Model::new(&robot).expect("valid");
    let mut stepper =
        Stepper::new(&model, IntegratorConfig::fixed(integrator, 1e-3)).expect("config");
    let mut state = State::zeros(6);
    state.q = DVector::from_vec(vec![0.1, 0.7, -0.3, 0.2, 0.4, -0.1]);
    let tau = [tau0, 0.5, -0.2, 0.0, 0.01, 0.0];
    for _ in 0..500 {
        stepper.step(&model, &mut state, &tau, 1e-3).expect("step");
    }
    state_hash(&state)
}

#[test]
fn fixed_step_runs_are_bit_identical() {
    for integrator in Integrator::ALL {
        let a = run_hash(integrator, 1.0);
        let b = std::thread::spawn(move || run_hash(integrator, 1.0))
            .join()
            .expect("thread");
        assert_eq!(a, b, "{integrator:?}: same inputs, same hash");
        let c = run_hash(integrator, 1.0 + 1e-12);
        assert_ne!(
            a, c,
            "{integrator:?}: a 1e-12 N·m change of τ changes the hash (a one-ulp change may round away)"
        );
    }
}

/// Issue #20 item 5 (`simulate_dt_much_larger_than_t_end`): with dt = 10 s and t_end = 1 ms
/// the fixed-step loop used to take no step and label the initial state t = t_end
/// (`accepted_steps: 0`). The last step is cut to land on t_end, as for any other dt: the
/// answer equals a run whose dt is exactly t_end, bit for bit.
#[test]
fn simulate_dt_much_larger_than_t_end_takes_the_step_to_t_end() {
    let robot = common::fixture("puma560");
    let model = Model::new(&robot).expect("valid");
    let q0 = [0.1, 0.7, -0.3, 0.2, 0.4, -0.1];
    let zeros = [0.0; 6];
    for integrator in Integrator::ALL {
        let run = |dt: f64| {
            simulate(
                &model,
                IntegratorConfig::fixed(integrator, dt),
                &q0,
                &zeros,
                &zeros,
                &[1e-3],
            )
            .expect("runs")
        };
        let (big, stats) = run(10.0);
        assert_eq!(stats.accepted, 1, "{integrator:?}: one step, cut to t_end");
        assert_eq!(big[0].t, 1e-3);
        assert_ne!(
            big[0].qd,
            zeros.to_vec(),
            "{integrator:?}: the arm started to fall"
        );
        let (exact, _) = run(1e-3);
        assert_eq!(big[0].q, exact[0].q, "{integrator:?}");
        assert_eq!(big[0].qd, exact[0].qd, "{integrator:?}");
    }
}
