//! The kinematics ops of the query protocol driven with JSON, as a client would.

use robosim_hl_interface::protocol::kinematics::dispatch;
use robosim_hl_interface::robot_json::{matrix4_from_json, matrix4_to_json, robot_to_json};
use robosim_kinematics::{Robot, builtin_robot, fk};
use serde_json::{Value, json};

fn no_library(_: &str) -> Option<Robot> {
    None
}

fn ask(req: Value) -> Result<Value, (String, String)> {
    let op = req["op"].as_str().expect("op").to_owned();
    dispatch(&op, &req, &no_library)
        .expect("op is ours")
        .map_err(|e| (e.kind.to_string(), e.message))
}

#[test]
fn fk_with_frames() {
    let a = ask(json!({"op": "fk", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "frames": true}))
        .expect("ok");
    assert_eq!(a["frames"].as_array().map(|f| f.len()), Some(8));
    let pose = matrix4_from_json(&a["pose"], "pose").expect("4x4");
    let robot = builtin_robot("puma560").expect("builtin");
    assert!((pose - fk::forward(&robot, &[0.0; 6])).abs().max() == 0.0);
    let e = ask(json!({"op": "fk", "robot": "puma560", "q": [0, 0, 0]})).expect_err("short q");
    assert_eq!(e.0, "bad_request");
    assert!(e.1.contains("q: 3 values"), "{}", e.1);
}

#[test]
fn jacobian_in_tool_frame_with_singularity_measure() {
    let a = ask(
        json!({"op": "jacobian", "robot": "puma560", "q": [0, 0.5, -1, 0, 0, 0], "frame": "tool"}),
    )
    .expect("ok");
    assert_eq!(a["jacobian"].as_array().map(|r| r.len()), Some(6));
    assert_eq!(a["jacobian"][0].as_array().map(|r| r.len()), Some(6));
    // q5 = 0: the PUMA's wrist is singular.
    assert!(a["singularity"]["sigma_min"].as_f64().expect("number") < 1e-12);
    assert!(
        a["singularity"]["condition"].is_null()
            || a["singularity"]["condition"].as_f64().expect("n") > 1e12
    );
}

#[test]
fn ik_all_analytic_and_auto_with_inline_robot() {
    let robot = builtin_robot("puma560").expect("builtin");
    let q = [0.3, -0.4, 0.6, 1.0, -0.8, 0.5];
    let pose = matrix4_to_json(&fk::forward(&robot, &q));
    let a = ask(
        json!({"op": "ik", "robot": "puma560", "pose": pose, "method": "analytic", "all": true}),
    )
    .expect("ok");
    let sols = a["solutions"].as_array().expect("solutions");
    assert_eq!(sols.len(), 8);
    assert_eq!(sols[0]["branch"], "lun");
    for s in sols {
        assert!(s["residual"]["position"].as_f64().expect("n") < 1e-10);
        assert!(s["within_limits"].is_boolean());
    }
    let inline = robot_to_json(&robot);
    let a = ask(json!({"op": "ik", "robot": inline, "pose": pose, "method": "auto", "q0": q}))
        .expect("ok");
    assert_eq!(a["method"], "analytic");
    let got: Vec<f64> = a["solutions"][0]["q"]
        .as_array()
        .expect("q")
        .iter()
        .map(|x| x.as_f64().expect("n"))
        .collect();
    assert!(
        got.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-9),
        "{got:?}"
    );
    // Per-axis tolerances, a free roll axis, the numeric method.
    let a = ask(json!({"op": "ik", "robot": "panda", "pose": matrix4_to_json(&fk::forward(&builtin_robot("panda").expect("b"), &[0.1, 0.2, 0.0, -1.5, 0.0, 1.5, 0.3])),
        "method": "dls", "tolerances": {"position": 1e-8, "orientation": [1e-8, 1e-8, null]}, "seed": 3})).expect("ok");
    assert_eq!(a["method"], "dls");
    assert_eq!(a["solutions"][0]["converged"], true);
}

#[test]
fn ik_errors_are_typed() {
    let far = json!([[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
    let e = ask(json!({"op": "ik", "robot": "puma560", "pose": far, "method": "analytic"}))
        .expect_err("far");
    assert_eq!(e.0, "unreachable");
    let e =
        ask(json!({"op": "ik", "robot": "puma560", "pose": far, "method": "dls", "restarts": 2}))
            .expect_err("far");
    assert_eq!(e.0, "not_converged");
    let e = ask(json!({"op": "ik", "robot": "panda", "pose": far, "method": "analytic"}))
        .expect_err("7 dof");
    assert_eq!(e.0, "not_applicable");
    let e = ask(json!({"op": "ik", "robot": "puma560", "pose": far, "method": "magic"}))
        .expect_err("method");
    assert_eq!(e.0, "bad_request");
    let e = ask(json!({"op": "ik", "robot": "nope", "pose": far})).expect_err("robot");
    assert_eq!(e.0, "unknown_robot");
    let e = ask(json!({"op": "ik", "robot": {"joints": [{"type": "hinge"}]}, "pose": far}))
        .expect_err("robot");
    assert_eq!(e.0, "bad_robot");
    assert!(e.1.contains("robot.joints[0].type"), "{}", e.1);
    let e =
        ask(json!({"op": "ik", "robot": "puma560", "pose": [[1, 0], [0, 1]]})).expect_err("pose");
    assert!(e.1.starts_with("pose"), "{}", e.1);
    assert!(dispatch("collide", &json!({}), &no_library).is_none());
}

#[test]
fn encoder_error_twelve_bits() {
    let a = ask(json!({"op": "encoder_error", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.7, 0], "bits": 12})).expect("ok");
    let p = a["position"].as_f64().expect("n");
    let w = a["position_worst_case"].as_f64().expect("n");
    assert!(p > 0.0 && w <= p + 1e-15);
    let b = ask(json!({"op": "encoder_error", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.7, 0], "bits": [13, 13, 13, 13, 13, 13]})).expect("ok");
    assert!((b["position"].as_f64().expect("n") * 2.0 - p).abs() < 1e-15);
    let e = ask(json!({"op": "encoder_error", "robot": "puma560", "q": [0, 0.5, -1, 0, 0.7, 0], "bits": [12]})).expect_err("bits");
    assert!(e.1.contains("bits"), "{}", e.1);
}

#[test]
fn library_names_resolve_through_the_callback_first() {
    let mut tiny = builtin_robot("puma560").expect("builtin");
    tiny.name = "mine".into();
    tiny.base[(2, 3)] = 1.0;
    let lib = move |name: &str| {
        if name == "mine" {
            Some(tiny.clone())
        } else {
            None
        }
    };
    let a = dispatch(
        "fk",
        &json!({"robot": "mine", "q": [0, 0, 0, 0, 0, 0]}),
        &lib,
    )
    .expect("ours")
    .expect("ok");
    let b = dispatch(
        "fk",
        &json!({"robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}),
        &lib,
    )
    .expect("ours")
    .expect("ok");
    assert!(
        (a["pose"][2][3].as_f64().expect("n") - b["pose"][2][3].as_f64().expect("n") - 1.0).abs()
            < 1e-12
    );
}

/// `fk` (pose and every frame) and `jacobian` (both frames) answer from a robot compiled once
/// per request (issue 37 item 1): the numbers equal the `&Robot` functions' with `==` (JSON
/// carries an f64 exactly), for builtin and inline robots.
#[test]
fn fk_and_jacobian_equal_the_robot_path_bit_for_bit() {
    use robosim_hl_interface::robot_json::matrix_to_json;
    use robosim_kinematics::jacobian::{Frame, jacobian};
    let qs = [
        ("puma560", vec![0.3, -0.7, 1.1, 0.2, -0.4, 2.0]),
        ("stanford", vec![-0.5, 0.9, 0.35, 1.3, 0.6, -1.2]),
        ("panda", vec![0.1, 0.2, -0.3, -1.5, 0.4, 1.6, 0.7]),
    ];
    for (name, q) in qs {
        let robot = builtin_robot(name).expect("builtin");
        for r in [json!(name), robot_to_json(&robot)] {
            let a = ask(json!({"op": "fk", "robot": r, "q": q, "frames": true})).expect("fk");
            let frames = fk::link_frames(&robot, &q);
            let want: Vec<Value> = frames.iter().map(matrix4_to_json).collect();
            assert_eq!(a["frames"], json!(want), "{name}");
            let a = ask(json!({"op": "fk", "robot": r, "q": q})).expect("fk");
            assert_eq!(
                a["pose"],
                matrix4_to_json(&fk::forward(&robot, &q)),
                "{name}"
            );
            for (frame, f) in [("base", Frame::Base), ("tool", Frame::Tool)] {
                let a = ask(json!({"op": "jacobian", "robot": r, "q": q, "frame": frame}))
                    .expect("jacobian");
                assert_eq!(
                    a["jacobian"],
                    matrix_to_json(&jacobian(&robot, &q, f)),
                    "{name} {frame}"
                );
            }
        }
    }
}
