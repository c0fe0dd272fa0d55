//! Library ops of the query protocol (DESIGN.md, "The query protocol"): list the library,
//! show a declaration's parameters, evaluate a declaration to plain data. Each op reads the
//! standard library unless the request names a `file`.
//!
//! | op | request | answer |
//! |---|---|---|
//! | `lib_list` | file? | declarations: [{name, kind, doc, location}] |
//! | `lib_params` | name, file? | params: [{name, default, default_si, unit, kind}] |
//! | `lib_evaluate` | name, params? {NAME: SI number or expression string}, facets?, geometry? (default true), file? | kind and, by kind: robot (the protocol's inline robot), link_names, ik, frames (solids per frame); scene: robots [{name, robot, q, solids}], solids, effects; solid: parts, mass |
//!
//! Robots are written in the protocol's inline form: `convention`, `joints` [{type, a, d,
//! alpha, theta, offset, qlim, mass, com, inertia (3×3 rows), motor_inertia, viscous,
//! coulomb}], `gravity`, `base` and `tool` (4×4, row-major nested arrays).

use super::finite::check;
use crate::robot_json::{matrix_to_json, matrix4_to_json, robot_to_json};
use crate::{ErrorKind, ProtocolError};
use robosim_instance_space::error_chain;
use robosim_kinematics::Robot;
use robosim_library::{Effects, Evaluated, Library, Params, PlacedSolid};
use serde_json::{Value, json};

/// Answers `op` if it is a library op (`None` otherwise). `robots` is unused: library ops
/// resolve names in the library itself.
pub fn dispatch(
    op: &str,
    req: &Value,
    robots: &dyn Fn(&str) -> Option<Robot>,
) -> Option<Result<Value, ProtocolError>> {
    let _ = robots;
    match op {
        "lib_list" | "lib_params" | "lib_evaluate" => Some(answer(op, req)),
        _ => None,
    }
}

fn answer(op: &str, req: &Value) -> Result<Value, ProtocolError> {
    let owned;
    let lib: &Library = match req.get("file") {
        None | Some(Value::Null) => robosim_library::standard_library().ok_or_else(|| {
            ProtocolError::new(
                ErrorKind::LibraryError,
                "the standard library failed to load",
            )
        })?,
        Some(Value::String(f)) => {
            owned = Library::load_with_standard(f)
                .map_err(|e| ProtocolError::new(ErrorKind::LibraryError, error_chain(&e)))?;
            &owned
        }
        Some(other) => {
            return Err(ProtocolError::new(
                ErrorKind::BadRequest,
                format!("`file` must be a string, got {other}"),
            ));
        }
    };
    let name = || -> Result<&str, ProtocolError> {
        req.get("name").and_then(Value::as_str).ok_or_else(|| {
            ProtocolError::new(ErrorKind::BadRequest, "missing `name` (a declaration name)")
        })
    };
    let lib_err = |e: robosim_library::Error| {
        let kind = match e {
            robosim_library::Error::NoSuchDeclaration { .. } => ErrorKind::UnknownDeclaration,
            robosim_library::Error::NoSuchParameter { .. }
            | robosim_library::Error::BadParameter { .. } => ErrorKind::BadParameter,
            robosim_library::Error::Source(ref s)
                if s.kind == robosim_library::ErrorKind::Overflow =>
            {
                ErrorKind::Overflow
            }
            _ => ErrorKind::LibraryError,
        };
        ProtocolError::new(kind, error_chain(&e))
    };
    match op {
        "lib_list" => Ok(json!({ "declarations": lib.declarations() })),
        "lib_params" => {
            Ok(json!({ "name": name()?, "params": lib.params(name()?).map_err(lib_err)? }))
        }
        _ => {
            let mut params = Params::new();
            match req.get("params") {
                None | Some(Value::Null) => {}
                Some(Value::Object(m)) => {
                    for (k, v) in m {
                        params = match v {
                            Value::Number(n) => params.si(k, n.as_f64().unwrap_or(f64::NAN)),
                            Value::String(s) => params.expr(k, s),
                            other => {
                                return Err(ProtocolError::new(
                                    ErrorKind::BadRequest,
                                    format!(
                                        "parameter `{k}`: give an SI number or an expression string, got {other}"
                                    ),
                                ));
                            }
                        };
                    }
                }
                Some(other) => {
                    return Err(ProtocolError::new(
                        ErrorKind::BadRequest,
                        format!("`params` must be an object, got {other}"),
                    ));
                }
            }
            let facets = match req.get("facets") {
                None | Some(Value::Null) => None,
                Some(v) => Some(
                    v.as_u64()
                        .filter(|n| (3..=robosim_geometry::shapes::FACET_LIMIT as u64).contains(n))
                        .ok_or_else(|| {
                            ProtocolError::new(
                                ErrorKind::BadRequest,
                                format!(
                                    "`facets` must be a whole number in [3, {}]",
                                    robosim_geometry::shapes::FACET_LIMIT
                                ),
                            )
                        })? as usize,
                ),
            };
            let geometry = req.get("geometry").and_then(Value::as_bool).unwrap_or(true);
            let e = lib
                .evaluate_with(
                    name()?,
                    &params,
                    &robosim_library::EvalOptions {
                        facets,
                        max_polygons: None,
                    },
                )
                .map_err(lib_err)?;
            check_evaluated(&e)?;
            Ok(evaluated_json(&e, geometry))
        }
    }
}

fn primitive_json(p: &robosim_library::Primitive) -> Value {
    use robosim_library::Primitive as P;
    match p {
        P::Box { size } => json!({"shape": "box", "size": size}),
        P::Cylinder {
            radius,
            height,
            facets,
        } => json!({"shape": "cylinder", "radius": radius, "height": height, "facets": facets}),
        P::Cone {
            radius,
            height,
            facets,
        } => json!({"shape": "cone", "radius": radius, "height": height, "facets": facets}),
        P::TruncatedCone {
            bottom,
            top,
            height,
            facets,
        } => {
            json!({"shape": "truncated_cone", "bottom": bottom, "top": top, "height": height, "facets": facets})
        }
        P::Sphere { radius, facets } => {
            json!({"shape": "sphere", "radius": radius, "facets": facets})
        }
        P::Extrusion { points, height } => {
            json!({"shape": "extrusion", "points": points, "height": height})
        }
        P::Revolution {
            points,
            angle,
            facets,
        } => json!({"shape": "revolution", "points": points, "angle": angle, "facets": facets}),
    }
}

/// The numbers the evaluation made beyond its expressions (which the library checks itself):
/// placed solids' transforms and vertices, mass properties.
fn check_evaluated(e: &Evaluated) -> Result<(), ProtocolError> {
    let solid = |what: &str, p: &PlacedSolid| -> Result<(), ProtocolError> {
        check(&format!("{what}.transform"), &p.transform)?;
        check(
            &format!("{what}.vertices"),
            p.polyhedron.vertices.as_slice(),
        )
    };
    let frames = |what: &str, frames: &[Vec<PlacedSolid>]| -> Result<(), ProtocolError> {
        for (f, parts) in frames.iter().enumerate() {
            for (i, p) in parts.iter().enumerate() {
                solid(&format!("{what}frames[{f}][{i}]"), p)?;
            }
        }
        Ok(())
    };
    match e {
        Evaluated::Robot(r) | Evaluated::Link(r) => frames("", &r.frames),
        Evaluated::Scene(s) => {
            for r in &s.robots {
                check(&format!("robots[{}].placement", r.name), &r.placement)?;
                frames(&format!("robots[{}].", r.name), &r.model.frames)?;
            }
            for i in &s.solids {
                check(&format!("solids[{}].placement", i.name), &i.placement)?;
                for (k, p) in i.solid.parts.iter().enumerate() {
                    solid(&format!("solids[{}].parts[{k}]", i.name), p)?;
                }
            }
            Ok(())
        }
        Evaluated::Solid(s) => {
            for (k, p) in s.parts.iter().enumerate() {
                solid(&format!("parts[{k}]"), p)?;
            }
            if let Some(m) = &s.mass {
                check("mass.mass", &m.mass)?;
                check("mass.volume", &m.volume)?;
                check("mass.com", &m.center_of_mass)?;
                check("mass.inertia", &m.inertia)?;
            }
            Ok(())
        }
        Evaluated::Constant { value, .. } => check("value", value),
        Evaluated::Colour { .. } | Evaluated::Surface(_) => Ok(()),
    }
}

fn solid_json(p: &PlacedSolid, geometry: bool) -> Value {
    let mut v = json!({
        "name": p.name,
        "primitive": primitive_json(&p.primitive),
        "transform": matrix4_to_json(&p.transform),
        "colour": p.colour,
        "surface": p.surface,
    });
    if geometry {
        let poly = &p.polyhedron;
        v["vertices"] = json!(
            poly.vertices
                .iter()
                .map(|x| [x.x, x.y, x.z])
                .collect::<Vec<_>>()
        );
        v["polygons"] = json!(
            (0..poly.polygons.len())
                .map(|i| poly.polygon_indices(i).to_vec())
                .collect::<Vec<_>>()
        );
    }
    v
}

fn frames_json(frames: &[Vec<PlacedSolid>], geometry: bool) -> Value {
    json!(
        frames
            .iter()
            .map(|f| f
                .iter()
                .map(|p| solid_json(p, geometry))
                .collect::<Vec<_>>())
            .collect::<Vec<_>>()
    )
}

fn effects_json(fx: &Effects) -> Value {
    serde_json::to_value(fx).unwrap_or(Value::Null)
}

fn evaluated_json(e: &Evaluated, geometry: bool) -> Value {
    match e {
        Evaluated::Robot(r) | Evaluated::Link(r) => json!({
            "kind": if matches!(e, Evaluated::Robot(_)) { "robot" } else { "link" },
            "robot": robot_to_json(&r.robot),
            "link_names": r.link_names,
            "ik": r.ik,
            "frames": frames_json(&r.frames, geometry),
        }),
        Evaluated::Scene(s) => json!({
            "kind": "scene",
            "name": s.name,
            "robots": s.robots.iter().map(|r| json!({
                "name": r.name, "robot": robot_to_json(&r.model.robot), "q": r.q, "placement": matrix4_to_json(&r.placement),
                "link_names": r.model.link_names, "ik": r.model.ik, "frames": frames_json(&r.model.frames, geometry),
            })).collect::<Vec<_>>(),
            "solids": s.solids.iter().map(|i| json!({
                "name": i.name, "placement": matrix4_to_json(&i.placement),
                "parts": i.solid.parts.iter().map(|p| solid_json(p, geometry)).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "effects": effects_json(&s.effects),
        }),
        Evaluated::Solid(s) => json!({
            "kind": "solid",
            "name": s.name,
            "parts": s.parts.iter().map(|p| solid_json(p, geometry)).collect::<Vec<_>>(),
            "mass": s.mass.map(|m| json!({"mass": m.mass, "volume": m.volume, "com": [m.center_of_mass.x, m.center_of_mass.y, m.center_of_mass.z], "inertia": matrix_to_json(&m.inertia)})),
        }),
        Evaluated::Constant { value, unit } => {
            json!({ "kind": "constant", "value": value, "unit": unit })
        }
        Evaluated::Colour { rgb } => json!({ "kind": "colour", "rgb": rgb }),
        Evaluated::Surface(s) => json!({ "kind": "surface", "surface": s }),
    }
}
