//! `robosim lib list|show|eval|check`, driven through [`render`].

use robosim_hl_interface::cli::lib::{LibCmd, render};

/// The library of `library-space/tests/api.rs`.
const SRC: &str = r#"
// A two-link planar arm.
colour red = rgb(1, 0, 0)
let steel = 7850 kg/m^3

solid bar(length = 0.5 m, width = 4 cm) {
    colour: red
    part box(length, width, width) at translate(-length / 2, 0, 0)
}

robot planar(l1 = 0.5 m, l2 = 30 cm) {
    base: translate(0, 0, 1 m)
    tool: translate(5 cm, 0, 0)
    link one {
        joint: revolute
        a: l1
        limits: [-90 deg, 90 deg]
        density: steel
        part bar(length: l1)
    }
    link two {
        joint: revolute
        a: l2
        mass: 2 kg
        part bar(length: l2)
    }
    link gripper {
        joint: fixed
        a: 2 cm
        part box(2 cm, 6 cm, 2 cm)
    }
}

scene demo(reach = 0.5 m) {
    place arm = planar(l1: reach) at translate(1 m, 0, 0) q [30 deg, -45 deg]
    place table = bar(length: 2 m) at translate(0, 0, 0.5 m)
    effects {
        joint_limits: on
        collision { mode: exact, self: on, continuous: on }
        dynamics { integrator: semi_implicit_euler, step: 2 ms }
        encoder_bits: 14
        log: ["q", "tau"]
    }
}
"#;

#[test]
fn cli_lists_shows_and_checks() {
    let out = render(LibCmd::List { file: None }).expect("list");
    assert!(
        out.lines()
            .any(|l| l.starts_with("robot") && l.contains("puma560"))
    );
    let out = render(LibCmd::Show {
        name: "surgical_positioner".into(),
        file: None,
    })
    .expect("show");
    assert!(
        out.contains("upper_arm") && out.contains("default 22 cm = 0.22 m"),
        "{out}"
    );
    let dir = tempfile::tempdir().expect("tmp");
    let good = dir.path().join("good.model");
    std::fs::write(&good, SRC).expect("write");
    assert!(
        render(LibCmd::Check { file: good })
            .expect("check")
            .contains("ok (5 declarations)")
    );
    let out = render(LibCmd::Eval {
        name: "surgical_positioner".into(),
        params: vec!["upper_arm = 30 cm".into()],
        facets: Some(8),
        geometry: false,
        file: None,
    })
    .expect("eval");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["robot"]["joints"][1]["a"], 0.3);
    assert!(
        render(LibCmd::Eval {
            name: "puma560".into(),
            params: vec!["nope".into()],
            facets: None,
            geometry: false,
            file: None
        })
        .is_err()
    );
    let bad = dir.path().join("bad.txt");
    std::fs::write(&bad, "solid a {\n  part box(1 m, 1 m, 1 deg)\n}\n").expect("write");
    let err = render(LibCmd::Check { file: bad.clone() }).expect_err("bad file");
    assert!(err.contains(&format!("{}:2:22", bad.display())), "{err}");
}
