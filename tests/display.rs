//! The display, end to end on the headless software adapter (Mesa llvmpipe on CI):
//! golden images of the PUMA 560 in two configurations and the Space Station; a wrong camera
//! and a missing object failing the same comparison; a session display that, when a writer in
//! another process moves one link, draws it in its next frame having uploaded that link's
//! transforms only; trajectory playback of the welding cell's two robots; the window under
//! Xvfb with scripted knob keys and a pick; and clear errors for bad input.
//!
//! Golden images live in tests/golden; `ROBOSIM_BLESS=1 cargo test -p robosim --test robosim display::` rewrites
//! them from this machine's renderer (look at them before committing).

use nalgebra::Point3;
use robosim_display::{Camera, Renderer, RgbaImage, Tolerance, compare};
use robosim_instance_space::{Client, Kind, Reader, Transaction};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

use common::{Procs, ROBOSIM, wait_for};

const PUMA_VIEW: [&str; 6] = [
    "--from",
    "-1.2,1.4,1.1",
    "--at",
    "0.1,0,0.55",
    "--size",
    "320x240",
];

fn robosim(args: &[&str]) -> Output {
    Command::new(ROBOSIM)
        .args(args)
        .output()
        .expect("run robosim")
}

fn render(out: &Path, args: &[&str]) {
    render_with(out, args, 4);
}

/// `samples` 1 turns multisampling off: another rasterization of the same picture.
fn render_with(out: &Path, args: &[&str], samples: u32) {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    let out_s = out.to_string_lossy().into_owned();
    all.extend(["--out", &out_s]);
    let o = Command::new(ROBOSIM)
        .args(&all)
        .env("ROBOSIM_DISPLAY_SAMPLES", samples.to_string())
        .output()
        .expect("run robosim");
    assert!(
        o.status.success(),
        "robosim {all:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn golden(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name)
}

fn load(p: &Path) -> RgbaImage {
    RgbaImage::load_png(p).unwrap_or_else(|e| panic!("{e}"))
}

/// Renders `args` and compares with the golden image `name` (rewritten under ROBOSIM_BLESS).
/// Also without multisampling: a different rasterization (every silhouette pixel changes)
/// that the tolerance must absorb, as it must another software-renderer version's.
fn check_golden(dir: &Path, name: &str, args: &[&str], tol: &Tolerance) {
    let out = dir.join(name);
    render(&out, args);
    let g = golden(name);
    if std::env::var_os("ROBOSIM_BLESS").is_some() {
        std::fs::copy(&out, &g).expect("bless");
        return;
    }
    let d = compare(&load(&out), &load(&g), tol).expect("same size");
    assert!(
        d.within(tol),
        "{name}: {d:?} exceeds {tol:?}; this run's image: {}",
        out.display()
    );
    let aliased = dir.join(format!("aliased-{name}"));
    render_with(&aliased, args, 1);
    let d = compare(&load(&aliased), &load(&g), tol).expect("same size");
    eprintln!("{name}: without multisampling {d:?}");
    assert!(
        d.within(tol),
        "{name} without multisampling: {d:?} exceeds {tol:?}"
    );
}

fn assert_differs(dir: &Path, name: &str, golden_name: &str, args: &[&str], tol: &Tolerance) {
    let out = dir.join(name);
    render(&out, args);
    let d = compare(&load(&out), &load(&golden(golden_name)), tol).expect("same size");
    eprintln!("{name} vs {golden_name}: {d:?}");
    assert!(
        !d.within(tol),
        "{name} should differ from {golden_name}: {d:?}"
    );
}

#[test]
fn golden_images_match_and_a_wrong_camera_or_missing_object_does_not() {
    if robosim_display::skipped_without_vulkan(
        "golden_images_match_and_a_wrong_camera_or_missing_object_does_not",
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let tol = Tolerance::default();
    // The station is mostly sub-pixel truss members, whose pixels come and go with the
    // rasterization (0.27 % without multisampling): it gets 1 %.
    let station_tol = Tolerance {
        fraction: 0.01,
        ..Tolerance::default()
    };
    check_golden(
        d,
        "puma560_zero.png",
        &[&["puma560"][..], &PUMA_VIEW].concat(),
        &tol,
    );
    check_golden(
        d,
        "puma560_bent.png",
        &[
            &["puma560", "--joints", "puma560=30,20,-150,20,40,60"][..],
            &PUMA_VIEW,
        ]
        .concat(),
        &tol,
    );
    let station = ["space_station", "--size", "640x512"];
    check_golden(d, "space_station.png", &station, &station_tol);
    if std::env::var_os("ROBOSIM_BLESS").is_some() {
        return;
    }
    // The same robot from a camera 30 cm to the side.
    assert_differs(
        d,
        "wrong_camera.png",
        "puma560_zero.png",
        &[
            "puma560",
            "--from",
            "-1.2,1.7,1.1",
            "--at",
            "0.1,0,0.55",
            "--size",
            "320x240",
        ],
        &tol,
    );
    // The same view without the forearm.
    assert_differs(
        d,
        "no_forearm.png",
        "puma560_zero.png",
        &[&["puma560", "--hide", "forearm"][..], &PUMA_VIEW].concat(),
        &tol,
    );
    // The bent configuration is not the zero one.
    assert_differs(
        d,
        "bent_vs_zero.png",
        "puma560_zero.png",
        &[
            &["puma560", "--joints", "puma560=30,20,-150,20,40,60"][..],
            &PUMA_VIEW,
        ]
        .concat(),
        &tol,
    );
    // The station without its port solar array.
    assert_differs(
        d,
        "no_port_array.png",
        "space_station.png",
        &[&station[..], &["--hide", "port_solar"]].concat(),
        &station_tol,
    );
}

fn frames(dir: &Path) -> Vec<Value> {
    std::fs::read_to_string(dir.join("frames.jsonl"))
        .unwrap_or_default()
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect()
}

#[test]
fn a_session_display_redraws_a_moved_link_uploading_its_transforms_only() {
    if robosim_display::skipped_without_vulkan(
        "a_session_display_redraws_a_moved_link_uploading_its_transforms_only",
    ) {
        return;
    }
    let mut k = Procs::new("dsp");
    k.start_keeper(&["--scene", "puma560"]);
    let out = k.home.path().join("display-out");
    let out_s = out.to_string_lossy().into_owned();
    k.spawn(
        &[
            &["display", "--headless", "--every-frame", "--out", &out_s][..],
            &PUMA_VIEW,
        ]
        .concat(),
    );
    let first = wait_for("the first frame", || frames(&out).into_iter().next());
    assert_eq!(
        first["upload"]["meshes"], 12,
        "the first frame uploads every body: {first}"
    );

    // Another process (this test) writes: link 2 (shoulder, the upper arm) turns 50° about
    // its z axis.
    let s = k.session();
    let mut reader = Reader::attach(&s, "test-reader").expect("reader");
    let snap = wait_for("a snapshot", || {
        reader.refresh().ok()?;
        reader.snapshot()
    });
    let link = snap.find("shoulder").expect("shoulder link");
    assert_eq!(snap.object(link).kind(), Some(Kind::Link));
    let link_id = snap.rec(link).id;
    // The link's own bodies: geometry objects under it, not under a further link.
    let mut bodies = 0;
    let mut stack = vec![link_id];
    while let Some(id) = stack.pop() {
        for i in 0..snap.len() {
            let o = snap.object(i);
            if o.rec.parent == id && o.kind() != Some(Kind::Link) {
                bodies += usize::from(snap.geometry(i).is_some());
                stack.push(o.rec.id);
            }
        }
    }
    assert!(bodies > 0);
    let p = snap.poses()[link].pose;
    let (c, sn) = (50f64.to_radians().cos(), 50f64.to_radians().sin());
    let mut turned = p;
    for r in 0..3 {
        turned[r * 4] = p[r * 4] * c + p[r * 4 + 1] * sn;
        turned[r * 4 + 1] = -p[r * 4] * sn + p[r * 4 + 1] * c;
    }
    let mut tx = Transaction::new();
    tx.set_pose(link_id, turned);
    let version = Client::connect(&s, "test-writer")
        .expect("client")
        .transact(&tx)
        .expect("commit")
        .version;

    let next = wait_for("the frame of the move", || {
        frames(&out).into_iter().find(|f| f["version"] == version)
    });
    let up = &next["upload"];
    assert_eq!(up["transforms"], bodies as u64, "{next}");
    assert_eq!(
        (up["meshes"].as_u64(), up["materials"].as_u64()),
        (Some(0), Some(0)),
        "{next}"
    );
    assert_eq!(next["upload_bytes"], 64 * bodies as u64, "{next}");

    // The frame shows the moved link: it matches an independent render of the same version
    // and differs from the frame before.
    let snap = wait_for("the moved version", || {
        reader.refresh().ok()?;
        reader.snapshot().filter(|s| s.version() == version)
    });
    let mut r = Renderer::headless().expect("adapter");
    r.sync(&snap);
    r.camera = Camera::looking(Point3::new(-1.2, 1.4, 1.1), Point3::new(0.1, 0.0, 0.55));
    // The session display draws the ground grid and axes by default.
    r.style.grid = true;
    let expected = r.render_image(320, 240).expect("frame");
    let shown = load(&out.join(next["png"].as_str().expect("png name")));
    let before = load(&out.join(first["png"].as_str().expect("png name")));
    let tol = Tolerance::default();
    let same = compare(&shown, &expected, &tol).expect("same size");
    assert!(same.within(&tol), "display frame vs own render: {same:?}");
    let moved = compare(&shown, &before, &tol).expect("same size");
    assert!(!moved.within(&tol), "the move is visible: {moved:?}");
}

#[test]
fn welding_cell_trajectories_play_both_robots_together() {
    if robosim_display::skipped_without_vulkan(
        "welding_cell_trajectories_play_both_robots_together",
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let arm = d.join("arm.traj");
    let pos = d.join("positioner.traj");
    std::fs::write(&arm, "# welding arm, degrees\n0 0 0 0 0 0\n20 -10 10 0 30 0\n40 -20 20 0 60 0\n60 -30 30 0 60 0\n")
        .expect("write");
    std::fs::write(&pos, "# tilt, turn (degrees)\n0 0\n10 45\n20 90\n").expect("write");
    let frames_dir = d.join("frames");
    let o = robosim(&[
        "render",
        "downhand_welding_cell",
        "--play",
        &format!("arm={}", arm.display()),
        "--play",
        &format!("positioner={}", pos.display()),
        "--frames",
        &frames_dir.to_string_lossy(),
        "--size",
        "200x150",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Four samples (the positioner holds its last one), no mesh after the first sync.
    assert!(stdout.starts_with("4 frames"), "{stdout}");
    assert!(stdout.contains("meshes re-uploaded: 0"), "{stdout}");
    let tol = Tolerance::default();
    let f = |k: usize| load(&frames_dir.join(format!("frame-{k:05}.png")));
    assert!(!compare(&f(0), &f(3), &tol).expect("size").within(&tol));
    // A bad trajectory line is named, and nothing is written for it.
    std::fs::write(&pos, "0 0\n10 x\n").expect("write");
    let o = robosim(&[
        "render",
        "downhand_welding_cell",
        "--play",
        &format!("positioner={}", pos.display()),
        "--frames",
        &d.join("bad").to_string_lossy(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("positioner.traj:2: column 2"),
        "{err}"
    );
    assert!(!d.join("bad").exists());
}

#[test]
fn bad_render_input_gets_a_clear_error_and_no_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("x.png");
    let out_s = out.to_string_lossy().into_owned();
    let cases: &[(&[&str], &str)] = &[
        (
            &["render", "no_such_scene"],
            "unknown scene \"no_such_scene\"",
        ),
        (&["render", "puma560", "--joints", "puma560=0,0,0"], "6"),
        (
            &["render", "puma560", "--joints", "puma560=0,0,0,0,0,NaN"],
            "not a finite number",
        ),
        (
            &["render", "puma560", "--joints", "puma560=0,90,0,0,0,0,"],
            "not a finite number",
        ),
        (
            &["render", "puma560", "--joints", "puma560=0,0,0,0,170,0"],
            "limit",
        ),
        (
            &["render", "puma560", "--joints", "ur5=0"],
            "no robot named \"ur5\"; robots here: puma560",
        ),
        (
            &["render", "puma560", "--from", "0,0,1", "--at", "0,0,1"],
            "LOOK-FROM equals LOOK-AT",
        ),
        (
            &["render", "puma560", "--from", "0,0,inf"],
            "three finite numbers",
        ),
        (&["render", "puma560", "--size", "0x10"], "1..=8192"),
        (
            &["render", "puma560", "--hide", "nothing"],
            "no object of that name",
        ),
    ];
    for (args, needle) in cases {
        let o = robosim(&[args, &["--out", &out_s][..]].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} wrote a file");
    }
}

#[test]
fn the_window_moves_joints_and_picks_under_xvfb() {
    if robosim_display::skipped_without_vulkan("the_window_moves_joints_and_picks_under_xvfb") {
        return;
    }
    let xvfb = Command::new("xvfb-run").arg("--help").output();
    assert!(
        xvfb.is_ok(),
        "xvfb-run is needed for the window test (Debian: xvfb; .ci/run installs it)"
    );
    let mut k = Procs::new("dwin");
    k.start_keeper(&["--scene", "puma560"]);
    let o = Command::new("xvfb-run")
        .args([
            "-a",
            ROBOSIM,
            "display",
            "--session",
            &k.name,
            "--max-frames",
            "5",
        ])
        .args([
            "--script",
            "left",
            "--script",
            "3",
            "--script",
            "right",
            "--script",
            "click:320,240",
            // The grid and axes off and on again (drawn in the frames between).
            "--script",
            "g",
            "--script",
            "g",
        ])
        .args(["--size", "640x480"])
        .env("ROBOSIM_HOME", k.home.path())
        .output()
        .expect("xvfb-run");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        stdout.contains("status: puma560 joint 1 = -2.0°"),
        "{stdout}"
    );
    assert!(
        stdout.contains("status: puma560 joint 3 = 2.0°"),
        "{stdout}"
    );
    // The click lands on the robot: path, link, polygon.
    let pick = stdout
        .lines()
        .find(|l| l.starts_with("pick: "))
        .expect("a pick line");
    assert!(
        pick.starts_with("pick: puma560/") && pick.contains("(link ") && pick.contains("polygon "),
        "{pick}"
    );
    // The knob moves went through the Instance Space.
    let s = k.session();
    let mut reader = Reader::attach(&s, "test-reader").expect("reader");
    let snap = wait_for("snapshot", || {
        reader.refresh().ok()?;
        reader.snapshot()
    });
    let q = |name: &str| {
        snap.poses()[snap.find(name).expect("link")]
            .joint
            .to_degrees()
    };
    assert!((q("waist") + 2.0).abs() < 1e-9 && (q("elbow") - 2.0).abs() < 1e-9);
    // The click is the session's selection (what `robosim edit` reads as `.`): the object the
    // pick line names, with a polygon.
    assert!(pick.contains("— selected (version "), "{pick}");
    let sel = snap.selection().expect("the click selected something");
    let i = snap
        .index_of(sel.object)
        .expect("the selected object exists");
    assert!(snap.path(i).starts_with("puma560/"), "{}", snap.path(i));
    assert!(
        pick.starts_with(&format!("pick: {}", snap.path(i))),
        "{pick}"
    );
    assert!(sel.polygon.is_some());
}

/// `--collisions` draws what is in contact in the collision colour: the positioner turned into
/// the patient's head turns the head red; the same view without the flag, or with the arm
/// turned away, does not.
#[test]
fn colliding_objects_are_highlighted() {
    if robosim_display::skipped_without_vulkan("colliding_objects_are_highlighted") {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let view = [
        "--from",
        "0.95,-0.75,0.55",
        "--at",
        "0.12,0,0.1",
        "--size",
        "200x150",
    ];
    let red_fraction = |args: &[&str], name: &str| {
        let out = dir.path().join(name);
        render(
            &out,
            &[&["surgical_positioner_cell"][..], &view, args].concat(),
        );
        let img = load(&out);
        let red = img
            .pixels
            .chunks_exact(4)
            .filter(|p| p[0] as i32 > p[1] as i32 + 100 && p[0] as i32 > p[2] as i32 + 100)
            .count();
        red as f64 / (img.width * img.height) as f64
    };
    let into_head = ["--joints", "positioner=170,10,-90,0,0,0"];
    let away = ["--joints", "positioner=0,10,-90,0,0,0"];
    let hit = red_fraction(&[&into_head[..], &["--collisions"]].concat(), "hit.png");
    assert!(hit > 0.1, "head and link drawn red: {hit}");
    assert!(red_fraction(&into_head, "hit_plain.png") < 0.001);
    assert!(red_fraction(&[&away[..], &["--collisions"]].concat(), "away.png") < 0.001);
}

/// `up --with display` starts the display as its own process (headless without a display
/// server), `ps` lists it with what it attached to, and `down` stops it cleanly.
#[test]
fn up_with_display_runs_it_headless_and_down_stops_it() {
    if robosim_display::skipped_without_vulkan("up_with_display_runs_it_headless_and_down_stops_it")
    {
        return;
    }
    let k = Procs::new("dup");
    let run = |args: &[&str]| {
        Command::new(ROBOSIM)
            .args(args)
            .args(["--session", &k.name])
            .env("ROBOSIM_HOME", k.home.path())
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .expect("robosim")
    };
    let up = run(&["up", "puma560", "--with", "display"]);
    assert!(
        up.status.success(),
        "{}",
        String::from_utf8_lossy(&up.stderr)
    );
    let ps = String::from_utf8_lossy(&run(&["ps"]).stdout).into_owned();
    let dir = k.home.path().join(&k.name).join("display");
    let first = wait_for("the display's first frame", || {
        frames(&dir).into_iter().next()
    });
    let down = run(&["down"]);
    assert!(
        ps.lines()
            .any(|l| l.starts_with("display") && l.contains("space/geometry/*")),
        "{ps}"
    );
    assert_eq!(first["bodies"], 12, "{first}");
    assert!(dir.join("latest.png").exists());
    assert!(down.status.success());
    let log = std::fs::read_to_string(k.home.path().join(&k.name).join("run/display.log"))
        .unwrap_or_default();
    assert!(
        !log.contains("robosim:"),
        "the display stopped with an error: {log}"
    );
}

/// MD's file mode into a live session: the display plays two trajectory files into the
/// welding cell's arm and positioner (it is a writer then), and another process sees both
/// robots end at their files' last samples.
#[test]
fn a_session_display_plays_trajectories_into_the_instance_space() {
    if robosim_display::skipped_without_vulkan(
        "a_session_display_plays_trajectories_into_the_instance_space",
    ) {
        return;
    }
    let mut k = Procs::new("dplay");
    k.start_keeper(&["--scene", "downhand_welding_cell"]);
    let arm = k.home.path().join("arm.traj");
    let pos = k.home.path().join("pos.traj");
    std::fs::write(
        &arm,
        "# dt: 0.01\n0 0 0 0 0 0\n10 -5 5 0 20 0\n20 -10 10 0 40 15\n",
    )
    .expect("write");
    std::fs::write(&pos, "# dt: 0.01\n0 0\n15 90\n").expect("write");
    let out = k.home.path().join("play-out");
    let (a, p, o) = (
        format!("arm={}", arm.display()),
        format!("positioner={}", pos.display()),
        out.to_string_lossy().into_owned(),
    );
    k.spawn(&[
        "display",
        "--headless",
        "--size",
        "160x120",
        "--out",
        &o,
        "--play",
        &a,
        "--play",
        &p,
    ]);
    let s = k.session();
    let mut reader = Reader::attach(&s, "test-reader").expect("reader");
    // `None` until the keeper has committed the scene (its request service, which
    // `start_keeper` waits for, is up before the scene is loaded).
    let joints = |snap: &robosim_instance_space::Snapshot, robot: &str| -> Option<Vec<f64>> {
        let rid = snap.objects()[(0..snap.len())
            .find(|&i| snap.name(i) == robot && snap.object(i).kind() == Some(Kind::Robot))?]
        .id;
        let mut links: Vec<(u32, f64)> = (0..snap.len())
            .filter(|&i| snap.rec(i).parent == rid && snap.object(i).kind() == Some(Kind::Link))
            .map(|i| {
                (
                    snap.rec(i).index_or_family,
                    snap.poses()[i].joint.to_degrees(),
                )
            })
            .collect();
        links.sort_by_key(|l| l.0);
        Some(links.into_iter().map(|l| l.1).collect())
    };
    let close = |q: &[f64], want: &[f64]| {
        q.len() == want.len() && q.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-9)
    };
    wait_for("both robots at their last samples", || {
        reader.refresh().ok()?;
        let snap = reader.snapshot()?;
        (close(
            &joints(&snap, "arm")?,
            &[20.0, -10.0, 10.0, 0.0, 40.0, 15.0],
        ) && close(&joints(&snap, "positioner")?, &[15.0, 90.0]))
        .then_some(())
    });
    wait_for("frames drawn", || (frames(&out).len() >= 2).then_some(()));
}

/// With a simulator running, the session display draws the simulator's published state (the
/// links where the simulator has them), not only the committed model: a lockstep simulator
/// drives the PUMA to a joint target while the Instance Space stays at q = 0; the frame
/// matches an independent render of the committed model with the links at the target.
#[test]
fn the_session_display_draws_the_running_simulators_state() {
    if robosim_display::skipped_without_vulkan(
        "the_session_display_draws_the_running_simulators_state",
    ) {
        return;
    }
    use robosim_instance_space::Snapshot;
    use robosim_instance_space::layout::PoseRec;
    use robosim_instance_space::state::CommandSender;
    let mut k = Procs::new("dsim");
    k.start_keeper(&["--scene", "puma560"]);
    k.spawn(&["simulator", "--mode", "lockstep"]);
    let out = k.home.path().join("display-out");
    let out_s = out.to_string_lossy().into_owned();
    k.spawn(
        &[
            &["display", "--headless", "--every-frame", "--out", &out_s][..],
            &PUMA_VIEW,
        ]
        .concat(),
    );
    let first = wait_for("the first frame", || frames(&out).into_iter().next());
    let s = k.session();
    let mut ctl = wait_for("the simulator's commands", || {
        CommandSender::open(&s, "simulator", "test").ok()
    });
    let target = [0.0, 0.8, -0.5, 0.0, 0.4, 0.0];
    let send = |ctl: &mut CommandSender, c: String| {
        let a = ctl
            .send(c.as_bytes(), std::time::Duration::from_secs(10))
            .expect("answer");
        assert_eq!(a, b"ok", "{c}: {}", String::from_utf8_lossy(&a));
    };
    send(
        &mut ctl,
        serde_json::json!({"cmd": "target", "robot": "puma560", "q": target}).to_string(),
    );
    // Kinematic motion at 1 rad/s, dt 1 ms: 0.8 rad takes 800 steps; 2,000 are taken.
    send(&mut ctl, r#"{"cmd": "step", "n": 2000}"#.to_owned());
    let shown = wait_for("a frame of the simulator's state at t = 2 s", || {
        frames(&out)
            .into_iter()
            .find(|f| f["sim_t"].as_f64().is_some_and(|t| t > 1.999))
    });
    assert!(shown["sim_seq"].as_u64().is_some_and(|n| n > 0), "{shown}");
    // The overlay says what is drawn: the simulator's time and the joints at the target, in
    // degrees (0.8 rad = 45.8°, −0.5 rad = −28.6°, 0.4 rad = 22.9°); the committed model's
    // frame has none.
    let status = shown["status"].as_str().expect("a status line").to_owned();
    assert!(
        status.starts_with("simulator  t = 2.000 s")
            && status.contains("\npuma560  0.0°  45.8°  -28.6°  0.0°  22.9°  0.0°"),
        "{status}"
    );
    assert!(first["status"].is_null(), "{first}");

    // The committed model did not move.
    let mut reader = Reader::attach(&s, "test-reader").expect("reader");
    let snap: std::rc::Rc<Snapshot> = wait_for("a snapshot", || {
        reader.refresh().ok()?;
        reader.snapshot()
    });
    let view = snap.robot("puma560").expect("the robot");
    assert!(view.joints.iter().all(|j| j.q == 0.0));
    // An independent render: the committed model with the links at the target.
    let scene = robosim_scene::CompiledScene::of(&snap);
    let robot = scene.robot("puma560").expect("compiled");
    let overrides: Vec<PoseRec> = robot
        .links
        .iter()
        .zip(robosim_scene::link_poses(&robot.robot, &target))
        .zip(target)
        .map(|((id, pose), joint)| PoseRec {
            id: *id,
            pose,
            joint,
        })
        .collect();
    let mut r = Renderer::headless().expect("adapter");
    r.sync(&snap.with_poses(&overrides));
    r.camera = Camera::looking(Point3::new(-1.2, 1.4, 1.1), Point3::new(0.1, 0.0, 0.55));
    r.style.grid = true;
    let plain = r.render_image(320, 240).expect("frame");
    r.set_status(Some(&status));
    let expected = r.render_image(320, 240).expect("frame");
    let img = load(&out.join(shown["png"].as_str().expect("png name")));
    // The overlay is drawn: without it the independent render is another picture.
    let tol = Tolerance::default();
    let no_overlay = compare(&img, &plain, &tol).expect("same size");
    assert!(
        !no_overlay.within(&tol),
        "the status is visible: {no_overlay:?}"
    );
    let before = load(&out.join(first["png"].as_str().expect("png name")));
    let same = compare(&img, &expected, &tol).expect("same size");
    assert!(
        same.within(&tol),
        "display frame vs render at the target: {same:?}"
    );
    let moved = compare(&img, &before, &tol).expect("same size");
    assert!(
        !moved.within(&tol),
        "the simulated motion is visible: {moved:?}"
    );
}

/// Issue 19, item 3: without `XDG_RUNTIME_DIR` (CI, `ssh`, containers) Mesa's device-select
/// layer asked libwayland for a compositor, and libwayland printed "error: XDG_RUNTIME_DIR is
/// invalid or not set" twice on a run that then succeeded. A successful `render` and a
/// successful headless session `display` print nothing called "error".
#[test]
fn render_and_display_print_no_error_without_xdg_runtime_dir() {
    if robosim_display::skipped_without_vulkan(
        "render_and_display_print_no_error_without_xdg_runtime_dir",
    ) {
        return;
    }
    fn bare(c: &mut Command) -> &mut Command {
        for k in [
            "XDG_RUNTIME_DIR",
            "WAYLAND_DISPLAY",
            "WAYLAND_SOCKET",
            "NODEVICE_SELECT",
            "MESA_VK_DEVICE_SELECT",
            "DRI_PRIME",
        ] {
            c.env_remove(k);
        }
        c
    }
    fn assert_quiet(what: &str, o: &Output) {
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(o.status.success(), "{what} failed: {text}");
        assert!(
            !text.to_lowercase().contains("error"),
            "{what} succeeded but printed an error: {text}"
        );
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("tmp.png");
    let o = bare(Command::new(ROBOSIM).args(["render", "puma560", "--out"]))
        .arg(&png)
        .output()
        .expect("robosim render");
    assert_quiet("render", &o);
    assert!(png.exists());

    let mut k = Procs::new("dxdg");
    k.start_keeper(&["--scene", "puma560"]);
    let out = k.home.path().join("display-out");
    let o = bare(Command::new(ROBOSIM).args([
        "display",
        "--headless",
        "--max-frames",
        "1",
        "--size",
        "160x120",
        "--session",
        &k.name,
        "--out",
    ]))
    .arg(&out)
    .env("ROBOSIM_HOME", k.home.path())
    .output()
    .expect("robosim display");
    assert_quiet("display --headless", &o);
    assert_eq!(frames(&out).len(), 1);
}

/// Every path under `dir` (itself included) whose mode lets the group or others in.
fn not_private(dir: &Path) -> Vec<(PathBuf, u32)> {
    use std::os::unix::fs::PermissionsExt;
    let mut wide = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(p) = stack.pop() {
        let Ok(m) = std::fs::symlink_metadata(&p) else {
            continue; // removed meanwhile (latest.png.tmp renamed)
        };
        let mode = m.permissions().mode() & 0o777;
        if mode & 0o077 != 0 {
            wide.push((p.clone(), mode));
        }
        if m.is_dir() {
            stack.extend(
                std::fs::read_dir(&p)
                    .into_iter()
                    .flatten()
                    .flatten()
                    .map(|e| e.path()),
            );
        }
    }
    wide
}

/// Issue 19, item 8: a session is private (0600 / 0700), and so is everything the display
/// writes into it — `display/` itself, `latest.png` (written to a temp file and renamed),
/// the kept frames and `frames.jsonl`.
#[test]
fn the_session_display_writes_only_private_files() {
    if robosim_display::skipped_without_vulkan("the_session_display_writes_only_private_files") {
        return;
    }
    let mut k = Procs::new("dpriv");
    k.start_keeper(&["--scene", "puma560"]);
    let display_dir = k.home.path().join(&k.name).join("display");
    k.spawn(&[
        "display",
        "--headless",
        "--every-frame",
        "--size",
        "160x120",
    ]);
    let first = wait_for("the first frame", || {
        frames(&display_dir).into_iter().next()
    });
    let png = first["png"].as_str().expect("a kept frame");
    for f in ["latest.png", "frames.jsonl", png] {
        assert!(display_dir.join(f).is_file(), "{f} written");
    }
    // Only display/ is the display's: iceoryx2 makes its iox2/nodes and iox2/services
    // directories 0750 (the Instance Space's session code, not this crate's).
    let wide = not_private(&display_dir);
    assert!(wide.is_empty(), "group/other-accessible: {wide:?}");
}

/// Issue 19, item 15: the display's software Vulkan driver is the one system package; without
/// any Vulkan driver `render` fails and says how to get one, and writes nothing.
#[test]
fn render_without_a_vulkan_driver_says_how_to_get_one() {
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("none.png");
    let missing = dir.path().join("no-such-icd.json");
    let o = Command::new(ROBOSIM)
        .args(["render", "puma560", "--out"])
        .arg(&png)
        // The loader's driver lists (new name, old name): a file that does not exist.
        .env("VK_DRIVER_FILES", &missing)
        .env("VK_ICD_FILENAMES", &missing)
        .output()
        .expect("robosim render");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("no graphics adapter")
            && err.contains("sudo apt-get install mesa-vulkan-drivers libvulkan1"),
        "{err}"
    );
    assert!(!png.exists());
}

/// Issue 19, item 16: `render --grid` adds the ground grid and world axes; without the flag
/// the picture is the golden one (checked by the golden test), so they are another picture.
#[test]
fn render_with_grid_is_not_the_golden_picture() {
    if robosim_display::skipped_without_vulkan("render_with_grid_is_not_the_golden_picture") {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("grid.png");
    render(&out, &[&["puma560", "--grid"][..], &PUMA_VIEW].concat());
    let tol = Tolerance::default();
    let d = compare(&load(&out), &load(&golden("puma560_zero.png")), &tol).expect("same size");
    assert!(!d.within(&tol), "the grid is visible: {d:?}");
}

/// Issue 19, item 16: a display opened on an empty session frames the camera when the first
/// bodies arrive: after `instantiate space_station` the frame is the station seen whole, as an
/// independent render framed on its bounding sphere shows it.
#[test]
fn a_display_opened_on_an_empty_session_frames_the_first_model() {
    if robosim_display::skipped_without_vulkan(
        "a_display_opened_on_an_empty_session_frames_the_first_model",
    ) {
        return;
    }
    let mut k = Procs::new("dframe");
    k.start_keeper(&[]);
    let out = k.home.path().join("display-out");
    let out_s = out.to_string_lossy().into_owned();
    k.spawn(&[
        "display",
        "--headless",
        "--every-frame",
        "--size",
        "320x240",
        "--out",
        &out_s,
    ]);
    let first = wait_for("the first frame", || frames(&out).into_iter().next());
    assert_eq!(first["bodies"], 0, "{first}");
    let st = Command::new(ROBOSIM)
        .args(["instantiate", "space_station", "--as", "station"])
        .args(["--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .status()
        .expect("instantiate");
    assert!(st.success());
    let shown = wait_for("a frame of the station", || {
        frames(&out)
            .into_iter()
            .find(|f| f["bodies"].as_u64().is_some_and(|b| b > 0))
    });
    let s = k.session();
    let mut reader = Reader::attach(&s, "test-reader").expect("reader");
    let version = shown["version"].as_u64().expect("version");
    let snap = wait_for("the shown version", || {
        reader.refresh().ok()?;
        reader.snapshot().filter(|s| s.version() >= version)
    });
    let mut r = Renderer::headless().expect("adapter");
    r.sync(&snap);
    assert_eq!(shown["bodies"], r.body_count() as u64, "{shown}");
    let (c, radius) = r.bounds();
    r.camera = Camera::framing_fov(c, radius, 40.0);
    r.style.grid = true;
    let expected = r.render_image(320, 240).expect("frame");
    let img = load(&out.join(shown["png"].as_str().expect("png name")));
    let tol = Tolerance {
        fraction: 0.01,
        ..Tolerance::default()
    };
    let d = compare(&img, &expected, &tol).expect("same size");
    assert!(d.within(&tol), "display frame vs the framed station: {d:?}");
}

/// Issue 19, item 16: with `--collisions` and a simulator running, the bodies in contact at
/// the simulator's state (not the committed model's) are drawn in the collision colour. The
/// simulator (kinematics only: nothing stops the motion) drives the surgical positioner into
/// the patient's head while the Instance Space keeps it folded away.
#[test]
fn the_session_display_colours_the_contacts_of_the_simulated_state() {
    if robosim_display::skipped_without_vulkan(
        "the_session_display_colours_the_contacts_of_the_simulated_state",
    ) {
        return;
    }
    use robosim_instance_space::state::CommandSender;
    let mut k = Procs::new("dsimc");
    let effects = k.home.path().join("effects.json");
    std::fs::write(
        &effects,
        r#"{"dt": 0.01, "max_speed": 1.0, "kinematics": true, "joint_limits": true}"#,
    )
    .expect("effects");
    k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let eff = effects.to_string_lossy().into_owned();
    k.spawn(&["simulator", "--mode", "lockstep", "--effects", &eff]);
    let out = k.home.path().join("display-out");
    let out_s = out.to_string_lossy().into_owned();
    k.spawn(&[
        "display",
        "--headless",
        "--collisions",
        "--no-grid",
        "--every-frame",
        "--out",
        &out_s,
        "--from",
        "0.95,-0.75,0.55",
        "--at",
        "0.12,0,0.1",
        "--size",
        "200x150",
    ]);
    let red_fraction = |f: &Value| {
        let img = load(&out.join(f["png"].as_str().expect("png name")));
        let red = img
            .pixels
            .chunks_exact(4)
            .filter(|p| p[0] as i32 > p[1] as i32 + 100 && p[0] as i32 > p[2] as i32 + 100)
            .count();
        red as f64 / (img.width * img.height) as f64
    };
    let first = wait_for("the first frame", || frames(&out).into_iter().next());
    assert!(red_fraction(&first) < 0.001, "nothing in contact at first");
    let s = k.session();
    let mut ctl = wait_for("the simulator's commands", || {
        CommandSender::open(&s, "simulator", "test").ok()
    });
    let into_head: Vec<f64> = [170.0f64, 10.0, -90.0, 0.0, 0.0, 0.0]
        .iter()
        .map(|d| d.to_radians())
        .collect();
    for c in [
        serde_json::json!({"cmd": "target", "robot": "positioner", "q": into_head}).to_string(),
        // 1 rad/s, 10 ms steps: the largest move (170°) takes about 300 steps.
        r#"{"cmd": "step", "n": 400}"#.to_owned(),
    ] {
        let a = ctl
            .send(c.as_bytes(), std::time::Duration::from_secs(10))
            .expect("answer");
        assert_eq!(a, b"ok", "{c}: {}", String::from_utf8_lossy(&a));
    }
    let hit = wait_for("a frame of the simulated state at t = 4 s", || {
        frames(&out)
            .into_iter()
            .find(|f| f["sim_t"].as_f64().is_some_and(|t| t > 3.999))
    });
    let red = red_fraction(&hit);
    assert!(
        red > 0.1,
        "head and link drawn red at the simulated state: {red}"
    );
}

const PANDA_VIEW: [&str; 6] = [
    "--from",
    "1.15,-0.9,0.85",
    "--at",
    "0.25,0,0.45",
    "--size",
    "320x240",
];

/// `robosim render FILE.urdf`: the Panda of example-robot-data drawn from its Collada visuals
/// (the file interface's URDF import: general joints, a tree, meshes) matches its golden image;
/// the collision hulls are not drawn over the visuals (hiding the hand's visual changes the
/// picture, which it would not if the hand's hull were drawn too); a bent arm is another
/// picture.
#[test]
fn a_urdf_robot_renders_from_its_visual_meshes() {
    if robosim_display::skipped_without_vulkan("a_urdf_robot_renders_from_its_visual_meshes") {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let tol = Tolerance::default();
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/urdf/panda.urdf");
    let urdf = urdf.to_str().expect("utf-8 path");
    let pose = ["--joints", "panda=0,-30,0,-120,0,90,45,0.03,0.03"];
    let args = [&[urdf][..], &pose, &PANDA_VIEW].concat();
    check_golden(d, "panda_urdf.png", &args, &tol);
    if std::env::var_os("ROBOSIM_BLESS").is_some() {
        return;
    }
    assert_differs(
        d,
        "panda_no_hand_visual.png",
        "panda_urdf.png",
        &[&args[..], &["--hide", "panda_hand-visual0"]].concat(),
        &tol,
    );
    assert_differs(
        d,
        "panda_zero.png",
        "panda_urdf.png",
        &[&[urdf][..], &PANDA_VIEW].concat(),
        &tol,
    );
}
