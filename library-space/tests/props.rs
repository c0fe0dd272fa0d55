//! Property tests: random parameters in range give valid robots with closed solids; the
//! language never panics on malformed input and always locates its errors inside the text.

use proptest::prelude::*;
use robosim_library::{Evaluated, Library, Params};

fn std_lib() -> &'static Library {
    robosim_library::standard_library().expect("standard library loads")
}

const WORDS: &[&str] = &[
    "solid",
    "link",
    "robot",
    "scene",
    "colour",
    "surface",
    "let",
    "part",
    "place",
    "include",
    "at",
    "for",
    "in",
    "q",
    "box",
    "cylinder",
    "sphere",
    "revolve",
    "extrude",
    "range",
    "translate",
    "rotate_z",
    "rgb",
    "a",
    "b",
    "x",
    "joint",
    "revolute",
    "limits",
    "mass",
    "effects",
    "collision",
    "mode",
    "on",
    "1",
    "0",
    "2.5",
    "1e-3",
    "m",
    "mm",
    "deg",
    "kg",
    "(",
    ")",
    "{",
    "}",
    "[",
    "]",
    ",",
    ":",
    "=",
    "+",
    "-",
    "*",
    "/",
    "^",
    ";",
    "\"std\"",
    "\n",
    "//c\n",
    "×",
];

// A fixed seed: the same cases on every run, so CI never meets a new random case (a random
// run failed CI once on a pose numeric IK cannot reach, core/kinematics/tests/properties.rs).
// Look for more by changing the seed or the case count.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 400,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x11B_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn malformed_text_is_an_error_located_in_the_text_never_a_panic(words in prop::collection::vec(0..WORDS.len(), 0..40)) {
        let text: String = words.iter().map(|&k| WORDS[k]).collect::<Vec<_>>().join(" ");
        if let Err(e) = Library::from_source("fuzz.rsl", &text) {
            let lines = text.split('\n').count();
            prop_assert!(e.location.line >= 1 && e.location.column >= 1, "{e}");
            if e.location.file == "fuzz.rsl" {
                prop_assert!(e.location.line <= lines, "line {} of {lines}: {e}", e.location.line);
            }
            prop_assert!(!e.message.is_empty());
            let pos = format!("{}:{}:{}", e.location.file, e.location.line, e.location.column);
            prop_assert!(e.to_string().contains(&pos));
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(text in "\\PC{0,80}") {
        let _ = Library::from_source("fuzz.rsl", &text);
    }
}

#[test]
fn deeply_nested_input_is_refused_not_a_stack_overflow() {
    for text in [
        format!("let x = {}1{}", "(".repeat(5000), ")".repeat(5000)),
        format!("let x = {}1", "-".repeat(5000)),
        format!("let x = {}", "[".repeat(5000)),
    ] {
        let e = Library::from_source("deep.rsl", &text).expect_err("too deep");
        assert_eq!(e.kind, robosim_library::ErrorKind::Syntax);
        assert!(
            e.message.contains("nested more than 200 deep"),
            "{}",
            e.message
        );
    }
    let text = format!("scene a {{ effects {} }}", "collision { ".repeat(5000));
    assert!(Library::from_source("deep.rsl", &text).is_err());
}

// A fixed seed: the same cases on every run, so CI never meets a new random case (a random
// run failed CI once on a pose numeric IK cannot reach, core/kinematics/tests/properties.rs).
// Look for more by changing the seed or the case count.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 24,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x11C_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn surgical_positioner_with_random_link_lengths_is_valid(
        upper in 10.0f64..40.0, forearm in 10.0f64..40.0, offset in 0.0f64..8.0, tool in 2.0f64..10.0
    ) {
        let p = Params::new()
            .expr("upper_arm", &format!("{upper} cm"))
            .expr("forearm", &format!("{forearm} cm"))
            .expr("elbow_offset", &format!("{offset} cm"))
            .expr("tool_length", &format!("{tool} cm"));
        let Ok(Evaluated::Robot(r)) = std_lib().evaluate("surgical_positioner", &p) else {
            return Err(TestCaseError::fail("not a robot"));
        };
        prop_assert!(r.robot.validate().is_ok());
        prop_assert!((r.robot.joints[1].a - upper / 100.0).abs() < 1e-12);
        prop_assert!((r.robot.joints[3].d - forearm / 100.0).abs() < 1e-12);
        for p in r.frames.iter().flatten() {
            prop_assert!(p.polyhedron.is_closed());
            prop_assert_eq!(p.polyhedron.euler_characteristic(), 2);
        }
    }

    #[test]
    fn station_parameters_in_range_evaluate(a in -180.0f64..180.0, b in -180.0f64..180.0, s in 0.0f64..50.0) {
        let p = Params::new().expr("outboard_angle", &format!("{a} deg")).expr("panel_angle", &format!("{b} deg")).si("servicer_position", s);
        let Ok(Evaluated::Scene(sc)) = std_lib().evaluate("space_station", &p) else {
            return Err(TestCaseError::fail("not a scene"));
        };
        prop_assert_eq!(sc.robots.len(), 5);
    }
}
