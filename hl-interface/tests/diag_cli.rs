//! The `robosim diag` commands and the `diag_*` query ops, driven directly.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_hl_interface::cli::CommandError;
use robosim_hl_interface::cli::diag::{DiagCmd, execute};
use robosim_hl_interface::protocol::automation::dispatch;
use serde_json::json;

#[test]
fn check_reports_the_model_and_refuses_inconsistent_ones() {
    let dir = tempfile::tempdir().unwrap();
    let dot = dir.path().join("eclss.dot");
    let out = execute(DiagCmd::Check {
        model: "eclss".into(),
        dot: Some(dot.clone()),
    })
    .unwrap();
    assert!(out.contains("model ECLSS"), "{out}");
    assert!(
        out.trim_end().ends_with("consistent (0 warning(s))"),
        "{out}"
    );
    let dot = std::fs::read_to_string(dot).unwrap();
    assert!(
        dot.starts_with("digraph hfm") && dot.contains("label=\"CO2Reduction\""),
        "{dot}"
    );
    assert_eq!(
        dot.matches(" -> ").count(),
        59 + 57,
        "every edge and alarm association drawn"
    );
    let bad = dir.path().join("bad.hfm");
    std::fs::write(&bad, "process R {\n  failure f failure g\n  propagate f -> g prob 1 time 0..1\n  propagate g -> f prob 1 time 0..1\n}\n").unwrap();
    let err = execute(DiagCmd::Check {
        model: bad.display().to_string(),
        dot: None,
    })
    .unwrap_err();
    assert!(matches!(err, CommandError::Refused(_)), "{err:?}");
    let err = err.to_string();
    assert!(err.contains("bad.hfm:2:3: error[zero-time-cycle]"), "{err}");
    let syntax = dir.path().join("syntax.hfm");
    std::fs::write(&syntax, "process R {\n  failure f\n  alarm A detect f\n}\n").unwrap();
    let err = execute(DiagCmd::Check {
        model: syntax.display().to_string(),
        dot: None,
    })
    .unwrap_err();
    // A model that does not parse is the fault-model reader's typed error.
    assert!(matches!(err, CommandError::FaultModel(_)), "{err:?}");
    let err = err.to_string();
    assert!(
        err.starts_with(&format!("{}:3:11: expected `detects`", syntax.display())),
        "{err}"
    );
    assert!(
        execute(DiagCmd::Check {
            model: "no-such-model".into(),
            dot: None
        })
        .is_err()
    );
}

#[test]
fn simulate_then_run_isolates_the_injected_fault() {
    let sim = execute(DiagCmd::Simulate {
        model: "eclss".into(),
        faults: vec!["CO2Removal.sorbent_bed_failure".into()],
        seed: 3,
        sample: false,
        drop: vec!["A_co2_bed".into(), "A_co2_removal".into()],
    })
    .unwrap();
    assert!(sim.starts_with("# model <eclss>; injected: ECLSS.AirControl.CO2Processing.CO2Removal.sorbent_bed_failure@0"), "{sim}");
    assert!(!sim.contains("A_co2_bed"));
    assert!(sim.contains("A_bosch_water"));
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("alarms.txt");
    std::fs::write(&file, &sim).unwrap();
    let out = execute(DiagCmd::Run {
        model: "eclss".into(),
        alarms: file.clone(),
        until: None,
        drop: vec!["A_co2_bed".into(), "A_co2_removal".into()],
    })
    .unwrap();
    assert!(
        out.contains("diagnosis (single fault, 1 candidate failure mode(s)):"),
        "{out}"
    );
    assert!(
        out.contains(
            "ECLSS.AirControl.CO2Processing.CO2Removal.sorbent_bed_failure  [co2_sorbent_bed]"
        ),
        "{out}"
    );
    assert!(out.contains("FSCI components: co2_sorbent_bed"), "{out}");
    // Without dropping the bed alarms, the same file makes those alarms "normal": the bed
    // cannot be the source, and the sorbent failure is explained otherwise or not at all.
    let out2 = execute(DiagCmd::Run {
        model: "eclss".into(),
        alarms: file,
        until: None,
        drop: vec![],
    })
    .unwrap();
    assert!(!out2.contains("sorbent_bed_failure  ["), "{out2}");
}

#[test]
fn run_reports_bad_alarm_files_with_place() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a.txt");
    std::fs::write(&file, "0 A_thc_hx\n5 A_nope\n").unwrap();
    let err = execute(DiagCmd::Run {
        model: "eclss".into(),
        alarms: file.clone(),
        until: None,
        drop: vec![],
    })
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{}:2:3: no alarm named `A_nope`", file.display())
    );
    std::fs::write(&file, "10 A_thc_hx\n5 A_thc_humidity\n").unwrap();
    let err = execute(DiagCmd::Run {
        model: "eclss".into(),
        alarms: file,
        until: None,
        drop: vec![],
    })
    .unwrap_err();
    assert!(
        err.to_string()
            .contains(":2:1: alarms must be in time order"),
        "{err}"
    );
}

#[test]
fn analyze_ends_with_a_summary_line() {
    let out = execute(DiagCmd::Analyze {
        model: "eclss".into(),
        sensors: Some(8),
        trials: 1,
        seed: 1,
    })
    .unwrap();
    let last = out.lines().last().unwrap();
    assert!(last.starts_with("summary: ECLSS: "), "{out}");
    assert!(last.contains("all 57 alarms isolate 21/21"), "{last}");
    assert!(last.contains("8 greedy-chosen alarms isolate"), "{last}");
    assert!(out.contains("advice: keep 8 alarm(s): "));
}

#[test]
fn query_ops_answer_json() {
    let none = |_: &str| None::<robosim_kinematics::Robot>;
    assert!(dispatch("fk", &json!({}), &none).is_none());
    let r = dispatch("diag_check", &json!({"model": "eclss"}), &none)
        .unwrap()
        .unwrap();
    assert_eq!(r["consistent"], json!(true));
    assert_eq!(r["alarms"], json!(57));
    let sim = dispatch(
        "diag_simulate",
        &json!({"model": "eclss", "faults": [{"fault": "Shower.consumer_leaking"}]}),
        &none,
    )
    .unwrap()
    .unwrap();
    let alarms = sim["alarms"].as_array().unwrap().clone();
    assert_eq!(alarms[0]["alarm"], json!("A_shower_leak"));
    // Only the symptoms: drop the leak alarms of both consumers.
    let symptoms: Vec<_> = alarms
        .iter()
        .filter(|a| a["alarm"] != json!("A_shower_leak"))
        .cloned()
        .collect();
    let d = dispatch(
        "diag_diagnose",
        &json!({"model": "eclss", "alarms": symptoms, "drop": ["A_shower_leak", "A_dish_leak"]}),
        &none,
    )
    .unwrap()
    .unwrap();
    let c: Vec<String> = d["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap().to_string())
        .collect();
    assert!(
        c.contains(&"ECLSS.Hygiene.Circulation.Shower.consumer_leaking".to_string()),
        "{d}"
    );
    assert!(
        c.contains(&"ECLSS.Hygiene.Circulation.Dishwasher.consumer_leaking".to_string()),
        "{d}"
    );
    assert_eq!(d["ilm"]["processes"].as_array().unwrap().len(), 2, "{d}");
    let e = dispatch(
        "diag_diagnose",
        &json!({"model": "eclss", "alarms": [{"alarm": "A_x", "t": 0}]}),
        &none,
    )
    .unwrap()
    .unwrap_err();
    assert_eq!(e.kind, "unknown_alarm");
    let e = dispatch("diag_check", &json!({}), &none)
        .unwrap()
        .unwrap_err();
    assert_eq!(e.kind, "bad_request");
}

#[test]
fn run_says_when_nothing_explains_the_alarms() {
    // Only the pump-flow alarm rings: both ways into Pumping.no_flow (the pump failure and the
    // missing inlet water) have allocated alarms that stay silent, so no source reaches it.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a.txt");
    std::fs::write(&file, "5 A_pump_flow\n").unwrap();
    let out = execute(DiagCmd::Run {
        model: "eclss".into(),
        alarms: file,
        until: None,
        drop: vec![],
    })
    .unwrap();
    assert!(
        out.contains("no hypothesis of up to 3 faults explains these alarms"),
        "{out}"
    );
}
