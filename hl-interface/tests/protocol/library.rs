//! The library ops of the query protocol, driven with JSON.

use robosim_hl_interface::protocol::library::dispatch;
use serde_json::{Value, json};

fn ask(op: &str, req: Value) -> Result<Value, robosim_hl_interface::ProtocolError> {
    dispatch(op, &req, &|_| None).expect("a library op")
}

#[test]
fn other_ops_are_not_ours() {
    assert!(dispatch("fk", &json!({}), &|_| None).is_none());
}

#[test]
fn list_params_and_evaluate() {
    let list = ask("lib_list", json!({})).expect("list");
    let decls = list["declarations"].as_array().expect("array");
    assert!(
        decls
            .iter()
            .any(|d| d["name"] == "puma560" && d["kind"] == "robot")
    );
    let p = ask("lib_params", json!({"name": "surgical_positioner"})).expect("params");
    assert!(
        p["params"]
            .as_array()
            .expect("array")
            .iter()
            .any(|x| x["name"] == "upper_arm" && x["unit"] == "m")
    );
    let r = ask("lib_evaluate", json!({"name": "surgical_positioner", "params": {"upper_arm": "30 cm", "forearm": 0.25}, "geometry": false})).expect("eval");
    assert_eq!(r["kind"], "robot");
    assert_eq!(r["robot"]["joints"][1]["a"], 0.3);
    assert_eq!(r["robot"]["joints"][3]["d"], 0.25);
    assert_eq!(r["robot"]["convention"], "standard");
    assert_eq!(r["robot"]["base"][3], json!([0.0, 0.0, 0.0, 1.0]));
    assert!(r["frames"][1][0].get("vertices").is_none());
    // with geometry: vertices and polygons of every solid
    let r = ask("lib_evaluate", json!({"name": "puma560", "facets": 8})).expect("eval");
    let flange = &r["frames"][6][0];
    assert_eq!(flange["primitive"]["shape"], "cylinder");
    assert_eq!(flange["vertices"].as_array().expect("vertices").len(), 16);
    let s = ask(
        "lib_evaluate",
        json!({"name": "space_station", "geometry": false}),
    )
    .expect("scene");
    assert_eq!(s["robots"].as_array().expect("robots").len(), 5);
    assert_eq!(s["effects"]["collision"]["mode"], "bbox");
}

#[test]
fn errors_have_kinds() {
    assert_eq!(
        ask("lib_evaluate", json!({"name": "pumma560"}))
            .expect_err("unknown")
            .kind,
        "unknown_declaration"
    );
    assert_eq!(
        ask(
            "lib_evaluate",
            json!({"name": "puma560", "params": {"x": 1}})
        )
        .expect_err("param")
        .kind,
        "bad_parameter"
    );
    assert_eq!(
        ask(
            "lib_evaluate",
            json!({"name": "surgical_positioner", "params": {"upper_arm": "30 deg"}})
        )
        .expect_err("unit")
        .kind,
        "bad_parameter"
    );
    assert_eq!(
        ask("lib_params", json!({})).expect_err("no name").kind,
        "bad_request"
    );
    assert_eq!(
        ask("lib_evaluate", json!({"name": "puma560", "facets": 1}))
            .expect_err("facets")
            .kind,
        "bad_request"
    );
    let e = ask("lib_list", json!({"file": "/no/such/file.rsl"})).expect_err("file");
    assert_eq!(e.kind, "library_error");
}
