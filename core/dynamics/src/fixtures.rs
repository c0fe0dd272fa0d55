//! The robots the dynamics reports and the query protocol fall back on by name: the PUMA 560,
//! Stanford arm and Panda with roboticstoolbox-python's dynamic parameters and motor inertia and
//! friction zero — the checked-in `testdata/dynamics/robots/{puma560,stanford,panda}.json`
//! (hl-interface's test `fixture_robots_match_their_json` checks each against its file).
//!
//! Entry point: [`fixture_robot`].

use robosim_kinematics::{Robot, builtin_robot};

/// A fixture robot by name (`"puma560"`, `"stanford"`, `"panda"`): the kinematics crate's
/// [`builtin_robot`] with motor inertia, viscous and Coulomb friction set to zero. `None` for
/// other names.
pub fn fixture_robot(name: &str) -> Option<Robot> {
    let mut robot = builtin_robot(name)?;
    for j in &mut robot.joints {
        j.motor_inertia = 0.0;
        j.viscous = 0.0;
        j.coulomb = 0.0;
    }
    Some(robot)
}
