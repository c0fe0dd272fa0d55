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

/// The simulator daemon and a floating session robot (issue 36): the simulator's pipeline holds
/// one coordinate per joint, so a floating root would not integrate and the robot object would
/// not move. The daemon refuses it by name instead: a running lock-step daemon that sees Solo
/// imported with `--floating` stops with the refusal, and one started on a session holding it
/// does not start — each exits unsuccessfully, its log naming the robot and the root's kind.
#[test]
fn the_simulator_refuses_a_floating_session_robot_by_name() {
    let mut k = Procs::new("floatsim");
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
        assert!(!status.success(), "the simulator ran a floating robot");
        let log = k.home.path().join(format!("logs/{pid}-simulator.log"));
        let text = std::fs::read_to_string(&log).expect("the simulator's log");
        assert!(
            text.contains("robot solo has a free_flyer base")
                && text.contains("does not integrate a floating root"),
            "{text}"
        );
    };
    // running when the robot arrives
    refused(&mut k, sim);
    // started on a session that holds it
    let again = k.spawn(&["simulator", "--mode", "lockstep"]);
    refused(&mut k, again);
}
