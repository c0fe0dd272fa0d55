//! A Library Space robot declared `from_urdf` (the Panda of testdata/urdf), instantiated into
//! a Store: its links are general joints (`Kinematics::Axis`, the tree kept), and the robot the
//! compiled scene builds from the snapshot has the library model's kinematics.

use nalgebra::Matrix4;
use rand::{Rng, SeedableRng};
use robosim_instance_space::{Kind, Kinematics, Snapshot, Store};
use robosim_kinematics::fk::link_frames;
use robosim_library::Evaluated;
use robosim_scene::{CompiledScene, Origin, build_library, instantiate};
use std::path::Path;

fn check(decl: &str, tip: Option<&str>, dof: usize) {
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf/panda.urdf");
    let tmp = tempfile::tempdir().expect("tmp");
    let rsl = tmp.path().join("panda.rsl");
    let tip = tip.map_or(String::new(), |t| format!("tip: \"{t}\""));
    std::fs::write(
        &rsl,
        format!(
            "robot {decl} from_urdf \"{}\" {{\n    {tip}\n    base: translate(0.2 m, -0.1 m, 0.4 m) * rotate_z(30 deg)\n}}\n",
            urdf.display()
        ),
    )
    .expect("write");
    let lib = build_library(std::slice::from_ref(&rsl)).expect("library");
    let Evaluated::Robot(model) = lib
        .evaluate(decl, &robosim_library::Params::new())
        .expect("evaluates")
    else {
        panic!("not a robot");
    };
    assert_eq!(model.robot.dof(), dof);
    let mut store = Store::new();
    store
        .apply(&instantiate(&lib, &Origin::defaults(decl), "arm").expect("instantiates"))
        .expect("applies");
    let snap = Snapshot::from_store(&store);
    let axes: Vec<(u32, u32)> = snap
        .objects()
        .iter()
        .filter(|o| o.kind() == Some(Kind::Link))
        .map(|o| match o.kinematics() {
            Some(Kinematics::Axis { index, parent, .. }) => (index, parent),
            other => panic!("a link of a URDF robot is not a general joint: {other:?}"),
        })
        .collect();
    let want: Vec<(u32, u32)> = (0..dof)
        .map(|j| {
            let p = model.robot.parents.get(j).copied().unwrap_or(j);
            (j as u32, p as u32)
        })
        .collect();
    assert_eq!(axes, want);
    let compiled = CompiledScene::of(&snap);
    let r = compiled.robot("arm").expect("compiled");
    assert_eq!(r.robot.dof(), dof);
    assert_eq!(r.robot.parents, model.robot.parents);
    // every body with a collision mesh in the URDF became a collision solid
    assert_eq!(r.solids.links.len(), dof + 1);
    assert!(
        r.solids.links.iter().all(Option::is_some),
        "every body has a solid"
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
    for _ in 0..30 {
        let q: Vec<f64> = model
            .robot
            .joints
            .iter()
            .map(|j| rng.random_range(j.qlim[0]..=j.qlim[1]))
            .collect();
        let a = link_frames(&r.robot, &q);
        let b = link_frames(&model.robot, &q);
        for (x, y) in a.iter().zip(&b) {
            let d: Matrix4<f64> = x - y;
            assert!(d.abs().max() <= 1e-12, "{decl} q {q:?}: {x} vs {y}");
        }
        let d = robosim_kinematics::fk::forward(&r.robot, &q)
            - robosim_kinematics::fk::forward(&model.robot, &q);
        assert!(d.abs().max() <= 1e-12);
    }
}

#[test]
fn a_from_urdf_chain_instantiates_as_general_joints_with_the_same_kinematics() {
    check("panda_arm", Some("panda_link8"), 7);
}

#[test]
fn a_from_urdf_tree_instantiates_as_a_tree_with_the_same_kinematics() {
    check("panda_tree", None, 9);
}
