//! The ORU swap (the `oru_swap` effect a scene may declare): a manipulator — the servicer —
//! takes a failed orbital replacement unit (ORU) off the robot that carries it, sets it down
//! beside the spare, and bolts the spare in its place. The plan is the same code for `robosim
//! study station` and the simulator daemon's swap stage; what each does with it:
//!
//! * [`Swap::from_scene`] reads the scene (its box parts, [`SceneParts`]): the servicer (a placed robot), the failed ORU (a box
//!   part named `oru…` on a link of another robot, the last found), the spare (a placed solid
//!   with such a box), the service angle of the carrying robot (its ORU's grapple facing up,
//!   [`crate::power::track`]) and the ORUs as scene objects;
//! * [`Swap::task`] solves the waypoints by inverse kinematics, [`Swap::schedule`] times them at
//!   the servicer's speed limits ([`servicer_speed`]) into a [`Plan`];
//! * [`Swap::state`] is where each ORU is at a time (on the mount, in the grip, set down) and
//!   whether the carrying robot is parked; [`Swap::frame`] is an ORU's world frame.
//!
//! The ORU frame is the grapple fixture's: the centre of the box's top face, z out of the box.
//!
//! Entry points: [`Swap`], [`Plan`], [`servicer_at`].

use crate::power::{self, SolarArray};
use nalgebra::{Isometry3, Matrix4, Point3, Vector3};
use robosim_collision::robot::isometry_from_matrix;
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::{Robot, fk};
use robosim_model::OruSwapEffect;
use robosim_model::parts::{BoxPart, SceneParts};

/// Why a swap cannot be planned: what and where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SwapError(pub String);

type Result<T> = std::result::Result<T, SwapError>;

macro_rules! bail {
    ($($t:tt)*) => { return Err(SwapError(format!($($t)*))) };
}

/// The grapple fixture's height: the effector's tip stops this far above the ORU's frame
/// (the fixture is not a body), m.
pub const GRAPPLE_M: f64 = 0.05;
/// Where the failed ORU is stowed: beside the spare on the truss top (body frame, m): the
/// ORU frame's position, 1.2 m along the truss from the spare's.
pub const STOW_OFFSET: [f64; 3] = [0.0, 1.2, 0.0];

/// The ORU's box among `parts` (a box whose leaf name starts with `oru`: `oru_box` in the
/// solid, `oru0` where the solar structure places it), with its height (box z).
fn oru_box(parts: &[BoxPart]) -> Option<(&BoxPart, f64)> {
    // a solid placed as a part takes the placing part's name (`oru0` on the mast)
    parts
        .iter()
        .find(|s| s.leaf().starts_with("oru"))
        .map(|s| (s, s.size[2]))
}

/// The swap read from a scene ([`Swap::from_scene`]).
#[derive(Debug, Clone)]
pub struct Swap {
    /// The servicer: index into the scene's robots, its kinematics (base placed) and start q.
    pub servicer: usize,
    pub servicer_robot: Robot,
    pub servicer_q0: Vec<f64>,
    /// The robot carrying the failed ORU: index into the scene's robots, its kinematics, the
    /// link the ORU rides on and the ORU frame in that link's frame.
    pub array: usize,
    pub array_robot: Robot,
    pub link: usize,
    pub mount: Isometry3<f64>,
    /// The spare's ORU frame in the world.
    pub spare: Isometry3<f64>,
    /// The carrying robot's joints with the ORU's grapple facing up (+z world): the service
    /// angle at which it is parked while the servicer works on it.
    pub service_q: Vec<f64>,
    /// The ORUs as objects of the scene (failed, spare): the object's path (names below the
    /// scene, as the display and the Instance Space name them) and its frame in the ORU frame.
    pub objects: [(String, Isometry3<f64>); 2],
    /// The failed ORU's part name on the carrying robot's link, and the box heights (failed,
    /// spare), m.
    pub failed_part: String,
    pub heights: [f64; 2],
    /// When the task starts, s (the declaration's).
    pub start_s: f64,
}

impl Swap {
    /// The swap `fx` declares in `scene`; an error names what the scene lacks.
    pub fn from_scene(scene: &SceneParts, fx: &OruSwapEffect) -> Result<Swap> {
        let lift = |h: f64| Isometry3::translation(0.0, 0.0, h / 2.0);
        let Some(si) = scene.robots.iter().position(|r| r.name == fx.servicer) else {
            bail!(
                "{}: oru_swap's servicer {} is not a placed robot",
                scene.name,
                fx.servicer
            );
        };
        // the failed ORU: on a link of another robot
        let mut found = None;
        for (ri, placed) in scene.robots.iter().enumerate() {
            if ri == si {
                continue;
            }
            for (link, parts) in placed.frames.iter().enumerate() {
                if let Some((solid, h)) = oru_box(parts) {
                    let mount = isometry_from_matrix(&solid.transform) * lift(h);
                    found = Some((ri, link, mount, solid.name.clone(), h));
                }
            }
        }
        let Some((ai, link, mount, name, h_failed)) = found else {
            bail!(
                "{}: no robot carries an ORU (a box part named oru…)",
                scene.name
            );
        };
        let placed = &scene.robots[ai];
        let Some(link_name) = link.checked_sub(1).and_then(|l| placed.link_names.get(l)) else {
            bail!(
                "{}: its ORU {name} rides on the base, not on a link",
                placed.name
            );
        };
        // the spare: a placed solid
        let Some(item) = scene.solids.iter().find(|x| x.name == fx.spare) else {
            bail!("{} places no {}", scene.name, fx.spare);
        };
        let Some((solid, h)) = oru_box(&item.parts) else {
            bail!("{}: {} has no box part named oru…", scene.name, fx.spare);
        };
        let spare = isometry_from_matrix(&(item.placement * solid.transform)) * lift(h);
        // the objects: the failed ORU is the part on the link (its frame the box's), the spare
        // the placed item (its frame the placement)
        let objects = [
            (
                format!("{}/{link_name}/{name}", placed.name),
                lift(h_failed).inverse(),
            ),
            (
                item.name.clone(),
                (isometry_from_matrix(&solid.transform) * lift(h)).inverse(),
            ),
        ];
        // the service angle: the grapple's z axis up
        let up = SolarArray {
            area_m2: 0.0,
            normal: mount * Vector3::z(),
            link,
        };
        let robot = &placed.robot;
        let (service_q, c) = power::track(robot, &up, &placed.q, &Vector3::z(), 1e-9);
        if c < 1.0 - 1e-9 {
            bail!(
                "{}: no joint angle turns its ORU's grapple up (best {:.2}° off)",
                placed.name,
                c.clamp(-1.0, 1.0).acos().to_degrees()
            );
        }
        Ok(Swap {
            servicer: si,
            servicer_robot: scene.robots[si].robot.clone(),
            servicer_q0: scene.robots[si].q.clone(),
            array: ai,
            array_robot: robot.clone(),
            link,
            mount,
            spare,
            service_q,
            objects,
            failed_part: name,
            heights: [h_failed, h],
            start_s: fx.start_s,
        })
    }

    /// The world frame of the mount (the failed ORU's place) with the carrying robot at `q`.
    pub fn mount_at(&self, q: &[f64]) -> Isometry3<f64> {
        let f = fk::link_frames(&self.array_robot, q);
        isometry_from_matrix(&f[self.link]) * self.mount
    }

    /// The servicer's effector frame at `q`.
    pub fn effector(&self, q: &[f64]) -> Isometry3<f64> {
        isometry_from_matrix(&fk::forward(&self.servicer_robot, q))
    }
    /// The sites of the swap (body frame, m): the failed ORU's frame with its array parked at the
    /// service angle, the spare's, and where the failed one is stowed.
    pub fn sites(&self) -> [Point3<f64>; 3] {
        self.sites_with(&Vector3::from(STOW_OFFSET))
    }

    /// [`Swap::sites`] with the failed ORU stowed at `stow_offset` from the spare (body frame,
    /// m) instead of [`STOW_OFFSET`].
    pub fn sites_with(&self, stow_offset: &Vector3<f64>) -> [Point3<f64>; 3] {
        let oru = self.mount_at(&self.service_q);
        let spare = self.spare.translation.vector;
        [
            Point3::from(oru.translation.vector),
            Point3::from(spare),
            Point3::from(spare + stow_offset),
        ]
    }

    /// The ORU swap: travel along the truss (the array carrying the failed ORU parks with its
    /// grapple up), reach over the ORU, grasp it, lift it out, carry it over the truss and set it
    /// down beside the spare, take the spare, carry it out, insert and bolt it, withdraw, return
    /// (the array tracks again). The effector's tip stops [`GRAPPLE_M`] above each ORU frame. The
    /// poses are solved by inverse kinematics (damped least squares over all six joints, rail
    /// included, seeded from the pose before); a site the servicer cannot reach is an error
    /// naming it.
    pub fn task(&self) -> Result<Vec<Waypoint>> {
        self.task_with(&Vector3::from(STOW_OFFSET))
    }

    /// [`Swap::task`] with the failed ORU stowed at `stow_offset` from the spare (body frame, m):
    /// the same waypoints (indices as [`SwapStep::waypoints`] names them), the stowage's solved
    /// for that site.
    pub fn task_with(&self, stow_offset: &Vector3<f64>) -> Result<Vec<Waypoint>> {
        let robot = &self.servicer_robot;
        let q0 = self.servicer_q0.clone();
        let solve = |what: &str, p: Point3<f64>, up: f64, seed: &[f64]| -> Result<Vec<f64>> {
            let p = [p.x, p.y, p.z + GRAPPLE_M + up];
            let opts = IkOptions {
                q0: Some(seed.to_vec()),
                ..IkOptions::default()
            };
            match ik::solve(robot, &down_at(p), Method::Dls, &opts) {
                Ok(r) => r
                    .solutions
                    .into_iter()
                    .next()
                    .map(|x| x.q)
                    .ok_or_else(|| SwapError(format!("servicer: no pose {what}"))),
                Err(e) => Err(SwapError(format!(
                    "servicer cannot reach {what} at ({:.2}, {:.2}, {:.2}) m: {e}",
                    p[0], p[1], p[2]
                ))),
            }
        };
        let [oru, spare, stow] = self.sites_with(stow_offset);
        let mut at_site = q0.clone();
        at_site[0] =
            (oru.y - robot.base[(1, 3)]).clamp(robot.joints[0].qlim[0], robot.joints[0].qlim[1]);
        let reach = solve("above the ORU", oru, ABOVE, &at_site)?;
        let grasp = solve("the ORU", oru, 0.0, &reach)?;
        let over_stow = solve("above the stowage", stow, ABOVE, &reach)?;
        let stow_q = solve("the stowage", stow, 0.0, &over_stow)?;
        let over_spare = solve("above the spare", spare, ABOVE, &over_stow)?;
        let spare_q = solve("the spare", spare, 0.0, &over_spare)?;
        let w = |what: &'static str, q: &Vec<f64>, dwell_s: f64| Waypoint {
            what,
            q: q.clone(),
            dwell_s,
            on_arrival: None,
            after_dwell: None,
        };
        let mut out = vec![
            w("start, stowed", &q0, 0.0),
            Waypoint {
                after_dwell: Some(OruEvent::Park),
                ..w("travel along the truss to the ORU site", &at_site, 0.0)
            },
            w(
                "reach over the ORU on the solar structure's mast",
                &reach,
                0.0,
            ),
            Waypoint {
                after_dwell: Some(OruEvent::GraspFailed),
                ..w("grasp the failed ORU and release its bolts", &grasp, 120.0)
            },
            w("lift it out", &reach, 0.0),
            w("carry it over the truss", &over_stow, 0.0),
            Waypoint {
                after_dwell: Some(OruEvent::StowFailed),
                ..w("set the failed ORU down beside the spare", &stow_q, 60.0)
            },
            w("lift off", &over_stow, 0.0),
            w("move over the spare", &over_spare, 0.0),
            Waypoint {
                after_dwell: Some(OruEvent::GraspSpare),
                ..w("take the spare", &spare_q, 60.0)
            },
            w("lift the spare", &over_spare, 0.0),
            w("carry the spare out", &reach, 0.0),
            Waypoint {
                after_dwell: Some(OruEvent::InstallSpare),
                ..w("insert and bolt the spare", &grasp, 180.0)
            },
            w("withdraw", &reach, 0.0),
            // the array tracks again once the servicer is back, clear of its sweep (the study's
            // arrays turn at once: no gimbal rate)
            Waypoint {
                on_arrival: Some(OruEvent::Unpark),
                ..w("fold and return", &q0, 0.0)
            },
        ];
        out.shrink_to_fit();
        Ok(out)
    }

    /// The task as a timed [`Plan`] starting at `start` (s).
    pub fn schedule(&self, start: f64) -> Result<Plan> {
        Ok(self.timed(&self.task()?, start))
    }

    /// `waypoints` timed from `start` (s): the first is reached at `start`, each next one when
    /// the slowest joint gets there at its speed limit ([`servicer_speed`]), dwells added; the
    /// ORU events at their times.
    pub fn timed(&self, waypoints: &[Waypoint], start: f64) -> Plan {
        let speed = servicer_speed(&self.servicer_robot);
        let mut out: Vec<(f64, Vec<f64>, &'static str)> = Vec::new();
        let mut events = Vec::new();
        let mut t = start;
        let mut prev: Option<&Vec<f64>> = None;
        for w in waypoints {
            if let Some(p) = &prev {
                let dur = p
                    .iter()
                    .zip(&w.q)
                    .zip(&speed)
                    .map(|((a, b), v)| (b - a).abs() / v)
                    .fold(0.0, f64::max);
                t += dur;
            }
            out.push((t, w.q.clone(), w.what));
            if let Some(e) = w.on_arrival {
                events.push((t, e));
            }
            if w.dwell_s > 0.0 {
                t += w.dwell_s;
                out.push((t, w.q.clone(), w.what));
            }
            if let Some(e) = w.after_dwell {
                events.push((t, e));
            }
            prev = Some(&w.q);
        }
        Plan {
            points: out,
            events,
        }
    }

    /// The swap's state at `t`: the plan's events up to and including `t` applied in order.
    pub fn state(&self, plan: &Plan, t: f64) -> OruState {
        let mut st = OruState {
            failed: Held::OnArray,
            spare: Held::Fixed(self.spare),
            parked: false,
        };
        let mount_world = || self.mount_at(&self.service_q);
        for &(te, e) in &plan.events {
            if te > t {
                break;
            }
            let end = self.effector(&servicer_at(&plan.points, te).0);
            match e {
                OruEvent::Park => st.parked = true,
                OruEvent::Unpark => st.parked = false,
                OruEvent::GraspFailed => st.failed = Held::Carried(end.inverse() * mount_world()),
                OruEvent::StowFailed => {
                    if let Held::Carried(g) = st.failed {
                        st.failed = Held::Fixed(end * g);
                    }
                }
                OruEvent::GraspSpare => {
                    if let Held::Fixed(w) = st.spare {
                        st.spare = Held::Carried(end.inverse() * w);
                    }
                }
                OruEvent::InstallSpare => st.spare = Held::OnArray,
            }
        }
        st
    }

    /// The world frame of an ORU held as `h`, with the array at `q_array` and the servicer at
    /// `q_servicer`.
    pub fn frame(&self, h: Held, q_array: &[f64], q_servicer: &[f64]) -> Isometry3<f64> {
        match h {
            Held::OnArray => self.mount_at(q_array),
            Held::Carried(g) => self.effector(q_servicer) * g,
            Held::Fixed(w) => w,
        }
    }
}

/// What happens to the ORUs at a point of the task.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OruEvent {
    /// The array carrying the failed ORU is parked at its service angle (grapple up).
    Park,
    /// The servicer holds the failed ORU (its bolts released).
    GraspFailed,
    /// The failed ORU is set down beside the spare, fixed there.
    StowFailed,
    /// The servicer holds the spare.
    GraspSpare,
    /// The spare is bolted on the array's mount.
    InstallSpare,
    /// The array tracks the sun again.
    Unpark,
}

/// One segment of the servicer's task: joint values to reach, a dwell there, and what happens
/// to the ORUs on arrival and after the dwell.
#[derive(Debug, Clone)]
pub struct Waypoint {
    pub what: &'static str,
    pub q: Vec<f64>,
    pub dwell_s: f64,
    pub on_arrival: Option<OruEvent>,
    pub after_dwell: Option<OruEvent>,
}

/// Height of the reach pose above each site, m.
pub const ABOVE: f64 = 2.5;

/// The swap's steps as a planner sequences them (`oru_swap.clp`, the station study's
/// `oru_plan`): each a run of [`Swap::task`]'s waypoints, parking and unparking the array
/// steps of their own (no motion).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SwapStep {
    /// Along the truss to the ORU site.
    Travel,
    /// The carrying robot turned to its service angle.
    Park,
    /// Reach over the failed ORU, grasp it and release its bolts.
    Grasp,
    /// Lift it out and carry it over the truss.
    Remove,
    /// Set it down beside the spare, lift off.
    SetDown,
    /// Move over the spare, take it, lift it.
    TakeSpare,
    /// Carry the spare out, insert and bolt it.
    Install,
    /// Withdraw, fold and return to the start.
    Return,
    /// The carrying robot tracks again.
    Unpark,
}

impl SwapStep {
    pub const ALL: [SwapStep; 9] = [
        SwapStep::Travel,
        SwapStep::Park,
        SwapStep::Grasp,
        SwapStep::Remove,
        SwapStep::SetDown,
        SwapStep::TakeSpare,
        SwapStep::Install,
        SwapStep::Return,
        SwapStep::Unpark,
    ];

    /// The rule base's name for it.
    pub fn name(self) -> &'static str {
        match self {
            SwapStep::Travel => "travel",
            SwapStep::Park => "park",
            SwapStep::Grasp => "grasp",
            SwapStep::Remove => "remove",
            SwapStep::SetDown => "set-down",
            SwapStep::TakeSpare => "take-spare",
            SwapStep::Install => "install",
            SwapStep::Return => "return",
            SwapStep::Unpark => "unpark",
        }
    }

    pub fn parse(s: &str) -> Option<SwapStep> {
        SwapStep::ALL.into_iter().find(|x| x.name() == s)
    }

    /// Its waypoints among [`Swap::task`]'s (empty for parking and unparking).
    pub fn waypoints(self) -> std::ops::Range<usize> {
        match self {
            SwapStep::Travel => 1..2,
            SwapStep::Park => 2..2,
            SwapStep::Grasp => 2..4,
            SwapStep::Remove => 4..6,
            SwapStep::SetDown => 6..8,
            SwapStep::TakeSpare => 8..11,
            SwapStep::Install => 11..13,
            SwapStep::Return => 13..15,
            SwapStep::Unpark => 15..15,
        }
    }

    /// The event of a step without motion.
    pub fn event(self) -> Option<OruEvent> {
        match self {
            SwapStep::Park => Some(OruEvent::Park),
            SwapStep::Unpark => Some(OruEvent::Unpark),
            _ => None,
        }
    }
}

/// The servicer's effector pose at `p` pointing down (z = −z body, x = +x body).
fn down_at(p: [f64; 3]) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m[(1, 1)] = -1.0;
    m[(2, 2)] = -1.0;
    m[(0, 3)] = p[0];
    m[(1, 3)] = p[1];
    m[(2, 3)] = p[2];
    m
}

/// Joint speed limits of the servicer: rail 0.05 m/s, revolute joints 1°/s (the scale of the
/// station's mobile servicing system, which moves at centimetres per second).
pub fn servicer_speed(robot: &Robot) -> Vec<f64> {
    robot
        .joints
        .iter()
        .map(|j| match j.joint_type {
            robosim_kinematics::JointType::Prismatic => 0.05,
            robosim_kinematics::JointType::Revolute => 1f64.to_radians(),
        })
        .collect()
}

/// The task timed: the servicer's (t, q, what) at each waypoint arrival and departure
/// (segments timed by the slowest joint at its speed limit) and the ORU events in time order.
#[derive(Debug, Clone)]
pub struct Plan {
    pub points: Vec<(f64, Vec<f64>, &'static str)>,
    pub events: Vec<(f64, OruEvent)>,
}

/// Where an ORU is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Held {
    /// On the array's mount (moving with its link).
    OnArray,
    /// In the servicer's effector: its frame at the effector frame × this grip.
    Carried(Isometry3<f64>),
    /// Set down: its frame in the body frame.
    Fixed(Isometry3<f64>),
}

/// The swap's state at a time: where each ORU is, and whether the array is parked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OruState {
    pub failed: Held,
    pub spare: Held,
    pub parked: bool,
}

/// The servicer's planned joint values at `t` (linear in joint space between schedule points;
/// before the start and after the end, at rest there), and what it is doing.
pub fn servicer_at(sched: &[(f64, Vec<f64>, &'static str)], t: f64) -> (Vec<f64>, &'static str) {
    let first = &sched[0];
    if t <= first.0 {
        return (first.1.clone(), "waiting");
    }
    for w in sched.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if t <= b.0 {
            let u = if b.0 > a.0 {
                (t - a.0) / (b.0 - a.0)
            } else {
                1.0
            };
            let q = a.1.iter().zip(&b.1).map(|(x, y)| x + u * (y - x)).collect();
            return (q, b.2);
        }
    }
    let last = &sched[sched.len() - 1];
    (last.1.clone(), "done")
}
