//! The random model generator and the advisor.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_automation::analysis::{advise_exhaustive, advise_greedy, evaluate};
use robosim_automation::diag::FaultGraph;
use robosim_automation::model::check::{check_model, is_consistent};
use robosim_automation::sim::SimOptions;
use robosim_report::automation::{GenOptions, advisor_gap, generate, measure_update_time};

#[test]
fn generated_models_are_consistent_and_sized() {
    for (n, seed) in [(30, 1), (100, 2), (1000, 3)] {
        let m = generate(&GenOptions {
            failure_modes: n,
            alarm_density: 0.5,
            seed,
        });
        let f = check_model(&m);
        assert!(
            is_consistent(&f),
            "{:?}",
            f.iter()
                .find(|x| x.severity == robosim_automation::model::check::Severity::Error)
        );
        assert!(
            m.failure_modes.len().abs_diff(n) <= n / 10 + 2,
            "{} for {n}",
            m.failure_modes.len()
        );
        assert!(m.max_depth() >= 1 || n <= 12);
    }
}

#[test]
fn with_every_alarm_every_fault_of_a_random_model_is_isolated() {
    let m = generate(&GenOptions {
        failure_modes: 200,
        alarm_density: 1.0,
        seed: 9,
    });
    let g = FaultGraph::new(&m);
    let r = evaluate(
        &m,
        &g,
        &vec![true; m.alarms.len()],
        &SimOptions {
            sample_probabilities: true,
            ..Default::default()
        },
        1,
    );
    assert_eq!(r.isolated, r.faults);
}

#[test]
fn greedy_advice_is_never_better_than_exhaustive_and_improves_with_budget() {
    let gap = advisor_gap(1, 14, 3);
    assert_eq!(gap.len(), 3);
    for (_, _, _, greedy, optimal) in &gap {
        assert!(*greedy >= optimal - 1e-9);
    }
    assert!(
        gap.windows(2).all(|w| w[1].3 <= w[0].3 + 1e-9),
        "greedy cost falls with the budget: {gap:?}"
    );
    // Exhaustive search with the full budget keeps every alarm's information.
    let m = generate(&GenOptions {
        failure_modes: 14,
        alarm_density: 0.5,
        seed: 100,
    });
    let g = FaultGraph::new(&m);
    let (all, cost) = advise_exhaustive(&m, &g, m.alarms.len(), &SimOptions::default());
    assert_eq!(all.len(), m.alarms.len());
    let greedy = advise_greedy(&m, &g, m.alarms.len(), &SimOptions::default(), 1);
    assert!((greedy.last().unwrap().1 - cost).abs() < 1e-9);
}

#[test]
fn update_time_measurement_runs() {
    let r = measure_update_time(100, 0.3, 3, 1);
    assert!(r.failure_modes >= 90 && r.updates > 0);
    assert!(r.mean_group >= 1.0);
}

#[test]
fn bounded_searches_give_the_same_diagnoses_as_full_ones() {
    use robosim_automation::diag::Diagnoser;
    use robosim_automation::sim::simulate;
    let m = generate(&GenOptions {
        failure_modes: 400,
        alarm_density: 0.3,
        seed: 5,
    });
    let g = FaultGraph::new(&m);
    let sources = m.source_failure_modes();
    let mut multiple = 0;
    for (k, &f) in sources.iter().enumerate().step_by(7) {
        // Two faults sometimes, so the multiple-fault search (which completes maps) runs too.
        let mut faults = vec![(f, 0.0)];
        if k % 3 == 0 {
            faults.push((sources[(k * 13 + 5) % sources.len()], 40.0));
        }
        let sim = simulate(
            &g,
            &faults,
            &SimOptions {
                seed: k as u64,
                sample_probabilities: true,
                ..Default::default()
            },
        );
        let mut fast = Diagnoser::new(&g, None);
        let mut full = Diagnoser::new(&g, None);
        full.bound_searches = false;
        for e in &sim.alarms {
            fast.add_alarm(e.alarm, e.time).unwrap();
            full.add_alarm(e.alarm, e.time).unwrap();
            assert_eq!(
                fast.candidates(),
                full.candidates(),
                "fault {f}, alarm {}",
                e.alarm
            );
        }
        fast.advance_to(1e6);
        full.advance_to(1e6);
        let v = fast.global_verdict();
        multiple += usize::from(!v.multiple.is_empty());
        assert_eq!(v, full.global_verdict(), "fault {f}");
    }
    assert!(
        multiple > 0,
        "some scenario needed the multiple-fault search"
    );
}

#[test]
fn eclss_resolution_falls_as_alarms_are_filtered_away() {
    let rows = robosim_report::automation::eclss_resolution(&[30, 15, 5], 1, 2).unwrap();
    let get = |label: &str| {
        &rows
            .iter()
            .find(|r| r.label.starts_with(label))
            .unwrap()
            .resolution
    };
    assert_eq!(get("all").isolation_rate(), 1.0);
    let (g30, g15, g5) = (get("greedy 30"), get("greedy 15"), get("greedy 5"));
    assert!(
        g30.isolation_rate() >= g15.isolation_rate() && g15.isolation_rate() >= g5.isolation_rate()
    );
    assert!(
        g5.isolation_rate() < 1.0 && g5.mean_group > 1.0,
        "5 alarms cannot separate 21 faults"
    );
    // The advisor beats random allocations of the same size on the quantity it optimises.
    assert!(g5.cost(21) <= get("random 5").cost(21));
}
