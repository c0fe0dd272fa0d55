//! `robosim report effects` — "only the effects a scene calls for": time per step of one scene
//! (a PUMA 560 moving between two joint targets among four box obstacles) with kinematics only,
//! then adding joint limits, collision in each mode, dynamics, and the joint friction effect;
//! and the checks that an undeclared effect costs nothing (kinematics only against kinematics
//! with collision declared off; dynamics on the PUMA without friction data against the same
//! with the built-in PUMA's friction data, the joint friction effect undeclared). Entry point:
//! [`report_effects`].

use crate::plot::RunError;
use crate::plot::{Plot, Report, Series, Table, percentile, write_report_with_x_names};
use nalgebra::{DVector, Isometry3, Vector3};
use robosim_collision::robot::Scene;
use robosim_collision::{Mode, Solid};
use robosim_kinematics::Robot;
use robosim_simulator::{
    CollisionEffect, DynamicsEffect, EncoderEffect, Integrator, LoggingEffect, SceneEffects, Signal,
};
use robosim_simulator::{Command, Pipeline, SceneGeometry};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

const Q_A: [f64; 6] = [0.0, 0.4, -0.6, 0.0, 0.5, 0.0];
const Q_B: [f64; 6] = [1.2, 0.9, -1.4, 0.8, -0.4, 1.0];

fn obstacles() -> Result<Scene, RunError> {
    let mut scene = Scene::new();
    let boxes = [
        ("floor", [3.0, 3.0, 0.1], [0.0, 0.0, -0.25]),
        ("wall", [0.1, 3.0, 2.0], [1.6, 0.0, 0.5]),
        ("shelf", [0.4, 0.4, 0.05], [-0.9, 0.9, 0.9]),
        ("post", [0.1, 0.1, 1.0], [0.0, -1.2, 0.3]),
    ];
    for (name, size, at) in boxes {
        let solid = Solid::cuboid(Vector3::from(size)).map_err(|source| RunError::Solid {
            what: "an obstacle box",
            source,
        })?;
        scene.add(
            name,
            Arc::new(solid),
            Isometry3::translation(at[0], at[1], at[2]),
        );
    }
    Ok(scene)
}

fn collision(mode: Mode, continuous: bool) -> Option<CollisionEffect> {
    Some(CollisionEffect {
        mode,
        continuous,
        self_collision: true,
        ..CollisionEffect::default()
    })
}

fn dynamics(integrator: Integrator) -> Option<DynamicsEffect> {
    Some(DynamicsEffect {
        integrator,
        dt: 1e-3,
        ..DynamicsEffect::default()
    })
}

/// Which PUMA a configuration runs: the fixture (no friction data), or the fixture with the
/// built-in PUMA's per-joint viscous and Coulomb friction (which act only where the joint
/// friction effect is declared).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Friction {
    NoData,
    Data,
}

/// Row names the undeclared-effect checks pair up.
const KIN_ONLY: &str = "kinematics only";
const COLLISION_OFF: &str = "kinematics, collision declared off";
const RK4: &str = "+ dynamics rk4 1 ms (no collision)";
const RK4_FRICTION_UNDECLARED: &str =
    "+ dynamics rk4 1 ms, robot with friction data, joint friction undeclared";

/// The configurations, kinematics-only first (the baseline).
fn configurations() -> Vec<(&'static str, SceneEffects, Friction)> {
    configurations_without_friction()
        .into_iter()
        .map(|(name, e)| (name, e, Friction::NoData))
        .chain([
            (
                RK4_FRICTION_UNDECLARED,
                SceneEffects {
                    joint_limits: true,
                    kinematics: true,
                    dynamics: dynamics(Integrator::Rk4),
                    ..SceneEffects::default()
                },
                Friction::Data,
            ),
            (
                "+ dynamics rk4 1 ms + joint friction (viscous, Coulomb stick-slip)",
                SceneEffects {
                    joint_limits: true,
                    kinematics: true,
                    dynamics: dynamics(Integrator::Rk4),
                    joint_friction: Some(Default::default()),
                    ..SceneEffects::default()
                },
                Friction::Data,
            ),
        ])
        .collect()
}

fn configurations_without_friction() -> Vec<(&'static str, SceneEffects)> {
    let kin = SceneEffects {
        kinematics: true,
        ..SceneEffects::default()
    };
    let lim = SceneEffects {
        joint_limits: true,
        ..kin.clone()
    };
    vec![
        (KIN_ONLY, kin.clone()),
        (
            COLLISION_OFF,
            SceneEffects {
                collision: Some(CollisionEffect {
                    enabled: false,
                    ..CollisionEffect::default()
                }),
                ..kin.clone()
            },
        ),
        ("+ joint limits", lim.clone()),
        (
            "+ collision bbox (self on)",
            SceneEffects {
                collision: collision(Mode::BBox, false),
                ..lim.clone()
            },
        ),
        (
            "+ collision polygon (self on)",
            SceneEffects {
                collision: collision(Mode::Polygon, false),
                ..lim.clone()
            },
        ),
        (
            "+ collision exact (self on)",
            SceneEffects {
                collision: collision(Mode::Exact, false),
                ..lim.clone()
            },
        ),
        (
            "+ collision exact, continuous",
            SceneEffects {
                collision: collision(Mode::Exact, true),
                ..lim.clone()
            },
        ),
        (
            RK4,
            SceneEffects {
                dynamics: dynamics(Integrator::Rk4),
                ..lim.clone()
            },
        ),
        (
            "+ dynamics semi_implicit_euler 1 ms",
            SceneEffects {
                dynamics: dynamics(Integrator::SemiImplicitEuler),
                ..lim.clone()
            },
        ),
        (
            "all: rk4 + limits + bbox + encoder + logging",
            SceneEffects {
                dynamics: dynamics(Integrator::Rk4),
                collision: collision(Mode::BBox, false),
                encoder: Some(EncoderEffect { bits: 16 }),
                logging: Some(LoggingEffect {
                    signals: vec![Signal::T, Signal::Q, Signal::QMeasured, Signal::Contact],
                    every: 10,
                    path: None,
                    unsupported: Vec::new(),
                }),
                ..lim
            },
        ),
    ]
}

/// Steps `pipe` `steps` times, switching targets every 500 steps; returns seconds per step.
/// (The motion repeats every 1000 steps, so measurements of whole thousands are alike.)
fn run(pipe: &mut Pipeline, steps: usize) -> Result<f64, RunError> {
    let start = Instant::now();
    for k in 0..steps {
        if k % 500 == 0 {
            let target = if (k / 500) % 2 == 0 { Q_B } else { Q_A };
            pipe.set_command(Command::Target(DVector::from_column_slice(&target)))?;
        }
        pipe.step()?;
    }
    Ok(start.elapsed().as_secs_f64() / steps as f64)
}

/// Runs the study and writes `effects.csv`, `effects.md`, `effects.png` into `out_dir`.
/// `quick` runs fewer steps and rounds (a few seconds, for CI).
pub fn report_effects(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, RunError> {
    let (report, names) = effects_report(quick)?;
    Ok(write_report_with_x_names(out_dir, &report, &[names])?)
}

/// The study's report and its plot's x names (the configurations, the table's first column).
fn effects_report(quick: bool) -> Result<(Report, Vec<String>), RunError> {
    let (robot, with_friction) = puma_without_and_with_friction()?;
    let configs = configurations();
    let rounds = if quick { 5 } else { 101 };
    let Pipelines {
        mut pipes,
        description,
        friction_description,
    } = build_pipelines(&configs, &robot, &with_friction)?;
    warm_up(&mut pipes)?;
    let index = |name: &str| {
        configs
            .iter()
            .position(|(n, _, _)| *n == name)
            .ok_or_else(|| format!("no configuration {name:?}"))
    };
    // The undeclared-effect checks: (baseline, the same with an effect undeclared or off).
    let pairs = [
        (index(KIN_ONLY)?, index(COLLISION_OFF)?),
        (index(RK4)?, index(RK4_FRICTION_UNDECLARED)?),
    ];
    let Samples {
        mut times,
        mut ratios,
        mut a_times,
        mut b_times,
    } = measure_rounds(&mut pipes, &pairs, rounds)?;
    let medians: Vec<f64> = times.iter_mut().map(|t| percentile(t, 50.0)).collect();
    let minima: Vec<f64> = times.iter_mut().map(|t| percentile(t, 10.0)).collect();
    let (table, points, points_min) = effects_table(&configs, &pipes, &medians, &minima);
    // (median, min, max of the A B B A ratios; 10th percentiles of A and B) per pair
    let mut checks = Vec::new();
    for k in 0..pairs.len() {
        let r = &mut ratios[k];
        checks.push((
            percentile(r, 50.0),
            percentile(r, 0.0),
            percentile(r, 100.0),
            percentile(&mut a_times[k], 10.0),
            percentile(&mut b_times[k], 10.0),
        ));
    }
    let (med, lo, hi, a_min, b_min) = checks[0];
    let (f_med, f_lo, f_hi, f_a_min, f_b_min) = checks[1];
    let declared = index("+ dynamics rk4 1 ms + joint friction (viscous, Coulomb stick-slip)")?;
    let rk4 = pairs[1].0;
    let notes = vec![
        format!("Scene: PUMA 560 (testdata/dynamics/robots/puma560.json) moving between two joint targets (kinematic motion at 1 rad/s, or a computed-torque controller under dynamics), four box obstacles, link solids from the DH segments (radius 5 cm). Each sample times {SAMPLE} steps (one back-and-forth motion) after a warm-up; {rounds} rounds, round-robin over the configurations; median and 10th percentile per configuration (samples long enough to be descheduled on this shared machine come out several times slower, so the 10th percentile is the better estimate of the cost itself)."),
        format!("Undeclared effect costs nothing: time(kinematics with collision declared off) / time(kinematics only), measured back to back (A B B A, {SAMPLE} steps each) in every round: median ratio {med:.3}, range {lo:.3} – {hi:.3} over {rounds} rounds; 10th percentiles {:.3} µs vs {:.3} µs per step (ratio {:.3}). Collision declared off builds no stage, so both pipelines run the same code; the spread is the machine's noise.", b_min * 1e6, a_min * 1e6, b_min / a_min),
        format!("Joint friction undeclared costs nothing: time(rk4 dynamics on the PUMA carrying the built-in PUMA's viscous and Coulomb friction data, joint friction effect undeclared) / time(the same on the fixture PUMA without friction data), measured back to back (A B B A, {SAMPLE} steps each) in every round: median ratio {f_med:.3}, range {f_lo:.3} – {f_hi:.3} over {rounds} rounds; 10th percentiles {:.3} µs vs {:.3} µs per step (ratio {:.3}). Undeclared, the stepper holds no friction model and runs the rigid-body equations alone. Declared (`joint_friction {{ viscous: on, coulomb: stick_slip }}`, the default), the step costs {:.2}× the rigid-body rk4 step (medians of the table; {:.2}× by their 10th percentiles).", f_b_min * 1e6, f_a_min * 1e6, f_b_min / f_a_min, medians[declared] / medians[rk4], minima[declared] / minima[rk4]),
        "Times are wall time on a shared 2-core machine (noisy); compare ratios within this run. Per-call costs of RNEA/CRBA/ABA are in docs/reports/dynamics.md.".into(),
        format!("The full pipeline as printed by the simulator:\n\n```\n{description}```"),
        format!("The joint friction row's pipeline:\n\n```\n{friction_description}```"),
    ];
    let plots = vec![Plot {
        title: "time per step by configuration".into(),
        x_label: "configuration (the table's rows in order)".into(),
        y_label: "µs per step".into(),
        log_x: false,
        log_y: true,
        series: vec![
            Series {
                label: "median time per step".into(),
                points,
            },
            Series {
                label: "10th percentile".into(),
                points: points_min,
            },
        ],
    }];
    let report = Report {
        name: "effects".into(),
        title: "Effects: only what a scene calls for".into(),
        notes,
        table,
        plots,
    };
    // the x ticks name the configurations (issue 39: they were numbers 1 … n)
    let names: Vec<String> = report.table.rows.iter().map(|r| r[0].clone()).collect();
    Ok((report, names))
}

/// Samples of 1000 steps (one back-and-forth motion), short enough that most run without
/// being descheduled on this shared machine; many rounds, round-robin over the configurations.
const SAMPLE: usize = 1000;

/// The fixture PUMA 560 (no friction data), and the same robot carrying the built-in PUMA's
/// per-joint viscous and Coulomb friction.
fn puma_without_and_with_friction() -> Result<(Robot, Robot), RunError> {
    let robot = robosim_dynamics::fixture_robot("puma560")
        .ok_or("the PUMA 560 fixture is missing from this build")?;
    // The same robot carrying the built-in PUMA's friction data (its motor inertia left out,
    // so that only the friction differs from the fixture).
    let builtin = robosim_kinematics::builtin_robot("puma560")
        .ok_or("the built-in PUMA 560 is missing from this build")?;
    let mut with_friction = robot.clone();
    for (j, b) in with_friction.joints.iter_mut().zip(&builtin.joints) {
        j.viscous = b.viscous;
        j.coulomb = b.coulomb;
    }
    if with_friction
        .joints
        .iter()
        .all(|j| j.viscous == 0.0 && j.coulomb == 0.0)
    {
        return Err("the built-in PUMA 560 has no friction data to measure".into());
    }
    Ok((robot, with_friction))
}

/// One pipeline per configuration, with the printed pipeline of the "all" row and of the
/// joint friction row.
struct Pipelines {
    pipes: Vec<Pipeline>,
    description: String,
    friction_description: String,
}

fn build_pipelines(
    configs: &[(&'static str, SceneEffects, Friction)],
    robot: &Robot,
    with_friction: &Robot,
) -> Result<Pipelines, RunError> {
    let mut pipes = Vec::new();
    let mut description = String::new();
    let mut friction_description = String::new();
    for (name, effects, friction) in configs {
        let pipe = Pipeline::build(
            match friction {
                Friction::NoData => robot,
                Friction::Data => with_friction,
            },
            &Q_A,
            effects,
            SceneGeometry {
                obstacles: obstacles()?,
                link_solids: None,
            },
        )
        .map_err(|source| RunError::Pipeline {
            what: name.to_string(),
            source,
        })?;
        if name.starts_with("all") {
            description = pipe.to_string();
        }
        if effects.joint_friction.is_some() {
            friction_description = pipe.to_string();
        }
        pipes.push(pipe);
    }
    Ok(Pipelines {
        pipes,
        description,
        friction_description,
    })
}

/// One untimed sample per pipeline.
fn warm_up(pipes: &mut [Pipeline]) -> Result<(), RunError> {
    for pipe in pipes.iter_mut() {
        run(pipe, SAMPLE)?; // warm-up
    }
    Ok(())
}

/// Per-sample seconds per step: per configuration, and for each undeclared-effect pair the
/// A B B A ratios and the A and B times.
struct Samples {
    times: Vec<Vec<f64>>,
    ratios: Vec<Vec<f64>>,
    a_times: Vec<Vec<f64>>,
    b_times: Vec<Vec<f64>>,
}

/// `rounds` rounds: one sample of every pipeline, then each pair back to back (A B B A).
fn measure_rounds(
    pipes: &mut [Pipeline],
    pairs: &[(usize, usize)],
    rounds: usize,
) -> Result<Samples, RunError> {
    // round-robin over the configurations so that machine noise hits them all alike
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); pipes.len()];
    let mut ratios: Vec<Vec<f64>> = vec![Vec::new(); pairs.len()];
    let mut a_times: Vec<Vec<f64>> = vec![Vec::new(); pairs.len()];
    let mut b_times: Vec<Vec<f64>> = vec![Vec::new(); pairs.len()];
    for _ in 0..rounds {
        for (i, pipe) in pipes.iter_mut().enumerate() {
            times[i].push(run(pipe, SAMPLE)?);
        }
        // the undeclared-effect checks: A B B A back to back, same number of steps
        for (k, &(a, b)) in pairs.iter().enumerate() {
            let a1 = run(&mut pipes[a], SAMPLE)?;
            let b1 = run(&mut pipes[b], SAMPLE)?;
            let b2 = run(&mut pipes[b], SAMPLE)?;
            let a2 = run(&mut pipes[a], SAMPLE)?;
            ratios[k].push((b1 + b2) / (a1 + a2));
            a_times[k].extend([a1, a2]);
            b_times[k].extend([b1, b2]);
        }
    }
    Ok(Samples {
        times,
        ratios,
        a_times,
        b_times,
    })
}

/// The table of the configurations and the plot's points (median, 10th percentile; µs).
fn effects_table(
    configs: &[(&'static str, SceneEffects, Friction)],
    pipes: &[Pipeline],
    medians: &[f64],
    minima: &[f64],
) -> (Table, Vec<(f64, f64)>, Vec<(f64, f64)>) {
    let base = medians[0];
    let mut table = Table {
        columns: [
            "configuration",
            "stages",
            "time per step (µs, median)",
            "(µs, 10th percentile)",
            "ratio to kinematics only (median)",
            "steps in contact",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
        rows: Vec::new(),
    };
    let mut points = Vec::new();
    let mut points_min = Vec::new();
    for (i, ((name, _, _), pipe)) in configs.iter().zip(pipes).enumerate() {
        let contacts = if pipe.data().contact.is_some() {
            pipe.data().contact_steps.to_string()
        } else {
            "-".into()
        };
        table.rows.push(vec![
            name.to_string(),
            pipe.stage_names().join(" → "),
            format!("{:.3}", medians[i] * 1e6),
            format!("{:.3}", minima[i] * 1e6),
            format!("{:.2}", medians[i] / base),
            contacts,
        ]);
        points.push((i as f64 + 1.0, medians[i] * 1e6));
        points_min.push((i as f64 + 1.0, minima[i] * 1e6));
    }
    (table, points, points_min)
}

#[cfg(test)]
mod tests {
    #[test]
    fn quick_report_writes_its_files() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (report, names) = super::effects_report(true).expect("report");
        let written = crate::plot::write_report_with_x_names(
            dir.path(),
            &report,
            std::slice::from_ref(&names),
        )
        .expect("written");
        assert_eq!(written.len(), 3);
        // the figure's x ticks are the configurations, in the table's order (issue 39)
        let ticks = crate::plot::draw(&dir.path().join("again.png"), &report.plots, &[names])
            .expect("drawn");
        let rows: Vec<String> = report
            .table
            .rows
            .iter()
            .map(|r| crate::plot::short_x_name(&r[0]))
            .collect();
        assert_eq!(ticks, [rows]);
        assert_eq!(ticks[0][0], "kinematics only");
        assert_eq!(ticks[0][2], "+ joint limits");
        assert!(
            ticks[0]
                .last()
                .is_some_and(|t| t.ends_with("Coulomb stick-slip)")),
            "{ticks:?}"
        );
        let md = std::fs::read_to_string(dir.path().join("effects.md")).expect("md");
        assert!(md.contains("collision declared off"));
        // the friction rows: undeclared measured against the same-run baseline, and the
        // declared row's pipeline really applies friction (the stage says so)
        assert!(md.contains("Joint friction undeclared costs nothing"));
        assert!(md.contains("joint friction undeclared |"));
        assert!(md.contains(", joint friction "), "{md}");
    }
}
