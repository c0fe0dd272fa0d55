//! The ORU swap planned by rules (issue 38 item 5, `studies/src/station/oru_plan.rs`,
//! `oru_swap.clp`): the swap only after the fault and its diagnosis, its steps in order with
//! their reasons, the failed ORU's loss ending at the bolt, the power scheduler's forecast
//! carrying the parked window before the park, and a blocked step refused, replanned, and
//! reported — never passed over. Skipped loudly without CLIPS (they fail in CI, which has it).

use robosim_simulator::swap::SwapStep;
use robosim_studies::station::oru_plan::{self, Obstacle};
use robosim_studies::station::scheduler::{Decision, PlanFacts, Scheduler, Scheduling};
use robosim_studies::station::{self, Held, Run, StationParams, loads};

fn oru_station(fault_s: f64) -> StationParams {
    StationParams {
        step_s: 30.0,
        orbits: 0.8,
        frames: 0,
        compare_off: false,
        scheduling: Scheduling::Off,
        fault: Some(
            station::faults::FaultSpec::parse(&format!("array_oru@{fault_s}")).expect("spec"),
        ),
        ..StationParams::default()
    }
}

fn oru_decisions(run: &Run) -> Vec<&Decision> {
    run.decisions
        .iter()
        .filter(|d| d.rule.starts_with("oru_swap "))
        .collect()
}

fn first<'a>(run: &'a Run, rule: &str) -> &'a Decision {
    run.decisions
        .iter()
        .find(|d| d.rule == rule)
        .unwrap_or_else(|| panic!("no {rule}: {:#?}", oru_decisions(run)))
}

#[test]
fn the_swap_starts_only_after_the_diagnosed_fault_and_its_steps_fire_in_order_with_reasons() {
    if robosim_rules::skipped_without_clips("the_swap_starts_only_after_the_diagnosed_fault") {
        return;
    }
    let p = oru_station(900.0);
    let s = station::setup(&p).expect("setup");
    let run = station::simulate(&s, &p).expect("runs");
    let r = run.swap.as_ref().expect("the planned swap");
    let q0 = &s.oru.swap.servicer_q0;
    // nothing moves before the rules diagnose the fault and the swap's start
    let diag = first(&run, "oru_swap oru-diagnose");
    assert!(diag.t > 900.0 && diag.target == r.array, "{diag:?}");
    assert!(diag.reason.contains("expects"), "{diag:?}");
    let plan = first(&run, "oru_swap oru-plan-swap");
    assert!(plan.t >= diag.t, "{plan:?}");
    let start = r.start_s.expect("scheduled");
    for st in &run.steps {
        if st.t <= start {
            assert_eq!(&st.servicer_q, q0, "the servicer moved at {} s", st.t);
            assert!(!st.oru.parked, "parked at {} s", st.t);
        }
    }
    // the steps: every one of the swap, in order, each asked for by its rule with a reason
    let done: Vec<SwapStep> = r.steps.iter().map(|x| x.0).collect();
    assert_eq!(done, SwapStep::ALL.to_vec(), "{:#?}", oru_decisions(&run));
    for w in r.steps.windows(2) {
        assert!(w[0].3 <= w[1].2, "{:?} ends after {:?} starts", w[0], w[1]);
    }
    let mut last = 0.0;
    for st in SwapStep::ALL {
        let rule = format!("oru_swap oru-{}", st.name());
        let d = first(&run, &rule);
        assert!(d.action.starts_with("do "), "{d:?}");
        assert!(d.reason.len() > 20, "{d:?}");
        assert!(d.t >= last, "{rule} at {} s before the step before it", d.t);
        last = d.t;
    }
    let done = first(&run, "oru_swap oru-done");
    assert!(done.t >= last, "{done:?}");
    // the geometry did it: the spare bolted, the failed unit stowed, the array tracking
    let end = run.steps.last().expect("steps");
    assert_eq!(end.oru.spare, Held::OnArray);
    assert!(matches!(end.oru.failed, Held::Fixed(_)));
    assert!(!end.oru.parked);
    // the failed ORU's loss: from the fault until the bolt, none after
    let bolted = r.bolted_s.expect("bolted");
    assert!(r.lost_j > 0.0);
    for &(t, w) in &r.loss_w {
        let sunlit = run
            .steps
            .iter()
            .find(|st| st.t == t)
            .is_some_and(|st| !st.eclipse);
        if t < 900.0 || t >= bolted {
            assert!(
                w == 0.0,
                "{w} W lost at {t} s (fault 900 s, bolted {bolted} s)"
            );
        } else if sunlit {
            assert!(w > 0.0, "no loss at {t} s while the ORU is failed");
        }
    }
}

#[test]
fn without_the_fault_the_planner_moves_nothing() {
    if robosim_rules::skipped_without_clips("without_the_fault_the_planner_moves_nothing") {
        return;
    }
    // a fault after the run's end: the rules watch, nothing is diagnosed, nothing moves
    let p = StationParams {
        orbits: 0.3,
        ..oru_station(1e6)
    };
    let s = station::setup(&p).expect("setup");
    let run = station::simulate(&s, &p).expect("runs");
    let r = run.swap.as_ref().expect("the planner ran");
    assert!(r.diagnosed_s.is_none() && r.steps.is_empty(), "{r:?}");
    assert!(
        run.steps
            .iter()
            .all(|st| st.servicer_q == s.oru.swap.servicer_q0)
    );
    assert_eq!(r.lost_j, 0.0);
}

#[test]
fn the_power_scheduler_forecast_carries_the_parked_window_before_the_park() {
    if robosim_rules::skipped_without_clips("the_power_scheduler_forecast_carries") {
        return;
    }
    let p = StationParams {
        scheduling: Scheduling::On,
        ..oru_station(300.0)
    };
    let s = station::setup(&p).expect("setup");
    let run = station::simulate(&s, &p).expect("runs");
    let r = run.swap.as_ref().expect("the planned swap");
    let parked = r
        .steps
        .iter()
        .find(|x| x.0 == SwapStep::Park)
        .map(|x| x.2)
        .expect("parked");
    let scheduled = r.scheduled_s.expect("scheduled");
    let ahead: Vec<_> = r
        .forecast_windows
        .iter()
        .filter(|x| x.0 >= scheduled && x.0 < parked)
        .collect();
    assert!(!ahead.is_empty());
    for (t, w, taken) in &ahead {
        let (a, b) = w.unwrap_or_else(|| panic!("no parked window in the forecast at {t} s"));
        // predicted ahead of the park, within a few steps of when it came
        assert!(
            a > *t && (a - parked).abs() <= 4.0 * p.step_s,
            "{a} vs {parked} at {t}"
        );
        assert!(b > a);
        assert!(*taken > 0.0, "the window takes no energy at {t} s");
    }
    // none before the swap was scheduled
    assert!(
        r.forecast_windows
            .iter()
            .filter(|x| x.0 < scheduled)
            .all(|x| x.1.is_none())
    );
}

/// station_power.clp with the forecast the planner gives it: at a battery level where the
/// plain forecast keeps everything on, the parked window coming (a loss it has not yet caused)
/// makes it shed before the park starts.
#[test]
fn the_scheduler_sheds_ahead_of_the_parked_window() {
    if robosim_rules::skipped_without_clips("the_scheduler_sheds_ahead_of_the_parked_window") {
        return;
    }
    let period = 5554.0;
    let eclipses = [[1716.0, 3840.0], [1716.0 + period, 3840.0 + period]];
    let t = 0.0;
    let plain = loads::Forecast::new(t, period, &eclipses, 200e3);
    // the window opens 20 min from now, over the sunlit arc before the eclipse
    let window = (1200.0, 1716.0);
    let (parked, taken) = oru_plan::park_in(plain.clone(), window, |_| 60e3);
    assert!((taken - 60e3 * 516.0).abs() < 1.0, "{taken}");
    assert!(
        parked.phases.iter().any(|x| x.1 == 1200.0 && x.3 == 140e3),
        "{:?}",
        parked.phases
    );
    let capacity = 150.0 * 3.6e6;
    let sheds = |f: &loads::Forecast, energy: f64| {
        let mut l = loads::Loads::new(
            robosim_simulator::consumers::default_consumers(100e3),
            Vec::new(),
        );
        let mut sch = Scheduler::new(Scheduling::On, None).expect("scheduler");
        sch.step(
            &PlanFacts {
                t,
                step_s: 10.0,
                energy_j: energy,
                capacity_j: capacity,
                charge_eff: 0.9,
                discharge_eff: 0.9,
                reserve_j: 0.25 * capacity,
                margin_j: 0.05 * capacity,
                forecast: f,
                windows: &[],
            },
            &mut l,
        )
        .expect("step");
        sch.decisions()
            .into_iter()
            .filter(|d| d.action == "off" || d.action == "reduced")
            .count()
    };
    // the lowest store at which the plain forecast sheds nothing (to 0.1 kWh)
    let (mut lo, mut hi) = (0.0, capacity);
    assert_eq!(sheds(&plain, hi), 0, "sheds even when full");
    while hi - lo > 0.1 * 3.6e6 {
        let m = 0.5 * (lo + hi);
        if sheds(&plain, m) == 0 {
            hi = m
        } else {
            lo = m
        }
    }
    assert_eq!(sheds(&plain, hi), 0);
    assert!(
        sheds(&parked, hi) > 0,
        "with the parked window coming it does not shed at {:.1} kWh",
        hi / 3.6e6
    );
}

#[test]
fn a_blocked_step_is_refused_replanned_and_reported_not_passed_over() {
    if robosim_rules::skipped_without_clips("a_blocked_step_is_refused") {
        return;
    }
    let base = oru_station(300.0);
    let s = station::setup(&base).expect("setup");
    let [_, _, stow] = s.oru.swap.sites();
    let alt =
        s.oru.swap.spare.translation.vector + nalgebra::Vector3::from(oru_plan::ALT_STOW_OFFSET);
    let unit = |p: nalgebra::Point3<f64>| Obstacle {
        at: nalgebra::Isometry3::translation(p.x, p.y, p.z),
        from_s: 0.0,
        until_s: f64::INFINITY,
    };
    // the stowage site occupied: the rules stow the failed ORU at the alternate site
    let p = StationParams {
        oru_obstacles: vec![unit(stow)],
        ..base.clone()
    };
    let run = station::simulate(&s, &p).expect("runs");
    let r = run.swap.as_ref().expect("the planned swap");
    let refused = first(&run, "oru_swap oru-set-down");
    assert_eq!(refused.action, "refused", "{refused:?}");
    assert!(refused.reason.contains("obstacle"), "{refused:?}");
    let replan = first(&run, "oru_swap oru-replan-stow");
    assert!(replan.t >= refused.t);
    assert!(r.bolted_s.is_some(), "{:#?}", oru_decisions(&run));
    let end = run.steps.last().expect("steps");
    let Held::Fixed(w) = end.oru.failed else {
        panic!("the failed ORU is not set down: {:?}", end.oru.failed)
    };
    assert!(
        (w.translation.vector - alt).norm() < 0.05,
        "{w:?} vs {alt:?}"
    );
    // both sites occupied: refused, retried, then halted and reported — no later step runs
    let p = StationParams {
        oru_obstacles: vec![unit(stow), unit(nalgebra::Point3::from(alt))],
        orbits: 1.0,
        ..base
    };
    let run = station::simulate(&s, &p).expect("runs");
    let r = run.swap.as_ref().expect("the planned swap");
    let halted = first(&run, "oru_swap oru-report-blocked");
    assert_eq!(halted.target, "set-down");
    assert!(halted.reason.contains("halted"), "{halted:?}");
    assert!(run.decisions.iter().any(|d| d.rule == "oru_swap oru-retry"));
    assert!(r.refused.len() >= 3, "{:?}", r.refused);
    let done: Vec<SwapStep> = r.steps.iter().map(|x| x.0).collect();
    assert!(
        !done.contains(&SwapStep::SetDown) && !done.contains(&SwapStep::TakeSpare),
        "{done:?}"
    );
    assert!(r.bolted_s.is_none() && r.halted_s.is_some());
    // still holding the failed unit where it was refused; the loss not ended
    let end = run.steps.last().expect("steps");
    assert!(
        matches!(end.oru.failed, Held::Carried(_)),
        "{:?}",
        end.oru.failed
    );
    assert!(r.loss_w.iter().rev().take(5).any(|x| x.1 > 0.0) || end.eclipse);
    let summary = station::summarise(&s, &p, &run);
    assert!(
        summary.notes.iter().any(|n| n.contains("halted")),
        "{:?}",
        summary.notes
    );
}
