//! The simulator: the effect pipeline over the kinematics, dynamics and collision cores
//! (DESIGN.md, "Scenes declare their effects"). A scene's [`SceneEffects`] declaration builds a
//! [`Pipeline`] holding only the declared stages; [`Pipeline::step`] runs them in order;
//! printing a pipeline describes what it built and what it left out.
//!
//! Entry points: [`SceneEffects`] (and its JSON form), [`Pipeline::build`], [`Pipeline::step`],
//! [`Command`]. `robosim sim` is `robosim_hl_interface::cli::sim`; `robosim report effects` is
//! `robosim_report::effects`.
//!
//! Not here yet: the headless daemon (`robosim up SCENE --with simulator`), state publishing and
//! the command channel of issue 6 — the pipeline is the plain-function core they will drive.

pub mod effects;
pub mod pipeline;
mod stages;

pub use effects::{
    CollisionEffect, DynamicsEffect, EffectsError, EncoderEffect, LoggingEffect, OnContact,
    SceneEffects, Signal,
};
pub use pipeline::{Command, Data, Model, Pipeline, SceneGeometry, Stage, StepError};
