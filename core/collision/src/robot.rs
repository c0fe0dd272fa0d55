//! Robots against scenes (seed §2.6, "special considerations when used with robots"; appendix
//! 2.2: USE, DONTUSE, CHECK, C_SWITCH, MOVEJ, MOVEJI).
//!
//! * A [`Scene`] holds objects; only those *in use* (the seed's USE list) are checked, through a
//!   BVH over their world boxes once the scene is large ([`crate::broad`] measured the choice).
//! * A robot carries one optional solid per link ([`LinkSolids`]): index 0 is the base (fixed to
//!   `robot.base`), index j the link moved by joint j, posed by link frame j of
//!   [`robosim_kinematics::fk::link_frames`]. The tool belongs to link n.
//! * [`check_robot`] — the seed's CHECK: a box per link (dilation product), a box for the robot
//!   (from its link boxes), then links from the end effector inward against the objects whose
//!   boxes meet, then self-collision (non-adjacent pairs, minus declared allowed pairs) when
//!   switched on. Depends only on q (and the scene's poses).
//! * [`move_checked`] — MOVEJ / MOVEJI with collision on: stops at the last safe step and
//!   reports the colliding pair (the seed's collision structure: objects and link numbers);
//!   optionally continuous between steps ([`crate::ccd`]).

use crate::bbox::world_box;
use crate::ccd;
use crate::exact::{self, ExactOptions};
use crate::outcome::{Mode, PairResult};
use crate::polygon::{self, PolygonOptions};
use crate::solid::{ShapeError, Solid};
use nalgebra::{Isometry3, Matrix4, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use parry3d_f64::bounding_volume::Aabb as PAabb;
use parry3d_f64::partitioning::Bvh;
use robosim_geometry::Aabb;
use robosim_kinematics::{Convention, JointType, ModelError, Robot, fk};
use std::sync::Arc;

/// Scenes with at least this many objects in use are searched through the BVH; smaller ones
/// by a linear scan of boxes (cheaper below this size).
const BVH_THRESHOLD: usize = 16;

/// The rigid transform of a 4×4 homogeneous matrix (assumed rigid, as `Robot::validate` and
/// the query layer check).
pub fn isometry_from_matrix(m: &Matrix4<f64>) -> Isometry3<f64> {
    let r = Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
    Isometry3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

fn paabb(b: &Aabb) -> PAabb {
    PAabb::new(b.mins(), b.maxs())
}

/// One object of a scene.
#[derive(Debug, Clone)]
pub struct SceneObject {
    pub name: String,
    pub solid: Arc<Solid>,
    pub pose: Isometry3<f64>,
    pub in_use: bool,
    world_box: Aabb,
}

impl SceneObject {
    pub fn world_box(&self) -> &Aabb {
        &self.world_box
    }
}

/// The objects of a simulation and the seed's USE list.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    objects: Vec<SceneObject>,
    bvh: Bvh,
    in_use: usize,
}

impl Scene {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an object at `pose` and puts it in use (USE); returns its index.
    pub fn add(
        &mut self,
        name: impl Into<String>,
        solid: Arc<Solid>,
        pose: Isometry3<f64>,
    ) -> usize {
        let world_box = world_box(&solid.bbox, &pose);
        self.objects.push(SceneObject {
            name: name.into(),
            solid,
            pose,
            in_use: false,
            world_box,
        });
        let id = self.objects.len() - 1;
        self.use_object(id);
        id
    }

    /// USE: the object takes part in collision checks. Out-of-range ids are ignored.
    pub fn use_object(&mut self, id: usize) {
        if let Some(o) = self.objects.get_mut(id)
            && !o.in_use
        {
            o.in_use = true;
            self.in_use += 1;
            self.bvh.insert(paabb(&o.world_box), id as u32);
        }
    }

    /// DONTUSE: the object is skipped by collision checks (it costs nothing).
    pub fn dont_use(&mut self, id: usize) {
        if let Some(o) = self.objects.get_mut(id)
            && o.in_use
        {
            o.in_use = false;
            self.in_use -= 1;
            self.bvh.remove(id as u32);
        }
    }

    /// Moves an object (PRE/POSTTRANSLATE, PRE/POSTROTATE end here).
    pub fn set_pose(&mut self, id: usize, pose: Isometry3<f64>) {
        if let Some(o) = self.objects.get_mut(id) {
            o.pose = pose;
            o.world_box = world_box(&o.solid.bbox, &pose);
            if o.in_use {
                self.bvh.insert(paabb(&o.world_box), id as u32);
            }
        }
    }

    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// Indices of the in-use objects whose world boxes meet `b` (appended to `out`).
    pub fn candidates(&self, b: &Aabb, out: &mut Vec<usize>) {
        if self.in_use < BVH_THRESHOLD {
            out.extend(
                self.objects
                    .iter()
                    .enumerate()
                    .filter(|(_, o)| o.in_use && o.world_box.overlaps(b))
                    .map(|(i, _)| i),
            );
        } else {
            let q = paabb(b);
            out.extend(self.bvh.intersect_aabb(&q).map(|i| i as usize));
        }
    }
}

/// The solid of one link, placed in its link frame.
#[derive(Debug, Clone)]
pub struct LinkSolid {
    pub solid: Arc<Solid>,
    /// Solid frame → link frame.
    pub offset: Isometry3<f64>,
}

/// A robot's collision geometry: `links[0]` the base, `links[j]` link j (1..=n), `None` for a
/// link without a solid; `allowed` lists link pairs never checked against each other.
#[derive(Debug, Clone, Default)]
pub struct LinkSolids {
    pub links: Vec<Option<LinkSolid>>,
    pub allowed: Vec<(usize, usize)>,
}

/// Why a check could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckError {
    /// q is the wrong length or not finite.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// The link solids do not match the robot: there must be `dof + 1` entries (base first).
    #[error(
        "link solids: {got} entries for a robot with {dof} joints (expected {expected}: the base, then one per joint)"
    )]
    LinkCount {
        dof: usize,
        got: usize,
        expected: usize,
    },
    /// A solid could not be built.
    #[error("{0}")]
    Shape(#[from] ShapeError),
    /// `steps` of a MOVEJI is zero.
    #[error("steps must be at least 1")]
    ZeroSteps,
}

impl LinkSolids {
    /// Simple link solids from the DH parameters, for robots whose model carries none: a
    /// square-section box of side `2 × radius` (m) along each non-zero DH segment — the d
    /// segment along z and the a segment along x — attached to the link that carries it
    /// (standard DH: both to link j; modified DH: a_{j−1} to link j−1, d_j to link j), and one
    /// along the tool offset on link n. A prismatic joint's own (sliding) d segment is left out.
    /// Links that end up with no solid are `None`; pairs of links separated only by such empty
    /// links are declared allowed (they meet at a shared joint, like adjacent links).
    pub fn from_dh(robot: &Robot, radius: f64) -> Result<Self, CheckError> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(ShapeError::BadDimension {
                field: "link_radius",
                value: radius,
            }
            .into());
        }
        let n = robot.dof();
        let mut segs: Vec<Vec<(Point3<f64>, Point3<f64>)>> = vec![Vec::new(); n + 1];
        for (k, j) in robot.joints.iter().enumerate() {
            let link = k + 1;
            let prismatic = j.joint_type == JointType::Prismatic;
            match robot.convention {
                Convention::Standard => {
                    // In frame k: o_{k−1} at Rx(−α)(−a, 0, −d), the elbow point at Rx(−α)(−a, 0, 0).
                    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), -j.alpha);
                    let elbow = Point3::from(rx * Vector3::new(-j.a, 0.0, 0.0));
                    let prev = Point3::from(rx * Vector3::new(-j.a, 0.0, -j.d));
                    if !prismatic {
                        segs[link].push((prev, elbow));
                    }
                    segs[link].push((elbow, Point3::origin()));
                }
                Convention::Modified => {
                    segs[link - 1].push((Point3::origin(), Point3::new(j.a, 0.0, 0.0)));
                    if !prismatic {
                        segs[link].push((Point3::new(0.0, 0.0, -j.d), Point3::origin()));
                    }
                }
            }
        }
        let tool_t = Point3::new(robot.tool[(0, 3)], robot.tool[(1, 3)], robot.tool[(2, 3)]);
        segs[n].push((Point3::origin(), tool_t));
        let mut parts = Vec::with_capacity(n + 1);
        for s in &segs {
            let mut link = Vec::new();
            for (p, q) in s {
                let v = q - p;
                let len = v.norm();
                if len < 1e-9 {
                    continue;
                }
                let b = Solid::cuboid(Vector3::new(len, 2.0 * radius, 2.0 * radius))?;
                let rot =
                    UnitQuaternion::rotation_between(&Vector3::x(), &v).unwrap_or_else(|| {
                        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI)
                    });
                link.push((
                    Isometry3::from_parts(Translation3::from(p.coords + v * 0.5), rot),
                    b,
                ));
            }
            parts.push(link);
        }
        Self::from_parts(parts)
    }

    /// Link solids from convex parts placed in each link frame: `parts[0]` the base's, `parts[j]`
    /// link j's (solid frame → link frame), for any joint model (DH rows, URDF origins and
    /// axes). A link with no part is `None`, one part is its solid at its offset, several make
    /// a compound. Pairs of links separated only by links without solids are declared allowed
    /// (they meet at a shared joint, like adjacent links). [`Self::from_dh`] ends here, and so
    /// does the URDF importer's collision geometry.
    pub fn from_parts(parts: Vec<Vec<(Isometry3<f64>, Solid)>>) -> Result<Self, CheckError> {
        let mut links = Vec::with_capacity(parts.len());
        for mut link in parts {
            links.push(match link.len() {
                0 => None,
                1 => link.pop().map(|(offset, s)| LinkSolid {
                    solid: Arc::new(s),
                    offset,
                }),
                _ => Some(LinkSolid {
                    solid: Arc::new(Solid::compound(link)?),
                    offset: Isometry3::identity(),
                }),
            });
        }
        let mut allowed = Vec::new();
        let solid_links: Vec<usize> = (0..links.len()).filter(|&i| links[i].is_some()).collect();
        for w in solid_links.windows(2) {
            if w[1] > w[0] + 1 {
                allowed.push((w[0], w[1]));
            }
        }
        Ok(LinkSolids { links, allowed })
    }

    fn allows(&self, i: usize, j: usize) -> bool {
        self.allowed
            .iter()
            .any(|&(a, b)| (a, b) == (i, j) || (a, b) == (j, i))
    }

    /// The pairs self-collision checks: non-adjacent links with solids, minus allowed pairs.
    pub fn self_pairs(&self) -> Vec<(usize, usize)> {
        let n = self.links.len();
        let mut out = Vec::new();
        for i in 0..n {
            for j in i + 2..n {
                if self.links[i].is_some() && self.links[j].is_some() && !self.allows(i, j) {
                    out.push((i, j));
                }
            }
        }
        out
    }
}

/// Collision switches (the seed's C_SWITCH and the separate self-collision switch) and mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollisionSettings {
    /// C_SWITCH: moves check for collisions at all.
    pub enabled: bool,
    /// Self-collision of the robot, switchable apart from the rest.
    pub self_collision: bool,
    pub mode: Mode,
    /// Collect every colliding pair (`true`) or stop at the first (the seed's behaviour).
    pub all_contacts: bool,
    /// MOVEJ/MOVEJI also check between steps (time of impact, exact distances).
    pub continuous: bool,
}

impl Default for CollisionSettings {
    fn default() -> Self {
        CollisionSettings {
            enabled: true,
            self_collision: true,
            mode: Mode::Exact,
            all_contacts: false,
            continuous: false,
        }
    }
}

/// A body taking part in a collision: a scene object, or a link of the checked robot (0 = base).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Body {
    Object {
        index: usize,
        name: String,
    },
    /// A link of the robot being checked ([`check_robot`]).
    Link(usize),
    /// A link of robot `robot` (its index in the slice given to [`check_robots`]).
    RobotLink {
        robot: usize,
        link: usize,
    },
}

/// One colliding pair — the seed's collision structure (S1, L1, S2, L2) with witness points.
#[derive(Debug, Clone, PartialEq)]
pub struct Collision {
    pub a: Body,
    pub b: Body,
    /// Minus the penetration depth, when the mode gives it (m).
    pub signed_distance: Option<f64>,
    /// World points on a and on b (exact), or the piercing point (polygon).
    pub witness: Option<[Point3<f64>; 2]>,
}

/// The answer of a robot check. `Unknown` is never folded into `Clear`.
#[derive(Debug, Clone, PartialEq)]
pub enum CheckResult {
    Clear,
    Contact(Vec<Collision>),
    Unknown { a: Body, b: Body, reason: String },
}

impl CheckResult {
    pub fn is_clear(&self) -> bool {
        matches!(self, CheckResult::Clear)
    }
}

/// The world pose of every link solid at q: `poses[j]` for `links[j]` (`None` where no solid).
pub fn link_poses(robot: &Robot, links: &LinkSolids, q: &[f64]) -> Vec<Option<Isometry3<f64>>> {
    let frames = fk::link_frames(robot, q);
    links
        .links
        .iter()
        .enumerate()
        .map(|(j, l)| {
            l.as_ref()
                .map(|l| isometry_from_matrix(&frames[j]) * l.offset)
        })
        .collect()
}

/// One pair in the chosen mode (exact without the separation distance: checks need only the
/// boolean, and the depth when in contact).
pub(crate) fn narrow(
    a: &Solid,
    pa: &Isometry3<f64>,
    b: &Solid,
    pb: &Isometry3<f64>,
    mode: Mode,
) -> PairResult {
    match mode {
        Mode::BBox => crate::bbox::collide(a, pa, b, pb),
        Mode::Polygon => polygon::collide(a, pa, b, pb, PolygonOptions::default()),
        Mode::Exact => exact::collide(
            a,
            pa,
            b,
            pb,
            ExactOptions {
                distance: false,
                depth: true,
            },
        ),
    }
}

fn link_boxes(links: &LinkSolids, lp: &[Option<Isometry3<f64>>]) -> Vec<Option<Aabb>> {
    links
        .links
        .iter()
        .zip(lp)
        .map(|(l, p)| match (l, p) {
            (Some(l), Some(p)) => Some(world_box(&l.solid.bbox, p)),
            _ => None,
        })
        .collect()
}

fn merged_box(boxes: &[Option<Aabb>]) -> Option<Aabb> {
    boxes
        .iter()
        .flatten()
        .fold(None::<Aabb>, |acc, b| Some(acc.map_or(*b, |a| a.merged(b))))
}

/// One robot of a multi-robot check: model, link solids and joint values.
#[derive(Debug, Clone, Copy)]
pub struct RobotAt<'a> {
    pub robot: &'a Robot,
    pub links: &'a LinkSolids,
    pub q: &'a [f64],
}

/// CHECK for several robots at once (seed §2.6): each robot against the scene (and itself, if
/// switched on), then robots against each other — one robot-box test per pair of robots, link
/// pairs only when the two robot boxes meet ("with three robots … only three bounding box
/// checks are required"). Bodies are reported as [`Body::RobotLink`] and [`Body::Object`].
pub fn check_robots(
    robots: &[RobotAt],
    scene: &Scene,
    settings: &CollisionSettings,
) -> Result<CheckResult, CheckError> {
    let mut placed = Vec::with_capacity(robots.len());
    for r in robots {
        r.robot.check_q(r.q)?;
        check_link_count(r.robot, r.links)?;
        let lp = link_poses(r.robot, r.links, r.q);
        let boxes = link_boxes(r.links, &lp);
        let rb = merged_box(&boxes);
        placed.push((lp, boxes, rb));
    }
    let tag = |i: usize, b: Body| match b {
        Body::Link(link) => Body::RobotLink { robot: i, link },
        other => other,
    };
    let mut contacts = Vec::new();
    let mut doubt = None;
    for (i, r) in robots.iter().enumerate() {
        match check_links(r.links, &placed[i].0, scene, settings) {
            CheckResult::Clear => {}
            CheckResult::Contact(cs) => {
                contacts.extend(cs.into_iter().map(|c| Collision {
                    a: tag(i, c.a),
                    b: tag(i, c.b),
                    ..c
                }));
                if !settings.all_contacts {
                    return Ok(CheckResult::Contact(contacts));
                }
            }
            CheckResult::Unknown { a, b, reason } => {
                doubt.get_or_insert((tag(i, a), tag(i, b), reason));
            }
        }
    }
    for i in 0..robots.len() {
        for k in i + 1..robots.len() {
            let (Some(bi), Some(bk)) = (&placed[i].2, &placed[k].2) else {
                continue;
            };
            if !bi.overlaps(bk) {
                continue;
            }
            for (a, (la, pa)) in robots[i]
                .links
                .links
                .iter()
                .zip(&placed[i].0)
                .enumerate()
                .rev()
            {
                let (Some(la), Some(pa), Some(ba)) = (la, pa, &placed[i].1[a]) else {
                    continue;
                };
                for (b, (lb, pb)) in robots[k]
                    .links
                    .links
                    .iter()
                    .zip(&placed[k].0)
                    .enumerate()
                    .rev()
                {
                    let (Some(lb), Some(pb), Some(bb)) = (lb, pb, &placed[k].1[b]) else {
                        continue;
                    };
                    if !ba.overlaps(bb) {
                        continue;
                    }
                    let (ea, eb) = (
                        Body::RobotLink { robot: i, link: a },
                        Body::RobotLink { robot: k, link: b },
                    );
                    match narrow(&la.solid, pa, &lb.solid, pb, settings.mode) {
                        PairResult::Clear { .. } => {}
                        PairResult::Contact {
                            signed_distance,
                            witness,
                        } => {
                            contacts.push(Collision {
                                a: ea,
                                b: eb,
                                signed_distance,
                                witness,
                            });
                            if !settings.all_contacts {
                                return Ok(CheckResult::Contact(contacts));
                            }
                        }
                        PairResult::Unknown { reason } => {
                            doubt.get_or_insert((ea, eb, reason));
                        }
                    }
                }
            }
        }
    }
    Ok(if !contacts.is_empty() {
        CheckResult::Contact(contacts)
    } else if let Some((a, b, reason)) = doubt {
        CheckResult::Unknown { a, b, reason }
    } else {
        CheckResult::Clear
    })
}

/// [`check_robot`]'s checks for link poses `lp` already computed ([`link_poses`]): the
/// robot's links against the scene and, when the settings ask, against each other. Public for
/// the collision report, which times the checks without forward kinematics.
pub fn check_links(
    links: &LinkSolids,
    lp: &[Option<Isometry3<f64>>],
    scene: &Scene,
    settings: &CollisionSettings,
) -> CheckResult {
    let boxes = link_boxes(links, lp);
    let robot_box = merged_box(&boxes);
    let mut contacts = Vec::new();
    let mut doubt: Option<(Body, Body, String)> = None;
    let mut record = |r: PairResult, a: Body, b: Body, contacts: &mut Vec<Collision>| -> bool {
        match r {
            PairResult::Clear { .. } => false,
            PairResult::Contact {
                signed_distance,
                witness,
            } => {
                contacts.push(Collision {
                    a,
                    b,
                    signed_distance,
                    witness,
                });
                !settings.all_contacts
            }
            PairResult::Unknown { reason } => {
                if doubt.is_none() {
                    doubt = Some((a, b, reason));
                }
                false
            }
        }
    };
    if let Some(rb) = robot_box {
        let mut cand = Vec::new();
        scene.candidates(&rb, &mut cand);
        'objects: for &oi in &cand {
            let o = &scene.objects[oi];
            // From the end effector inward (seed: a collision is likelier there).
            for j in (0..links.links.len()).rev() {
                let (Some(l), Some(p), Some(b)) = (&links.links[j], &lp[j], &boxes[j]) else {
                    continue;
                };
                if !b.overlaps(&o.world_box) {
                    continue;
                }
                let r = narrow(&l.solid, p, &o.solid, &o.pose, settings.mode);
                if record(
                    r,
                    Body::Link(j),
                    Body::Object {
                        index: oi,
                        name: o.name.clone(),
                    },
                    &mut contacts,
                ) {
                    break 'objects;
                }
            }
        }
    }
    if settings.self_collision && (settings.all_contacts || contacts.is_empty()) {
        for (i, j) in links.self_pairs() {
            let (Some(bi), Some(bj)) = (&boxes[i], &boxes[j]) else {
                continue;
            };
            if !bi.overlaps(bj) {
                continue;
            }
            let (Some(li), Some(lj), Some(pi), Some(pj)) =
                (&links.links[i], &links.links[j], &lp[i], &lp[j])
            else {
                continue;
            };
            let r = narrow(&li.solid, pi, &lj.solid, pj, settings.mode);
            if record(r, Body::Link(j), Body::Link(i), &mut contacts) {
                break;
            }
        }
    }
    if !contacts.is_empty() {
        CheckResult::Contact(contacts)
    } else if let Some((a, b, reason)) = doubt {
        CheckResult::Unknown { a, b, reason }
    } else {
        CheckResult::Clear
    }
}

/// The seed's CHECK for one robot at joint values `q` (rad / m) against the in-use objects of
/// `scene`, and against itself when `settings.self_collision` is on. Ignores `settings.enabled`
/// (a direct check is always made). Links are tested from the end effector inward.
pub fn check_robot(
    robot: &Robot,
    links: &LinkSolids,
    q: &[f64],
    scene: &Scene,
    settings: &CollisionSettings,
) -> Result<CheckResult, CheckError> {
    robot.check_q(q)?;
    check_link_count(robot, links)?;
    let lp = link_poses(robot, links, q);
    Ok(check_links(links, &lp, scene, settings))
}

pub(crate) fn check_link_count(robot: &Robot, links: &LinkSolids) -> Result<(), CheckError> {
    if links.links.len() != robot.dof() + 1 {
        return Err(CheckError::LinkCount {
            dof: robot.dof(),
            got: links.links.len(),
            expected: robot.dof() + 1,
        });
    }
    Ok(())
}

/// What a checked move did.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveOutcome {
    /// The joint values the robot ends at: `q_to` if the move completed, else the last safe step.
    pub q: Vec<f64>,
    /// Steps completed (0..=steps).
    pub steps_done: usize,
    pub completed: bool,
    /// Why the move stopped: the contact (or doubt) found at the next step, or along the way to
    /// it when continuous checking is on.
    pub stopped_by: Option<CheckResult>,
    /// With continuous checking: the fraction (0..1] of the failing step at which the first
    /// contact was found.
    pub time_of_impact: Option<f64>,
}

/// MOVEJI with collision on (MOVEJ is `steps = 1`): joint-space linear interpolation from
/// `q_from` to `q_to` in `steps` equal steps; each step is checked (and, with
/// `settings.continuous`, the motion between steps is swept, see [`crate::ccd`]). Stops at the
/// last safe step and says which pair collided. `q_from` itself is checked first (a robot that
/// starts in contact does not move). With `settings.enabled` off, moves unchecked (C_SWITCH off).
#[allow(clippy::too_many_arguments)]
pub fn move_checked(
    robot: &Robot,
    links: &LinkSolids,
    q_from: &[f64],
    q_to: &[f64],
    steps: usize,
    scene: &Scene,
    settings: &CollisionSettings,
) -> Result<MoveOutcome, CheckError> {
    robot.check_q(q_from)?;
    robot.check_q(q_to)?;
    check_link_count(robot, links)?;
    if steps == 0 {
        return Err(CheckError::ZeroSteps);
    }
    if !settings.enabled {
        return Ok(MoveOutcome {
            q: q_to.to_vec(),
            steps_done: steps,
            completed: true,
            stopped_by: None,
            time_of_impact: None,
        });
    }
    let at = |k: usize| -> Vec<f64> {
        let s = k as f64 / steps as f64;
        q_from
            .iter()
            .zip(q_to)
            .map(|(a, b)| a + (b - a) * s)
            .collect()
    };
    let start = check_robot(robot, links, q_from, scene, settings)?;
    if !start.is_clear() {
        return Ok(MoveOutcome {
            q: q_from.to_vec(),
            steps_done: 0,
            completed: false,
            stopped_by: Some(start),
            time_of_impact: None,
        });
    }
    let mut prev = q_from.to_vec();
    for k in 1..=steps {
        let next = if k == steps { q_to.to_vec() } else { at(k) };
        if settings.continuous {
            match ccd::sweep_robot(
                robot,
                links,
                &prev,
                &next,
                scene,
                settings.self_collision,
                &ccd::SweepOptions::default(),
            )? {
                ccd::Sweep::Clear => {}
                ccd::Sweep::Contact { s, collision } => {
                    return Ok(MoveOutcome {
                        q: prev,
                        steps_done: k - 1,
                        completed: false,
                        stopped_by: Some(CheckResult::Contact(vec![collision])),
                        time_of_impact: Some(s),
                    });
                }
                ccd::Sweep::Unknown { a, b, reason } => {
                    return Ok(MoveOutcome {
                        q: prev,
                        steps_done: k - 1,
                        completed: false,
                        stopped_by: Some(CheckResult::Unknown { a, b, reason }),
                        time_of_impact: None,
                    });
                }
            }
        }
        let r = check_robot(robot, links, &next, scene, settings)?;
        if !r.is_clear() {
            return Ok(MoveOutcome {
                q: prev,
                steps_done: k - 1,
                completed: false,
                stopped_by: Some(r),
                time_of_impact: None,
            });
        }
        prev = next;
    }
    Ok(MoveOutcome {
        q: prev,
        steps_done: steps,
        completed: true,
        stopped_by: None,
        time_of_impact: None,
    })
}
