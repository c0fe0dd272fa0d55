//! The ROBOSIM language against the seed: Table 1 verbatim runs and writes `C.LOC` with Table
//! 2's rows; a failed program writes nothing; link files load as a robot whose FK equals a DH
//! model written by hand.

use nalgebra::{Matrix4, Vector3};
use robosim_editor::{program, robot};
use robosim_file_io::linkfile::{LinkFile, LinkJoint};
use std::path::Path;

const TABLE1: &str = include_str!("../../testdata/robosim/table1.rsim");
const TABLE2: &str = include_str!("../../testdata/robosim/table2.txt");

fn rot(axis: usize, deg: f64) -> Matrix4<f64> {
    robosim_editor::shape::axis_rotation(axis, deg.to_radians())
}
fn tr(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new_translation(&Vector3::new(x, y, z))
}

#[test]
fn table_1_verbatim_writes_c_loc_with_table_2_rows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = program::run(TABLE1, "table1.rsim").expect("Table 1 runs");
    assert_eq!(out.links.len(), 1);
    assert_eq!(out.links[0].name, "C.LOC");
    assert_eq!(out.look_from, Some([-1.0, 1.0, 0.45]));
    assert_eq!(out.views.len(), 1);
    let paths = program::write_links(&out, dir.path()).expect("writes");
    assert_eq!(paths, vec![dir.path().join("C.LOC")]);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names.len(), 1, "only C.LOC, no temporary left: {names:?}");

    // Table 2's row numbers: 1 DH, 2 joints, 3 AINERT, 7 AJNT-I, 11 AJNT-I+1, 15 AMAT, 19 NVEC,
    // 20 the first vector, NVEC+19 the last.
    let rows: Vec<u32> = TABLE2
        .lines()
        .filter_map(|l| l.split('\t').next()?.trim().parse().ok())
        .collect();
    assert_eq!(rows, vec![1, 2, 3, 7, 11, 15, 19, 20, 21]);
    let text = std::fs::read_to_string(&paths[0]).expect("read");
    let lines: Vec<Vec<f64>> = text
        .lines()
        .map(|l| {
            l.split_whitespace()
                .map(|t| t.parse().expect("number"))
                .collect()
        })
        .collect();
    assert!(
        lines.iter().all(|l| l.len() == 4),
        "four columns in every row"
    );
    let nvec = lines[18][0] as usize;
    assert_eq!(lines.len(), nvec + 19, "rows 20 … NVEC+19 are the vectors");
    assert_eq!(
        &lines[1],
        &[1.0, 1.0, 3.0, 1.0],
        "JA1 JA2 JTYPE1 (fixed) JTYPE2 (revolute)"
    );
    assert_eq!(&lines[18][1..], &[0.0, 0.0, 0.0]);
    assert_eq!(lines[19][3], 0.0, "the list starts with a move");

    let f = LinkFile::read(&paths[0]).expect("reads back");
    assert_eq!(f.joint_i, Some(LinkJoint::Fixed));
    assert_eq!(f.joint_i1, Some(LinkJoint::Revolute));
    // F-JOINT-I: TRANSLATE Z = -25 (cm) after Y = -30.
    assert!((f.ajnt_i - tr(0.0, -0.3, -0.25)).amax() < 1e-15);
    // R-JOINT-I+1: ROTATE X = -45, ROTATE Z = 90, TRANSLATE (-5, -30, 55) cm.
    let want = tr(-0.05, -0.3, 0.55) * rot(2, 90.0) * rot(0, -45.0);
    assert!((f.ajnt_i1 - want).amax() < 1e-15, "{}", f.ajnt_i1);
    let amat = f.ajnt_i.try_inverse().expect("inverse") * f.ajnt_i1;
    assert!((f.amat - amat).amax() < 1e-15);

    // Mass: the 24-facet cylinder prism (r = 10 cm, h = 50 cm) plus the extruded pentagon
    // (area 625 cm², 10 cm thick), at 2700 kg/m³ — closed forms.
    let n = out.links[0]
        .objects
        .iter()
        .find_map(|o| match &o.shape {
            robosim_editor::shape::Shape::Cylinder { n, .. } => Some(*n as f64),
            _ => None,
        })
        .expect("a cylinder");
    let v_cyl = n / 2.0 * 0.1f64.powi(2) * (std::f64::consts::TAU / n).sin() * 0.5;
    let area = 0.2 * 0.25 + 0.5 * 0.2 * 0.1 + 0.0; // rectangle (-10..15) x (-10..10) + triangle to x = 25
    let v_ext = area * 0.1;
    let mass = f.ainert[(3, 3)];
    assert!(
        (mass - 2700.0 * (v_cyl + v_ext)).abs() < 1e-9,
        "{mass} vs {}",
        2700.0 * (v_cyl + v_ext)
    );

    // The custom object sits on the cylinder: one of its polygons is centred on the cylinder's
    // top centre (0, -30, 25) cm with its normal pointing down, opposite the top's.
    let polys = f.polygons(Path::new("C.LOC")).expect("polygons");
    let centre = |p: &Vec<[f64; 3]>| {
        p.iter()
            .fold(Vector3::zeros(), |a, v| a + Vector3::from(*v))
            / p.len() as f64
    };
    let hits = polys
        .iter()
        .filter(|p| (centre(p) - Vector3::new(0.0, -0.3, 0.25)).norm() < 1e-12)
        .count();
    assert_eq!(
        hits, 2,
        "the cylinder's top and the custom object's base share their centre"
    );
}

#[test]
fn a_failed_program_writes_no_link_file_and_says_where() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Table 1 with a second link whose cylinder has a negative radius, after C.LOC was stored.
    let bad = TABLE1.replace(
        "VIEW\nEND",
        "CLEAR\nCYLINDER R = -1.0, H = 5\nSTORE-LINK C.L1\nVIEW\nEND",
    );
    let e = program::run(&bad, "bad.rsim").expect_err("negative radius");
    assert_eq!(
        e.to_string(),
        "bad.rsim:38:10: CYLINDER: argument R must be positive, got -1"
    );
    // What `robosim lang run` does with it: the output folder (existing, empty) stays empty —
    // C.LOC, stored before the error, is not written either.
    let program = dir.path().join("bad.rsim");
    std::fs::write(&program, &bad).expect("program");
    let out = dir.path().join("out");
    std::fs::create_dir(&out).expect("out");
    let e = robosim_editor::cli::lang_run(&program, &out)
        .expect_err("negative radius")
        .to_string();
    assert!(
        e.ends_with("bad.rsim:38:10: CYLINDER: argument R must be positive, got -1"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_dir(&out).expect("out").count(),
        0,
        "a failed program wrote into {}",
        out.display()
    );
    // the same program without the error writes both links there (the check can fail)
    let good = bad.replace("R = -1.0", "R = 1.0");
    std::fs::write(&program, &good).expect("program");
    robosim_editor::cli::lang_run(&program, &out).expect("runs");
    assert!(out.join("C.LOC").exists() && out.join("C.L1").exists());

    let cases = [
        (
            "CLEAR\nWIBBLE X = 1\n",
            "u.rsim:2:1: WIBBLE: unknown command",
        ),
        (
            "BOX X = 1, Y = 2\n",
            "u.rsim:1:1: BOX: argument Z is missing",
        ),
        ("ADD Q\n", "u.rsim:1:5: ADD: register Q was never stored"),
        (
            "ROTATE X = 1 cm\n",
            "u.rsim:1:8: ROTATE: argument X is an angle; cm is not a unit of that",
        ),
        (
            "UNITS FURLONG\n",
            "u.rsim:1:7: UNITS: unknown unit \"FURLONG\" (M, CM, MM, IN, FT, DEG or RAD)",
        ),
        (
            "END\nCLEAR\n",
            "u.rsim:2:1: CLEAR: a command after END (line 1)",
        ),
        (
            "MOVE X=0\nDRAW X=1\nDRAW Y=1\n",
            "u.rsim:1:1: MOVE: this MOVE/DRAW polygon is never used by EXTRUDE-SURFACE or REV-SURFACE",
        ),
    ];
    for (text, want) in cases {
        let e = program::run(text, "u.rsim").expect_err(text);
        assert_eq!(e.to_string(), want);
    }
}

#[test]
fn a_non_dh_joint_pair_is_refused_with_the_broken_parameter() {
    let text = "UNITS M\nBOX X=0.1, Y=0.1, Z=0.4\nR-JOINT-I\nTRANSLATE Z = -0.2\nSTORE B\nCLEAR\nR-JOINT-I+1\nTRANSLATE Y = 0.05, Z = 0.2\nADD B\nSTORE-LINK R.L1\n";
    let e = program::run(text, "dh.rsim").expect_err("offset along y");
    assert!(
        e.to_string().starts_with("dh.rsim:10:12: STORE-LINK: link R.L1: the I joint and the I+1 joint are not related by a DH transform: DA:"),
        "{e}"
    );
}

/// Table 1's base link and a box link: R-JOINT-I at its bottom, R-JOINT-I+1 at its top turned
/// 90° about x (DH: d = 40 cm, α = 90°).
pub fn two_link_program() -> String {
    TABLE1.replace(
        "VIEW\nEND",
        "CLEAR\nBOX X = 10., Y = 10., Z = 40.\nSTORE B\nCLEAR\nR-JOINT-I\n  TRANSLATE Z = -20.\nADD B\nSTORE B\nCLEAR\nR-JOINT-I+1\n  ROTATE X = 90.\n  TRANSLATE Z = 20.\nADD B\nSTORE-LINK C.L1\nVIEW\nEND",
    )
}

#[test]
fn link_files_load_as_a_robot_whose_fk_equals_a_hand_written_dh_model() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = program::run(&two_link_program(), "two.rsim").expect("runs");
    program::write_links(&out, dir.path()).expect("writes");
    let (prefix, paths) = robot::link_paths(dir.path(), None).expect("paths");
    assert_eq!(prefix, "C");
    let r = robot::load_links(&paths, "c").expect("loads");
    // By hand: base = AJNT-I⁻¹ · AJNT-I+1 of C.LOC = T(-5, 0, 80) Rz(90°) Rx(-45°) (cm);
    // joint 1: revolute, d = 0.4 m, a = 0, α = 90°.
    let base = tr(-0.05, 0.0, 0.8) * rot(2, 90.0) * rot(0, -45.0);
    let hand = robosim_kinematics::Robot {
        joints: vec![robosim_kinematics::Joint {
            d: 0.4,
            alpha: std::f64::consts::FRAC_PI_2,
            ..Default::default()
        }],
        base,
        ..Default::default()
    };
    for q in [-2.0, -0.3, 0.0, 0.7, 3.0] {
        let a = robosim_kinematics::fk::forward(&r.robot, &[q]);
        let b = robosim_kinematics::fk::forward(&hand, &[q]);
        assert!((a - b).amax() < 1e-12, "q = {q}: {a} vs {b}");
    }
    // Into an Instance Space: the robot reads back as the same kinematics model.
    let tx = robot::robot_transaction(&r, "c").expect("tx");
    let mut store = robosim_instance_space::Store::new();
    store.apply(&tx).expect("the keeper's checks accept it");
    let snap = robosim_instance_space::Snapshot::from_store(&store);
    let views = snap.robots();
    assert_eq!(views.len(), 1);
    let model = robosim_scene::robot_model(&snap, &views[0]).expect("model");
    for q in [-1.0, 0.5] {
        let a = robosim_kinematics::fk::forward(&model, &[q]);
        let b = robosim_kinematics::fk::forward(&hand, &[q]);
        assert!((a - b).amax() < 1e-12);
    }
    // The box's vertices in the world at q = 0.3 are where the hand model puts them.
    let q = 0.3;
    let frames = robosim_kinematics::fk::link_frames(&hand, &[q]);
    let f1 = LinkFile::read(&dir.path().join("C.L1")).expect("C.L1");
    let to_world = frames[1] * f1.ajnt_i1.try_inverse().expect("inv");
    let snap_q = {
        let mut st = robosim_instance_space::Store::new();
        st.apply(&tx).expect("tx");
        let link = robosim_instance_space::Snapshot::from_store(&st)
            .find("C.L1")
            .expect("link");
        let id = robosim_instance_space::Snapshot::from_store(&st).objects()[link].id;
        let poses = robosim_scene::link_poses(&model, &[q]);
        let mut t = robosim_instance_space::Transaction::new();
        t.set_pose(id, poses[0]);
        st.apply(&t).expect("pose");
        robosim_instance_space::Snapshot::from_store(&st)
    };
    let s1 = (0..snap_q.len())
        .find(|&i| {
            snap_q.name(i) == "s1"
                && snap_q.object(i).rec.parent != 0
                && snap_q.name(
                    snap_q
                        .index_of(snap_q.object(i).rec.parent)
                        .expect("parent"),
                ) == "C.L1"
        })
        .expect("the box solid");
    let w = robosim_scene::pose::to_matrix(&snap_q.world_pose(s1));
    let g = snap_q.geometry(s1).expect("geometry");
    for v in g.vertices {
        let p = (w * Vector3::from(*v).push(1.0)).xyz();
        let mut best = f64::INFINITY;
        for (fv, _) in &f1.vectors {
            let h = (to_world * Vector3::from(*fv).push(1.0)).xyz();
            best = best.min((h - p).norm());
        }
        assert!(
            best < 1e-12,
            "vertex {v:?} is {best} m from the hand model's"
        );
    }
}

/// Issue 34 item 11: two `TRANSLATE X=1e308` in metres wrote `inf` into the link file and
/// succeeded; `lang load` then refused the run's own output. The overflow is refused at the
/// TRANSLATE that makes it, naming its line and the object's.
#[test]
fn lang_run_refuses_a_translate_that_overflows_instead_of_writing_inf() {
    let text = "UNITS M\nBOX X = 1, Y = 1, Z = 1\nTRANSLATE X = 1e308\nTRANSLATE X = 1e308\nSTORE-LINK A.L\nEND\n";
    let e = program::run(text, "inf.rsim").expect_err("overflow");
    assert_eq!(e.span.line, 4, "{e}");
    assert_eq!(e.command, "TRANSLATE", "{e}");
    assert!(
        e.what.contains("object made on line 2") && e.what.contains("outside f64's range"),
        "{e}"
    );
    let e = program::run("UNITS M\nBOX X = 1e309, Y = 1, Z = 1\nEND\n", "big.rsim")
        .expect_err("a literal beyond f64");
    assert!(e.what.contains("not finite"), "{e}");
}

/// What `lang run` stores must be what `lang load` reads: a box whose mass overflows (a
/// density of 1e300 kg/m³) is refused at STORE-LINK, not written as `inf`.
#[test]
fn lang_run_writes_only_link_files_lang_load_reads_back() {
    let text =
        "DENSITY RHO = 1e300\nUNITS M\nBOX X = 1000, Y = 1000, Z = 1000\nSTORE-LINK HUGE.L\nEND\n";
    let e = program::run(text, "huge.rsim").expect_err("mass overflows");
    assert_eq!(e.span.line, 4, "{e}");
    assert!(e.what.contains("would not read back"), "{e}");
    // and a normal program's every link reads back equal
    let out = program::run(TABLE1, "table1.rsim").expect("Table 1 runs");
    for l in &out.links {
        let back = LinkFile::parse(&l.file.to_text(), Path::new(&l.name)).expect("reads back");
        assert_eq!(back.to_text(), l.file.to_text());
    }
}

/// Issue 34 item 15: BOX, STORE A, then 40 × (ADD A, STORE A) doubles the working object 40
/// times (a 613-byte program grew to 3.7 GB). The polygon budget refuses it at the first ADD
/// over the budget, naming the budget, the count and how to raise it.
#[test]
fn lang_doubling_add_is_refused_by_the_polygon_budget() {
    let mut text = String::from("BOX X = 1, Y = 1, Z = 1\nSTORE A\n");
    for _ in 0..40 {
        text.push_str("ADD A\nSTORE A\n");
    }
    text.push_str("END\n");
    let cmds = robosim_editor::lang::parse(&text, "double.rsim").expect("parses");
    let e = program::run_with_budget(&cmds, "double.rsim", 1000).expect_err("over budget");
    assert_eq!(e.command, "ADD", "{e}");
    assert!(
        e.what.contains("over the budget of 1000")
            && e.what.contains("1536 polygons")
            && e.what.contains(program::POLYGON_BUDGET_ENV),
        "{e}"
    );
    // the default budget refuses it too (2^40 boxes), long before memory runs out
    let e = program::run(&text, "double.rsim").expect_err("over the default budget");
    assert!(e.what.contains("over the budget"), "{e}");
}
