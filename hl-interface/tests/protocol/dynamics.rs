//! The dynamics ops of the query protocol driven with JSON, as a client would send them.

use robosim_hl_interface::protocol::dynamics::dispatch;
use robosim_kinematics::{Joint, Robot};
use serde_json::{Value, json};

fn no_library(_: &str) -> Option<Robot> {
    None
}

/// The dynamics fixtures, `testdata/dynamics/`.
fn testdata() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/dynamics")
}

fn ask(req: Value) -> Result<Value, robosim_hl_interface::ProtocolError> {
    let op = req["op"].as_str().expect("op").to_string();
    dispatch(&op, &req, &no_library).expect("a dynamics op")
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn reference_case(robot: &str) -> Value {
    let text = std::fs::read_to_string(testdata().join("reference.json")).expect("reference data");
    let v: Value = serde_json::from_str(&text).expect("json");
    v["robots"][robot][0].clone()
}

fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() <= tol * (1.0 + y.abs()))
}

#[test]
fn id_mass_matrix_gravity_fd_answer_with_the_reference_values() {
    let c = reference_case("puma560");
    let tau =
        ask(json!({"op": "id", "robot": "puma560", "q": c["q"], "qd": c["qd"], "qdd": c["qdd"]}))
            .expect("id");
    assert!(close(&nums(&tau["tau"]), &nums(&c["tau"]), 1e-9));
    let m =
        ask(json!({"op": "mass_matrix", "robot": "puma560", "q": c["q"]})).expect("mass_matrix");
    let rows = m["mass_matrix"].as_array().expect("rows");
    assert_eq!(rows.len(), 6);
    for (r, want) in rows.iter().zip(c["mass_matrix"].as_array().expect("rows")) {
        assert!(close(&nums(r), &nums(want), 1e-9));
    }
    let g = ask(json!({"op": "gravity", "robot": "puma560", "q": c["q"]})).expect("gravity");
    assert!(close(&nums(&g["tau"]), &nums(&c["gravity"]), 1e-9));
    for method in ["aba", "cholesky"] {
        let fd = ask(json!({"op": "fd", "robot": "puma560", "q": c["q"], "qd": c["qd"], "tau": c["tau_fd"], "method": method})).expect("fd");
        assert!(
            close(&nums(&fd["qdd"]), &nums(&c["qdd_fd"]), 1e-9),
            "{method}"
        );
    }
}

#[test]
fn inline_robot_and_library_resolver_are_used() {
    let text = std::fs::read_to_string(testdata().join("robots/synthetic_modified.json"))
        .expect("fixture");
    let robot: Value = serde_json::from_str(&text).expect("json");
    let c = reference_case("synthetic_modified");
    let tau = ask(json!({"op": "id", "robot": robot, "q": c["q"], "qd": c["qd"], "qdd": c["qdd"]}))
        .expect("id");
    assert!(close(&nums(&tau["tau"]), &nums(&c["tau"]), 1e-9));

    // a library that knows a one-link arm turning about the vertical axis
    let library = |name: &str| {
        (name == "pendulum").then(|| Robot {
            joints: vec![Joint {
                a: 1.0,
                mass: 2.0,
                ..Joint::default()
            }],
            ..Robot::default()
        })
    };
    // a point mass on a 1 m link turning in the horizontal plane: no gravity torque, M = m l²
    let req = json!({"op": "gravity", "robot": "pendulum", "q": [0.3]});
    let g = dispatch("gravity", &req, &library)
        .expect("ours")
        .expect("answer");
    assert_eq!(
        nums(&g["tau"]),
        vec![0.0],
        "horizontal plane: gravity along the axis gives no torque"
    );
    let req = json!({"op": "mass_matrix", "robot": "pendulum", "q": [0.3]});
    let m = dispatch("mass_matrix", &req, &library)
        .expect("ours")
        .expect("answer");
    assert!(
        (m["mass_matrix"][0][0].as_f64().expect("number") - 2.0).abs() < 1e-12,
        "m l² = 2"
    );
}

#[test]
fn simulate_answers_samples_for_every_integrator() {
    let q0 = json!([0.0, 0.3, -0.5, 0.2, 0.6, 0.0]);
    let outputs = json!([0.0, 0.1, 0.25, 0.5]);
    let mut finals = Vec::new();
    for (integrator, step) in [
        ("euler", json!({"dt": 1e-5})),
        ("semi_implicit_euler", json!({"dt": 1e-5})),
        ("rk4", json!({"dt": 1e-3})),
        ("dopri5", json!({"dt": 1e-3})),
        ("dopri5", json!({"rtol": 1e-10, "atol": 1e-12})),
    ] {
        let mut req = json!({"op": "simulate", "robot": "puma560", "q0": q0, "t_end": 0.5, "outputs": outputs, "integrator": integrator});
        for (k, v) in step.as_object().expect("object") {
            req[k] = v.clone();
        }
        let ans = ask(req).expect("simulate");
        let samples = ans["samples"].as_array().expect("samples");
        assert_eq!(samples.len(), 4);
        for (s, t) in samples.iter().zip([0.0, 0.1, 0.25, 0.5]) {
            assert_eq!(
                s["t"].as_f64(),
                Some(t),
                "{integrator}: sample times land exactly on the outputs"
            );
            assert_eq!(nums(&s["q"]).len(), 6);
            assert_eq!(nums(&s["qd"]).len(), 6);
            assert!(s["energy"].as_f64().expect("energy").is_finite());
        }
        assert_eq!(
            nums(&samples[0]["q"]),
            nums(&q0),
            "{integrator}: t = 0 is the initial state"
        );
        assert!(ans["stats"]["accepted_steps"].as_u64().expect("stats") > 0);
        finals.push(nums(&samples[3]["q"]));
    }
    // all agree with the tight dopri5 run within their accuracy at these steps
    let best = finals.last().expect("runs").clone();
    for (f, tol) in finals.iter().zip([1e-3, 1e-3, 1e-7, 1e-7]) {
        assert!(close(f, &best, tol), "{f:?} vs {best:?}");
    }
}

#[test]
fn bad_requests_get_typed_errors() {
    assert!(
        dispatch("fk", &json!({}), &no_library).is_none(),
        "not a dynamics op"
    );
    let kind = |req: Value| ask(req).expect_err("must fail").kind;
    assert_eq!(
        kind(json!({"op": "id", "robot": "nonesuch", "q": [], "qd": [], "qdd": []})),
        "unknown_robot"
    );
    assert_eq!(
        kind(json!({"op": "gravity", "q": [0.0]})),
        "invalid_request"
    );
    assert_eq!(
        kind(json!({"op": "gravity", "robot": "puma560", "q": [0.0, 1.0]})),
        "invalid_request"
    );
    assert_eq!(
        kind(json!({"op": "gravity", "robot": "puma560", "q": [0, 0, "x", 0, 0, 0]})),
        "invalid_request"
    );
    assert_eq!(
        kind(
            json!({"op": "gravity", "robot": {"joints": [{"type": "revolute", "mas": 1.0}]}, "q": [0.0]})
        ),
        "invalid_robot"
    );
    assert_eq!(
        kind(json!({"op": "gravity", "robot": {"joints": [{"mass": -1.0}]}, "q": [0.0]})),
        "invalid_robot"
    );
    assert_eq!(
        kind(
            json!({"op": "fd", "robot": {"joints": [{"a": 1.0}]}, "q": [0.0], "qd": [0.0], "tau": [1.0]})
        ),
        "singular",
        "a massless link cannot be accelerated"
    );
    let sim = |extra: Value| {
        let mut req = json!({"op": "simulate", "robot": "puma560", "q0": [0, 0, 0, 0, 0, 0], "t_end": 1.0, "integrator": "rk4", "dt": 0.01});
        for (k, v) in extra.as_object().expect("object") {
            if v.is_null() {
                req.as_object_mut().expect("object").remove(k);
            } else {
                req[k] = v.clone();
            }
        }
        ask(req).map(|_| ()).map_err(|e| e.kind)
    };
    assert_eq!(sim(json!({})), Ok(()));
    assert_eq!(
        sim(json!({"integrator": "leapfrog"})),
        Err("invalid_request".into())
    );
    assert_eq!(
        sim(json!({"rtol": 1e-6})),
        Err("invalid_request".into()),
        "dt and rtol together"
    );
    assert_eq!(
        sim(json!({"dt": null, "rtol": 1e-6})),
        Err("invalid_request".into()),
        "tolerances need dopri5"
    );
    assert_eq!(sim(json!({"dt": -0.1})), Err("invalid_request".into()));
    assert_eq!(
        sim(json!({"outputs": [0.5, 2.0]})),
        Err("invalid_request".into()),
        "output after t_end"
    );
    assert_eq!(
        sim(json!({"outputs": [0.5, 0.2]})),
        Err("invalid_request".into()),
        "outputs out of order"
    );
    assert_eq!(
        sim(json!({"dt": 1e-6, "max_steps": 1000})),
        Err("too_many_steps".into())
    );
    assert_eq!(sim(json!({"limits": "yes"})), Err("invalid_request".into()));
    assert_eq!(sim(json!({"t_end": null})), Err("invalid_request".into()));
}

/// Issue #20 item 6 (`dynamics_overflow_is_an_error`): q̇ = 1e200 is finite, but the
/// velocity products overflow. `id` and `fd` used to answer `ok` with `null` numbers and
/// `simulate` called the same input `singular`; every one now refuses with `overflow`, naming
/// the result that overflowed.
#[test]
fn dynamics_overflow_is_an_error_never_null_inside_a_success() {
    let q = json!([0.1, 0.7, -0.3, 0.2, 0.4, -0.1]);
    let qd = json!([1e200, 0.0, 0.0, 0.0, 0.0, 1e200]);
    let zeros = json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let mut requests = vec![
        (
            json!({"op": "id", "robot": "puma560", "q": q, "qd": qd, "qdd": zeros}),
            "`tau`",
        ),
        (
            json!({"op": "fd", "robot": "puma560", "q": q, "qd": qd, "tau": zeros}),
            "`qdd`",
        ),
        (
            json!({"op": "fd", "robot": "puma560", "q": q, "qd": qd, "tau": zeros, "method": "cholesky"}),
            "`qdd`",
        ),
    ];
    for integrator in ["euler", "rk4", "dopri5", "semi_implicit_euler"] {
        let mut r = json!({"op": "simulate", "robot": "puma560", "q0": q, "qd0": qd,
                           "t_end": 0.01, "integrator": integrator});
        if integrator == "dopri5" {
            r["rtol"] = json!(1e-6);
        } else {
            r["dt"] = json!(1e-3);
        }
        requests.push((r, "overflowed"));
    }
    for (req, names) in requests {
        let e = ask(req.clone()).expect_err("refused");
        assert_eq!(e.kind.as_str(), "overflow", "{req}: {e:?}");
        assert!(
            e.message.contains(names) && e.message.contains("overflowed"),
            "{req}: {}",
            e.message
        );
    }
}

/// Issue 36: `id` and `fd` on a URDF robot are the rigid-body equations (Pinocchio's numbers)
/// although xArm7's URDF has damping and friction on every joint; `"passive": true` adds them
/// (reported apart as `tau_passive`), and `fd` with it holds a robot at rest whose torques are
/// within the Coulomb limits of what gravity needs.
#[test]
fn issue_36_friction_acts_only_when_the_request_says_passive() {
    let corpus =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf_corpus");
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(corpus.join("reference.json")).expect("reference"),
    )
    .expect("json");
    let rob = reference["robots"]
        .as_array()
        .expect("robots")
        .iter()
        .find(|r| r["file"] == "xarm_description/xarm7.urdf")
        .expect("xarm7")
        .clone();
    let robot = json!({
        "urdf": corpus.join("robots/xarm_description/xarm7.urdf"),
        "tip": rob["tip"],
    });
    let s = &rob["chain"]["samples"][0];
    let id = json!({"op": "id", "robot": robot, "q": s["q"], "qd": s["v"], "qdd": s["a"]});
    let rigid = ask(id.clone()).expect("id");
    assert!(
        close(&nums(&rigid["tau"]), &nums(&s["rnea"]), 1e-10),
        "{rigid}"
    );
    assert!(rigid.get("tau_passive").is_none());
    let mut with = id.clone();
    with["passive"] = json!(true);
    let with = ask(with).expect("id passive");
    let (t, p) = (nums(&with["tau"]), nums(&with["tau_passive"]));
    let r = nums(&rigid["tau"]);
    for j in 0..7 {
        assert!((t[j] - (r[j] - p[j])).abs() < 1e-12);
        assert!(p[j] * nums(&s["v"])[j] < 0.0, "friction opposes motion");
    }
    // at rest, the gravity torque plus 0.5 N·m on joint 1 (below its 1 N·m Coulomb limit)
    let zero = vec![0.0; 7];
    let g = ask(json!({"op": "gravity", "robot": robot, "q": s["q"]})).expect("gravity");
    let mut tau = nums(&g["tau"]);
    tau[0] += 0.5;
    let fd = json!({"op": "fd", "robot": robot, "q": s["q"], "qd": zero, "tau": tau});
    let free = ask(fd.clone()).expect("fd");
    assert!(nums(&free["qdd"]).iter().any(|a| a.abs() > 1e-3), "{free}");
    let mut held = fd;
    held["passive"] = json!(true);
    let held = ask(held).expect("fd passive");
    assert!(nums(&held["qdd"]).iter().all(|a| a.abs() < 1e-9), "{held}");
    assert!((nums(&held["tau_passive"])[0] + 0.5).abs() < 1e-9, "{held}");
    let bad = ask(
        json!({"op": "id", "robot": robot, "q": s["q"], "qd": s["v"], "qdd": s["a"], "passive": {"coulomb": "sticky"}}),
    );
    assert!(bad.is_err());
}
