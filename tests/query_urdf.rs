//! `"robot": {"urdf": PATH, "tip": LINK}` through the real `robosim query` process: FK and both
//! Jacobians of the vendored UR5 and Panda URDFs against Pinocchio 4.1
//! (testdata/urdf/pinocchio_reference.json, made by pinocchio_reference.py), IK round trips
//! checked by FK, dynamics ops on the same robot, and the errors for a missing file, a tip that
//! is not a link, malformed XML and a field of the wrong type — each answered in place.

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

const ROBOSIM: &str = env!("CARGO_BIN_EXE_robosim");

fn urdf_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/urdf")
}

/// One `robosim query` process, asked one line at a time.
struct Query {
    child: Child,
    to: Option<ChildStdin>,
    from: BufReader<ChildStdout>,
}

impl Query {
    fn start() -> Query {
        let mut child = Command::new(ROBOSIM)
            .arg("query")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn robosim query");
        let to = child.stdin.take();
        let from = BufReader::new(child.stdout.take().expect("stdout"));
        Query { child, to, from }
    }

    fn ask(&mut self, req: &Value) -> Value {
        let to = self.to.as_mut().expect("stdin open");
        writeln!(to, "{req}").expect("write request");
        to.flush().expect("flush");
        let mut line = String::new();
        self.from.read_line(&mut line).expect("read answer");
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("answer not JSON ({e}): {line}"))
    }

    fn ok(&mut self, req: &Value) -> Value {
        let a = self.ask(req);
        assert_eq!(a["ok"], true, "{req} answered {a}");
        a
    }

    fn finish(mut self) {
        drop(self.to.take());
        let status = self.child.wait().expect("wait");
        assert!(status.success(), "robosim query exited with {status:?}");
    }
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Largest entry-wise difference of two nested arrays of the same shape.
fn max_diff(a: &Value, b: &Value) -> f64 {
    let (ra, rb) = (a.as_array().expect("rows"), b.as_array().expect("rows"));
    assert_eq!(ra.len(), rb.len(), "row count: {a} vs {b}");
    ra.iter()
        .zip(rb)
        .map(|(x, y)| {
            let (x, y) = (floats(x), floats(y));
            assert_eq!(x.len(), y.len(), "column count");
            x.iter()
                .zip(&y)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

fn reference() -> Value {
    serde_json::from_str(
        &std::fs::read_to_string(urdf_dir().join("pinocchio_reference.json")).expect("reference"),
    )
    .expect("reference JSON")
}

fn urdf_robot(r: &Value) -> Value {
    let file = urdf_dir().join(r["file"].as_str().expect("file"));
    json!({"urdf": file.to_str().expect("utf-8 path"), "tip": r["tip"]})
}

#[test]
fn urdf_robots_answer_fk_and_jacobian_as_pinocchio() {
    let reference = reference();
    let mut query = Query::start();
    let (mut worst_fk, mut worst_j) = (0.0_f64, 0.0_f64);
    for name in ["ur5", "panda"] {
        let r = &reference["robots"][name];
        let robot = urdf_robot(r);
        let samples = r["samples"].as_array().expect("samples");
        assert_eq!(samples.len(), 20);
        for (i, s) in samples.iter().enumerate() {
            let fk = query.ok(&json!({"id": i, "op": "fk", "robot": robot, "q": s["q"]}));
            let e_fk = max_diff(&fk["pose"], &s["tip"]);
            assert!(e_fk <= 1e-12, "{name} sample {i}: FK off by {e_fk:e}");
            let mut e_j: f64 = 0.0;
            for (frame, key) in [("base", "jacobian"), ("tool", "jacobian_tool")] {
                let j = query
                    .ok(&json!({"op": "jacobian", "robot": robot, "q": s["q"], "frame": frame}));
                e_j = e_j.max(max_diff(&j["jacobian"], &s[key]));
            }
            assert!(e_j <= 1e-12, "{name} sample {i}: Jacobian off by {e_j:e}");
            worst_fk = worst_fk.max(e_fk);
            worst_j = worst_j.max(e_j);
        }
    }
    eprintln!(
        "robosim query on URDF robots vs Pinocchio: FK {worst_fk:.1e}, Jacobian {worst_j:.1e}"
    );
    query.finish();
}

#[test]
fn urdf_robots_answer_ik_and_dynamics() {
    let reference = reference();
    let mut query = Query::start();
    for name in ["ur5", "panda"] {
        let r = &reference["robots"][name];
        let robot = urdf_robot(r);
        for s in r["samples"].as_array().expect("samples").iter().take(3) {
            let target = &s["tip"];
            // A start near the answer: numeric IK from far away may find another branch or
            // none; the round trip is what is checked.
            let q0: Vec<f64> = floats(&s["q"]).iter().map(|x| x + 0.1).collect();
            let ik = query.ok(&json!({"op": "ik", "robot": robot, "pose": target, "q0": q0}));
            let sols = ik["solutions"].as_array().expect("solutions");
            assert!(!sols.is_empty(), "{name}: {ik}");
            for sol in sols {
                let back = query.ok(&json!({"op": "fk", "robot": robot, "q": sol["q"]}));
                let e = max_diff(&back["pose"], target);
                assert!(e <= 1e-9, "{name}: IK solution off by {e:e} under FK: {ik}");
            }
        }
        // The dynamics ops take the same robot; the UR5's URDF has no friction, so its inverse
        // dynamics is Pinocchio's RNEA.
        let s = &r["samples"][0];
        let g = query.ok(&json!({"op": "gravity", "robot": robot, "q": s["q"]}));
        assert_eq!(
            g["tau"].as_array().map(Vec::len),
            s["q"].as_array().map(Vec::len)
        );
        if name == "ur5" {
            let id = query.ok(
                &json!({"op": "id", "robot": robot, "q": s["q"], "qd": s["qd"], "qdd": s["qdd"]}),
            );
            let (ours, theirs) = (floats(&id["tau"]), floats(&s["rnea"]));
            let scale = theirs.iter().map(|x| x.abs()).fold(1.0, f64::max);
            let e = ours
                .iter()
                .zip(&theirs)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
                / scale;
            assert!(e <= 1e-10, "UR5 id vs Pinocchio RNEA: {e:e} relative");
        }
    }
    query.finish();
}

#[test]
fn urdf_robot_errors_name_what_and_where() {
    let dir = tempfile::tempdir().expect("tempdir");
    let broken = dir.path().join("broken.urdf");
    std::fs::write(
        &broken,
        "<robot name=\"r\">\n  <link name=\"a\"/>\n  <joint name=\"j\" type=\"revolute\">\n</robot>\n",
    )
    .expect("write broken URDF");
    let ur5 = urdf_dir().join("ur5_robot.urdf");
    let ur5 = ur5.to_str().expect("utf-8 path");
    let missing = dir.path().join("nowhere.urdf");
    let missing = missing.to_str().expect("utf-8 path");
    let mut query = Query::start();
    let q6 = json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let cases: [(Value, &[&str]); 5] = [
        (
            json!({"urdf": missing, "tip": "tool0"}),
            &["robot.urdf", missing, "cannot read"],
        ),
        (
            json!({"urdf": ur5, "tip": "gripper"}),
            &[
                "robot.urdf",
                "ur5_robot.urdf",
                "\"gripper\"",
                "not a <link>",
            ],
        ),
        (
            json!({"urdf": broken.to_str().expect("utf-8"), "tip": "a"}),
            &["broken.urdf:", "malformed XML"],
        ),
        (
            json!({"urdf": 5, "tip": "tool0"}),
            &["robot.urdf", "string"],
        ),
        (
            json!({"urdf": ur5, "tip": "tool0", "tpi": 1}),
            &["robot.tpi", "unknown field"],
        ),
    ];
    for (i, (robot, words)) in cases.iter().enumerate() {
        for op in ["fk", "jacobian", "gravity"] {
            let a = query.ask(&json!({"id": i, "op": op, "robot": robot, "q": q6}));
            assert_eq!(
                (a["id"].clone(), a["ok"].clone()),
                (json!(i), json!(false)),
                "{a}"
            );
            let kind = a["error"]["kind"].as_str().expect("kind");
            assert!(kind == "bad_robot" || kind == "invalid_robot", "{op}: {a}");
            let message = a["error"]["message"].as_str().expect("message");
            for w in *words {
                assert!(message.contains(w), "{op} {robot}: {message:?} lacks {w:?}");
            }
        }
    }
    // The stream goes on after the errors.
    let fk = query.ok(&json!({"op": "fk", "robot": {"urdf": ur5, "tip": "tool0"}, "q": q6}));
    assert_eq!(fk["pose"].as_array().map(Vec::len), Some(4));
    query.finish();
}
