//! The structure editor (R2, seed §2.3) and the ROBOSIM command language (Table 1).
//!
//! * [`lang`] — the language's syntax: commands, `KEY = VALUE [UNIT]` arguments, file:line:column
//!   errors.
//! * [`program`] — its meaning: the working object, registers, MOVE/DRAW polygons, STORE-LINK
//!   into link files (`robosim_file_io::linkfile`, Table 2); [`program::run`].
//! * [`shape`] — the objects (primitives, special surfaces, joint markers) and face frames.
//! * [`robot`] — link files → a robot (kinematics model and Instance Space transaction).
//!
//! Documentation: docs/editor.md.

#![forbid(unsafe_code)]

pub mod bench;
pub mod cli;
pub mod codegen;
pub mod commands;
pub mod lang;
pub mod lang_cmd;
pub mod program;
pub mod robot;
pub mod session;
pub mod shape;
pub mod structure;
