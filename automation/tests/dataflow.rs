//! Dataflow graphs from files: the parser's errors (file:line, what), the built-in actors
//! against closed forms, ifall/ifany, demand-driven sampling, live reconfiguration keeping the
//! state of unchanged actors, and the shipped graphs.
#![allow(
    clippy::unwrap_used,
    reason = "a test unwraps: failing there is the test failing"
)]
use robosim_automation::dataflow::{
    LiveGraph, PassError, SinkAddr, SourceAddr, kinds, load_graph, parse_graph,
};
use std::path::Path;

fn live(text: &str) -> LiveGraph {
    LiveGraph::build(parse_graph(text, "test.flow").unwrap()).unwrap()
}

fn sink(g: &mut LiveGraph, sources: &[(&str, f64)], node: &str) -> Option<f64> {
    let out = g.pass(sources).unwrap();
    out.iter()
        .find(|s| s.sink.node == node)
        .and_then(|s| s.value)
}

const SERVO: &str = "\
rate 10
source q = joint arm 2
source ref = pose marker x
data e
data u
data q_next
actor err = sub(ref, q) -> e
actor ctl = pd(e) -> u kp=2 kd=0.5
actor step = add(q, u) -> q_next
sink q_next -> joint arm 2
";

#[test]
fn a_graph_file_declares_sources_actors_and_sinks() {
    let g = parse_graph(SERVO, "servo.flow").unwrap();
    assert_eq!(g.rate_hz, Some(10.0));
    assert_eq!(
        g.sources[0].addr,
        SourceAddr::Joint {
            robot: "arm".into(),
            index: 2
        }
    );
    assert_eq!(g.actors.len(), 3);
    // dt comes from the rate line when the actor does not give it.
    assert_eq!(g.actors[1].params["dt"], 0.1);
    assert_eq!(g.actors[1].params["kp"], 2.0);
    assert_eq!(
        g.sinks[0].addr,
        SinkAddr::Joint {
            robot: "arm".into(),
            index: 2
        }
    );
}

#[test]
fn the_pd_servo_computes_its_closed_form() {
    let mut g = live(SERVO);
    // e = 1 - 0.25 = 0.75; first sample: de/dt = 0; q_next = q + kp e.
    assert_eq!(
        sink(&mut g, &[("q", 0.25), ("ref", 1.0)], "q_next"),
        Some(0.25 + 1.5)
    );
    // e = 0.5: u = 2*0.5 + 0.5*(0.5-0.75)/0.1 = 1 - 1.25 = -0.25.
    let v = sink(&mut g, &[("q", 0.5), ("ref", 1.0)], "q_next").unwrap();
    assert!((v - (0.5 - 0.25)).abs() < 1e-12, "{v}");
}

#[test]
fn parse_errors_name_the_file_the_line_and_what() {
    let cases: &[(&str, usize, &str)] = &[
        ("source q = joint arm two\n", 1, "joint index"),
        (
            "\n\nactor a = nope(x) -> y\n",
            3,
            "unknown actor kind `nope`",
        ),
        (
            "source x = const 1\ndata y\nactor a = add(x) -> y\n",
            3,
            "takes 2 input(s)",
        ),
        (
            "source x = const 1\nactor a = gain(x) -> y k=2\n",
            2,
            "writes `y`, which no `data` line declares",
        ),
        ("data y\nactor a = gain(x) -> y k=2\n", 2, "reads `x`"),
        (
            "source x = const 1\ndata y\nactor a = gain(x) -> y\n",
            3,
            "needs the parameter k=",
        ),
        (
            "source x = const 1\ndata y\nactor a = gain(x) -> y k=2 q=1\n",
            3,
            "no parameter `q`",
        ),
        (
            "source x = const 1\ndata y\nactor a = lowpass(x) -> y tau=1\n",
            3,
            "needs dt=",
        ),
        (
            "source x = const 1\ndata y\nactor a = gain(x) -> y k=2\nactor b = gain(x) -> y k=3\n",
            4,
            "already writes",
        ),
        (
            "source x = const 1\nsource x = const 2\n",
            2,
            "already declared",
        ),
        (
            "source x = const 1\ndata y\nsink y -> joint arm 0\n",
            3,
            "no actor writes",
        ),
        ("rate -3\n", 1, "positive"),
        (
            "source x = const 1\ndata y\nactor a = gain(x) -> y k=2\nrate 5\n",
            4,
            "before the actors",
        ),
        ("frobnicate\n", 1, "unknown declaration"),
        ("source x = pose obj w\n", 1, "expected x, y or z"),
        (
            "source x = const 1\ndata y\nactor a = threshold(x) -> y\n",
            3,
            "above= or below=",
        ),
        (
            "source x = const 1\ndata y\nactor a = clamp(x) -> y lo=2 hi=1\n",
            3,
            "above hi",
        ),
        ("source x = const inf\n", 1, "finite"),
        ("data y $\n", 1, "unexpected character"),
    ];
    for (text, line, what) in cases {
        let e = parse_graph(text, "g.flow").unwrap_err();
        assert_eq!(e.file, "g.flow");
        assert_eq!(e.line, *line, "{text:?}: {e}");
        assert!(e.message.contains(what), "{text:?}: {e}");
        assert!(
            e.to_string().starts_with(&format!("g.flow:{line}: ")),
            "{e}"
        );
    }
}

#[test]
fn a_missing_file_is_an_error_naming_it() {
    let e = load_graph(Path::new("/nonexistent/graph.flow")).unwrap_err();
    assert_eq!(e.line, 0);
    assert!(e.to_string().contains("/nonexistent/graph.flow"), "{e}");
}

#[test]
fn the_lowpass_step_response_is_the_backward_euler_closed_form() {
    let mut g = live(
        "source x = const 0\ndata y\nactor f = lowpass(x) -> y tau=0.5 dt=0.1\nsink y -> alarm y\n",
    );
    // The first sample sets y = x = 0; then a unit step: y_n = 1 - (tau/(tau+dt))^n.
    assert_eq!(sink(&mut g, &[("x", 0.0)], "y"), Some(0.0));
    let r: f64 = 0.5 / 0.6;
    for n in 1..=20 {
        let y = sink(&mut g, &[("x", 1.0)], "y").unwrap();
        assert!((y - (1.0 - r.powi(n))).abs() < 1e-12, "n {n}: {y}");
    }
}

#[test]
fn the_integrator_pid_and_threshold_behave() {
    let mut g = live(
        "rate 4\nsource x = const 0\ndata i\ndata u\ndata a\n\
         actor int = integrator(x) -> i k=2 y0=1\n\
         actor ctl = pid(x) -> u kp=1 ki=1 lo=-2 hi=2\n\
         actor al = threshold(x) -> a above=1 hysteresis=0.5\n\
         sink i -> alarm i\nsink u -> alarm u\nsink a -> alarm a\n",
    );
    let step = |g: &mut LiveGraph, x: f64| {
        let out = g.pass(&[("x", x)]).unwrap();
        let v = |n: &str| {
            out.iter()
                .find(|s| s.sink.node == n)
                .and_then(|s| s.value)
                .unwrap()
        };
        (v("i"), v("u"), v("a"))
    };
    // integrator: 1 + 2*1*0.25 = 1.5; pid: 1 + 0.25 = 1.25; threshold: 1 > 1 is false.
    assert_eq!(step(&mut g, 1.0), (1.5, 1.25, 0.0));
    // x = 3: integral 3 + 2*3*0.25 = 3; pid raw = 3 + (0.25+0.75) = 4 > hi: held at 2, the
    // integral does not move (anti-windup); the alarm rings.
    assert_eq!(step(&mut g, 3.0), (3.0, 2.0, 1.0));
    // x = 0.7: inside the bound but not by the hysteresis: still ringing; pid = 0.7 + 0.25 + 0.175.
    let (_, u, a) = step(&mut g, 0.7);
    assert!((u - (0.7 + 0.25 + 0.175)).abs() < 1e-12, "{u}");
    assert_eq!(a, 1.0);
    // x = 0.4: back by more than the hysteresis: cleared.
    assert_eq!(step(&mut g, 0.4).2, 0.0);
}

#[test]
fn ifall_waits_for_every_input_ifany_fires_on_one() {
    let mut g = live(
        "source a = const 0\nsource b = const 0\ndata all\ndata any\n\
         actor sum_all = add(a, b) -> all\nactor sum_any = add(a, b) -> any ifany\n\
         sink all -> alarm all\nsink any -> alarm any\n",
    );
    // Only `a` gets a token (b never had a value): neither can compute (b is unknown).
    g.pass(&[("a", 1.0)]).unwrap();
    assert_eq!(g.fired("sum_all"), Some(0));
    // Both: both fire.
    g.pass(&[("a", 1.0), ("b", 2.0)]).unwrap();
    assert_eq!(g.value("all"), Some(3.0));
    assert_eq!(g.value("any"), Some(3.0));
    // Only `a` again: ifany fires with b's last value, ifall waits.
    g.pass(&[("a", 5.0)]).unwrap();
    assert_eq!(g.value("any"), Some(7.0));
    assert_eq!(g.value("all"), Some(3.0));
    assert_eq!(g.fired("sum_all"), Some(1));
}

#[test]
fn demand_driven_actors_fire_only_for_the_sinks() {
    let mut g = live(
        "source x = const 0\ndata used\ndata unused\n\
         actor a = gain(x) -> used k=2 demand\nactor b = gain(x) -> unused k=3 demand\n\
         sink used -> alarm used\n",
    );
    for k in 1..=3 {
        g.pass(&[("x", f64::from(k))]).unwrap();
        assert_eq!(g.value("used"), Some(2.0 * f64::from(k)));
    }
    // `a` answered each pass's demand once; nothing asked for `b`'s output.
    assert_eq!(g.fired("a"), Some(3));
    assert_eq!(g.fired("b"), Some(0));
    assert_eq!(g.value("unused"), None);
}

#[test]
fn a_loop_that_feeds_itself_is_reported_not_run_forever() {
    // Every built-in kind needs a value on each input, so a loop cannot start from nothing;
    // rewired onto a node that already holds one, it can.
    let mut g = live("source x = const 1\ndata y\nactor a = gain(x) -> y k=1\nsink y -> alarm y\n");
    g.pass(&[("x", 1.0)]).unwrap();
    g.reconfigure(
        parse_graph(
            "source x = const 1\ndata y\nactor a = add(x, y) -> y ifany\nsink y -> alarm y\n",
            "t.flow",
        )
        .unwrap(),
    )
    .unwrap();
    assert!(matches!(g.pass(&[("x", 1.0)]), Err(PassError::Runaway(_))));
}

#[test]
fn reconfiguring_keeps_the_state_of_unchanged_actors() {
    let before = "rate 1\nsource x = const 0\ndata i\ndata y\n\
                  actor int = integrator(x) -> i\nactor out = gain(i) -> y k=1\n\
                  sink y -> alarm y\n";
    let mut g = live(before);
    for _ in 0..3 {
        g.pass(&[("x", 1.0)]).unwrap();
    }
    assert_eq!(g.value("y"), Some(3.0));
    // The gain changes, a low-pass is added, the integrator is the same line moved down.
    let after = "rate 1\nsource x = const 0\ndata i\ndata y\ndata f\n\n\
                 actor out = gain(i) -> y k=10\n\
                 actor int = integrator(x) -> i\n\
                 actor filt = lowpass(i) -> f tau=1\n\
                 sink y -> alarm y\nsink f -> alarm f\n";
    let r = g
        .reconfigure(parse_graph(after, "test.flow").unwrap())
        .unwrap();
    assert_eq!(r.kept, vec!["int".to_string()]);
    assert_eq!(r.replaced, vec!["out".to_string()]);
    assert_eq!(r.added, vec!["filt".to_string()]);
    g.pass(&[("x", 1.0)]).unwrap();
    // The integrator went on from 3 (not from 0): 4, times the new gain.
    assert_eq!(g.value("i"), Some(4.0));
    assert_eq!(g.value("y"), Some(40.0));
    // A new actor reads only what is written after it came: the filter's first sample is 4.
    assert_eq!(g.value("f"), Some(4.0));
    assert_eq!(g.fired("filt"), Some(1));
    // The replacing gain continued from where the old one stopped: it fired once, on the new
    // value of `i`, not on the stale 3 as well.
    assert_eq!(g.fired("out"), Some(1));
    assert_eq!(g.fired("int"), Some(4));
    // Removing an actor and its node.
    let smaller =
        "rate 1\nsource x = const 0\ndata i\nactor int = integrator(x) -> i\nsink i -> alarm i\n";
    let r = g
        .reconfigure(parse_graph(smaller, "test.flow").unwrap())
        .unwrap();
    assert_eq!(r.removed, vec!["out".to_string(), "filt".to_string()]);
    g.pass(&[("x", 1.0)]).unwrap();
    assert_eq!(g.value("i"), Some(5.0));
    assert_eq!(g.value("y"), None);
}

#[test]
fn a_changed_retention_recreates_the_node_and_rewires_its_readers() {
    let mut g = live("source x = const 0\ndata y\nactor a = gain(x) -> y k=2\nsink y -> alarm y\n");
    g.pass(&[("x", 1.0)]).unwrap();
    let r = g
        .reconfigure(
            parse_graph(
                "source x = const 0\ndata y stream\nactor a = gain(x) -> y k=2\nsink y -> alarm y\n",
                "t.flow",
            )
            .unwrap(),
        )
        .unwrap();
    assert_eq!(r.replaced, vec!["a".to_string()]);
    g.pass(&[("x", 4.0)]).unwrap();
    assert_eq!(g.value("y"), Some(8.0));
}

#[test]
fn the_shipped_graphs_parse_and_compute() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs");
    let servo = load_graph(&dir.join("carriage_servo.flow")).unwrap();
    let mut g = LiveGraph::build(servo).unwrap();
    // The spare ORU at y = 14 m: set-point 39 m on the rail; the carriage at 20 m moves
    // 0.1 m per pass (the limit), never beyond the rail's end.
    let out = g.pass(&[("target", 14.0), ("q", 20.0)]).unwrap();
    assert!((out[0].value.unwrap() - 20.1).abs() < 1e-12);
    let out = g.pass(&[("target", 40.0), ("q", 49.95)]).unwrap();
    assert_eq!(out[0].value, Some(50.0));
    let energy = load_graph(&dir.join("energy_predictor.flow")).unwrap();
    let mut g = LiveGraph::build(energy).unwrap();
    // 100 kW short for an orbit: 154 kWh; from 150 kWh of 150: predicted below zero: alarm.
    let src = [
        ("power", 0.0),
        ("load", 1e5),
        ("battery", 150.0),
        ("capacity", 150.0),
    ];
    let out = g.pass(&src).unwrap();
    assert_eq!(out[0].value, Some(1.0));
    assert!((g.value("predicted").unwrap() - (150.0 - 154.33)).abs() < 1e-9);
    // Surplus: cleared once the (smoothed) prediction is back above 35 %.
    let mut cleared = false;
    for _ in 0..20_000 {
        g.pass(&[
            ("power", 2e5),
            ("load", 1e5),
            ("battery", 60.0),
            ("capacity", 150.0),
        ])
        .unwrap();
        if g.value("low") == Some(0.0) {
            cleared = true;
            assert!(g.value("fraction").unwrap() > 0.35);
            break;
        }
    }
    assert!(cleared);
}

#[test]
fn every_kind_is_documented_with_ports() {
    for k in kinds() {
        assert!(
            !k.inputs.is_empty() && !k.outputs.is_empty() && !k.doc.is_empty(),
            "{}",
            k.name
        );
    }
}
