//! Robot model and kinematics as plain functions over plain data (`&Robot`, `&mut State`):
//! no shared memory, no transport and no reports here, so the query protocol
//! (`robosim_hl_interface::protocol::kinematics`), the reports (`robosim_report::ik`) and the
//! simulator all call the same code.
//!
//! Entry points:
//! * [`Robot`], [`Joint`], [`Convention`], [`JointGeometry`] — the one joint model (a fixed
//!   placement, a motion about a unit axis, a trailing transform; DH rows and general URDF-style
//!   joints both fill it: see the `model` module docs) and [`chain::build_chain`], which folds
//!   fixed joints into it (DESIGN.md, "The query protocol"; its
//!   inline JSON form is read and written by [`json`]);
//!   [`builtin_robot`] — the shipped PUMA 560, Stanford arm and Franka Panda.
//! * [`RootJoint`] — a floating base (free-flyer or planar root joint, Pinocchio's q and v
//!   layouts; [`Robot::nq`] ≠ [`Robot::nv`]): see [`root`].
//! * [`spherical`] — spherical (ball) joints ([`Joint::spherical`]: 4 q, 3 v, Pinocchio's
//!   layout) in the general algorithms; what refuses them.
//! * [`fk::forward`], [`fk::link_frames`] — forward kinematics.
//! * [`KinematicModel`] — the robot compiled once for FK and Jacobians (constant joint
//!   geometry folded, rigid transforms per joint kind; the `&Robot` functions run the same
//!   kernels compiling joint by joint).
//! * [`Data`] — the working memory (frames, Jacobian) apart from the model: sized once for a
//!   robot, reused so a step or an IK iteration allocates nothing.
//! * [`jacobian::jacobian`], [`jacobian::singularity`] — geometric Jacobians, distance to
//!   singularity.
//! * [`ik::solve`] — inverse kinematics (analytic, Newton, damped least squares, hybrid, auto).
//! * [`encoder::encoder_error`] — encoder quantisation bounds (seed §2.7).
//! * [`movej::movej_interpolate`] — MOVEJI's per-step joint-limit check.
//! * [`mimic`] — mimic joints: the [`mimic::Coupling`] of reduced to full coordinates, FK and
//!   Jacobians over the reduced ones (the robot itself stays the full model).

#![forbid(unsafe_code)]

mod builtin;
pub mod chain;
mod compiled;
mod data;
pub mod encoder;
pub mod fk;
pub mod ik;
pub mod jacobian;
pub mod json;
mod kinematic_model;
pub mod mimic;
mod model;
pub mod movej;
pub mod pose;
pub mod root;
pub mod spherical;

pub use builtin::{BUILTIN_NAMES, builtin_robot};
pub use data::Data;
pub use kinematic_model::KinematicModel;
pub use model::{
    Convention, Joint, JointGeometry, JointType, ModelError, Origin, Robot, State, axis_rotation,
};
pub use movej::{LimitViolation, MoveJError, movej_interpolate};
pub use root::{RootJoint, RootKind};
