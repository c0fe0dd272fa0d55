//! A floating robot in a session (issue 36): `robosim import urdf FILE --floating` puts Solo-12
//! in a running session with its free-flyer root (the robot object is its base link), and the
//! protocol's fk, id and mass_matrix on the session's robot answer what the pure ops answer on
//! the same file read as `{"urdf": FILE, "floating": true}` — the session robot at q being the
//! file's robot at q with its root moved by the object's world pose. A session write keeps the
//! root at the identity (the base moves with the object); a joint write moves the links to the
//! floating robot's FK relative to the base link.

use crate::common::{self, Down, Procs};
use nalgebra::{Matrix4, Rotation3, UnitQuaternion, Vector3};
use robosim_instance_space::{Kinematics, Reader};
use serde_json::{Value, json};
use std::path::PathBuf;

const SOLO: &str = "testdata/urdf_corpus/robots/solo_description/solo12.urdf";

fn ok(k: &Procs, args: &[&str]) -> String {
    let (good, out) = common::robosim(k, args);
    assert!(good, "robosim {args:?} failed:\n{out}");
    out
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("array, got {v}"))
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn matrix(v: &Value) -> Matrix4<f64> {
    let r: Vec<Vec<f64>> = v.as_array().expect("rows").iter().map(nums).collect();
    let mut m = Matrix4::identity();
    for (i, row) in r.iter().enumerate().take(4) {
        for (j, x) in row.iter().enumerate().take(4) {
            m[(i, j)] = *x;
        }
    }
    m
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

/// The reference's first Solo-12 sample (a unit quaternion, joints anywhere): q (19), v and a (18).
fn sample() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("testdata/floating/reference.json"),
    )
    .expect("testdata/floating/reference.json");
    let r: Value = serde_json::from_str(&text).expect("JSON");
    let s = &r["robots"][0]["samples"][0];
    (nums(&s["q"]), nums(&s["v"]), nums(&s["a"]))
}

#[test]
fn a_floating_urdf_robot_in_a_session_answers_as_the_pure_ops_on_its_file() {
    let k = Procs::new("floats");
    let _down = Down(&k);
    ok(&k, &["up", "demo"]);
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(SOLO);
    let file_s = file.to_str().expect("UTF-8 path");
    let out = ok(
        &k,
        &[
            "import",
            "urdf",
            file_s,
            "--floating",
            "--as",
            "solo",
            "--at",
            "0.5,0.2,0.3,10,-20,30",
        ],
    );
    assert!(out.contains("a free_flyer base and 12 joints"), "{out}");

    // The robot object is the base link: its record names the root, its mass is the trunk's.
    let session = k.session();
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let i = snap.find("solo").expect("solo");
    assert!(
        matches!(
            snap.rec(i).kinematics(),
            Some(Kinematics::FloatingRobot { .. })
        ),
        "{:?}",
        snap.rec(i).kinematics()
    );
    let file_robot = robosim_file_io::urdf_import::import_urdf_tree_floating(
        &file,
        robosim_kinematics::RootKind::FreeFlyer,
    )
    .expect("imports");
    let trunk = file_robot.robot.root.as_ref().expect("root");
    assert_eq!(snap.rec(i).dynamics().map(|m| m.mass), Some(trunk.mass));
    let world = robosim_scene::pose::to_matrix(&snap.world_pose(i));
    drop(snap);
    drop(reader);

    // q of the session robot; q_file: the same robot of the file, its root moved by `world`.
    let (q, v, a) = sample();
    let r_world = Rotation3::from_matrix_unchecked(world.fixed_view::<3, 3>(0, 0).into_owned());
    let quat = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[6], q[3], q[4], q[5]));
    let p = r_world * Vector3::new(q[0], q[1], q[2]) + world.fixed_view::<3, 1>(0, 3);
    let moved = UnitQuaternion::from_rotation_matrix(&r_world) * quat;
    let mut q_file = q.clone();
    q_file[..3].copy_from_slice(p.as_slice());
    q_file[3..7].copy_from_slice(moved.coords.as_slice());

    let pure = json!({"urdf": file_s, "floating": true});
    let mut neutral_joints = vec![0.0; 19];
    neutral_joints[6] = 1.0;
    neutral_joints[8] = 0.4;
    let mut moved_root = neutral_joints.clone();
    moved_root[0] = 0.1;
    let requests = [
        json!({"op": "get_robot", "robot": "solo"}),
        json!({"op": "fk", "robot": "solo", "q": q, "frames": true}),
        json!({"op": "fk", "robot": pure, "q": q_file, "frames": true}),
        json!({"op": "id", "robot": "solo", "q": q, "qd": v, "qdd": a}),
        json!({"op": "id", "robot": pure, "q": q_file, "qd": v, "qdd": a}),
        json!({"op": "mass_matrix", "robot": "solo", "q": q}),
        json!({"op": "mass_matrix", "robot": pure, "q": q_file}),
        json!({"op": "c_switch", "on": false}),
        json!({"op": "movej", "robot": "solo", "q": moved_root}),
        json!({"op": "movej", "robot": "solo", "q": neutral_joints}),
        json!({"op": "get_robot", "robot": "solo"}),
    ];
    let lines: String = requests
        .iter()
        .enumerate()
        .map(|(n, r)| {
            let mut r = r.clone();
            r["id"] = json!(n);
            format!("{r}\n")
        })
        .collect();
    let input = k.home.path().join("requests.jsonl");
    std::fs::write(&input, lines).expect("requests");
    let out = ok(&k, &["query", "--input", input.to_str().expect("UTF-8")]);
    let answers: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON answer"))
        .collect();
    assert_eq!(answers.len(), requests.len(), "{out}");
    for (n, ans) in answers.iter().enumerate() {
        if n != 8 {
            assert_eq!(ans["ok"], true, "request {n}: {ans}");
        }
    }

    // get_robot: the root inline, q = nq values with the root at the identity.
    assert_eq!(
        answers[0]["robot"]["root"]["kind"], "free_flyer",
        "{}",
        answers[0]
    );
    let q_now = nums(&answers[0]["q"]);
    assert_eq!(q_now.len(), 19);
    assert_eq!(&q_now[..7], &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);

    // fk: every frame, the session's (q) = the file's (q_file), and frames[0] is the base link.
    let (fs, ff) = (
        answers[1]["frames"].as_array().expect("frames"),
        answers[2]["frames"].as_array().expect("frames"),
    );
    assert_eq!(fs.len(), 12 + 2);
    assert_eq!(fs.len(), ff.len());
    for (j, (a, b)) in fs.iter().zip(ff).enumerate() {
        let e = (matrix(a) - matrix(b)).abs().max();
        assert!(e < 1e-12, "frame {j}: {e:e}");
    }
    // id and mass_matrix: the same numbers (gravity seen from the moved base included).
    let e = max_diff(&nums(&answers[3]["tau"]), &nums(&answers[4]["tau"]));
    let scale = nums(&answers[4]["tau"])
        .iter()
        .fold(1.0_f64, |m, x| m.max(x.abs()));
    assert!(e <= 1e-10 * scale, "id: {e:e}");
    let flat = |v: &Value| -> Vec<f64> {
        v["m"]
            .as_array()
            .or_else(|| v["mass_matrix"].as_array())
            .unwrap_or_else(|| panic!("a matrix in {v}"))
            .iter()
            .flat_map(nums)
            .collect()
    };
    let (ms, mf) = (flat(&answers[5]), flat(&answers[6]));
    assert_eq!(ms.len(), 18 * 18);
    assert!(max_diff(&ms, &mf) <= 1e-10, "mass_matrix");

    // A write with the root off the identity is refused (the base is the object's pose); one
    // with the root held moves the joints.
    assert_eq!(answers[8]["ok"], false, "{}", answers[8]);
    assert!(
        answers[8]["error"]["message"]
            .as_str()
            .is_some_and(|m| m.contains("pretranslate")),
        "{}",
        answers[8]
    );
    assert_eq!(answers[9]["completed"], true, "{}", answers[9]);
    assert_eq!(nums(&answers[10]["q"]), neutral_joints);

    // The links the session now holds: the floating robot's FK at that q, relative to the
    // base link (the robot object), and the object did not move.
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let i = snap.find("solo").expect("solo");
    assert_eq!(robosim_scene::pose::to_matrix(&snap.world_pose(i)), world);
    let robot = snap.robot("solo").expect("solo");
    let frames = robosim_kinematics::fk::link_frames(&file_robot.robot, &neutral_joints);
    for (j, link) in robot.joints.iter().enumerate() {
        let m = robosim_scene::pose::to_matrix(&snap.poses()[link.index].pose);
        assert!((m - frames[j + 1]).abs().max() < 1e-12, "link {j}");
        assert_eq!(snap.poses()[link.index].joint, neutral_joints[7 + j]);
    }
}

/// Asks the session's simulator (`robosim simctl`), returning whether it was accepted and what
/// it printed.
fn simctl(k: &Procs, cmds: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(common::ROBOSIM)
        .arg("simctl")
        .args(["--session", &k.name])
        .args(cmds)
        .env("ROBOSIM_HOME", k.home.path())
        .env("IOX2_LOG_LEVEL", "Error")
        .output()
        .expect("simctl");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr),
    )
}

/// A 3×4 row-major pose record as a 4×4 matrix.
fn pose_matrix(p: &[f64; 12]) -> Matrix4<f64> {
    robosim_scene::pose::to_matrix(p)
}

/// The simulator daemon integrates a floating session robot (issue 36 item 2): Solo-12 imported
/// with `--floating` at a turned pose falls under gravity in a lock-step daemon for 200 steps
/// of 2 ms (RK4) while its joints are driven by torques; what the daemon publishes — the
/// robot object's pose (committed pose ∘ root motion) and the joints' q (the root left out) —
/// and the root `get` reports equal the query protocol's `simulate` of the same file from the
/// same state (the root at the object's pose, the same torques, integrator and step) to 1e-9;
/// the quaternion stays unit. A joint target for it is refused by name.
#[test]
fn the_simulator_integrates_a_floating_session_robot_as_simulate_does() {
    const STEPS: usize = 200;
    const DT: f64 = 0.002;
    let mut k = Procs::new("floatsim");
    k.start_keeper(&[]);
    let session = k.session();
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(SOLO);
    let file_s = file.to_str().expect("UTF-8 path");
    ok(
        &k,
        &[
            "import",
            "urdf",
            file_s,
            "--floating",
            "--as",
            "solo",
            "--at",
            "0.3,-0.2,1.5,10,-20,30",
        ],
    );
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let i = snap.find("solo").expect("solo");
    let (object_id, world0, local0) = (
        snap.rec(i).id,
        pose_matrix(&snap.world_pose(i)),
        pose_matrix(&snap.pose(i).pose),
    );
    let robot = snap.robot("solo").expect("solo");
    let links: Vec<u64> = robot.joints.iter().map(|l| snap.rec(l.index).id).collect();
    assert_eq!(links.len(), 12);
    drop(snap);
    drop(reader);

    let effects = k.home.path().join("effects.json");
    std::fs::write(
        &effects,
        format!(
            r#"{{"dt": {DT}, "kinematics": true, "dynamics": {{"integrator": "rk4", "dt": {DT}, "gravity": [0, 0, -9.81]}}}}"#
        ),
    )
    .expect("effects");
    let eff = effects.to_str().expect("UTF-8").to_owned();
    k.spawn(&["simulator", "--mode", "lockstep", "--effects", &eff]);
    let mut state = common::wait_for("the state service", || {
        robosim_instance_space::state::StateSubscriber::open(&session, "simulator", "test").ok()
    });
    common::wait_for("the simulator registered", || {
        session
            .processes()
            .iter()
            .any(|p| p.role == "simulator")
            .then_some(())
    });

    // a joint target would need the root actuated: refused by name, nothing changed
    let (good, out) = simctl(
        &k,
        &[r#"{"cmd": "target", "robot": "solo", "q": [0,0,0,0,0,0,0,0,0,0,0,0]}"#],
    );
    assert!(
        !good && out.contains("free_flyer base") && out.contains("`torque`"),
        "{out}"
    );
    let tau = [
        0.3, -0.2, 0.1, -0.3, 0.25, -0.1, 0.2, 0.15, -0.2, -0.1, 0.3, 0.05,
    ];
    let torque = json!({"cmd": "torque", "robot": "solo", "tau": tau}).to_string();
    let step = json!({"cmd": "step", "n": STEPS}).to_string();
    let (good, out) = simctl(&k, &[&torque, &step]);
    assert!(good, "{out}");
    let mut records = Vec::new();
    common::wait_for("the states of every step", || {
        records.extend(
            state
                .wait(std::time::Duration::from_millis(100))
                .expect("state"),
        );
        (records.len() >= STEPS).then_some(())
    });
    let last = records.last().expect("records");
    assert!((last.header.t - STEPS as f64 * DT).abs() < 1e-12);
    let (good, out) = simctl(&k, &["get"]);
    assert!(good, "{out}");
    let get: Value = serde_json::from_str(out.trim()).expect("get's JSON");
    let got = &get["robots"][0];
    assert_eq!(got["name"], "solo", "{get}");

    // the query protocol's simulate of the file: the root at the object's world pose
    let r0 = Rotation3::from_matrix_unchecked(world0.fixed_view::<3, 3>(0, 0).into_owned());
    let quat0 = UnitQuaternion::from_rotation_matrix(&r0);
    let mut q0 = vec![0.0; 19];
    q0[..3].copy_from_slice(&[world0[(0, 3)], world0[(1, 3)], world0[(2, 3)]]);
    q0[3..7].copy_from_slice(quat0.coords.as_slice());
    let mut tau_v = vec![0.0; 18];
    tau_v[6..].copy_from_slice(&tau);
    let t_end = STEPS as f64 * DT;
    let request = json!({
        "op": "simulate", "id": 0, "robot": {"urdf": file_s, "floating": true},
        "q0": q0, "tau": tau_v, "t_end": t_end, "outputs": [t_end],
        "integrator": "rk4", "dt": DT,
    });
    let input = k.home.path().join("simulate.jsonl");
    std::fs::write(&input, format!("{request}\n")).expect("request");
    let out = ok(&k, &["query", "--input", input.to_str().expect("UTF-8")]);
    let answer: Value = serde_json::from_str(out.lines().next().expect("answer")).expect("JSON");
    assert_eq!(answer["ok"], true, "{answer}");
    let sample = &answer["samples"][0];
    let q_ref = nums(&sample["q"]);
    let m_ref = robosim_kinematics::RootKind::FreeFlyer.transform(&q_ref[..7]);

    // published: the object's pose (relative to its parent) = committed ∘ root motion
    let body = last
        .bodies
        .iter()
        .find(|b| b.id == object_id)
        .expect("the robot object's pose is published");
    let world_pub = world0 * local0.try_inverse().expect("rigid") * pose_matrix(&body.pose);
    let e_pose = (world_pub - m_ref).abs().max();
    // published: the joints' q, in link order
    let q_pub: Vec<f64> = links
        .iter()
        .map(|id| {
            last.joints
                .iter()
                .find(|j| j.id == *id)
                .expect("every link's joint")
                .q
        })
        .collect();
    let e_joints = max_diff(&q_pub, &q_ref[7..]);
    // get: the root (relative to the object's committed pose) and the base link's world pose
    let root = &got["root"];
    assert_eq!(root["kind"], "free_flyer", "{got}");
    let q_root = nums(&root["q"]);
    let quat_norm = q_root[3..7].iter().map(|x| x * x).sum::<f64>().sqrt();
    let e_base = (matrix(&root["base"]) - m_ref).abs().max();
    let e_root = (world0 * robosim_kinematics::RootKind::FreeFlyer.transform(&q_root) - m_ref)
        .abs()
        .max();
    let e_get_q = max_diff(&nums(&got["q"]), &q_ref[7..]);
    let e_get_v = max_diff(
        &nums(&root["v"])
            .into_iter()
            .chain(nums(&got["qd"]))
            .collect::<Vec<_>>(),
        &nums(&sample["qd"]),
    );
    eprintln!(
        "measured: floating Solo-12 in the session simulator vs simulate, {STEPS} rk4 steps of {DT} s: \
         object pose {e_pose:.2e}, joints q {e_joints:.2e}, get base {e_base:.2e}, root {e_root:.2e}, \
         v {e_get_v:.2e}, |quat| − 1 = {:.2e}; base fell {:.3} m",
        quat_norm - 1.0,
        world0[(2, 3)] - m_ref[(2, 3)]
    );
    assert!(e_pose < 1e-9, "object pose: {e_pose:e}");
    assert!(e_joints < 1e-9, "joints: {e_joints:e}");
    assert!(e_base < 1e-9 && e_root < 1e-9, "get: {e_base:e} {e_root:e}");
    assert!(
        e_get_q < 1e-9 && e_get_v < 1e-8,
        "get: {e_get_q:e} {e_get_v:e}"
    );
    assert!(
        (quat_norm - 1.0).abs() < 1e-12,
        "quaternion norm {quat_norm}"
    );
    // it fell (½ g t² = 0.78 m for the centre of mass) and the joints turned
    assert!(world0[(2, 3)] - m_ref[(2, 3)] > 0.5, "{m_ref}");
    assert!(q_pub.iter().any(|q| q.abs() > 1e-2), "{q_pub:?}");
    // the committed pose has not moved: nothing was written to the Instance Space
    let reader = Reader::attach(&session, "test").expect("attach");
    let snap = reader.snapshot().expect("snapshot");
    let i = snap.find("solo").expect("solo");
    assert_eq!(pose_matrix(&snap.world_pose(i)), world0);
}

/// What the simulator does not simulate for a floating robot is refused by name: kinematic
/// motion without dynamics (the daemon's default effects, "kinematics only") has no law that
/// moves a free base. A running lock-step daemon that sees Solo imported with `--floating`
/// stops with the refusal, and one started on a session holding it does not start — each exits
/// unsuccessfully, its log naming the robot, the root's kind and the effect.
#[test]
fn the_simulator_refuses_kinematic_motion_of_a_floating_robot_by_name() {
    let mut k = Procs::new("floatkin");
    k.start_keeper(&[]);
    let session = k.session();
    let sim = k.spawn(&["simulator", "--mode", "lockstep"]);
    common::wait_for("the simulator registered", || {
        session
            .processes()
            .iter()
            .any(|p| p.role == "simulator")
            .then_some(())
    });
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(SOLO);
    let file_s = file.to_str().expect("UTF-8 path");
    ok(
        &k,
        &["import", "urdf", file_s, "--floating", "--as", "solo"],
    );
    let refused = |k: &mut Procs, pid: u32| {
        let i = k
            .children
            .iter()
            .position(|c| c.id() == pid)
            .expect("a process this test started");
        let status = common::wait_for("the simulator to stop", || {
            k.children[i].try_wait().expect("try_wait")
        });
        assert!(
            !status.success(),
            "the simulator ran kinematic motion of a floating robot"
        );
        let log = k.home.path().join(format!("logs/{pid}-simulator.log"));
        let text = std::fs::read_to_string(&log).expect("the simulator's log");
        assert!(
            text.contains("robot solo")
                && text.contains("`dynamics`")
                && text.contains("free_flyer base")
                && text.contains("declare the dynamics effect"),
            "{text}"
        );
    };
    // running when the robot arrives
    refused(&mut k, sim);
    // started on a session that holds it
    let again = k.spawn(&["simulator", "--mode", "lockstep"]);
    refused(&mut k, again);
}
