//! Floating bases through the query protocol (issue 36 item 2): Solo-12 read as
//! `{"urdf": PATH, "floating": true}` (and `"planar"`) answers fk, jacobian, id, gravity, fd and
//! mass_matrix with Pinocchio 4.1's values (testdata/floating/reference.json, made by
//! testdata/floating/make_floating_reference.py) for q of length nq and v/a/τ of length nv;
//! the inline form with `"root"` answers the same; `simulate` integrates on the manifold (a
//! robot at rest in free fall drops ½ g t² with its quaternion unchanged); a q of the wrong
//! length is refused naming nq, a velocity naming nv, a non-unit quaternion by its norm.
//! `ik` holds the root at q0 and solves one leg's chain from the base link (the answer a whole
//! q, the root bit for bit q0's); `encoder_error` uses the floating Jacobian's joint columns.

use nalgebra::DMatrix;
use robosim_file_io::urdf_import::import_urdf_tree_floating;
use robosim_hl_interface::ProtocolError;
use robosim_hl_interface::protocol::{dynamics, kinematics};
use robosim_hl_interface::robot_json::robot_to_json;
use robosim_kinematics::fk::link_pose;
use robosim_kinematics::{Robot, RootKind};
use serde_json::{Value, json};
use std::path::PathBuf;

const SOLO: &str = "testdata/urdf_corpus/robots/solo_description/solo12.urdf";
/// Relative tolerances over max(1, max |reference|): the core's floating.rs test's.
const DYN_TOL: f64 = 1e-10;
const POSE_TOL: f64 = 1e-12;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn no_library(_: &str) -> Option<Robot> {
    None
}

fn ask(req: Value) -> Result<Value, ProtocolError> {
    let op = req["op"].as_str().expect("op").to_string();
    kinematics::dispatch(&op, &req, &no_library)
        .or_else(|| dynamics::dispatch(&op, &req, &no_library))
        .expect("a kinematics or dynamics op")
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("array, got {v}"))
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn rows(v: &Value) -> DMatrix<f64> {
    let r: Vec<Vec<f64>> = v.as_array().expect("rows").iter().map(nums).collect();
    let (n, m) = (r.len(), r.first().map_or(0, Vec::len));
    DMatrix::from_fn(n, m, |i, j| r[i][j])
}

fn rel_err(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    got.iter()
        .zip(want)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

fn flat(m: &DMatrix<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

/// Pinocchio's velocity index k → robosim's (root first in both, then the joints by name).
fn velocity_map(robosim_names: &[String], pin_names: &[&str], nvr: usize) -> Vec<usize> {
    let mut out: Vec<usize> = (0..nvr).collect();
    for n in pin_names {
        let i = robosim_names
            .iter()
            .position(|j| j == n)
            .unwrap_or_else(|| panic!("joint {n} not imported"));
        out.push(nvr + i);
    }
    out
}

/// A reference vector (Pinocchio's order, `nroot` root entries first) in robosim's order.
fn to_robosim(values: &[f64], nroot: usize, map: &[usize], nvr: usize) -> Vec<f64> {
    let mut out = vec![0.0; values.len()];
    out[..nroot].copy_from_slice(&values[..nroot]);
    for (k, &i) in map.iter().enumerate().skip(nvr) {
        out[i - nvr + nroot] = values[k - nvr + nroot];
    }
    out
}

fn reference() -> Value {
    let text = std::fs::read_to_string(repo().join("testdata/floating/reference.json"))
        .expect("reference.json");
    serde_json::from_str(&text).expect("JSON")
}

#[test]
fn solo12_floating_from_a_urdf_answers_pinocchios_values() {
    let reference = reference();
    let path = repo().join(SOLO);
    let path_s = path.to_str().expect("UTF-8 path");
    let mut checked = 0;
    for rob in reference["robots"].as_array().expect("robots") {
        assert_eq!(rob["file"], SOLO);
        let kind_name = rob["root"].as_str().expect("root");
        let kind = RootKind::from_name(kind_name).expect("kind");
        // the joint names in robosim's order (the protocol's robot is the same import)
        let imported = import_urdf_tree_floating(&path, kind).expect("imports");
        let names: Vec<String> = imported.joints.iter().map(|j| j.name.clone()).collect();
        let pin_names: Vec<&str> = rob["joints"]
            .as_array()
            .expect("joints")
            .iter()
            .map(|n| n.as_str().expect("name"))
            .collect();
        let (nqr, nvr) = (kind.nq(), kind.nv());
        let (nq, nv) = (
            rob["nq"].as_u64().expect("nq") as usize,
            rob["nv"].as_u64().expect("nv") as usize,
        );
        let map = velocity_map(&names, &pin_names, nvr);
        let floating = if kind == RootKind::FreeFlyer {
            json!(true)
        } else {
            json!(kind_name)
        };
        let from_file = json!({"urdf": path_s, "floating": floating});
        let inline = robot_to_json(&imported.robot);
        assert_eq!(inline["root"]["kind"], kind_name, "{inline}");
        for s in rob["samples"].as_array().expect("samples") {
            let q = to_robosim(&nums(&s["q"]), nqr, &map, nvr);
            let [v, a, tau] = ["v", "a", "tau"].map(|k| to_robosim(&nums(&s[k]), nvr, &map, nvr));
            let want = |k: &str| to_robosim(&nums(&s[k]), nvr, &map, nvr);
            assert_eq!((q.len(), v.len()), (nq, nv));
            for robot in [&from_file, &inline] {
                let at = |what: &str| format!("{kind_name} {what} ({robot})");
                // fk: every link frame (frames[0] the base link, frames[k] joint k−1's child)
                let fk =
                    ask(json!({"op": "fk", "robot": robot, "q": q, "frames": true})).expect("fk");
                let frames = fk["frames"].as_array().expect("frames");
                assert_eq!(frames.len(), names.len() + 2);
                for (name, fr) in s["frames"].as_object().expect("frames") {
                    let link = names.iter().position(|n| n == name).map_or(0, |i| i + 1);
                    let e = rel_err(&flat(&rows(&frames[link])), &flat(&rows(&fr["pose"])));
                    assert!(e <= POSE_TOL, "{}: {e:e}", at(&format!("fk {name}")));
                }
                // the tool is the last joint's child link; its Jacobian has nv columns
                let last = names.last().expect("joints");
                let tool = &s["frames"][last.as_str()];
                let e = rel_err(&flat(&rows(&fk["pose"])), &flat(&rows(&tool["pose"])));
                assert!(e <= POSE_TOL, "{}: {e:e}", at("fk pose"));
                let jac = ask(json!({"op": "jacobian", "robot": robot, "q": q})).expect("jacobian");
                let j = rows(&jac["jacobian"]);
                assert_eq!((j.nrows(), j.ncols()), (6, nv));
                let j_ref = rows(&tool["jacobian"]);
                let j_want = DMatrix::from_fn(6, nv, |r, c| {
                    j_ref[(r, map.iter().position(|&x| x == c).expect("map"))]
                });
                let e = rel_err(&flat(&j), &flat(&j_want));
                assert!(e <= POSE_TOL, "{}: {e:e}", at("jacobian"));
                // dynamics
                let id = ask(json!({"op": "id", "robot": robot, "q": q, "qd": v, "qdd": a}))
                    .expect("id");
                let e = rel_err(&nums(&id["tau"]), &want("rnea"));
                assert!(e <= DYN_TOL, "{}: {e:e}", at("id"));
                let g = ask(json!({"op": "gravity", "robot": robot, "q": q})).expect("gravity");
                let e = rel_err(&nums(&g["tau"]), &want("gravity"));
                assert!(e <= DYN_TOL, "{}: {e:e}", at("gravity"));
                for method in ["aba", "cholesky"] {
                    let fd = ask(json!({"op": "fd", "robot": robot, "q": q, "qd": v, "tau": tau, "method": method}))
                        .expect("fd");
                    let e = rel_err(&nums(&fd["qdd"]), &want("aba"));
                    assert!(e <= DYN_TOL, "{}: {e:e}", at(&format!("fd {method}")));
                }
                let m =
                    ask(json!({"op": "mass_matrix", "robot": robot, "q": q})).expect("mass_matrix");
                let m_ref = rows(&s["M"]);
                let m_want = DMatrix::from_fn(nv, nv, |i, j| {
                    let pi = map.iter().position(|&x| x == i).expect("map");
                    let pj = map.iter().position(|&x| x == j).expect("map");
                    m_ref[(pi, pj)]
                });
                let e = rel_err(&flat(&rows(&m["mass_matrix"])), &flat(&m_want));
                assert!(e <= DYN_TOL, "{}: {e:e}", at("mass_matrix"));
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 16, "2 roots × 4 samples × 2 robot forms");
}

fn solo() -> Value {
    json!({"urdf": repo().join(SOLO).to_str().expect("UTF-8 path"), "floating": true})
}

/// Solo at rest, legs bent, the base tilted 0.4 rad about x at 1 m.
fn solo_q() -> Vec<f64> {
    let (s, c) = (0.2f64).sin_cos();
    let mut q = vec![0.0, 0.0, 1.0, s, 0.0, 0.0, c];
    for i in 0..12 {
        q.push([0.1, 0.8, -1.6][i % 3]);
    }
    q
}

#[test]
fn simulate_drops_a_resting_floating_robot_by_half_g_t_squared() {
    let q0 = solo_q();
    let t = 0.5;
    for integrator in ["rk4", "semi_implicit_euler"] {
        let r = ask(
            json!({"op": "simulate", "robot": solo(), "q0": q0, "t_end": t,
            "integrator": integrator, "dt": 1e-3}),
        )
        .expect("simulate");
        let last = &r["samples"][0];
        let (q, qd) = (nums(&last["q"]), nums(&last["qd"]));
        assert_eq!((q.len(), qd.len()), (19, 18), "{integrator}");
        // in free fall nothing pulls the joints: every body falls with g
        let z = 1.0 - 0.5 * 9.81 * t * t;
        let tol = if integrator == "rk4" { 1e-9 } else { 1e-2 };
        assert!((q[2] - z).abs() <= tol, "{integrator}: z {} vs {z}", q[2]);
        for (i, (got, want)) in q.iter().zip(&q0).enumerate() {
            if i != 2 {
                assert!(
                    (got - want).abs() <= 1e-9,
                    "{integrator}: q[{i}] {got} vs {want}"
                );
            }
        }
        // the base's velocity is LOCAL: g seen in the tilted base frame, the rest at rest
        let g_local = [0.0, -9.81 * t * (0.4f64).sin(), -9.81 * t * (0.4f64).cos()];
        for (i, (got, want)) in qd.iter().zip(g_local.iter().chain(&[0.0; 15])).enumerate() {
            assert!(
                (got - want).abs() <= 1e-9,
                "{integrator}: qd[{i}] {got} vs {want}"
            );
        }
    }
}

#[test]
fn wrong_lengths_and_a_non_unit_quaternion_are_refused_by_name() {
    let q = solo_q();
    let short = &q[..18];
    for op in ["fk", "jacobian", "mass_matrix", "gravity"] {
        let e = ask(json!({"op": op, "robot": solo(), "q": short})).expect_err(op);
        assert!(
            matches!(e.kind.as_str(), "bad_request" | "invalid_request")
                && e.message.contains("18 values")
                && e.message.contains("nq = 19")
                && e.message.contains("free_flyer"),
            "{op}: {e:?}"
        );
    }
    let e = ask(
        json!({"op": "id", "robot": solo(), "q": q, "qd": vec![0.0; 19], "qdd": vec![0.0; 18]}),
    )
    .expect_err("qd of nq values");
    assert!(
        e.message.contains("`qd` has 19 values") && e.message.contains("nv = 18"),
        "{e:?}"
    );
    let e = ask(json!({"op": "simulate", "robot": solo(), "q0": short, "t_end": 0.1, "integrator": "rk4", "dt": 1e-3}))
        .expect_err("q0 of nv values");
    assert!(
        e.message.contains("`q0` has 18 values") && e.message.contains("nq = 19"),
        "{e:?}"
    );
    let mut bad = q.clone();
    bad[6] = 2.0;
    for op in ["fk", "gravity"] {
        let e = ask(json!({"op": op, "robot": solo(), "q": bad})).expect_err(op);
        assert!(
            matches!(e.kind.as_str(), "bad_request" | "invalid_request")
                && e.message.contains("not unit"),
            "{op}: {e:?}"
        );
    }
    // encoder_error's bits are per joint (12), not per coordinate
    let e = ask(json!({"op": "encoder_error", "robot": solo(), "q": q, "bits": vec![16; 18]}))
        .expect_err("bits per velocity coordinate");
    assert_eq!(e.kind.as_str(), "bad_request", "{e:?}");
    // `tip` has no meaning for the whole tree
    let e = ask(json!({"op": "fk", "robot": {"urdf": repo().join(SOLO).to_str(), "floating": true, "tip": "FL_FOOT"}, "q": q}))
        .expect_err("tip");
    assert!(e.message.contains("robot.tip"), "{e:?}");
}

/// A two-body robot on a free-flyer, as MJCF (`<freejoint>` on the world's first body) and as
/// a URDF with a `floating` root joint (core/urdf's mjcf.rs floating test's pair).
const MJCF_FREE: &str = r#"<mujoco model="m"><worldbody>
  <body name="base" pos="0 0 0.5">
    <freejoint name="root"/>
    <inertial pos="0.1 0 0" mass="2" diaginertia="0.01 0.02 0.03"/>
    <body name="l1" pos="1 0 0">
      <joint name="j2" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0.2 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    </body>
  </body></worldbody></mujoco>"#;
const URDF_BASE: &str = r#"<robot name="m">
  <link name="base"><inertial><origin xyz="0.1 0 0"/><mass value="2"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1"><inertial><origin xyz="0 0.2 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j2" type="continuous"><parent link="base"/><child link="l1"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/></joint></robot>"#;

#[test]
fn an_mjcf_free_joint_is_the_same_floating_robot_as_the_urdf_one() {
    let dir = std::env::temp_dir().join(format!("robosim-hffp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (mjcf, urdf) = (dir.join("m.xml"), dir.join("m.urdf"));
    std::fs::write(&mjcf, MJCF_FREE).expect("write");
    std::fs::write(&urdf, URDF_BASE).expect("write");
    let (s, c) = (0.3f64).sin_cos();
    // MJCF's body pos (0 0 0.5) is the root joint's placement: q's x y z are relative to it
    let q = json!([0.2, -0.1, 0.3, 0.0, s, 0.0, c, 0.7]);
    let (qd, qdd) = (
        json!([0.3, -0.2, 0.1, 0.5, -0.4, 0.8, 1.1]),
        json!([0.1, 0.2, -0.3, 0.4, 0.5, -0.6, 0.7]),
    );
    let id = |robot: Value| {
        ask(json!({"op": "id", "robot": robot, "q": q, "qd": qd, "qdd": qdd}))
            .map(|a| nums(&a["tau"]))
    };
    let from_mjcf = id(json!({"mjcf": mjcf.to_str()})).expect("mjcf free joint");
    let from_urdf = id(json!({"urdf": urdf.to_str(), "floating": true})).expect("urdf");
    assert_eq!(from_mjcf.len(), 7);
    assert!(
        rel_err(&from_mjcf, &from_urdf) <= 1e-12,
        "{from_mjcf:?} vs {from_urdf:?}"
    );
    // the MJCF's 8-value q, 7-value v: a q of 7 is refused naming nq = 8
    let e = ask(json!({"op": "gravity", "robot": {"mjcf": mjcf.to_str()}, "q": qd}))
        .expect_err("q of nv values");
    assert!(e.message.contains("nq = 8"), "{e:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Solo with its base at a general pose: translated, rotated 0.7 rad about (1, -2, 3)/|.|, legs
/// bent.
fn solo_q_tilted() -> Vec<f64> {
    let axis = [1.0, -2.0, 3.0];
    let n = (axis.iter().map(|x: &f64| x * x).sum::<f64>()).sqrt();
    let (s, c) = (0.35f64).sin_cos();
    let mut q = vec![
        0.3,
        -0.2,
        0.45,
        s * axis[0] / n,
        s * axis[1] / n,
        s * axis[2] / n,
        c,
    ];
    for i in 0..12 {
        q.push([0.1, 0.8, -1.6][i % 3]);
    }
    q
}

fn pose_of(v: &Value) -> nalgebra::Matrix4<f64> {
    let m = rows(v);
    assert_eq!((m.nrows(), m.ncols()), (4, 4));
    nalgebra::Matrix4::from_fn(|i, j| m[(i, j)])
}

/// IK on a free-flyer (issue 36 item 2, "a chain from the base link still works"): the root is
/// held where q0 puts it (a general pose, not the identity), the chain from the base link to
/// one leg's link frame moves, and the answer is a full q (nq = 19) that reaches, by the
/// library's FK of the floating robot, a pose made by that FK at other joint values; the root
/// and the other legs are q0's bit for bit.
#[test]
fn ik_moves_one_legs_chain_with_the_floating_root_held() {
    let path = repo().join(SOLO);
    let imported = import_urdf_tree_floating(&path, RootKind::FreeFlyer).expect("imports");
    let robot = &imported.robot;
    let index = |name: &str| {
        imported
            .joints
            .iter()
            .position(|j| j.name == name)
            .unwrap_or_else(|| panic!("{name}"))
    };
    let q0 = solo_q_tilted();
    // the front-right knee's link frame (a leg in the middle of q) and the last link, where the
    // tool hangs (the default `link`)
    let fr = index("FR_KFE") + 1;
    for (link, request_link) in [(fr, Some(fr)), (robot.dof(), None)] {
        let moved: Vec<usize> = robot.support(link).iter().map(|j| 7 + j).collect();
        assert_eq!(moved.len(), 3, "a leg is 3 joints");
        let mut q_target = q0.clone();
        for (&i, dq) in moved.iter().zip([0.25, -0.3, 0.5]) {
            q_target[i] += dq;
        }
        let target = if link == robot.dof() {
            robosim_kinematics::fk::forward(robot, &q_target)
        } else {
            link_pose(robot, &q_target, link)
        };
        let before = if link == robot.dof() {
            robosim_kinematics::fk::forward(robot, &q0)
        } else {
            link_pose(robot, &q0, link)
        };
        assert!(
            (target.fixed_view::<3, 1>(0, 3) - before.fixed_view::<3, 1>(0, 3)).norm() > 0.02,
            "the target is not the seed's pose"
        );
        let mut req = json!({"op": "ik", "robot": solo(), "q0": q0,
            "pose": target.row_iter().map(|r| r.iter().copied().collect::<Vec<_>>()).collect::<Vec<_>>()});
        if let Some(l) = request_link {
            req["link"] = json!(l);
        }
        let r = ask(req).expect("ik");
        assert_eq!(r["link"], json!(link));
        assert_eq!(
            nums(&r["chain"]),
            moved.iter().map(|&i| i as f64).collect::<Vec<_>>()
        );
        let sol = &r["solutions"][0];
        assert_eq!(sol["converged"], json!(true), "{r}");
        let q = nums(&sol["q"]);
        assert_eq!(q.len(), 19);
        for i in (0..19).filter(|i| !moved.contains(i)) {
            assert_eq!(
                q[i].to_bits(),
                q0[i].to_bits(),
                "q[{i}] moved: {} vs {}",
                q[i],
                q0[i]
            );
        }
        let reached = if link == robot.dof() {
            robosim_kinematics::fk::forward(robot, &q)
        } else {
            link_pose(robot, &q, link)
        };
        let dp = (reached.fixed_view::<3, 1>(0, 3) - target.fixed_view::<3, 1>(0, 3)).norm();
        let dr = (reached.fixed_view::<3, 3>(0, 0) - target.fixed_view::<3, 3>(0, 0)).norm();
        assert!(dp <= 1e-9 && dr <= 1e-9, "link {link}: {dp} m, {dr} off");
        // and the protocol's own fk agrees for the tip
        if link == robot.dof() {
            let f = ask(json!({"op": "fk", "robot": solo(), "q": q})).expect("fk");
            assert!((pose_of(&f["pose"]) - target).norm() <= 1e-9);
        }
    }

    // a pose 5 m from the base: the usual typed error, its best q a full q with the root held
    let mut far = link_pose(robot, &q0, fr);
    far[(0, 3)] += 5.0;
    let far_json: Vec<Vec<f64>> = far
        .row_iter()
        .map(|r| r.iter().copied().collect())
        .collect();
    let e = ask(json!({"op": "ik", "robot": solo(), "q0": q0, "link": fr, "pose": far_json}))
        .expect_err("5 m away");
    match e.kind.as_str() {
        "unreachable" => {}
        "not_converged" => {
            let best = e.message.split("best q ").nth(1).expect("best q");
            let best: Vec<f64> = serde_json::from_str(best).expect("a q");
            assert_eq!(best.len(), 19, "{e:?}");
            for i in 0..7 {
                assert_eq!(best[i].to_bits(), q0[i].to_bits(), "root q[{i}]");
            }
        }
        k => panic!("kind {k}: {e:?}"),
    }

    // the root needs a place to be held: q0 is required, and of nq values; link in 1..=n
    let e = ask(json!({"op": "ik", "robot": solo(), "pose": far_json})).expect_err("no q0");
    assert!(
        e.kind.as_str() == "bad_request" && e.message.contains("q0") && e.message.contains("19"),
        "{e:?}"
    );
    let e = ask(json!({"op": "ik", "robot": solo(), "q0": &q0[7..], "pose": far_json}))
        .expect_err("q0 of joints only");
    assert!(e.message.contains("nq = 19"), "{e:?}");
    for link in [0, 13] {
        let e = ask(json!({"op": "ik", "robot": solo(), "q0": q0, "link": link, "pose": far_json}))
            .expect_err("link out of range");
        assert!(
            e.kind.as_str() == "bad_request" && e.message.contains("link"),
            "{link}: {e:?}"
        );
    }
}

/// encoder_error on a free-flyer: the 12 joint encoders' bound with the root held at q, the
/// floating Jacobian's joint columns (nv-index 6 + k), not its first 12 columns.
#[test]
fn encoder_error_uses_the_joint_columns_of_a_floating_jacobian() {
    let q = solo_q_tilted();
    let bits: Vec<u32> = (0..12).map(|k| 10 + k).collect();
    let r = ask(json!({"op": "encoder_error", "robot": solo(), "q": q, "bits": bits}))
        .expect("encoder_error");
    let j = rows(
        &ask(json!({"op": "jacobian", "robot": solo(), "q": q})).expect("jacobian")["jacobian"],
    );
    assert_eq!((j.nrows(), j.ncols()), (6, 18));
    let res: Vec<f64> = bits
        .iter()
        .map(|&b| 2.0 * std::f64::consts::PI / 2f64.powi(b as i32))
        .collect();
    assert!(rel_err(&nums(&r["resolution"]), &res) <= 1e-15);
    let want: Vec<f64> = (0..6)
        .map(|i| (0..12).map(|k| j[(i, 6 + k)].abs() * res[k]).sum())
        .collect();
    let got = nums(&r["per_axis"]);
    let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(scale > 0.0);
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert!((g - w).abs() <= 1e-12 * scale, "per_axis[{i}] {g} vs {w}");
    }
    // the tip's leg is the last 3 joints: their columns carry it, the root's would not count
    let wrong: f64 = (0..12).map(|k| j[(0, k)].abs() * res[k]).sum();
    assert!(
        (wrong - want[0]).abs() > 1e-6 * scale,
        "the test tells the columns apart"
    );
}

/// A tree with ball joints (testdata/ball, read from its MJCF): the protocol sizes q by `nq`
/// (4 per ball joint) and v, τ, q̈ by `nv` (3 per ball joint). q sized by the joint count — or
/// a non-unit quaternion — is refused by name; it used to reach FK and panic on an index.
#[test]
fn a_ball_jointed_robot_is_sized_by_nq_and_nv_and_a_joint_count_q_is_refused() {
    let file = repo().join("testdata/ball/ball_tree.xml");
    let robot = json!({"mjcf": file, "tip": "finger"});
    // joints: ball, hinge, ball, slide → nq 10, nv 8
    let q = json!([0.0, 0.0, 0.0, 1.0, 0.1, 0.0, 0.0, 0.0, 1.0, 0.2]);
    let v = json!([0.0, 0.0, 0.0, 0.1, 0.0, 0.2, 0.0, 0.0]);
    for op in ["fk", "jacobian", "mass_matrix", "gravity"] {
        let ok = ask(json!({"op": op, "robot": robot, "q": q}));
        assert!(ok.is_ok(), "{op}: {ok:?}");
        let e = ask(json!({"op": op, "robot": robot, "q": [0.1, 0.2, 0.3, 0.4]}))
            .expect_err("q with one value per joint");
        assert!(e.message.contains("nq = 10"), "{op}: {}", e.message);
        let e = ask(json!({"op": op, "robot": robot,
            "q": [0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0, 0.2]}))
        .expect_err("a zero quaternion");
        assert!(e.message.contains("not unit"), "{op}: {}", e.message);
    }
    let tau = ask(json!({"op": "id", "robot": robot, "q": q, "qd": v, "qdd": v})).expect("id");
    assert_eq!(nums(&tau["tau"]).len(), 8);
    let qdd =
        ask(json!({"op": "fd", "robot": robot, "q": q, "qd": v, "tau": tau["tau"]})).expect("fd");
    // fd undoes id
    assert!(rel_err(&nums(&qdd["qdd"]), &nums(&v)) < 1e-9, "{qdd}");
    let e = ask(json!({"op": "id", "robot": robot, "q": q, "qd": [0.0, 0.0, 0.0, 0.0], "qdd": v}))
        .expect_err("v with one value per joint");
    assert!(e.message.contains("nv = 8"), "{}", e.message);
}
