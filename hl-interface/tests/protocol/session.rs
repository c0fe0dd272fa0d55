//! A planner's session: mixed requests across every crate's ops in one stream, answered in
//! order with the right ids and ok flags, and values equal to what each crate's own functions
//! compute for the same robot.

use crate::{assert_close, kind, numbers, rows, run_values};
use nalgebra::{Isometry3, Vector3};
use robosim_collision::{Mode, Solid};
use robosim_dynamics::{Data, Model};
use robosim_hl_interface::robot_json::{matrix4_to_json, robot_to_json};
use robosim_hl_interface::{OPS, resolve_robot};
use robosim_kinematics::jacobian::{Frame, jacobian};
use robosim_kinematics::{encoder::encoder_error, fk};
use serde_json::{Value, json};

fn at(x: f64, y: f64, z: f64) -> Value {
    json!([
        [1.0, 0.0, 0.0, x],
        [0.0, 1.0, 0.0, y],
        [0.0, 0.0, 1.0, z],
        [0.0, 0.0, 0.0, 1.0]
    ])
}

#[test]
fn mixed_session_answers_in_order_with_each_crates_values() {
    let puma = resolve_robot("puma560").expect("puma560 resolves");
    let panda = resolve_robot("panda").expect("panda resolves");
    let q = [0.1, -0.4, 0.7, 0.2, -0.6, 0.3];
    let qd = [0.3, -0.2, 0.1, 0.5, -0.4, 0.2];
    let qdd = [1.0, -0.5, 0.25, 2.0, -1.0, 0.5];
    let q_panda = [0.1, 0.2, 0.0, -1.5, 0.0, 1.5, 0.3];
    let pose = fk::forward(&puma, &q);
    let model = Model::new(&puma).expect("puma560 has valid dynamics");
    let mut data = Data::new(&model);
    let tau: Vec<f64> = robosim_dynamics::rnea(&model, &mut data, &q, &qd, &qdd)
        .expect("rnea")
        .iter()
        .copied()
        .collect();
    let mut far = pose;
    far[(0, 3)] = 5.0;
    // The PUMA's end effector at q = 0 is near (0.45, -0.15, 1.10) m: one crate there, one far.
    let crate_at = |x: f64| json!({"objects": [{"shape": "box", "size": [0.2, 0.2, 0.2], "name": "crate", "pose": at(x, -0.15, 1.1)}]});
    let reqs = vec![
        json!({"id": 1, "op": "fk", "robot": "puma560", "q": q}),
        json!({"id": 2, "op": "jacobian", "robot": "puma560", "q": q, "frame": "base"}),
        json!({"id": 3, "op": "ik", "robot": "puma560", "pose": matrix4_to_json(&pose), "method": "analytic", "all": true}),
        json!({"id": 4, "op": "encoder_error", "robot": "puma560", "q": q, "bits": 12}),
        json!({"id": "five", "op": "id", "robot": "puma560", "q": q, "qd": qd, "qdd": qdd}),
        json!({"id": 6, "op": "mass_matrix", "robot": "puma560", "q": q}),
        json!({"id": 7, "op": "gravity", "robot": "puma560", "q": q}),
        json!({"id": 8, "op": "fd", "robot": "puma560", "q": q, "qd": qd, "tau": tau}),
        json!({"id": 9, "op": "simulate", "robot": "puma560", "q0": q, "t_end": 0.05, "outputs": [0.0, 0.025, 0.05], "integrator": "rk4", "dt": 1e-3}),
        json!({"id": 10, "op": "collide", "a": {"shape": "sphere", "radius": 0.5}, "pose_a": at(0.0, 0.0, 0.0), "b": {"shape": "box", "size": [1.0, 1.0, 1.0]}, "pose_b": at(1.5, 0.0, 0.0)}),
        json!({"id": 11, "op": "check", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": crate_at(0.45)}),
        json!({"id": 12, "op": "check", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": crate_at(3.0)}),
        json!({"id": 13, "op": "lib_list"}),
        json!({"id": 14, "op": "lib_params", "name": "puma560"}),
        json!({"id": 15, "op": "lib_evaluate", "name": "puma560", "geometry": false}),
        json!({"id": 16, "op": "diag_check", "model": "eclss"}),
        json!({"id": 17, "op": "ik", "robot": "puma560", "pose": matrix4_to_json(&far), "method": "analytic"}),
        json!({"id": 18, "op": "ops"}),
        json!({"op": "fk", "robot": "panda", "q": q_panda}),
        json!({"id": 20, "op": "fk", "robot": robot_to_json(&puma), "q": q}),
        json!({"id": 21, "op": "diag_simulate", "model": "eclss", "faults": [{"fault": "Shower.consumer_leaking"}]}),
        json!({"id": 22, "op": "nonesuch"}),
        json!({"id": 23, "op": "fk", "robot": "puma560", "q": q}),
    ];
    let answers = run_values(&reqs);
    assert_eq!(answers.len(), reqs.len(), "one answer per request");
    for (req, (raw, a)) in reqs.iter().zip(&answers) {
        let id = req.get("id").cloned().unwrap_or(Value::Null);
        assert_eq!(a["id"], id, "ids in order: {raw}");
        assert!(
            raw.starts_with(&format!("{{\"id\":{id},\"ok\":")),
            "id and ok first: {raw}"
        );
        let want_ok = ![17, 22].contains(&req["id"].as_i64().unwrap_or(0));
        assert_eq!(a["ok"], want_ok, "ok flag of {req}: {raw}");
    }
    let a = |i: usize| &answers[i].1;

    // fk: the pose (and the same pose from an inline robot, and the last repeat).
    let want: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| pose[(r, c)]).collect())
        .collect();
    for i in [0, 19, 22] {
        let got = rows(&a(i)["pose"], "pose");
        for r in 0..4 {
            assert_close(&got[r], &want[r], 1e-12, "fk pose");
        }
    }
    let p = fk::forward(&panda, &q_panda);
    let got = rows(&a(18)["pose"], "panda pose");
    for r in 0..4 {
        assert_close(
            &got[r],
            &(0..4).map(|c| p[(r, c)]).collect::<Vec<_>>(),
            1e-12,
            "panda",
        );
    }

    // jacobian: 6×n, rows vx vy vz ωx ωy ωz.
    let j = jacobian(&puma, &q, Frame::Base);
    let got = rows(&a(1)["jacobian"], "jacobian");
    assert_eq!(got.len(), 6);
    for r in 0..6 {
        assert_close(
            &got[r],
            &(0..6).map(|c| j[(r, c)]).collect::<Vec<_>>(),
            1e-12,
            "jacobian",
        );
    }

    // ik: every analytic solution reaches the pose, and the one we started from is among them.
    let sols = a(2)["solutions"].as_array().expect("solutions");
    assert_eq!(sols.len(), 8, "the PUMA has 8 analytic branches");
    let mut found = false;
    for s in sols {
        let qs = numbers(&s["q"], "ik q");
        let reached = fk::forward(&puma, &qs);
        assert!(
            (reached - pose).abs().max() < 1e-9,
            "ik solution misses the pose: {s}"
        );
        found |= qs.iter().zip(&q).all(|(x, y)| (x - y).abs() < 1e-9);
    }
    assert!(found, "the generating q is one of the solutions");
    assert_eq!(kind(a(16)), "unreachable");

    // encoder_error.
    let e = encoder_error(&puma, &q, &[12; 6]).expect("encoder_error");
    assert_close(
        &[a(3)["position"].as_f64().expect("position")],
        &[e.position],
        1e-12,
        "pos",
    );
    assert_close(
        &numbers(&a(3)["per_axis"], "per_axis"),
        &e.per_axis,
        1e-12,
        "per_axis",
    );

    // Dynamics: id, mass matrix, gravity, fd (which must invert id), simulate.
    assert_close(&numbers(&a(4)["tau"], "tau"), &tau, 1e-12, "id tau");
    let m = robosim_dynamics::crba(&model, &mut data, &q)
        .expect("crba")
        .clone();
    let got = rows(&a(5)["mass_matrix"], "mass_matrix");
    for r in 0..6 {
        assert_close(
            &got[r],
            &(0..6).map(|c| m[(r, c)]).collect::<Vec<_>>(),
            1e-12,
            "M",
        );
    }
    let g: Vec<f64> = robosim_dynamics::gravity(&model, &mut data, &q)
        .expect("gravity")
        .iter()
        .copied()
        .collect();
    assert_close(&numbers(&a(6)["tau"], "gravity"), &g, 1e-12, "gravity");
    assert_close(
        &numbers(&a(7)["qdd"], "qdd"),
        &qdd,
        1e-8,
        "fd(id(qdd)) = qdd",
    );
    let samples = a(8)["samples"].as_array().expect("samples");
    assert_eq!(samples.len(), 3);
    assert_close(
        &numbers(&samples[0]["q"], "q(0)"),
        &q,
        0.0,
        "simulate starts at q0",
    );
    assert_eq!(samples[2]["t"], 0.05);
    assert!(samples[2]["energy"].is_object() || samples[2]["energy"].is_number());

    // collide: the crate's own verdict and distance.
    let r = robosim_collision::collide(
        &Solid::sphere(0.5, None).expect("sphere"),
        &Isometry3::identity(),
        &Solid::cuboid(Vector3::new(1.0, 1.0, 1.0)).expect("box"),
        &Isometry3::translation(1.5, 0.0, 0.0),
        Mode::Exact,
    );
    assert_eq!(a(9)["intersect"], json!(r.intersects()));
    let sd = r.signed_distance().expect("exact mode gives a distance");
    assert_close(
        &[a(9)["signed_distance"].as_f64().expect("sd")],
        &[sd],
        1e-12,
        "sd",
    );
    assert!((sd - 0.5).abs() < 1e-9);

    // check: contact with the crate at the hand, clear with the crate 3 m away.
    assert_eq!(a(10)["verdict"], "contact", "{}", a(10));
    assert_eq!(a(10)["contacts"][0]["b"]["name"], "crate");
    assert_eq!(a(11)["verdict"], "clear", "{}", a(11));
    assert_eq!(a(11)["clear"], true);

    // Library.
    let decls = robosim_library::standard_library()
        .expect("stdlib")
        .declarations();
    let listed = a(12)["declarations"].as_array().expect("declarations");
    assert_eq!(listed.len(), decls.len());
    assert!(
        listed
            .iter()
            .any(|d| d["name"] == "puma560" && d["kind"] == "robot")
    );
    assert!(a(13)["params"].is_array());
    assert_eq!(a(14)["kind"], "robot");
    assert_eq!(a(14)["robot"]["joints"].as_array().map(Vec::len), Some(6));

    // Automation.
    assert_eq!(a(15)["consistent"], true);
    assert_eq!(a(15)["alarms"], 57);
    assert_eq!(a(20)["alarms"][0]["alarm"], "A_shower_leak");

    // The transport's own op, and the unknown op that lists it.
    let ops: Vec<&str> = a(17)["ops"]
        .as_array()
        .expect("ops")
        .iter()
        .map(|o| o["op"].as_str().expect("op name"))
        .collect();
    assert_eq!(ops, OPS.iter().map(|(o, _)| *o).collect::<Vec<_>>());
    assert_eq!(kind(a(21)), "unknown_op");
    for (op, _) in OPS {
        assert!(
            a(21)["error"]["message"]
                .as_str()
                .expect("message")
                .contains(op),
            "unknown_op lists {op}"
        );
    }
}

/// Every op in [`OPS`] is claimed by some crate: a request with only `op` gets that crate's
/// own complaint (or an answer), never `unknown_op`. Catches the list drifting from the crates.
#[test]
fn every_listed_op_reaches_its_crate() {
    let reqs: Vec<Value> = OPS
        .iter()
        .enumerate()
        .map(|(i, (op, _))| json!({"id": i, "op": op}))
        .collect();
    for (req, (raw, a)) in reqs.iter().zip(run_values(&reqs)) {
        assert_eq!(a["id"], req["id"]);
        if a["ok"] == false {
            assert_ne!(kind(&a), "unknown_op", "{req} -> {raw}");
            assert_ne!(kind(&a), "internal_error", "{req} -> {raw}");
        }
    }
}
