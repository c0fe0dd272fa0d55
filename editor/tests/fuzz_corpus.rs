//! The fuzz targets of the ROBOSIM language and the editor's command lines
//! and link files
//! (`fuzz/src/{program,edit,linkfile}.rs`) over every file of their corpora (`fuzz/seeds/TARGET/`: the
//! seed's Table 1 and pictures 1–5, hostile programs and scripts, and each input the fuzzer once
//! crashed on), on stable, so `cargo test` re-checks them without nightly. See
//! `docs/fuzzing.md`.

#[path = "../../fuzz/src/edit.rs"]
mod edit;
#[path = "../../fuzz/src/linkfile.rs"]
mod linkfile;
#[path = "../../fuzz/src/program.rs"]
mod program;
#[path = "../../fuzz/src/replay.rs"]
mod replay;

use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

#[test]
fn program_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "program", program::run);
}

#[test]
fn linkfile_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "linkfile", linkfile::run);
}

#[test]
fn edit_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "edit", edit::run);
}

/// Writes `fuzz/seeds/linkfile/`: the link files `lang run` writes for Table 1 and for the
/// two-link program of the `program` seeds, one file per seed and the robot's files joined by
/// `%%` lines (the `linkfile` target's envelope). Run by hand after a change to the link
/// file format: `cargo test -p robosim-editor --test editor -- --ignored
/// regenerate_linkfile_seeds`.
#[test]
#[ignore = "writes fuzz/seeds/linkfile/; run by hand"]
fn regenerate_linkfile_seeds() {
    let seeds = fuzz_dir().join("seeds");
    let out = seeds.join("linkfile");
    std::fs::create_dir_all(&out).expect("seeds/linkfile");
    for prog in ["table1.rsim", "two-link-robot.rsim"] {
        let path = seeds.join("program").join(prog);
        let text = std::fs::read_to_string(&path).expect("program seed");
        let o = robosim_editor::program::run(&text, prog).expect("the seed program runs");
        let mut all = Vec::new();
        for l in &o.links {
            std::fs::write(out.join(&l.name), l.file.to_text()).expect("write");
            all.push(l.file.to_text());
        }
        if all.len() > 1 {
            let stem = prog.trim_end_matches(".rsim");
            std::fs::write(out.join(format!("{stem}.robot")), all.join("%%\n")).expect("write");
        }
    }
}

/// Issue 34 (fuzzing, `edit` target): an unknown verb starting with a multi-byte character
/// (`日本`) panicked in the "did you mean" hint, which sliced the verb's first two *bytes*.
#[test]
fn unknown_verb_starting_with_a_multibyte_character_is_an_error_not_a_panic() {
    let mut ed = robosim_editor::session::Editor::new(robosim_instance_space::Store::new(), "r")
        .expect("a new design");
    let mut p = robosim_editor::commands::Prompt::default();
    let e = robosim_editor::commands::execute(&mut ed, &mut p, "日本 x")
        .expect_err("unknown")
        .to_string();
    assert!(e.contains("unknown command \"日本\""), "{e}");
    let e = robosim_editor::commands::execute(&mut ed, &mut p, "bo x")
        .expect_err("unknown")
        .to_string();
    assert!(e.contains("did you mean box?"), "{e}");
}

/// Found by the `edit` fuzz target: `delete k` then `undo` brings `k` back under a new id, and
/// a restarted editor (reading the design from the space) listed the link's objects in id order
/// — `t` before `k` — so its listing and generated code changed order. The design record now
/// carries each link's object order.
#[test]
fn undo_of_a_delete_keeps_the_design_order_when_read_back_from_the_space() {
    let mut ed = robosim_editor::session::Editor::new(robosim_instance_space::Store::new(), "r")
        .expect("a new design");
    let mut p = robosim_editor::commands::Prompt::default();
    for line in [
        "cone k R = 3, H = 4",
        "truncated-cone t R1 = 3, R2 = 5, H = 6, N = 8",
        "delete k",
        "undo",
    ] {
        robosim_editor::commands::execute(&mut ed, &mut p, line).expect(line);
    }
    let names = |d: &robosim_editor::structure::Design| -> Vec<String> {
        d.links
            .iter()
            .flat_map(|l| l.objects.iter().map(|o| o.name.clone()))
            .collect()
    };
    assert_eq!(names(ed.design()), ["k", "t"], "the editor's own order");
    let snap = robosim_instance_space::Snapshot::from_store(&ed.space);
    let back = robosim_editor::session::design_from_snapshot(&snap, "r").expect("read back");
    assert_eq!(
        names(&back),
        ["k", "t"],
        "the order read back from the space"
    );
    assert_eq!(&back, ed.design());
}
