//! The file interface across processes (issue #15): real keepers, displays and simulators
//! started with `robosim`, over real shared memory.
//!
//! * a session saved, stopped and started again from the file has the same model digest
//!   (Space Station, welding cell; binary and JSON; a fresh session and the same one);
//! * a load reaches a running display and simulator as one change (one version step);
//! * refused loads (truncated, flipped byte, wrong magic, future format, missing parent id,
//!   a model the keeper refuses) change nothing: same digest, same version;
//! * import of a mesh and export of a session as glTF and STL.

use crate::common;

use common::{Procs, ROBOSIM, wait_for};
use robosim_file_io::format::{self, Encoding};
use robosim_file_io::{SavedModel, scene_model};
use robosim_instance_space::Reader;
use robosim_instance_space::state::StateSubscriber;
use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

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
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("robosim runs")
}

fn ok(p: &Procs, args: &[&str]) -> String {
    let o = run(p, args);
    assert!(
        o.status.success(),
        "robosim {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn refused(p: &Procs, args: &[&str]) -> String {
    let o = run(p, args);
    assert!(!o.status.success(), "robosim {args:?} succeeded");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `robosim info`: (version, digest, object count).
fn info(p: &Procs) -> (u64, String, usize) {
    let out = ok(p, &["info"]);
    let field = |name: &str| -> String {
        out.lines()
            .find_map(|l| l.strip_prefix(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} in {out}"))
            .to_owned()
    };
    let objects = field("objects");
    (
        field("version").parse().expect("version"),
        field("digest"),
        objects
            .split_whitespace()
            .next()
            .and_then(|n| n.parse().ok())
            .expect("object count"),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn round_trip(scene: &str, tag: &str) {
    let a = Procs::new(tag);
    let _up_a = Up(&a);
    ok(&a, &["up", scene]);
    let (_, digest, objects) = info(&a);
    let bin = a.home.path().join(format!("{scene}.rsm"));
    let json = a.home.path().join(format!("{scene}.json"));
    ok(&a, &["save", s(&bin)]);
    ok(&a, &["save", s(&json)]);
    ok(&a, &["down"]);

    // A fresh session from the binary file.
    let b = Procs::new(&format!("{tag}b"));
    let _up_b = Up(&b);
    ok(&b, &["up", "--load", s(&bin)]);
    let (_, d, n) = info(&b);
    assert_eq!(
        (d.as_str(), n),
        (digest.as_str(), objects),
        "{scene}: binary round trip"
    );
    ok(&b, &["down"]);

    // The original session again, from the JSON file: the file replaces the model its journal
    // recovered (one more version), and the digest is the saved one.
    ok(&a, &["up", "--load", s(&json)]);
    let (_, d, n) = info(&a);
    assert_eq!(
        (d.as_str(), n),
        (digest.as_str(), objects),
        "{scene}: JSON round trip"
    );

    if scene == "space_station" {
        // glTF of the running session: one node per object, one mesh per body.
        let glb = a.home.path().join("station.glb");
        ok(&a, &["export", s(&glb)]);
        let g = gltf::Gltf::open(&glb).expect("the gltf crate reads the export");
        assert_eq!(g.nodes().count(), objects);
        let model = format::read(&bin).expect("saved model");
        let bodies = model
            .objects
            .iter()
            .filter(|o| o.geometry.is_some())
            .count();
        assert_eq!(g.meshes().count(), bodies);
    }
}

#[test]
fn space_station_round_trips_through_a_file_with_the_same_digest() {
    round_trip("space_station", "fst");
}

#[test]
fn welding_cell_round_trips_through_a_file_with_the_same_digest() {
    round_trip("downhand_welding_cell", "fwc");
}

/// What the display writes per frame (frames.jsonl): version, bodies, triangles.
fn frames(dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("frames.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

fn simctl(p: &Procs, cmd: &str) {
    ok(p, &["simctl", cmd]);
}

#[test]
fn a_load_reaches_a_running_display_and_simulator_as_one_change() {
    if robosim_display::skipped_without_vulkan(
        "a_load_reaches_a_running_display_and_simulator_as_one_change",
    ) {
        return;
    }
    let mut k = Procs::new("fds");
    k.start_keeper(&["--scene", "puma560"]);
    let out = k.home.path().join("display-out");
    k.spawn(&[
        "display",
        "--headless",
        "--size",
        "320x240",
        "--out",
        s(&out),
    ]);
    k.spawn(&["simulator", "--mode", "lockstep"]);
    let session = k.session();
    let mut state = wait_for("the simulator's state service", || {
        StateSubscriber::open(&session, "simulator", "test-state").ok()
    });
    wait_for("the display's first frame", || {
        frames(&out).into_iter().next()
    });
    let mut reader = Reader::attach(&session, "test-reader").expect("reader");
    let v0 = reader.snapshot().expect("snapshot").version();
    simctl(&k, r#"{"cmd": "step", "n": 1}"#);
    wait_for("a state of the first model", || {
        state
            .wait(Duration::from_millis(100))
            .expect("state")
            .into_iter()
            .find(|r| r.header.structure_version == v0)
    });

    // The welding cell, saved by the file interface, replaces the PUMA.
    let cell = scene_model("downhand_welding_cell", &[]).expect("cell");
    let file = k.home.path().join("cell.rsm");
    format::write(&cell, &file, Encoding::Binary).expect("write");
    ok(&k, &["load", s(&file)]);

    // Every reader sees one change: one version step, structure included.
    let mut changes = Vec::new();
    wait_for("the load's change record", || {
        changes.extend(reader.wait_change(Duration::from_millis(100)).ok()?);
        changes.iter().any(|c| c.version > v0).then_some(())
    });
    let after: Vec<_> = changes.iter().filter(|c| c.version > v0).collect();
    assert_eq!(after.len(), 1, "one change: {after:?}");
    let v1 = after[0].version;
    assert_eq!(v1, v0 + 1);
    assert!(after[0].aspects & robosim_instance_space::aspect::STRUCTURE != 0);

    // The display draws the whole cell at v1 and never anything in between.
    let bodies = cell.objects.iter().filter(|o| o.geometry.is_some()).count();
    let triangles: usize = cell
        .objects
        .iter()
        .filter_map(|o| o.geometry.as_ref())
        .flat_map(|g| g.polygons.iter().map(|p| p.len() - 2))
        .sum();
    let frame = wait_for("the display's frame of the load", || {
        frames(&out).into_iter().find(|f| f["version"] == v1)
    });
    assert_eq!(frame["bodies"], bodies as u64, "{frame}");
    assert_eq!(frame["triangles"], triangles as u64, "{frame}");
    for f in frames(&out) {
        let v = f["version"].as_u64().expect("version");
        assert!(v <= v0 || v == v1, "a frame of a version in between: {f}");
    }

    // The simulator rebuilt for the cell at v1: every joint of both robots.
    let joints = cell
        .objects
        .iter()
        .filter(|o| {
            matches!(
                o.kinematics,
                Some(robosim_instance_space::Kinematics::Joint { .. })
            )
        })
        .count();
    simctl(&k, r#"{"cmd": "step", "n": 1}"#);
    let rec = wait_for("a state of the loaded model", || {
        state
            .wait(Duration::from_millis(100))
            .expect("state")
            .into_iter()
            .find(|r| r.header.structure_version >= v1)
    });
    assert_eq!(rec.header.structure_version, v1);
    assert_eq!(
        rec.joints.len(),
        joints,
        "the simulator runs the loaded robots"
    );
}

/// `bytes` with format version `v` and a checksum that matches (what a newer writer makes).
fn with_version(good: &[u8], v: u32) -> Vec<u8> {
    let mut b = good.to_vec();
    b[8..12].copy_from_slice(&v.to_le_bytes());
    let mut h = crc32fast::Hasher::new();
    h.update(&b[8..24]);
    h.update(&b[28..]);
    let crc = h.finalize();
    b[24..28].copy_from_slice(&crc.to_le_bytes());
    b
}

#[test]
fn refused_loads_leave_the_session_untouched_and_import_export_work() {
    let mut k = Procs::new("fbad");
    k.start_keeper(&["--scene", "demo"]);
    let before = info(&k);
    let dir = k.home.path();
    let puma = scene_model("puma560", &[]).expect("puma");
    let good = format::encode_binary(&puma);
    let mut cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "truncated.rsm",
            good[..good.len() - 64].to_vec(),
            "truncated",
        ),
        (
            "magic.rsm",
            [b"NOTMODEL", &good[8..]].concat(),
            "not a robosim model file",
        ),
        (
            "future.rsm",
            with_version(&good, 99),
            "format version 99, newer than this build",
        ),
    ];
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x04;
    cases.push(("flipped.rsm", flipped, "checksum mismatch"));
    let mut orphan: SavedModel = puma.clone();
    orphan.objects[3].parent = 424_242;
    cases.push((
        "orphan.rsm",
        format::encode_binary(&orphan),
        "names parent 424242, which is not in the file",
    ));
    // Valid as a file, refused by the keeper: a link hung under a solid.
    let mut wrong = puma.clone();
    let link = wrong
        .objects
        .iter()
        .position(|o| o.kind == robosim_instance_space::Kind::Link)
        .expect("a link");
    let solid = wrong
        .objects
        .iter()
        .find(|o| o.kind == robosim_instance_space::Kind::Solid && o.parent == wrong.objects[0].id)
        .expect("a base solid")
        .id;
    wrong.objects[link].parent = solid;
    let link_name = wrong.objects[link].name.clone();
    cases.push((
        "wrong.rsm",
        format::encode_binary(&wrong),
        "a link cannot be a child of a solid",
    ));
    for (name, bytes, want) in &cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).expect("write");
        let err = refused(&k, &["load", s(&path)]);
        assert!(err.contains(want), "{name}: {err}");
        assert!(
            err.contains(name),
            "{name}: the error names the file or object: {err}"
        );
        assert_eq!(info(&k), before, "{name}: the session is untouched");
    }
    let err = refused(&k, &["load", s(&dir.join("wrong.rsm"))]);
    assert!(
        err.contains(&format!("{link_name:?}")),
        "names the object: {err}"
    );

    // Import: an OBJ cube in millimetres, placed at (1, 0, 0.5) turned 90° about z.
    let obj = dir.join("cube.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 100 0 0\nv 100 100 0\nv 0 100 0\nv 0 0 100\nv 100 0 100\nv 100 100 100\nv 0 100 100\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .expect("obj");
    let out = ok(
        &k,
        &[
            "import",
            "mesh",
            s(&obj),
            "--as",
            "fixture",
            "--at",
            "1,0,0.5,0,0,90",
            "--scale",
            "0.001",
        ],
    );
    assert!(out.contains("12 triangles read"), "{out}");
    let (v, _, n) = info(&k);
    assert_eq!(
        (v, n),
        (before.0 + 1, before.2 + 2),
        "one transaction: item and solid"
    );
    // STL of the imported body in world coordinates: x from 0.9 to 1.0 after the turn.
    let stl = dir.join("fixture.stl");
    ok(&k, &["export", "stl", s(&stl), "--body", "fixture"]);
    let tris = robosim_file_io::stl::read_stl(&std::fs::read(&stl).expect("stl"), &stl)
        .expect("reads back");
    assert_eq!(tris.len(), 12);
    let xs: Vec<f64> = tris.iter().flatten().map(|p| p[0]).collect();
    let lo = xs.iter().cloned().fold(f64::MAX, f64::min);
    let hi = xs.iter().cloned().fold(f64::MIN, f64::max);
    assert!(
        (lo - 0.9).abs() < 1e-6 && (hi - 1.0).abs() < 1e-6,
        "{lo} {hi}"
    );
    // And the session as glTF: one node per object.
    let glb = dir.join("session.glb");
    ok(&k, &["export", "gltf", s(&glb)]);
    let g = gltf::Gltf::open(&glb).expect("gltf reads it");
    assert_eq!(g.nodes().count(), n);
}

/// The Panda of testdata/urdf without its Collada visuals, collision meshes by absolute path,
/// written into `dir` (the line count kept, so errors point at the original's lines).
fn collision_only_panda(dir: &Path) -> std::path::PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/urdf");
    let text = std::fs::read_to_string(root.join("panda.urdf")).expect("panda.urdf");
    let mut out = String::new();
    let mut rest = text.as_str();
    while let Some(start) = rest.find("<visual>") {
        out.push_str(&rest[..start]);
        let end = rest[start..].find("</visual>").expect("closed") + start + "</visual>".len();
        out.push_str(&"\n".repeat(rest[start..end].matches('\n').count()));
        rest = &rest[end..];
    }
    out.push_str(rest);
    let out = out.replace(
        "package://example-robot-data/",
        &format!("file://{}/", root.join("example-robot-data").display()),
    );
    let path = dir.join("panda.urdf");
    std::fs::write(&path, out).expect("write");
    path
}

/// `robosim import urdf` into a running session: one transaction (robot, 9 general-joint links,
/// the collision solids); the session's ops use it (get_robot reads the tree back, movej moves
/// it and writes the link poses FK gives); the model saves as format version 2 and loads into
/// a fresh session with the same digest; a URDF whose mesh is missing is refused with file and
/// line, and changes nothing.
#[test]
fn a_urdf_robot_imported_into_a_session_is_a_robot_of_the_session() {
    let k = Procs::new("urdfs");
    let _up = Up(&k);
    ok(&k, &["up", "demo"]);
    let before = info(&k);
    let urdf = collision_only_panda(k.home.path());
    let out = ok(
        &k,
        &[
            "import",
            "urdf",
            s(&urdf),
            "--as",
            "arm",
            "--at",
            "1,0,0,0,0,90",
        ],
    );
    assert!(out.contains("9 joints (a tree)"), "{out}");
    let solids = robosim_file_io::urdf_import::import_urdf_tree(&urdf)
        .expect("imports")
        .geometry
        .counts()
        .1;
    let (v, _, n) = info(&k);
    assert_eq!(
        (v, n),
        (before.0 + 1, before.2 + 1 + 9 + solids),
        "one transaction: robot, links, solids"
    );

    // The session's ops: get_robot, then a movej (collision checks off: the demo's table).
    let q = [0.3, -0.5, 0.2, -2.0, 0.1, 1.6, 0.7, 0.01, 0.02];
    let requests = format!(
        "{{\"id\": 1, \"op\": \"get_robot\", \"robot\": \"arm\"}}\n\
         {{\"id\": 2, \"op\": \"c_switch\", \"on\": false}}\n\
         {{\"id\": 3, \"op\": \"movej\", \"robot\": \"arm\", \"q\": {q:?}}}\n"
    );
    let req = k.home.path().join("requests.jsonl");
    std::fs::write(&req, requests).expect("requests");
    let out = ok(&k, &["query", "--input", s(&req)]);
    let answers: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON answer"))
        .collect();
    assert_eq!(answers[0]["ok"], true, "{out}");
    let links: Vec<&str> = answers[0]["links"]
        .as_array()
        .expect("links")
        .iter()
        .map(|l| l["name"].as_str().expect("name"))
        .collect();
    assert_eq!(links[0], "panda_link1");
    assert_eq!(links[8], "panda_rightfinger");
    assert_eq!(answers[2]["ok"], true, "{out}");
    assert_eq!(answers[2]["completed"], true, "{out}");
    // The link poses the session now holds are the tree's FK at q (from the file itself).
    let model = robosim_file_io::urdf_import::import_urdf_tree(&urdf).expect("imports");
    let frames = robosim_kinematics::fk::link_frames(&model.robot, &q);
    let session = k.session();
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let robot = snap.robot("arm").expect("arm");
    for (j, link) in robot.joints.iter().enumerate() {
        let p = snap.poses()[link.index].pose;
        let m = robosim_scene::pose::to_matrix(&p);
        assert!(
            (m - frames[j + 1]).abs().max() < 1e-12,
            "link {j} pose after movej"
        );
        assert_eq!(snap.poses()[link.index].joint, q[j]);
    }
    drop(snap);
    drop(reader);

    // The simulator runs it: rigid-body dynamics of the tree under gravity (RK4 at 1 ms, a soft
    // PD hold of the committed joints that gravity overcomes), 1 s in lock-step: finite, no
    // step error, moved by gravity, and held within its joint limits by the limits stage.
    let effects = k.home.path().join("effects.json");
    std::fs::write(
        &effects,
        r#"{"dt": 0.01, "joint_limits": true, "dynamics": {"integrator": "rk4", "dt": 0.001, "gravity": [0, 0, -9.81], "kp": 100, "kd": 20}}"#,
    )
    .expect("effects");
    let mut daemon = Command::new(ROBOSIM)
        .args(["simulator", "--mode", "lockstep", "--effects", s(&effects)])
        .args(["--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("simulator");
    let simctl = |cmd: &str| {
        let o = run(&k, &["simctl", cmd]);
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let state = wait_for("the simulator at t = 1 s", || {
        simctl(r#"{"cmd": "step", "n": 1}"#);
        let g: serde_json::Value = serde_json::from_str(&simctl(r#"{"cmd": "get"}"#)).ok()?;
        let steps = g["steps"].as_u64()?;
        if steps < 100 {
            simctl(&format!(r#"{{"cmd": "step", "n": {}}}"#, 100 - steps));
        }
        (steps >= 100).then_some(g)
    });
    let _ = daemon.kill();
    let _ = daemon.wait();
    let arm = state["robots"]
        .as_array()
        .expect("robots")
        .iter()
        .find(|r| r["name"] == "arm")
        .unwrap_or_else(|| panic!("the simulator has the imported robot: {state}"))
        .clone();
    assert!(arm["error"].is_null(), "{arm}");
    assert!(
        arm["stages"]
            .as_array()
            .expect("stages")
            .iter()
            .any(|s| s == "dynamics"),
        "{arm}"
    );
    let sim_q: Vec<f64> = arm["q"]
        .as_array()
        .expect("q")
        .iter()
        .map(|v| v.as_f64().expect("finite q"))
        .collect();
    assert_eq!(sim_q.len(), 9);
    let off = sim_q
        .iter()
        .zip(q)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(off > 1e-4, "gravity moved the arm: {off} rad, q {sim_q:?}");
    for (j, (v, joint)) in sim_q.iter().zip(&model.robot.joints).enumerate() {
        assert!(
            *v >= joint.qlim[0] - 1e-9 && *v <= joint.qlim[1] + 1e-9,
            "joint {j} at {v} within its limits {:?}",
            joint.qlim
        );
    }

    // One tip of the tree: kinv and jacob on the chain to link 7 (the fingers held). The
    // target is link 7's world pose at another q; the answer's q is the robot's whole q.
    let q2 = [-0.4, 0.3, 0.5, -1.7, -0.2, 2.1, 0.3, q[7], q[8]];
    let base = {
        let reader = Reader::attach(&session, "base").expect("attach");
        let snap = reader.snapshot().expect("snapshot");
        let i = snap.robot("arm").expect("arm").index;
        robosim_scene::pose::to_matrix(&snap.world_pose(i))
    };
    let target = base * robosim_kinematics::fk::link_frames(&model.robot, &q2)[7];
    let rows: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| target[(r, c)]).collect())
        .collect();
    let req = k.home.path().join("tip.jsonl");
    std::fs::write(
        &req,
        format!(
            "{{\"id\": 4, \"op\": \"jacob\", \"robot\": \"arm\", \"tip\": \"panda_link7\"}}\n\
             {{\"id\": 5, \"op\": \"kinv\", \"robot\": \"arm\", \"tip\": \"panda_link7\", \"pose\": {}}}\n\
             {{\"id\": 6, \"op\": \"kinv\", \"robot\": \"arm\", \"tip\": \"panda_hand\", \"pose\": {}}}\n",
            serde_json::json!(rows),
            serde_json::json!(rows)
        ),
    )
    .expect("requests");
    let out = ok(&k, &["query", "--input", s(&req)]);
    let answers: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON answer"))
        .collect();
    assert_eq!(
        answers[0]["chain"],
        serde_json::json!([0, 1, 2, 3, 4, 5, 6]),
        "{out}"
    );
    assert_eq!(
        answers[0]["jacobian"][0].as_array().map(Vec::len),
        Some(7),
        "{out}"
    );
    assert_eq!(answers[1]["ok"], true, "{out}");
    let sol: Vec<f64> = answers[1]["solutions"][0]["q"]
        .as_array()
        .expect("q")
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect();
    assert_eq!(sol.len(), 9, "the whole q");
    assert_eq!((sol[7], sol[8]), (q[7], q[8]), "the fingers held");
    let reached = base * robosim_kinematics::fk::link_frames(&model.robot, &sol)[7];
    assert!(
        (reached - target).abs().max() < 1e-6,
        "kinv on the chain reaches link 7's target: {}",
        (reached - target).abs().max()
    );
    assert_eq!(answers[2]["ok"], false, "{out}");
    assert!(
        answers[2]["error"]["message"]
            .as_str()
            .is_some_and(|m| m.contains("panda_link7")),
        "a tip that is not a link object lists the links: {out}"
    );

    // Saved: version 2 (a general joint); loaded into a fresh session: the same model.
    let (_, digest, objects) = info(&k);
    let bin = k.home.path().join("with-urdf.rsm");
    ok(&k, &["save", s(&bin)]);
    let bytes = std::fs::read(&bin).expect("saved");
    assert_eq!(bytes[8..12], 2u32.to_le_bytes(), "format version 2");
    let b = Procs::new("urdfs2");
    let _up_b = Up(&b);
    ok(&b, &["up", "--load", s(&bin)]);
    assert_eq!(info(&b).1, digest);
    assert_eq!(info(&b).2, objects);

    // A missing mesh: refused before the session is touched.
    let text = std::fs::read_to_string(&urdf)
        .expect("read")
        .replace("collision/link5.stl", "collision/link5_gone.stl");
    std::fs::write(&urdf, &text).expect("write");
    let line = text
        .lines()
        .position(|l| l.contains("link5_gone.stl"))
        .expect("there")
        + 1;
    let here = info(&k);
    let err = refused(&k, &["import", "urdf", s(&urdf), "--as", "arm2"]);
    assert!(err.contains(&format!("panda.urdf:{line}")), "{err}");
    assert!(err.contains("link5_gone.stl"), "{err}");
    assert_eq!(info(&k), here, "nothing entered the session");
}
