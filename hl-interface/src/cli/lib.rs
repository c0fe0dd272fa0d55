//! The `robosim lib …` commands: list declarations, show one's parameters, check a file.
//!
//! The binary parses the command line into a [`LibCmd`] (src/cli/hl_interface.rs) and calls
//! [`run`]; on `Err(message)` print it to stderr and exit non-zero (the message of a source
//! error starts with `error[…]` and names file:line:col).

use super::CommandError;
use robosim_library::{Evaluated, Library, Params};
use std::path::PathBuf;

#[derive(Debug, Clone)]
pub enum LibCmd {
    /// List every declaration with its kind (the standard library, or FILE with --file).
    List {
        /// A library file to list instead of the standard library (it may `include "std"`).
        file: Option<PathBuf>,
    },
    /// Show a declaration: kind, description, parameters with defaults and units.
    Show {
        /// The declaration (`robosim lib list` names them).
        name: String,
        /// Look NAME up in this library file instead of the standard library.
        file: Option<PathBuf>,
    },
    /// Check a library file (any name): parse, resolve, evaluate every declaration at its
    /// defaults. Exit status non-zero with file:line:col on the first error.
    Check {
        /// The library file to check.
        file: PathBuf,
    },
    /// Evaluate a declaration and print it as JSON (the `lib_evaluate` query answer).
    Eval {
        /// The declaration to evaluate.
        name: String,
        /// A parameter value as NAME=EXPR, e.g. `--param "upper_arm=30 cm"`; repeatable.
        params: Vec<String>,
        /// Force this facet count on every round primitive.
        facets: Option<usize>,
        /// Include every solid's vertices and polygons.
        geometry: bool,
        /// Look NAME up in this library file instead of the standard library.
        file: Option<PathBuf>,
    },
}

fn open(file: &Option<PathBuf>, session: Option<&Library>) -> Result<Library, CommandError> {
    match (file, session) {
        // A user's file sees the standard library (its scenes may place `puma560()`).
        (Some(f), _) => Ok(Library::load_with_standard(f)?),
        // A session's Library Space, rebuilt from the source text in shared memory.
        (None, Some(lib)) => {
            Ok(Library::from_sources(&lib.sources()).map_err(robosim_library::Error::from)?)
        }
        (None, None) => Ok(Library::standard().map_err(robosim_library::Error::from)?),
    }
}

/// Runs one `lib` command, printing to stdout. `Err` carries the message for stderr.
pub fn run(cmd: LibCmd) -> Result<(), CommandError> {
    print!("{}", render(cmd)?);
    Ok(())
}

/// The text [`run`] prints (for tests and other front ends).
pub fn render(cmd: LibCmd) -> Result<String, CommandError> {
    render_with(cmd, None)
}

/// [`render`] against a given library (a session's Library Space) instead of the standard
/// one, where the command names no `--file`.
pub fn render_with(cmd: LibCmd, session: Option<&Library>) -> Result<String, CommandError> {
    let mut out = String::new();
    match cmd {
        LibCmd::List { file } => render_list(&mut out, &file, session)?,
        LibCmd::Show { name, file } => render_show(&mut out, &name, &file, session)?,
        LibCmd::Eval {
            name,
            params,
            facets,
            geometry,
            file,
        } => render_eval(&mut out, name, &params, facets, geometry, &file)?,
        LibCmd::Check { file } => render_check(&mut out, &file)?,
    }
    Ok(out)
}

/// `lib list`: every declaration with its kind and the first line of its description.
fn render_list(
    out: &mut String,
    file: &Option<PathBuf>,
    session: Option<&Library>,
) -> Result<(), CommandError> {
    use std::fmt::Write as _;
    let lib = open(file, session)?;
    let decls = lib.declarations();
    let w = decls.iter().map(|d| d.name.len()).max().unwrap_or(4);
    for d in decls {
        let doc = d
            .doc
            .as_deref()
            .and_then(|s| s.lines().next())
            .unwrap_or("");
        let _ = writeln!(out, "{:<9} {:<w$}  {}", d.kind.as_str(), d.name, doc);
    }
    Ok(())
}

/// `lib show`: a declaration's kind, description and parameters, then what it evaluates to at
/// its defaults.
fn render_show(
    out: &mut String,
    name: &str,
    file: &Option<PathBuf>,
    session: Option<&Library>,
) -> Result<(), CommandError> {
    use std::fmt::Write as _;
    let lib = open(file, session)?;
    let info = lib.declarations().into_iter().find(|d| d.name == name);
    let params = lib.params(name)?;
    let Some(d) = info else {
        return Err(CommandError::Refused(format!(
            "no declaration named `{name}`"
        )));
    };
    let _ = writeln!(out, "{} {}  ({})", d.kind.as_str(), d.name, d.location);
    if let Some(doc) = &d.doc {
        for l in doc.lines() {
            let _ = writeln!(out, "  {l}");
        }
    }
    if params.is_empty() {
        let _ = writeln!(out, "parameters: none");
    } else {
        let _ = writeln!(out, "parameters:");
        let w = params.iter().map(|p| p.name.len()).max().unwrap_or(4);
        for p in &params {
            let si = p
                .default_si
                .map(|v| format!(" = {v} {}", p.unit))
                .unwrap_or_default();
            let _ = writeln!(
                out,
                "  {:<w$}  default {}{si}  ({})",
                p.name, p.default_source, p.kind
            );
        }
    }
    render_evaluated(out, lib.evaluate(name, &Params::new())?);
    Ok(())
}

/// The summary of an evaluated declaration `lib show` ends with.
fn render_evaluated(out: &mut String, evaluated: Evaluated) {
    use std::fmt::Write as _;
    match evaluated {
        Evaluated::Robot(r) | Evaluated::Link(r) => {
            let _ = writeln!(
                out,
                "robot: {} joints, {:?} DH, analytic IK: {}",
                r.robot.dof(),
                r.robot.convention,
                r.ik.as_deref().unwrap_or("none")
            );
            for (j, (n, jt)) in r.link_names.iter().zip(&r.robot.joints).enumerate() {
                let _ = writeln!(
                    out,
                    "  {:>2} {:<14} {:?} a={} d={} alpha={:.4} offset={:.4} limits=[{:.4}, {:.4}] mass={} kg",
                    j + 1,
                    n,
                    jt.joint_type,
                    jt.a,
                    jt.d,
                    jt.alpha,
                    jt.offset,
                    jt.qlim[0],
                    jt.qlim[1],
                    jt.mass
                );
            }
        }
        Evaluated::Solid(s) => {
            let polys: usize = s.parts.iter().map(|p| p.polyhedron.polygons.len()).sum();
            let _ = writeln!(out, "solid: {} primitives, {polys} polygons", s.parts.len());
            if let Some(m) = s.mass {
                let _ = writeln!(
                    out,
                    "  mass {} kg, volume {} m^3, centre of mass {:?}",
                    m.mass,
                    m.volume,
                    m.center_of_mass.coords.as_slice()
                );
            }
        }
        Evaluated::Scene(s) => {
            let _ = writeln!(
                out,
                "scene: {} robots, {} solids",
                s.robots.len(),
                s.solids.len()
            );
            for r in &s.robots {
                let _ = writeln!(out, "  robot {} ({} joints)", r.name, r.model.robot.dof());
            }
            for i in &s.solids {
                let _ = writeln!(
                    out,
                    "  solid {} ({} primitives)",
                    i.name,
                    i.solid.parts.len()
                );
            }
            let _ = writeln!(out, "  effects: {}", describe_effects(&s.effects));
        }
        Evaluated::Constant { value, unit } => {
            let _ = writeln!(out, "value: {value} {unit}");
        }
        Evaluated::Colour { rgb } => {
            let _ = writeln!(out, "rgb: {rgb:?}");
        }
        Evaluated::Surface(s) => {
            let _ = writeln!(out, "surface: {s:?}");
        }
    }
}

/// `lib eval`: the `lib_evaluate` query's answer as pretty JSON.
fn render_eval(
    out: &mut String,
    name: String,
    params: &[String],
    facets: Option<usize>,
    geometry: bool,
    file: &Option<PathBuf>,
) -> Result<(), CommandError> {
    use std::fmt::Write as _;
    let mut obj = serde_json::Map::new();
    for p in params {
        let (k, v) = p
            .split_once('=')
            .ok_or_else(|| format!("--param `{p}`: expected NAME=EXPR"))?;
        obj.insert(
            k.trim().to_string(),
            serde_json::Value::String(v.trim().to_string()),
        );
    }
    let mut req = serde_json::json!({ "name": name, "params": obj, "geometry": geometry });
    if let Some(n) = facets {
        req["facets"] = n.into();
    }
    if let Some(f) = file {
        req["file"] = f.display().to_string().into();
    }
    let answer = crate::protocol::library::dispatch("lib_evaluate", &req, &|_| None)
        .unwrap_or_else(|| {
            Err(crate::ProtocolError::new(
                crate::ErrorKind::InternalError,
                "lib_evaluate not handled",
            ))
        })?;
    let _ = writeln!(out, "{}", serde_json::to_string_pretty(&answer)?);
    Ok(())
}

/// `lib check`: the file loads, resolves and evaluates; its own declarations.
fn render_check(out: &mut String, file: &std::path::Path) -> Result<(), CommandError> {
    use std::fmt::Write as _;
    let lib = Library::load_with_standard(file)?;
    let own = lib.own_declarations();
    let _ = writeln!(
        out,
        "{}: ok ({} declarations of its own: {}; the standard library's {} visible to it)",
        file.display(),
        own.len(),
        own.iter()
            .map(|d| format!("{} {}", d.kind.as_str(), d.name))
            .collect::<Vec<_>>()
            .join(", "),
        lib.declarations().len() - own.len()
    );
    Ok(())
}

/// One line naming the effects a scene calls for.
fn describe_effects(fx: &robosim_library::Effects) -> String {
    let mut parts = Vec::new();
    if fx.kinematics {
        parts.push("kinematics".to_string());
    }
    if fx.joint_limits {
        parts.push("joint limits".to_string());
    }
    if let Some(c) = fx.collision {
        let on = |b: bool| if b { "on" } else { "off" };
        parts.push(format!(
            "collision {:?} (self {}, continuous {})",
            c.mode,
            on(c.self_collision),
            on(c.continuous)
        ));
    }
    if let Some(d) = fx.dynamics {
        let g = d.gravity.unwrap_or_default();
        parts.push(format!(
            "dynamics {:?}, step {} s, gravity [{}, {}, {}] m/s^2",
            d.integrator, d.dt, g[0], g[1], g[2]
        ));
    }
    if let Some(b) = fx.encoder.map(|e| e.bits) {
        parts.push(format!("{b}-bit encoders"));
    }
    if let Some(l) = &fx.logging {
        parts.push(format!("logging {}", l.names().join(", ")));
    }
    if let Some(a) = &fx.automation {
        parts.push(format!(
            "automation plant {} (time scale {})",
            a.model, a.time_scale
        ));
    }
    if parts.is_empty() {
        "none".into()
    } else {
        parts.join("; ")
    }
}
