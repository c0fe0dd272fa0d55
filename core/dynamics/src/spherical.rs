//! A spherical (ball) joint in the dynamics passes (`robosim_kinematics::Joint::spherical`;
//! layout in `robosim_kinematics::spherical`: q a unit quaternion `qx qy qz qw`, v the angular
//! velocity in the child frame — Pinocchio's `JointModelSpherical`): its motion subspace and ABA's
//! per-joint quantities.
//!
//! RNEA, CRBA, ABA and energy of a model with spherical joints are the same recursions as the
//! one-coordinate ones with a joint's motion subspace `S_j` of k columns (k = 1, or 3 for a
//! spherical joint: the child frame's unit rotations `[e_i; 0]`, constant in the child frame, so
//! the joint's velocity-product term is 0) and its coordinates at `Link::iv` in v (Featherstone
//! 2008, Tables 5.1, 6.2 and 7.1 with multi-DOF joints; ABA's `D = Sᵀ Iᴬ S` is 3 × 3 and inverted
//! by Cholesky). Motor inertia (armature) adds to each of a spherical joint's three diagonal
//! entries, as Pinocchio's and MuJoCo's armature does. Each algorithm's file holds its variant
//! next to the one-coordinate code: [`crate::rnea`] (`spherical_rnea_pass`), [`crate::crba`]
//! (`spherical_crba_pass`), [`crate::aba`] (`spherical_aba`), [`crate::energy`]
//! (`spherical_energy`) and the transforms of [`crate::data`] (`spherical_update_transforms`).
//! A model without spherical joints never takes them (the passes check one flag), so its numbers
//! and speed are those of the one-coordinate code.

use crate::model::Link;
use crate::spatial::Motion;
use nalgebra::{Matrix3, Matrix6x3, Vector3};

/// A spherical joint's ABA quantities: `U = Iᴬ S` (6 × 3), `D⁻¹` and `u = τ − Sᵀ pᴬ`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct BallScratch {
    pub u6: Matrix6x3<f64>,
    pub dinv: Matrix3<f64>,
    pub u: Vector3<f64>,
}

/// The motion subspace's columns of `link` (the first `k` of the array are used).
#[inline]
pub(crate) fn columns(link: &Link) -> ([Motion; 3], usize) {
    if link.spherical {
        let e = |i: usize| Motion {
            w: Vector3::ith(i, 1.0),
            v: Vector3::zeros(),
        };
        ([e(0), e(1), e(2)], 3)
    } else {
        ([link.s, Motion::zero(), Motion::zero()], 1)
    }
}

/// `Σ S_i x[i]` over the link's columns (an `x` too short reads as zeros).
#[inline]
pub(crate) fn combine(cols: &[Motion; 3], k: usize, x: &[f64], at: usize) -> Motion {
    let mut m = Motion::zero();
    for (i, c) in cols.iter().enumerate().take(k) {
        m = m.add(&c.scale(x.get(at + i).copied().unwrap_or(0.0)));
    }
    m
}
