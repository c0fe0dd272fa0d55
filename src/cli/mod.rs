//! The command line: clap lives here and nowhere else in the workspace (issue 35). One module
//! per library crate holds that crate's commands as clap types, converted (`From`) to the plain
//! argument types the crate's functions take; `main.rs` parses and dispatches.

pub mod bridge;
pub mod display;
pub mod file_io;
pub mod hl_interface;
pub mod report;
pub mod studies;
