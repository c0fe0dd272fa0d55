//! The evaluation API: declarations, params, evaluate (the CLI's test is in hl-interface, the
//! bench's in the report crate).

use nalgebra::Vector3;
use robosim_library::{DeclKind, Error, Evaluated, Library, Params, Primitive};

/// A two-link planar arm with a gripper and a scene declaring every effect (shared with
/// hl-interface's CLI test).
const SRC: &str = include_str!("planar_demo.rsl");

fn lib() -> Library {
    Library::from_source("demo.rsl", SRC).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn declarations_and_params() {
    let l = lib();
    let kinds: Vec<(String, DeclKind)> = l
        .declarations()
        .into_iter()
        .map(|d| (d.name, d.kind))
        .collect();
    assert_eq!(
        kinds,
        vec![
            ("red".into(), DeclKind::Colour),
            ("steel".into(), DeclKind::Constant),
            ("bar".into(), DeclKind::Solid),
            ("planar".into(), DeclKind::Robot),
            ("demo".into(), DeclKind::Scene)
        ]
    );
    assert_eq!(
        l.declarations()[0].doc.as_deref(),
        Some("A two-link planar arm.")
    );
    let p = l.params("planar").expect("params");
    assert_eq!(p.len(), 2);
    assert_eq!(
        (
            p[1].name.as_str(),
            p[1].default_source.as_str(),
            p[1].default_si,
            p[1].unit.as_str()
        ),
        ("l2", "30 cm", Some(0.3), "m")
    );
    assert!(
        matches!(l.params("planr"), Err(Error::NoSuchDeclaration { suggestion: Some(s), .. }) if s == "planar")
    );
}

#[test]
fn robot_evaluates_with_mass_from_density_and_fixed_links_folded_into_the_tool() {
    let l = lib();
    let Ok(Evaluated::Robot(r)) = l.evaluate("planar", &Params::new().expr("l2", "40 cm")) else {
        panic!("robot")
    };
    assert_eq!(r.robot.dof(), 2);
    assert_eq!(r.link_names, vec!["one", "two"]);
    assert!((r.robot.joints[1].a - 0.4).abs() < 1e-15);
    // link one: a steel bar 0.5 × 0.04 × 0.04 centred at x = -0.25 in link frame 1
    let j = &r.robot.joints[0];
    assert!((j.mass - 7850.0 * 0.5 * 0.04 * 0.04).abs() < 1e-9);
    assert!((j.com - Vector3::new(-0.25, 0.0, 0.0)).norm() < 1e-12);
    let ixx = j.mass * (0.04f64.powi(2) * 2.0) / 12.0;
    let iyy = j.mass * (0.5f64.powi(2) + 0.04f64.powi(2)) / 12.0;
    assert!((j.inertia[(0, 0)] - ixx).abs() < 1e-9 && (j.inertia[(1, 1)] - iyy).abs() < 1e-9);
    // link two: mass given, com and inertia from geometry scaled to 2 kg
    assert_eq!(r.robot.joints[1].mass, 2.0);
    assert!((r.robot.joints[1].com.x + 0.2).abs() < 1e-12);
    // the fixed gripper is folded into the tool: Tx(2 cm) then the declared tool
    assert!((r.robot.tool[(0, 3)] - 0.07).abs() < 1e-15);
    assert_eq!(r.frames[2].len(), 2, "link two's bar and the gripper");
    assert_eq!(r.frames[2][0].colour, Some([1.0, 0.0, 0.0]));
    assert!(matches!(r.frames[2][1].primitive, Primitive::Box { .. }));
    assert!((r.robot.base[(2, 3)] - 1.0).abs() < 1e-15);
}

#[test]
fn scene_evaluates_placements_q_and_effects() {
    let l = lib();
    let Ok(Evaluated::Scene(s)) = l.evaluate("demo", &Params::new().si("reach", 0.6)) else {
        panic!("scene")
    };
    assert_eq!(s.robots.len(), 1);
    let arm = &s.robots[0];
    assert!(
        (arm.q[0] - 30f64.to_radians()).abs() < 1e-15
            && (arm.q[1] + 45f64.to_radians()).abs() < 1e-15
    );
    assert!((arm.model.robot.joints[0].a - 0.6).abs() < 1e-15);
    assert!(
        (arm.model.robot.base[(0, 3)] - 1.0).abs() < 1e-15
            && (arm.model.robot.base[(2, 3)] - 1.0).abs() < 1e-15
    );
    assert_eq!(s.solids[0].name, "table");
    let fx = &s.effects;
    assert!(fx.kinematics && fx.joint_limits);
    let c = fx.collision.expect("collision");
    assert_eq!(
        (c.mode, c.self_collision, c.continuous),
        (robosim_library::CollisionMode::Exact, true, true)
    );
    let d = fx.dynamics.expect("dynamics");
    assert_eq!(
        (d.integrator, d.dt),
        (robosim_library::Integrator::SemiImplicitEuler, 0.002)
    );
    assert_eq!(d.gravity, Some([0.0, 0.0, -9.81]));
    assert_eq!(fx.encoder.map(|e| e.bits), Some(14));
    let log = fx.logging.as_ref().expect("logging");
    assert_eq!(
        log.signals,
        [robosim_library::Signal::Q, robosim_library::Signal::Tau]
    );
}

#[test]
fn bad_parameter_values_are_refused_with_the_name() {
    let l = lib();
    assert!(
        matches!(l.evaluate("planar", &Params::new().expr("l1", "30 deg")), Err(Error::BadParameter { name, .. }) if name == "l1")
    );
    // Issue #19 item 9: the message names the parameter once ("parameter `l1` of `planar` is
    // a length …", not "parameter `l1` of `planar`: parameter `l1` of `planar` is …").
    let e = l
        .evaluate("planar", &Params::new().expr("l1", "30 deg"))
        .expect_err("an angle for a length")
        .to_string();
    assert_eq!(e.matches("parameter `l1`").count(), 1, "{e}");
    assert!(
        e.starts_with("parameter `l1` of `planar` is a length"),
        "{e}"
    );
    assert!(matches!(
        l.evaluate("planar", &Params::new().si("l3", 1.0)),
        Err(Error::NoSuchParameter { .. })
    ));
    match l.evaluate("planar", &Params::new().expr("l1", "0.5 m +")) {
        Err(Error::Source(e)) => assert_eq!(e.location.file, "<parameter l1>"),
        other => panic!("{other:?}"),
    }
    // out of range at evaluation time: a negative length breaks the box
    assert!(
        matches!(l.evaluate("planar", &Params::new().si("l1", -1.0)), Err(Error::Source(e)) if e.kind == robosim_library::ErrorKind::OutOfRange)
    );
}

#[test]
fn a_library_rebuilt_from_its_sources_evaluates_the_same() {
    let std = robosim_library::standard_library().expect("standard library");
    let files = std.sources();
    assert!(files.iter().any(|(n, _)| n == "std/station.rsl"));
    let again = Library::from_sources(&files).expect("rebuilt");
    let names = |l: &Library| {
        l.declarations()
            .into_iter()
            .map(|d| d.name)
            .collect::<std::collections::BTreeSet<_>>()
    };
    assert_eq!(names(std), names(&again));
    assert_eq!(
        std.evaluate("puma560", &Params::new()),
        again.evaluate("puma560", &Params::new())
    );
}

#[test]
fn standard_robot_resolves_library_names() {
    let puma = robosim_library::standard_robot("puma560").expect("puma560");
    assert_eq!(puma.dof(), 6);
    assert!(
        robosim_library::standard_robot("space_station").is_none(),
        "a scene is not a robot"
    );
    assert!(robosim_library::standard_robot("no_such_robot").is_none());
}

#[test]
fn a_loop_variable_may_shadow_a_declaration_name() {
    let src = "solid k {\n  part box(1 m, 1 m, 1 m)\n}\nsolid row {\n  part box(1 m, 1 m, 1 m) at translate(k * 2 m, 0, 0) for k in range(3)\n}\n";
    let lib: Library = src.parse().unwrap_or_else(|e| panic!("{e}"));
    let Ok(Evaluated::Solid(s)) = lib.evaluate("row", &Params::new()) else {
        panic!("solid")
    };
    assert_eq!(s.parts.len(), 3);
    assert_eq!(s.parts[2].transform[(0, 3)], 4.0);
}

#[test]
fn declared_links_are_called_from_robots_and_bad_arguments_name_the_parameter() {
    let src = r#"
link arm_segment(len = 0.3 m, twist = 0 deg) {
    joint: revolute
    a: len
    alpha: twist
    density: 2700 kg/m^3
    part box(len, 3 cm, 3 cm) at translate(-len / 2, 0, 0)
}
robot two(first = 0.4 m, second = 0.25 m) {
    link upper = arm_segment(len: first, twist: 90 deg)
    link lower = arm_segment(second)
}
"#;
    let lib = Library::from_source("links.rsl", src).unwrap_or_else(|e| panic!("{e}"));
    let Ok(Evaluated::Robot(r)) = lib.evaluate("two", &Params::new()) else {
        panic!("robot")
    };
    assert_eq!(r.link_names, vec!["upper", "lower"]);
    assert!(
        (r.robot.joints[0].a - 0.4).abs() < 1e-15
            && (r.robot.joints[0].alpha - std::f64::consts::FRAC_PI_2).abs() < 1e-15
    );
    assert!((r.robot.joints[1].a - 0.25).abs() < 1e-15);
    assert!((r.robot.joints[1].mass - 2700.0 * 0.25 * 0.03 * 0.03).abs() < 1e-9);
    // a link declaration evaluated alone is a one-joint robot
    assert!(
        matches!(lib.evaluate("arm_segment", &Params::new()), Ok(Evaluated::Link(l)) if l.robot.dof() == 1)
    );
    match lib.evaluate(
        "two",
        &Params::new().si("first", 0.5).expr("second", "10 deg"),
    ) {
        Err(Error::BadParameter { name, message, .. }) => {
            assert_eq!(name, "second");
            assert!(
                message.contains("is a length (0.25 m), but this is an angle (10 deg)"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn evaluated_models_round_trip_through_serde() {
    // bincode (what a shared-memory transport would carry) round-trips every f64 exactly
    let std = robosim_library::standard_library().expect("standard library");
    let cfg = bincode::config::standard();
    for name in [
        "space_station",
        "puma560",
        "station_middle_truss",
        "brushed_metal",
        "grey",
        "aluminium",
    ] {
        let e = std.evaluate(name, &Params::new()).expect("evaluates");
        let bytes = bincode::serde::encode_to_vec(&e, cfg).expect("serialize");
        let (back, _): (Evaluated, usize) =
            bincode::serde::decode_from_slice(&bytes, cfg).expect("deserialize");
        assert!(back == e, "{name} differs after a round trip");
        // and JSON carries the same structure (floats to within serde_json's parsing)
        let text = serde_json::to_string(&e).expect("json");
        assert!(serde_json::from_str::<Evaluated>(&text).is_ok(), "{name}");
    }
}

#[test]
fn doc_comments_attach_to_the_next_declaration_only() {
    let src = "// file header\r\n\r\n// the red colour\r\n// (pure)\r\ncolour red = rgb(1, 0, 0)\r\n  \r\ncolour blue = rgb(0, 0, 1)\n";
    let lib = Library::from_source("d.rsl", src).unwrap_or_else(|e| panic!("{e}"));
    let d = lib.declarations();
    assert_eq!(d[0].doc.as_deref(), Some("the red colour\n(pure)"));
    assert_eq!(d[1].doc, None);
}

#[test]
fn the_examples_in_the_language_reference_load() {
    let doc = include_str!("../../docs/library.md");
    let mut blocks = 0;
    for block in doc.split("```rsl\n").skip(1) {
        let src = block.split("```").next().expect("closed block");
        // effects-only fragments are wrapped in a scene to be checked
        let src = if src.trim_start().starts_with("effects") {
            format!(
                "scene fragment {{\n{}\n}}\n",
                src.replace("bbox | polygon | exact", "polygon")
                    .replace("on|off", "on")
                    .replace("euler | semi_implicit_euler | rk4 | dopri5", "rk4")
            )
        } else {
            src.to_string()
        };
        Library::from_source("docs/library.md", &src)
            .unwrap_or_else(|e| panic!("example {blocks} in docs/library.md:\n{e}"));
        blocks += 1;
    }
    assert!(blocks >= 2, "found {blocks} examples");
}

/// The `automation` effect (a scene's fault-monitoring plant, started by `robosim up`): the
/// switch means the ECLSS at the wall clock's pace, the block sets model and pace, and bad
/// values are refused by name and place.
#[test]
fn the_automation_effect_declares_the_plant_and_refuses_bad_values() {
    let scene = |effects: &str| {
        let src = format!("scene plant_scene(pace = 30) {{\n    effects {{ {effects} }}\n}}\n");
        Library::from_source("a.rsl", &src)
            .map_err(|e| e.to_string())
            .and_then(|l| {
                l.evaluate("plant_scene", &Params::new())
                    .map_err(|e| e.to_string())
            })
    };
    let fx = |effects: &str| match scene(effects) {
        Ok(Evaluated::Scene(s)) => s.effects,
        other => panic!("{effects}: {other:?}"),
    };
    assert_eq!(fx("kinematics: on").automation, None, "off unless declared");
    let a = fx("automation: on").automation.expect("declared");
    assert_eq!((a.model.as_str(), a.time_scale), ("eclss", 1.0));
    assert_eq!(fx("automation: off").automation, None);
    let a = fx("automation { model: \"plant.hfm\", time_scale: pace }")
        .automation
        .expect("declared");
    assert_eq!((a.model.as_str(), a.time_scale), ("plant.hfm", 30.0));
    for (bad, says) in [
        (
            "automation { time_scale: 0 }",
            "time_scale 0 is out of range",
        ),
        ("automation { time_scale: 2 s }", "time_scale"),
        (
            "automation { model: 3 }",
            "the automation model must be a name in quotes",
        ),
        (
            "automation { model: \"\" }",
            "the automation model must be a name in quotes",
        ),
        ("automation { modle: \"eclss\" }", "did you mean `model`"),
    ] {
        let e = scene(bad).expect_err(bad);
        assert!(e.contains(says) && e.contains("a.rsl:2:"), "{bad}: {e}");
    }
}

/// Issue 36: `effects { joint_friction { … } }` declares the joint friction effect (the robot's
/// viscous and Coulomb data act in the dynamics stage); `joint_friction: on` its default;
/// an unknown Coulomb model is refused; undeclared, none.
#[test]
fn issue_36_the_joint_friction_effect_is_declared_by_the_scene() {
    let with = |effects: &str| {
        let src = SRC.replace(
            "        encoder_bits: 14\n",
            &format!("        encoder_bits: 14\n        {effects}\n"),
        );
        assert_ne!(src, SRC);
        let l = Library::from_source("demo.rsl", &src).map_err(|e| e.to_string())?;
        match l.evaluate("demo", &Params::new()) {
            Ok(Evaluated::Scene(s)) => Ok(s.effects.joint_friction),
            Ok(_) => panic!("a scene"),
            Err(e) => Err(e.to_string()),
        }
    };
    let f = with("joint_friction { viscous: off, coulomb: regularised, velocity: 0.001 rad/s }")
        .expect("evaluates")
        .expect("declared");
    assert!(!f.viscous);
    assert_eq!(f.coulomb, robosim_model::CoulombModel::Regularised);
    assert!((f.velocity - 1e-3).abs() < 1e-18);
    let on = with("joint_friction: on").expect("evaluates");
    assert_eq!(on, Some(robosim_model::JointFrictionEffect::default()));
    assert!(with("joint_friction { coulomb: sticky }").is_err());
    let Ok(Evaluated::Scene(s)) = lib().evaluate("demo", &Params::new()) else {
        panic!("scene")
    };
    assert_eq!(s.effects.joint_friction, None);
}

/// Issue 37 item 3: `collision { tolerance: … }` sets how closely exact distances are computed
/// (`certified`, the default, or a GJK tolerance as a length); zero, negative, unitless-wrong
/// and unknown words are refused with the place.
#[test]
fn issue_37_the_collision_effect_takes_a_distance_tolerance() {
    use robosim_model::CollisionTolerance;
    let with = |group: &str| {
        let src = SRC.replace(
            "        collision { mode: exact, self: on, continuous: on }\n",
            &format!("        {group}\n"),
        );
        assert_ne!(src, SRC);
        let l = Library::from_source("demo.rsl", &src).map_err(|e| e.to_string())?;
        match l.evaluate("demo", &Params::new()) {
            Ok(Evaluated::Scene(s)) => Ok(s.effects.collision.expect("collision declared")),
            Ok(_) => panic!("a scene"),
            Err(e) => Err(e.to_string()),
        }
    };
    let c = with("collision { mode: exact, continuous: on, tolerance: 1e-6 m }").expect("1e-6 m");
    assert_eq!(c.tolerance, CollisionTolerance::Gjk(1e-6));
    assert!(c.continuous);
    let c = with("collision { mode: exact, tolerance: 0.002 mm }").expect("0.002 mm");
    assert!(matches!(c.tolerance, CollisionTolerance::Gjk(t) if (t - 2e-6).abs() < 1e-18));
    let c = with("collision { mode: exact, tolerance: certified }").expect("certified");
    assert_eq!(c.tolerance, CollisionTolerance::Certified);
    let c = with("collision { mode: exact }").expect("default");
    assert_eq!(c.tolerance, CollisionTolerance::Certified);
    for (bad, says) in [
        ("collision { tolerance: 0 m }", "out of range"),
        ("collision { tolerance: -1 mm }", "out of range"),
        ("collision { tolerance: 1 s }", "collision"),
        ("collision { tolerance: exact }", "demo.rsl:"),
        (
            "collision { tolerence: 1e-6 m }",
            "did you mean `tolerance`",
        ),
    ] {
        let e = with(bad).expect_err(bad);
        assert!(e.contains(says) && e.contains("demo.rsl:"), "{bad}: {e}");
    }
}
