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

pub use crate::bodies::{
    Body, CheckError, Collision, LinkSolid, LinkSolids, Scene, SceneObject, isometry_from_matrix,
    link_poses,
};

use crate::bbox::{exact_box, world_box};
use crate::bodies::check_link_count;
use crate::ccd;
use crate::exact::{self, ExactOptions, Tolerance};
use crate::outcome::{Mode, PairResult};
use crate::polygon::{self, PolygonOptions};
use crate::solid::Solid;
use nalgebra::Isometry3;
use robosim_geometry::Aabb;
use robosim_kinematics::{KinematicModel, Robot};

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
    /// Exact mode: the penetration depth and witness points of each contact reported, to this
    /// tolerance, computed for those pairs only once the certified boolean has found them.
    /// `None`: the boolean alone (what the simulator's collision stage asks). Every pair is
    /// tested by the boolean either way.
    pub depth: Option<Tolerance>,
}

impl Default for CollisionSettings {
    fn default() -> Self {
        CollisionSettings {
            enabled: true,
            self_collision: true,
            mode: Mode::Exact,
            all_contacts: false,
            continuous: false,
            depth: Some(Tolerance::Certified),
        }
    }
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

/// One pair in the chosen mode: the boolean only in exact mode (certified; no distance, no
/// depth). Allocates nothing unless the answer is `Unknown` (its reason).
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
        Mode::Exact if !boxes_may_meet(a, pa, b, pb) => PairResult::Clear {
            distance: None,
            witness: None,
        },
        Mode::Exact => exact::collide(a, pa, b, pb, ExactOptions::BOOLEAN),
    }
}

/// The seed's two-way box test (each solid's own box carried into the other's frame, Eq. 8–9)
/// as the exact mode's mid-phase: the world boxes of a rotated link are loose, its own box is
/// not. Each box is the faceted form's, widened by the tessellation error (so that it holds
/// the exact solid, whatever the facet count) and by 1e-9 of its size and a nanometre, far
/// above the rounding of the dilation product, so a touching pair is never culled.
fn boxes_may_meet(a: &Solid, pa: &Isometry3<f64>, b: &Solid, pb: &Isometry3<f64>) -> bool {
    let widened = |s: &Solid| {
        let x = exact_box(s);
        let margin = 1e-9 * (1.0 + x.center.coords.norm() + x.half.norm());
        Aabb {
            center: x.center,
            half: x.half.add_scalar(margin),
        }
    };
    crate::bbox::overlap_two_way(&widened(a), pa, &widened(b), pb)
}

/// The depth and witness points of a pair [`narrow`] found in contact, when the settings ask
/// for them (exact mode; the other modes' answers already carry what they have).
fn detail(
    r: PairResult,
    a: &Solid,
    pa: &Isometry3<f64>,
    b: &Solid,
    pb: &Isometry3<f64>,
    settings: &CollisionSettings,
) -> PairResult {
    let Some(tolerance) = settings.depth else {
        return r;
    };
    if settings.mode != Mode::Exact || !matches!(r, PairResult::Contact { .. }) {
        return r;
    }
    exact::collide(
        a,
        pa,
        b,
        pb,
        ExactOptions {
            distance: false,
            depth: true,
            tolerance,
        },
    )
}

/// World boxes of the link solids at poses `lp`: of the exact solids in exact mode
/// ([`exact_box`]), of the faceted ones otherwise.
fn link_boxes(links: &LinkSolids, lp: &[Option<Isometry3<f64>>], mode: Mode) -> Vec<Option<Aabb>> {
    links
        .links
        .iter()
        .zip(lp)
        .map(|(l, p)| match (l, p) {
            (Some(l), Some(p)) if mode == Mode::Exact => Some(world_box(&exact_box(&l.solid), p)),
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
        let boxes = link_boxes(r.links, &lp, settings.mode);
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
                    let r = narrow(&la.solid, pa, &lb.solid, pb, settings.mode);
                    match detail(r, &la.solid, pa, &lb.solid, pb, settings) {
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
    let boxes = link_boxes(links, lp, settings.mode);
    let robot_box = merged_box(&boxes);
    let mut contacts = Vec::new();
    let mut doubt: Option<(Body, Body, String)> = None;
    // The bodies are named (an object's name copied) only for a pair that is reported.
    let mut record =
        |r: PairResult, bodies: &dyn Fn() -> (Body, Body), contacts: &mut Vec<Collision>| -> bool {
            match r {
                PairResult::Clear { .. } => false,
                PairResult::Contact {
                    signed_distance,
                    witness,
                } => {
                    let (a, b) = bodies();
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
                        let (a, b) = bodies();
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
            let o = &scene.objects()[oi];
            // From the end effector inward (seed: a collision is likelier there).
            for j in (0..links.links.len()).rev() {
                let (Some(l), Some(p), Some(b)) = (&links.links[j], &lp[j], &boxes[j]) else {
                    continue;
                };
                let object_box = if settings.mode == Mode::Exact {
                    o.exact_world_box()
                } else {
                    o.world_box()
                };
                if !b.overlaps(object_box) {
                    continue;
                }
                let r = narrow(&l.solid, p, &o.solid, &o.pose, settings.mode);
                let r = detail(r, &l.solid, p, &o.solid, &o.pose, settings);
                let bodies = || {
                    (
                        Body::Link(j),
                        Body::Object {
                            index: oi,
                            name: o.name.clone(),
                        },
                    )
                };
                if record(r, &bodies, &mut contacts) {
                    break 'objects;
                }
            }
        }
    }
    if settings.self_collision && (settings.all_contacts || contacts.is_empty()) {
        for (i, j) in links.self_pair_iter() {
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
            let r = detail(r, &li.solid, pi, &lj.solid, pj, settings);
            if record(r, &|| (Body::Link(j), Body::Link(i)), &mut contacts) {
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

/// [`check_robot`] with the link frames from `kin`, `robot` compiled once
/// ([`KinematicModel::new`]) by a caller that checks the same robot again and again (the
/// simulator's collision stage, MOVEJ's steps): the same poses and answers, bit for bit,
/// without re-deriving the joints' constant geometry per check. `kin` must be compiled from
/// `robot` (its snapshot; `robot` is read for the q and link-count checks).
pub fn check_robot_compiled(
    kin: &KinematicModel,
    robot: &Robot,
    links: &LinkSolids,
    q: &[f64],
    scene: &Scene,
    settings: &CollisionSettings,
) -> Result<CheckResult, CheckError> {
    robot.check_q(q)?;
    check_link_count(robot, links)?;
    let lp = link_poses_compiled(kin, links, q);
    Ok(check_links(links, &lp, scene, settings))
}

/// [`link_poses`] from `kin` (compiled from the robot once): the same poses, bit for bit.
pub fn link_poses_compiled(
    kin: &KinematicModel,
    links: &LinkSolids,
    q: &[f64],
) -> Vec<Option<Isometry3<f64>>> {
    let mut frames = vec![nalgebra::Matrix4::identity(); kin.dof() + 2];
    kin.link_frames_into(q, &mut frames);
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
    // Compiled once for the move: every step's check reads it.
    let kin = KinematicModel::new(robot);
    let start = check_robot_compiled(&kin, robot, links, q_from, scene, settings)?;
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
            match ccd::sweep_robot_compiled(
                &kin,
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
        let r = check_robot_compiled(&kin, robot, links, &next, scene, settings)?;
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
