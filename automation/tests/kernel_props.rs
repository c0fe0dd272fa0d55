//! Property: whatever the interleaving of writes, firings and rewiring (moving the reader,
//! disconnecting it, connecting a new one), every token written to a stream node is consumed
//! exactly once and in order.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use proptest::prelude::*;
use robosim_automation::kernel::{ActorId, ActorSpec, Ctx, Graph, Retention, Value};
use std::sync::{Arc, Mutex};

#[derive(Debug, Clone)]
enum Op {
    Write,
    Step,
    Move,
    Disconnect,
    Reconnect,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        4 => Just(Op::Write),
        4 => Just(Op::Step),
        1 => Just(Op::Move),
        1 => Just(Op::Disconnect),
        1 => Just(Op::Reconnect),
    ]
}

// A fixed seed: the same cases on every run, so CI never meets a new random case (a random
// run failed CI once on a pose numeric IK cannot reach, core/kinematics/tests/properties.rs).
// Look for more by changing the seed or the case count.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 200,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0xA0_2026),
        ..ProptestConfig::default()
    })]
    #[test]
    fn stream_tokens_are_consumed_exactly_once_in_order(ops in proptest::collection::vec(op(), 1..80)) {
        let g = Graph::manual();
        let seen = Arc::new(Mutex::new(Vec::<i64>::new()));
        let sink = |name: &str, seen: Arc<Mutex<Vec<i64>>>| {
            ActorSpec::new(name, move |ctx: &mut Ctx<'_>| {
                let x = ctx.input_f64("x").ok_or("no token")? as i64;
                seen.lock().map_err(|_| "poisoned")?.push(x);
                Ok(())
            })
            .inputs(&["x"])
        };
        let (q, a, b) = g
            .edit(|e| -> Result<_, robosim_automation::kernel::KernelError> {
                let q = e.add_data("q", Retention::Stream)?;
                let a = e.add_actor(sink("A", seen.clone()))?;
                let b = e.add_actor(sink("B", seen.clone()))?;
                e.connect_in(q, a, "x")?;
                Ok((q, a, b))
            })
            .unwrap();
        // Which actor reads q now (None: nobody).
        let mut reader: Option<ActorId> = Some(a);
        let other = |r: ActorId| if r == a { b } else { a };
        let mut last_reader = a;
        let mut written = 0i64;
        for o in ops {
            match o {
                Op::Write => {
                    g.write(q, Value::F64(written as f64)).unwrap();
                    written += 1;
                }
                Op::Step => {
                    g.step().unwrap();
                }
                Op::Move => {
                    if let Some(r) = reader {
                        let to = other(r);
                        g.edit(|e| e.move_input(r, "x", to, "x")).unwrap();
                        reader = Some(to);
                        last_reader = to;
                    }
                }
                Op::Disconnect => {
                    if let Some(r) = reader {
                        g.edit(|e| e.disconnect_in(r, "x")).unwrap();
                        reader = None;
                    }
                }
                Op::Reconnect => {
                    if reader.is_none() {
                        let to = other(last_reader);
                        g.edit(|e| e.connect_in(q, to, "x")).unwrap();
                        reader = Some(to);
                        last_reader = to;
                    }
                }
            }
        }
        if reader.is_none() {
            g.edit(|e| e.connect_in(q, a, "x")).unwrap();
        }
        g.run_manual(10_000).unwrap();
        let seen = seen.lock().unwrap().clone();
        prop_assert_eq!(seen, (0..written).collect::<Vec<_>>());
        prop_assert!(g.queued(q).unwrap().is_empty());
        prop_assert!(g.errors().is_empty());
    }
}
