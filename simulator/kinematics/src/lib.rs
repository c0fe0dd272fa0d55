//! Robot model and kinematics as plain functions over plain data (`&Robot`, `&mut State`):
//! no shared memory here, so the query protocol, the benches and the simulator daemon all call
//! the same code.
//!
//! Entry points:
//! * [`Robot`], [`Joint`], [`Convention`] — the model (DESIGN.md, "The query protocol").
//! * [`fk::forward`], [`fk::link_frames`] — forward kinematics.

pub mod fk;
mod model;

pub use model::{Convention, Joint, JointType, ModelError, Robot, State};
