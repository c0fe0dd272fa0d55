//! Rigid-body dynamics of serial DH robots and time integration, as plain functions over a
//! [`Model`] (what the robot is) and a [`Data`] workspace (scratch and results) — the split of
//! Pinocchio's `Model`/`Data` and MuJoCo's `mjModel`/`mjData`. The seed lists dynamics as future
//! work (chapter 5) and keeps a per-link pseudo-inertia matrix (appendix 2.1); this crate is where
//! robosim goes past it.
//!
//! Entry points:
//! * [`Model::new`], [`Data::new`] — build once per robot; the algorithms then allocate nothing.
//! * [`rnea`] (inverse dynamics), [`gravity`], [`coriolis`] — recursive Newton–Euler.
//! * [`crba`] (mass matrix), [`fd_cholesky`] — composite-rigid-body algorithm and M⁻¹ by Cholesky.
//! * [`aba`] — forward dynamics by the articulated-body algorithm.
//! * [`energy`] — kinetic + potential energy.
//! * [`Stepper`], [`simulate`], [`state_hash`] — explicit / semi-implicit Euler, RK4 and
//!   Dormand–Prince 5(4) with step control; inelastic joint stops ([`apply_joint_stops`]).
//! * [`fixture_robot`] — the PUMA 560, Stanford arm and Panda without friction or motor inertia.
//! * [`pseudo_inertia`], [`from_pseudo_inertia`], [`physically_consistent`] — the seed's
//!   4×4 pseudo-inertia and its consistency test.
//!
//! Conventions: SI units; standard or modified DH as in DESIGN.md; revolute and prismatic joints;
//! gravity from the robot (world frame); joint friction `b q̇ + c sign(q̇)` and motor (rotor)
//! inertia reflected to the joint, both optional (zero by default).

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
mod integrate;
mod model;
mod rnea;
mod spatial;

pub use aba::aba;
pub use crba::{crba, fd_cholesky};
pub use data::Data;
pub use energy::{Energy, energy, kinetic_gradient};
pub use fixtures::fixture_robot;
pub use integrate::{
    Integrator, IntegratorConfig, Sample, Stats, StepSize, Stepper, apply_joint_stops, simulate,
    state_hash,
};
pub use model::{DynamicsError, Model, from_pseudo_inertia, physically_consistent, pseudo_inertia};
pub use rnea::{coriolis, gravity, rnea};
