//! The seed's simulation library (appendix 2.2) on a running session's Instance Space, as ops
//! of the query protocol: `robosim query --session NAME` answers these and passes every other
//! op to the pure query protocol (hl-interface).
//!
//! | op | request | does |
//! |---|---|---|
//! | `get_robot` | robot | the robot as the protocol's inline robot, its link ids and current q |
//! | `movej` | robot, q | MOVEJ: one step, joint limits and (C_SWITCH on) collision checked; writes joints + link poses |
//! | `moveji` | robot, q, steps | MOVEJI: interpolated, limits and collision checked per step; each step one transaction; stops at the last safe step and names the colliding pair |
//! | `pretranslate` / `posttranslate` | object, by [x,y,z] | T·pose (parent frame) / pose·T (own frame) |
//! | `prerotate` / `postrotate` | object, axis [x,y,z], angle | likewise with a rotation |
//! | `kinv` | robot, pose, method?, all? | KINV: IK of the robot where it stands (base = its world pose, q0 = current q) |
//! | `jacob` | robot, frame? | JACOB at the current q |
//! | `encoder` | robot, bits | encoder-quantisation error bound at the current q (seed §2.7) |
//! | `check` | robot | CHECK: the robot at its current q against the objects in use |
//! | `use` / `dontuse` | object | USE / DONTUSE: the object takes part in collision checks or not |
//! | `c_switch` | on, self_collision?, mode? (bbox\|polygon\|exact) | C_SWITCH |
//!
//! Robots and objects are named as in the Instance Space (instance names, e.g. `puma560`).

use crate::bridge;
use nalgebra::{Isometry3, Matrix4, Point3, Vector3};
use robosim_collision::robot::{
    Body, CheckResult, CollisionSettings, LinkSolid, LinkSolids, Scene,
};
use robosim_collision::{Mode, Solid};
use robosim_instance_space::{Client, Id, Kind, Reader, Session, Snapshot, Transaction};
use serde_json::{Value, json};
use std::collections::HashSet;
use std::io::{BufRead, Write};
use std::sync::Arc;

type OpResult = std::result::Result<Value, (String, String)>;

fn err(kind: &str, message: impl Into<String>) -> (String, String) {
    (kind.to_owned(), message.into())
}

/// Session state of one query stream: its attachments and the seed's collision switches.
pub struct Ops {
    reader: Reader,
    client: Client,
    settings: CollisionSettings,
    unused: HashSet<Id>,
}

pub const OPS: &[&str] = &[
    "get_robot",
    "movej",
    "moveji",
    "pretranslate",
    "posttranslate",
    "prerotate",
    "postrotate",
    "kinv",
    "jacob",
    "encoder",
    "check",
    "use",
    "dontuse",
    "c_switch",
];

fn to_m4(p: &[f64; 12]) -> Matrix4<f64> {
    Matrix4::new(
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], 0.0, 0.0, 0.0,
        1.0,
    )
}

fn pose_rows(p: &[f64; 12]) -> Value {
    json!([
        [p[0], p[1], p[2], p[3]],
        [p[4], p[5], p[6], p[7]],
        [p[8], p[9], p[10], p[11]],
        [0.0, 0.0, 0.0, 1.0]
    ])
}

fn iso(p: &[f64; 12]) -> Isometry3<f64> {
    robosim_collision::robot::isometry_from_matrix(&to_m4(p))
}

fn str_field<'a>(req: &'a Value, f: &str) -> std::result::Result<&'a str, (String, String)> {
    req.get(f)
        .and_then(Value::as_str)
        .ok_or_else(|| err("bad_request", format!("`{f}` must be a string")))
}

fn vec_field(req: &Value, f: &str) -> std::result::Result<Vec<f64>, (String, String)> {
    let arr = req
        .get(f)
        .and_then(Value::as_array)
        .ok_or_else(|| err("bad_request", format!("`{f}` must be an array of numbers")))?;
    arr.iter()
        .enumerate()
        .map(|(i, v)| {
            v.as_f64()
                .filter(|x| x.is_finite())
                .ok_or_else(|| err("bad_request", format!("`{f}[{i}]` is not a finite number")))
        })
        .collect()
}

/// A robot of the snapshot, placed where it stands, with its collision geometry.
pub(crate) struct Placed {
    pub robot: robosim_kinematics::Robot,
    pub links: Vec<Id>,
    pub q: Vec<f64>,
    pub subtree: HashSet<Id>,
    pub solids: LinkSolids,
}

/// The collision solid of one Instance Space object's geometry (convex hull when convex,
/// else a mesh).
fn solid_of(snap: &Snapshot, i: usize) -> Option<Solid> {
    let g = snap.geometry(i)?;
    let pts: Vec<Point3<f64>> = g
        .vertices
        .iter()
        .map(|v| Point3::new(v[0], v[1], v[2]))
        .collect();
    let convex = g.polygons.iter().all(|p| {
        pts.iter()
            .all(|v| p.plane[0] * v.x + p.plane[1] * v.y + p.plane[2] * v.z + p.plane[3] <= 1e-9)
    });
    if convex {
        Solid::convex(&pts).ok()
    } else {
        let polys: Vec<Vec<u32>> = g
            .polygons
            .iter()
            .map(|p| g.indices[p.start as usize..(p.start + p.len) as usize].to_vec())
            .collect();
        Solid::mesh(pts, &polys).ok()
    }
}

fn children(snap: &Snapshot, id: Id) -> Vec<usize> {
    (0..snap.len())
        .filter(|&k| snap.objects()[k].parent == id)
        .collect()
}

/// The solids under object `id` (recursively), posed relative to `id`'s frame.
fn solids_under(snap: &Snapshot, id: Id, skip_links: bool) -> Vec<(Isometry3<f64>, Solid)> {
    let mut out = Vec::new();
    let mut stack: Vec<(usize, Isometry3<f64>)> = children(snap, id)
        .into_iter()
        .map(|k| (k, Isometry3::identity()))
        .collect();
    while let Some((k, parent)) = stack.pop() {
        let o = snap.object(k);
        if skip_links && o.kind() == Some(Kind::Link) {
            continue;
        }
        let here = parent * iso(&o.pose.pose);
        if let Some(s) = solid_of(snap, k) {
            out.push((here, s));
        }
        stack.extend(children(snap, o.rec.id).into_iter().map(|c| (c, here)));
    }
    out
}

fn link_solid(parts: Vec<(Isometry3<f64>, Solid)>) -> Option<LinkSolid> {
    match parts.len() {
        0 => None,
        1 => parts.into_iter().next().map(|(offset, s)| LinkSolid {
            solid: Arc::new(s),
            offset,
        }),
        _ => Solid::compound(parts).ok().map(|s| LinkSolid {
            solid: Arc::new(s),
            offset: Isometry3::identity(),
        }),
    }
}

fn subtree(snap: &Snapshot, top: Id) -> HashSet<Id> {
    let mut set = HashSet::from([top]);
    let mut grew = true;
    while grew {
        grew = false;
        for o in snap.objects() {
            if set.contains(&o.parent) && set.insert(o.id) {
                grew = true;
            }
        }
    }
    set
}

pub(crate) fn placed(snap: &Snapshot, name: &str) -> std::result::Result<Placed, (String, String)> {
    let i = (0..snap.len())
        .find(|&i| snap.name(i) == name && snap.object(i).kind() == Some(Kind::Robot))
        .ok_or_else(|| {
            let names: Vec<&str> = (0..snap.len())
                .filter(|&i| snap.object(i).kind() == Some(Kind::Robot))
                .map(|i| snap.name(i))
                .collect();
            err(
                "unknown_robot",
                format!(
                    "no robot named {name:?} in the session; robots: {}",
                    names.join(", ")
                ),
            )
        })?;
    let id = snap.objects()[i].id;
    let r = bridge::robots(snap)
        .into_iter()
        .find(|r| {
            r.robot.name == name
                && r.links.first().is_none_or(|l| {
                    snap.index_of(*l)
                        .is_some_and(|k| snap.objects()[k].parent == id)
                })
        })
        .ok_or_else(|| err("unknown_robot", format!("robot {name:?} has no joints")))?;
    let mut robot = r.robot;
    robot.base = to_m4(&snap.world_pose(i));
    let rec = &snap.objects()[i];
    robot.tool = if rec.kin_tag == robosim_instance_space::layout::flags::KIN_ROBOT {
        to_m4(&rec.tool)
    } else {
        Matrix4::identity()
    };
    let mut links = vec![link_solid(solids_under(snap, id, true))];
    for l in &r.links {
        links.push(link_solid(solids_under(snap, *l, false)));
    }
    let mut solids = LinkSolids {
        links,
        allowed: Vec::new(),
    };
    // Allowed pairs (the seed's robot-declared exceptions; MoveIt's "default" collisions):
    // link solids that already overlap at the DH zero configuration are structural contacts of
    // the model (a housing around a joint), not events. Adjacent links are skipped by the
    // checker itself.
    let zero = vec![0.0; robot.dof()];
    let self_only = CollisionSettings {
        all_contacts: true,
        ..CollisionSettings::default()
    };
    if let Ok(CheckResult::Contact(cs)) =
        robosim_collision::robot::check_robot(&robot, &solids, &zero, &Scene::new(), &self_only)
    {
        for c in cs {
            if let (Body::Link(a), Body::Link(b)) = (&c.a, &c.b) {
                solids.allowed.push(((*a).min(*b), (*a).max(*b)));
            }
        }
    }
    Ok(Placed {
        robot,
        links: r.links,
        q: r.q,
        subtree: subtree(snap, id),
        solids,
    })
}

/// Objects with geometry under `top` (itself included), not descending into other links.
fn bodies_under(snap: &Snapshot, top: Id) -> Vec<Id> {
    let mut out = Vec::new();
    let mut stack = vec![top];
    while let Some(id) = stack.pop() {
        if let Some(i) = snap.index_of(id)
            && snap.geometry(i).is_some()
        {
            out.push(id);
        }
        for k in children(snap, id) {
            if snap.object(k).kind() != Some(Kind::Link) {
                stack.push(snap.objects()[k].id);
            }
        }
    }
    out
}

/// Every object with geometry in contact, for the display's collision highlight: each robot
/// of the snapshot checked at its current q against itself (allowed pairs excepted) and the
/// objects outside it (exact mode, all contacts). Robots that cannot be placed are skipped.
pub(crate) fn colliding_ids(snap: &Snapshot) -> HashSet<Id> {
    let settings = CollisionSettings {
        all_contacts: true,
        ..CollisionSettings::default()
    };
    let mut hit = HashSet::new();
    for i in 0..snap.len() {
        if snap.object(i).kind() != Some(Kind::Robot) {
            continue;
        }
        let robot_id = snap.objects()[i].id;
        let Ok(p) = placed(snap, snap.name(i)) else {
            continue;
        };
        let (scene, _, ids) = obstacles(snap, &p, &HashSet::new());
        let Ok(CheckResult::Contact(cs)) =
            robosim_collision::robot::check_robot(&p.robot, &p.solids, &p.q, &scene, &settings)
        else {
            continue;
        };
        for c in cs {
            for b in [&c.a, &c.b] {
                match b {
                    Body::Link(0) => {
                        // The base: the robot's own solids that are not under a link.
                        for k in children(snap, robot_id) {
                            if snap.object(k).kind() != Some(Kind::Link) {
                                hit.extend(bodies_under(snap, snap.objects()[k].id));
                            }
                        }
                    }
                    Body::Link(j) => {
                        if let Some(l) = p.links.get(j - 1) {
                            hit.extend(bodies_under(snap, *l));
                        }
                    }
                    Body::Object { index, .. } => hit.extend(ids.get(*index).copied()),
                    Body::RobotLink { .. } => {}
                }
            }
        }
    }
    hit
}

fn body(b: &Body, p: &Placed, snap: &Snapshot, scene_names: &[String]) -> Value {
    match b {
        Body::Link(0) => json!({"robot": p.robot.name, "link": 0, "name": "base"}),
        Body::Link(j) => {
            json!({"robot": p.robot.name, "link": j, "name": p.links.get(j - 1).and_then(|id| snap.index_of(*id)).map_or("", |k| snap.name(k))})
        }
        Body::Object { index, .. } => {
            json!({"object": scene_names.get(*index).cloned().unwrap_or_default()})
        }
        Body::RobotLink { robot, link } => json!({"robot": robot, "link": link}),
    }
}

fn contacts(res: &CheckResult, p: &Placed, snap: &Snapshot, names: &[String]) -> Value {
    match res {
        CheckResult::Clear => json!({"status": "clear"}),
        CheckResult::Contact(cs) => {
            json!({"status": "contact", "contacts": cs.iter().map(|c| json!({
            "a": body(&c.a, p, snap, names), "b": body(&c.b, p, snap, names),
            "signed_distance": c.signed_distance,
            "witness": c.witness.map(|w| [[w[0].x, w[0].y, w[0].z], [w[1].x, w[1].y, w[1].z]]),
        })).collect::<Vec<_>>()})
        }
        CheckResult::Unknown { a, b, reason } => {
            json!({"status": "unknown", "a": body(a, p, snap, names), "b": body(b, p, snap, names), "reason": reason})
        }
    }
}

impl Ops {
    pub fn attach(session: &Session) -> crate::Result<Self> {
        Ok(Ops {
            reader: Reader::attach(session, "query")?,
            client: Client::connect(session, "query")?,
            settings: CollisionSettings::default(),
            unused: HashSet::new(),
        })
    }

    fn snap(&mut self) -> std::result::Result<std::rc::Rc<Snapshot>, (String, String)> {
        self.reader
            .refresh()
            .map_err(|e| err("session", e.to_string()))?;
        self.reader
            .snapshot()
            .ok_or_else(|| err("session", "no snapshot"))
    }

    fn scene(&self, snap: &Snapshot, p: &Placed) -> (Scene, Vec<String>) {
        let (scene, names, _) = obstacles(snap, p, &self.unused);
        (scene, names)
    }
}

/// The objects a robot can hit: every solid outside its own subtree and not in `unused`,
/// named by path.
pub(crate) fn obstacles(
    snap: &Snapshot,
    p: &Placed,
    unused: &HashSet<Id>,
) -> (Scene, Vec<String>, Vec<Id>) {
    {
        let mut scene = Scene::new();
        let mut names = Vec::new();
        let mut ids = Vec::new();
        for i in 0..snap.len() {
            let o = &snap.objects()[i];
            if p.subtree.contains(&o.id) || unused.contains(&o.id) {
                continue;
            }
            if let Some(s) = solid_of(snap, i) {
                // Named by path from its top object (`head/cylinder1`), as the seed's collision
                // structure names the object.
                let mut path = snap.name(i).to_owned();
                let mut parent = o.parent;
                while let Some(k) = (parent != 0).then(|| snap.index_of(parent)).flatten() {
                    path = format!("{}/{path}", snap.name(k));
                    parent = snap.objects()[k].parent;
                }
                scene.add(path.as_str(), Arc::new(s), iso(&snap.world_pose(i)));
                names.push(path);
                ids.push(o.id);
            }
        }
        (scene, names, ids)
    }
}

impl Ops {
    fn write_q(&mut self, p: &Placed, q: &[f64]) -> std::result::Result<u64, (String, String)> {
        let tx = bridge::joint_tx(&p.robot, &p.links, q);
        self.client
            .transact(&tx)
            .map(|a| a.version)
            .map_err(|e| err("transaction", e.to_string()))
    }

    fn pure(req: Value) -> OpResult {
        let text = robosim_hl_interface::handle_request(&req);
        let mut v: Value =
            serde_json::from_str(&text).map_err(|e| err("internal", e.to_string()))?;
        if v.get("ok").and_then(Value::as_bool) == Some(true) {
            if let Some(m) = v.as_object_mut() {
                m.remove("ok");
                m.remove("id");
            }
            Ok(v)
        } else {
            let e = v.get("error").cloned().unwrap_or(Value::Null);
            Err((
                e.get("kind")
                    .and_then(Value::as_str)
                    .unwrap_or("error")
                    .to_owned(),
                e.get("message")
                    .and_then(Value::as_str)
                    .unwrap_or("")
                    .to_owned(),
            ))
        }
    }

    /// Answers `op` if it is a session op.
    pub fn dispatch(&mut self, op: &str, req: &Value) -> Option<OpResult> {
        if !OPS.contains(&op) {
            return None;
        }
        Some(self.answer(op, req))
    }

    fn answer(&mut self, op: &str, req: &Value) -> OpResult {
        let snap = self.snap()?;
        match op {
            "use" | "dontuse" => {
                let name = str_field(req, "object")?;
                let i = snap
                    .find(name)
                    .ok_or_else(|| err("unknown_object", format!("no object named {name:?}")))?;
                let id = snap.objects()[i].id;
                if op == "use" {
                    self.unused.remove(&id);
                } else {
                    self.unused.insert(id);
                }
                Ok(json!({"object": name, "in_use": op == "use"}))
            }
            "c_switch" => {
                let on = req
                    .get("on")
                    .and_then(Value::as_bool)
                    .ok_or_else(|| err("bad_request", "`on` must be true or false"))?;
                self.settings.enabled = on;
                if let Some(s) = req.get("self_collision").and_then(Value::as_bool) {
                    self.settings.self_collision = s;
                }
                if let Some(m) = req.get("mode").and_then(Value::as_str) {
                    self.settings.mode = match m {
                        "bbox" => Mode::BBox,
                        "polygon" => Mode::Polygon,
                        "exact" => Mode::Exact,
                        other => {
                            return Err(err(
                                "bad_request",
                                format!("mode {other:?}: expected bbox, polygon or exact"),
                            ));
                        }
                    };
                }
                Ok(
                    json!({"collision": self.settings.enabled, "self_collision": self.settings.self_collision, "mode": format!("{:?}", self.settings.mode).to_lowercase()}),
                )
            }
            "pretranslate" | "posttranslate" | "prerotate" | "postrotate" => {
                let name = str_field(req, "object")?;
                let i = snap
                    .find(name)
                    .ok_or_else(|| err("unknown_object", format!("no object named {name:?}")))?;
                let t = if op.ends_with("translate") {
                    let v = vec_field(req, "by")?;
                    if v.len() != 3 {
                        return Err(err("bad_request", "`by` must have 3 numbers"));
                    }
                    Isometry3::translation(v[0], v[1], v[2])
                } else {
                    let axis = vec_field(req, "axis")?;
                    let angle = req
                        .get("angle")
                        .and_then(Value::as_f64)
                        .filter(|a| a.is_finite())
                        .ok_or_else(|| {
                            err("bad_request", "`angle` must be a finite number (rad)")
                        })?;
                    let a = Vector3::new(
                        *axis.first().unwrap_or(&0.0),
                        *axis.get(1).unwrap_or(&0.0),
                        *axis.get(2).unwrap_or(&0.0),
                    );
                    if axis.len() != 3 || a.norm() < 1e-12 {
                        return Err(err("bad_request", "`axis` must be 3 numbers, not all zero"));
                    }
                    Isometry3::new(Vector3::zeros(), a.normalize() * angle)
                };
                let cur = iso(&snap.poses()[i].pose);
                let new = if op.starts_with("pre") {
                    t * cur
                } else {
                    cur * t
                };
                let pose = crate::instantiate::pose(&new.to_homogeneous());
                let mut tx = Transaction::new();
                tx.set_pose(snap.objects()[i].id, pose);
                let v = self
                    .client
                    .transact(&tx)
                    .map_err(|e| err("transaction", e.to_string()))?
                    .version;
                Ok(json!({"object": name, "pose": pose_rows(&pose), "version": v}))
            }
            _ => self.robot_op(op, req, &snap),
        }
    }

    fn robot_op(&mut self, op: &str, req: &Value, snap: &Snapshot) -> OpResult {
        let p = placed(snap, str_field(req, "robot")?)?;
        let inline = robosim_hl_interface::robot_json::robot_to_json(&p.robot);
        match op {
            "get_robot" => {
                let links: Vec<Value> = p.links.iter().map(|id| json!({"id": id, "name": snap.index_of(*id).map_or("", |k| snap.name(k))})).collect();
                Ok(
                    json!({"robot": inline, "q": p.q, "links": links, "allowed_pairs": p.solids.allowed}),
                )
            }
            "kinv" => {
                let mut r = req.clone();
                if let Some(m) = r.as_object_mut() {
                    m.insert("op".into(), json!("ik"));
                    m.insert("robot".into(), inline);
                    m.entry("q0").or_insert(json!(p.q));
                }
                Self::pure(r)
            }
            "jacob" => Self::pure(
                json!({"op": "jacobian", "robot": inline, "q": p.q, "frame": req.get("frame").cloned().unwrap_or(json!("base"))}),
            ),
            "encoder" => Self::pure(
                json!({"op": "encoder_error", "robot": inline, "q": p.q, "bits": req.get("bits").cloned().unwrap_or(Value::Null)}),
            ),
            "check" => {
                let (scene, names) = self.scene(snap, &p);
                let res = robosim_collision::robot::check_robot(
                    &p.robot,
                    &p.solids,
                    &p.q,
                    &scene,
                    &self.settings,
                )
                .map_err(|e| err("check", e.to_string()))?;
                Ok(contacts(&res, &p, snap, &names))
            }
            "movej" | "moveji" => {
                let q = vec_field(req, "q")?;
                p.robot
                    .check_q(&q)
                    .map_err(|e| err("bad_request", e.to_string()))?;
                let steps = if op == "movej" {
                    1
                } else {
                    req.get("steps")
                        .and_then(Value::as_u64)
                        .filter(|s| *s > 0 && *s <= 100_000)
                        .ok_or_else(|| {
                            err("bad_request", "`steps` must be an integer in 1..=100000")
                        })? as usize
                };
                // Joint limits at every step (MOVEJI's check), before anything moves.
                let path = robosim_kinematics::movej_interpolate(&p.robot, &p.q, &q, steps)
                    .map_err(|e| err("joint_limit", e.to_string()))?;
                let (scene, names) = self.scene(snap, &p);
                let outcome = robosim_collision::robot::move_checked(
                    &p.robot,
                    &p.solids,
                    &p.q,
                    &q,
                    steps,
                    &scene,
                    &self.settings,
                )
                .map_err(|e| err("check", e.to_string()))?;
                let mut version = snap.version();
                for step in path.iter().take(outcome.steps_done) {
                    version = self.write_q(&p, step)?;
                }
                Ok(json!({
                    "completed": outcome.completed,
                    "steps_done": outcome.steps_done,
                    "q": path.get(outcome.steps_done.wrapping_sub(1)).cloned().unwrap_or(p.q.clone()),
                    "version": version,
                    "stopped_by": outcome.stopped_by.as_ref().map(|r| contacts(r, &p, snap, &names)),
                    "collision_checked": self.settings.enabled,
                }))
            }
            other => Err(err("unknown_op", format!("op {other:?}"))),
        }
    }
}

/// `robosim query --session NAME`: the session ops, offered to hl-interface's `serve_with`
/// as an extension (so framing, bad lines, panics and flushing behave exactly as in the pure
/// protocol); every other op goes to the crates.
pub fn serve(session: &Session, input: impl BufRead, output: impl Write) -> crate::Result<()> {
    let mut ops = Ops::attach(session)?;
    let listing: Vec<(&str, &str)> = OPS.iter().map(|op| (*op, "session")).collect();
    let mut answer =
        |op: &str,
         req: &Value|
         -> Option<std::result::Result<Value, robosim_hl_interface::ProtocolError>> {
            ops.dispatch(op, req).map(|r| {
                r.map_err(|(kind, message)| robosim_hl_interface::ProtocolError {
                    kind: robosim_hl_interface::ErrorKind::from_wire(&kind),
                    message,
                })
            })
        };
    robosim_hl_interface::serve_with(
        input,
        output,
        robosim_hl_interface::Extension {
            ops: &listing,
            answer: &mut answer,
        },
    )?;
    Ok(())
}
