//! The simulator: the effect pipeline over the kinematics, dynamics and collision cores
//! (DESIGN.md, "Scenes declare their effects"). A scene's effect declaration — the one typed
//! [`Options`] of `robosim-model`, here also called [`SceneEffects`] — builds a [`Pipeline`]: a
//! [`Model`] with a part per declared stage and a [`Data`] holding all per-step state;
//! [`Pipeline::step`] runs the declared stage functions in a fixed order; printing a pipeline
//! describes what it built and what it left out.
//!
//! Entry points: [`SceneEffects`] (and its JSON form, [`Options::from_json`]),
//! [`Pipeline::build`], [`Pipeline::step`], [`Pipeline::rewind`], [`Command`]. `robosim sim` is
//! `robosim_hl_interface::cli::sim`; `robosim report effects` is `robosim_report::effects`.
//!
//! Scene-level effects (not per robot): [`orbit`] (a circular orbit, the sun vector, eclipses)
//! and [`power`] (solar arrays found by their panels, sun tracking of their gimbals, array
//! power, the battery) — the models the simulator daemon's space stage and `robosim study
//! station` share; [`swap`] (the `oru_swap` effect: the servicer's ORU swap planned, the ORUs'
//! state over time) for the same two; [`numeric`] (golden-section search) for them and the
//! studies; [`attitude`] (the `attitude` effect: rigid-body attitude under gravity-gradient and
//! drag torques, a CMG cluster, desaturation by thrusters) for the station study; [`consumers`] (the
//! station's loads with priorities, and how a shortfall is shared) for the station study. They read a scene as [`robosim_model::parts::SceneParts`] (its box parts), not as
//! library types: this crate does not depend on the Library Space. The daemon itself is
//! `robosim-simulator-daemon`.

#![forbid(unsafe_code)]

pub mod attitude;
pub mod consumers;
pub mod model;
pub mod numeric;
pub mod orbit;
pub mod pipeline;
pub mod power;
mod stages;
pub mod swap;

/// A declaration that cannot be built, under the simulator's older name: [`BuildError`].
pub use model::BuildError as EffectsError;
pub use model::{BuildError, Model, SceneGeometry, StepError};
pub use pipeline::Pipeline;
/// The scene's effect declaration under the simulator's older name: [`Options`].
pub use robosim_model::Options as SceneEffects;
pub use robosim_model::{
    CollisionEffect, Command, Data, DynamicsEffect, EncoderEffect, Integrator, LoggingEffect,
    OnContact, Options, OptionsError, Signal,
};
