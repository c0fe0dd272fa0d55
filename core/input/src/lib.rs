//! How robosim reads and writes the files a user names: one mechanism for every format.
//!
//! Every reader of a user-supplied path (URDF, meshes, Collada, model files, link files, editor
//! scripts, fault models, effects, trajectories, library sources, `robosim info`) goes through
//! [`read_file`] / [`read_to_string`]: only a regular file is read (after following symbolic
//! links; a FIFO, a device such as `/dev/zero`, a directory or a socket is refused by name, and
//! the check comes before the open, so a FIFO never blocks), and at most a [`Limit`]'s bytes
//! are read (one byte past it and the file is refused with its size and the limit). A stream
//! read line by line (`robosim query`'s requests) goes through [`read_line_bounded`], which
//! never buffers more than its limit. XML is checked for its nesting depth by [`xml_depth`]
//! before a recursive parser sees it. Every user-facing output file is written by
//! [`write_file_atomic`]: to a temporary file beside it, synced, renamed, and never onto
//! anything but a regular file.
//!
//! Entry points: [`read_file`], [`read_to_string`], [`open_regular`], [`Limit`] (with the
//! per-format defaults [`Limit::TEXT`], [`Limit::MESH`], [`Limit::MODEL`], [`Limit::LINE`]),
//! [`read_line_bounded`] / [`skip_line`], [`xml_depth`], [`write_file_atomic`].

#![forbid(unsafe_code)]

mod limit;
mod line;
mod read;
mod write;
mod xml;

pub use limit::{Limit, LimitError, format_bytes};
pub use line::{Line, read_line_bounded, skip_line};
pub use read::{FileKind, InputError, InputProblem, open_regular, read_file, read_to_string};
pub use write::{OutputError, OutputProblem, check_output_path, write_file_atomic};
pub use xml::{MAX_XML_DEPTH, XmlTooDeep, xml_depth};
