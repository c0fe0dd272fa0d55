//! The model language and its consistency checks.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_automation::model::check::{Severity, check_model, is_consistent};
use robosim_automation::model::{load_model, parse_model};

#[test]
fn eclss_loads_and_is_consistent() {
    let m = load_model("eclss").expect("shipped model parses");
    let findings = check_model(&m);
    for f in &findings {
        eprintln!("{}", f.render(&m.source));
    }
    assert!(is_consistent(&findings));
    assert!(
        findings.is_empty(),
        "the shipped ECLSS model has no warnings either"
    );
    // Figure 7's hierarchy: the three subsystems and the named subprocesses.
    for p in [
        "ECLSS.AirControl.THC",
        "ECLSS.AirControl.Ventilation",
        "ECLSS.AirControl.O2Generation",
        "ECLSS.AirControl.CO2Processing.CO2Removal",
        "ECLSS.AirControl.CO2Processing.CO2Reduction",
        "ECLSS.PotableWater.Pumping",
        "ECLSS.PotableWater.DistributionStorage",
        "ECLSS.PotableWater.MultiFiltration",
        "ECLSS.PotableWater.WaterTesting",
        "ECLSS.PotableWater.Controller",
        "ECLSS.Hygiene.HygieneProcess",
        "ECLSS.Hygiene.UrineProcessing",
        "ECLSS.Hygiene.Circulation.WasteWaterSupply",
        "ECLSS.Hygiene.Circulation.Collector",
        "ECLSS.Hygiene.Circulation.VapourAddition",
    ] {
        assert!(m.processes.iter().any(|q| q.path == p), "missing {p}");
    }
    assert!(
        m.edges.iter().all(|e| e.assumed),
        "the seed gives no numbers: all edges are assumptions"
    );
    assert!(m.find_failure_mode("no_water_for_potable_supply").is_ok());
}

fn codes(text: &str) -> Vec<(&'static str, Severity)> {
    let m = parse_model(text, "t.hfm").expect("parses");
    check_model(&m)
        .into_iter()
        .map(|f| (f.code, f.severity))
        .collect()
}

#[test]
fn signal_between_non_adjacent_processes_is_refused() {
    let c = codes(
        "process R { process A { process A1 { output x } } process B { input y }
           connect A.A1.x -> B.y }",
    );
    assert_eq!(c, vec![("signal-hierarchy", Severity::Error)]);
}

#[test]
fn signal_direction_is_checked() {
    let c = codes("process R { process A { input x } process B { input y } connect A.x -> B.y }");
    assert_eq!(c, vec![("signal-direction", Severity::Error)]);
}

#[test]
fn sibling_edge_needs_a_physical_link() {
    let base = "process R { process A { output x failure f } process B { input y failure g }
                %C propagate A.f -> B.g prob 1 time 1..2 alarm a detects B.g }";
    assert_eq!(
        codes(&base.replace("%C", "")),
        vec![("edge-without-link", Severity::Error)]
    );
    assert!(codes(&base.replace("%C", "connect A.x -> B.y")).is_empty());
    // Against the flow is not a physical path either.
    let back = "process R { process A { input x failure f alarm a detects f } process B { output y failure g }
                connect B.y -> A.x propagate A.f -> B.g prob 1 time 1..2 alarm b detects B.g }";
    assert_eq!(codes(back), vec![("edge-without-link", Severity::Error)]);
}

#[test]
fn edge_across_non_adjacent_processes_is_refused() {
    let c = codes(
        "process R { process A { process A1 { failure f } } process B { failure g }
           propagate A.A1.f -> B.g prob 1 time 1..2 alarm a detects B.g }",
    );
    assert!(c.contains(&("edge-hierarchy", Severity::Error)), "{c:?}");
}

#[test]
fn zero_time_cycle_is_an_error_and_incompleteness_warns() {
    let m = parse_model(
        "process R { failure f failure g failure h derived failure u
           propagate f -> g prob 1 time 0..1 propagate g -> f prob 1 time 0..3
           alarm a detects f }",
        "t.hfm",
    );
    let m = m.expect("parses");
    let f = check_model(&m);
    let rendered: Vec<String> = f.iter().map(|x| x.render("t.hfm")).collect();
    assert_eq!(f[0].code, "zero-time-cycle", "{rendered:?}");
    assert!(rendered[0].contains("R.f, R.g"), "{rendered:?}");
    assert!(
        f.iter()
            .any(|x| x.code == "unobservable" && x.message.contains("R.u"))
    );
    assert!(
        f.iter()
            .any(|x| x.code == "unreachable" && x.message.contains("R.h"))
    );
    assert!(!is_consistent(&f));
}

#[test]
fn alarm_outside_its_process_warns() {
    let c = codes(
        "process R { process A { failure f alarm X detects R.B.g } process B { failure g } }",
    );
    assert!(c.contains(&("alarm-scope", Severity::Warning)), "{c:?}");
}
