//! The dataflow kernel: firing modes, demand-driven requests, rewiring a running graph, the
//! tracer and the DOT export; the reconfigurable-controller example.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_automation::kernel::{ActorSpec, Ctx, Drive, Firing, Graph, Reason, Retention, Value};
use robosim_automation::reconfig::{ReconfigOptions, run_reconfig_demo};
use std::sync::{Arc, Mutex};

fn adder(ctx: &mut Ctx<'_>) -> Result<(), String> {
    let s = ctx.input_f64("a").unwrap_or(0.0) + ctx.input_f64("b").unwrap_or(0.0);
    ctx.emit("out", Value::F64(s))
}

#[test]
fn ifall_waits_for_every_input_ifany_fires_on_one() {
    let g = Graph::manual();
    g.set_tracing(true);
    let (a, b, all_out, any_out) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let a = e.add_data("a", Retention::Stream)?;
            let b = e.add_data("b", Retention::Stream)?;
            let all_out = e.add_data("all_out", Retention::Stream)?;
            let any_out = e.add_data("any_out", Retention::Stream)?;
            let all = e.add_actor(
                ActorSpec::new("all", adder)
                    .inputs(&["a", "b"])
                    .outputs(&["out"]),
            )?;
            let any = e.add_actor(
                ActorSpec::new("any", adder)
                    .inputs(&["a", "b"])
                    .outputs(&["out"])
                    .firing(Firing::IfAny),
            )?;
            for x in [all, any] {
                e.connect_in(a, x, "a")?;
                e.connect_in(b, x, "b")?;
            }
            e.connect_out(all, "out", all_out)?;
            e.connect_out(any, "out", any_out)?;
            Ok((a, b, all_out, any_out))
        })
        .unwrap();
    g.write(a, Value::F64(1.0)).unwrap();
    assert_eq!(g.run_manual(100).unwrap(), 1);
    assert_eq!(g.queued(any_out).unwrap(), vec![Value::F64(1.0)]);
    assert!(
        g.queued(all_out).unwrap().is_empty(),
        "ifall must wait for b"
    );
    g.write(b, Value::F64(2.0)).unwrap();
    assert_eq!(g.run_manual(100).unwrap(), 2);
    assert_eq!(g.queued(all_out).unwrap(), vec![Value::F64(3.0)]);
    assert_eq!(
        g.queued(any_out).unwrap(),
        vec![Value::F64(1.0), Value::F64(2.0)]
    );
    let t = g.trace();
    assert_eq!(
        t.iter().map(|r| r.actor.as_str()).collect::<Vec<_>>(),
        ["any", "all", "any"]
    );
    assert_eq!(
        t[1].inputs,
        vec![
            ("a".to_string(), Value::F64(1.0)),
            ("b".to_string(), Value::F64(2.0))
        ]
    );
    assert_eq!(t[1].outputs, vec![("out".to_string(), Value::F64(3.0))]);
    assert!(
        t.iter()
            .all(|r| r.reason == Reason::Data && r.error.is_none())
    );
}

#[test]
fn demand_driven_read_sends_requests_upstream() {
    let g = Graph::manual();
    g.set_tracing(true);
    let counter = Arc::new(Mutex::new(0.0));
    let c2 = counter.clone();
    let (raw, doubled, shown) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let raw = e.add_data("raw", Retention::LastValue)?;
            let doubled = e.add_data("doubled", Retention::Stream)?;
            let shown = e.add_data("shown", Retention::Stream)?;
            let sensor = e.add_actor(
                ActorSpec::new("sensor", move |ctx: &mut Ctx<'_>| {
                    let mut c = c2.lock().map_err(|_| "poisoned")?;
                    *c += 1.0;
                    ctx.emit("out", Value::F64(*c))
                })
                .outputs(&["out"])
                .drive(Drive::Demand),
            )?;
            let double = e.add_actor(
                ActorSpec::new("double", |ctx: &mut Ctx<'_>| {
                    let x = ctx.input_f64("x").ok_or("no x")?;
                    ctx.emit("out", Value::F64(2.0 * x))
                })
                .inputs(&["x"])
                .outputs(&["out"])
                .drive(Drive::Demand),
            )?;
            // A data-driven consumer downstream: the mixed mode.
            let show = e.add_actor(
                ActorSpec::new("show", |ctx: &mut Ctx<'_>| {
                    let x = ctx.input_f64("x").ok_or("no x")?;
                    ctx.emit("out", Value::F64(x + 0.5))
                })
                .inputs(&["x"])
                .outputs(&["out"]),
            )?;
            e.connect_out(sensor, "out", raw)?;
            e.connect_in(raw, double, "x")?;
            e.connect_out(double, "out", doubled)?;
            e.connect_in(doubled, show, "x")?;
            e.connect_out(show, "out", shown)?;
            Ok((raw, doubled, shown))
        })
        .unwrap();
    assert_eq!(
        g.run_manual(100).unwrap(),
        0,
        "nothing is demanded, nothing fires"
    );
    assert_eq!(g.request(doubled).unwrap(), None);
    assert_eq!(g.run_manual(100).unwrap(), 3);
    let t = g.trace();
    assert_eq!(
        t.iter()
            .map(|r| (r.actor.as_str(), r.reason))
            .collect::<Vec<_>>(),
        [
            ("sensor", Reason::Demand),
            ("double", Reason::Demand),
            ("show", Reason::Data)
        ]
    );
    assert_eq!(g.latest(raw).unwrap(), Some(Value::F64(1.0)));
    assert_eq!(g.queued(shown).unwrap(), vec![Value::F64(2.5)]);
    // Reading a node that holds a value sends no request.
    assert_eq!(g.request(raw).unwrap(), Some(Value::F64(1.0)));
    assert_eq!(g.run_manual(100).unwrap(), 0);
    // A second demand on the (now drained) stream runs the chain once more.
    assert!(g.queued(doubled).unwrap().is_empty());
    g.request(doubled).unwrap();
    assert_eq!(g.run_manual(100).unwrap(), 3);
    // `shown` has no reader: it keeps both results.
    assert_eq!(
        g.queued(shown).unwrap(),
        vec![Value::F64(2.5), Value::F64(4.5)]
    );
}

#[test]
fn a_script_reading_an_empty_input_demands_it() {
    let g = Graph::manual();
    g.set_tracing(true);
    let (fast, out) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let fast = e.add_data("fast", Retention::Stream)?;
            let slow = e.add_data("slow", Retention::LastValue)?;
            let out = e.add_data("out", Retention::Stream)?;
            let src = e.add_actor(
                ActorSpec::new("slow_source", |ctx: &mut Ctx<'_>| {
                    ctx.emit("v", Value::F64(10.0))
                })
                .outputs(&["v"])
                .drive(Drive::Demand),
            )?;
            let mix = e.add_actor(
                ActorSpec::new("mix", |ctx: &mut Ctx<'_>| {
                    match (ctx.input_f64("fast"), ctx.input_f64("slow")) {
                        (Some(f), None) => {
                            // The slow input is empty: ask for it and wait for it to arrive.
                            ctx.request("slow").map_err(|e| e.to_string())?;
                            ctx.emit("out", Value::F64(f))
                        }
                        (f, Some(s)) => ctx.emit("out", Value::F64(f.unwrap_or(0.0) + s)),
                        (None, None) => Ok(()),
                    }
                })
                .inputs(&["fast", "slow"])
                .outputs(&["out"])
                .firing(Firing::IfAny),
            )?;
            e.connect_out(src, "v", slow)?;
            e.connect_in(fast, mix, "fast")?;
            e.connect_in(slow, mix, "slow")?;
            e.connect_out(mix, "out", out)?;
            Ok((fast, out))
        })
        .unwrap();
    g.write(fast, Value::F64(1.0)).unwrap();
    assert_eq!(g.run_manual(10).unwrap(), 3);
    let t = g.trace();
    assert_eq!(
        t.iter()
            .map(|r| (r.actor.as_str(), r.reason))
            .collect::<Vec<_>>(),
        [
            ("mix", Reason::Data),
            ("slow_source", Reason::Demand),
            ("mix", Reason::Data)
        ]
    );
    assert_eq!(
        g.queued(out).unwrap(),
        vec![Value::F64(1.0), Value::F64(10.0)]
    );
}

#[test]
fn rewiring_a_running_graph_loses_no_token() {
    let g = Graph::new(2);
    let seen: Arc<Mutex<Vec<(String, i64)>>> = Arc::new(Mutex::new(Vec::new()));
    let consumer = |name: &'static str, seen: Arc<Mutex<Vec<(String, i64)>>>| {
        ActorSpec::new(name, move |ctx: &mut Ctx<'_>| {
            let x = ctx.input_f64("x").ok_or("no x")? as i64;
            seen.lock()
                .map_err(|_| "poisoned")?
                .push((name.to_string(), x));
            std::thread::yield_now();
            Ok(())
        })
        .inputs(&["x"])
    };
    let (q, a) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let q = e.add_data("q", Retention::Stream)?;
            let a = e.add_actor(consumer("A", seen.clone()))?;
            e.connect_in(q, a, "x")?;
            Ok((q, a))
        })
        .unwrap();
    for i in 0..200 {
        g.write(q, Value::F64(i as f64)).unwrap();
        if i == 100 {
            // While A is busy with the queue: add B and move A's reader to it.
            g.edit(|e| -> Result<(), robosim_automation::kernel::KernelError> {
                let b = e.add_actor(consumer("B", seen.clone()))?;
                e.move_input(a, "x", b, "x")?;
                e.remove_actor(a)
            })
            .unwrap();
        }
    }
    g.wait_idle();
    let seen = seen.lock().unwrap().clone();
    let mut values: Vec<i64> = seen.iter().map(|s| s.1).collect();
    values.sort_unstable();
    assert_eq!(
        values,
        (0..200).collect::<Vec<_>>(),
        "every token read exactly once"
    );
    assert!(seen.iter().any(|s| s.0 == "B"));
    assert!(g.errors().is_empty());
}

#[test]
fn tokens_wait_in_a_node_without_reader() {
    let g = Graph::manual();
    let (q, a) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let q = e.add_data("q", Retention::Stream)?;
            let a = e.add_actor(ActorSpec::new("A", |_: &mut Ctx<'_>| Ok(())).inputs(&["x"]))?;
            e.connect_in(q, a, "x")?;
            Ok((q, a))
        })
        .unwrap();
    g.write(q, Value::F64(1.0)).unwrap();
    assert_eq!(g.run_manual(10).unwrap(), 1);
    g.edit(|e| e.disconnect_in(a, "x")).unwrap();
    for i in 2..5 {
        g.write(q, Value::F64(i as f64)).unwrap();
    }
    assert_eq!(g.run_manual(10).unwrap(), 0);
    assert_eq!(
        g.queued(q).unwrap(),
        vec![Value::F64(2.0), Value::F64(3.0), Value::F64(4.0)]
    );
    let b = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let b = e.add_actor(ActorSpec::new("B", |_: &mut Ctx<'_>| Ok(())).inputs(&["x"]))?;
            e.connect_in(q, b, "x")?;
            Ok(b)
        })
        .unwrap();
    assert_eq!(g.run_manual(10).unwrap(), 3);
    assert_eq!(g.fired(b).unwrap(), 3);
    // Typed errors for bad edits.
    assert!(g.edit(|e| e.connect_in(q, b, "nope")).is_err());
    assert!(
        g.edit(|e| e.connect_in(q, b, "x")).is_err(),
        "port already connected"
    );
    assert!(g.edit(|e| e.add_data("q", Retention::Stream)).is_err());
}

#[test]
fn dot_export_shows_live_state() {
    let g = Graph::manual();
    let q = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let q = e.add_data("queue", Retention::Stream)?;
            let a = e.add_actor(
                ActorSpec::new("worker", |_: &mut Ctx<'_>| Ok(()))
                    .inputs(&["x"])
                    .firing(Firing::IfAny),
            )?;
            e.connect_in(q, a, "x")?;
            Ok(q)
        })
        .unwrap();
    g.write(q, Value::F64(7.0)).unwrap();
    let dot = g.to_dot();
    assert!(dot.starts_with("digraph"));
    assert!(
        dot.contains("queue\\nstream, 1 held\\nlast = 7.0000"),
        "{dot}"
    );
    assert!(
        dot.contains("fillcolor=yellow"),
        "the worker is ready: {dot}"
    );
    assert!(dot.contains("ifany, data-driven"));
    assert!(
        dot.contains("x (1)"),
        "one token pending on the edge: {dot}"
    );
}

#[test]
fn checker_reconfigures_p_to_pid_and_the_error_drops() {
    let fixed = run_reconfig_demo(&ReconfigOptions {
        allow_switch: false,
        ..Default::default()
    })
    .unwrap();
    assert_eq!(fixed.switched_at, None);
    // Against gravity P alone keeps an error: m g l sin(q) / Kp is about 0.17 rad here.
    assert!(fixed.rms_error_after > 0.1, "{}", fixed.summary());
    let r = run_reconfig_demo(&ReconfigOptions::default()).unwrap();
    let t = r.switched_at.expect("the Checker switches");
    assert!((1.5..2.5).contains(&t), "switch at {t}");
    assert!(r.rms_error_before > 0.05);
    assert!(r.rms_error_after < 0.01, "{}", r.summary());
    assert_eq!(r.steps, 6000);
    assert!(r.dot_before.contains("\"P\\n") && !r.dot_before.contains("PID"));
    assert!(r.dot_after.contains("PID") && !r.dot_after.contains("\"P\\n"));
    assert!(
        run_reconfig_demo(&ReconfigOptions {
            dt: 0.0,
            ..Default::default()
        })
        .is_err()
    );
}

#[test]
fn the_diagnoser_runs_as_an_actor_of_a_running_graph() {
    use robosim_automation::diag::{FaultGraph, Ilm};
    use robosim_automation::model::{Model, load_model};
    use robosim_automation::sim::{SimOptions, simulate};
    // Leaked: the actor's context holds an ILM session borrowing model and graph for 'static.
    let model: &'static Model = Box::leak(Box::new(load_model("eclss").unwrap()));
    let graph: &'static FaultGraph = Box::leak(Box::new(FaultGraph::new(model)));
    let fault = model.find_failure_mode("bosch_reactor_failure").unwrap();
    let present: Vec<bool> = model
        .alarms
        .iter()
        .map(|a| a.detects.iter().all(|&x| model.failure_modes[x].derived))
        .collect();
    let g = Graph::new(2);
    let (alarms, guess) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let alarms = e.add_data("alarms", Retention::Stream)?;
            let guess = e.add_data("guess", Retention::LastValue)?;
            let manager = e.add_actor(
                ActorSpec::new("diagnostic_manager", move |ctx: &mut Ctx<'_>| {
                    let v = ctx
                        .input("alarm")
                        .and_then(Value::as_vec)
                        .ok_or("no alarm")?
                        .to_vec();
                    let ilm = ctx.context::<Ilm<'static>>().ok_or("context")?;
                    ilm.on_alarm(v[1] as usize, v[0])
                        .map_err(|e| e.to_string())?;
                    ilm.run_to_completion();
                    let fms = ilm
                        .best_guess()
                        .map(|g| g.failure_modes)
                        .unwrap_or_default();
                    ctx.emit("guess", Value::Vec(fms.iter().map(|&f| f as f64).collect()))
                })
                .inputs(&["alarm"])
                .outputs(&["guess"])
                .context(Ilm::new(model, graph, Some(&present))),
            )?;
            e.connect_in(alarms, manager, "alarm")?;
            e.connect_out(manager, "guess", guess)?;
            Ok((alarms, guess))
        })
        .unwrap();
    let sim = simulate(graph, &[(fault, 0.0)], &SimOptions::default());
    for ev in sim.alarms.iter().filter(|ev| present[ev.alarm]) {
        g.write(alarms, Value::Vec(vec![ev.time, ev.alarm as f64]))
            .unwrap();
    }
    g.wait_idle();
    assert!(g.errors().is_empty(), "{:?}", g.errors());
    assert_eq!(
        g.latest(guess).unwrap(),
        Some(Value::Vec(vec![fault as f64]))
    );
}

#[test]
fn a_panicking_script_is_an_error_not_a_dead_worker() {
    let g = Graph::new(1);
    let q = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let q = e.add_data("q", Retention::Stream)?;
            let a = e.add_actor(
                ActorSpec::new("fragile", |ctx: &mut Ctx<'_>| {
                    if ctx.input_f64("x") == Some(0.0) {
                        panic!("division by zero");
                    }
                    Ok(())
                })
                .inputs(&["x"]),
            )?;
            e.connect_in(q, a, "x")?;
            Ok(q)
        })
        .unwrap();
    g.set_tracing(true);
    for x in [1.0, 0.0, 2.0] {
        g.write(q, Value::F64(x)).unwrap();
    }
    g.wait_idle();
    assert_eq!(
        g.trace().len(),
        3,
        "the worker survived and fired the third token"
    );
    assert_eq!(
        g.errors(),
        vec!["fragile: script panicked: division by zero".to_string()]
    );
}

#[test]
fn move_input_hands_over_exactly_the_unread_tokens() {
    let g = Graph::manual();
    g.set_tracing(true);
    let sink = |name: &str| ActorSpec::new(name, |_: &mut Ctx<'_>| Ok(())).inputs(&["x"]);
    let (q, a, b) = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let q = e.add_data("q", Retention::Stream)?;
            let a = e.add_actor(sink("A"))?;
            let b = e.add_actor(sink("B"))?;
            e.connect_in(q, a, "x")?;
            Ok((q, a, b))
        })
        .unwrap();
    for i in 0..5 {
        g.write(q, Value::F64(i as f64)).unwrap();
    }
    assert!(g.step().unwrap().is_some());
    assert!(g.step().unwrap().is_some());
    assert_eq!(
        g.queued(q).unwrap().len(),
        3,
        "read tokens are dropped, unread ones held"
    );
    g.edit(|e| e.move_input(a, "x", b, "x")).unwrap();
    assert_eq!(g.run_manual(10).unwrap(), 3);
    let got: Vec<(String, Value)> = g
        .trace()
        .into_iter()
        .map(|r| (r.actor, r.inputs[0].1.clone()))
        .collect();
    let want: Vec<(String, Value)> = [("A", 0.0), ("A", 1.0), ("B", 2.0), ("B", 3.0), ("B", 4.0)]
        .iter()
        .map(|(n, v)| (n.to_string(), Value::F64(*v)))
        .collect();
    assert_eq!(got, want);
}

#[test]
fn actors_run_only_on_their_worker_pool() {
    let g = Graph::with_pools(&[("control", 1), ("supervision", 2)]);
    g.set_tracing(true);
    let q = g
        .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
            let q = e.add_data("q", Retention::Stream)?;
            let fast =
                e.add_actor(ActorSpec::new("loop", |_: &mut Ctx<'_>| Ok(())).inputs(&["x"]))?;
            let slow = e.add_actor(
                ActorSpec::new("watch", |_: &mut Ctx<'_>| Ok(()))
                    .inputs(&["x"])
                    .pool("supervision"),
            )?;
            e.connect_in(q, fast, "x")?;
            e.connect_in(q, slow, "x")?;
            Ok(q)
        })
        .unwrap();
    for i in 0..300 {
        g.write(q, Value::F64(i as f64)).unwrap();
    }
    g.wait_idle();
    let t = g.trace();
    assert_eq!(t.len(), 600);
    // Worker 0 is the control pool's thread; workers 1 and 2 belong to supervision.
    assert!(
        t.iter()
            .filter(|r| r.actor == "loop")
            .all(|r| r.worker == 0)
    );
    assert!(
        t.iter()
            .filter(|r| r.actor == "watch")
            .all(|r| r.worker == 1 || r.worker == 2)
    );
    assert!(g.to_dot().contains("pool supervision"));
    let err = g
        .edit(|e| e.add_actor(ActorSpec::new("x", |_: &mut Ctx<'_>| Ok(())).pool("gpu")))
        .unwrap_err();
    assert_eq!(err.to_string(), "no worker pool named `gpu`");
}
