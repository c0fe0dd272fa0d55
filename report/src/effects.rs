//! `robosim report effects` — "only the effects a scene calls for": time per step of one scene
//! (a PUMA 560 moving between two joint targets among four box obstacles) with kinematics only,
//! then adding joint limits, collision in each mode, and dynamics; and the check that an
//! undeclared effect costs nothing (kinematics only against kinematics with collision declared
//! off). Entry point: [`report_effects`].

use crate::plot::{Plot, Report, Series, Table, percentile, write_report};
use nalgebra::{DVector, Isometry3, Vector3};
use robosim_collision::robot::Scene;
use robosim_collision::{Mode, Solid};
use robosim_simulator::{
    CollisionEffect, DynamicsEffect, EncoderEffect, Integrator, LoggingEffect, SceneEffects, Signal,
};
use robosim_simulator::{Command, Pipeline, SceneGeometry};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

const Q_A: [f64; 6] = [0.0, 0.4, -0.6, 0.0, 0.5, 0.0];
const Q_B: [f64; 6] = [1.2, 0.9, -1.4, 0.8, -0.4, 1.0];

fn obstacles() -> Result<Scene, String> {
    let mut scene = Scene::new();
    let boxes = [
        ("floor", [3.0, 3.0, 0.1], [0.0, 0.0, -0.25]),
        ("wall", [0.1, 3.0, 2.0], [1.6, 0.0, 0.5]),
        ("shelf", [0.4, 0.4, 0.05], [-0.9, 0.9, 0.9]),
        ("post", [0.1, 0.1, 1.0], [0.0, -1.2, 0.3]),
    ];
    for (name, size, at) in boxes {
        let solid = Solid::cuboid(Vector3::from(size)).map_err(|e| e.to_string())?;
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

/// The configurations, kinematics-only first (the baseline).
fn configurations() -> Vec<(&'static str, SceneEffects)> {
    let kin = SceneEffects {
        kinematics: true,
        ..SceneEffects::default()
    };
    let lim = SceneEffects {
        joint_limits: true,
        ..kin.clone()
    };
    vec![
        ("kinematics only", kin.clone()),
        (
            "kinematics, collision declared off",
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
            "+ dynamics rk4 1 ms (no collision)",
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
fn run(pipe: &mut Pipeline, steps: usize) -> Result<f64, String> {
    let start = Instant::now();
    for k in 0..steps {
        if k % 500 == 0 {
            let target = if (k / 500) % 2 == 0 { Q_B } else { Q_A };
            pipe.set_command(Command::Target(DVector::from_column_slice(&target)))
                .map_err(|e| e.to_string())?;
        }
        pipe.step().map_err(|e| e.to_string())?;
    }
    Ok(start.elapsed().as_secs_f64() / steps as f64)
}

/// Runs the study and writes `effects.csv`, `effects.md`, `effects.png` into `out_dir`.
/// `quick` runs fewer steps and rounds (a few seconds, for CI).
pub fn report_effects(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, String> {
    let robot = robosim_dynamics::fixture_robot("puma560")
        .ok_or("the PUMA 560 fixture is missing from this build")?;
    let configs = configurations();
    // Samples of 1000 steps (one back-and-forth motion), short enough that most run without
    // being descheduled on this shared machine; many rounds, round-robin over the configurations.
    const SAMPLE: usize = 1000;
    let rounds = if quick { 5 } else { 101 };
    let mut pipes = Vec::new();
    let mut description = String::new();
    for (name, effects) in &configs {
        let pipe = Pipeline::build(
            &robot,
            &Q_A,
            effects,
            SceneGeometry {
                obstacles: obstacles()?,
                link_solids: None,
            },
        )
        .map_err(|e| format!("{name}: {e}"))?;
        if name.starts_with("all") {
            description = pipe.to_string();
        }
        pipes.push(pipe);
    }
    for pipe in pipes.iter_mut() {
        run(pipe, SAMPLE)?; // warm-up
    }
    // round-robin over the configurations so that machine noise hits them all alike
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); configs.len()];
    let mut ratio_off: Vec<f64> = Vec::new();
    let (mut a_times, mut b_times) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        for (i, pipe) in pipes.iter_mut().enumerate() {
            times[i].push(run(pipe, SAMPLE)?);
        }
        // the undeclared-effect check: A B B A back to back, same number of steps
        let a1 = run(&mut pipes[0], SAMPLE)?;
        let b1 = run(&mut pipes[1], SAMPLE)?;
        let b2 = run(&mut pipes[1], SAMPLE)?;
        let a2 = run(&mut pipes[0], SAMPLE)?;
        ratio_off.push((b1 + b2) / (a1 + a2));
        a_times.extend([a1, a2]);
        b_times.extend([b1, b2]);
    }
    let medians: Vec<f64> = times.iter_mut().map(|t| percentile(t, 50.0)).collect();
    let minima: Vec<f64> = times.iter_mut().map(|t| percentile(t, 10.0)).collect();
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
    for (i, ((name, _), pipe)) in configs.iter().zip(&pipes).enumerate() {
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
    let mut r = ratio_off.clone();
    let (lo, med, hi) = (
        percentile(&mut r, 0.0),
        percentile(&mut r, 50.0),
        percentile(&mut r, 100.0),
    );
    let (a_min, b_min) = (
        percentile(&mut a_times, 10.0),
        percentile(&mut b_times, 10.0),
    );
    let notes = vec![
        format!("Scene: PUMA 560 (testdata/dynamics/robots/puma560.json) moving between two joint targets (kinematic motion at 1 rad/s, or a computed-torque controller under dynamics), four box obstacles, link solids from the DH segments (radius 5 cm). Each sample times {SAMPLE} steps (one back-and-forth motion) after a warm-up; {rounds} rounds, round-robin over the configurations; median and 10th percentile per configuration (samples long enough to be descheduled on this shared machine come out several times slower, so the 10th percentile is the better estimate of the cost itself)."),
        format!("Undeclared effect costs nothing: time(kinematics with collision declared off) / time(kinematics only), measured back to back (A B B A, {SAMPLE} steps each) in every round: median ratio {med:.3}, range {lo:.3} – {hi:.3} over {rounds} rounds; 10th percentiles {:.3} µs vs {:.3} µs per step (ratio {:.3}). Collision declared off builds no stage, so both pipelines run the same code; the spread is the machine's noise.", b_min * 1e6, a_min * 1e6, b_min / a_min),
        "Times are wall time on a shared 2-core machine (noisy); compare ratios within this run. Per-call costs of RNEA/CRBA/ABA are in docs/reports/dynamics.md.".into(),
        format!("The full pipeline as printed by the simulator:\n\n```\n{description}```"),
    ];
    let plots = vec![Plot {
        title: "time per step by configuration".into(),
        x_label: "configuration: the table's rows in order (1 = kinematics only)".into(),
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
    write_report(out_dir, &report).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    #[test]
    fn quick_report_writes_its_files() {
        let dir = tempfile::tempdir().expect("temp dir");
        let written = super::report_effects(dir.path(), true).expect("report");
        assert_eq!(written.len(), 3);
        let md = std::fs::read_to_string(dir.path().join("effects.md")).expect("md");
        assert!(md.contains("collision declared off"));
    }
}
