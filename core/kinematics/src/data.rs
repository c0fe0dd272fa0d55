//! The kinematics' working memory, apart from the model (Pinocchio's `Model`/`Data`, MuJoCo's
//! `mjModel`/`mjData`): a [`Robot`] says what the arm is and never changes while it is used; a
//! [`Data`] is sized once for it and holds what a call computes — the link frames and the
//! Jacobian — so an IK iteration or a simulation step allocates nothing.
//!
//! Entry points: [`Data::new`], [`Data::forward_kinematics`] (every link frame),
//! [`Data::fk_and_jacobian`] (tool pose and base-frame Jacobian); with a
//! [`KinematicModel`] compiled once, [`Data::forward_kinematics_compiled`] and
//! [`Data::fk_and_jacobian_compiled`] (the same numbers, without re-deriving the joints'
//! constant geometry on every call).

use crate::fk::link_frames_into;
use crate::jacobian::{Jacobian, fk_and_jacobian_into};
use crate::kinematic_model::KinematicModel;
use crate::model::Robot;
use nalgebra::Matrix4;

/// Scratch and results of the kinematics functions for one robot (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Data {
    /// World frames `base, 1..n, tool` at the last [`Data::forward_kinematics`] (n + 2).
    pub frames: Vec<Matrix4<f64>>,
    /// The 6 × n base-frame geometric Jacobian at the last [`Data::fk_and_jacobian`].
    pub jacobian: Jacobian,
    /// The tool pose at the last [`Data::fk_and_jacobian`].
    pub tool: Matrix4<f64>,
}

impl Data {
    /// Working memory for `robot` (n + 2 frames, a 6 × nv Jacobian), all identity / zero.
    pub fn new(robot: &Robot) -> Data {
        Data {
            frames: vec![Matrix4::identity(); robot.dof() + 2],
            jacobian: Jacobian::zeros(robot.nv()),
            tool: Matrix4::identity(),
        }
    }

    /// Whether this data was sized for a robot of `robot`'s joint count.
    pub fn fits(&self, robot: &Robot) -> bool {
        self.frames.len() == robot.dof() + 2 && self.jacobian.ncols() == robot.nv()
    }

    /// Every link frame at `q` into [`Data::frames`]. `q` must have `robot.dof()` entries and
    /// the data must have been made for a robot of that size ([`Data::fits`]).
    pub fn forward_kinematics(&mut self, robot: &Robot, q: &[f64]) -> &[Matrix4<f64>] {
        link_frames_into(robot, q, &mut self.frames);
        &self.frames
    }

    /// Tool pose and base-frame Jacobian at `q` in one pass, into [`Data::tool`] and
    /// [`Data::jacobian`] (same preconditions as [`Data::forward_kinematics`]).
    pub fn fk_and_jacobian(&mut self, robot: &Robot, q: &[f64]) -> (&Matrix4<f64>, &Jacobian) {
        self.tool = fk_and_jacobian_into(robot, q, &mut self.jacobian);
        (&self.tool, &self.jacobian)
    }

    /// [`Data::forward_kinematics`] from a compiled model (the data sized for its robot).
    pub fn forward_kinematics_compiled(
        &mut self,
        model: &KinematicModel,
        q: &[f64],
    ) -> &[Matrix4<f64>] {
        model.link_frames_into(q, &mut self.frames);
        &self.frames
    }

    /// [`Data::fk_and_jacobian`] from a compiled model (the data sized for its robot).
    pub fn fk_and_jacobian_compiled(
        &mut self,
        model: &KinematicModel,
        q: &[f64],
    ) -> (&Matrix4<f64>, &Jacobian) {
        self.tool = model.fk_and_jacobian_into(q, &mut self.jacobian);
        (&self.tool, &self.jacobian)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin_robot;
    use crate::fk::link_frames;
    use crate::jacobian::fk_and_jacobian;

    /// Reused data gives exactly what the allocating functions give, at every q of a walk
    /// (a stale entry from a previous q would show here).
    #[test]
    fn reused_data_equals_fresh_calls() {
        let robot = builtin_robot("puma560").expect("builtin");
        let mut d = Data::new(&robot);
        assert!(d.fits(&robot));
        for k in 0..5 {
            let q: Vec<f64> = (0..6).map(|j| 0.3 * k as f64 - 0.2 * j as f64).collect();
            assert_eq!(
                d.forward_kinematics(&robot, &q),
                link_frames(&robot, &q).as_slice()
            );
            let (t, j) = fk_and_jacobian(&robot, &q);
            let (dt, dj) = d.fk_and_jacobian(&robot, &q);
            assert_eq!((dt, dj), (&t, &j));
            let model = KinematicModel::new(&robot);
            let mut c = Data::new(&robot);
            assert_eq!(
                c.forward_kinematics_compiled(&model, &q),
                link_frames(&robot, &q).as_slice()
            );
            assert_eq!(c.fk_and_jacobian_compiled(&model, &q), (&t, &j));
        }
    }
}
