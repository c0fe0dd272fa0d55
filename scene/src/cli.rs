//! `robosim instantiate`, `robosim set` and a running session's Library Space by the session's
//! name: what the binary calls with the arguments it parsed. Each answers the line the command
//! prints (the binary prints it) or the [`SceneError`] that says what failed and where.
//!
//! Entry points: [`instantiate`], [`set`], [`session_library`].

use crate::{Origin, SceneError, instantiate_in_session, parse_params, set_in_session};
use robosim_instance_space::{Reader, Session};
use robosim_library::Library;

/// `robosim instantiate DECL [--as NAME] [--set K=V]…`: `declaration` with the `set` values
/// placed in the running session as `name` (the declaration's own name without one); the line
/// to print: what was instantiated, how many objects, the new version.
pub fn instantiate(
    declaration: &str,
    name: Option<&str>,
    set: &[String],
    session: Option<&str>,
) -> Result<String, SceneError> {
    let origin = Origin {
        declaration: declaration.to_owned(),
        params: parse_params(set)?,
    };
    let name = name.unwrap_or(declaration);
    let a = instantiate_in_session(&Session::existing(session)?, &origin, name)?;
    Ok(format!(
        "instantiated {declaration} as {name}: {} objects, version {}",
        a.created.len(),
        a.version
    ))
}

/// `robosim set INSTANCE K=V…`: the instance re-instantiated with the `pairs` over its recorded
/// values; the line to print: how many objects changed, which aspects, the new version.
pub fn set(instance: &str, pairs: &[String], session: Option<&str>) -> Result<String, SceneError> {
    let params = parse_params(pairs)?;
    let a = set_in_session(&Session::existing(session)?, instance, params)?;
    let aspects: Vec<&str> = robosim_instance_space::aspect::names(a.aspects());
    Ok(format!(
        "re-instantiated {instance}: {} objects changed ({}), version {}",
        a.changes.len(),
        aspects.join(", "),
        a.version
    ))
}

/// The Library Space of the running session `session` (one that must exist: a missing one is
/// the error naming the sessions that run).
pub fn session_library(session: Option<&str>) -> Result<Library, SceneError> {
    let s = Session::existing(session)?;
    let mut reader = Reader::attach(&s, "library")?;
    crate::session_library(&mut reader)
}
