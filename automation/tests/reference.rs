//! Against outside references (testdata/automation, generated with networkx and scipy by
//! testdata/automation/gen_reference.py): the diagnoser's per-alarm searches (admissible
//! reachability, dmin, dmax), the zero-time-cycle check, and the arm of the reconfiguration
//! example under its P controller.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_automation::diag::{Diagnoser, FaultGraph};
use robosim_automation::model::check::check_model;
use robosim_automation::model::parse_model;
use robosim_automation::reconfig::{ReconfigOptions, run_reconfig_demo};
use serde_json::Value;

fn data(name: &str) -> Value {
    let path = format!(
        "{}/../testdata/automation/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    serde_json::from_str(&std::fs::read_to_string(&path).expect("reference file present"))
        .expect("valid JSON")
}

#[test]
fn explanations_match_networkx() {
    let d = data("fault_graph_reference.json");
    let mut compared = 0;
    for case in d["cases"].as_array().unwrap() {
        let m = parse_model(case["model"].as_str().unwrap(), "reference").unwrap();
        let g = FaultGraph::new(&m);
        let mut diag = Diagnoser::new(&g, None);
        let rung: Vec<(usize, f64)> = case["rung"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| (m.find_alarm(a.as_str().unwrap()).unwrap(), 0.0))
            .collect();
        diag.add_batch(&rung).unwrap();
        diag.complete_explanations();
        for r in diag.ringing() {
            let name = &m.alarms[r.alarm].name;
            let expected = case["explain"][name].as_object().unwrap();
            assert_eq!(
                r.explain.len(),
                expected.len(),
                "seed {} alarm {name}",
                case["seed"]
            );
            for (fm, bounds) in expected {
                let f = m.find_failure_mode(fm).unwrap();
                let (dmin, dmax) = r
                    .explain
                    .get(&f)
                    .copied()
                    .unwrap_or_else(|| panic!("{fm} missing for {name}"));
                assert!(
                    (dmin - bounds[0].as_f64().unwrap()).abs() < 1e-9,
                    "{name} {fm} dmin"
                );
                match bounds[1].as_f64() {
                    Some(x) => assert!((dmax - x).abs() < 1e-9, "{name} {fm} dmax {dmax} vs {x}"),
                    None => assert!(
                        dmax.is_infinite(),
                        "{name} {fm}: no certain path, dmax {dmax}"
                    ),
                }
                compared += 1;
            }
        }
        let cycles: Vec<String> = check_model(&m)
            .into_iter()
            .filter(|f| f.code == "zero-time-cycle")
            .map(|f| f.message)
            .collect();
        let expected = case["zero_time_cycles"].as_array().unwrap();
        assert_eq!(cycles.len(), expected.len());
        for (msg, members) in cycles.iter().zip(expected) {
            let names: Vec<String> = members
                .as_array()
                .unwrap()
                .iter()
                .map(|x| format!("R.{}", x.as_str().unwrap()))
                .collect();
            assert!(msg.contains(&names.join(", ")), "{msg} vs {names:?}");
        }
    }
    assert!(compared > 800, "compared {compared} source bounds");
}

#[test]
fn arm_under_p_control_matches_scipy() {
    let d = data("pendulum_reference.json");
    let p = &d["params"];
    let opts = ReconfigOptions {
        mass: p["mass"].as_f64().unwrap(),
        length: p["length"].as_f64().unwrap(),
        damping: p["damping"].as_f64().unwrap(),
        gravity: p["gravity"].as_f64().unwrap(),
        kp: p["kp"].as_f64().unwrap(),
        setpoint: p["setpoint"].as_f64().unwrap(),
        duration: 3.0,
        allow_switch: false,
        ..ReconfigOptions::default()
    };
    let out = run_reconfig_demo(&opts).unwrap();
    let mut worst: f64 = 0.0;
    for s in d["samples"].as_array().unwrap() {
        let t = s["t"].as_f64().unwrap();
        let (_, e) = out
            .tracking
            .iter()
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .copied()
            .unwrap();
        let q = opts.setpoint - e;
        worst = worst.max((q - s["q"].as_f64().unwrap()).abs());
    }
    // Semi-implicit Euler at 1 ms with the controller one step behind the plant (the dataflow
    // loop): first-order accurate; over 3 s of a lightly damped swing the gap stays below 0.02 rad.
    assert!(worst < 0.02, "worst |q - q_scipy| = {worst}");
}
