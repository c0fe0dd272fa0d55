//! Agreement with Pinocchio 4.1 on the robots the peer timing uses (testdata/kinematics/peers/,
//! written by tools/peers/kinematics.py): PUMA 560 (DH, Pinocchio's model built joint by joint)
//! and UR10, xArm7, Panda from example-robot-data's URDFs (robosim reads Pinocchio's joint
//! placements and axes as general joints). Tool pose and base-frame Jacobian
//! (LOCAL_WORLD_ALIGNED) for all, every link frame for the URDF arms (their link frame j is
//! Pinocchio's joint frame j), through the compiled model and through `&Robot`.

use nalgebra::Matrix4;
use robosim_kinematics::jacobian::{Frame, Jacobian, jacobian};
use robosim_kinematics::json::matrix4_from_json;
use robosim_kinematics::{KinematicModel, fk};

#[path = "../benches/common/mod.rs"]
mod common;

fn doc(name: &str) -> serde_json::Value {
    let path = format!(
        "{}/../../testdata/kinematics/peers/{name}.json",
        env!("CARGO_MANIFEST_DIR")
    );
    serde_json::from_str(&std::fs::read_to_string(&path).expect("fixture")).expect("JSON")
}

#[test]
fn fk_and_jacobians_match_pinocchio_on_the_peer_robots() {
    let mut worst = [0.0_f64; 3];
    for fx in common::fixtures() {
        let d = doc(&fx.name);
        let model = KinematicModel::new(&fx.robot);
        let n = fx.robot.dof();
        let samples = d["samples"].as_array().expect("samples");
        assert_eq!(samples.len(), fx.qs.len());
        let mut frames = vec![Matrix4::zeros(); n + 2];
        let mut jac = Jacobian::zeros(n);
        for (s, q) in samples.iter().zip(&fx.qs) {
            let tool = matrix4_from_json(&s["tool"], "tool").expect("4x4");
            let tee = model.fk_and_jacobian_into(q, &mut jac);
            assert_eq!(tee, fk::forward(&fx.robot, q));
            assert_eq!(jac, jacobian(&fx.robot, q, Frame::Base));
            let e_tool = (tee - tool).abs().max();
            let theirs = s["jacobian"].as_array().expect("rows");
            let mut e_jac: f64 = 0.0;
            for (i, row) in theirs.iter().enumerate() {
                for (c, x) in row.as_array().expect("row").iter().enumerate() {
                    e_jac = e_jac.max((jac[(i, c)] - x.as_f64().expect("number")).abs());
                }
            }
            model.link_frames_into(q, &mut frames);
            assert_eq!(frames, fk::link_frames(&fx.robot, q));
            let mut e_frames: f64 = 0.0;
            if fx.name != "puma560" {
                for (j, f) in s["joint_frames"]
                    .as_array()
                    .expect("frames")
                    .iter()
                    .enumerate()
                {
                    let theirs = matrix4_from_json(f, "frame").expect("4x4");
                    e_frames = e_frames.max((frames[j + 1] - theirs).abs().max());
                }
            }
            assert!(
                e_tool <= 1e-14 && e_jac <= 1e-14 && e_frames <= 1e-14,
                "{} at {q:?}: tool {e_tool:e}, jacobian {e_jac:e}, frames {e_frames:e}",
                fx.name
            );
            for (w, e) in worst.iter_mut().zip([e_tool, e_jac, e_frames]) {
                *w = w.max(e);
            }
        }
    }
    eprintln!(
        "worst vs Pinocchio: tool pose {:.1e}, Jacobian {:.1e}, link frames {:.1e}",
        worst[0], worst[1], worst[2]
    );
}
