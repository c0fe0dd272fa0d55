//! MJCF export against MuJoCo (issue 36 item 4): the library robots exported by robosim
//! (`to_mjcf`), read back by robosim's own MJCF import, have the tool pose and mass matrix MuJoCo
//! computed on the exported files (testdata/mjcf/exports/mujoco_exports.json, written by
//! tools/peers/check_exports.py with MuJoCo 4.0, which also checks Pinocchio and the URDF
//! export; docs/file-io.md has its table).

use crate::reference::{floats, matrix, testdata};
use nalgebra::Matrix4;
use robosim_file_io::mjcf::import_mjcf_tree_str;
use robosim_file_io::mjcf_export::{physical_inertia, to_mjcf};
use robosim_kinematics::fk;
use std::path::Path;

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(testdata().join("mjcf/exports/mujoco_exports.json"))
        .expect("testdata/mjcf/exports/mujoco_exports.json");
    serde_json::from_str(&text).expect("reference JSON")
}

/// The largest tool-pose difference and relative M difference of `text` (MJCF) re-imported,
/// against MuJoCo's numbers in `entry`.
fn compare(name: &str, text: &str, entry: &serde_json::Value) -> (f64, f64) {
    let r = import_mjcf_tree_str(text, Path::new("export.xml"))
        .unwrap_or_else(|e| panic!("{name}: robosim does not read its own export: {e}"));
    let tool = &r.geometry.links[&format!("{name}_tool")];
    let model = robosim_dynamics::Model::new(&r.robot).expect("dynamics model");
    let mut data = robosim_dynamics::Data::new(&model);
    let (mut ex, mut em) = (0.0f64, 0.0f64);
    for s in entry["samples"].as_array().expect("samples") {
        let q = floats(&s["q"]);
        let x = fk::link_frames(&r.robot, &q)[tool.body] * tool.in_body;
        let want = matrix(&s["tool"]);
        let want = Matrix4::from_fn(|i, j| want[(i, j)]);
        ex = ex.max((x - want).amax());
        let theirs = matrix(&s["mass_matrix"]);
        let ours = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
        em = em.max((ours - &theirs).amax() / theirs.amax().max(1.0));
    }
    (ex, em)
}

#[test]
fn library_robots_exported_to_mjcf_have_mujocos_fk_and_mass_matrix() {
    let reference = reference();
    let robots = reference["robots"].as_array().expect("robots");
    for name in ["puma560", "stanford", "weld_positioner"] {
        let entry = robots
            .iter()
            .find(|r| r["name"] == name)
            .unwrap_or_else(|| panic!("{name} in the reference"));
        let mut robot = robosim_library::standard_robot(name).expect("a library robot");
        robot.name = name.to_string();
        let (text, _notes) = to_mjcf(&robot).expect("exports");
        let (ex, em) = compare(name, &text, entry);
        eprintln!("{name}: tool {ex:.1e}, M {em:.1e}");
        assert!(
            ex < 1e-10,
            "{name}: tool pose differs from MuJoCo's by {ex:e}"
        );
        assert!(em < 1e-10, "{name}: M differs from MuJoCo's by {em:e}");
    }
}

/// The checked-in exports (URDF-imported robots included) read back the same way.
#[test]
fn checked_in_exports_read_back_with_mujocos_numbers() {
    let reference = reference();
    for entry in reference["robots"].as_array().expect("robots") {
        let name = entry["name"].as_str().expect("name");
        let path = testdata()
            .join("mjcf/exports")
            .join(entry["file"].as_str().expect("file"));
        let text = std::fs::read_to_string(&path).expect("exported file");
        let (ex, em) = compare(name, &text, entry);
        assert!(ex < 1e-10 && em < 1e-10, "{name}: tool {ex:e}, M {em:e}");
    }
}

/// The PUMA's link 3 in the library's data breaks A + B ≥ C: the export says so and writes a
/// tensor that satisfies it, with the largest moment kept.
#[test]
fn puma_link_3_is_made_physical_and_said() {
    let robot = robosim_library::standard_robot("puma560").expect("puma560");
    let (_, notes) = to_mjcf(&robot).expect("exports");
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("link 3:") && n.contains("A + B ≥ C")),
        "{notes:?}"
    );
    let (fixed, note) = physical_inertia(&robot.joints[2].inertia, "link 3");
    assert!(note.is_some());
    let mut e: Vec<f64> = fixed
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .copied()
        .collect();
    e.sort_by(f64::total_cmp);
    assert!(e[0] + e[1] >= e[2], "{e:?}");
}
