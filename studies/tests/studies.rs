//! The welding and station studies end to end on short runs (coarse steps, part of an orbit):
//! what they write, that it is consistent with the models, and how bad parameters are refused.
//! The orbit's closed forms are tested in `studies/src/orbit.rs`.

use nalgebra::Vector3;
use robosim_collision::Mode;
use robosim_studies::station::{self, StationParams};
use robosim_studies::welding::{self, SeamKind, WeldingParams};
use std::path::Path;

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).expect("the file reads");
    let mut lines = text.lines();
    let cols: Vec<String> = lines
        .next()
        .expect("the file reads")
        .split(',')
        .map(String::from)
        .collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse::<f64>().expect("a number"))
                .collect()
        })
        .collect();
    for r in &rows {
        assert_eq!(r.len(), cols.len());
        assert!(
            r.iter().all(|v| v.is_finite()),
            "non-finite value in {path:?}"
        );
    }
    (cols, rows)
}

fn col(cols: &[String], name: &str) -> usize {
    cols.iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name} in {cols:?}"))
}

/// Every column name says its unit (or is a flag / count / ratio by name).
fn units_named(cols: &[String]) {
    for c in cols {
        let ok = [
            "_s",
            "_m",
            "_deg",
            "_mm",
            "_kw",
            "_kwh",
            "_pct",
            "_ratio",
            "_soc",
            "_feathered",
        ]
        .iter()
        .any(|u| c.ends_with(u))
            || [
                "seam", "welding", "feasible", "eclipse", "blocked", "sun_x", "sun_y", "sun_z",
            ]
            .contains(&c.as_str());
        assert!(ok, "column {c} names no unit");
    }
}

fn quick_welding() -> WeldingParams {
    WeldingParams {
        step_s: 0.5,
        speed_m_s: 0.01,
        frames: 0,
        ..WeldingParams::default()
    }
}

#[test]
fn welding_study_welds_both_seams_downhand_and_writes_playable_trajectories() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = quick_welding();
    let mut log = Vec::new();
    let run = welding::run(&p, dir.path(), &mut log).expect("temp dir");
    let setup = welding::setup(&p).expect("the study sets up");
    // every weld step feasible, downhand and the torch angles held at the steps
    let weld: Vec<_> = run.steps.iter().filter(|s| s.s >= 0.0).collect();
    assert!(weld.len() > 50);
    for st in &weld {
        assert!(st.problem.is_empty(), "t {}: {}", st.t, st.problem);
        assert!(st.downhand_err < 1e-3, "downhand {}", st.downhand_err);
        assert!(st.work_err.abs() < 1e-6 && st.travel_err.abs() < 1e-6);
        assert!(st.tip_err < 1e-6);
        assert!(st.clearance >= p.min_clearance_m);
        assert!(st.arm_speed_ratio <= 1.0 && st.pos_speed_ratio <= 1.0);
    }
    // both seams covered to their ends
    for (i, seam) in setup.seams.iter().enumerate() {
        let last = weld
            .iter()
            .filter(|s| s.seam == i)
            .map(|s| s.s)
            .fold(0.0, f64::max);
        assert!((last - seam.length()).abs() < 1e-9);
    }
    // within the joint limits at every step, welding or not
    let (arm, pos) = welding::robots(&setup);
    for st in &run.steps {
        assert!(arm.outside_limits(&st.q_arm).is_none());
        assert!(pos.outside_limits(&st.q_pos).is_none());
    }
    // the CSV: finite, units named, one row per step
    let (cols, rows) = read_csv(&dir.path().join("welding.csv"));
    units_named(&cols);
    assert_eq!(rows.len(), run.steps.len());
    assert!(rows.iter().all(|r| r[col(&cols, "feasible")] == 1.0));
    // the trajectories load in the display's file mode, one sample per step, in limits
    for (name, robot) in [("arm", arm), ("positioner", pos)] {
        let t =
            robosim_display::trajectory::Trajectory::load(&dir.path().join(format!("{name}.traj")))
                .expect("the trajectory loads");
        assert_eq!(t.samples.len(), run.steps.len());
        assert_eq!(t.columns(), robot.dof());
        assert!((t.dt - p.step_s).abs() < 1e-12);
        let prismatic = vec![false; robot.dof()];
        for k in 0..t.samples.len() {
            assert!(robot.outside_limits(&t.sample_si(k, &prismatic)).is_none());
        }
    }
    // the summary says what was found
    let md =
        std::fs::read_to_string(dir.path().join("welding_summary.md")).expect("the file reads");
    assert!(
        md.contains("| circle |") && md.contains("| saddle |"),
        "{md}"
    );
    assert!(md.contains("Every step of every seam can be welded downhand"));
    assert!(dir.path().join("welding_summary.png").exists());
}

#[test]
fn seams_lie_on_the_workpiece_and_the_positioner_turns_them_up() {
    let p = quick_welding();
    let s = welding::setup(&p).expect("the study sets up");
    let circle = s
        .seams
        .iter()
        .find(|x| x.kind == SeamKind::Circle)
        .expect("the study sets up");
    // the circle: radius of the pipe (0.1 m), on the flange top (0.02 m), length 2πr
    assert!((circle.length() - std::f64::consts::TAU * 0.1).abs() < 1e-3);
    for (pt, n) in circle.points.iter().zip(&circle.normals) {
        assert!((pt.coords.xy().norm() - 0.1).abs() < 1e-12);
        assert!((pt.z - 0.02).abs() < 1e-12);
        // a 90° fillet: the bisector is 45° up from the pipe's radial direction
        assert!((n.z - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
    }
    let saddle = s
        .seams
        .iter()
        .find(|x| x.kind == SeamKind::Saddle)
        .expect("the seam is there");
    for pt in &saddle.points {
        // on the pipe (r = 0.1 about z) and on the branch (r = 0.05 about x at z = 0.2)
        assert!((pt.coords.xy().norm() - 0.1).abs() < 1e-9);
        assert!((Vector3::new(0.0, pt.y, pt.z - 0.2).norm() - 0.05).abs() < 1e-9);
    }
    // the saddle is longer than the branch's circumference (it climbs the pipe's curvature)
    assert!(saddle.length() > std::f64::consts::TAU * 0.05);
    // downhand: any seam normal is turned up by the positioner
    for n in [
        Vector3::new(0.0, 0.0, 1.0),
        Vector3::new(1.0, 0.0, 1.0).normalize(),
        Vector3::new(-0.3, 0.8, 0.2).normalize(),
        Vector3::new(0.5, -0.5, -0.1).normalize(),
    ] {
        let (_, err) = welding::downhand(&s, &n, &[0.0, 0.0], 1e-7);
        assert!(err < 1e-4, "normal {n:?}: {err}");
    }
}

#[test]
fn an_unreachable_seam_is_reported_where_and_why_without_nan() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = WeldingParams {
        arm_x_m: Some(-1.45),
        seams: vec![SeamKind::Saddle],
        ..quick_welding()
    };
    let mut log = Vec::new();
    let run = welding::run(&p, dir.path(), &mut log).expect("the study runs");
    let s = welding::setup(&p).expect("the study sets up");
    let sections = welding::sections(&s, &run);
    assert!(!sections.is_empty());
    assert!(
        sections.iter().any(|x| x.3.contains("unreachable")),
        "{sections:?}"
    );
    // some of the saddle can still be welded: not everything is infeasible
    assert!(run.steps.iter().any(|x| x.s >= 0.0 && x.problem.is_empty()));
    let (cols, rows) = read_csv(&dir.path().join("welding.csv"));
    assert!(rows.iter().any(|r| r[col(&cols, "feasible")] == 0.0));
    let md =
        std::fs::read_to_string(dir.path().join("welding_summary.md")).expect("the file reads");
    assert!(md.contains("Infeasible: saddle seam"), "{md}");
}

#[test]
fn bad_welding_parameters_are_refused_by_name() {
    let bad = |p: WeldingParams, words: &str| {
        let dir = tempfile::tempdir().expect("temp dir");
        let e = welding::run(&p, dir.path(), &mut Vec::new()).expect_err("refused");
        assert!(e.0.contains(words), "{e}");
        assert!(!dir.path().join("welding.csv").exists());
    };
    bad(
        WeldingParams {
            branch_height_m: Some(0.4),
            ..quick_welding()
        },
        "off the workpiece",
    );
    bad(
        WeldingParams {
            speed_m_s: -0.01,
            ..quick_welding()
        },
        "travel speed",
    );
    bad(
        WeldingParams {
            step_s: f64::NAN,
            ..quick_welding()
        },
        "step",
    );
    bad(
        WeldingParams {
            seams: vec![],
            ..quick_welding()
        },
        "no seam",
    );
}

fn quick_station() -> StationParams {
    StationParams {
        step_s: 30.0,
        orbits: 0.4,
        frames: 0,
        ..StationParams::default()
    }
}

#[test]
fn station_study_tracks_the_sun_feathers_for_the_servicer_and_keeps_the_battery() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = quick_station();
    let mut log = Vec::new();
    let run = station::run(&p, dir.path(), &mut log).expect("temp dir");
    let s = station::setup(&p).expect("the study sets up");
    let area: f64 = s.arrays.iter().map(|a| a.area_m2).sum();
    // 2 outboard wings of 2 × 10 m × 30 m and 2 solar structures of 2 × 6 m × 16 m
    assert!((area - (2.0 * 600.0 + 2.0 * 192.0)).abs() < 1e-9);
    let max_p = area * s.efficiency * station::SOLAR_FLUX;
    let mut feathered = 0;
    for st in &run.steps {
        assert!(st.power_w >= 0.0 && st.power_w <= max_p + 1e-6);
        assert!(st.power_w <= st.tracked_power_w + 1e-6);
        assert!((0.0..=1.0).contains(&st.soc));
        if st.eclipse {
            assert_eq!(st.power_w, 0.0);
        }
        assert!(!st.blocked, "t {}", st.t);
        assert!(st.clearance_arrays >= p.keep_out_m - 1e-9, "t {}", st.t);
        assert!(st.clearance_structure > 0.0, "t {}", st.t);
        for (a, (q, c, f)) in s.arrays.iter().zip(&st.arrays) {
            // the two-axis outboard arrays face the sun when not feathered
            if q.len() == 2 && !f {
                assert!(*c > 1.0 - 1e-6, "t {} incidence cos {c}", st.t);
            }
            let _ = a;
            feathered += *f as usize;
        }
    }
    // the servicer passes the port solar structure: it is feathered and power is lost
    assert!(feathered > 0);
    assert!(run.lost_j > 0.0);
    // the battery: charged while the arrays give more than the load, within capacity
    let first = &run.steps[0];
    assert!(first.power_w > p.load_w);
    assert!(run.steps[1].soc > first.soc);
    let (cols, rows) = read_csv(&dir.path().join("station.csv"));
    units_named(&cols);
    assert_eq!(rows.len(), run.steps.len());
    for c in [
        "t_s",
        "eclipse",
        "power_kw",
        "battery_soc",
        "clearance_arrays_m",
        "port_outboard_alpha_joint_deg",
        "port_solar_incidence_deg",
    ] {
        col(&cols, c);
    }
    // trajectory files for all five manipulators, playable in the display's file mode
    for b in &s.bodies {
        let t = robosim_display::trajectory::Trajectory::load(
            &dir.path().join(format!("{}.traj", b.name)),
        )
        .expect("the trajectory loads");
        assert_eq!(t.samples.len(), run.steps.len());
        assert_eq!(t.columns(), b.robot.dof());
    }
    let md =
        std::fs::read_to_string(dir.path().join("station_summary.md")).expect("the file reads");
    assert!(md.contains("Array feathered for the servicer"), "{md}");
    assert!(md.contains("energy lost to feathering"));
}

#[test]
fn station_orbit_matches_the_closed_forms_and_the_declared_effect() {
    let p = quick_station();
    let s = station::setup(&p).expect("the study sets up");
    // the scene's declared orbit: 400 km, beta 20°
    assert!((s.orbit.altitude_m - 400e3).abs() < 1e-6);
    assert!((s.orbit.beta_rad - 20f64.to_radians()).abs() < 1e-12);
    let run = station::simulate(
        &s,
        &StationParams {
            orbits: 1.0,
            step_s: 60.0,
            task_start_s: 1e9,
            ..p.clone()
        },
    )
    .expect("it succeeds");
    let shadow: f64 = run.eclipses.iter().map(|[a, b]| b - a).sum();
    assert!((shadow / run.period_s - s.orbit.eclipse_fraction_closed_form()).abs() < 1e-6);
    // the run ends one period after it started
    assert!((run.steps.last().expect("it succeeds").t - run.period_s).abs() < 1e-9);
    // parameters override the declared orbit; a high beta has no eclipse
    let high = station::setup(&StationParams {
        beta_rad: Some(80f64.to_radians()),
        altitude_m: Some(800e3),
        ..p.clone()
    })
    .expect("it succeeds");
    assert_eq!(high.orbit.eclipse_fraction_closed_form(), 0.0);
}

#[test]
fn bbox_clearances_are_conservative_against_exact() {
    let p = quick_station();
    let s = station::setup(&p).expect("the study sets up");
    let exact = station::simulate(&s, &p).expect("the simulation runs");
    let bbox = station::simulate(
        &s,
        &StationParams {
            mode: Mode::BBox,
            ..p.clone()
        },
    )
    .expect("it succeeds");
    // bbox gives lower bounds only: wherever exact has to feather, bbox feathers too or finds
    // no angle it can prove clear (blocked)
    for (e, b) in exact.steps.iter().zip(&bbox.steps) {
        if e.arrays.iter().any(|a| a.2) {
            assert!(b.blocked || b.arrays.iter().any(|a| a.2), "t {}", e.t);
        }
        assert!(b.clearance_arrays <= e.clearance_arrays + 1e-9 || b.blocked);
    }
    assert!(exact.steps.iter().all(|x| !x.blocked));
}

#[test]
fn bad_station_parameters_are_refused_by_name() {
    let bad = |p: StationParams, words: &str| {
        let dir = tempfile::tempdir().expect("temp dir");
        let e = station::run(&p, dir.path(), &mut Vec::new()).expect_err("refused");
        assert!(e.0.contains(words), "{e}");
        assert!(!dir.path().join("station.csv").exists());
    };
    bad(
        StationParams {
            altitude_m: Some(-400e3),
            ..quick_station()
        },
        "altitude",
    );
    // positive but below an orbit: the library's orbit effect refuses it
    bad(
        StationParams {
            altitude_m: Some(50e3),
            ..quick_station()
        },
        "orbit altitude",
    );
    bad(
        StationParams {
            beta_rad: Some(2.0),
            ..quick_station()
        },
        "beta",
    );
    bad(
        StationParams {
            step_s: 0.0,
            ..quick_station()
        },
        "step",
    );
    bad(
        StationParams {
            soc0: 1.5,
            ..quick_station()
        },
        "battery",
    );
}
