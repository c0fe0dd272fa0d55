//! `robosim report dynamics` — "what accuracy costs in time" for the integrators: the error at
//! t = 2 s of a PUMA 560 falling from rest under gravity (no friction, no motor inertia, no joint
//! stops) against a high-accuracy solution, for each integrator over a range of steps and
//! tolerances, against wall time; plus the per-call cost of RNEA, CRBA and ABA for the PUMA 560
//! and the 7-DOF Panda. Entry point: [`report_dynamics`].
//!
//! Timing is wall time on a shared, noisy machine: each figure is the median of several repeats
//! and is also given as a ratio to the cost of one ABA evaluation measured in the same run.

use crate::plot::RunError;
use crate::plot::{Plot, Report, Series, Table, percentile, write_report};
use robosim_dynamics::{
    Data, Integrator, IntegratorConfig, Model, aba, crba, fixture_robot, rnea, simulate,
};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The falling arm's initial pose (rad): away from singularities, every joint loaded.
pub const FALL_Q0: [f64; 6] = [0.0, 0.3, -0.5, 0.2, 0.6, 0.0];
/// The time at which errors are measured (s).
pub const FALL_T: f64 = 2.0;

type Points = Vec<(f64, f64)>;

struct Run {
    label: &'static str,
    setting: String,
    x_step: Option<f64>,
    config: IntegratorConfig,
}

/// The `p`-th percentile of the wall time (s) of `f` over `reps` repeats.
fn time_percentile(reps: usize, p: f64, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    percentile(&mut t, p)
}

/// Median time (s) of one call of `f`, from `batches` batches of `per_batch` calls.
fn per_call(batches: usize, per_batch: usize, mut f: impl FnMut()) -> f64 {
    time_percentile(batches, 50.0, || {
        for _ in 0..per_batch {
            f();
        }
    }) / per_batch as f64
}

/// Runs the study and writes `dynamics.csv`, `dynamics.md`, `dynamics.png` into `out_dir`.
/// `quick` trims the smallest steps and the repeats (for CI smoke runs; a few seconds).
pub fn report_dynamics(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, RunError> {
    let robot =
        fixture_robot("puma560").ok_or("the PUMA 560 fixture is missing from this build")?;
    let model = Model::new(&robot).map_err(|source| RunError::Dynamics {
        what: "the PUMA 560's model",
        source,
    })?;
    let panda = Model::new(&fixture_robot("panda").ok_or("the Panda fixture is missing")?)
        .map_err(|source| RunError::Dynamics {
            what: "the Panda's model",
            source,
        })?;
    // The same PUMA with every joint general (placement and axis, as a URDF gives them): the
    // algorithms are one code path; this times the general placements against DH rows.
    let general = Model::new(&robosim_kinematics::chain::to_general(&robot)).map_err(|source| {
        RunError::Dynamics {
            what: "the general-joint PUMA 560's model",
            source,
        }
    })?;
    let reps = if quick { 1 } else { 5 };
    let (mut notes, aba_cost) = algorithm_costs(
        &[
            ("PUMA 560 (6 DOF)", &model),
            ("PUMA 560 as general joints", &general),
            ("Panda (7 DOF)", &panda),
        ],
        quick,
    );
    let reference = Reference::of_fall(&model, quick)?;
    let runs = integrator_runs(quick);
    let (table, by_label) = measure_runs(&model, &runs, &reference, reps, aba_cost)?;
    notes.insert(
        0,
        format!(
            "PUMA 560 (roboticstoolbox-python parameters, testdata/dynamics/robots/puma560.json) falling from rest at q0 = {FALL_Q0:?} rad under gravity, τ = 0, no friction, no motor inertia, no joint stops. Error = max over joints of |q(2 s) − q_ref(2 s)|."
        ),
    );
    notes.insert(
        1,
        format!(
            "Reference: dopri5 with rtol = atol = 1e-13; it agrees with RK4 at dt = {} s to {:.1e} rad. E(0) = {:.6} J.",
            if quick { "1e-4" } else { "2e-5" },
            reference.check,
            reference.e0
        ),
    );
    notes.push(format!(
        "Wall times: fastest of {reps} run(s) each, one thread, on a shared 2-core machine (noisy; the other engineers' builds run alongside); 'wall time / ABA call' divides by the PUMA's median ABA cost measured above in the same process ({:.2} µs), so it is comparable across machines. The semi-implicit Euler step is the momentum-form symplectic Euler (CRBA + two Cholesky factorisations + a fixed-point solve per step), hence its higher cost per step.",
        aba_cost * 1e6
    ));
    if quick {
        notes.push("Quick run (fewer steps and repeats): regenerate with quick = false for the published figures.".into());
    }
    let report = Report {
        name: "dynamics".into(),
        title: "Dynamics: what integration accuracy costs in time".into(),
        notes,
        table,
        plots: error_plots(&by_label),
    };
    Ok(write_report(out_dir, &report)?)
}

/// Per-call cost of RNEA, CRBA and ABA for each (name, model): a note per model, a note
/// comparing the second model to the first (general joints against DH rows), and the first
/// model's median ABA cost (s), the baseline of the report's time ratios.
fn algorithm_costs(models: &[(&str, &Model)], quick: bool) -> (Vec<String>, f64) {
    let mut notes = Vec::new();
    let mut medians = Vec::new();
    let (batches, per) = if quick { (5, 1_000) } else { (201, 1_000) };
    for &(name, m) in models {
        let mut t = rnea_crba_aba_times(m, batches, per);
        let med: Vec<f64> = t.iter_mut().map(|x| percentile(x, 50.0) * 1e6).collect();
        let min: Vec<f64> = t.iter_mut().map(|x| percentile(x, 10.0) * 1e6).collect();
        notes.push(format!(
            "{name}: RNEA {:.2} µs, CRBA {:.2} µs, ABA {:.2} µs per call (median of {batches} interleaved batches of {per} calls; 10th percentile {:.2} / {:.2} / {:.2} µs; ABA/RNEA = {:.2}).",
            med[0], med[1], med[2], min[0], min[1], min[2], med[2] / med[0]
        ));
        medians.push(med);
    }
    notes.push(format!(
        "PUMA 560, general joints / DH rows (same run): RNEA {:.2}, CRBA {:.2}, ABA {:.2}.",
        medians[1][0] / medians[0][0],
        medians[1][1] / medians[0][1],
        medians[1][2] / medians[0][2]
    ));
    (notes, medians[0][2] * 1e-6)
}

/// Per-call times (s) of RNEA, CRBA and ABA on `m` at a fixed (q, q̇, q̈), one per batch of
/// `per` calls. The three algorithms are interleaved batch by batch so that machine noise hits
/// them alike; short batches, most of them undisturbed.
fn rnea_crba_aba_times(m: &Model, batches: usize, per: usize) -> [Vec<f64>; 3] {
    let n = m.dof();
    let mut data = Data::new(m);
    let q: Vec<f64> = (0..n).map(|j| 0.3 + 0.1 * j as f64).collect();
    let qd: Vec<f64> = (0..n).map(|j| 0.5 - 0.2 * j as f64).collect();
    let qdd: Vec<f64> = (0..n).map(|j| 1.0 - 0.3 * j as f64).collect();
    let mut t = [Vec::new(), Vec::new(), Vec::new()];
    for _ in 0..batches {
        t[0].push(per_call(1, per, || {
            black_box(
                rnea(m, &mut data, black_box(&q), &qd, &qdd)
                    .map(|t| t[0])
                    .ok(),
            );
        }));
        t[1].push(per_call(1, per, || {
            black_box(crba(m, &mut data, black_box(&q)).map(|t| t[(0, 0)]).ok());
        }));
        t[2].push(per_call(1, per, || {
            black_box(
                aba(m, &mut data, black_box(&q), &qd, &qdd)
                    .map(|t| t[0])
                    .ok(),
            );
        }));
    }
    t
}

/// The fall's high-accuracy solution: dopri5 at rtol = atol = 1e-13.
struct Reference {
    /// Energy at t = 0 (J).
    e0: f64,
    /// q at [`FALL_T`] (rad).
    q: Vec<f64>,
    /// max |q − q_ref| of RK4 at a small fixed step (1e-4 s quick, else 2e-5 s): how far the
    /// reference is from an independent method (rad).
    check: f64,
}

impl Reference {
    fn of_fall(model: &Model, quick: bool) -> Result<Self, RunError> {
        let zeros = [0.0; 6];
        let (reference, _) = simulate(
            model,
            IntegratorConfig::adaptive(1e-13, 1e-13),
            &FALL_Q0,
            &zeros,
            &zeros,
            &[0.0, FALL_T],
        )
        .map_err(|source| RunError::Dynamics {
            what: "the reference fall",
            source,
        })?;
        let q = reference[1].q.clone();
        let (check, _) = simulate(
            model,
            IntegratorConfig::fixed(Integrator::Rk4, if quick { 1e-4 } else { 2e-5 }),
            &FALL_Q0,
            &zeros,
            &zeros,
            &[FALL_T],
        )
        .map_err(|source| RunError::Dynamics {
            what: "the fall's RK4 check",
            source,
        })?;
        Ok(Reference {
            e0: reference[0].energy,
            check: max_diff(&check[0].q, &q),
            q,
        })
    }
}

/// Every integrator at each of its fixed steps, then dopri5 at each tolerance.
fn integrator_runs(quick: bool) -> Vec<Run> {
    let mut runs = Vec::new();
    let fixed = |label, integrator, steps: &[f64], runs: &mut Vec<Run>| {
        for &dt in steps {
            runs.push(Run {
                label,
                setting: format!("dt = {dt:e} s"),
                x_step: Some(dt),
                config: IntegratorConfig::fixed(integrator, dt),
            });
        }
    };
    let (euler_steps, rk_steps, dp_steps, tols): (&[f64], &[f64], &[f64], &[f64]) = if quick {
        (&[1e-3, 1e-4], &[1e-2, 1e-3], &[2e-2, 2e-3], &[1e-4, 1e-8])
    } else {
        (
            &[1e-3, 3e-4, 1e-4, 3e-5, 1e-5],
            &[2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4],
            &[4e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3],
            &[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11],
        )
    };
    fixed("euler", Integrator::Euler, euler_steps, &mut runs);
    fixed(
        "semi_implicit_euler",
        Integrator::SemiImplicitEuler,
        euler_steps,
        &mut runs,
    );
    fixed("rk4", Integrator::Rk4, rk_steps, &mut runs);
    fixed(
        "dopri5 (fixed step)",
        Integrator::Dopri5,
        dp_steps,
        &mut runs,
    );
    for &tol in tols {
        runs.push(Run {
            label: "dopri5 (rtol = atol)",
            setting: format!("tol = {tol:e}"),
            x_step: None,
            config: IntegratorConfig::adaptive(tol, tol),
        });
    }
    runs
}

/// Per integrator: its label, (wall ms, error) points and (step, error) points.
type ByLabel = Vec<(&'static str, Points, Points)>;

/// Simulates the fall with each run (the fastest of `reps` repeats) and tabulates steps,
/// evaluations, wall time (also over `aba_cost`, s), error against the reference and energy
/// drift; the points of the plots, by integrator.
fn measure_runs(
    model: &Model,
    runs: &[Run],
    reference: &Reference,
    reps: usize,
    aba_cost: f64,
) -> Result<(Table, ByLabel), RunError> {
    let zeros = [0.0; 6];
    let columns = [
        "integrator",
        "step or tolerance",
        "accepted steps",
        "rejected",
        "ABA evaluations",
        "wall time (ms)",
        "wall time / ABA call",
        "max |q - q_ref| at 2 s (rad)",
        "|E(2 s) - E(0)| (J)",
    ];
    let mut table = Table {
        columns: columns.iter().map(|s| s.to_string()).collect(),
        rows: Vec::new(),
    };
    let mut by_label: ByLabel = Vec::new();
    for run in runs {
        let mut result = None;
        // the fastest repeat: a run of up to a second is often descheduled on this shared machine
        let wall = time_percentile(reps, 0.0, || {
            result = Some(simulate(
                model,
                run.config,
                &FALL_Q0,
                &zeros,
                &zeros,
                &[FALL_T],
            ));
        });
        let (samples, stats) = match result {
            Some(Ok(r)) => r,
            Some(Err(source)) => {
                return Err(RunError::DynamicsRun {
                    run: format!("{} {}", run.label, run.setting),
                    source,
                });
            }
            None => return Err("no repeats".into()),
        };
        let err = max_diff(&samples[0].q, &reference.q);
        let de = (samples[0].energy - reference.e0).abs();
        table.rows.push(vec![
            run.label.to_string(),
            run.setting.clone(),
            stats.accepted.to_string(),
            stats.rejected.to_string(),
            stats.evaluations.to_string(),
            format!("{:.3}", wall * 1e3),
            format!("{:.0}", wall / aba_cost),
            format!("{err:.3e}"),
            format!("{de:.3e}"),
        ]);
        let slot = match by_label.iter().position(|(l, _, _)| *l == run.label) {
            Some(i) => i,
            None => {
                by_label.push((run.label, Vec::new(), Vec::new()));
                by_label.len() - 1
            }
        };
        // log axes cannot show 0: floor the error at 1e-16
        by_label[slot].1.push((wall * 1e3, err.max(1e-16)));
        if let Some(dt) = run.x_step {
            by_label[slot].2.push((dt, err.max(1e-16)));
        }
    }
    Ok((table, by_label))
}

/// Error against wall time (every integrator) and against fixed step size (the fixed-step
/// ones), both log-log.
fn error_plots(by_label: &ByLabel) -> Vec<Plot> {
    vec![
        Plot {
            title: "PUMA 560 falling for 2 s: error against wall time".into(),
            x_label: "wall time (ms)".into(),
            y_label: "max |q - q_ref| (rad)".into(),
            log_x: true,
            log_y: true,
            series: by_label
                .iter()
                .map(|(l, pts, _)| Series {
                    label: l.to_string(),
                    points: pts.clone(),
                })
                .collect(),
        },
        Plot {
            title: "error against fixed step size".into(),
            x_label: "dt (s)".into(),
            y_label: "max |q - q_ref| (rad)".into(),
            log_x: true,
            log_y: true,
            series: by_label
                .iter()
                .filter(|(_, _, s)| !s.is_empty())
                .map(|(l, _, s)| Series {
                    label: l.to_string(),
                    points: s.clone(),
                })
                .collect(),
        },
    ]
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

#[cfg(test)]
mod tests {
    #[test]
    fn quick_report_writes_csv_markdown_and_png() {
        let dir = tempfile::tempdir().expect("temp dir");
        let written = super::report_dynamics(dir.path(), true).expect("report");
        assert_eq!(written.len(), 3);
        let csv = std::fs::read_to_string(dir.path().join("dynamics.csv")).expect("csv");
        for integrator in [
            "euler",
            "semi_implicit_euler",
            "rk4",
            "dopri5 (fixed step)",
            "dopri5 (rtol = atol)",
        ] {
            assert!(
                csv.contains(integrator),
                "{integrator} missing from the table"
            );
        }
    }
}
