//! FSPI's four constraints, multiple faults, FSCI and ILM on small hand-made models, and the
//! ECLSS baseline (every single fault isolated with all alarms present).
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_automation::analysis::evaluate;
use robosim_automation::diag::{Diagnoser, FaultGraph, Ilm, fsci};
use robosim_automation::model::{Model, load_model, parse_model};
use robosim_automation::sim::SimOptions;

fn model(text: &str) -> Model {
    parse_model(text, "test.hfm").expect("test model parses")
}

fn names(m: &Model, fms: &[usize]) -> Vec<String> {
    fms.iter()
        .map(|&f| m.failure_modes[f].name.clone())
        .collect()
}

fn single(m: &Model, d: &Diagnoser<'_>) -> Vec<String> {
    names(m, &d.candidates().iter().map(|c| c.fm).collect::<Vec<_>>())
}

fn alarm(m: &Model, name: &str) -> usize {
    m.find_alarm(name).expect("alarm exists")
}

#[test]
fn reachability_constraint_alone_decides() {
    let m = model(
        "process R { failure a failure b failure x derived failure y derived
           propagate a -> x prob 0.9 time 1..2  propagate b -> y prob 0.9 time 1..2
           alarm AX detects x  alarm AY detects y }",
    );
    let g = FaultGraph::new(&m);
    let mut d = Diagnoser::new(&g, None);
    d.add_alarm(alarm(&m, "AX"), 1.5).unwrap();
    assert_eq!(single(&m, &d), ["a"]);
}

#[test]
fn monitor_constraint_alone_decides() {
    // a reaches x only through m, whose alarm stays normal; b reaches x directly.
    let m = model(
        "process R { failure a failure b failure m derived failure x derived
           propagate a -> m prob 0.9 time 1..2  propagate m -> x prob 0.9 time 1..2
           propagate b -> x prob 0.9 time 1..2
           alarm AM detects m  alarm AX detects x }",
    );
    let g = FaultGraph::new(&m);
    let mut d = Diagnoser::new(&g, None);
    d.add_alarm(alarm(&m, "AX"), 3.0).unwrap();
    assert_eq!(single(&m, &d), ["b"]);
    // Without the monitor (AM not allocated) both explain the alarm.
    let present: Vec<bool> = m.alarms.iter().map(|a| a.name != "AM").collect();
    let mut d = Diagnoser::new(&g, Some(&present));
    d.add_alarm(alarm(&m, "AX"), 3.0).unwrap();
    assert_eq!(single(&m, &d), ["a", "b"]);
}

#[test]
fn temporal_constraint_alone_decides() {
    let m = model(
        "process R { failure a failure b failure x derived failure y derived
           propagate a -> x prob 0.9 time 10..20  propagate a -> y prob 1 time 10..20
           propagate b -> x prob 0.9 time 1..5  propagate b -> y prob 1 time 1..5
           alarm AX detects x  alarm AY detects y }",
    );
    let g = FaultGraph::new(&m);
    let mut d = Diagnoser::new(&g, None);
    d.add_alarm(alarm(&m, "AX"), 100.0).unwrap();
    assert_eq!(single(&m, &d), ["a", "b"]);
    d.add_alarm(alarm(&m, "AY"), 110.0).unwrap();
    // a: t0 <= 90 (x; p < 1 gives no lower bound on t0) and t0 in [90, 100] (y) -> 90.
    // b: t0 <= 99 and t0 in [105, 109]: empty. (No alarm is overdue: consistency is silent.)
    assert_eq!(single(&m, &d), ["a"]);
    let c = d.candidates()[0];
    assert!(
        (c.t0.0 - 90.0).abs() < 1e-9 && (c.t0.1 - 90.0).abs() < 1e-9,
        "{c:?}"
    );
}

#[test]
fn consistency_constraint_alone_decides() {
    // a must cause z (probability 1) within 2 s of causing x; z's alarm stays normal.
    let m = model(
        "process R { failure a failure b failure x derived failure z derived
           propagate a -> x prob 1 time 1..2  propagate a -> z prob 1 time 1..2
           propagate b -> x prob 0.5 time 1..2
           alarm AX detects x  alarm AZ detects z }",
    );
    let g = FaultGraph::new(&m);
    let mut d = Diagnoser::new(&g, None);
    d.add_alarm(alarm(&m, "AX"), 10.0).unwrap();
    assert_eq!(single(&m, &d), ["a", "b"], "z is not overdue yet");
    d.advance_to(10.5);
    assert_eq!(
        single(&m, &d),
        ["a", "b"],
        "a's fault time can be 9: z due by 11"
    );
    d.advance_to(20.0);
    assert_eq!(single(&m, &d), ["b"]);
}

#[test]
fn multiple_faults_are_found_when_no_single_fault_explains() {
    let m = model(
        "process R { component pump, valve
           failure a components pump  failure b components pump, valve  failure c components valve
           failure x derived failure y derived
           propagate a -> x prob 0.9 time 1..2  propagate b -> y prob 0.9 time 1..2
           propagate c -> y prob 0.9 time 1..2
           alarm AX detects x  alarm AY detects y }",
    );
    let g = FaultGraph::new(&m);
    let mut d = Diagnoser::new(&g, None);
    d.add_alarm(alarm(&m, "AX"), 2.0).unwrap();
    d.add_alarm(alarm(&m, "AY"), 3.0).unwrap();
    assert!(d.candidates().is_empty());
    let v = d.global_verdict();
    let hyps: Vec<Vec<String>> = v.multiple.iter().map(|h| names(&m, h)).collect();
    assert_eq!(hyps, vec![vec!["a", "b"], vec!["a", "c"]]);
    // FSCI: a and b share the pump; a and c share nothing.
    let comp = |cs: Vec<usize>| {
        cs.iter()
            .map(|&c| m.components[c].name.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(comp(fsci(&m, &v.multiple[0], true)), ["pump"]);
    assert_eq!(comp(fsci(&m, &v.multiple[1], true)), ["pump", "valve"]);
    // A single fault: the union of the candidates' components.
    let b = m.find_failure_mode("b").unwrap();
    let c = m.find_failure_mode("c").unwrap();
    assert_eq!(comp(fsci(&m, &[b, c], false)), ["pump", "valve"]);
}

#[test]
fn three_simultaneous_faults() {
    let m = model(
        "process R { failure a failure b failure c failure x derived failure y derived failure z derived
           propagate a -> x prob 1 time 1..2  propagate b -> y prob 1 time 1..2  propagate c -> z prob 1 time 1..2
           alarm AX detects x  alarm AY detects y  alarm AZ detects z }",
    );
    let g = FaultGraph::new(&m);
    let mut d = Diagnoser::new(&g, None);
    d.add_batch(&[
        (alarm(&m, "AX"), 2.0),
        (alarm(&m, "AY"), 2.0),
        (alarm(&m, "AZ"), 2.0),
    ])
    .unwrap();
    let v = d.global_verdict();
    assert_eq!(
        v.multiple.iter().map(|h| names(&m, h)).collect::<Vec<_>>(),
        vec![vec!["a", "b", "c"]]
    );
}

#[test]
fn alarm_errors_are_typed() {
    let m = model("process R { failure a alarm A detects a alarm B detects a }");
    let g = FaultGraph::new(&m);
    let present = [true, false];
    let mut d = Diagnoser::new(&g, Some(&present));
    assert!(d.add_alarm(7, 1.0).is_err());
    assert!(d.add_alarm(1, 1.0).is_err(), "B is not allocated");
    d.add_alarm(0, 5.0).unwrap();
    assert!(d.add_alarm(0, 1.0).is_err(), "out of order");
    assert!(d.add_alarm(0, f64::NAN).is_err());
}

const TWO_LEVEL: &str = "process R {
  process A {
    output o
    process A1 { output o component c1 failure f1 components c1 alarm L1 detects f1 }
    process A2 { component c2 failure f2 components c2 alarm L2 detects f2 }
    connect A1.o -> o
    failure fa derived
    propagate A1.f1 -> fa prob 1 time 10..20
    propagate A2.f2 -> fa prob 1 time 10..20
    alarm LA detects fa
  }
  process B { input i failure fb derived alarm LB detects fb }
  connect A.o -> B.i
  propagate A.fa -> B.fb prob 1 time 10..20
}";

#[test]
fn ilm_refines_level_by_level_and_restarts_on_a_higher_alarm() {
    let m = model(TWO_LEVEL);
    let g = FaultGraph::new(&m);
    let present: Vec<bool> = m.alarms.iter().map(|a| a.name != "LA").collect();
    let mut ilm = Ilm::new(&m, &g, Some(&present));
    assert!(ilm.best_guess().is_none());
    ilm.on_alarm(alarm(&m, "L1"), 0.0).unwrap();
    assert!(ilm.step());
    let guess = ilm.best_guess().unwrap();
    assert_eq!(guess.depth, 1);
    assert_eq!(m.processes[guess.processes[0]].path, "R.A.A1");
    assert!(ilm.step());
    let guess = ilm.best_guess().unwrap();
    assert_eq!(guess.depth, 2);
    assert_eq!(names(&m, &guess.failure_modes), ["f1"]);
    assert_eq!(
        guess
            .components
            .iter()
            .map(|&c| m.components[c].name.as_str())
            .collect::<Vec<_>>(),
        ["c1"]
    );
    assert!(
        !ilm.step(),
        "f1 belongs to A1 itself: finest resolution reached"
    );
    // An alarm on the level being processed does not restart (a second fault, in A2)...
    ilm.on_alarm(alarm(&m, "L2"), 15.0).unwrap();
    assert_eq!(ilm.restarts, 0);
    assert_eq!(ilm.levels().len(), 2);
    // ...an alarm higher up does: the search begins again at depth 0.
    ilm.on_alarm(alarm(&m, "LB"), 30.0).unwrap();
    assert_eq!(ilm.restarts, 1);
    assert!(ilm.levels().is_empty());
    assert!(
        ilm.log.iter().any(|l| l.contains("restart at depth 0")),
        "{:?}",
        ilm.log
    );
    assert!(ilm.step());
    let guess = ilm.best_guess().unwrap();
    assert_eq!(guess.depth, 0);
    assert_eq!(
        guess
            .processes
            .iter()
            .map(|&p| m.processes[p].path.as_str())
            .collect::<Vec<_>>(),
        ["R.A"]
    );
    ilm.run_to_completion();
    let guess = ilm.best_guess().unwrap();
    assert!(guess.multiple);
    assert_eq!(names(&m, &guess.failure_modes), ["f1", "f2"]);
    assert_eq!(
        guess
            .components
            .iter()
            .map(|&c| m.components[c].name.as_str())
            .collect::<Vec<_>>(),
        ["c1", "c2"]
    );
}

#[test]
fn ilm_climbs_when_the_cause_lies_in_a_sibling() {
    // Only B's alarm is allocated: the cause is in A, outside the alarmed process.
    let m = model(TWO_LEVEL);
    let g = FaultGraph::new(&m);
    let present: Vec<bool> = m.alarms.iter().map(|a| a.name == "LB").collect();
    let mut ilm = Ilm::new(&m, &g, Some(&present));
    ilm.on_alarm(alarm(&m, "LB"), 40.0).unwrap();
    ilm.run_to_completion();
    let guess = ilm.best_guess().unwrap();
    assert_eq!(names(&m, &guess.failure_modes), ["f1", "f2"]);
}

#[test]
fn every_eclss_single_fault_is_isolated_with_all_alarms() {
    let m = load_model("eclss").unwrap();
    let g = FaultGraph::new(&m);
    let all = vec![true; m.alarms.len()];
    for sample in [false, true] {
        let opts = SimOptions {
            seed: 7,
            sample_probabilities: sample,
            ..SimOptions::default()
        };
        let r = evaluate(&m, &g, &all, &opts, if sample { 3 } else { 1 });
        assert_eq!(
            r.faults,
            m.source_failure_modes().len() * if sample { 3 } else { 1 }
        );
        for o in &r.outcomes {
            assert!(
                o.isolated,
                "{} -> {:?}",
                m.failure_modes[o.fault].path,
                names(&m, &o.group)
            );
            assert_eq!(o.time_to_isolation, Some(0.0));
        }
    }
    // ILM reaches the same answer, level by level, from the complete alarm sequence.
    for f in m.source_failure_modes() {
        let sim = robosim_automation::sim::simulate(&g, &[(f, 0.0)], &SimOptions::default());
        let mut ilm = Ilm::new(&m, &g, None);
        for e in &sim.alarms {
            ilm.on_alarm(e.alarm, e.time).unwrap();
            ilm.step();
        }
        ilm.run_to_completion();
        let guess = ilm.best_guess().unwrap();
        assert_eq!(guess.failure_modes, vec![f], "{}", m.failure_modes[f].path);
        assert_eq!(guess.processes, vec![m.failure_modes[f].process]);
    }
}

#[test]
fn alarms_that_ring_together_are_one_update() {
    // x follows a with no delay: both alarms carry the same time stamp.
    let m = model(
        "process R { failure a failure b failure x derived
           propagate a -> x prob 1 time 0..0  propagate b -> x prob 0.5 time 1..5
           alarm AA detects a  alarm AX detects x }",
    );
    let g = FaultGraph::new(&m);
    let mut ilm = Ilm::new(&m, &g, None);
    // Listed x first: taken one by one, a would look silent when x rang.
    ilm.on_alarms(&[(alarm(&m, "AX"), 3.0), (alarm(&m, "AA"), 3.0)])
        .unwrap();
    ilm.run_to_completion();
    assert_eq!(names(&m, &ilm.best_guess().unwrap().failure_modes), ["a"]);
    let mut d = Diagnoser::new(&g, None);
    d.add_alarm(alarm(&m, "AX"), 3.0).unwrap();
    assert_eq!(
        single(&m, &d),
        ["b"],
        "one by one, the silent a is excluded"
    );
}
