//! `robosim lib list|show|eval|check`, driven through [`render`].

use robosim_hl_interface::cli::CommandError;
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
            .contains("ok (5 declarations of its own:")
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
    // The library's located error, kept typed.
    assert!(
        matches!(
            err,
            CommandError::Library(robosim_library::Error::Source(ref e))
                if e.location.line == 2 && e.location.column == 22
        ),
        "{err:?}"
    );
    let err = err.to_string();
    assert!(err.contains(&format!("{}:2:22", bad.display())), "{err}");
}

/// Issue 39 item 3: a user's file sees the standard library — its scene places `puma560()`
/// beside a solid of its own — without `include "std"`; `check` counts the file's own
/// declarations, and `eval --file` evaluates its scene with the standard robot in it.
#[test]
fn a_users_file_places_a_standard_robot_in_a_scene_of_its_own() {
    let dir = tempfile::tempdir().expect("tmp");
    let file = dir.path().join("my.rsl");
    std::fs::write(
        &file,
        "solid my_table(width = 1.2 m) {\n    part box(width, 0.8 m, 0.04 m)\n}\n\
         scene my_cell(reach = 0.7 m) {\n    place table = my_table() at translate(reach, 0, 0)\n    \
         place arm = puma560()\n}\n",
    )
    .expect("write");
    let out = render(LibCmd::Check { file: file.clone() }).expect("check");
    assert!(
        out.contains(
            "ok (2 declarations of its own: solid my_table, scene my_cell; the standard library's"
        ),
        "{out}"
    );
    let out = render(LibCmd::Eval {
        name: "my_cell".into(),
        params: vec![],
        facets: Some(8),
        geometry: false,
        file: Some(file),
    })
    .expect("eval");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["name"], "my_cell");
    assert!(
        out.contains("\"puma_waist1/housing\""),
        "the PUMA 560's own solids: {out}"
    );
    assert!(
        out.contains("\"name\": \"arm\"") && out.contains("\"name\": \"table\""),
        "{out}"
    );
}
