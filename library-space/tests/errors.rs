//! One test per error class: each asserts the file:line:column, the quoted line and the
//! wording (message and expectation).

use robosim_library::{ErrorKind, LibError, Library};

fn fail(src: &str) -> LibError {
    match Library::from_source("model.rsl", src) {
        Ok(_) => panic!("expected an error for:\n{src}"),
        Err(e) => e,
    }
}

fn at(e: &LibError, line: usize, column: usize) {
    assert_eq!(
        (e.location.file.as_str(), e.location.line, e.location.column),
        ("model.rsl", line, column),
        "{e}"
    );
}

#[test]
fn syntax_error_names_the_token_and_what_was_expected() {
    let e = fail("solid a {\n    part box(1 m, 2 m 3 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Syntax);
    at(&e, 2, 23);
    assert_eq!(e.message, "unexpected number `3`");
    assert_eq!(
        e.expected.as_deref(),
        Some("`,` or `)` in the argument list")
    );
    assert_eq!(e.location.line_text, "    part box(1 m, 2 m 3 m)");
    let shown = e.to_string();
    assert!(shown.contains("--> model.rsl:2:23"), "{shown}");
    assert!(
        shown.contains(" 2 |     part box(1 m, 2 m 3 m)\n   |                       ^"),
        "{shown}"
    );
}

#[test]
fn unicode_operators_get_a_hint() {
    let e = fail("let x = 2 × 3\n");
    assert_eq!(e.kind, ErrorKind::Syntax);
    at(&e, 1, 11);
    assert_eq!(
        e.message,
        "unexpected character `×` (write `*` for multiplication)"
    );
}

#[test]
fn unknown_name_suggests_the_nearest() {
    let e = fail("solid arm(length = 1 m) {\n    part box(lenght, 1 cm, 1 cm)\n}\n");
    assert_eq!(e.kind, ErrorKind::UnknownName);
    at(&e, 2, 14);
    assert_eq!(e.message, "unknown name `lenght`; did you mean `length`?");
    assert_eq!(e.location.width, 6);
}

#[test]
fn unknown_function_is_an_unknown_name() {
    let e = fail("solid a {\n  part cylindre(1 m, 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::UnknownName);
    at(&e, 2, 8);
    assert!(
        e.message
            .starts_with("unknown function `cylindre`; did you mean `cylinder`?"),
        "{}",
        e.message
    );
}

#[test]
fn unknown_property_lists_the_allowed_ones() {
    let e = fail("link l {\n  joint: revolute\n  alpah: 90 deg\n}\n");
    assert_eq!(e.kind, ErrorKind::UnknownProperty);
    at(&e, 3, 3);
    assert_eq!(
        e.message,
        "a link has no property `alpah`; did you mean `alpha`?"
    );
    assert!(
        e.expected
            .as_deref()
            .is_some_and(|x| x.starts_with("one of: joint, a, alpha, d, theta"))
    );
}

#[test]
fn unknown_parameter_in_a_call() {
    let e = fail(
        "solid ball(radius = 1 m) {\n  part sphere(radius)\n}\nsolid t {\n  part ball(raduis: 2 m)\n}\n",
    );
    assert_eq!(e.kind, ErrorKind::UnknownProperty);
    at(&e, 5, 13);
    assert_eq!(
        e.message,
        "solid `ball` has no parameter `raduis`; did you mean `radius`?"
    );
    assert_eq!(e.expected.as_deref(), Some("ball(radius)"));
}

#[test]
fn duplicate_declaration_points_at_both() {
    let e = fail("colour red = rgb(1, 0, 0)\nsolid red {\n  part box(1 m, 1 m, 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Duplicate);
    at(&e, 2, 7);
    assert_eq!(e.message, "`red` is declared twice");
    let (note, loc) = e.note.clone().expect("note");
    assert_eq!(note, "first declared here as a colour");
    assert_eq!((loc.line, loc.column), (1, 8));
}

#[test]
fn duplicate_part_name() {
    let e =
        fail("solid a {\n  part leg = box(1 m, 1 m, 1 m)\n  part leg = box(1 m, 1 m, 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Duplicate);
    at(&e, 3, 8);
    assert_eq!(e.message, "`a` already has a part named `leg`");
    assert_eq!(e.note.as_ref().map(|n| n.1.line), Some(2));
}

#[test]
fn duplicate_property() {
    let e = fail("link l {\n  joint: revolute\n  a: 1 m\n  a: 2 m\n}\n");
    assert_eq!(e.kind, ErrorKind::Duplicate);
    at(&e, 4, 3);
    assert_eq!(e.message, "`a` is given twice");
}

#[test]
fn wrong_arity_shows_the_signature() {
    let e = fail("solid a {\n  part box(1 m, 2 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Arity);
    at(&e, 2, 8);
    assert_eq!(e.message, "`box` is missing its `z` argument");
    assert_eq!(e.expected.as_deref(), Some("box(x, y, z)"));
    let e = fail("solid a {\n  part sphere(1 m, 12, 3)\n}\n");
    assert_eq!(e.kind, ErrorKind::Arity);
    at(&e, 2, 24);
    assert_eq!(
        e.message,
        "too many arguments to `sphere`: it takes at most 2"
    );
}

#[test]
fn type_error_names_both_kinds() {
    let e = fail("solid a {\n  part rgb(1, 0, 0)\n}\n");
    assert_eq!(e.kind, ErrorKind::Type);
    at(&e, 2, 8);
    assert_eq!(
        e.message,
        "a part of `a` must be a solid, but this is a colour"
    );
}

#[test]
fn unit_error_adding_degrees_to_millimetres() {
    let e = fail("let x = 5 mm + 3 deg\n");
    assert_eq!(e.kind, ErrorKind::Unit);
    at(&e, 1, 9);
    assert_eq!(
        e.message,
        "cannot add a length (m, cm, mm) and an angle (deg, rad)"
    );
    assert_eq!(
        e.expected.as_deref(),
        Some("both sides of `+` in the same unit dimension")
    );
    assert_eq!(e.location.width, "5 mm + 3 deg".len());
}

#[test]
fn unit_error_where_a_length_is_expected() {
    let e = fail("link l {\n  joint: revolute\n  a: 90 deg\n}\n");
    assert_eq!(e.kind, ErrorKind::Unit);
    at(&e, 3, 6);
    assert_eq!(
        e.message,
        "expected a length (m, cm, mm), found an angle (90 deg)"
    );
    // and a plain number where a length is needed (only a bare 0 may stand for any unit)
    let e = fail("solid a {\n  part box(1, 1 m, 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Unit);
    at(&e, 2, 12);
}

#[test]
fn cycle_between_declarations() {
    let e = fail("solid a {\n  part b()\n}\nsolid b {\n  part c()\n}\nsolid c {\n  part a()\n}\n");
    assert_eq!(e.kind, ErrorKind::Cycle);
    at(&e, 8, 8);
    assert_eq!(
        e.message,
        "declarations refer to each other in a circle: a → b → c → a"
    );
}

#[test]
fn out_of_range_values() {
    let e = fail("solid a {\n  part cylinder(radius: -1 m, height: 2 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    at(&e, 2, 8);
    assert_eq!(
        e.message,
        "cylinder: `bottom radius` must be zero or positive and finite, got -1"
    );
    let e = fail("colour c = rgb(1.5, 0, 0)\n");
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    at(&e, 1, 16);
    assert_eq!(e.message, "colour component 1.5 is outside [0, 1]");
    let e = fail("link l {\n  joint: revolute\n  limits: [90 deg, -90 deg]\n}\n");
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    at(&e, 3, 11);
    assert_eq!(
        e.message,
        "joint limits are reversed: lower 90 deg > upper -90 deg"
    );
    let e = fail("solid a {\n  part extrude([[0, 0], [1 m, 1 m], [1 m, 0], [0, 1 m]], 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    assert!(e.message.contains("self-intersecting"), "{}", e.message);
}

#[test]
fn include_of_a_missing_file() {
    let e = fail("include \"no/such/file.rsl\"\n");
    assert_eq!(e.kind, ErrorKind::Include);
    at(&e, 1, 9);
    assert!(
        e.message
            .starts_with("cannot read included file `no/such/file.rsl`"),
        "{}",
        e.message
    );
}

#[test]
fn missing_required_property() {
    let e = fail("robot r {\n  link l {\n    a: 1 m\n  }\n}\n");
    assert_eq!(e.kind, ErrorKind::Missing);
    at(&e, 2, 8);
    assert_eq!(e.message, "link `l` has no `joint:`");
    assert_eq!(
        e.expected.as_deref(),
        Some("`joint: revolute`, `joint: prismatic` or `joint: fixed`")
    );
}

#[test]
fn wrong_word_for_an_enumerated_property() {
    let e = fail("link l {\n  joint: revolut\n}\n");
    assert_eq!(e.kind, ErrorKind::UnknownName);
    at(&e, 2, 10);
    assert_eq!(
        e.message,
        "`revolut` is not a joint type; did you mean `revolute`?"
    );
    assert_eq!(
        e.expected.as_deref(),
        Some("one of: revolute, prismatic, fixed")
    );
}

#[test]
fn scene_joint_values_outside_the_limits() {
    let src = "robot r {\n  link l {\n    joint: revolute\n    limits: [-90 deg, 90 deg]\n  }\n}\nscene cell {\n  place a = r() q [120 deg]\n}\n";
    let e = fail(src);
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    at(&e, 8, 20);
    assert_eq!(
        e.message,
        "q[0] = 120 deg is outside joint 1 (l)'s limits [-90 deg, 90 deg]"
    );
}

#[test]
fn unit_names_are_reserved() {
    let e = fail("solid s {\n  part box(1 m, 1 m, 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Syntax);
    at(&e, 1, 7);
    assert_eq!(e.message, "`s` is a unit and cannot be used as a name");
}

#[test]
fn errors_are_found_at_load_time_in_files_and_includes() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(
        dir.path().join("part.rsl"),
        "solid p {\n  part box(1 m, 1 m, 1 kg)\n}\n",
    )
    .expect("write");
    std::fs::write(
        dir.path().join("main.rsl"),
        "include \"part.rsl\"\nsolid q {\n  part p()\n}\n",
    )
    .expect("write");
    let e = match Library::load(dir.path().join("main.rsl")) {
        Err(robosim_library::Error::Source(e)) => e,
        other => panic!("expected a source error, got {other:?}"),
    };
    assert_eq!(e.kind, ErrorKind::Unit);
    assert!(e.location.file.ends_with("part.rsl"));
    assert_eq!((e.location.line, e.location.column), (2, 22));
}

#[test]
fn an_expression_that_overflows_is_an_overflow_error_never_inf() {
    // issue 34 item 8: `let x = 2 ^ 100000` and `1e308 m * 10` evaluated to inf, which reached
    // answers as JSON null
    let e = fail("solid a {\n  let x = 2 ^ 100000\n  part box(x * 1 m, 1 m, 1 m)\n}\n");
    assert_eq!(e.kind, ErrorKind::Overflow);
    at(&e, 2, 11);
    assert_eq!(
        e.message,
        "the value of this expression is not a finite number (+inf): it overflows f64's range"
    );
    let e = fail("let c = 1e308 m * 10\n");
    assert_eq!(e.kind, ErrorKind::Overflow, "{e}");
    at(&e, 1, 9);
    let e = fail("let c = 1e400 m\n");
    assert_eq!(e.kind, ErrorKind::Overflow, "{e}");
}
