//! Target `urdf`: the URDF reader (`core/urdf/src/urdf_import.rs`, `urdf_geometry.rs`) on
//! text, read both ways `robosim import urdf` and `from_urdf` read it: as a chain to the only
//! leaf (`import_urdf_str`) and as the whole tree (`import_urdf_tree_str`).
//!
//! Whatever the bytes: a robot or a [`UrdfError`] that names the file given (`fuzz.urdf`) and a
//! line inside it; never a panic, a stack overflow or unbounded time. An accepted robot is a
//! valid robot (`Robot::validate`), with one `UrdfJoint` per coordinate. When it has no
//! `<mesh>` (meshes name files; reading files is not what this target tests) and at most
//! [`MAX_ROUND_SHAPES`] spheres and cylinders (each up to 256 facets), its collision solids are
//! built too, through the robot model (`robosim_model::Model::from_imported`, then
//! `collision_solids`): solids, or an error naming the object and its frame.

use robosim_urdf::UrdfError;
use robosim_urdf::urdf_geometry::Geometry;
use robosim_urdf::urdf_import::{import_urdf_str, import_urdf_tree_str};
use std::path::Path;

/// Round collision shapes built per input at most.
pub const MAX_ROUND_SHAPES: usize = 8;

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let file = Path::new("fuzz.urdf");
    let lines = text.bytes().filter(|&b| b == b'\n').count() + 1;
    let located = |e: &UrdfError| {
        assert_eq!(e.file, file, "error names another file: {e}");
        assert!(
            (e.line as usize) <= lines,
            "error at line {} of a {lines}-line file: {e}",
            e.line
        );
        let _ = e.to_string();
    };
    for tree in [false, true] {
        let r = if tree {
            import_urdf_tree_str(text, file)
        } else {
            import_urdf_str(text, file, None)
        };
        match r {
            Ok(robot) => {
                if let Err(e) = robot.robot.validate() {
                    panic!("accepted robot does not validate: {e}");
                }
                assert_eq!(
                    robot.joints.len(),
                    robot.robot.dof(),
                    "one UrdfJoint per coordinate"
                );
                let shapes = robot
                    .geometry
                    .links
                    .values()
                    .flat_map(|g| g.collision.iter().chain(&g.visual));
                let mut round = 0;
                let mut mesh = false;
                for s in shapes {
                    match &s.geometry {
                        Geometry::Mesh(_) => mesh = true,
                        Geometry::Sphere { .. } | Geometry::Cylinder { .. } => round += 1,
                        Geometry::Box { .. } => {}
                    }
                }
                if !mesh
                    && round <= MAX_ROUND_SHAPES
                    && let Err(e) = robosim_model::Model::from(&robot).collision_solids()
                {
                    // No mesh here, so no reader's error: the object and frame are named.
                    assert!(e.mesh().is_none(), "a mesh error without a mesh: {e}");
                    let _ = e.to_string();
                }
            }
            Err(e) => located(&e),
        }
    }
}
