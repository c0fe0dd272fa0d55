//! The query-protocol ops of collision detection (DESIGN.md, "The query protocol"):
//!
//! * `collide` — `{a, pose_a, b, pose_b, mode?, tolerance?}` → `{verdict, intersect, distance,
//!   signed_distance, witness_a, witness_b, reason?, tessellation_error}`. Shapes in DESIGN.md's
//!   form (`box` size, `sphere` radius, `cylinder`/`cone` radius + height, `convex` points,
//!   `mesh` vertices + polygons), plus `facets` on round shapes and a `compound` extension
//!   (`parts`: shapes each with a `pose`). Poses are 4×4 row-major. `mode`: bbox | polygon |
//!   exact (default exact). `intersect` is `null` when the verdict is `unknown`. `tolerance`
//!   (exact mode): `"certified"` (default: the distance within 1e-11 m) or a number of metres,
//!   GJK's bracket width ([`robosim_collision::Tolerance`]; the verdict stays certified).
//! * `check` — `{robot, q, scene: {objects: [shape + name + pose + use?]}, mode?,
//!   self_collision? (true), all? (false), links?, allowed?, link_radius? (0.04 m)}` →
//!   `{verdict, clear, contacts: [{a, b, signed_distance, witness_a, witness_b}], reason?,
//!   link_solids}`. `depth?` (true): the contacts' depth and witness points (exact mode; `false`
//!   answers the certified boolean alone, `signed_distance` and witnesses `null`), to
//!   `tolerance?` as in `collide`. A body is `{"link": j}` (0 = base) or `{"object": i, "name"}`.
//!   **Link solids**: `links` gives one entry per link, base first (`null` or a shape with a
//!   `pose` in the link frame). A robot without them gets [`LinkSolids::from_dh`] boxes of
//!   half-width `link_radius` along its DH segments; the answer says which was used.
//!
//! A sphere's `facets` is at most [`MAX_SPHERE_FACETS`] (the most its default ever is).
//!
//! Shapes are built once: the ops take solids from a bounded cache keyed by the shape's
//! canonical JSON text ([`cached_solid`]), so a client repeating a shape with new poses pays
//! for parsing and a lookup only. Only what the mode uses is built: an exact-mode `collide`
//! builds a cylinder or cone without the faceted form (the faceted modes build it when they
//! first need it).
//!
//! Errors: `bad_request` (field path and reason), `bad_shape`, `unknown_robot`, `bad_robot`.
//!
//! Entry points: [`dispatch`], [`solid_from_json`], [`pose_from_json`].

use super::RobotArg;
use super::finite::check;
use crate::robot_json::{number, number_array, robot_from_json};
use crate::{ErrorKind, ProtocolError};
use nalgebra::{Isometry3, Point3};
use robosim_collision::Solid;
use robosim_collision::exact::{self, ExactOptions};
use robosim_collision::json::ShapeJsonError;
use robosim_collision::robot::{
    Body, CheckResult, CollisionSettings, LinkSolid, LinkSolids, Scene, check_robot,
};
use robosim_collision::{Mode, PairResult, Tolerance};
use robosim_kinematics::{Robot, builtin_robot};
use serde_json::{Map, Value, json};
use std::borrow::Cow;
use std::collections::HashMap;
use std::sync::{Arc, LazyLock, Mutex, PoisonError};

fn bad(message: impl Into<String>) -> ProtocolError {
    ProtocolError::new(ErrorKind::BadRequest, message)
}

/// `bad_request` with `e`'s message, keeping `e` as the source.
fn caused(e: impl std::error::Error + Send + Sync + 'static) -> ProtocolError {
    ProtocolError::caused(ErrorKind::BadRequest, e)
}

pub use robosim_collision::json::MAX_SPHERE_FACETS;

/// A shape or pose that could not be read: a field is a `bad_request`, a solid the fields do
/// not make (degenerate, ...) a `bad_shape`.
impl From<ShapeJsonError> for ProtocolError {
    fn from(e: ShapeJsonError) -> Self {
        let kind = match &e {
            ShapeJsonError::Field(_) => ErrorKind::BadRequest,
            ShapeJsonError::Shape { .. } => ErrorKind::BadShape,
        };
        ProtocolError::new(kind, e.to_string())
    }
}

/// Answers `collide` and `check`; `None` for any other op.
pub fn dispatch(
    op: &str,
    req: &Value,
    robots: &dyn Fn(&str) -> Option<Robot>,
) -> Option<Result<Value, ProtocolError>> {
    dispatch_with(op, req, RobotArg::Request(robots))
}

/// [`dispatch`] with `check`'s robot given: by the request ([`RobotArg::Request`]) or typed by
/// the caller ([`RobotArg::Given`]; the request's `robot` is not read).
pub fn dispatch_with(
    op: &str,
    req: &Value,
    robot: RobotArg<'_>,
) -> Option<Result<Value, ProtocolError>> {
    match op {
        "collide" => Some(op_collide(req)),
        "check" => Some(op_check(req, robot)),
        _ => None,
    }
}

fn field<'a>(v: &'a Value, key: &str, path: &str) -> Result<&'a Value, ProtocolError> {
    v.get(key)
        .ok_or_else(|| bad(format!("{path}.{key}: missing")))
}

/// A rigid 4×4 pose (row-major nested arrays); refuses non-rigid matrices
/// ([`robosim_collision::json::pose_from_json`]).
pub fn pose_from_json(v: &Value, path: &str) -> Result<Isometry3<f64>, ProtocolError> {
    Ok(robosim_collision::json::pose_from_json(v, path)?)
}

/// A solid from DESIGN.md's shape JSON ([`robosim_collision::json::solid_from_json`]). `extra`
/// lists keys the caller handles (name, pose…).
pub fn solid_from_json(v: &Value, path: &str, extra: &[&str]) -> Result<Solid, ProtocolError> {
    Ok(robosim_collision::json::solid_from_json(v, path, extra)?)
}

/// Solids the ops have built, by canonical shape text, least recently used evicted first.
/// Bounded by entry count and by the total length of the keys (a mesh's text is its size).
struct ShapeCache {
    map: HashMap<String, (Arc<Solid>, u64)>,
    tick: u64,
    key_bytes: usize,
}

/// Most solids kept.
const CACHE_ENTRIES: usize = 512;
/// Most key text kept, bytes (meshes are keyed by their whole description).
const CACHE_KEY_BYTES: usize = 32 << 20;
/// Shapes with a longer description are built every time (never cached).
const MAX_KEY_BYTES: usize = 4 << 20;

impl ShapeCache {
    fn get(&mut self, key: &str) -> Option<Arc<Solid>> {
        self.tick += 1;
        let tick = self.tick;
        self.map.get_mut(key).map(|(s, used)| {
            *used = tick;
            Arc::clone(s)
        })
    }

    fn insert(&mut self, key: String, solid: Arc<Solid>) {
        self.tick += 1;
        if let Some(entry) = self.map.get_mut(&key) {
            // built twice at once (two threads): keep one, count its key once
            *entry = (solid, self.tick);
            return;
        }
        while !self.map.is_empty()
            && (self.map.len() >= CACHE_ENTRIES || self.key_bytes + key.len() > CACHE_KEY_BYTES)
        {
            let oldest = self
                .map
                .iter()
                .min_by_key(|(_, (_, used))| *used)
                .map(|(k, _)| k.clone());
            match oldest.and_then(|k| self.map.remove_entry(&k)) {
                Some((k, _)) => self.key_bytes -= k.len(),
                None => break,
            }
        }
        self.key_bytes += key.len();
        self.map.insert(key, (solid, self.tick));
    }
}

static SHAPES: LazyLock<Mutex<ShapeCache>> = LazyLock::new(|| {
    Mutex::new(ShapeCache {
        map: HashMap::new(),
        tick: 0,
        key_bytes: 0,
    })
});

/// The canonical text of shape `v` without the keys its caller handles (`extra`: name, pose,
/// use…): serde_json's maps are sorted, so equal shapes give equal text.
fn shape_key(v: &Value, extra: &[&str]) -> Option<String> {
    let text = match v.as_object() {
        Some(o) if extra.iter().any(|k| o.contains_key(*k)) => {
            let shape: Map<String, Value> = o
                .iter()
                .filter(|(k, _)| !extra.contains(&k.as_str()))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect();
            serde_json::to_string(&shape).ok()?
        }
        _ => serde_json::to_string(v).ok()?,
    };
    (text.len() <= MAX_KEY_BYTES).then_some(text)
}

/// [`solid_from_json`] through the op cache: a shape described before is not built again.
/// Errors are not cached (the path in the message is the request's).
pub fn cached_solid(v: &Value, path: &str, extra: &[&str]) -> Result<Arc<Solid>, ProtocolError> {
    cached_solid_for(v, path, extra, Mode::Polygon)
}

/// [`cached_solid`] for a request in `mode`: exact mode takes whatever the cache holds and
/// builds a first-seen cylinder or cone without its faceted form, which it never reads
/// ([`robosim_collision::json::exact_solid_from_json`]); the faceted modes take only a solid
/// with its faceted form, and build the whole solid (replacing an exact-only one) when the
/// cache has none.
fn cached_solid_for(
    v: &Value,
    path: &str,
    extra: &[&str],
    mode: Mode,
) -> Result<Arc<Solid>, ProtocolError> {
    let exact_only = mode == Mode::Exact;
    let build = || -> Result<Solid, ProtocolError> {
        Ok(if exact_only {
            robosim_collision::json::exact_solid_from_json(v, path, extra)?
        } else {
            solid_from_json(v, path, extra)?
        })
    };
    let Some(key) = shape_key(v, extra) else {
        return Ok(Arc::new(build()?));
    };
    let lock = || SHAPES.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(s) = lock().get(&key)
        && (exact_only || s.has_faceted_form())
    {
        return Ok(s);
    }
    let s = Arc::new(build()?);
    lock().insert(key, Arc::clone(&s));
    Ok(s)
}

/// `tolerance`: absent, `null` or `"certified"` — the certified distance; a positive number
/// of metres — GJK's bracket width.
fn tolerance_field(req: &Value) -> Result<Tolerance, ProtocolError> {
    match req.get("tolerance") {
        None | Some(Value::Null) => Ok(Tolerance::Certified),
        Some(Value::String(s)) if s == "certified" => Ok(Tolerance::Certified),
        Some(Value::Number(n)) => n
            .as_f64()
            .ok_or_else(|| bad("tolerance: not a number"))
            .and_then(|t| Tolerance::gjk(t).map_err(|e| bad(format!("tolerance: {e}")))),
        Some(_) => Err(bad(
            "tolerance: expected \"certified\" or a positive number of metres",
        )),
    }
}

fn mode_field(req: &Value) -> Result<Mode, ProtocolError> {
    match req.get("mode") {
        None | Some(Value::Null) => Ok(Mode::Exact),
        Some(Value::String(s)) => match s.as_str() {
            "bbox" => Ok(Mode::BBox),
            "polygon" => Ok(Mode::Polygon),
            "exact" => Ok(Mode::Exact),
            _ => Err(bad(format!(
                "mode: \"{s}\" is not one of bbox, polygon, exact"
            ))),
        },
        Some(_) => Err(bad("mode: expected a string")),
    }
}

fn bool_field(req: &Value, key: &str, default: bool) -> Result<bool, ProtocolError> {
    match req.get(key) {
        None | Some(Value::Null) => Ok(default),
        Some(Value::Bool(b)) => Ok(*b),
        Some(_) => Err(bad(format!("{key}: expected true or false"))),
    }
}

fn pt(p: &Point3<f64>) -> Value {
    json!([p.x, p.y, p.z])
}

fn op_collide(req: &Value) -> Result<Value, ProtocolError> {
    let mode = mode_field(req)?;
    let a = cached_solid_for(field(req, "a", "request")?, "a", &[], mode)?;
    let b = cached_solid_for(field(req, "b", "request")?, "b", &[], mode)?;
    let pa = pose_from_json(field(req, "pose_a", "request")?, "pose_a")?;
    let pb = pose_from_json(field(req, "pose_b", "request")?, "pose_b")?;
    let tolerance = tolerance_field(req)?;
    let r = match mode {
        Mode::Exact => exact::collide(
            &a,
            &pa,
            &b,
            &pb,
            ExactOptions {
                tolerance,
                ..ExactOptions::default()
            },
        ),
        _ => robosim_collision::collide(&a, &pa, &b, &pb, mode),
    };
    let (verdict, reason) = match &r {
        PairResult::Clear { .. } => ("clear", None),
        PairResult::Contact { .. } => ("contact", None),
        PairResult::Unknown { reason } => ("unknown", Some(reason.clone())),
    };
    let distance = match &r {
        PairResult::Clear { distance, .. } => distance.map(|d| json!(d)).unwrap_or(Value::Null),
        PairResult::Contact { .. } => json!(0.0),
        PairResult::Unknown { .. } => Value::Null,
    };
    let w = r.witness();
    check("signed_distance", &r.signed_distance())?;
    check("witness", &w)?;
    let mut out = json!({
        "mode": mode.name(),
        "verdict": verdict,
        "intersect": r.intersects(),
        "distance": distance,
        "signed_distance": r.signed_distance(),
        "witness_a": w.map(|w| pt(&w[0])),
        "witness_b": w.map(|w| pt(&w[1])),
        "tessellation_error": [a.tessellation_error, b.tessellation_error],
    });
    if let Some(reason) = reason {
        out["reason"] = json!(reason);
    }
    Ok(out)
}

fn robot_field<'a>(req: &Value, arg: RobotArg<'a>) -> Result<Cow<'a, Robot>, ProtocolError> {
    let robots = match arg {
        RobotArg::Given(robot) => return Ok(Cow::Borrowed(robot)),
        RobotArg::Request(robots) => robots,
    };
    match field(req, "robot", "request")? {
        Value::String(name) => robots(name)
            .or_else(|| builtin_robot(name))
            .map(Cow::Owned)
            .ok_or_else(|| {
                ProtocolError::new(
                    ErrorKind::UnknownRobot,
                    format!("robot: no robot named \"{name}\""),
                )
            }),
        v @ Value::Object(_) => robot_from_json(v)
            .map(Cow::Owned)
            .map_err(|e| ProtocolError::caused(ErrorKind::BadRobot, e)),
        _ => Err(bad(
            "robot: expected a library name or an inline robot object",
        )),
    }
}

fn body_json(b: &Body) -> Value {
    match b {
        Body::Link(j) => json!({"link": j}),
        Body::RobotLink { robot, link } => json!({"robot": robot, "link": link}),
        Body::Object { index, name } => json!({"object": index, "name": name}),
    }
}

fn op_check(req: &Value, arg: RobotArg<'_>) -> Result<Value, ProtocolError> {
    let robot = robot_field(req, arg)?;
    let q = number_array(field(req, "q", "request")?, "q").map_err(caused)?;
    robot.check_q(&q).map_err(|e| bad(format!("q: {e}")))?;
    let mut scene = Scene::new();
    let objs = field(field(req, "scene", "request")?, "objects", "scene")?
        .as_array()
        .ok_or_else(|| bad("scene.objects: expected an array"))?;
    for (i, o) in objs.iter().enumerate() {
        let path = format!("scene.objects[{i}]");
        let solid = cached_solid(o, &path, &["name", "pose", "use"])?;
        let pose = match o.get("pose") {
            None | Some(Value::Null) => Isometry3::identity(),
            Some(p) => pose_from_json(p, &format!("{path}.pose"))?,
        };
        let name = o
            .get("name")
            .and_then(Value::as_str)
            .map_or_else(|| format!("object{i}"), str::to_owned);
        let id = scene.add(name, solid, pose);
        if !bool_field(o, "use", true)? {
            scene.dont_use(id);
        }
    }
    let (links, source) = match req.get("links") {
        None | Some(Value::Null) => {
            let radius = match req.get("link_radius") {
                None | Some(Value::Null) => 0.04,
                Some(v) => number(v, "link_radius").map_err(caused)?,
            };
            let l = LinkSolids::from_dh(&robot, radius)
                .map_err(|e| bad(format!("link_radius: {e}")))?;
            (
                l,
                format!(
                    "assumed: boxes of half-width {radius} m along the DH segments (no link solids given)"
                ),
            )
        }
        Some(Value::Array(arr)) => {
            let mut links = Vec::with_capacity(arr.len());
            for (j, l) in arr.iter().enumerate() {
                if l.is_null() {
                    links.push(None);
                    continue;
                }
                let path = format!("links[{j}]");
                let solid = cached_solid(l, &path, &["pose"])?;
                let offset = match l.get("pose") {
                    None | Some(Value::Null) => Isometry3::identity(),
                    Some(p) => pose_from_json(p, &format!("{path}.pose"))?,
                };
                links.push(Some(LinkSolid { solid, offset }));
            }
            (
                LinkSolids {
                    links,
                    allowed: Vec::new(),
                },
                "given".to_owned(),
            )
        }
        Some(_) => {
            return Err(bad(
                "links: expected an array (base first, one entry per link, null for none)",
            ));
        }
    };
    let mut links = links;
    if let Some(a) = req.get("allowed") {
        let arr = a
            .as_array()
            .ok_or_else(|| bad("allowed: expected an array of [i, j] link pairs"))?;
        for (k, p) in arr.iter().enumerate() {
            let ij = number_array(p, &format!("allowed[{k}]")).map_err(caused)?;
            if ij.len() != 2 || ij.iter().any(|x| *x < 0.0 || x.fract() != 0.0) {
                return Err(bad(format!("allowed[{k}]: expected two link indices")));
            }
            links.allowed.push((ij[0] as usize, ij[1] as usize));
        }
    }
    let settings = CollisionSettings {
        mode: mode_field(req)?,
        self_collision: bool_field(req, "self_collision", true)?,
        all_contacts: bool_field(req, "all", false)?,
        depth: if bool_field(req, "depth", true)? {
            Some(tolerance_field(req)?)
        } else {
            None
        },
        ..CollisionSettings::default()
    };
    let r = check_robot(&robot, &links, &q, &scene, &settings).map_err(caused)?;
    let mut out = json!({"mode": settings.mode.name(), "link_solids": source});
    match r {
        CheckResult::Clear => {
            out["verdict"] = json!("clear");
            out["clear"] = json!(true);
            out["contacts"] = json!([]);
        }
        CheckResult::Contact(cs) => {
            out["verdict"] = json!("contact");
            out["clear"] = json!(false);
            for (i, c) in cs.iter().enumerate() {
                check(
                    &format!("contacts[{i}].signed_distance"),
                    &c.signed_distance,
                )?;
                check(&format!("contacts[{i}].witness"), &c.witness)?;
            }
            out["contacts"] = Value::Array(
                cs.iter()
                    .map(|c| {
                        json!({
                            "a": body_json(&c.a), "b": body_json(&c.b),
                            "signed_distance": c.signed_distance,
                            "witness_a": c.witness.map(|w| pt(&w[0])),
                            "witness_b": c.witness.map(|w| pt(&w[1])),
                        })
                    })
                    .collect(),
            );
        }
        CheckResult::Unknown { a, b, reason } => {
            out["verdict"] = json!("unknown");
            out["clear"] = json!(false);
            out["contacts"] = json!([]);
            out["unknown_pair"] = json!([body_json(&a), body_json(&b)]);
            out["reason"] = json!(reason);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shape_cache_is_keyed_by_the_shape_alone_and_bounded() {
        let a = json!({"shape": "box", "size": [0.123, 0.456, 0.789], "name": "x", "pose": null});
        let b = json!({"shape": "box", "size": [0.123, 0.456, 0.789], "name": "y"});
        let extra = ["name", "pose", "use"];
        assert_eq!(shape_key(&a, &extra), shape_key(&b, &extra));
        let sa = cached_solid(&a, "a", &extra).expect("box");
        let sb = cached_solid(&b, "b", &extra).expect("box");
        assert!(Arc::ptr_eq(&sa, &sb), "built twice");
        // Bounded: the least recently used goes first.
        let mut c = ShapeCache {
            map: HashMap::new(),
            tick: 0,
            key_bytes: 0,
        };
        for i in 0..CACHE_ENTRIES + 10 {
            c.insert(format!("k{i}"), Arc::clone(&sa));
            if i >= 1 {
                // k0 stays the most recently used
                assert!(c.get("k0").is_some(), "{i}");
            }
        }
        assert_eq!(c.map.len(), CACHE_ENTRIES);
        assert!(c.get("k1").is_none(), "the oldest unused entry was kept");
        assert_eq!(c.key_bytes, c.map.keys().map(String::len).sum::<usize>());
    }

    #[test]
    fn exact_mode_builds_no_faceted_form_and_the_faceted_modes_never_get_one_without() {
        // A shape no other test uses (the cache is shared by the process's tests).
        let cyl = json!({"shape": "cylinder", "radius": 0.2345678, "height": 0.5});
        let cone = json!({"shape": "cone", "radius": 0.1534567, "height": 0.4});
        let pose_b = json!([[1, 0, 0, 0.3], [0, 1, 0, 0.05], [0, 0, 1, 0], [0, 0, 0, 1]]);
        let eye = json!([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
        let req = |mode: &str| json!({"a": cyl, "pose_a": eye, "b": cone, "pose_b": pose_b, "mode": mode});
        let exact_first = op_collide(&req("exact")).expect("exact");
        let lean = cached_solid_for(&cyl, "a", &[], Mode::Exact).expect("cached");
        assert!(
            !lean.has_faceted_form(),
            "exact mode built the faceted form"
        );
        // The faceted modes answer as with solids built whole, and replace the cached entry.
        for mode in ["polygon", "bbox"] {
            let got = op_collide(&req(mode)).expect(mode);
            let whole_a = solid_from_json(&cyl, "a", &[]).expect("a");
            let whole_b = solid_from_json(&cone, "b", &[]).expect("b");
            let pa = pose_from_json(&eye, "pose_a").expect("pose");
            let pb = pose_from_json(&pose_b, "pose_b").expect("pose");
            let m = if mode == "bbox" {
                Mode::BBox
            } else {
                Mode::Polygon
            };
            let want = robosim_collision::collide(&whole_a, &pa, &whole_b, &pb, m);
            assert_eq!(got["intersect"], json!(want.intersects()), "{mode}");
            assert_eq!(
                got["signed_distance"],
                json!(want.signed_distance()),
                "{mode}"
            );
        }
        let whole = cached_solid_for(&cyl, "a", &[], Mode::Exact).expect("cached");
        assert!(
            whole.has_faceted_form(),
            "the faceted request's solid was not kept"
        );
        // Exact answers do not depend on which form the cache held.
        assert_eq!(op_collide(&req("exact")).expect("exact"), exact_first);
    }
}
