//! The effect pipeline: only declared stages are built, and each stage does what its effect says.

use nalgebra::{DVector, Isometry3, Vector3};
use robosim_collision::robot::Scene;
use robosim_collision::{Mode, Solid};
use robosim_dynamics::fixture_robot;
use robosim_kinematics::{Robot, fk};
use robosim_simulator::{
    CollisionEffect, Command, DynamicsEffect, EncoderEffect, Integrator, LoggingEffect, OnContact,
    Pipeline, SceneEffects, SceneGeometry, Signal, StepError,
};
use std::sync::Arc;

fn puma() -> Robot {
    fixture_robot("puma560").expect("fixture compiled in")
}

const Q0: [f64; 6] = [0.0, 0.4, -0.6, 0.0, 0.5, 0.0];

fn build(effects: &SceneEffects) -> Pipeline {
    Pipeline::build(&puma(), &Q0, effects, SceneGeometry::default()).expect("builds")
}

fn target(q: &[f64]) -> Command {
    Command::Target(DVector::from_column_slice(q))
}

#[test]
fn only_declared_stages_are_built() {
    let kin = SceneEffects {
        kinematics: true,
        ..SceneEffects::default()
    };
    let p = build(&kin);
    assert_eq!(p.stage_names(), ["motion", "link_frames"]);
    assert!(p.data().frames.is_some());
    assert!(
        p.data().q_measured.is_none() && p.data().contact.is_none(),
        "no memory for undeclared effects"
    );
    let off = SceneEffects {
        collision: Some(CollisionEffect {
            enabled: false,
            ..CollisionEffect::default()
        }),
        ..kin.clone()
    };
    assert_eq!(
        build(&off).stage_names(),
        ["motion", "link_frames"],
        "collision declared off is not in the pipeline"
    );
    assert!(build(&SceneEffects::default()).stage_names().is_empty());
    let all = SceneEffects {
        kinematics: true,
        joint_limits: true,
        collision: Some(CollisionEffect::default()),
        dynamics: Some(DynamicsEffect::default()),
        encoder: Some(EncoderEffect { bits: 12 }),
        logging: Some(LoggingEffect::default()),
        ..SceneEffects::default()
    };
    let p = build(&all);
    assert_eq!(
        p.stage_names(),
        [
            "dynamics",
            "joint_limits",
            "link_frames",
            "collision",
            "encoder",
            "logging"
        ]
    );
    let text = p.to_string();
    for s in [
        "1. dynamics",
        "semi_implicit_euler",
        "6. logging",
        "bbox, self on",
    ] {
        assert!(text.contains(s), "description lacks {s:?}:\n{text}");
    }
    let text = build(&kin).to_string();
    assert!(text.contains("not declared (not in the pipeline, no cost): dynamics, joint_limits, collision, encoder, logging"), "{text}");
}

#[test]
fn kinematic_motion_reaches_the_target_at_the_speed_limit_and_frames_follow() {
    let mut p = build(&SceneEffects {
        kinematics: true,
        max_speed: 2.0,
        ..SceneEffects::default()
    });
    let goal = [0.5, 0.4, -0.6, 0.0, 0.5, -1.0];
    p.set_command(target(&goal)).expect("command");
    for _ in 0..250 {
        p.step().expect("step");
    }
    // 0.25 s at 2 rad/s: joint 1 has covered 0.5 rad exactly, joint 6 only half of its 1 rad
    assert!((p.data().state.q[0] - 0.5).abs() < 1e-12);
    assert!(
        (p.data().state.q[5] + 0.5).abs() < 1e-9,
        "{}",
        p.data().state.q[5]
    );
    assert!((p.data().state.t - 0.25).abs() < 1e-15);
    let frames = p.data().frames.as_ref().expect("declared");
    let want = fk::link_frames(&p.model().robot, p.data().state.q.as_slice());
    for (a, b) in frames.iter().zip(&want) {
        assert!((a - b).abs().max() < 1e-14);
    }
}

#[test]
fn joint_limits_stop_a_joint_at_its_limit() {
    // A constant shoulder torque under dynamics drives joint 2 up to its limit: with the
    // joint-limits effect it stops there; without it, it goes past (the effect is the only
    // thing that models the mechanical stop).
    let robot = puma();
    let hi = robot.joints[1].qlim[1];
    let push = |joint_limits: bool| {
        let mut p = build(&SceneEffects {
            joint_limits,
            dynamics: Some(DynamicsEffect::default()),
            ..SceneEffects::default()
        });
        p.set_command(Command::Torque(DVector::from_column_slice(&[
            0.0, 400.0, 0.0, 0.0, 0.0, 0.0,
        ])))
        .expect("command");
        let mut worst = f64::NEG_INFINITY;
        for _ in 0..3000 {
            p.step().expect("step");
            worst = worst.max(p.data().state.q[1]);
            if worst > hi + 0.2 {
                break; // through the stop: no need to spin the arm up further
            }
        }
        worst
    };
    assert_eq!(push(true), hi, "held at the limit");
    assert!(
        push(false) > hi + 0.1,
        "without the effect the joint goes past"
    );
}

/// Issue #20 item 4 (`simctl_validates_like_a_transaction`): a target outside the joint
/// limits (here `1e308`) is refused by name, like a transaction with that joint value, and
/// the previous command stays.
#[test]
fn a_target_outside_the_joint_limits_is_refused_and_changes_nothing() {
    let mut p = build(&SceneEffects {
        kinematics: true,
        ..SceneEffects::default()
    });
    let before = p.data().command.clone();
    let e = p
        .set_command(target(&[0.0, 1e308, 0.0, 0.0, 0.0, 0.0]))
        .expect_err("refused");
    let m = e.to_string();
    assert!(
        m.contains("target[1] = 1e308 is outside joint 2's limits [-0.785"),
        "{m}"
    );
    assert_eq!(p.data().command, before);
}

#[test]
fn dynamics_controller_holds_and_moves_the_arm_and_torque_needs_dynamics() {
    let effects = SceneEffects {
        dynamics: Some(DynamicsEffect {
            integrator: Integrator::Rk4,
            kp: 400.0,
            kd: 40.0,
            ..DynamicsEffect::default()
        }),
        ..SceneEffects::default()
    };
    let mut p = build(&effects);
    let goal = [0.3, 0.6, -0.8, 0.2, 0.4, 0.1];
    p.set_command(target(&goal)).expect("command");
    for _ in 0..4000 {
        p.step().expect("step");
    }
    let err = p
        .data()
        .state
        .q
        .iter()
        .zip(goal)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        err < 1e-3,
        "computed torque settles on the target (error {err})"
    );
    assert!((p.data().state.t - 4.0).abs() < 1e-12);
    // idle under dynamics: the arm falls
    p.set_command(Command::Idle).expect("command");
    for _ in 0..200 {
        p.step().expect("step");
    }
    assert!(p.data().state.qd.norm() > 0.1);
    let mut k = build(&SceneEffects {
        kinematics: true,
        ..SceneEffects::default()
    });
    assert!(
        k.set_command(Command::Torque(DVector::zeros(6))).is_err(),
        "torques need the dynamics effect"
    );
    assert!(k.set_command(target(&[0.0; 5])).is_err(), "wrong length");
}

fn wall_scene() -> Scene {
    let mut scene = Scene::new();
    // a wall across x = 0.35 … 0.45, within reach of the upper arm (a = 0.43 m) at q1 = 0
    let wall = Solid::cuboid(Vector3::new(0.1, 3.0, 3.0)).expect("box");
    scene.add(
        "wall",
        Arc::new(wall),
        Isometry3::translation(0.4, 0.0, 0.5),
    );
    scene
}

#[test]
fn collision_stops_the_arm_before_an_obstacle_or_reports() {
    for mode in [Mode::BBox, Mode::Polygon, Mode::Exact] {
        for continuous in [false, true] {
            if continuous && mode != Mode::Exact {
                continue;
            }
            let effects = SceneEffects {
                kinematics: true,
                collision: Some(CollisionEffect {
                    mode,
                    continuous,
                    self_collision: false,
                    ..CollisionEffect::default()
                }),
                ..SceneEffects::default()
            };
            let q0 = [std::f64::consts::PI, 0.0, 0.0, 0.0, 0.0, 0.0]; // arm points away from the wall
            let mut p = Pipeline::build(
                &puma(),
                &q0,
                &effects,
                SceneGeometry {
                    obstacles: wall_scene(),
                    link_solids: None,
                },
            )
            .expect("builds");
            p.step().expect("step");
            assert_eq!(
                p.data().contact,
                Some(false),
                "{mode:?}: clear at the start"
            );
            p.set_command(target(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
                .expect("command"); // swing into the wall
            for _ in 0..4000 {
                p.step().expect("step");
            }
            assert!(
                p.data().state.q[0] > 0.1,
                "{mode:?}/{continuous}: stopped before reaching the wall (q1 = {})",
                p.data().state.q[0]
            );
            assert!(p.data().contact_steps > 0, "{mode:?}: contact seen");
            let effects = SceneEffects {
                kinematics: true,
                collision: Some(CollisionEffect {
                    mode,
                    continuous,
                    self_collision: false,
                    on_contact: OnContact::Report,
                    ..CollisionEffect::default()
                }),
                ..SceneEffects::default()
            };
            let mut p = Pipeline::build(
                &puma(),
                &q0,
                &effects,
                SceneGeometry {
                    obstacles: wall_scene(),
                    link_solids: None,
                },
            )
            .expect("builds");
            p.set_command(target(&[0.0; 6])).expect("command");
            for _ in 0..4000 {
                p.step().expect("step");
            }
            assert_eq!(
                p.data().state.q[0],
                0.0,
                "{mode:?}: report mode does not stop the motion"
            );
            assert_eq!(p.data().contact, Some(true));
        }
    }
}

#[test]
fn encoder_quantises_and_logging_records() {
    let dir = tempfile::tempdir().expect("temp dir");
    let csv = dir.path().join("run.csv");
    for path in [None, Some(csv.clone())] {
        let effects = SceneEffects {
            kinematics: true,
            encoder: Some(EncoderEffect { bits: 10 }),
            logging: Some(LoggingEffect {
                signals: vec![Signal::T, Signal::Q, Signal::QMeasured],
                every: 10,
                path: path.clone(),
                unsupported: Vec::new(),
            }),
            ..SceneEffects::default()
        };
        let mut p = build(&effects);
        p.set_command(target(&[0.3, 0.1, -0.2, 0.7, 0.0, 0.0]))
            .expect("command");
        for _ in 0..100 {
            p.step().expect("step");
        }
        let r = std::f64::consts::TAU / 1024.0;
        let m = p.data().q_measured.as_ref().expect("declared");
        for j in 0..6 {
            assert!((m[j] - p.data().state.q[j]).abs() <= r / 2.0 + 1e-15);
            assert!(((m[j] / r).round() * r - m[j]).abs() < 1e-15);
        }
        assert_eq!(p.log_header().expect("declared").len(), 1 + 6 + 6);
        if path.is_none() {
            let rows = p.log();
            assert_eq!(rows.len(), 10);
            assert!((rows[9][0] - 0.1).abs() < 1e-15, "t of the last row");
            assert_eq!(rows[9][1..7], *p.data().state.q.as_slice());
        }
        drop(p);
    }
    let text = std::fs::read_to_string(&csv).expect("csv written");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 11);
    assert!(
        lines[0].starts_with("t_s,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,q_measured1_rad,"),
        "{}",
        lines[0]
    );
}

/// Issue #19 item 5: the time is always the first column, and every column carries its unit
/// — metres for the Stanford arm's prismatic joint 3, radians for the others.
#[test]
fn log_header_has_time_first_and_units_per_joint_type() {
    let robot = robosim_kinematics::builtin_robot("stanford").expect("builtin");
    let q0 = [0.0, 0.0, 0.5, 0.0, 0.0, 0.0];
    let effects = SceneEffects {
        dynamics: Some(DynamicsEffect::default()),
        logging: Some(LoggingEffect {
            signals: vec![Signal::Q, Signal::Qd, Signal::Qdd, Signal::Tau],
            every: 2,
            path: None,
            unsupported: Vec::new(),
        }),
        ..SceneEffects::default()
    };
    let mut p = Pipeline::build(&robot, &q0, &effects, SceneGeometry::default()).expect("builds");
    let h = p.log_header().expect("declared");
    assert_eq!(h[0], "t_s", "time first although not declared");
    assert_eq!(
        h[1..7],
        ["q1_rad", "q2_rad", "q3_m", "q4_rad", "q5_rad", "q6_rad"]
    );
    assert_eq!(h[9], "qd3_m_s");
    assert_eq!(h[15], "qdd3_m_s2");
    assert_eq!(h[19..22], ["tau1_Nm", "tau2_Nm", "tau3_N"]);
    assert_eq!(h.len(), 1 + 4 * 6);
    for _ in 0..4 {
        p.step().expect("step");
    }
    let rows = p.log();
    assert_eq!(rows.len(), 2);
    let dt = p.model().dt;
    assert!((rows[1][0] - 4.0 * dt).abs() < 1e-15, "t_s of the last row");
    assert_eq!(rows[1][1..7], *p.data().state.q.as_slice());
}

#[test]
fn effects_parse_from_json_with_errors_that_say_where() {
    let text = r#"{"kinematics": true, "joint_limits": true,
        "collision": {"mode": "polygon", "self": false, "continuous": false},
        "dynamics": {"integrator": "rk4", "dt": 0.002, "gravity": [0, 0, -1.62]},
        "encoder": {"bits": 14}, "logging": {"signals": ["t", "q", "tau"], "every": 5}}"#;
    let e = SceneEffects::from_json(text).expect("parses");
    assert_eq!(
        e.collision.as_ref().map(|c| (c.mode, c.self_collision)),
        Some((Mode::Polygon, false))
    );
    let p = build(&e);
    assert_eq!(p.model().dt, 0.002);
    assert!(p.to_string().contains("gravity [0, 0, -1.62]"));
    let err =
        SceneEffects::from_json("{\"kinematics\": true,\n \"colision\": {}}").expect_err("typo");
    assert!(
        err.to_string().contains("line 2") && err.to_string().contains("colision"),
        "{err}"
    );
    // the integrator is typed where the declaration is read: an unknown name never reaches
    // the pipeline
    let err = SceneEffects::from_json("{\"dynamics\": {\"integrator\": \"leapfrog\"}}")
        .expect_err("refused");
    assert!(
        err.to_string().contains("unknown integrator \"leapfrog\""),
        "{err}"
    );
    let bad = SceneEffects {
        logging: Some(LoggingEffect {
            signals: vec![Signal::QMeasured],
            every: 1,
            path: None,
            unsupported: Vec::new(),
        }),
        ..SceneEffects::default()
    };
    assert_eq!(
        Pipeline::build(&puma(), &Q0, &bad, SceneGeometry::default())
            .err()
            .expect("refused")
            .field(),
        "logging.signals"
    );
}

#[test]
fn pipeline_runs_are_bit_identical() {
    let effects = SceneEffects {
        joint_limits: true,
        dynamics: Some(DynamicsEffect {
            integrator: Integrator::Rk4,
            ..DynamicsEffect::default()
        }),
        ..SceneEffects::default()
    };
    let run = || {
        let mut p = build(&effects);
        p.set_command(target(&[0.3, 0.6, -0.8, 0.2, 0.4, 0.1]))
            .expect("command");
        for _ in 0..500 {
            p.step().expect("step");
        }
        robosim_dynamics::state_hash(&p.data().state)
    };
    assert_eq!(run(), run());
}

#[test]
fn every_integrator_runs_in_the_pipeline_and_agrees_with_simulate() {
    // free fall (idle command) for 0.2 s: the pipeline's dynamics stage must reproduce
    // robosim_dynamics::simulate with the same integrator and step
    use robosim_dynamics::{IntegratorConfig, Model, simulate};
    let model = Model::new(&puma()).expect("valid");
    // worst |Δq| for the fixed-step and the adaptive runs, and worst |t − 0.2|
    let (mut fixed_worst, mut adaptive_worst, mut t_worst) = (0.0_f64, 0.0_f64, 0.0_f64);
    for (integrator, rtol) in [
        ("euler", None),
        ("semi_implicit_euler", None),
        ("rk4", None),
        ("dopri5", None),
        ("dopri5", Some(1e-9)),
    ] {
        let d = DynamicsEffect {
            integrator: Integrator::from_name(integrator).expect("name"),
            dt: 1e-3,
            rtol,
            atol: rtol,
            ..DynamicsEffect::default()
        };
        let mut p = build(&SceneEffects {
            dynamics: Some(d),
            ..SceneEffects::default()
        });
        for _ in 0..200 {
            p.step().expect("step");
        }
        let config = match rtol {
            None => IntegratorConfig::fixed(
                robosim_dynamics::Integrator::from_name(integrator).expect("name"),
                1e-3,
            ),
            Some(t) => IntegratorConfig::adaptive(t, t),
        };
        let (s, _) =
            simulate(&model, config, &Q0, &[0.0; 6], &[0.0; 6], &[0.2]).expect("simulates");
        let diff = p
            .data()
            .state
            .q
            .iter()
            .zip(&s[0].q)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        // fixed steps: the same arithmetic; adaptive: the pipeline clips its steps at
        // every 1 ms boundary, so it agrees to the tolerance only
        let tol = if rtol.is_some() { 1e-7 } else { 1e-12 };
        assert!(
            diff <= tol,
            "{integrator} (rtol {rtol:?}): pipeline and simulate differ by {diff}"
        );
        assert!((p.data().state.t - 0.2).abs() < 1e-12);
        if rtol.is_some() {
            adaptive_worst = adaptive_worst.max(diff);
        } else {
            fixed_worst = fixed_worst.max(diff);
        }
        t_worst = t_worst.max((p.data().state.t - 0.2).abs());
    }
    let test = "every_integrator_runs_in_the_pipeline_and_agrees_with_simulate";
    eprintln!(
        "measured: {test}: max |Δq| fixed steps = {fixed_worst:.3e} rad (bound {:e})",
        1e-12
    );
    eprintln!(
        "measured: {test}: max |Δq| adaptive = {adaptive_worst:.3e} rad (bound {:e})",
        1e-7
    );
    eprintln!(
        "measured: {test}: max |t − 0.2| = {t_worst:.3e} s (bound {:e})",
        1e-12
    );
}

/// Data is all the state: saved mid-run (a clone), run on, put back — the steps after it come
/// out bit for bit the same, for every stage that remembers something between steps (the
/// adaptive integrator's step proposal and counters, the collision stage's last safe q).
#[test]
fn a_saved_data_rewinds_the_run_bit_for_bit() {
    let effects = SceneEffects {
        kinematics: true,
        joint_limits: true,
        dynamics: Some(DynamicsEffect {
            integrator: Integrator::Dopri5,
            rtol: Some(1e-8),
            atol: Some(1e-8),
            ..DynamicsEffect::default()
        }),
        collision: Some(CollisionEffect {
            mode: Mode::BBox,
            self_collision: false,
            on_contact: OnContact::Stop,
            ..CollisionEffect::default()
        }),
        encoder: Some(EncoderEffect { bits: 12 }),
        ..SceneEffects::default()
    };
    let geometry = SceneGeometry {
        obstacles: wall_scene(),
        link_solids: None,
    };
    // the arm points away from the wall and swings into it (as in the collision test)
    let q0 = [std::f64::consts::PI, 0.0, 0.0, 0.0, 0.0, 0.0];
    let mut p = Pipeline::build(&puma(), &q0, &effects, geometry).expect("builds");
    p.set_command(target(&[0.0; 6])).expect("target");
    for _ in 0..150 {
        p.step().expect("step");
    }
    let saved = p.data().clone();
    assert!(saved.integrator.is_some() && saved.q_safe.is_some());
    let mut first = Vec::new();
    for _ in 0..600 {
        p.step().expect("step");
        first.push(p.data().clone());
    }
    let last = &first[first.len() - 1];
    assert_ne!(*last, saved, "the run moved on");
    assert!(
        last.contact_steps > saved.contact_steps,
        "the arm reached the wall after the save ({} contact steps before, {} after)",
        saved.contact_steps,
        last.contact_steps
    );
    assert!(
        last.integrator.as_ref().map(|i| i.stepper.stats)
            != saved.integrator.as_ref().map(|i| i.stepper.stats),
        "the integrator's counters are part of the state"
    );
    p.rewind(saved.clone()).expect("fits");
    assert_eq!(*p.data(), saved);
    for (k, want) in first.iter().enumerate() {
        p.step().expect("step");
        let got = p.data();
        assert_eq!(got, want, "step {k} after the rewind");
        let bits = |v: &DVector<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got.state.q), bits(&want.state.q), "step {k}: q bits");
        assert_eq!(
            bits(&got.state.qd),
            bits(&want.state.qd),
            "step {k}: qd bits"
        );
    }
    // a Data from another pipeline (other stages) does not fit
    let other = build(&SceneEffects {
        kinematics: true,
        ..SceneEffects::default()
    });
    assert!(p.rewind(other.data().clone()).is_err());
}

/// Issue 36: the robot's friction data act in the dynamics stage only where the scene declares
/// the joint friction effect. A PUMA in zero gravity with 5 N·m Coulomb friction on every
/// joint, at rest, 3 N·m on the shoulder: declared (stick–slip), the arm stays still; not
/// declared, the rigid-body step moves it.
#[test]
fn issue_36_joint_friction_acts_only_where_declared() {
    let mut robot = puma();
    robot.gravity = Vector3::zeros();
    for j in &mut robot.joints {
        j.coulomb = 5.0;
    }
    let run = |friction: Option<robosim_model::JointFrictionEffect>| {
        let effects = SceneEffects {
            dynamics: Some(DynamicsEffect {
                integrator: Integrator::Rk4,
                ..DynamicsEffect::default()
            }),
            joint_friction: friction,
            ..SceneEffects::default()
        };
        let mut p =
            Pipeline::build(&robot, &Q0, &effects, SceneGeometry::default()).expect("builds");
        let tau = DVector::from_column_slice(&[0.0, 3.0, 0.0, 0.0, 0.0, 0.0]);
        p.set_command(Command::Torque(tau)).expect("command");
        for _ in 0..500 {
            p.step().expect("step");
        }
        (p.data().state.q[1] - Q0[1]).abs()
    };
    let held = run(Some(robosim_model::JointFrictionEffect::default()));
    assert!(held < 1e-12, "held joint moved {held} rad");
    let moved = run(None);
    assert!(moved > 1e-3, "without the effect it moves: {moved}");
}

/// The link-frames and collision stages read the robot compiled once with the pipeline
/// (issue 37 item 1): at every step of a move the frames equal `fk::link_frames` on the robot
/// and the contact flag equals `check_robot`'s answer on the `&Robot` path, with `==`, on the
/// PUMA and the Panda; the compiled model is there exactly when a stage needs link frames.
#[test]
fn compiled_frames_and_collision_stages_equal_the_robot_path_at_every_step() {
    use robosim_collision::robot::{CollisionSettings, LinkSolids, check_robot};
    for name in ["puma560", "panda"] {
        let robot = fixture_robot(name).expect("fixture compiled in");
        let mid = |f: f64| -> Vec<f64> {
            robot
                .joints
                .iter()
                .map(|j| j.qlim[0].max(-3.0) + f * (j.qlim[1].min(3.0) - j.qlim[0].max(-3.0)))
                .collect()
        };
        // Blocks around the arm at reach, so the moves pass in and out of contact.
        let mut scene = Scene::new();
        for (k, (x, y, z)) in [(0.5, 0.0, 0.6), (0.0, 0.5, 0.3), (-0.4, -0.4, 0.9)]
            .into_iter()
            .enumerate()
        {
            scene.add(
                format!("block{k}"),
                Arc::new(Solid::cuboid(Vector3::new(0.35, 0.35, 0.35)).expect("box")),
                Isometry3::translation(x, y, z),
            );
        }
        let effect = CollisionEffect {
            on_contact: OnContact::Report,
            ..CollisionEffect::default()
        };
        let effects = SceneEffects {
            kinematics: true,
            max_speed: 2.0,
            collision: Some(effect.clone()),
            ..SceneEffects::default()
        };
        let geometry = SceneGeometry {
            obstacles: scene.clone(),
            link_solids: None,
        };
        let mut p = Pipeline::build(&robot, &mid(0.5), &effects, geometry).expect("builds");
        assert!(p.model().kinematics().is_some());
        let links = LinkSolids::from_dh(&robot, effect.link_radius).expect("links");
        let settings = CollisionSettings {
            self_collision: effect.self_collision,
            mode: effect.mode,
            depth: None,
            ..CollisionSettings::default()
        };
        let (mut contact, mut clear) = (0, 0);
        for goal in [mid(0.1), mid(0.9), mid(0.4)] {
            p.set_command(target(&goal)).expect("command");
            for _ in 0..400 {
                p.step().expect("step");
                let q = p.data().state.q.as_slice();
                let frames = p.data().frames.as_ref().expect("declared");
                assert_eq!(frames, &fk::link_frames(&robot, q), "{name} at {q:?}");
                let old = check_robot(&robot, &links, q, &scene, &settings).expect("check");
                assert_eq!(p.data().contact, Some(!old.is_clear()), "{name} at {q:?}");
                if old.is_clear() {
                    clear += 1;
                } else {
                    contact += 1;
                }
            }
        }
        assert!(
            contact > 0 && clear > 0,
            "{name}: {contact} contact, {clear} clear steps"
        );
    }
    let none = build(&SceneEffects {
        joint_limits: true,
        ..SceneEffects::default()
    });
    assert!(
        none.model().kinematics().is_none(),
        "no stage needs link frames"
    );
}

/// The PUMA on a floating root of `kind`: its base link is a 5 kg box, the arm hangs from it.
fn floating_puma(kind: robosim_kinematics::RootKind) -> Robot {
    let mut r = puma();
    r.root = Some(robosim_kinematics::RootJoint {
        kind,
        mass: 5.0,
        com: Vector3::new(0.01, -0.02, 0.05),
        inertia: nalgebra::Matrix3::from_diagonal(&Vector3::new(0.05, 0.06, 0.04)),
    });
    r
}

/// Issue 36 item 2 in the simulator: a floating robot's pipeline holds its whole state (nq, nv)
/// and its dynamics stage integrates it as `robosim_dynamics::simulate` does (same integrator,
/// same step: the same numbers), the quaternion kept unit; a torque command is the joints'
/// (the root is not actuated); the encoder and the log see the joints only. A joint target,
/// kinematic motion without dynamics and collision are refused by name.
#[test]
fn a_floating_robot_integrates_as_simulate_does_and_its_joint_stages_see_the_joints() {
    use robosim_dynamics::{IntegratorConfig, Model, simulate};
    use robosim_kinematics::RootKind;
    for kind in [RootKind::FreeFlyer, RootKind::Planar] {
        let robot = floating_puma(kind);
        let (nq, nv, n) = (robot.nq(), robot.nv(), robot.dof());
        let mut q0 = robot.neutral_q().as_slice().to_vec();
        q0[kind.nq()..].copy_from_slice(&Q0);
        let effects = SceneEffects {
            dynamics: Some(DynamicsEffect {
                integrator: Integrator::from_name("rk4").expect("rk4"),
                dt: 1e-3,
                ..DynamicsEffect::default()
            }),
            encoder: Some(EncoderEffect { bits: 16 }),
            logging: Some(LoggingEffect {
                signals: vec![Signal::Q, Signal::Tau, Signal::QMeasured],
                every: 1,
                ..LoggingEffect::default()
            }),
            joint_limits: false,
            ..SceneEffects::default()
        };
        let mut p =
            Pipeline::build(&robot, &q0, &effects, SceneGeometry::default()).expect("builds");
        assert!(
            p.to_string()
                .contains(&format!("on a {} base", kind.name()))
        );
        let t_joints = [2.0, -1.0, 0.5, 0.1, -0.2, 0.05];
        p.set_command(Command::Torque(DVector::from_column_slice(&t_joints)))
            .expect("one torque per joint");
        let wrong = p.set_command(Command::Torque(DVector::zeros(nv)));
        assert!(
            wrong.is_err(),
            "a torque with the root's entries is refused"
        );
        let e = p
            .set_command(target(&Q0))
            .expect_err("a joint target on a floating base");
        assert!(
            e.to_string().contains(&format!("{} base", kind.name())),
            "{e}"
        );
        let steps = 300;
        for _ in 0..steps {
            p.step().expect("step");
        }
        let mut tau = vec![0.0; nv];
        tau[kind.nv()..].copy_from_slice(&t_joints);
        let config = IntegratorConfig::fixed(robosim_dynamics::Integrator::Rk4, 1e-3);
        let model = Model::new(&robot).expect("valid");
        let (s, _) = simulate(&model, config, &q0, &vec![0.0; nv], &tau, &[0.3]).expect("runs");
        let d = p.data();
        assert_eq!(
            (d.state.q.len(), d.state.qd.len(), d.tau.len()),
            (nq, nv, nv)
        );
        let dq = d
            .state
            .q
            .iter()
            .zip(&s[0].q)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        let dv = d
            .state
            .qd
            .iter()
            .zip(&s[0].qd)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        eprintln!(
            "measured: floating {} pipeline vs simulate, 300 rk4 steps: |Δq| {dq:.3e}, |Δv| {dv:.3e}",
            kind.name()
        );
        assert!(dq <= 1e-12 && dv <= 1e-10, "Δq {dq:e}, Δv {dv:e}");
        // it moved: the root fell (free-flyer: z; planar: the torques turn it) and the joints turned
        let root_moved = d.state.q.iter().zip(&q0).take(kind.nq());
        assert!(root_moved.fold(0.0_f64, |m, (a, b)| m.max((a - b).abs())) > 1e-3);
        assert!((d.state.q[kind.nq()] - Q0[0]).abs() > 1e-3);
        assert!(kind.unit_error(d.state.q.as_slice(), 1e-12).is_none());
        // root_transform is the root's motion; joint_state the joints' part
        let m = p.root_transform().expect("floating");
        assert_eq!(m, kind.transform(&d.state.q.as_slice()[..kind.nq()]));
        let (qj, qdj, tauj) = p.joint_state();
        assert_eq!(qj, &d.state.q.as_slice()[kind.nq()..]);
        assert_eq!((qj.len(), qdj.len()), (n, n));
        assert_eq!(tauj, &t_joints);
        assert!(d.tau.iter().take(kind.nv()).all(|x| *x == 0.0));
        // the encoder reads the joints, the log has one column per joint and signal
        let measured = d.q_measured.as_ref().expect("encoder");
        assert_eq!(measured.len(), n);
        for (m, q) in measured.iter().zip(qj) {
            assert!((m - q).abs() <= std::f64::consts::TAU / 65536.0);
        }
        let log = p.log();
        assert_eq!(log.len(), steps);
        assert_eq!(log[steps - 1].len(), 1 + 3 * n);
        assert_eq!(&log[steps - 1][1..=n], qj);
        // teleport: the whole configuration (root first), at rest
        let mut q1 = q0.clone();
        q1[kind.nq()] = 0.3;
        p.teleport(&q1).expect("nq values");
        assert_eq!(p.data().state.q.as_slice(), &q1[..]);
        assert!(
            p.teleport(&Q0).is_err(),
            "joints alone are not the configuration"
        );

        // refused by name: kinematic motion without dynamics, collision
        let kin = SceneEffects {
            kinematics: true,
            ..SceneEffects::default()
        };
        let e = Pipeline::build(&robot, &q0, &kin, SceneGeometry::default())
            .err()
            .expect("kinematic motion of a floating base is refused");
        assert_eq!(e.field(), "dynamics");
        assert!(
            e.to_string().contains(&format!("{} base", kind.name())),
            "{e}"
        );
        let col = SceneEffects {
            collision: Some(CollisionEffect::default()),
            ..effects.clone()
        };
        let e = Pipeline::build(&robot, &q0, &col, SceneGeometry::default())
            .err()
            .expect("collision of a floating base is refused");
        assert_eq!(e.field(), "collision");
        assert!(e.to_string().contains("floating root"), "{e}");
    }
}

#[test]
fn a_refused_robot_or_dynamics_keeps_the_library_error_as_its_source() {
    use robosim_kinematics::ModelError;
    use robosim_simulator::BuildError;
    use std::error::Error;
    // a start q of the wrong length: the kinematic model's own refusal, kept whole
    let e = Pipeline::build(
        &puma(),
        &Q0[..5],
        &SceneEffects::default(),
        SceneGeometry::default(),
    )
    .err()
    .expect("refused");
    assert!(
        matches!(
            e,
            BuildError::Robot {
                field: "q0",
                source: ModelError::WrongDof {
                    expected: 6,
                    got: 5
                }
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().starts_with("scene effects, `q0`: "), "{e}");
    let source = e.source().expect("the cause is kept");
    assert!(source.downcast_ref::<ModelError>().is_some(), "{source:?}");
    // a stick-slip band that is not a number: the dynamics crate's refusal, kept
    let friction = SceneEffects {
        dynamics: Some(DynamicsEffect::default()),
        joint_friction: Some(robosim_model::JointFrictionEffect {
            velocity: f64::NAN,
            ..Default::default()
        }),
        ..SceneEffects::default()
    };
    let e = Pipeline::build(&puma(), &Q0, &friction, SceneGeometry::default())
        .err()
        .expect("refused");
    assert!(
        matches!(
            e,
            BuildError::Dynamics {
                field: "joint_friction",
                source: robosim_dynamics::DynamicsError::BadOption { .. }
            }
        ),
        "{e:?}"
    );
    assert_eq!(e.field(), "joint_friction");
    assert!(e.to_string().contains("sticking band"), "{e}");
}

/// Issue 35 item 4: a CSV log that cannot be written is refused with the I/O error kept as the
/// source (not flattened into text) and the file named, under the same message as before.
#[test]
fn a_log_write_error_keeps_the_io_error_and_names_the_file() {
    use std::error::Error as _;
    let robot = robosim_kinematics::builtin_robot("stanford").expect("builtin");
    let q0 = [0.0, 0.0, 0.5, 0.0, 0.0, 0.0];
    // /dev/full opens and takes the header into the buffer; writing it out fails (ENOSPC)
    let full = std::path::Path::new("/dev/full");
    let effects = SceneEffects {
        logging: Some(LoggingEffect {
            signals: vec![Signal::Q],
            every: 1,
            path: Some(full.to_owned()),
            unsupported: Vec::new(),
        }),
        ..SceneEffects::default()
    };
    let mut p = Pipeline::build(&robot, &q0, &effects, SceneGeometry::default()).expect("builds");
    p.step().expect("a row into the buffer");
    let e = p.flush_log().expect_err("/dev/full refuses the write");
    let StepError::Logging { path, source } = &e else {
        panic!("not StepError::Logging: {e:?}");
    };
    assert_eq!(path, full);
    assert_eq!(source.raw_os_error(), Some(28), "ENOSPC: {source}");
    assert_eq!(e.to_string(), format!("logging: /dev/full: {source}"));
    let cause = e.source().expect("the I/O error as the source");
    assert!(
        cause.downcast_ref::<std::io::Error>().is_some(),
        "{cause:?}"
    );
}
