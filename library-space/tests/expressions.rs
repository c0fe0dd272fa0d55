//! Expression semantics: units, operators, functions, transforms; fixed links.

use robosim_library::{ErrorKind, Evaluated, Library, Params};

fn constant(expr: &str) -> (f64, String) {
    let lib = Library::from_source("e.rsl", &format!("let x = {expr}\n"))
        .unwrap_or_else(|e| panic!("{expr}: {e}"));
    match lib.evaluate("x", &Params::new()) {
        Ok(Evaluated::Constant { value, unit }) => (value, unit),
        other => panic!("{expr}: {other:?}"),
    }
}

fn close(expr: &str, value: f64, unit: &str) {
    let (v, u) = constant(expr);
    assert!(
        (v - value).abs() <= 1e-12 * value.abs().max(1.0),
        "{expr} = {v}, expected {value}"
    );
    assert_eq!(u, unit, "{expr}");
}

#[test]
fn units_scale_to_si_and_combine() {
    close("431.8 mm", 0.4318, "m");
    close("12 cm + 3 mm", 0.123, "m");
    close("90 deg", std::f64::consts::FRAC_PI_2, "rad");
    close("250 g", 0.25, "kg");
    close("2700 kg/m^3", 2700.0, "kg/m^3");
    close("0.35 kg*m^2", 0.35, "kg*m^2");
    close("9.81 m/s^2", 9.81, "m/s^2");
    close("5 ms", 0.005, "s");
    close("2 m * 3 m", 6.0, "m^2");
    close("6 m^2 / 2 m", 3.0, "m");
    close("10 * mm", 0.01, "m");
    close("(2 m) ^ 2", 4.0, "m^2");
    close("2 ^ 0.5", 2f64.sqrt(), "1");
    close("-(3 m - 5 m)", 2.0, "m");
    close("1 - 2 * 3", -5.0, "1");
    close("8 / 2 / 2", 2.0, "1");
}

#[test]
fn functions() {
    close("sin(30 deg)", 0.5, "1");
    close("cos(pi * rad)", -1.0, "1");
    close("tan(45 deg)", 1.0, "1");
    close("atan2(1 m, 1 m)", std::f64::consts::FRAC_PI_4, "rad");
    close("sqrt(9 m^2)", 3.0, "m");
    close("abs(-2 kg)", 2.0, "kg");
    close("min(3 cm, 2 cm)", 0.02, "m");
    close("max(0, 2 cm)", 0.02, "m");
}

#[test]
fn function_misuse_is_refused() {
    for (src, kind) in [
        ("let x = sin(1 m)", ErrorKind::Unit),
        ("let x = sqrt(2 m)", ErrorKind::Unit),
        ("let x = sqrt(-4)", ErrorKind::OutOfRange),
        ("let x = atan2(1 m, 1 deg)", ErrorKind::Unit),
        ("let x = 1 m / 0", ErrorKind::OutOfRange),
        ("let x = (2 m) ^ 0.5", ErrorKind::Unit),
        ("let x = 2 m ^ 0.5", ErrorKind::Syntax),
        ("let x = 2 ^ 1 m", ErrorKind::Unit),
        ("let x = sin(1 deg, 2 deg)", ErrorKind::Arity),
        ("let x = translate(1 m, 2 m)", ErrorKind::Arity),
        (
            "let x = rgb(red: 1, green: 0, bleu: 0)",
            ErrorKind::UnknownProperty,
        ),
        (
            "let x = matrix([[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])",
            ErrorKind::OutOfRange,
        ),
        ("let x = translate(0, 0, 1 m) + 1", ErrorKind::Type),
    ] {
        let e = Library::from_source("e.rsl", src).expect_err(src);
        assert_eq!(e.kind, kind, "{src}: {e}");
        assert_eq!(e.location.line, 1);
    }
}

#[test]
fn transforms_compose_right_to_left_on_column_vectors() {
    let src = r#"
solid plate {
    part box(2 m, 1 m, 1 m) at translate(10 m, 0, 0) * rotate_z(90 deg)
    part box(1 m, 1 m, 1 m) at ypr(90 deg, 0 deg, 0 deg)
    part box(1 m, 1 m, 1 m) at matrix([[0, -1, 0, 1 m], [1, 0, 0, 2 m], [0, 0, 1, 3 m], [0, 0, 0, 1]])
}
"#;
    let lib = Library::from_source("t.rsl", src).unwrap_or_else(|e| panic!("{e}"));
    let Ok(Evaluated::Solid(s)) = lib.evaluate("plate", &Params::new()) else {
        panic!("solid")
    };
    let t = s.parts[0].transform;
    // rotate first (the 2 m side turns onto y), then translate
    assert!((t[(0, 3)] - 10.0).abs() < 1e-15 && (t[(1, 0)] - 1.0).abs() < 1e-15);
    assert!(
        (s.parts[1].transform - s.parts[2].transform)
            .fixed_view::<3, 3>(0, 0)
            .abs()
            .max()
            < 1e-15
    );
    assert_eq!(
        (
            s.parts[2].transform[(0, 3)],
            s.parts[2].transform[(1, 3)],
            s.parts[2].transform[(2, 3)]
        ),
        (1.0, 2.0, 3.0)
    );
}

#[test]
fn leading_fixed_links_fold_into_the_base_and_middle_ones_are_refused() {
    let src = r#"
robot r {
    link stand {
        joint: fixed
        d: 1 m
        part cylinder(radius: 10 cm, height: 1 m) at translate(0, 0, -0.5 m)
    }
    link arm {
        joint: revolute
        a: 0.5 m
    }
}
"#;
    let lib = Library::from_source("f.rsl", src).unwrap_or_else(|e| panic!("{e}"));
    let Ok(Evaluated::Robot(r)) = lib.evaluate("r", &Params::new()) else {
        panic!("robot")
    };
    assert_eq!(r.robot.dof(), 1);
    assert_eq!(r.robot.base[(2, 3)], 1.0);
    assert_eq!(r.frames[0].len(), 1);
    assert_eq!(
        r.frames[0][0].transform[(2, 3)],
        0.5,
        "the stand's part, in frame 0"
    );
    let bad = "robot r {\n  link a {\n    joint: revolute\n  }\n  link b {\n    joint: fixed\n  }\n  link c {\n    joint: revolute\n  }\n}\n";
    let e = Library::from_source("f.rsl", bad).expect_err("middle fixed link");
    assert_eq!(e.kind, ErrorKind::Type);
    assert_eq!((e.location.line, e.location.column), (5, 3));
    assert_eq!(e.message, "fixed link `b` sits between two moving joints");
}

#[test]
fn models_too_large_for_memory_are_refused() {
    let src = "solid row(n = 1) {\n  part box(1 m, 1 m, 1 m) at translate(k * 2 m, 0, 0) for k in range(n)\n}\n";
    let lib = Library::from_source("big.rsl", src).unwrap_or_else(|e| panic!("{e}"));
    let opts = robosim_library::EvalOptions {
        facets: None,
        max_polygons: Some(600),
    };
    assert!(
        lib.evaluate_with("row", &Params::new().si("n", 100.0), &opts)
            .is_ok()
    );
    match lib.evaluate_with("row", &Params::new().si("n", 101.0), &opts) {
        Err(robosim_library::Error::Source(e)) => {
            assert_eq!(e.kind, ErrorKind::OutOfRange);
            assert_eq!(e.message, "the model has more than 600 polygons");
            assert_eq!((e.location.line, e.location.column), (2, 8));
        }
        other => panic!("{other:?}"),
    }
    let e = Library::from_source("big.rsl", "solid b {\n  part sphere(1 m, 2048)\n}\n")
        .expect_err("sphere facets");
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    assert!(
        e.message.contains("out of range [4, 1024]"),
        "{}",
        e.message
    );
}

#[test]
fn facets_property_applies_to_its_body_and_what_it_calls() {
    let src = r#"
solid rod { part cylinder(radius: 1 cm, height: 10 cm) }
robot r {
    facets: 12
    part cylinder(radius: 1 m, height: 1 m)
    link l {
        joint: revolute
        facets: 6
        part rod()
        part cylinder(radius: 1 m, height: 1 m, facets: 40)
    }
}
"#;
    let lib = Library::from_source("f.rsl", src).unwrap_or_else(|e| panic!("{e}"));
    let Ok(Evaluated::Robot(r)) = lib.evaluate("r", &Params::new()) else {
        panic!("robot")
    };
    let sides = |p: &robosim_library::PlacedSolid| p.polyhedron.polygons.len() - 2;
    assert_eq!(sides(&r.frames[0][0]), 12);
    assert_eq!(
        sides(&r.frames[1][0]),
        6,
        "the inline link's facets reach the called solid"
    );
    assert_eq!(sides(&r.frames[1][1]), 40, "an explicit argument wins");
    let Ok(Evaluated::Solid(s)) = lib.evaluate("rod", &Params::new()) else {
        panic!("solid")
    };
    assert_eq!(
        sides(&s.parts[0]),
        robosim_geometry::shapes::default_facets(0.01, robosim_geometry::shapes::DEFAULT_CHORD_TOL)
    );
}
