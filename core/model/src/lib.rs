//! What a simulation is told and what it is doing, each as one value (MuJoCo's `mjOption` and
//! `mjData`):
//!
//! * [`Model`] — one robot as every reader produces it (Pinocchio's `Model` + `GeometryModel`):
//!   the joint tree ([`robosim_kinematics::Robot`]), joint and link names, the mimic coupling,
//!   the analytic IK family, and a [`GeometryModel`] of its visual and collision objects
//!   (primitives as primitives, mesh files by name, polygons), whose collision solids one
//!   function builds ([`geometry::link_solids`]).
//! * [`Options`] — every effect and knob a scene declares (integrator, step, collision mode,
//!   on-contact policy, gravity, joint limits, encoder bits, logged signals, orbit, power, ORU
//!   swap, automation), typed once where the scene is read: the Library Space's `effects { … }`
//!   block ([`Options`] is `robosim_library::Effects`) or the simulator's JSON form
//!   ([`Options::from_json`]). Nothing downstream parses a string again.
//! * [`Data`] — all per-step state of the simulator pipeline (q, q̇, q̈, t, the command, the
//!   link frames, the encoder readings, the contact verdict, the collision stage's last safe q,
//!   the integrator's state), so a step can be saved (`Clone`), compared (`PartialEq`) and
//!   rewound (assign the saved value back).
//! * [`parts`] — the box parts of a compiled scene that the scene-level plans find by name
//!   (solar panels, ORUs), filled by whoever compiles the scene.
//!
//! Entry points: [`Model`], [`GeometryModel`], [`geometry::link_solids`], [`Options`], [`Data`], [`Command`], [`parts::SceneParts`].

#![forbid(unsafe_code)]

mod data;
pub mod geometry;
mod options;
pub mod parts;
mod robot;

pub use data::{Command, Data, IntegratorState};
pub use geometry::{GeometryError, GeometryModel, GeometryObject, MeshFile, Role, Shape};
pub use options::{
    AttitudeEffect, AttitudeHold, AutomationEffect, CollisionEffect, CollisionMode,
    CollisionTolerance, CoulombModel, DynamicsEffect, EncoderEffect, Integrator,
    JointFrictionEffect, LoggingEffect, OnContact, Options, OptionsError, OrbitEffect,
    OruSwapEffect, PowerEffect, Signal,
};
pub use robot::Model;
