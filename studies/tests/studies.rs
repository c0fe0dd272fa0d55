//! The welding and station studies end to end on short runs (coarse steps, part of an orbit):
//! what they write, that it is consistent with the models, and how bad parameters are refused.
//! The orbit's closed forms are tested in `studies/src/orbit.rs`.

use nalgebra::Vector3;
use robosim_collision::Mode;
use robosim_studies::station::{self, StationParams};
use robosim_studies::welding::{self, SeamKind, WeldingParams};
use std::path::Path;

mod station_oru;

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
            // the loads' flags (issue 38 item 3)
            "_shed",
            "_running",
        ]
        .iter()
        .any(|u| c.ends_with(u))
            || [
                "seam", "welding", "feasible", "eclipse", "blocked", "parked", "sun_x", "sun_y",
                "sun_z",
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

/// Issue 35 item 4: a study's failure keeps its cause typed. A CSV in a directory that does
/// not exist fails on the real `io::Error`, reachable as the error's `source()`, and the one
/// message still names the file (the CLI's error chain says the cause once); a report writer
/// that refuses a line ends the study with [`StudyError::Report`], its io error the source.
#[test]
fn study_errors_keep_their_io_cause_and_name_the_file() {
    use robosim_studies::StudyError;
    use std::error::Error as _;
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("no_such_dir").join("t.csv");
    let e = robosim_studies::common::Csv::create(&path, &["t".to_owned()])
        .err()
        .expect("no directory to write in");
    let io = e
        .source()
        .and_then(|s| s.downcast_ref::<std::io::Error>())
        .expect("the io error is the source");
    assert_eq!(io.kind(), std::io::ErrorKind::NotFound, "{e:?}");
    assert!(
        matches!(&e, StudyError::Io { path: p, .. } if p == &path),
        "{e:?}"
    );
    let said = e.to_string();
    assert!(said.starts_with(&path.display().to_string()), "{said}");
    assert!(said.ends_with(&io.to_string()), "{said}");
    assert_eq!(robosim_instance_space::error_chain(&e), said);

    /// A report writer whose every write fails.
    struct Refusing;
    impl std::io::Write for Refusing {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::other("the reader went away"))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let out = tempfile::tempdir().expect("temp dir");
    let e = welding::run(&quick_welding(), out.path(), &mut Refusing)
        .expect_err("the report cannot be written");
    assert!(matches!(e, StudyError::Report(_)), "{e:?}");
    let io = e
        .source()
        .and_then(|s| s.downcast_ref::<std::io::Error>())
        .expect("the io error is the source");
    assert_eq!(io.to_string(), "the reader went away");
    assert_eq!(
        e.to_string(),
        "writing the study report: the reader went away"
    );
    assert_eq!(robosim_instance_space::error_chain(&e), e.to_string());
}

#[test]
fn bad_welding_parameters_are_refused_by_name() {
    let bad = |p: WeldingParams, words: &str| {
        let dir = tempfile::tempdir().expect("temp dir");
        let e = welding::run(&p, dir.path(), &mut Vec::new()).expect_err("refused");
        assert!(e.to_string().contains(words), "{e}");
        assert!(!dir.path().join("welding.csv").exists());
    };
    // the branch moved (a scene parameter) so far up that it leaves the pipe
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
    let area: f64 = s.arrays.iter().map(|a| a.cells.area_m2).sum();
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
    assert!(md.contains("energy lost to feathering and parking"));
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
        assert!(e.to_string().contains(words), "{e}");
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

/// The circle seam alone at `step_s`, quick.
fn circle_at(step_s: f64) -> WeldingParams {
    WeldingParams {
        seams: vec![SeamKind::Circle],
        step_s,
        speed_m_s: 0.01,
        frames: 0,
        ..WeldingParams::default()
    }
}

/// Audit of issue 17, item 1 (`mid_step_point_on_a_seams_shortened_last_step`): the mid-step
/// check measured against the seam point v·h/2 back from the step's end, which on a seam's
/// last (shortened) step is not the midpoint — the 1 s and 0.5 s rows of the accuracy table
/// were identical. Between-step errors now shrink with the step.
#[test]
fn between_step_errors_shrink_as_the_step_shrinks() {
    // both seams: on the circle the positioner only turns the table, so its downhand error
    // between steps is at the solver's tolerance; the saddle tilts it
    let at = |h: f64| WeldingParams {
        seams: vec![SeamKind::Circle, SeamKind::Saddle],
        ..circle_at(h)
    };
    let s = welding::setup(&at(1.0)).expect("the study sets up");
    let mut last: Option<(f64, f64, f64)> = None;
    for h in [2.0, 1.0, 0.5, 0.25] {
        let r = welding::simulate(&s, &at(h)).expect("the simulation runs");
        eprintln!(
            "step {h} s: mid-step downhand {:.3e} rad, tip {:.3e} m",
            r.mid_downhand, r.mid_tip
        );
        assert!(r.steps.iter().all(|x| x.problem.is_empty()), "h {h}");
        assert!(r.mid_downhand > 0.0 && r.mid_tip > 0.0);
        if let Some((h0, dh0, tip0)) = last {
            assert!(
                r.mid_downhand < 0.8 * dh0 && r.mid_tip < 0.8 * tip0,
                "step {h0} s: {dh0} rad / {tip0} m; step {h} s: {} rad / {} m",
                r.mid_downhand,
                r.mid_tip
            );
        }
        last = Some((h, r.mid_downhand, r.mid_tip));
    }
}

#[test]
fn a_seam_the_positioner_cannot_turn_up_is_reported_not_downhand() {
    let p = circle_at(1.0);
    let mut s = welding::setup(&p).expect("the study sets up");
    // a positioner whose tilt is limited to ±10°: the fillet's normal, 45° from the table's
    // axis, cannot be brought within 5° of vertical
    s.positioner.robot.joints[0].qlim = [-10f64.to_radians(), 10f64.to_radians()];
    s.positioner.q0 = vec![0.0, 0.0];
    let run = welding::simulate(&s, &p).expect("the simulation runs");
    let secs = welding::sections(&s, &run);
    assert!(
        secs.iter()
            .any(|x| x.0 == "circle" && x.3.starts_with("not downhand")),
        "{secs:?}"
    );
    for st in run.steps.iter().filter(|x| x.s >= 0.0) {
        // 45° − 10° = 35° left at best
        assert!(st.downhand_err > 30f64.to_radians(), "{}", st.downhand_err);
        assert!(st.problem.starts_with("not downhand"), "{}", st.problem);
        assert!(st.q_pos.iter().chain(&st.q_arm).all(|v| v.is_finite()));
    }
    let md = welding::summarise(&s, &p, &run);
    assert!(
        md.notes
            .iter()
            .any(|n| n.starts_with("Infeasible: circle seam") && n.contains("not downhand")),
        "{:?}",
        md.notes
    );
}

#[test]
fn a_travel_speed_over_a_joint_speed_limit_is_reported() {
    // 50 mm/s round the r = 0.1 m circle turns the table at 0.5 rad/s (29°/s); its limit here
    // is 10°/s
    let p = WeldingParams {
        speed_m_s: 0.05,
        positioner_speed: [60f64.to_radians(), 10f64.to_radians()],
        ..circle_at(0.5)
    };
    let s = welding::setup(&p).expect("the study sets up");
    let run = welding::simulate(&s, &p).expect("the simulation runs");
    let over: Vec<_> = run
        .steps
        .iter()
        .filter(|x| x.s > 0.0 && x.problem.starts_with("joint speed over the limit"))
        .collect();
    assert!(!over.is_empty());
    for st in &over {
        assert!(st.pos_speed_ratio > 1.0, "{}", st.pos_speed_ratio);
        // the table's speed is the travel speed over the radius, against 10°/s
        assert!((st.pos_speed_ratio - 0.5 / 10f64.to_radians()).abs() < 0.1);
    }
    assert!(
        welding::sections(&s, &run)
            .iter()
            .any(|x| x.3.contains("joint speed over the limit"))
    );
    // the default speed limits hold at the same travel speed
    let ok = welding::simulate(
        &s,
        &WeldingParams {
            speed_m_s: 0.05,
            ..circle_at(0.5)
        },
    )
    .expect("it runs");
    assert!(ok.steps.iter().all(|x| x.problem.is_empty()));
}

#[test]
fn the_branch_height_moves_the_branch_and_the_saddle_with_it() {
    let p = |h: Option<f64>| WeldingParams {
        seams: vec![SeamKind::Saddle],
        branch_height_m: h,
        ..quick_welding()
    };
    let lo = welding::setup(&p(None)).expect("the study sets up");
    let hi = welding::setup(&p(Some(0.22))).expect("the study sets up");
    // the saddle's points rise by the change of height (0.18 → 0.22 m)
    for (a, b) in lo.seams[0].points.iter().zip(&hi.seams[0].points) {
        assert!((b.z - a.z - 0.04).abs() < 1e-9 && (b.xy() - a.xy()).norm() < 1e-9);
    }
    // and the branch that is drawn and collided moved with them
    let branch = |s: &welding::Setup| {
        s.positioner
            .parts
            .iter()
            .find(|x| x.name.ends_with("branch"))
            .map(|x| x.offset.translation.vector.z)
            .expect("a branch part")
    };
    assert!((branch(&hi) - branch(&lo) - 0.04).abs() < 1e-9);
}

#[test]
fn frames_are_rendered_headless() {
    if robosim_display::skipped_without_vulkan("frames_are_rendered_headless") {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let p = WeldingParams {
        frames: 2,
        ..circle_at(2.0)
    };
    if let Err(e) = welding::run(&p, dir.path(), &mut Vec::new()) {
        panic!("{e}");
    }
    let pngs: Vec<_> = std::fs::read_dir(dir.path().join("frames"))
        .expect("the frames directory")
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "png"))
        .collect();
    assert!(pngs.len() >= 2, "{} frames", pngs.len());
    for f in pngs {
        let bytes = std::fs::read(f.path()).expect("the frame reads");
        assert_eq!(&bytes[1..4], b"PNG");
        assert!(bytes.len() > 1000);
    }
}

#[test]
fn welding_accuracy_section_rows_and_errors_shrink_with_the_step() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = WeldingParams {
        speed_m_s: 0.02,
        ..circle_at(1.0)
    };
    let r = welding::accuracy(&p, dir.path(), &[1.0, 0.5]).expect("the section runs");
    // 4 configurations × 2 steps
    assert_eq!(r.table.rows.len(), 8);
    let col = |name: &str| {
        r.table
            .columns
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    };
    let tip = col("worst tip error mid-step (mm)");
    let num = |row: usize, c: usize| r.table.rows[row][c].parse::<f64>().expect("a number");
    // exact mode (both positioner tolerances): the tip error between steps about halves with
    // the step (joint interpolation of a smooth path). bbox and polygon choose other IK
    // solutions (they prove no 5 mm clearance) and may switch roll between two steps, which
    // no step size removes; they are only checked to report a number.
    for pair in [0, 6] {
        assert!(
            num(pair + 1, tip) < 0.7 * num(pair, tip),
            "{:?}",
            r.table.rows
        );
    }
    for row in 0..8 {
        assert!(num(row, tip).is_finite());
    }
    for ext in ["md", "csv", "png"] {
        assert!(dir.path().join(format!("welding_accuracy.{ext}")).exists());
    }
}

#[test]
fn station_accuracy_section_compares_steps_against_the_finest() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = StationParams {
        orbits: 0.15,
        ..quick_station()
    };
    let r = station::accuracy(&p, dir.path(), &[60.0, 30.0]).expect("the section runs");
    // 3 configurations × 2 steps
    assert_eq!(r.table.rows.len(), 6);
    let c = |name: &str| {
        r.table
            .columns
            .iter()
            .position(|x| x == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    };
    // the finest exact run is the reference: its energy error is 0
    assert_eq!(r.table.rows[1][c("step (s)")], "30");
    assert_eq!(r.table.rows[1][c("energy rel. error")], "0.00e0");
    for row in &r.table.rows {
        let between: f64 = row[c("min clearance between steps (m)")]
            .parse()
            .expect("a number");
        assert!(between.is_finite());
    }
    assert!(dir.path().join("station_accuracy.md").exists());
}

/// Power against a hand calculation: at orbit noon (θ = 0) the sun is (0, sin β, cos β) in the
/// body frame; the outboard arrays (2 axes) face it exactly, and the solar structures turning
/// about body x face it too (the sun has no x component at noon). So every panel delivers
/// 1584 m² × 0.14 × 1361 W/m² = 301 817.76 W.
#[test]
fn power_at_orbit_noon_is_the_hand_calculation() {
    let p = StationParams {
        orbits: 0.01,
        step_s: 10.0,
        task_start_s: 1e9,
        ..quick_station()
    };
    let s = station::setup(&p).expect("the study sets up");
    let run = station::simulate(&s, &p).expect("the simulation runs");
    let noon = &run.steps[0];
    assert_eq!(noon.t, 0.0);
    assert!(!noon.eclipse);
    let hand = 1584.0 * 0.14 * 1361.0;
    assert!(
        (noon.power_w - hand).abs() < 1e-3,
        "{} W against {hand} W",
        noon.power_w
    );
    assert_eq!(noon.power_w, noon.tracked_power_w);
}

#[test]
fn station_clearance_is_checked_between_steps() {
    // a coarse step: the servicer sweeps far between samples
    let p = StationParams {
        step_s: 60.0,
        orbits: 0.4,
        ..quick_station()
    };
    let s = station::setup(&p).expect("the study sets up");
    let run = station::simulate(&s, &p).expect("the simulation runs");
    assert!(run.steps[0].between_clearance.is_infinite());
    let mut moving = 0;
    for w in run.steps.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        assert!(b.between_clearance.is_finite(), "t {}", b.t);
        let n = station::between_samples(&s, &p, &a.servicer_q, &b.servicer_q);
        if n > 1 {
            moving += 1;
        }
    }
    // the servicer moves more than half the keep-out within a step several times
    assert!(moving > 0);
    // the summary reports the between-steps check
    let md = station::summarise(&s, &p, &run);
    assert!(
        md.table
            .rows
            .iter()
            .any(|r| r[0] == "minimum servicer–array clearance between steps"),
        "{:?}",
        md.table.rows
    );
    assert!(
        md.notes
            .iter()
            .any(|n| n.starts_with("Between the samples"))
    );
}

/// The library refuses the station's effects where they mean nothing, naming them.
#[test]
fn the_library_refuses_tracking_without_an_orbit_and_a_bad_efficiency() {
    let eval = |effects: &str| {
        let src = format!(
            "robot arm1 {{ link a {{ joint: revolute }} }}\nscene cell() {{\n    place one = arm1()\n    effects {{\n{effects}\n    }}\n}}\n"
        );
        // every declaration is evaluated when the library is loaded: the error comes then
        let lib = robosim_library::Library::from_sources(&[("t.rsl".to_owned(), src)])
            .map_err(|e| e.to_string())?;
        lib.evaluate("cell", &robosim_library::Params::new())
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    let e = eval("        sun_tracking: on").expect_err("refused");
    assert!(e.contains("sun_tracking") && e.contains("orbit"), "{e}");
    let e = eval("        power { efficiency: 0.14 }").expect_err("refused");
    assert!(e.contains("power") && e.contains("orbit"), "{e}");
    let e =
        eval("        orbit { altitude: 400 km, beta: 0 deg }\n        power { efficiency: 1.5 }")
            .expect_err("refused");
    assert!(e.contains("efficiency 1.5 is out of range"), "{e}");
    let e =
        eval("        orbit { altitude: 400 km, beta: 0 deg }\n        power { efficiency: 0 }")
            .expect_err("refused");
    assert!(e.contains("efficiency 0 is out of range"), "{e}");
    eval("        orbit { altitude: 400 km, beta: 0 deg }\n        sun_tracking: on\n        power { efficiency: 0.3 }")
        .expect("a valid declaration");
    // the swap names placed things; the kinematic step is a time in (0, 1 s]
    let e = eval("        oru_swap { servicer: \"nobody\", spare: \"x\" }").expect_err("refused");
    assert!(
        e.contains("servicer \"nobody\" is not a placed robot"),
        "{e}"
    );
    let e = eval("        oru_swap { servicer: \"one\", spare: \"x\" }").expect_err("refused");
    assert!(e.contains("spare \"x\" is not a placed solid"), "{e}");
    let e = eval("        oru_swap { servicer: \"one\" }").expect_err("refused");
    assert!(e.contains("needs a servicer and a spare"), "{e}");
    let e = eval("        kinematics { step: 2 s }").expect_err("refused");
    assert!(e.contains("kinematic step 2 s is out of range"), "{e}");
}

/// The ORU swap moves objects: the failed ORU rides its array's mast until grasped, travels in
/// the servicer's effector, ends set down beside the spare; the spare travels the other way and
/// ends bolted where the failed one was. Both are clearance-checked wherever they are.
#[test]
fn the_oru_swap_carries_the_failed_unit_out_and_the_spare_to_its_site() {
    let p = StationParams {
        orbits: 0.6,
        ..quick_station()
    };
    let s = station::setup(&p).expect("the study sets up");
    let run = station::simulate(&s, &p).expect("the simulation runs");
    let [site, spare0, stow] = station::sites(&s);
    let first = &run.steps[0];
    assert_eq!(first.oru.failed, station::Held::OnArray);
    assert!((first.oru_at[1] - spare0).norm() < 1e-9);
    let last = run.steps.last().expect("steps");
    assert_eq!(last.oru.spare, station::Held::OnArray, "the task ended");
    assert!(matches!(last.oru.failed, station::Held::Fixed(_)));
    assert!(!last.oru.parked);
    // where they end: at the sites, to the IK's tolerance
    assert!(
        (last.oru_at[0] - stow).norm() < 1e-3,
        "{:?}",
        last.oru_at[0]
    );
    // the spare is on the mount of a tracking array again: its frame turns with the array,
    // but at the service angle it is where the failed one was; the servicer let go of it
    // there, to the IK's tolerance
    let mount = station::oru_frame(&s, station::Held::OnArray, &s.oru.swap.service_q, &[]);
    assert!((mount.translation.vector - site.coords).norm() < 1e-9);
    let install = station::install_error(&s, &run).expect("the spare was bolted");
    assert!(install < 1e-3, "{install} m");
    // in between: carried, each ORU moves with the effector, and both are checked
    let mut carried = [0, 0];
    for st in &run.steps {
        for (i, h) in [st.oru.failed, st.oru.spare].iter().enumerate() {
            if let station::Held::Carried(_) = h {
                carried[i] += 1;
                let tip =
                    robosim_kinematics::fk::forward(&s.bodies[s.servicer].robot, &st.servicer_q);
                // the grapple stays GRAPPLE_M below the effector's tip
                let d = nalgebra::Vector3::new(tip[(0, 3)], tip[(1, 3)], tip[(2, 3)])
                    - st.oru_at[i].coords;
                assert!(
                    (d.norm() - station::GRAPPLE_M).abs() < 1e-3,
                    "t {}: {d:?}",
                    st.t
                );
            }
        }
        assert!(st.clearance_structure > 0.0, "t {}", st.t);
        assert!(st.clearance_serviced > 0.0, "t {}", st.t);
        if st.oru.parked {
            assert!(st.clearance_serviced.is_finite());
            assert_eq!(st.arrays[s.oru.array].0, s.oru.swap.service_q);
        }
    }
    assert!(carried[0] > 0 && carried[1] > 0, "{carried:?}");
    let md = station::summarise(&s, &p, &run);
    assert!(
        md.notes
            .iter()
            .any(|n| n.contains("the spare bolted on the mount"))
    );
    assert!(
        md.notes
            .iter()
            .any(|n| n.starts_with("At the end: the spare bolted"))
    );
}

/// The default run (10 s steps, one orbit) keeps the 1 m keep-out between the steps too: an
/// array angle is chosen at each sample to clear the servicer's planned sweep over the steps on
/// either side, so the arm sweeping ~1.2 m in one step cannot pass inside the keep-out unseen
/// (before this, the step ending at 10.5 min came to 0.775 m). The between-step check verifies.
#[test]
fn the_default_station_run_keeps_the_keep_out_between_steps() {
    let p = StationParams {
        frames: 0,
        ..StationParams::default()
    };
    let s = station::setup(&p).expect("the study sets up");
    let run = station::simulate(&s, &p).expect("the simulation runs");
    let worst = run
        .steps
        .iter()
        .map(|st| st.between_clearance)
        .fold(f64::INFINITY, f64::min);
    assert!(
        worst >= p.keep_out_m,
        "closest approach between steps {worst} m"
    );
    for st in &run.steps {
        assert!(!st.blocked, "t {}", st.t);
        assert!(st.clearance_arrays >= p.keep_out_m, "t {}", st.t);
    }
    let md = station::summarise(&s, &p, &run);
    assert!(
        md.notes
            .iter()
            .any(|n| n.contains("the keep-out holds between every pair of steps")),
        "{:?}",
        md.notes
    );
}

/// The headless frames draw the ORUs where the swap has them, not where the scene places them:
/// the model the display draws for a frame mid-carry has each ORU object at the pose
/// `station.csv` gives for that time (the data path to the renderer, no pixels), and that is
/// metres from its scene position.
#[test]
fn headless_frames_draw_the_orus_where_the_swap_has_carried_them() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = StationParams {
        orbits: 0.6,
        ..quick_station()
    };
    let run = station::run(&p, dir.path(), &mut Vec::new()).expect("the study runs");
    let s = station::setup(&p).expect("the study sets up");
    let (cols, rows) = read_csv(&dir.path().join("station.csv"));
    let args = station::frame_args(&s, &run, dir.path(), 12);
    let scene = robosim_display::app::played_snapshot(&args, 0).expect("the first frame");
    let mut checked = 0;
    for (i, prefix) in [(0, "failed_oru"), (1, "spare_oru")] {
        let (object, in_oru) = &s.oru.swap.objects[i];
        // a step where this ORU is in the servicer's grip
        let k = run
            .steps
            .iter()
            .position(|st| {
                let h = if i == 0 { st.oru.failed } else { st.oru.spare };
                matches!(h, station::Held::Carried(_))
            })
            .expect("the ORU is carried");
        let k = k + 1; // one step into the carry
        let snap = robosim_display::app::played_snapshot(&args, k).expect("the frame's model");
        let at = robosim_display::app::find_path(&snap, object)
            .unwrap_or_else(|| panic!("no object {object}"));
        let w = snap.world_pose(at);
        let obj = nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(w[3], w[7], w[11]),
            nalgebra::UnitQuaternion::from_matrix(&nalgebra::Matrix3::new(
                w[0], w[1], w[2], w[4], w[5], w[6], w[8], w[9], w[10],
            )),
        );
        // the ORU frame the object stands for, against the CSV's row of that step
        let oru = (obj * in_oru.inverse()).translation.vector;
        let row = &rows[k];
        assert_eq!(row[col(&cols, "t_s")], run.steps[k].t);
        let csv = nalgebra::Vector3::new(
            row[col(&cols, &format!("{prefix}_x_m"))],
            row[col(&cols, &format!("{prefix}_y_m"))],
            row[col(&cols, &format!("{prefix}_z_m"))],
        );
        assert!(
            (oru - csv).norm() < 1e-6,
            "{object} at t {}: drawn at {oru:?}, station.csv {csv:?}",
            run.steps[k].t
        );
        // and not where the scene places it
        let at0 = robosim_display::app::find_path(&scene, object).expect("in the scene");
        let w0 = scene.world_pose(at0);
        let moved = nalgebra::Vector3::new(w[3] - w0[3], w[7] - w0[7], w[11] - w0[11]).norm();
        assert!(moved > 0.1, "{object} drawn {moved} m from its scene place");
        checked += 1;
    }
    assert_eq!(checked, 2);
    // a track that names no object is refused by name
    let mut bad = args.clone();
    bad.poses[0].object = "port_solar/gimbal/no_such".into();
    match robosim_display::app::played_snapshot(&bad, 0) {
        Ok(_) => panic!("a track naming no object was accepted"),
        Err(e) => assert!(e.0.contains("no_such"), "{}", e.0),
    }
}

/// Issue 34 item 15: `robosim study station --step 0.000001` tried to allocate 2.7 TB. The step
/// budget refuses it before the loop, naming the count, the budget and how to raise it.
#[test]
fn station_study_with_a_microsecond_step_is_refused_by_the_step_budget() {
    let p = StationParams {
        step_s: 1e-6,
        ..quick_station()
    };
    let s = station::setup(&p).expect("the study sets up");
    let e = station::simulate(&s, &p)
        .err()
        .expect("over the step budget")
        .to_string();
    assert!(
        e.contains("time steps, over the budget of")
            && e.contains(robosim_studies::common::STEP_BUDGET_ENV)
            && e.contains("a step of 0.000001 s"),
        "{e}"
    );
}

#[test]
fn welding_study_with_a_tiny_step_is_refused_by_the_step_budget() {
    let p = WeldingParams {
        step_s: 1e-9,
        ..quick_welding()
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let mut log = Vec::new();
    let e = welding::run(&p, dir.path(), &mut log)
        .err()
        .expect("over the step budget")
        .to_string();
    assert!(e.contains("over the budget of"), "{e}");
}

fn quick_attitude() -> StationParams {
    StationParams {
        attitude: true,
        attitude_step_s: 2.0,
        ..quick_station()
    }
}

/// The attitude effect in the station study: the CMGs hold the commanded attitude, the model's
/// inertia and drag area follow the arrays, the arrays track the sun in the actual attitude,
/// the outputs carry the attitude's columns and rows; without `--attitude` none of it is there.
#[test]
fn station_attitude_is_held_by_the_cmgs_with_the_model_inertia() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = quick_attitude();
    let mut log = Vec::new();
    let run = station::run(&p, dir.path(), &mut log).expect("the study runs");
    let a = run.attitude.as_ref().expect("the attitude was integrated");
    eprintln!("{}", String::from_utf8_lossy(&log));
    // the model's mass: every robot link's and the middle truss's
    let s = station::setup(&p).expect("the study sets up");
    let robots: f64 = s
        .bodies
        .iter()
        .flat_map(|b| b.robot.joints.iter().map(|j| j.mass))
        .sum();
    let truss = s
        .scene
        .solids
        .iter()
        .filter_map(|x| x.solid.mass.map(|m| m.mass))
        .sum::<f64>();
    assert!(
        (a.mass.mass - robots - truss).abs() < 1e-6 * a.mass.mass,
        "{} against {}",
        a.mass.mass,
        robots + truss
    );
    assert!(truss > 0.0, "the middle truss has a mass");
    // recomputed at every step; the inertia and drag area change as the arrays turn
    assert_eq!(
        a.recomputes,
        run.steps.len() + 1,
        "one at the start and one per step"
    );
    let att: Vec<_> = run.steps.iter().filter_map(|st| st.attitude).collect();
    assert_eq!(att.len(), run.steps.len());
    let spread = |f: &dyn Fn(&station::attitude::AttStep) -> f64| {
        let (lo, hi) = att
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        (hi - lo) / hi
    };
    assert!(
        spread(&|x| x.drag_area_m2) > 0.05,
        "drag area follows the arrays"
    );
    assert!(
        spread(&|x| x.inertia[2]) > 1e-4,
        "inertia follows the arrays"
    );
    // held: between desaturations the error stays small, and the momentum is within capacity
    assert!(a.max_error_quiet_deg < 1.0, "{}", a.max_error_quiet_deg);
    assert!(att.iter().all(|x| x.h_fraction <= 1.0));
    // the sun tracked in the actual attitude: the incidence of a tracking outboard stays small
    let worst = run
        .steps
        .iter()
        .flat_map(|st| st.arrays.iter().filter(|x| !x.2).map(|x| x.1))
        .fold(1.0f64, f64::min);
    assert!(worst.is_finite());
    let (cols, rows) = read_csv(&dir.path().join("station.csv"));
    for c in [
        "attitude_error_deg",
        "cmg_capacity_fraction",
        "desaturating",
        "drag_area_m2",
    ] {
        assert!(cols.iter().any(|x| x == c), "{c} in {cols:?}");
    }
    assert_eq!(rows.len(), run.steps.len());
    let md = std::fs::read_to_string(dir.path().join("station_summary.md")).expect("summary");
    assert!(md.contains("mean interval between desaturations"), "{md}");
    // without --attitude: no attitude, no columns
    let dir2 = tempfile::tempdir().expect("temp dir");
    let plain = station::run(&quick_station(), dir2.path(), &mut Vec::new()).expect("runs");
    assert!(plain.attitude.is_none() && plain.steps.iter().all(|s| s.attitude.is_none()));
    let (cols, _) = read_csv(&dir2.path().join("station.csv"));
    assert!(!cols.iter().any(|x| x == "attitude_error_deg"));
}

/// Issue 39 item 8: the quick station study (a quarter orbit at β = 20°) said "Eclipses: none
/// (β beyond the critical angle)" — the critical angle at 400 km is 70.2°; the quarter orbit
/// just does not reach the shadow. Each case says its own reason.
#[test]
fn no_eclipse_says_whether_beta_or_the_run_length_is_why() {
    use robosim_simulator::orbit::Orbit;
    let low = Orbit::new(400e3, 20f64.to_radians()).expect("orbit");
    let text = robosim_studies::station::no_eclipse_reason(&low, 0.25);
    assert!(
        text.contains("β = 20.0° is below the critical angle 70.2°")
            && text.contains("the 0.25 orbits run does not reach the shadow"),
        "{text}"
    );
    let high = Orbit::new(400e3, 75f64.to_radians()).expect("orbit");
    let text = robosim_studies::station::no_eclipse_reason(&high, 1.0);
    assert!(
        text.contains("β = 75.0° is beyond the critical angle 70.2°"),
        "{text}"
    );
}

// ---------------------------------------------------------------- loads and their scheduler
// (issue 38 items 3-4)

fn loads_station(orbits: f64, scheduling: station::scheduler::Scheduling) -> StationParams {
    StationParams {
        step_s: 60.0,
        orbits,
        frames: 0,
        compare_off: false,
        scheduling,
        ..StationParams::default()
    }
}

/// Every joule is accounted for: over every interval and over the run, produced = served +
/// shunted + Δstored + losses; the stored energy's change is the battery's; no load is served
/// more than it asks; the CSV carries each load's columns and the ledger's.
#[test]
fn station_energy_bookkeeping_closes_over_a_run() {
    use station::scheduler::Scheduling;
    let dir = tempfile::tempdir().expect("temp dir");
    let p = loads_station(1.3, Scheduling::Off);
    let run = station::run(&p, dir.path(), &mut Vec::new()).expect("the study runs");
    let f = run.totals.flow;
    assert!(f.produced_j > 1e9, "{f:?}");
    assert!(f.imbalance_j().abs() < 1e-6 * f.produced_j, "{f:?}");
    let mut sum = robosim_simulator::power::Flow::default();
    for st in &run.steps {
        let l = &st.loads;
        assert!(
            l.flow.imbalance_j().abs() < 1e-6 * l.flow.produced_j.max(1.0),
            "{l:?}"
        );
        for (d, s) in l.demand_w.iter().zip(&l.served_w) {
            assert!(*s <= d + 1e-9 && *s >= 0.0, "{l:?}");
        }
        // the loads' served power is the interval's served energy
        if l.interval_s > 0.0 {
            let served: f64 = l.served_w.iter().sum::<f64>() * l.interval_s;
            assert!(
                (served - l.flow.served_j).abs() < 1e-6 * served.max(1.0),
                "{l:?}"
            );
        }
        sum.add(&l.flow);
    }
    assert!((sum.produced_j - f.produced_j).abs() < 1e-3);
    // the stored energy's change over the run is the battery's
    let de = (run.steps.last().expect("steps").soc - p.soc0) * p.battery_j;
    assert!(
        (f.stored_j - de).abs() < 1e-3 * p.battery_j,
        "{} {de}",
        f.stored_j
    );
    // a run that fills the battery shunts, and charging loses 10 %
    assert!(f.shunted_j > 0.0 && f.losses_j > 0.0, "{f:?}");
    let (cols, rows) = read_csv(&dir.path().join("station.csv"));
    for c in [
        "air_crew_served_kw",
        "air_experiment_shed",
        "materials_furnace_running",
        "shunted_kw",
        "battery_losses_kw",
        "unserved_kw",
    ] {
        col(&cols, c);
    }
    let (pr, sv, sh, bi, lo) = (
        col(&cols, "produced_kw"),
        col(&cols, "served_kw"),
        col(&cols, "shunted_kw"),
        col(&cols, "battery_in_kw"),
        col(&cols, "battery_losses_kw"),
    );
    for r in &rows {
        assert!(
            (r[pr] - (r[sv] + r[sh] + r[bi] + r[lo])).abs() < 1e-6,
            "{r:?}"
        );
    }
    let md = std::fs::read_to_string(dir.path().join("station_summary.md")).expect("summary");
    assert!(
        md.contains("ledger: produced − (served + shunted + Δstored + losses)"),
        "{md}"
    );
}

/// The scheduler's worth, measured: over three orbits the unscheduled station (every load at
/// full, every experiment started when asked for) runs its battery empty and leaves vital
/// loads unserved while sheddable ones draw; with station_power.clp no vital load is ever
/// unserved, nothing is served to a sheddable load while a vital one is short, and every
/// decision names its rule and reason.
#[test]
fn the_scheduler_keeps_vital_loads_served_where_the_unscheduled_station_does_not() {
    use station::power_report::vital_unserved_while_sheddable_served_j;
    use station::scheduler::Scheduling;
    if robosim_rules::skipped_without_clips("the_scheduler_keeps_vital_loads_served") {
        return;
    }
    let s = station::setup(&loads_station(3.0, Scheduling::On)).expect("setup");
    let on = station::simulate(&s, &loads_station(3.0, Scheduling::On)).expect("runs");
    let off = station::simulate(&s, &loads_station(3.0, Scheduling::Off)).expect("runs");
    let v = robosim_simulator::consumers::Priority::Vital as usize;
    let vital_unserved = |r: &station::Run| r.totals.demanded_j[v] - r.totals.served_j[v];
    assert!(vital_unserved(&off) > 3.6e6, "off: {:?}", off.totals);
    assert!(vital_unserved_while_sheddable_served_j(&off) > 0.0);
    assert!(vital_unserved(&on) < 1e-3, "on: {:?}", on.totals);
    assert_eq!(vital_unserved_while_sheddable_served_j(&on), 0.0);
    assert!(on.rules_ran && !on.decisions.is_empty());
    for d in &on.decisions {
        assert!(
            d.rule.starts_with("station_power sp-") && !d.reason.is_empty(),
            "{d:?}"
        );
    }
    // seed §4.2: the crew modules' air control is never reduced; hygiene goes before the
    // experiment modules' air
    assert!(!on.decisions.iter().any(|d| d.target == "air_crew"));
    let first = |rule: &str| on.decisions.iter().position(|d| d.rule.ends_with(rule));
    if let Some(air) = first("sp-reduce-experiment-air") {
        assert!(
            first("sp-defer-hygiene").is_some_and(|h| h < air),
            "{:?}",
            on.decisions
        );
    }
}

/// Seed §4.2 constraint 2: a microgravity experiment asked for just before a docking event is
/// moved after it (the decision says so), and no sensitive run is disturbed by it; without the
/// scheduler it runs through the docking.
#[test]
fn a_microgravity_experiment_is_moved_out_of_a_docking_window() {
    use station::scheduler::Scheduling;
    if robosim_rules::skipped_without_clips("a_microgravity_experiment_is_moved") {
        return;
    }
    let p = |sch| StationParams {
        dockings: vec![[1500.0, 3300.0]],
        // the furnace alone, asked for at 20 min
        experiments: robosim_simulator::consumers::default_experiments()
            .into_iter()
            .filter(|e| e.name == "materials_furnace")
            .collect(),
        ..loads_station(1.0, sch)
    };
    let on = station::run(
        &p(Scheduling::On),
        tempfile::tempdir().expect("dir").path(),
        &mut Vec::new(),
    )
    .expect("runs");
    let moved = on
        .decisions
        .iter()
        .find(|d| d.rule.ends_with("sp-move-experiment") && d.target == "materials_furnace")
        .unwrap_or_else(|| panic!("not moved: {:?}", on.decisions));
    assert!(moved.reason.contains("3300"), "{moved:?}");
    assert_eq!(on.loads.exps[0].disturbed_s, 0.0);
    assert!(on.loads.exps[0].run_s > 0.0, "it ran after the docking");
    let start = on
        .steps
        .iter()
        .find(|st| st.loads.demand_w.last().is_some_and(|w| *w > 0.0))
        .map(|st| st.t)
        .expect("started");
    assert!(start >= 3300.0, "{start}");
    let off = station::simulate(
        &station::setup(&p(Scheduling::Off)).expect("setup"),
        &p(Scheduling::Off),
    )
    .expect("runs");
    assert!(off.loads.exps[0].disturbed_s > 0.0, "{:?}", off.loads.exps);
}

/// Item 4: a failed potable-water pump rings its alarms; eclss_guard.clp diagnoses them (the
/// diagnosis names the pump), isolates it and brings the spare on line; the consumer draws its
/// standby share while the process stands still, then catches up; the scheduler sees the fault
/// and its changed demand (a decision with its reason) — all recorded in order.
#[test]
fn a_failed_pump_is_diagnosed_replaced_and_the_scheduler_reacts() {
    use station::scheduler::Scheduling;
    if robosim_rules::skipped_without_clips("a_failed_pump_is_diagnosed") {
        return;
    }
    let p = StationParams {
        step_s: 30.0,
        fault: Some(station::faults::FaultSpec::parse("pump_failure@1500").expect("spec")),
        ..loads_station(1.0, Scheduling::On)
    };
    let dir = tempfile::tempdir().expect("dir");
    let run = station::run(&p, dir.path(), &mut Vec::new()).expect("runs");
    let f = run.fault.as_ref().expect("the fault");
    let at = |rule: &str| {
        run.decisions
            .iter()
            .find(|d| d.rule == rule)
            .unwrap_or_else(|| panic!("no {rule}: {:?}", run.decisions))
    };
    let diag = at("eclss_guard diagnose");
    assert!(
        diag.target.contains("water_pump") && diag.t >= 1500.0,
        "{diag:?}"
    );
    let iso = at("eclss_guard isolate");
    let spare = at("eclss_guard reconfigure");
    assert_eq!(spare.target, "water_pump_spare");
    assert!(diag.t <= iso.t && iso.t <= spare.t);
    assert_eq!(f.spare_at, Some(spare.t));
    let react = at("station_power sp-fault-reaction");
    assert!(
        react.target == "potable_water" && react.reason.contains("water_pump"),
        "{react:?}"
    );
    // the potable water's demand: full before, standby after the fault, twice after the spare
    let pw = run
        .loads
        .names()
        .iter()
        .position(|n| *n == "potable_water")
        .expect("potable water");
    let demand = |t: f64| {
        run.steps
            .iter()
            .find(|st| st.t >= t)
            .map(|st| st.loads.demand_w[pw])
            .expect("a step")
    };
    assert!((demand(1400.0) - 5e3).abs() < 1e-6);
    assert!((demand(1530.0) - 500.0).abs() < 1e-6, "{}", demand(1530.0));
    let catching = spare.t + station::faults::SPARE_START_S + 60.0;
    assert!(
        (demand(catching) - 10e3).abs() < 1e-6,
        "{}",
        demand(catching)
    );
    let text = std::fs::read_to_string(dir.path().join("station_decisions.csv")).expect("csv");
    assert!(
        text.contains("eclss_guard isolate") && text.contains("water_pump"),
        "{text}"
    );
}
