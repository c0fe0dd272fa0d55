//! The editor and the ROBOSIM language as processes (issue 13): `robosim edit --script` writes
//! the seed's pictures 1–5 walk-through into a session piece by piece — each piece a separate
//! editor process that resumes the design from the Instance Space — while a headless display
//! process beside it draws every committed version; then `robosim lang run` and `robosim lang
//! load` turn the result into a robot of the session.

use crate::common;

use common::{Procs, ROBOSIM, wait_for};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn robosim(p: &Procs, args: &[&str]) -> Output {
    Command::new(ROBOSIM)
        .args(args)
        .args(["--session", &p.name])
        .env("ROBOSIM_HOME", p.home.path())
        .output()
        .expect("run robosim")
}

fn frames(dir: &Path) -> Vec<Value> {
    std::fs::read_to_string(dir.join("frames.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

const EDITS: &[&str] = &[
    "box",
    "cylinder",
    "cone",
    "truncated-cone",
    "sphere",
    "extrude",
    "revolve",
    "clone",
    "translate",
    "home",
    "rotate",
    "rotate-rel",
    "delete",
    "attach",
    "resize",
    "r-joint-i",
    "p-joint-i",
    "f-joint-i",
    "r-joint-i+1",
    "p-joint-i+1",
    "f-joint-i+1",
    "link",
    "undo",
    "redo",
    "load",
    "restart",
    "read-code",
];

#[test]
fn the_walkthrough_edited_piece_by_piece_is_seen_by_a_display_and_loads_as_a_robot() {
    if robosim_display::skipped_without_vulkan(
        "the_walkthrough_edited_piece_by_piece_is_seen_by_a_display_and_loads_as_a_robot",
    ) {
        return;
    }
    let mut k = Procs::new("edt");
    k.start_keeper(&[]);
    let out = k.home.path().join("display-out");
    let out_s = out.to_string_lossy().into_owned();
    k.spawn(&[
        "display",
        "--headless",
        "--every-frame",
        "--size",
        "160x120",
        "--out",
        &out_s,
    ]);
    wait_for("the display's first frame", || {
        frames(&out).into_iter().next()
    });
    let links = k.home.path().join("links");
    let script = include_str!("../testdata/robosim/pictures1-5.edit")
        .replace("@DIR@", &links.display().to_string());

    // Pieces: the lines up to and including one edit (units and the polygon travel with it).
    let mut pieces: Vec<String> = Vec::new();
    let mut cur = String::from("units cm\nunits deg\n");
    for line in script.lines() {
        cur.push_str(line);
        cur.push('\n');
        let verb = line.split_whitespace().next().unwrap_or("");
        if EDITS.contains(&verb) {
            pieces.push(std::mem::replace(
                &mut cur,
                String::from("units cm\nunits deg\n"),
            ));
        }
    }
    pieces.push(cur);
    let edits = script
        .lines()
        .filter(|l| EDITS.contains(&l.split_whitespace().next().unwrap_or("")))
        .count();
    let mut bodies = 0u64;
    let mut seen = 0;
    for (i, piece) in pieces.iter().enumerate() {
        let f = k.home.path().join(format!("piece{i}.edit"));
        std::fs::write(&f, piece).expect("piece");
        let o = robosim(
            &k,
            &["edit", "--robot", "C", "--script", &f.to_string_lossy()],
        );
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            o.status.success(),
            "piece {i}:\n{piece}\n{stdout}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let verb = piece
            .lines()
            .last()
            .and_then(|l| l.split_whitespace().next())
            .unwrap_or("");
        if !EDITS.contains(&verb) {
            // the tail: check, list, code, run — no edit
            assert!(!stdout.contains("ok, version"), "piece {i}: {stdout}");
            continue;
        }
        // "ok, version N (k ops)": the version this edit committed
        let version = stdout
            .lines()
            .filter_map(|l| l.strip_prefix("ok, version "))
            .filter_map(|l| l.split_whitespace().next()?.parse::<u64>().ok())
            .next_back()
            .unwrap_or_else(|| panic!("piece {i} ({verb}) committed nothing: {stdout}"));
        if matches!(verb, "cylinder" | "extrude" | "box") {
            bodies += 1;
        }
        let frame = wait_for(&format!("the display's frame of version {version}"), || {
            frames(&out).into_iter().find(|f| f["version"] == version)
        });
        assert_eq!(frame["bodies"], bodies, "piece {i} ({verb}): {frame}");
        seen += 1;
    }
    assert_eq!(edits, 15, "the walk-through's edits");
    assert_eq!(seen, edits, "every edit was drawn");
    assert!(links.join("C.LOC").exists() && links.join("C.L1").exists());

    // The same link files from `lang run` of the generated program, and into the session.
    let again = k.home.path().join("again");
    let o = robosim(
        &k,
        &[
            "lang",
            "run",
            &links.join("C.rsim").to_string_lossy(),
            "--out",
            &again.to_string_lossy(),
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["C.LOC", "C.L1"] {
        assert_eq!(
            std::fs::read(links.join(f)).expect("first"),
            std::fs::read(again.join(f)).expect("again"),
            "{f}"
        );
    }
    let o = robosim(
        &k,
        &["lang", "load", &links.to_string_lossy(), "--as", "c2"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = k.session();
    let mut reader = robosim_instance_space::Reader::attach(&s, "test").expect("reader");
    let snap = wait_for("the robot", || {
        reader.refresh().ok()?;
        reader.snapshot().filter(|s| s.robot("c2").is_some())
    });
    let view = snap.robot("c2").expect("c2");
    let model = robosim_scene::robot_model(&snap, &view).expect("a robot the simulator can use");
    assert_eq!(model.joints.len(), 1);
    assert!((model.joints[0].d - 0.4).abs() < 1e-12);

    // A failed program writes nothing and says where.
    let bad = k.home.path().join("bad.rsim");
    std::fs::write(
        &bad,
        "BOX X = 1, Y = 1, Z = 1\nSTORE-LINK B.LOC\nCYLINDER R = -2, H = 1\n",
    )
    .expect("bad");
    let none = k.home.path().join("none");
    let o = robosim(
        &k,
        &[
            "lang",
            "run",
            &bad.to_string_lossy(),
            "--out",
            &none.to_string_lossy(),
        ],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("bad.rsim:3:10: CYLINDER: argument R must be positive, got -2"),
        "{err}"
    );
    assert!(!none.join("B.LOC").exists());
}

/// Issue 13 §5: the display's pick selects what the next editor command acts on, carried
/// through the Instance Space. An editor process builds two boxes; a headless display process
/// looking at box `a` along +y clicks the middle of its image, which commits the session's
/// selection (box `a`, its −y face); a second editor process reads the pick and
/// `attach b bottom to . .` puts box b's bottom on that face.
#[test]
fn a_pick_in_the_display_is_what_the_next_editor_command_acts_on() {
    use robosim_editor::shape::face_frame;
    if robosim_display::skipped_without_vulkan(
        "a_pick_in_the_display_is_what_the_next_editor_command_acts_on",
    ) {
        return;
    }
    let mut k = Procs::new("pck");
    k.start_keeper(&[]);
    let first = k.home.path().join("first.edit");
    std::fs::write(
        &first,
        "units cm\nbox a X = 20, Y = 20, Z = 20\nbox b X = 10, Y = 10, Z = 4\ntranslate b X = 100\n",
    )
    .expect("script");
    let o = robosim(
        &k,
        &["edit", "--robot", "P", "--script", &first.to_string_lossy()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // The display: from 3 m along −y, looking at a's centre; one click in the middle.
    let out = k.home.path().join("display-out");
    let display = k.spawn(&[
        "display",
        "--headless",
        "--size",
        "160x120",
        "--from",
        "0,-3,0",
        "--at",
        "0,0,0",
        "--out",
        &out.to_string_lossy(),
        "--script",
        "click:80,60",
    ]);
    let s = k.session();
    let mut reader = robosim_instance_space::Reader::attach(&s, "test").expect("reader");
    let snap = wait_for("the display's pick", || {
        reader.refresh().ok()?;
        reader.snapshot().filter(|s| s.selection().is_some())
    });
    k.stop(display);
    let sel = snap.selection().expect("selected");
    let i = snap.index_of(sel.object).expect("the picked object exists");
    assert_eq!(snap.name(i), "a", "the pick hit box a");
    let polygon = sel.polygon.expect("the pick hit a polygon") as usize;
    let design = robosim_editor::session::design_from_snapshot(&snap, "P").expect("design");
    let a = design.object("a").expect("a");
    let poly = a.shape.polyhedron().expect("shape").expect("polygons");
    let fa = face_frame(&poly, polygon);
    assert!(
        (fa[(1, 2)] + 1.0).abs() < 1e-12,
        "the face seen from −y has its normal along −y: {fa}"
    );
    drop(snap);

    // A second editor process: the pick, as the selection it reads, is `.`.
    let second = k.home.path().join("second.edit");
    std::fs::write(&second, "picked\nattach b bottom to . .\n").expect("script");
    let o = robosim(
        &k,
        &[
            "edit",
            "--robot",
            "P",
            "--script",
            &second.to_string_lossy(),
        ],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        stdout.contains(&format!("picked: a, polygon {polygon}")),
        "{stdout}"
    );
    let version: u64 = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("ok, version "))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .next_back()
        .expect("the attach committed");
    let snap = wait_for("the attach", || {
        reader.refresh().ok()?;
        reader.snapshot().filter(|s| s.version() >= version)
    });
    let design = robosim_editor::session::design_from_snapshot(&snap, "P").expect("design");
    let b = design.object("b").expect("b");
    assert_eq!(b.parent.as_deref(), Some("a"));
    assert_eq!(b.faces.map(|f| f[0]), Some(polygon), "on the picked face");
    // In the world: b's bottom centre on a's picked face centre, the normals opposite.
    let bpoly = b.shape.polyhedron().expect("shape").expect("polygons");
    let bottom = (0..bpoly.polygons.len())
        .min_by(|&x, &y| {
            bpoly.polygons[x]
                .plane
                .normal
                .z
                .total_cmp(&bpoly.polygons[y].plane.normal.z)
        })
        .expect("bottom");
    let wa = design.world("a").expect("a") * face_frame(&poly, polygon);
    let wb = design.world("b").expect("b") * face_frame(&bpoly, bottom);
    for r in 0..3 {
        assert!(
            (wa[(r, 3)] - wb[(r, 3)]).abs() < 1e-12,
            "centres: {wa} {wb}"
        );
        assert!(
            (wa[(r, 2)] + wb[(r, 2)]).abs() < 1e-12,
            "normals: {wa} {wb}"
        );
    }
    // The space holds b under a.
    let ia = snap.find("a").expect("a");
    let ib = snap.find("b").expect("b");
    assert_eq!(snap.rec(ib).parent, snap.rec(ia).id);
}

/// Issue 39 item 5: a second `robosim edit` of a design undoes the session's edits of it — the
/// first editor process's — and a third redoes; each is its own process on one session.
#[test]
fn a_second_editor_process_undoes_the_first_ones_edits() {
    let mut k = Procs::new("edundo");
    k.start_keeper(&[]);
    let run = |k: &Procs, i: usize, script: &str| -> String {
        let f = k.home.path().join(format!("undo{i}.edit"));
        std::fs::write(&f, script).expect("script");
        let o = robosim(
            k,
            &["edit", "--robot", "U", "--script", &f.to_string_lossy()],
        );
        let text =
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "editor {i}:\n{script}\n{text}");
        text
    };
    let mut reader =
        robosim_instance_space::Reader::attach(&k.session(), "edundo-reader").expect("attach");
    let design_at = |reader: &mut robosim_instance_space::Reader, text: &str| {
        let version: u64 = text
            .lines()
            .filter_map(|l| l.strip_prefix("ok, version "))
            .filter_map(|l| l.split_whitespace().next()?.parse().ok())
            .next_back()
            .unwrap_or_else(|| panic!("no committed version in {text}"));
        let snap = wait_for("the edit", || {
            reader.refresh().ok()?;
            reader.snapshot().filter(|s| s.version() >= version)
        });
        robosim_editor::session::design_from_snapshot(&snap, "U").expect("design")
    };
    let t1 = run(&k, 1, "box a X=1 Y=1 Z=1\n");
    let one = design_at(&mut reader, &t1);
    let t2 = run(&k, 2, "cylinder b R=0.5 H=2\ntranslate a X=3\n");
    let three = design_at(&mut reader, &t2);
    assert_ne!(one, three);
    // Another process: two undos (of the three edits kept) take the design back to what the
    // first editor left.
    let t3 = run(&k, 3, "undo\nundo\n");
    assert!(t3.contains("3 edit(s) to undo"), "{t3}");
    assert_eq!(design_at(&mut reader, &t3), one, "{t3}");
    // And another: redo both.
    let t4 = run(&k, 4, "redo\nredo\n");
    assert_eq!(design_at(&mut reader, &t4), three, "{t4}");
}
