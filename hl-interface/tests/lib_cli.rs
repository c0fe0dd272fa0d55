//! `robosim lib list|show|eval|check`, driven through [`render`].

use robosim_hl_interface::cli::lib::{LibCmd, render};

/// The library of `library-space/tests/api.rs`.
const SRC: &str = include_str!("../../library-space/tests/planar_demo.rsl");

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
