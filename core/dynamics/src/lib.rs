//! Rigid-body dynamics of serial DH robots and time integration, as plain functions over a
//! [`Model`] (what the robot is) and a [`Data`] workspace (scratch and results) — the split of
//! Pinocchio's `Model`/`Data` and MuJoCo's `mjModel`/`mjData`. The seed lists dynamics as future
//! work (chapter 5) and keeps a per-link pseudo-inertia matrix (appendix 2.1); this crate is where
//! robosim goes past it.
//!
//! Entry points:
//! * [`Model::new`], [`Data::new`] — build once per robot; the algorithms then allocate nothing.
//! * [`rnea`] (inverse dynamics), [`gravity`], [`coriolis`] — recursive Newton–Euler.
//! * [`friction`]: joint friction apart from the rigid-body algorithms — [`JointFriction`],
//!   [`passive_torque`], [`friction_torque`] (stick–slip), [`aba_with_friction`].
//! * [`crba`] (mass matrix), [`fd_cholesky`] — composite-rigid-body algorithm and M⁻¹ by Cholesky.
//! * [`aba`] — forward dynamics by the articulated-body algorithm.
//! * [`energy`] — kinetic + potential energy.
//! * Spherical (ball) joints (`robosim_kinematics::Joint::spherical`, Pinocchio's layout: 4 q,
//!   3 v) go through RNEA, CRBA, ABA, gravity, energy and the explicit integrators (Euler, RK4,
//!   Dormand–Prince; the quaternion integrated on the manifold and kept unit). Refused by name
//!   (`ModelError::SphericalUnsupported`): the symplectic Euler step and the kinetic-energy
//!   gradient it uses, joint friction and the mimic coupling.
//! * [`mimic`] — RNEA, gravity, CRBA and forward dynamics over the reduced coordinates of a
//!   robot with mimic joints (`robosim_kinematics::mimic::Coupling`).
//! * [`Stepper`], [`simulate`], [`state_hash`] — explicit / semi-implicit Euler, RK4 and
//!   Dormand–Prince 5(4) with step control; inelastic joint stops ([`apply_joint_stops`]).
//! * [`fixture_robot`] — the PUMA 560, Stanford arm and Panda without friction or motor inertia.
//! * [`pseudo_inertia`], [`from_pseudo_inertia`], [`physically_consistent`] — the seed's
//!   4×4 pseudo-inertia and its consistency test.
//!
//! Conventions: SI units; standard or modified DH as in DESIGN.md; revolute and prismatic joints;
//! gravity from the robot (world frame); motor (rotor) inertia reflected to the joint (zero by
//! default; Pinocchio's armature). RNEA, CRBA and ABA are the rigid-body equations, Pinocchio's
//! (DESIGN.md, "Dynamics contract"): a joint's viscous and Coulomb data act only through
//! [`friction`] (a scene's joint friction effect: [`Stepper::with_friction`]).

#![forbid(unsafe_code)]
#![expect(
    clippy::needless_range_loop,
    reason = "the algorithms index several per-joint arrays in step; indices read like the papers"
)]

mod aba;
mod crba;
mod data;
mod energy;
mod fixtures;
pub mod friction;
mod integrate;
pub mod mimic;
mod model;
mod rnea;
mod spatial;
mod spherical;

pub use aba::aba;
pub use crba::{crba, fd_cholesky};
pub use data::Data;
pub use energy::{Energy, energy, kinetic_gradient};
pub use fixtures::fixture_robot;
pub use friction::{Coulomb, JointFriction, aba_with_friction, friction_torque, passive_torque};
pub use integrate::{
    Integrator, IntegratorConfig, Sample, Stats, StepSize, Stepper, apply_joint_stops, simulate,
    simulate_with_friction, state_hash,
};
pub use model::{DynamicsError, Model, from_pseudo_inertia, physically_consistent, pseudo_inertia};
pub use rnea::{coriolis, gravity, rnea};
