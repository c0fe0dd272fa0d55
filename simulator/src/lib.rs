//! The simulator: the effect pipeline over the kinematics, dynamics and collision cores
//! (DESIGN.md, "Scenes declare their effects"). A scene's [`SceneEffects`] declaration builds a
//! [`Pipeline`] holding only the declared stages; [`Pipeline::step`] runs them in order;
//! printing a pipeline describes what it built and what it left out.
//!
//! Entry points: [`SceneEffects`] (and its JSON form), [`Pipeline::build`], [`Pipeline::step`],
//! [`Command`]. `robosim sim` is `robosim_hl_interface::cli::sim`; `robosim report effects` is
//! `robosim_report::effects`.
//!
//! Scene-level effects (not per robot): [`orbit`] (a circular orbit, the sun vector, eclipses)
//! and [`power`] (solar arrays found by their panels, sun tracking of their gimbals, array
//! power, the battery) — the models the simulator daemon's space stage and `robosim study
//! station` share; [`swap`] (the `oru_swap` effect: the servicer's ORU swap planned, the ORUs'
//! state over time) for the same two; [`numeric`] (golden-section search) for them and the studies. The daemon
//! itself is `robosim-simulator-daemon`.

#![forbid(unsafe_code)]

pub mod effects;
pub mod numeric;
pub mod orbit;
pub mod pipeline;
pub mod power;
mod stages;
pub mod swap;

pub use effects::{
    CollisionEffect, DynamicsEffect, EffectsError, EncoderEffect, LoggingEffect, OnContact,
    SceneEffects, Signal,
};
pub use pipeline::{Command, Data, Model, Pipeline, SceneGeometry, Stage, StepError};
