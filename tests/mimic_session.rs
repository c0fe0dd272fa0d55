//! A robot with `<mimic>` joints in a session (issue 36 item 1): `robosim import urdf` of the
//! corpus Panda (its second finger mimics the first) gives a session robot whose coordinates
//! are the reduced ones — the follower is a mimic joint (`Kinematics::Mimic`), not a
//! coordinate — and the protocol's fk, jacobian, id and mass_matrix on the session's robot
//! answer what the pure ops answer on the same file read as `{"urdf": FILE, "mimic": true}`
//! (checked against Pinocchio's `mimic=True` model by hl-interface's protocol::mimic test).
//! A session write takes the reduced q (a full-length q is refused by name) and puts the
//! follower at its relation's value.

use crate::common::{self, Down, Procs};
use robosim_instance_space::{Kinematics, Reader};
use serde_json::{Value, json};
use std::path::PathBuf;

const PANDA: &str = "testdata/urdf_corpus/robots/panda_description/panda.urdf";

fn ok(k: &Procs, args: &[&str]) -> String {
    let (good, out) = common::robosim(k, args);
    assert!(good, "robosim {args:?} failed:\n{out}");
    out
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("array, got {v}"))
        .iter()
        .flat_map(|x| match x {
            Value::Array(_) => nums(x),
            x => vec![x.as_f64().expect("number")],
        })
        .collect()
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn a_urdf_robot_with_mimic_joints_in_a_session_answers_as_the_pure_mimic_ops() {
    let k = Procs::new("mimics");
    let _down = Down(&k);
    ok(&k, &["up", "demo"]);
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(PANDA);
    let file_s = file.to_str().expect("UTF-8 path");
    // Not "panda": a pure op naming a built-in robot answers for the built-in one.
    ok(&k, &["import", "urdf", file_s, "--as", "arm", "--mimic"]);

    // The file's whole tree: 9 joints, the right finger's joint follows the left one's.
    let tree = robosim_file_io::urdf_import::import_urdf_tree(&file).expect("imports");
    let c = tree.coupling.as_ref().expect("a coupling");
    assert_eq!((c.full_nq(), c.reduced_nq()), (9, 8));
    let follower = (0..9).find(|&i| c.is_follower(i)).expect("a follower");
    let leader = (tree.joints.iter())
        .position(|j| j.name == "panda_finger_joint1")
        .expect("the leader");

    // The session holds the follower as a mimic joint, its leader by index.
    let session = k.session();
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let view = snap.robot("arm").expect("arm");
    assert_eq!(view.joints.len(), 9);
    let m = view.joints[follower]
        .mimic
        .expect("the follower is a mimic joint");
    assert_eq!(m.leader, Some(leader as u32));
    assert_eq!((m.multiplier, m.offset), (1.0, 0.0));
    assert!(matches!(
        snap.rec(view.joints[follower].index).kinematics(),
        Some(Kinematics::Mimic { .. })
    ));
    let world = robosim_scene::pose::to_matrix(&snap.world_pose(view.index));
    assert_eq!(
        world,
        nalgebra::Matrix4::identity(),
        "imported at the origin"
    );
    drop(snap);
    drop(reader);

    // a reduced q inside the limits: the arm anywhere, the finger half open
    let qr: Vec<f64> = (c.free().iter())
        .map(|&i| match tree.joints[i].name.as_str() {
            "panda_finger_joint1" => 0.02,
            "panda_joint4" => -1.5,
            "panda_joint6" => 1.2,
            _ => 0.1 * (i as f64 + 1.0) - 0.35,
        })
        .collect();
    let (v, a): (Vec<f64>, Vec<f64>) = (0..8)
        .map(|k| (0.3 - 0.05 * k as f64, 0.5 * (k as f64) - 1.0))
        .unzip();
    let pure = json!({"urdf": file_s, "mimic": true});
    let mut full_q = c.expand_q(&qr).expect("q");
    full_q[follower] = 0.01; // not the relation's value
    let target: Vec<f64> = qr.iter().map(|x| x * 0.5).collect();
    let requests = [
        json!({"op": "get_robot", "robot": "arm"}),
        json!({"op": "fk", "robot": "arm", "q": qr, "frames": true}),
        json!({"op": "fk", "robot": pure, "q": qr, "frames": true}),
        json!({"op": "jacobian", "robot": "arm", "q": qr}),
        json!({"op": "jacobian", "robot": pure, "q": qr}),
        json!({"op": "id", "robot": "arm", "q": qr, "qd": v, "qdd": a}),
        json!({"op": "id", "robot": pure, "q": qr, "qd": v, "qdd": a}),
        json!({"op": "mass_matrix", "robot": "arm", "q": qr}),
        json!({"op": "mass_matrix", "robot": pure, "q": qr}),
        json!({"op": "c_switch", "on": false}),
        json!({"op": "movej", "robot": "arm", "q": full_q}),
        json!({"op": "movej", "robot": "arm", "q": target}),
        json!({"op": "get_robot", "robot": "arm"}),
        json!({"op": "jacob", "robot": "arm"}),
        json!({"op": "jacobian", "robot": pure, "q": target}),
    ];
    let lines: String = (requests.iter().enumerate())
        .map(|(n, r)| {
            let mut r = r.clone();
            r["id"] = json!(n);
            format!("{r}\n")
        })
        .collect();
    let input = k.home.path().join("requests.jsonl");
    std::fs::write(&input, lines).expect("requests");
    let out = ok(&k, &["query", "--input", input.to_str().expect("UTF-8")]);
    let answers: Vec<Value> = (out.lines())
        .map(|l| serde_json::from_str(l).expect("JSON answer"))
        .collect();
    assert_eq!(answers.len(), requests.len(), "{out}");
    for (n, ans) in answers.iter().enumerate() {
        if n != 10 {
            assert_eq!(ans["ok"], true, "request {n}: {ans}");
        }
    }

    // get_robot: 8 coordinates, the follower at its leader's value in the full q.
    assert_eq!(nums(&answers[0]["q"]).len(), 8, "{}", answers[0]);
    assert_eq!(answers[0]["coordinates"], json!(c.free()), "{}", answers[0]);
    // fk (every frame), jacobian, id, mass_matrix: the session's = the pure mimic op's.
    for (s, p, field, tol) in [
        (1, 2, "frames", 1e-12),
        (3, 4, "jacobian", 1e-12),
        (5, 6, "tau", 1e-10),
        (7, 8, "mass_matrix", 1e-10),
        (13, 14, "jacobian", 1e-12),
    ] {
        let (x, y) = (nums(&answers[s][field]), nums(&answers[p][field]));
        assert!(!y.is_empty(), "{field}: {}", answers[p]);
        let e = max_rel(&x, &y);
        assert!(e <= tol, "{field} (requests {s}, {p}): {e:e}");
    }
    assert_eq!(nums(&answers[5]["tau"]).len(), 8);
    assert_eq!(nums(&answers[3]["jacobian"]).len(), 6 * 8);

    // A full-length q is refused by name; the reduced one moves the robot, the follower with
    // its leader.
    assert_eq!(answers[10]["ok"], false, "{}", answers[10]);
    let msg = answers[10]["error"]["message"].as_str().unwrap_or("");
    assert!(
        msg.contains("9 values") && msg.contains("8 coordinates"),
        "{msg}"
    );
    assert_eq!(answers[11]["completed"], true, "{}", answers[11]);
    assert_eq!(nums(&answers[12]["q"]), target, "{}", answers[12]);
    let q_full = nums(&answers[12]["q_full"]);
    assert_eq!(q_full[follower], q_full[leader]);
    assert_eq!(
        q_full[leader],
        target[c.free().iter().position(|&i| i == leader).expect("free")]
    );

    // What the session holds: the follower's committed value and its link where FK puts it.
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let view = snap.robot("arm").expect("arm");
    let full = c.expand_q(&target).expect("q");
    let frames = robosim_kinematics::fk::link_frames(&tree.robot, &full);
    for (j, link) in view.joints.iter().enumerate() {
        assert_eq!(snap.poses()[link.index].joint, full[j], "joint {j}");
        let m = robosim_scene::pose::to_matrix(&snap.poses()[link.index].pose);
        assert!((m - frames[j + 1]).abs().max() < 1e-12, "link {j}");
    }
    drop(snap);
    drop(reader);

    // The simulator holds the coupled robot at its committed joints (its pipeline would move
    // the follower on its own): published with `held` saying why, never stepped, a command to
    // it refused with that reason — and the simulator keeps running.
    let mut sim = std::process::Command::new(common::ROBOSIM)
        .args(["simulator", "--mode", "lockstep", "--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("simulator");
    // The joint state it publishes, read from its first record on.
    let mut published = common::wait_for("the simulator's state service", || {
        robosim_instance_space::state::StateSubscriber::open(&session, "simulator", "test-state")
            .ok()
    });
    // 10 steps asked for once, when the simulator is there to take them.
    common::wait_for("the simulator to take a step command", || {
        let (good, _) = common::robosim(&k, &["simctl", r#"{"cmd": "step", "n": 10}"#]);
        good.then_some(())
    });
    let state = common::wait_for("the simulator after 10 steps", || {
        let (good, out) = common::robosim(&k, &["simctl", "get"]);
        let g: Value = serde_json::from_str(&out).ok().filter(|_| good)?;
        (g["run_steps"].as_u64()? >= 10).then_some(g)
    });
    // The published clock is the stepping robots' (10 steps of dt), not the held robot's,
    // which stays at 0 — the held `arm` comes last among the session's robots.
    let dt = state["t_s"].as_f64().expect("t_s") / 10.0;
    let clock = common::wait_for("a published state after 10 steps", || {
        let records = published.wait(std::time::Duration::from_millis(100)).ok()?;
        records
            .iter()
            .map(|r| r.header.t)
            .reduce(f64::max)
            .filter(|t| *t > 0.0)
    });
    assert!(
        dt > 0.0 && (clock - 10.0 * dt).abs() < 1e-9 * (10.0 * dt),
        "published t = {clock} s after 10 steps of {dt} s"
    );
    let target_cmd = json!({"cmd": "target", "robot": "arm", "q": full}).to_string();
    let (took, refusal) = common::robosim(&k, &["simctl", &target_cmd]);
    let _ = sim.kill();
    let _ = sim.wait();
    let arm = (state["robots"].as_array().expect("robots").iter())
        .find(|r| r["name"] == "arm")
        .unwrap_or_else(|| panic!("the simulator shows the robot: {state}"));
    let held = arm["held"]
        .as_str()
        .unwrap_or_else(|| panic!("held: {arm}"));
    assert!(held.contains("mimic joint"), "{held}");
    assert_eq!(nums(&arm["q"]), full, "held at its committed joints: {arm}");
    assert!(!took && refusal.contains("mimic joint"), "{refusal}");
}
