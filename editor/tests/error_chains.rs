//! Issue 35 item 4: the editor's commands, `lang run`/`lang load` and the link-file loader keep
//! the lower error whole (matched by variant, reachable through `source()`) while the message
//! still names what and where, as it did when it was a string.

use robosim_editor::cli::{self, RunError};
use robosim_editor::commands::{CommandError, Prompt, execute};
use robosim_editor::program::{self, WriteLinksError};
use robosim_editor::robot::{self, RobotError};
use robosim_editor::session::Editor;
use robosim_editor::structure::EditError;
use robosim_file_io::linkfile::DhViolation;
use robosim_instance_space::Store;
use std::error::Error;

const TABLE1: &str = include_str!("../../testdata/robosim/table1.rsim");

/// `load FILE` of a JSON file that is not a design: serde's error is the source, and the
/// message names the command and the file.
#[test]
fn load_of_a_file_that_is_not_a_design_keeps_serdes_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"robot\": 3}").expect("write");
    let mut ed = Editor::new(Store::new(), "S").expect("editor");
    let mut p = Prompt::default();
    let e = execute(&mut ed, &mut p, &format!("load {}", bad.display())).expect_err("not a design");
    let CommandError::LoadFormat { file, source } = &e else {
        panic!("not a format error: {e:?}");
    };
    assert_eq!(file, &bad.display().to_string());
    assert!(source.is_data(), "{source}");
    let cause = e.source().expect("a source");
    assert!(
        cause.downcast_ref::<serde_json::Error>().is_some(),
        "{cause:?}"
    );
    assert!(
        e.to_string()
            .starts_with(&format!("load: {}: invalid type", bad.display())),
        "{e}"
    );
}

/// `resize a X=-3`: the geometry's shape error is kept inside the edit error, which names the
/// object.
#[test]
fn resize_to_a_negative_length_keeps_the_geometrys_shape_error() {
    let mut ed = Editor::new(Store::new(), "S").expect("editor");
    let mut p = Prompt::default();
    execute(&mut ed, &mut p, "box a X=1 Y=1 Z=1").expect("box");
    let e = execute(&mut ed, &mut p, "resize a X=-3").expect_err("negative");
    let CommandError::Edit(EditError::Solid { object, source }) = &e else {
        panic!("not a solid error: {e:?}");
    };
    assert_eq!(object, "a");
    assert_eq!(
        e.to_string(),
        format!("a: {source}"),
        "the message is the object and the geometry's words"
    );
    assert!(
        source
            .to_string()
            .contains("`x` must be a positive finite length")
    );
}

/// A link whose AMAT is not a DH transform: the violation (which DH parameter breaks) is kept,
/// and the message names the link file.
#[test]
fn a_link_whose_amat_is_not_dh_keeps_the_violation() {
    let out = program::run(TABLE1, "table1.rsim").expect("Table 1 runs");
    let base = out.links[0].file.clone();
    let mut moving = base.clone();
    moving.joint_i = Some(robosim_file_io::linkfile::LinkJoint::Revolute);
    // Offset 10 cm along y: the x axis misses the z axis, no DH row makes it.
    moving.amat = nalgebra::Matrix4::new_translation(&nalgebra::Vector3::new(0.0, 0.1, 0.0));
    let mut fixed_base = base;
    fixed_base.joint_i = None;
    fixed_base.joint_i1 = Some(robosim_file_io::linkfile::LinkJoint::Revolute);
    let e = robot::from_links(
        vec![("C.LOC".into(), fixed_base), ("C.L1".into(), moving)],
        "c",
    )
    .expect_err("not DH");
    let RobotError::NotDh { link, source } = &e else {
        panic!("not a DH error: {e:?}");
    };
    assert_eq!(link, "C.L1");
    assert!(
        matches!(source, DhViolation::XMissesZ { miss } if (miss - 0.1).abs() < 1e-12),
        "{source:?}"
    );
    let cause = e.source().expect("a source");
    assert!(cause.downcast_ref::<DhViolation>().is_some());
    assert!(
        e.to_string()
            .starts_with("C.L1: AMAT is not a DH transform: DA:"),
        "{e}"
    );
}

/// `lang run` into a folder where a symbolic link stands at a link file's name: the output
/// check's error is kept (its problem reachable), nothing is written.
#[test]
fn lang_run_through_a_symlink_keeps_the_output_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let prg = dir.path().join("box.rsim");
    std::fs::write(
        &prg,
        "UNITS M\nBOX X=0.1, Y=0.1, Z=0.4\nSTORE-LINK C.L1\nEND\n",
    )
    .expect("write");
    let out = dir.path().join("out");
    std::fs::create_dir(&out).expect("mkdir");
    std::os::unix::fs::symlink(dir.path().join("elsewhere"), out.join("C.L1")).expect("symlink");
    let e = cli::lang_run(&prg, &out).expect_err("a link is refused");
    let RunError::WriteLinks(WriteLinksError::Target(o)) = &e else {
        panic!("not an output error: {e:?}");
    };
    assert_eq!(o.path, out.join("C.L1"));
    assert!(o.source().is_some(), "the problem is kept");
    assert!(e.to_string().contains("symbolic link"), "{e}");
}

/// `lang run --as NAME` of a program whose links belong to two robots: the loader's refusal is
/// kept, the message names the program.
#[test]
fn lang_run_into_of_two_robots_keeps_the_loaders_refusal_and_names_the_program() {
    let dir = tempfile::tempdir().expect("tempdir");
    let prg = dir.path().join("two.rsim");
    std::fs::write(
        &prg,
        "UNITS M\nBOX X=0.1, Y=0.1, Z=0.4\nSTORE-LINK A.LOC\nSTORE-LINK B.LOC\nEND\n",
    )
    .expect("write");
    let session =
        robosim_instance_space::Session::open_in(dir.path(), Some("errchain")).expect("session");
    let e = cli::lang_run_into(&prg, None, "r", &session).expect_err("two robots");
    let RunError::Order { program, source } = &e else {
        panic!("not an order error: {e:?}");
    };
    assert_eq!(program, &prg);
    assert!(matches!(source, RobotError::Refused(_)), "{source:?}");
    assert_eq!(
        e.to_string(),
        format!(
            "{}: links of several robots (A, B); write them with --out and load one with `robosim lang load DIR --robot NAME`",
            prg.display()
        )
    );
}
