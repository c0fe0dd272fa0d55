//! The query-protocol ops `collide` and `check`, driven through `dispatch` with JSON.

use robosim_hl_interface::protocol::collision::dispatch;
use robosim_kinematics::Robot;
use serde_json::{Value, json};

fn no_robots(_: &str) -> Option<Robot> {
    None
}

fn ask(op: &str, req: Value) -> Result<Value, robosim_hl_interface::ProtocolError> {
    dispatch(op, &req, &no_robots).expect("op is ours")
}

fn at(x: f64, y: f64, z: f64) -> Value {
    json!([
        [1.0, 0.0, 0.0, x],
        [0.0, 1.0, 0.0, y],
        [0.0, 0.0, 1.0, z],
        [0.0, 0.0, 0.0, 1.0]
    ])
}

#[test]
fn collide_answers_intersect_distance_and_witnesses_in_every_mode() {
    let req = json!({"a": {"shape": "sphere", "radius": 0.5}, "pose_a": at(0.0, 0.0, 0.0),
                     "b": {"shape": "box", "size": [1.0, 1.0, 1.0]}, "pose_b": at(1.5, 0.0, 0.0)});
    let r = ask("collide", req.clone()).expect("ok");
    assert_eq!(r["verdict"], "clear");
    assert_eq!(r["intersect"], false);
    assert!((r["distance"].as_f64().expect("d") - 0.5).abs() < 1e-12);
    assert!((r["signed_distance"].as_f64().expect("sd") - 0.5).abs() < 1e-12);
    assert!((r["witness_a"][0].as_f64().expect("x") - 0.5).abs() < 1e-12);
    assert!((r["witness_b"][0].as_f64().expect("x") - 1.0).abs() < 1e-12);
    let mut deep = req.clone();
    deep["pose_b"] = at(0.8, 0.0, 0.0);
    let r = ask("collide", deep.clone()).expect("ok");
    assert_eq!(r["intersect"], true);
    assert!((r["signed_distance"].as_f64().expect("sd") + 0.2).abs() < 1e-12);
    for mode in ["bbox", "polygon"] {
        deep["mode"] = json!(mode);
        let r = ask("collide", deep.clone()).expect("ok");
        assert_eq!(r["intersect"], true, "{mode}");
        assert_eq!(r["mode"], mode);
    }
    // cylinder, cone, convex and mesh shapes parse and answer.
    let shapes = [
        json!({"shape": "cylinder", "radius": 0.2, "height": 1.0}),
        json!({"shape": "cone", "radius": 0.2, "height": 1.0, "facets": 16}),
        json!({"shape": "convex", "points": [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]}),
        json!({"shape": "mesh", "vertices": [[0,0,0],[1,0,0],[0,1,0],[0,0,1]], "polygons": [[0,2,1],[0,1,3],[0,3,2],[1,2,3]]}),
    ];
    for s in shapes {
        let r = ask("collide", json!({"a": s, "pose_a": at(0.0, 0.0, 0.0), "b": {"shape": "sphere", "radius": 0.1}, "pose_b": at(3.0, 0.0, 0.0)})).expect("ok");
        assert_eq!(r["intersect"], false, "{s}");
    }
}

#[test]
fn collide_refuses_bad_input_with_the_field_named() {
    let base = json!({"a": {"shape": "sphere", "radius": 0.5}, "pose_a": at(0.0, 0.0, 0.0),
                      "b": {"shape": "sphere", "radius": 0.5}, "pose_b": at(1.5, 0.0, 0.0)});
    let mut r = base.clone();
    r["b"]["radius"] = json!(-1.0);
    let e = ask("collide", r).expect_err("negative radius");
    assert_eq!(e.kind, "bad_shape");
    assert!(
        e.message.contains("b:") && e.message.contains("radius"),
        "{}",
        e.message
    );
    let mut r = base.clone();
    r["a"]["raduis"] = json!(1.0);
    assert!(
        ask("collide", r)
            .expect_err("typo")
            .message
            .contains("a.raduis")
    );
    let mut r = base.clone();
    r["pose_b"] = json!([[2.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
    assert!(
        ask("collide", r)
            .expect_err("not rigid")
            .message
            .contains("pose_b")
    );
    let mut r = base.clone();
    r["mode"] = json!("fast");
    assert!(
        ask("collide", r)
            .expect_err("mode")
            .message
            .contains("mode")
    );
    let mut r = base;
    r["a"] = json!({"shape": "mesh", "vertices": [[0,0,0],[1,0,0],[2,0,0],[0,1,0]], "polygons": [[0,1,3],[0,1,2]]});
    let e = ask("collide", r).expect_err("degenerate");
    assert!(e.message.contains("polygon 1"), "{}", e.message);
    assert!(dispatch("fk", &json!({}), &no_robots).is_none());
}

#[test]
fn check_puma_against_a_scene_with_assumed_and_given_link_solids() {
    let scene = json!({"objects": [
        {"name": "table", "shape": "box", "size": [1.0, 2.0, 0.05], "pose": at(0.8, 0.0, 0.475)},
        {"name": "ghost", "shape": "sphere", "radius": 5.0, "use": false}
    ]});
    let r = ask(
        "check",
        json!({"robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": scene}),
    )
    .expect("ok");
    assert_eq!(r["verdict"], "clear", "{r}");
    assert_eq!(r["clear"], true);
    assert!(r["link_solids"].as_str().expect("s").starts_with("assumed"));
    let r = ask(
        "check",
        json!({"robot": "puma560", "q": [0, -0.6, 0, 0, 0, 0], "scene": scene, "mode": "polygon"}),
    )
    .expect("ok");
    assert_eq!(r["verdict"], "contact", "{r}");
    assert_eq!(r["contacts"][0]["b"]["name"], "table");
    assert!(r["contacts"][0]["a"]["link"].as_u64().is_some());
    // Given link solids: only a 2 m rod on link 6 (the tool), pointing along its z.
    let mut links = vec![Value::Null; 7];
    links[6] =
        json!({"shape": "cylinder", "radius": 0.02, "height": 2.0, "pose": at(0.0, 0.0, 1.0)});
    let r = ask("check", json!({"robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": {"objects": [
        {"name": "ceiling", "shape": "box", "size": [4, 4, 0.1], "pose": at(0.0, 0.0, 2.5)}]}, "links": links})).expect("ok");
    assert_eq!(r["link_solids"], "given");
    assert_eq!(r["verdict"], "contact", "{r}");
    assert_eq!(r["contacts"][0]["a"]["link"], 6);
    // Wrong q length and unknown robot.
    assert_eq!(
        ask(
            "check",
            json!({"robot": "puma560", "q": [0, 0], "scene": {"objects": []}})
        )
        .expect_err("q")
        .kind,
        "bad_request"
    );
    assert_eq!(
        ask(
            "check",
            json!({"robot": "r2d2", "q": [], "scene": {"objects": []}})
        )
        .expect_err("robot")
        .kind,
        "unknown_robot"
    );
}

/// Issue 37 item 3: a GJK tolerance per request. A cylinder–cone pair (curved, where GJK's
/// bracket closes slowly): the distance at 1e-4 m is within 1e-4 m of the certified one and
/// never below it (GJK's upper end), the verdict is the same, and bad tolerances are refused.
#[test]
fn collide_takes_a_tolerance_and_stays_within_it() {
    let tilt = json!([
        [0.8, 0.0, 0.6, 0.9],
        [0.0, 1.0, 0.0, 0.1],
        [-0.6, 0.0, 0.8, 0.35],
        [0.0, 0.0, 0.0, 1.0]
    ]);
    let req = json!({"a": {"shape": "cylinder", "radius": 0.3, "height": 0.8}, "pose_a": at(0.0, 0.0, 0.0),
                     "b": {"shape": "cone", "radius": 0.25, "height": 0.6}, "pose_b": tilt});
    let certified = ask("collide", req.clone()).expect("ok");
    let mut named = req.clone();
    named["tolerance"] = json!("certified");
    assert_eq!(ask("collide", named).expect("ok"), certified);
    let d0 = certified["distance"].as_f64().expect("clear");
    assert!(d0 > 0.0, "{certified}");
    for tol in [1e-9, 1e-6, 1e-4] {
        let mut r = req.clone();
        r["tolerance"] = json!(tol);
        let got = ask("collide", r).expect("ok");
        assert_eq!(got["verdict"], "clear", "{tol}");
        let d = got["distance"].as_f64().expect("distance");
        assert!(d >= d0 - 1e-11 && d <= d0 + tol, "{tol}: {d} vs {d0}");
    }
    for bad in [json!(0.0), json!(-1e-6), json!("loose"), json!(true)] {
        let mut r = req.clone();
        r["tolerance"] = bad.clone();
        let e = ask("collide", r).expect_err("refused");
        assert!(e.to_string().contains("tolerance"), "{bad}: {e}");
    }
}

/// Issue 37 item 2: `check` with `depth: false` answers the certified boolean alone — the same
/// verdict and pair as with depth, no depth or witnesses.
#[test]
fn check_without_depth_gives_the_same_pair_and_no_depth() {
    let scene = json!({"objects": [{"shape": "box", "size": [0.2, 0.2, 0.2], "pose": at(0.45, -0.15, 1.0), "name": "crate"}]});
    let with = ask(
        "check",
        json!({"robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": scene}),
    )
    .expect("ok");
    let without = ask(
        "check",
        json!({"robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": scene, "depth": false}),
    )
    .expect("ok");
    assert_eq!(with["verdict"], "contact", "{with}");
    assert_eq!(without["verdict"], "contact");
    assert_eq!(with["contacts"][0]["a"], without["contacts"][0]["a"]);
    assert_eq!(with["contacts"][0]["b"], without["contacts"][0]["b"]);
    assert!(
        with["contacts"][0]["signed_distance"]
            .as_f64()
            .expect("depth")
            < 0.0
    );
    assert!(
        without["contacts"][0]["signed_distance"].is_null(),
        "{without}"
    );
    assert!(without["contacts"][0]["witness_a"].is_null());
}

/// Issue 37 item 4: a shape repeated with other poses (and, for scene objects, other names)
/// answers exactly as a fresh one: the cache changes nothing but the time.
#[test]
fn repeated_shapes_answer_as_fresh_ones() {
    let cyl = json!({"shape": "cylinder", "radius": 0.21, "height": 0.77, "facets": 24});
    let cone = json!({"shape": "cone", "radius": 0.13, "height": 0.41});
    let mut first = Vec::new();
    for x in [0.3, 0.5, 0.9] {
        first.push(
            ask("collide", json!({"a": cyl, "pose_a": at(0.0, 0.0, 0.0), "b": cone, "pose_b": at(x, 0.0, 0.1)}))
                .expect("ok"),
        );
    }
    for (x, f) in [0.3, 0.5, 0.9].into_iter().zip(&first) {
        let again = ask(
            "collide",
            json!({"a": cyl, "pose_a": at(0.0, 0.0, 0.0), "b": cone, "pose_b": at(x, 0.0, 0.1)}),
        )
        .expect("ok");
        assert_eq!(&again, f, "{x}");
    }
    assert_eq!(first[0]["verdict"], "contact");
    assert_eq!(first[2]["verdict"], "clear");
    // A bad shape is refused every time (errors are not cached) with its own path.
    for path in ["a", "b"] {
        let mut req =
            json!({"a": cyl, "pose_a": at(0.0, 0.0, 0.0), "b": cyl, "pose_b": at(1.0, 0.0, 0.0)});
        req[path]["radius"] = json!(-1.0);
        let e = ask("collide", req).expect_err("negative radius");
        assert!(e.to_string().contains(&format!(": {path}: ")), "{e}");
    }
}
