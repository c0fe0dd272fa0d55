//! The seed's simulation library (appendix 2.2) on a running session's Instance Space, as ops
//! of the query protocol: `robosim query --session NAME` answers these and passes every other
//! op to the pure query protocol. [`Ops`] is also the library form a client embeds (the Python
//! package, a Rust planner): attach to a session, then [`Ops::dispatch`] requests.
//!
//! The robots and obstacles come from a [`CompiledScene`] kept across requests: compiled once
//! per structure version, updated in place when only joints and poses changed — so MOVEJ,
//! CHECK and KINV after a MOVEJI do not re-decode or re-hull anything.
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
//! | `check` | robot (only) | CHECK: the robot at its current q against the objects in use |
//! | `use` / `dontuse` | object | USE / DONTUSE: the object takes part in collision checks or not |
//! | `c_switch` | on, self_collision?, mode? (bbox\|polygon\|exact) | C_SWITCH |
//! | `sim_state` | — | the running simulator's state: the answer of `robosim simctl get` (time, steps, mode, per robot q, qd, τ, target, contact) |
//!
//! Robots and objects are named as in the Instance Space (instance names, e.g. `puma560`).
//!
//! An op that is both a session op and a pure op (`check`, see [`SHARED`]) is routed by the
//! request's form alone, never by what the session holds: a request that brings the pure op's
//! own data (`q` or `scene`, or an inline robot object) is the pure op's, so a pure request
//! means the same with and without `--session`; one that only names a robot is the session's.

use crate::protocol::RobotArg;
use crate::{ErrorKind, ProtocolError};
use nalgebra::{Isometry3, Vector3};
use robosim_collision::Mode;
use robosim_collision::robot::{Body, CheckResult, CollisionSettings};
use robosim_instance_space::{Client, Id, Reader, Session, Snapshot, Transaction, aspect};
use robosim_kinematics::Robot;
use robosim_kinematics::mimic::Coupling;
use robosim_scene::{CompiledRobot, CompiledScene, Obstacles, SceneError, joint_tx, pose};
use serde_json::{Value, json};
use std::collections::HashSet;
use std::io::{BufRead, Write};

type OpResult = std::result::Result<Value, ProtocolError>;

fn err(kind: ErrorKind, message: impl Into<String>) -> ProtocolError {
    ProtocolError::new(kind, message)
}

fn scene_err(e: SceneError) -> ProtocolError {
    let kind = match e {
        SceneError::UnknownRobot { .. } | SceneError::NoJoints(_) => ErrorKind::UnknownRobot,
        SceneError::FixedJoint { .. }
        | SceneError::BadRobot { .. }
        | SceneError::Geometry { .. } => ErrorKind::BadRobot,
        SceneError::Session(_) => ErrorKind::Session,
        _ => ErrorKind::Scene,
    };
    ProtocolError::caused(kind, e)
}

/// A writer's failure as the protocol's error: the keeper's refusal is `transaction`, a keeper
/// that is missing or went away (or any other transport failure) is `session`.
pub fn client_err(e: robosim_instance_space::ClientError) -> ProtocolError {
    use robosim_instance_space::ClientError;
    let kind = match e {
        ClientError::Refused(_) => ErrorKind::Transaction,
        ClientError::Conflict { .. } => ErrorKind::Conflict,
        _ => ErrorKind::Session,
    };
    ProtocolError::caused(kind, e)
}

impl From<robosim_instance_space::ClientError> for ProtocolError {
    fn from(e: robosim_instance_space::ClientError) -> Self {
        client_err(e)
    }
}

/// The newest snapshot of `reader`, with `scene` brought to it.
fn fresh_snapshot(
    reader: &mut Reader,
    scene: &mut CompiledScene,
) -> std::result::Result<std::rc::Rc<Snapshot>, ProtocolError> {
    reader
        .refresh()
        .map_err(|e| ProtocolError::caused(ErrorKind::Session, e))?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| err(ErrorKind::Session, "no snapshot"))?;
    scene.sync(&snap);
    Ok(snap)
}

/// The rigid motion of a `pretranslate` / `posttranslate` (`by` [x,y,z], m) or a `prerotate` /
/// `postrotate` (`axis` [x,y,z] of any non-zero finite length, `angle` rad) request.
fn relative_motion(op: &str, req: &Value) -> std::result::Result<Isometry3<f64>, ProtocolError> {
    if op.ends_with("translate") {
        let v = vec_field(req, "by")?;
        if v.len() != 3 {
            return Err(err(ErrorKind::BadRequest, "`by` must have 3 numbers"));
        }
        return Ok(Isometry3::translation(v[0], v[1], v[2]));
    }
    let axis = vec_field(req, "axis")?;
    let angle = req
        .get("angle")
        .and_then(Value::as_f64)
        .filter(|a| a.is_finite())
        .ok_or_else(|| {
            err(
                ErrorKind::BadRequest,
                "`angle` must be a finite number (rad)",
            )
        })?;
    let unit = match axis[..] {
        [x, y, z] => robosim_geometry::unit_axis(Vector3::new(x, y, z)),
        _ => None,
    }
    .ok_or_else(|| {
        err(
            ErrorKind::BadRequest,
            format!("`axis` must be 3 finite numbers, not all zero (got {axis:?})"),
        )
    })?;
    Ok(Isometry3::from_parts(
        nalgebra::Translation3::identity(),
        nalgebra::UnitQuaternion::from_axis_angle(&unit, angle),
    ))
}

/// Why a session could not be attached.
#[derive(Debug, thiserror::Error)]
pub enum AttachError {
    #[error(transparent)]
    Reader(#[from] robosim_instance_space::ReaderError),
    #[error(transparent)]
    Client(#[from] robosim_instance_space::ClientError),
}

/// Session state of one query stream: its attachments, the compiled scene, and the seed's
/// collision switches (C_SWITCH, USE/DONTUSE). The switches belong to the stream: a new
/// `robosim query --session` starts with collision on, self-collision on, mode exact and
/// every object in use.
pub struct Ops {
    session: Session,
    reader: Reader,
    client: Client,
    scene: CompiledScene,
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
    "sim_state",
];

/// The ops that exist both here and in the pure protocol ([`crate::OPS`]), each with the
/// fields that only its pure form carries. A request for such an op with any of these fields,
/// or with an inline robot (an object in `robot`), is answered by the pure op; otherwise by the
/// session op ([`is_pure_form`]).
pub const SHARED: &[(&str, &[&str])] = &[("check", &["q", "scene"])];

/// Whether `req` is the pure form of `op`, an op in [`SHARED`] (for any other op: false).
pub fn is_pure_form(op: &str, req: &Value) -> bool {
    SHARED.iter().any(|(o, fields)| {
        *o == op
            && (req.get("robot").is_some_and(Value::is_object)
                || fields.iter().any(|f| req.get(f).is_some()))
    })
}

/// Refuses a field of `req` outside `allowed` (besides `id` and `op`), naming it and `hint`.
fn only_fields(
    req: &Value,
    op: &str,
    allowed: &[&str],
    hint: &str,
) -> std::result::Result<(), ProtocolError> {
    let Some(extra) = req.as_object().and_then(|m| {
        m.keys()
            .find(|k| !["id", "op"].contains(&k.as_str()) && !allowed.contains(&k.as_str()))
    }) else {
        return Ok(());
    };
    Err(err(
        ErrorKind::BadRequest,
        format!(
            "`{extra}`: the session `{op}` takes only {}; {hint}",
            allowed
                .iter()
                .map(|f| format!("`{f}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    ))
}

/// The index of the object named `name`, or an `unknown_object` error naming it.
fn object_index(snap: &Snapshot, name: &str) -> std::result::Result<usize, ProtocolError> {
    snap.find(name).ok_or_else(|| {
        err(
            ErrorKind::UnknownObject,
            format!("no object named {name:?}"),
        )
    })
}

fn str_field<'a>(req: &'a Value, f: &str) -> std::result::Result<&'a str, ProtocolError> {
    req.get(f)
        .and_then(Value::as_str)
        .ok_or_else(|| err(ErrorKind::BadRequest, format!("`{f}` must be a string")))
}

fn vec_field(req: &Value, f: &str) -> std::result::Result<Vec<f64>, ProtocolError> {
    let arr = req.get(f).and_then(Value::as_array).ok_or_else(|| {
        err(
            ErrorKind::BadRequest,
            format!("`{f}` must be an array of numbers"),
        )
    })?;
    arr.iter()
        .enumerate()
        .map(|(i, v)| {
            v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                err(
                    ErrorKind::BadRequest,
                    format!("`{f}[{i}]` is not a finite number"),
                )
            })
        })
        .collect()
}

/// A floating robot's q written by a session op keeps its root at the identity (the root's
/// coordinates of `robot.neutral_q()`): the base is where the robot object stands, moved by
/// moving the object (`pretranslate`, `prerotate`, …), never by a joint write.
fn root_held(robot: &Robot, q: &[f64]) -> std::result::Result<(), ProtocolError> {
    let nq = robot.root_nq();
    if nq == 0 || q.len() < nq {
        return Ok(());
    }
    let neutral = robot.neutral_q();
    if q[..nq] == neutral.as_slice()[..nq] {
        return Ok(());
    }
    Err(err(
        ErrorKind::BadRequest,
        format!(
            "robot {}: a session robot's floating base is its object's pose: q's first {nq} \
             values (the root) must be {:?}; move the base with pretranslate/prerotate on the \
             robot object",
            robot.name,
            &neutral.as_slice()[..nq]
        ),
    ))
}

/// The coupling of a session robot's mimic joints (`Kinematics::Mimic` records: a URDF's
/// `<mimic>` followers, `robosim import urdf`), over its compiled robot; `None` when no joint
/// follows another. Its q in every session op is then the **reduced** one (the independent
/// joints, in q order, a floating root's first): what `{"urdf": P, "mimic": true}` takes.
fn coupling_of(
    snap: &Snapshot,
    robot: &Robot,
) -> std::result::Result<Option<Coupling>, ProtocolError> {
    match snap.robot(&robot.name) {
        Some(view) => robosim_scene::robot_coupling(&view, robot).map_err(scene_err),
        None => Ok(None),
    }
}

/// A session write's `q` for a robot with mimic joints: its reduced coordinates, expanded to
/// the full q the Instance Space holds (each follower at its relation's value). A full-length
/// q is refused by name: the followers are not coordinates.
fn expand_written(
    robot: &Robot,
    c: &Coupling,
    q: &[f64],
) -> std::result::Result<Vec<f64>, ProtocolError> {
    if q.len() != c.reduced_nq() {
        let followers: Vec<usize> = (0..c.full_dof()).filter(|&i| c.is_follower(i)).collect();
        return Err(err(
            ErrorKind::BadRequest,
            format!(
                "robot {}: q has {} values but the robot has {} coordinates — its mimic joints                  (joint indices {followers:?}) follow their leaders and are not written; give                  the independent joints' values, in q order",
                robot.name,
                q.len(),
                c.reduced_nq()
            ),
        ));
    }
    c.expand_q(q)
        .map_err(|e| err(ErrorKind::BadRequest, format!("robot {}: {e}", robot.name)))
}

/// The reduced q of a full one (the followers left out).
fn reduced_of(c: &Coupling, q: &[f64]) -> Vec<f64> {
    c.restrict(q).unwrap_or_else(|_| q.to_vec())
}

fn body(b: &Body, p: &CompiledRobot, snap: &Snapshot, scene_names: &[String]) -> Value {
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

fn contacts(res: &CheckResult, p: &CompiledRobot, snap: &Snapshot, names: &[String]) -> Value {
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
    /// Attaches to `session` as a reader and a writer (role `query`).
    pub fn attach(session: &Session) -> std::result::Result<Self, AttachError> {
        Ok(Ops {
            session: session.clone(),
            reader: Reader::attach(session, "query")?,
            client: Client::connect(session, "query")?,
            scene: CompiledScene::new(),
            settings: CollisionSettings::default(),
            unused: HashSet::new(),
        })
    }

    /// The newest snapshot, with the compiled scene brought to it.
    fn snap(&mut self) -> std::result::Result<std::rc::Rc<Snapshot>, ProtocolError> {
        fresh_snapshot(&mut self.reader, &mut self.scene)
    }

    /// Changes `robot`'s joint values by `change` from their committed values, in one
    /// transaction with the poses of its links, whatever other writers commit meanwhile: `q`
    /// is read, changed and written back with a precondition that none of the robot's links
    /// moved since the read, and read again when one did ([`Client::transact_fresh`]). So
    /// concurrent writers of different joints of one robot (`(robosim set-joint R I Q)` in
    /// rule bases) or of relative moves of the same joint never undo each other. The same
    /// refusals as [`Ops::set_joints`] for the `q` it makes; `conflict` after
    /// [`robosim_instance_space::MAX_FRESH_ATTEMPTS`] lost races. The acknowledged version.
    pub fn update_joints(
        &mut self,
        robot: &str,
        mut change: impl FnMut(&mut [f64]) -> std::result::Result<(), ProtocolError>,
    ) -> std::result::Result<u64, ProtocolError> {
        let Ops {
            reader,
            client,
            scene,
            ..
        } = self;
        let committed = client.transact_fresh(|_| {
            let snap = fresh_snapshot(reader, scene)?;
            let p = scene.robot(robot).map_err(scene_err)?;
            let coupling = coupling_of(&snap, &p.robot)?;
            let q = match &coupling {
                // the change is made to the reduced coordinates, the followers then follow
                Some(c) => {
                    let mut qr = reduced_of(c, &p.q);
                    change(&mut qr)?;
                    expand_written(&p.robot, c, &qr)?
                }
                None => {
                    let mut q = p.q.clone();
                    change(&mut q)?;
                    q
                }
            };
            p.robot
                .check_q(&q)
                .map_err(|e| err(ErrorKind::BadRequest, format!("robot {robot}: {e}")))?;
            root_held(&p.robot, &q)?;
            robosim_kinematics::movej_interpolate(&p.robot, &q, &q, 1)
                .map_err(|e| err(ErrorKind::JointLimit, format!("robot {robot}: {e}")))?;
            let mut tx = joint_tx(&p.robot, &p.links, &q);
            for id in &p.links {
                tx.expect(*id, aspect::POSE | aspect::STRUCTURE, snap.version());
            }
            Ok::<_, ProtocolError>(tx)
        })?;
        Ok(committed.version)
    }

    /// `pretranslate` / `posttranslate` / `prerotate` / `postrotate`: the object's committed
    /// local pose composed with the request's motion (`T·pose` / `pose·T`), applied against
    /// the pose the keeper holds when it commits — a concurrent move of the same object is
    /// read again, never overwritten ([`Client::transact_fresh`]).
    fn relative_move(&mut self, op: &str, req: &Value) -> OpResult {
        let name = str_field(req, "object")?;
        let t = relative_motion(op, req)?;
        let pre = op.starts_with("pre");
        let Ops {
            reader,
            client,
            scene,
            ..
        } = self;
        let mut pose = robosim_instance_space::IDENTITY;
        let committed = client.transact_fresh(|_| {
            let snap = fresh_snapshot(reader, scene)?;
            let i = object_index(&snap, name)?;
            let id = snap.rec(i).id;
            let cur = pose::to_isometry(&snap.poses()[i].pose);
            pose = pose::from_isometry(&if pre { t * cur } else { cur * t });
            let mut tx = Transaction::new();
            tx.expect(id, aspect::POSE | aspect::STRUCTURE, snap.version())
                .set_pose(id, pose);
            Ok::<_, ProtocolError>(tx)
        })?;
        Ok(json!({"object": name, "pose": pose::rows(&pose), "version": committed.version}))
    }

    /// The session this attachment belongs to.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The reader under the ops (a client waits for changes on it: [`Reader::wait_change`]).
    pub fn reader_mut(&mut self) -> &mut Reader {
        &mut self.reader
    }

    /// The transaction client under the ops (a client sends its own transactions on it).
    pub fn client_mut(&mut self) -> &mut Client {
        &mut self.client
    }

    /// Sets the committed joint values of `robot` (rad / m, in chain order) and the poses of its
    /// links, in one transaction, without a collision check (that is MOVEJ's); returns the
    /// acknowledged version. Refused, changing nothing, when `q` has the wrong length, is not
    /// finite (`bad_request`) or leaves the joint limits (`joint_limit`), or when the keeper
    /// refuses the transaction (`transaction`).
    pub fn set_joints(
        &mut self,
        robot: &str,
        q: &[f64],
    ) -> std::result::Result<u64, ProtocolError> {
        let snap = self.snap()?;
        let p = self.scene.robot(robot).map_err(scene_err)?.clone();
        let full;
        let q = match coupling_of(&snap, &p.robot)? {
            Some(c) => {
                full = expand_written(&p.robot, &c, q)?;
                &full[..]
            }
            None => q,
        };
        p.robot
            .check_q(q)
            .map_err(|e| err(ErrorKind::BadRequest, format!("robot {robot}: {e}")))?;
        root_held(&p.robot, q)?;
        robosim_kinematics::movej_interpolate(&p.robot, q, q, 1)
            .map_err(|e| err(ErrorKind::JointLimit, format!("robot {robot}: {e}")))?;
        self.write_q(&p, q)
    }

    /// The compiled scene (as of the last request), e.g. for its counters.
    pub fn compiled(&self) -> &CompiledScene {
        &self.scene
    }

    /// The obstacles around `p`, without the objects out of use (DONTUSE) and their parts;
    /// refused when one of them has no collision solid (a check could not say "clear"
    /// honestly): the message names it and how to leave it out.
    fn obstacles(
        &self,
        p: &CompiledRobot,
        snap: &Snapshot,
    ) -> std::result::Result<Obstacles, ProtocolError> {
        // An instance's solids are its parts (e.g. `head` → `.../head/cylinder1`): leaving
        // the instance out leaves out everything under it, as it stands in this snapshot.
        let unused: HashSet<Id> = self
            .unused
            .iter()
            .flat_map(|id| robosim_scene::solids::subtree(snap, *id))
            .collect();
        let o = self.scene.obstacles(p, &unused);
        match o.refused.first() {
            None => Ok(o),
            Some(why) => Err(ProtocolError::new(
                ErrorKind::Check,
                format!(
                    "{why}; the check cannot be certified with it (leave it out with `dontuse`, or turn checks off with `c_switch`)"
                ),
            )),
        }
    }

    fn write_q(&mut self, p: &CompiledRobot, q: &[f64]) -> std::result::Result<u64, ProtocolError> {
        let tx = joint_tx(&p.robot, &p.links, q);
        self.client
            .transact(&tx)
            .map(|a| a.version)
            .map_err(client_err)
    }

    /// The pure kinematics op `op` on `robot` as compiled (no inline-JSON round trip), answered
    /// by the same code `serve` uses, a panic included (`internal_error`).
    fn pure_kinematics(op: &str, req: &Value, robot: &Robot) -> OpResult {
        crate::guarded(op, || {
            crate::protocol::kinematics::dispatch_with(op, req, RobotArg::Given(robot))
        })
        .unwrap_or_else(|| Err(err(ErrorKind::UnknownOp, format!("op {op:?}"))))
    }

    /// Answers `op` if it is a session op and `req` is not the pure form of a [`SHARED`] op;
    /// and a pure op (fk, ik, gravity, collide, …) whose `robot` names a robot of the session
    /// that no standard or reference robot is called ([`Ops::pure_on_session_robot`]).
    pub fn dispatch(&mut self, op: &str, req: &Value) -> Option<OpResult> {
        if (!OPS.contains(&op) || is_pure_form(op, req))
            && let Some(answer) = self.pure_on_session_robot(op, req)
        {
            return Some(answer);
        }
        if !OPS.contains(&op) || is_pure_form(op, req) {
            return None;
        }
        if op == "sim_state" {
            return Some(self.sim_state());
        }
        Some(self.answer(op, req))
    }

    /// A pure op of the protocol whose `robot` is a name that [`crate::resolve_robot`] does
    /// not know but the session has (`{"op": "fk", "robot": "arm2", …}`): answered by the
    /// pure op on the session's robot as compiled now (its base pose in the world included, as
    /// for the session ops). A standard-library name keeps its library meaning, so the pure
    /// ops answer the same with and without a session. `None` for anything else.
    fn pure_on_session_robot(&mut self, op: &str, req: &Value) -> Option<OpResult> {
        let name = req.get("robot")?.as_str()?;
        if op == "ops" || !crate::OPS.iter().any(|(o, _)| *o == op) {
            return None;
        }
        if crate::resolve_robot(name).is_some() {
            return None;
        }
        if let Err(e) = self.snap() {
            return Some(Err(e));
        }
        let robot = self.scene.robot(name).ok()?.robot.clone();
        // a robot with mimic joints: fk, jacobian, id, fd, mass_matrix and gravity over its
        // reduced coordinates (as `{"urdf": P, "mimic": true}`); the other pure ops refused
        let snap = match self.reader.snapshot() {
            Some(s) => s,
            None => return Some(Err(err(ErrorKind::Session, "no snapshot"))),
        };
        match coupling_of(&snap, &robot) {
            Err(e) => return Some(Err(e)),
            Ok(Some(c)) => {
                return crate::guarded(op, || {
                    Some(crate::protocol::mimic::answer_given(op, req, &robot, &c))
                });
            }
            Ok(None) => {}
        }
        let robots = move |n: &str| {
            if n == robot.name {
                Some(robot.clone())
            } else {
                crate::resolve_robot(n)
            }
        };
        crate::guarded(op, || crate::dispatch_with_robots(op, req, &robots))
    }

    /// `sim_state`: asks the session's simulator daemon (`{"cmd": "get"}` on its command
    /// service) and answers its JSON as it is.
    fn sim_state(&self) -> OpResult {
        let none = |e: String| err(ErrorKind::Session, e);
        // The message does not name the session: the same request gets the same answer in any
        // session without a simulator (docs/query.md's example is checked against a fresh one).
        let mut sender = robosim_instance_space::state::CommandSender::open(
            &self.session,
            "simulator",
            "query-sim",
        )
        .map_err(|_| {
            none(
                "no simulator runs in this session: start one with `robosim up SCENE --with \
                 simulator` (or `robosim simulator`)"
                    .into(),
            )
        })?;
        // A simulator that dies (kill -9) is said at once by name, not after the timeout.
        let answer = sender
            .send(br#"{"cmd":"get"}"#, std::time::Duration::from_secs(10))
            .map_err(|e| match e {
                robosim_instance_space::state::StateError::ReceiverDead { .. } => {
                    none(e.to_string())
                }
                e => none(format!("the simulator: {e}")),
            })?;
        match serde_json::from_slice::<Value>(&answer) {
            Ok(Value::Object(m)) => Ok(Value::Object(m)),
            _ => Err(none(format!(
                "the simulator answered {:?}, not its state",
                String::from_utf8_lossy(&answer)
            ))),
        }
    }

    fn answer(&mut self, op: &str, req: &Value) -> OpResult {
        let snap = self.snap()?;
        match op {
            "use" | "dontuse" => {
                let name = str_field(req, "object")?;
                let i = object_index(&snap, name)?;
                let id = snap.rec(i).id;
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
                    .ok_or_else(|| err(ErrorKind::BadRequest, "`on` must be true or false"))?;
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
                                ErrorKind::BadRequest,
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
                self.relative_move(op, req)
            }
            _ => self.robot_op(op, req, &snap),
        }
    }

    /// kinv or jacob on the chain `robot` (joints `joints` of a robot at `q`): the answer of
    /// the pure op on the chain, with `chain` (the joints' indices in the robot's q) and, for
    /// kinv, each solution's `q` given whole (the joints off the chain where they are).
    fn chain_op(op: &str, req: &Value, robot: &Robot, joints: &[usize], q: &[f64]) -> OpResult {
        let q_chain: Vec<f64> = joints.iter().map(|&j| q[j]).collect();
        let mut out = if op == "kinv" {
            let mut r = req.clone();
            if let Some(m) = r.as_object_mut() {
                m.remove("tip");
                m.insert("op".into(), json!("ik"));
                m.entry("q0").or_insert(json!(q_chain));
            }
            Self::pure_kinematics("ik", &r, robot)?
        } else {
            Self::pure_kinematics(
                "jacobian",
                &json!({"op": "jacobian", "q": q_chain, "frame": req.get("frame").cloned().unwrap_or(json!("base"))}),
                robot,
            )?
        };
        if let Some(sols) = out.get_mut("solutions").and_then(Value::as_array_mut) {
            for s in sols {
                let Some(qc) = s.get("q").and_then(Value::as_array).cloned() else {
                    continue;
                };
                let mut whole: Vec<Value> = q.iter().map(|x| json!(x)).collect();
                for (k, &j) in joints.iter().enumerate() {
                    if let Some(v) = qc.get(k) {
                        whole[j] = v.clone();
                    }
                }
                s["q"] = Value::Array(whole);
            }
        }
        out["chain"] = json!(joints);
        Ok(out)
    }

    /// The session ops on a robot with mimic joints: q in and out is the reduced one
    /// ([`coupling_of`]). `get_robot` (q reduced, plus `coordinates`: each one's joint index,
    /// and `q_full`), `movej`/`moveji` (reduced target; every step written with the followers
    /// at their relation's value), `jacob` (J G over the reduced coordinates), `check`;
    /// `kinv`, `encoder` and `tip` are refused by name (not yet over the coupling).
    fn coupled_robot_op(
        &mut self,
        op: &str,
        req: &Value,
        snap: &Snapshot,
        p: &CompiledRobot,
        c: &Coupling,
    ) -> OpResult {
        let qr = reduced_of(c, &p.q);
        if !matches!(req.get("tip"), None | Some(Value::Null)) || matches!(op, "kinv" | "encoder") {
            return Err(err(
                ErrorKind::BadRequest,
                format!(
                    "robot {} has mimic joints: {op}{} is not taken on it yet (get_robot, movej,                      moveji, jacob, check take its reduced coordinates)",
                    p.robot.name,
                    if matches!(req.get("tip"), None | Some(Value::Null)) {
                        ""
                    } else {
                        " with `tip`"
                    }
                ),
            ));
        }
        match op {
            "get_robot" => {
                let inline = crate::robot_json::robot_to_json(&p.robot);
                let links: Vec<Value> = p.links.iter().map(|id| json!({"id": id, "name": snap.index_of(*id).map_or("", |k| snap.name(k))})).collect();
                Ok(
                    json!({"robot": inline, "q": qr, "coordinates": c.free(), "q_full": p.q,
                    "links": links, "allowed_pairs": p.solids.allowed}),
                )
            }
            "jacob" => crate::protocol::mimic::answer_given(
                "jacobian",
                &json!({"op": "jacobian", "q": qr, "frame": req.get("frame").cloned().unwrap_or(json!("base"))}),
                &p.robot,
                c,
            ),
            "movej" | "moveji" => {
                let target = expand_written(&p.robot, c, &vec_field(req, "q")?)?;
                let mut r = req.clone();
                r["q"] = json!(target);
                let mut out = self.robot_op_full(op, &r, snap, p, Some(c))?;
                if let Some(q) = out.get("q").and_then(Value::as_array) {
                    let q: Vec<f64> = q.iter().filter_map(Value::as_f64).collect();
                    out["q"] = json!(reduced_of(c, &q));
                }
                Ok(out)
            }
            _ => self.robot_op_full(op, req, snap, p, Some(c)),
        }
    }

    fn robot_op(&mut self, op: &str, req: &Value, snap: &Snapshot) -> OpResult {
        let p = self
            .scene
            .robot(str_field(req, "robot")?)
            .map_err(scene_err)?
            .clone();
        if let Some(c) = coupling_of(snap, &p.robot)? {
            return self.coupled_robot_op(op, req, snap, &p, &c);
        }
        self.robot_op_full(op, req, snap, &p, None)
    }

    /// A session op on `p` over its full q (`coupling`: a robot with mimic joints, whose
    /// `movej`/`moveji` steps are then written with the followers at their relation's value).
    fn robot_op_full(
        &mut self,
        op: &str,
        req: &Value,
        snap: &Snapshot,
        p: &CompiledRobot,
        coupling: Option<&Coupling>,
    ) -> OpResult {
        let chain = tip_chain(op, req, snap, p)?;
        if let Some((robot, joints)) = chain {
            return Self::chain_op(op, req, &robot, &joints, &p.q);
        }
        match op {
            "get_robot" => {
                let inline = crate::robot_json::robot_to_json(&p.robot);
                let links: Vec<Value> = p.links.iter().map(|id| json!({"id": id, "name": snap.index_of(*id).map_or("", |k| snap.name(k))})).collect();
                Ok(
                    json!({"robot": inline, "q": p.q, "links": links, "allowed_pairs": p.solids.allowed}),
                )
            }
            "kinv" => {
                let mut r = req.clone();
                if let Some(m) = r.as_object_mut() {
                    m.insert("op".into(), json!("ik"));
                    m.entry("q0").or_insert(json!(p.q));
                }
                Self::pure_kinematics("ik", &r, &p.robot)
            }
            "jacob" => Self::pure_kinematics(
                "jacobian",
                &json!({"op": "jacobian", "q": p.q, "frame": req.get("frame").cloned().unwrap_or(json!("base"))}),
                &p.robot,
            ),
            "encoder" => Self::pure_kinematics(
                "encoder_error",
                &json!({"op": "encoder_error", "q": p.q, "bits": req.get("bits").cloned().unwrap_or(Value::Null)}),
                &p.robot,
            ),
            "check" => {
                only_fields(
                    req,
                    op,
                    &["robot"],
                    "it checks the robot at its current q with c_switch's settings \
                     (set `mode` and `self_collision` with `c_switch`); \
                     a check of a given q and scene takes `q` and `scene` too",
                )?;
                let Obstacles { scene, names, .. } = self.obstacles(&p, snap)?;
                let res = robosim_collision::robot::check_robot(
                    &p.robot,
                    &p.solids,
                    &p.q,
                    &scene,
                    &self.settings,
                )
                .map_err(|e| ProtocolError::caused(ErrorKind::Check, e))?;
                Ok(contacts(&res, &p, snap, &names))
            }
            "movej" | "moveji" => self.move_op(op, req, snap, p, coupling),
            other => Err(err(ErrorKind::UnknownOp, format!("op {other:?}"))),
        }
    }

    /// `movej` (one step) and `moveji` (`steps` interpolated steps) of `p` to `q`: limits at
    /// every step, then as far as the collision check lets it, each step written.
    fn move_op(
        &mut self,
        op: &str,
        req: &Value,
        snap: &Snapshot,
        p: &CompiledRobot,
        coupling: Option<&Coupling>,
    ) -> OpResult {
        let q = vec_field(req, "q")?;
        p.robot
            .check_q(&q)
            .map_err(|e| ProtocolError::caused(ErrorKind::BadRequest, e))?;
        root_held(&p.robot, &q)?;
        let steps = if op == "movej" {
            1
        } else {
            req.get("steps")
                .and_then(Value::as_u64)
                .filter(|s| *s > 0 && *s <= 100_000)
                .ok_or_else(|| {
                    err(
                        ErrorKind::BadRequest,
                        "`steps` must be an integer in 1..=100000",
                    )
                })? as usize
        };
        // Joint limits at every step (MOVEJI's check), before anything moves.
        let mut path = robosim_kinematics::movej_interpolate(&p.robot, &p.q, &q, steps)
            .map_err(|e| ProtocolError::caused(ErrorKind::JointLimit, e))?;
        // an interpolation of two coupled q's is coupled up to rounding: each step's
        // followers are put back at exactly their relation's value
        if let Some(c) = coupling {
            for step in &mut path {
                if let Ok(q) = c.restrict(step).and_then(|qr| c.expand_q(&qr)) {
                    *step = q;
                }
            }
        }
        let Obstacles { scene, names, .. } = self.obstacles(&p, snap)?;
        let outcome = robosim_collision::robot::move_checked(
            &p.robot,
            &p.solids,
            &p.q,
            &q,
            steps,
            &scene,
            &self.settings,
        )
        .map_err(|e| ProtocolError::caused(ErrorKind::Check, e))?;
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
}

/// The chain a request's `tip` names (a link of `p`; kinv and jacob then act on the chain
/// from the base to it — a branching robot, a Panda's fingers, has one per leaf — the other
/// joints held), None without a `tip`.
fn tip_chain(
    op: &str,
    req: &Value,
    snap: &Snapshot,
    p: &CompiledRobot,
) -> std::result::Result<Option<(Robot, Vec<usize>)>, ProtocolError> {
    let chain = match req.get("tip") {
        None | Some(Value::Null) => None,
        Some(t) => {
            let name = t
                .as_str()
                .ok_or_else(|| err(ErrorKind::BadRequest, "`tip` must be a link name"))?;
            let k = p
                .links
                .iter()
                .position(|id| snap.index_of(*id).is_some_and(|i| snap.name(i) == name))
                .ok_or_else(|| {
                    let names: Vec<&str> = p
                        .links
                        .iter()
                        .filter_map(|id| snap.index_of(*id).map(|i| snap.name(i)))
                        .collect();
                    err(
                        ErrorKind::BadRequest,
                        format!(
                            "`tip` {name:?} is not a link of {}; its links: {}",
                            p.robot.name,
                            names.join(", ")
                        ),
                    )
                })?;
            if !matches!(op, "kinv" | "jacob") {
                return Err(err(
                    ErrorKind::BadRequest,
                    format!("`tip` is for kinv and jacob, not {op}"),
                ));
            }
            p.robot.chain_to(k + 1)
        }
    };
    Ok(chain)
}

/// `robosim query --session NAME`: the session ops, offered to [`crate::serve_with`] as an
/// extension (so framing, bad lines, panics and flushing behave exactly as in the pure
/// protocol); every other op goes to the pure protocol.
/// `robosim query --session S [--input FILE]`: [`serve`] from `input` (a file; `None` or `-`:
/// standard input) to standard output. A reader that went away (a closed pipe) ends it
/// quietly.
pub fn serve_stdio(
    session: &Session,
    input: Option<&std::path::Path>,
) -> std::result::Result<(), ServeError> {
    let out = std::io::stdout();
    let served = match input {
        Some(p) if p.as_os_str() != "-" => serve(
            session,
            std::io::BufReader::new(std::fs::File::open(p)?),
            out.lock(),
        ),
        _ => serve(session, std::io::stdin().lock(), out.lock()),
    };
    match served {
        Ok(_) => Ok(()),
        Err(ServeError::Io(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(e),
    }
}

pub fn serve(
    session: &Session,
    input: impl BufRead,
    output: impl Write,
) -> std::result::Result<crate::ServeStats, ServeError> {
    // A session that cannot take this process (no keeper, its reader or writer limit reached)
    // answers every session op with a `session` error saying so, pure ops as ever; the stream
    // then ends with that error (the exit status says the session was not served).
    let mut ops = Ops::attach(session);
    let listing: Vec<(&str, &str)> = OPS.iter().map(|op| (*op, "session")).collect();
    let mut answer = |op: &str, req: &Value| -> Option<OpResult> {
        match &mut ops {
            Ok(ops) => ops.dispatch(op, req),
            Err(why) => (OPS.contains(&op) && !is_pure_form(op, req))
                .then(|| Err(err(ErrorKind::Session, why.to_string()))),
        }
    };
    let stats = crate::serve_with(
        input,
        output,
        crate::Extension {
            ops: &listing,
            answer: &mut answer,
        },
    )?;
    match ops {
        Ok(_) => Ok(stats),
        Err(e) => Err(e.into()),
    }
}

/// Why [`serve`] stopped early.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error(transparent)]
    Attach(#[from] AttachError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_op_in_both_protocols_has_a_routing_rule() {
        for op in OPS {
            let pure = crate::OPS.iter().any(|(o, _)| o == op);
            let ruled = SHARED.iter().any(|(o, _)| o == op);
            assert_eq!(pure, ruled, "{op}: pure op {pure}, in SHARED {ruled}");
        }
    }

    #[test]
    fn the_request_form_alone_picks_the_pure_or_the_session_check() {
        let session = json!({"id": 1, "op": "check", "robot": "positioner"});
        assert!(!is_pure_form("check", &session));
        for pure in [
            json!({"op": "check", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0], "scene": {"objects": []}}),
            json!({"op": "check", "robot": "puma560", "q": [0, 0, 0, 0, 0, 0]}),
            json!({"op": "check", "robot": "puma560", "scene": {"objects": []}}),
            json!({"op": "check", "robot": {"joints": []}}),
        ] {
            assert!(is_pure_form("check", &pure), "{pure}");
        }
        // Ops that are only session ops are never routed away, whatever their fields.
        assert!(!is_pure_form(
            "movej",
            &json!({"robot": "positioner", "q": [0.0]})
        ));
    }

    #[test]
    fn the_session_check_names_a_field_it_does_not_take() {
        let e = only_fields(
            &json!({"id": 1, "op": "check", "robot": "positioner", "mode": "bbox"}),
            "check",
            &["robot"],
            "hint",
        )
        .expect_err("mode is refused");
        assert_eq!(e.kind, ErrorKind::BadRequest);
        assert!(
            e.message
                .starts_with("`mode`: the session `check` takes only `robot`"),
            "{}",
            e.message
        );
        assert!(
            only_fields(
                &json!({"id": 1, "op": "check", "robot": "p"}),
                "check",
                &["robot"],
                ""
            )
            .is_ok()
        );
    }
}
