//! Issue 17 with real processes: the two study scenes run as daemons (`robosim up … --with
//! simulator`) — the station's declared orbit, sun tracking and power simulated by the daemon's
//! space stage, the welding cell without them — and `robosim study` from the command line.
//! Each test has its own ROBOSIM_HOME and session name and stops what it started.

use crate::common;

use common::{Procs, ROBOSIM, wait_for};
use serde_json::{Value, json};
use std::process::{Command, Output};

/// A session started with `robosim up`: its processes are not this test's children, so
/// `robosim down` stops them when the guard drops (also when an assertion failed).
struct Up<'a>(&'a Procs);

impl Drop for Up<'_> {
    fn drop(&mut self) {
        let _ = run(self.0, &["down"]);
    }
}

fn run(p: &Procs, args: &[&str]) -> Output {
    Command::new(ROBOSIM)
        .args(args)
        .args(["--session", &p.name])
        .env("ROBOSIM_HOME", p.home.path())
        .env("IOX2_LOG_LEVEL", "Error")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("robosim runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn ok(p: &Procs, args: &[&str]) -> String {
    let o = run(p, args);
    assert!(
        o.status.success(),
        "robosim {args:?} failed:\n{}\n{}",
        text(&o.stdout),
        text(&o.stderr)
    );
    text(&o.stdout)
}

/// `simctl get` once the daemon answers.
fn get(p: &Procs) -> Value {
    wait_for("the simulator's state", || {
        let o = run(p, &["simctl", "get"]);
        if !o.status.success() {
            return None;
        }
        serde_json::from_slice(&o.stdout).ok()
    })
}

/// Pauses the (realtime) daemon, steps `n` steps and waits until they are taken.
fn step(p: &Procs, n: u64) -> Value {
    let before = get(p)["steps"].as_u64().expect("steps");
    assert_eq!(
        ok(p, &["simctl", &json!({"cmd": "step", "n": n}).to_string()]),
        "ok\n"
    );
    wait_for("the steps taken", || {
        let s = get(p);
        (s["state"] == "paused" && s["steps"].as_u64() >= Some(before + n)).then_some(s)
    })
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// The station scene as a daemon: the space stage runs (orbit clock, sun, eclipse), the
/// arrays' gimbals turn to the sun through their own pipelines and follow it as the orbit goes
/// on, power and battery are in `get`; the angles are the study's tracking solution at the
/// same orbit angle.
#[test]
fn the_station_scene_runs_its_orbit_sun_tracking_and_power_in_the_daemon() {
    let p = Procs::new("stsp");
    let _up = Up(&p);
    ok(&p, &["up", "space_station_study", "--with", "simulator"]);
    let s0 = get(&p);
    assert_eq!(ok(&p, &["simctl", r#"{"cmd": "pause"}"#]), "ok\n");
    let space = &s0["space"];
    assert!(space.is_object(), "no space stage in {s0}");
    assert_eq!(space["sun_tracking"], true);
    assert!((space["orbit"]["altitude_m"].as_f64().expect("altitude") - 400e3).abs() < 1e-6);
    let names: Vec<&str> = space["arrays"]
        .as_array()
        .expect("arrays")
        .iter()
        .map(|a| a["robot"].as_str().expect("robot"))
        .collect();
    for n in [
        "port_outboard",
        "starboard_outboard",
        "port_solar",
        "starboard_solar",
    ] {
        assert!(names.contains(&n), "{names:?}");
    }
    // the arrays start at rest at q = 0 and slew to the sun at the kinematic speed limit
    // (1 rad/s): 4 s of steps bring every one there
    let dt = s0["dt_s"].as_f64().expect("dt");
    let s1 = step(&p, (4.0 / dt).round() as u64);
    let sp = &s1["space"];
    let t1 = sp["t_s"].as_f64().expect("t");
    assert!((t1 - s1["t_s"].as_f64().expect("t")).abs() < 1e-9);
    let study = robosim_studies::station::setup(&robosim_studies::station::StationParams {
        frames: 0,
        ..Default::default()
    })
    .expect("the study sets up");
    let theta = study.orbit.angle(0.0, t1);
    assert!((sp["orbit"]["angle_deg"].as_f64().expect("angle") - theta.to_degrees()).abs() < 1e-9);
    let sun = study.orbit.sun_body(theta);
    let sun_json = floats(&sp["sun_body"]);
    assert!((nalgebra::Vector3::new(sun_json[0], sun_json[1], sun_json[2]) - sun).norm() < 1e-12);
    assert_eq!(sp["eclipse"], false, "orbit noon");
    let alpha_at = |s: &Value| -> f64 {
        let a = s["space"]["arrays"]
            .as_array()
            .expect("arrays")
            .iter()
            .find(|a| a["robot"] == "port_outboard")
            .expect("port_outboard");
        floats(&a["q"])[0]
    };
    for a in sp["arrays"].as_array().expect("arrays") {
        let name = a["robot"].as_str().expect("name");
        let q = floats(&a["q"]);
        // the same joints are what the simulator publishes for that robot
        let robot = s1["robots"]
            .as_array()
            .expect("robots")
            .iter()
            .find(|r| r["name"] == name)
            .expect("the array is a simulated robot");
        assert_eq!(floats(&robot["q"]), q);
        assert!(robot["target"].is_array(), "{name} is driven: {robot}");
        // the study's tracking at the same sun, from the same angles
        let ai = study
            .arrays
            .iter()
            .position(|x| study.bodies[x.body].name == name)
            .expect("the study has the array");
        let (want, cos) =
            robosim_studies::station::track(&study, &study.arrays[ai], &q, &sun, 1e-6);
        let inc = a["incidence_deg"].as_f64().expect("incidence");
        assert!(
            (inc - cos.clamp(-1.0, 1.0).acos().to_degrees()).abs() < 0.05,
            "{name}: incidence {inc}° against the study's {}°",
            cos.acos().to_degrees()
        );
        for (x, y) in q.iter().zip(&want) {
            assert!((x - y).abs() < 1e-3, "{name}: {q:?} against {want:?}");
        }
        if q.len() == 2 {
            // two axes face the sun
            assert!(inc < 0.05, "{name}: {inc}°");
        }
        assert!(a["power_w"].as_f64().expect("power") > 0.0);
    }
    // power is the sum over the arrays, the battery charges (power above the 100 kW load)
    let pw = &sp["power"];
    let total: f64 = sp["arrays"]
        .as_array()
        .expect("arrays")
        .iter()
        .map(|a| a["power_w"].as_f64().expect("power"))
        .sum();
    assert!((pw["power_w"].as_f64().expect("power") - total).abs() < 1e-6);
    assert!(
        total > 100e3 && total <= 1584.0 * 0.14 * 1361.0 + 1e-6,
        "{total} W"
    );
    assert!(pw["battery_soc"].as_f64().expect("soc") > 0.8, "{pw}");
    assert!(pw["energy_kwh"].as_f64().expect("energy") > 0.0);

    // the orbit goes on: the sun turns about body y at the orbit rate, and the outboard's
    // alpha joint (about the truss, body y) follows it
    let a1 = alpha_at(&s1);
    let s2 = step(&p, (2.0 / dt).round() as u64);
    let t2 = s2["space"]["t_s"].as_f64().expect("t");
    let a2 = alpha_at(&s2);
    let turned = study.orbit.rate() * (t2 - t1);
    assert!(
        ((a2 - a1).abs() - turned).abs() < 2.5e-4,
        "alpha moved {} rad, the sun {turned} rad",
        a2 - a1
    );
    assert!(s2["space"]["power"]["battery_soc"].as_f64() > pw["battery_soc"].as_f64());
}

/// The welding cell as a daemon: it starts and steps; it declares no orbit, so there is no
/// space stage and nothing in `get` for one.
#[test]
fn the_welding_scene_runs_in_the_daemon_without_a_space_stage() {
    let p = Procs::new("stwd");
    let _up = Up(&p);
    ok(&p, &["up", "downhand_welding_study", "--with", "simulator"]);
    get(&p);
    assert_eq!(ok(&p, &["simctl", r#"{"cmd": "pause"}"#]), "ok\n");
    let s = step(&p, 20);
    assert!(s.get("space").is_none(), "{s}");
    // nor a swap stage: the welding scene declares no oru_swap
    assert!(s.get("swap").is_none(), "{s}");
    let robots = s["robots"].as_array().expect("robots");
    let names: Vec<&str> = robots
        .iter()
        .map(|r| r["name"].as_str().unwrap_or(""))
        .collect();
    assert!(
        names.contains(&"arm") && names.contains(&"positioner"),
        "{names:?}"
    );
    for r in robots {
        let stages: Vec<&str> = r["stages"]
            .as_array()
            .expect("stages")
            .iter()
            .map(|x| x.as_str().unwrap_or(""))
            .collect();
        assert!(stages.contains(&"collision"), "{stages:?}");
        assert_eq!(r["error"], Value::Null, "{r}");
        assert_eq!(r["contact"], false, "the start pose is clear: {r}");
    }
}

/// `robosim study welding` from the command line writes what docs/studies.md says; a bad
/// parameter is refused by name with a failing exit status.
#[test]
fn robosim_study_runs_from_the_command_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("w");
    let o = Command::new(ROBOSIM)
        .args(["study", "welding", "--out"])
        .arg(&out)
        .args([
            "--seam",
            "circle",
            "--step",
            "1",
            "--speed",
            "20",
            "--frames",
            "0",
            "--accuracy",
            "false",
        ])
        .output()
        .expect("robosim study");
    assert!(o.status.success(), "{}", text(&o.stderr));
    let said = text(&o.stdout);
    assert!(
        said.contains("welding study: 1 seam(s) (circle 628 mm)"),
        "{said}"
    );
    for f in [
        "welding.csv",
        "arm.traj",
        "positioner.traj",
        "welding_summary.md",
        "welding_summary.csv",
        "welding_summary.png",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    assert!(!out.join("welding_accuracy.md").exists());
    let o = Command::new(ROBOSIM)
        .args(["study", "station", "--out"])
        .arg(dir.path().join("s"))
        .args(["--altitude", "-400", "--frames", "0"])
        .output()
        .expect("robosim study");
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("altitude"), "{}", text(&o.stderr));
    assert!(!dir.path().join("s").join("station.csv").exists());
}

/// The station scene's declared ORU swap runs in the daemon: stepped in lock-step through the
/// whole task, the ORU objects the daemon publishes are where the one-command study's
/// station.csv has them at the same simulated times (both run the same plan,
/// `robosim_simulator::swap`), and they end on the mount and at the stowage.
#[test]
fn the_station_daemon_carries_out_the_oru_swap_as_the_study_does() {
    use robosim_studies::station::{self, Held, StationParams};
    // the study, one command, in this process: 0.45 orbit covers the task (5 to 37 min)
    let dir = tempfile::tempdir().expect("temp dir");
    let sp = StationParams {
        orbits: 0.45,
        frames: 0,
        ..StationParams::default()
    };
    station::run(&sp, dir.path(), &mut Vec::new()).expect("the study runs");
    let study = station::setup(&sp).expect("the study sets up");
    let csv = std::fs::read_to_string(dir.path().join("station.csv")).expect("station.csv");
    let mut lines = csv.lines();
    let cols: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let col = |n: &str| cols.iter().position(|c| *c == n).expect(n);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().expect("a number")).collect())
        .collect();
    let row_at = |t: f64| rows.iter().find(|r| (r[col("t_s")] - t).abs() < 1e-6);

    let p = Procs::new("stsw");
    let _up = Up(&p);
    ok(&p, &["up", "space_station_study", "--with", "simulator"]);
    get(&p);
    assert_eq!(ok(&p, &["simctl", r#"{"cmd": "pause"}"#]), "ok\n");
    let s0 = get(&p);
    let dt = s0["dt_s"].as_f64().expect("dt");
    assert_eq!(dt, 1.0, "the scene's declared kinematic step");
    let sw = &s0["swap"];
    assert!(sw.is_object(), "no swap stage in {s0}");
    let end = sw["end_s"].as_f64().expect("end");
    let plan = station::schedule(&study, sp.task_start_s).expect("the plan");
    assert!((end - plan.points.last().expect("points").0).abs() < 1e-9);
    let oru = |s: &Value, i: usize| -> (String, nalgebra::Vector3<f64>) {
        let o = &s["swap"]["orus"][i];
        let v = floats(&o["position_m"]);
        (
            o["held"].as_str().expect("held").to_owned(),
            nalgebra::Vector3::new(v[0], v[1], v[2]),
        )
    };
    // step to every minute of the task and past its end, comparing with the study's rows
    let mut t = s0["t_s"].as_f64().expect("t");
    let mut compared = [0, 0];
    let mut misses = Vec::new();
    let mut minutes = 0;
    let mut last = s0.clone();
    let mut checkpoint = (t / 60.0).ceil() * 60.0;
    while checkpoint <= end + 120.0 {
        let n = ((checkpoint - t) / dt).round() as u64;
        let s = if n > 0 { step(&p, n) } else { get(&p) };
        t = s["t_s"].as_f64().expect("t");
        assert!((t - checkpoint).abs() < 1e-6, "{t} against {checkpoint}");
        let r = row_at(t).unwrap_or_else(|| panic!("no study row at {t} s"));
        let parked = s["swap"]["parked"].as_bool().expect("parked");
        assert_eq!(parked, r[col("parked")] == 1.0, "t {t}: parked");
        // the servicer where the plan has it, every minute: the daemon's pipelines see the
        // other robots where they are simulated (the parked array at its service angle), so
        // nothing holds it back
        let robot = s["robots"]
            .as_array()
            .and_then(|r| r.iter().find(|r| r["name"] == "servicer"))
            .expect("the servicer");
        let q_now = floats(&robot["q"]);
        let q_plan = station::servicer_at(&plan.points, t).0;
        if q_now.iter().zip(&q_plan).any(|(a, b)| (a - b).abs() > 1e-6) {
            misses.push(format!(
                "t {t}: servicer at {q_now:?}, the plan's {q_plan:?} (contact {}, contact_steps {})",
                robot["contact"], robot["contact_steps"]
            ));
        }
        minutes += 1;
        for (i, prefix) in ["failed_oru", "spare_oru"].iter().enumerate() {
            let (held, at) = oru(&s, i);
            // on the mount of a tracking array the study may feather where the daemon does not:
            // compared where the plan alone says where it is
            if held == "on_mount" && !parked {
                continue;
            }
            let want = nalgebra::Vector3::new(
                r[col(&format!("{prefix}_x_m"))],
                r[col(&format!("{prefix}_y_m"))],
                r[col(&format!("{prefix}_z_m"))],
            );
            if (at - want).norm() >= 1e-3 {
                misses.push(format!(
                    "t {t}: {prefix} {held} at {at:?}, the study's {want:?} ({:.4} m); servicer q {:?}",
                    (at - want).norm(),
                    s["robots"]
                        .as_array()
                        .and_then(|r| r.iter().find(|r| r["name"] == "servicer"))
                        .map(|r| (r["q"].clone(), r["contact_steps"].clone()))
                ));
            }
            compared[i] += 1;
        }
        last = s;
        checkpoint += 60.0;
    }
    assert!(misses.is_empty(), "{}", misses.join("\n"));
    assert!(compared[0] > 10 && compared[1] > 10, "{compared:?}");
    // every minute from the first checkpoint to two minutes past the end was compared
    assert!(
        minutes as f64 >= (end + 120.0 - s0["t_s"].as_f64().expect("t")) / 60.0 - 1.0,
        "{minutes} minutes compared"
    );
    // the end: the failed ORU set down at the stowage, the spare bolted on the mount of the
    // array as the daemon has it now, every event taken
    let events: Vec<&str> = last["swap"]["events"]
        .as_array()
        .expect("events")
        .iter()
        .map(|e| e["event"].as_str().expect("event"))
        .collect();
    assert_eq!(
        events,
        [
            "Park",
            "GraspFailed",
            "StowFailed",
            "GraspSpare",
            "InstallSpare",
            "Unpark"
        ]
    );
    let [_, _, stow] = station::sites(&study);
    let (held, failed) = oru(&last, 0);
    assert_eq!(held, "set_down");
    assert!(
        (failed - stow.coords).norm() < 1e-3,
        "{failed:?} against {stow:?}"
    );
    let (held, spare) = oru(&last, 1);
    assert_eq!(held, "on_mount");
    let q_array = last["robots"]
        .as_array()
        .expect("robots")
        .iter()
        .find(|r| r["name"] == "port_solar")
        .map(|r| floats(&r["q"]))
        .expect("port_solar");
    let mount = station::oru_frame(&study, Held::OnArray, &q_array, &[]);
    assert!(
        (spare - mount.translation.vector).norm() < 1e-3,
        "{spare:?} against the mount {:?}",
        mount.translation.vector
    );
    // the object's world pose is the ORU frame with the object's offset (what is published)
    let w = floats(&last["swap"]["orus"][1]["object_world"]);
    let (_, in_oru) = &study.oru.swap.objects[1];
    let world = mount * in_oru;
    assert!((nalgebra::Vector3::new(w[3], w[7], w[11]) - world.translation.vector).norm() < 1e-3);
}

/// The daemon's pipelines see the other robots where they are simulated, not where they are
/// committed. In the welding study's cell (two robots, exact collision, a contact stops the
/// robot) the arm is driven down onto the workpiece, once with the positioner level and once
/// with it tilted by a `target` — nothing committed to the Instance Space — and once level
/// again: the arm stops where the positioner's simulated joints put the workpiece (a daemon
/// that kept the positioner at its committed, level joints stopped it at the same place all
/// three times).
#[test]
fn a_robot_driven_by_the_simulation_is_an_obstacle_where_it_is_simulated() {
    let p = Procs::new("stfo");
    let _up = Up(&p);
    ok(&p, &["up", "downhand_welding_study", "--with", "simulator"]);
    get(&p);
    assert_eq!(ok(&p, &["simctl", r#"{"cmd": "pause"}"#]), "ok\n");
    let robot = |s: &Value, name: &str| -> Value {
        s["robots"]
            .as_array()
            .and_then(|r| r.iter().find(|r| r["name"] == name))
            .cloned()
            .unwrap_or_else(|| panic!("no robot {name} in {s}"))
    };
    let s = step(&p, 1);
    let start = floats(&robot(&s, "arm")["q"]);
    for name in ["arm", "positioner"] {
        assert_eq!(
            robot(&s, name)["contact"],
            false,
            "the cell starts clear: {s}"
        );
    }
    // 3 s of motion at the pipeline's step: every move below gets where it can
    let steps = (3.0 / s["dt_s"].as_f64().expect("dt")).ceil() as u64;
    let drive = |name: &str, q: &[f64]| -> Value {
        let cmd = json!({"cmd": "target", "robot": name, "q": q}).to_string();
        assert_eq!(ok(&p, &["simctl", &cmd]), "ok\n");
        step(&p, steps)
    };
    // the shoulder forward: down onto the workpiece, where it stops in contact
    let mut down = start.clone();
    down[1] = 0.3;
    let mut stops = Vec::new();
    for tilt in [0.0, 0.8, 0.0] {
        let s = drive("positioner", &[tilt, 0.0]);
        let pos = robot(&s, "positioner");
        let at = floats(&pos["q"]);
        assert!((at[0] - tilt).abs() < 1e-9 && at[1].abs() < 1e-9, "{pos}");
        assert_eq!(pos["contact"], false, "{pos}");
        let arm = robot(&drive("arm", &down), "arm");
        assert_eq!(arm["contact"], true, "tilt {tilt}: {arm}");
        let q = floats(&arm["q"]);
        assert!(q[1] < down[1], "tilt {tilt}: stopped short: {arm}");
        stops.push(q[1]);
        // back up to the start, clear
        let arm = robot(&drive("arm", &start), "arm");
        let back = floats(&arm["q"]);
        assert!(
            back.iter().zip(&start).all(|(a, b)| (a - b).abs() < 1e-9),
            "{arm}"
        );
        assert_eq!(arm["contact"], false, "{arm}");
    }
    eprintln!("the shoulder stopped at {stops:?} rad (level, tilted 0.8 rad, level)");
    assert_eq!(stops[0], stops[2], "level twice, the same stop");
    assert!(
        (stops[0] - stops[1]).abs() > 0.02,
        "the tilted positioner stops the arm elsewhere: {stops:?}"
    );
}
