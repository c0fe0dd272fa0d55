//! One module per stage of the pipeline (see [`crate::pipeline`]): each is plain functions —
//! `build` (the stage's compiled part of [`crate::Model`] from its declared effect, checked),
//! `run` (one step: reads the model, reads and writes [`robosim_model::Data`]) and `describe`
//! (its settings, for the printable pipeline). No stage keeps state of its own.

pub mod collision;
pub mod dynamics;
pub mod encoder;
pub mod frames;
pub mod limits;
pub mod logging;
pub mod motion;
