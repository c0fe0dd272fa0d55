//! One module per stage of the pipeline (see [`crate::pipeline`]).

pub mod collision;
pub mod dynamics;
pub mod encoder;
pub mod frames;
pub mod limits;
pub mod logging;
pub mod motion;
