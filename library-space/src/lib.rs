//! The Library Space (seed §3.3, rlib.h): a declarative, parametric modelling language for
//! colours, surfaces, solids made of parts, links, robots and scenes; its evaluator to plain
//! data; the standard library (PUMA 560, Stanford arm, Panda, the surgical positioner, the
//! welding cell, the Space Station of §4.1).
//!
//! The language is described with examples in `docs/library.md`.
//!
//! Entry points:
//! * [`Library::load`], [`Library::from_source`], [`Library::standard`] — parse and check.
//! * [`Library::declarations`], [`Library::params`] — list and inspect.
//! * [`Library::evaluate`] → [`Evaluated`] — plain data: [`RobotModel`] (a
//!   `robosim_kinematics::Robot` plus per-link solids), [`SolidModel`], [`SceneModel`] with
//!   its [`Effects`].
//! * [`standard_robot`] — a standard-library robot by name, for the query protocol.
//! * [`Library::encode_checked`], [`Library::decode_checked`] — the checked library as bytes,
//!   what a session publishes so that its processes read the library instead of re-parsing
//!   and re-checking it.

#![forbid(unsafe_code)]
#![expect(
    clippy::result_large_err,
    reason = "errors carry the located source line for the user; they are rare and not on a hot path"
)]

mod ast;
mod checked;
mod error;
mod eval;
mod lexer;
mod library;
mod model;
mod parser;
mod source;
mod stdlib;
mod units;
mod value;

pub use ast::DeclKind;
pub use checked::{CHECKED_FORMAT, DecodeFailure, StaleEncoding, sources_digest};
pub use error::{ErrorKind, LibError};
pub use eval::{EVAL_STEP_BUDGET, EvalOptions, POLYGON_BUDGET};
pub use library::{DeclInfo, Error, Library, ParamInfo, ParamValue, Params};
pub use model::*;
pub use source::{Location, MAX_SOURCE_BYTES};
pub use stdlib::FILES as STDLIB_FILES;

/// The standard library, loaded and checked once per process (it is embedded, so this only
/// fails if the shipped files are broken — which the tests rule out).
pub fn standard_library() -> Option<&'static Library> {
    static STD: std::sync::OnceLock<Option<Library>> = std::sync::OnceLock::new();
    STD.get_or_init(|| Library::standard().ok()).as_ref()
}

/// The robot model of standard-library robot `name` at its default parameters (`puma560`,
/// `stanford`, `panda`, …); `None` when there is no such robot. Suits the query protocol's
/// `robots` resolver: the library is parsed once per process and each robot evaluated once.
pub fn standard_robot(name: &str) -> Option<robosim_kinematics::Robot> {
    use std::collections::HashMap;
    use std::sync::Mutex;
    static CACHE: std::sync::OnceLock<Mutex<HashMap<String, Option<robosim_kinematics::Robot>>>> =
        std::sync::OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Ok(c) = cache.lock()
        && let Some(r) = c.get(name)
    {
        return r.clone();
    }
    let robot = match standard_library()?.evaluate(name, &Params::new()).ok()? {
        Evaluated::Robot(r) | Evaluated::Link(r) => Some(r.robot),
        _ => None,
    };
    if let Ok(mut c) = cache.lock() {
        c.insert(name.to_string(), robot.clone());
    }
    robot
}
