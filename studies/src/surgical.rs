//! `robosim demo`: a headless session that does real work and reports what it did. Every
//! number printed is computed in this run; every step goes through the real crates, the real
//! processes and the shared memory.
//!
//! The scene is the standard library's `surgical_positioner_cell` (seed §2.7: the kinematic
//! surgical positioner beside the patient's head). Steps:
//! 1. start the session (keeper and simulator daemon, each its own process);
//! 2. attach a reader: the model is mapped from shared memory; the mapped robot is checked
//!    against the Library Space evaluation of the same scene;
//! 3. kinematics: a tool pose 1 mm off the head (the seed's 20.1 cm from its axis), derived
//!    from the head's pose in the snapshot; all analytic IK solutions (seed §2.4);
//! 4. collision: every solution's link solids against the head in the scene's declared mode
//!    (seed §2.6); a collision-free solution whose MOVEJI path is also clear is kept; then the
//!    seed's whole sweep (861 tool poses over the head: reached clear / out of reach /
//!    blocked, and the worst 12-bit position bound);
//! 5. MOVEJI (appendix 2.2): each interpolated step one journaled transaction; the reader sees
//!    every version, in order, naming only the links;
//! 6. the simulator daemon's state for the new structure version;
//! 7. the twelve-bit encoder study at the final pose (seed §2.7);
//! 8. dynamics: link masses from the link solids (aluminium; the positioner declares none),
//!    gravity torques at the final pose checked against ∂V/∂q, held and unpowered runs;
//! 9. automation: an ECLSS fault with its own sensor failed, its alarms, the diagnosis
//!    (seed §4.3); and a two-sensor case that stays ambiguous;
//! 10. bad input refused whole; 11. clean stop.
//!
//! Entry point: [`run`].

use crate::common::collision_solids;
use crate::{Result, bail, say};
use nalgebra::{Matrix4, Vector3};
use robosim_collision::Mode;
use robosim_collision::robot::{
    Body, CheckResult, CollisionSettings, LinkSolids, Scene, check_robot, isometry_from_matrix,
    move_checked,
};
use robosim_geometry::MassProperties;
use robosim_instance_space::state::StateSubscriber;
use robosim_instance_space::{Client, Kind, Reader, Session, Snapshot, Transaction, aspect};
use robosim_kinematics::ik::{self, IkOptions, IkResult, Method};
use robosim_kinematics::{Robot, encoder, movej_interpolate, pose::Residual};
use robosim_launcher as launcher;
use robosim_library::{
    CollisionMode, Evaluated, Library, Params, PlacedRobot, PlacedSolid, Primitive, RobotModel,
    SceneModel,
};
use robosim_scene::pose::to_matrix as m4;
use robosim_scene::{CompiledRobot, CompiledScene, joint_tx};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The library scene the demo runs.
const SCENE: &str = "surgical_positioner_cell";
/// The seed's §2.7 study: the tool tip 20.1 cm from the head's axis (1 mm off its surface).
const TIP_FROM_AXIS: f64 = 0.201;
/// Where on the head the demo aims: this angle above the horizontal, towards the robot's side…
const ARC_DEG: f64 = 45.0;
/// …and this far along the head's axis from its centre, m.
const ALONG_AXIS: f64 = 0.05;
/// MOVEJI steps.
const STEPS: usize = 30;

struct SessionGuard {
    name: String,
    remove_dir: bool,
}

impl Drop for SessionGuard {
    fn drop(&mut self) {
        let _ = launcher::down(Some(&self.name));
        if self.remove_dir
            && let Ok(s) = Session::open(Some(&self.name))
        {
            let _ = std::fs::remove_dir_all(s.dir());
        }
    }
}

fn xyz(m: &Matrix4<f64>) -> String {
    format!("({:+.3}, {:+.3}, {:+.3})", m[(0, 3)], m[(1, 3)], m[(2, 3)])
}

fn vec_str(v: &[f64], digits: usize) -> String {
    let scale = 10f64.powi(digits as i32);
    // Rounded first, and + 0.0 so that a value rounding to zero prints without a minus sign.
    let parts: Vec<String> = v
        .iter()
        .map(|x| format!("{:+.digits$}", (x * scale).round() / scale + 0.0))
        .collect();
    format!("[{}]", parts.join(", "))
}

/// The robot's link solids (base first): its robot model's
/// ([`robosim_model::Model::collision_solids`]: one solid per frame, a compound where a frame
/// carries several parts).
fn link_solids(model: &RobotModel) -> Result<LinkSolids> {
    model
        .model()
        .collision_solids()
        .map_err(|e| crate::StudyError::at(format!("robot {}", model.robot.name), e))
}

/// The scene's fixed solids as collision obstacles, in the world.
fn obstacles(scene: &SceneModel) -> Result<Scene> {
    let mut out = Scene::new();
    for it in &scene.solids {
        for p in &it.solid.parts {
            let pose = isometry_from_matrix(&(it.placement * p.transform));
            for solid in collision_solids(p, &it.name)? {
                out.add(it.name.clone(), Arc::new(solid), pose);
            }
        }
    }
    Ok(out)
}

fn body_name(b: &Body, link_names: &[String]) -> String {
    match b {
        Body::Object { name, .. } => name.clone(),
        Body::Link(0) | Body::RobotLink { link: 0, .. } => "base".into(),
        Body::Link(j) | Body::RobotLink { link: j, .. } => link_names
            .get(j - 1)
            .cloned()
            .unwrap_or_else(|| format!("link {j}")),
    }
}

fn verdict(r: &CheckResult, link_names: &[String]) -> String {
    match r {
        CheckResult::Clear => "clear".into(),
        CheckResult::Contact(cs) => {
            let mut pairs: Vec<String> = cs
                .iter()
                .map(|c| {
                    format!(
                        "{}×{}",
                        body_name(&c.a, link_names),
                        body_name(&c.b, link_names)
                    )
                })
                .collect();
            pairs.dedup();
            format!("HITS {}", pairs.join(", "))
        }
        CheckResult::Unknown { a, b, reason } => format!(
            "unknown ({}×{}: {reason})",
            body_name(a, link_names),
            body_name(b, link_names)
        ),
    }
}

/// The mapped robot of the snapshot: DH rows from the link records, base from the robot
/// object's world pose, tool from its record.
fn mapped_robot(snap: &Snapshot, arm: &CompiledRobot, name: &str) -> Result<Robot> {
    let i = snap
        .find(name)
        .ok_or_else(|| crate::StudyError::Message(format!("no object {name} in the snapshot")))?;
    Ok(Robot {
        base: m4(&snap.world_pose(i)),
        tool: m4(&snap.rec(i).tool),
        ..arm.robot.clone()
    })
}

/// Largest difference between the kinematic data of two robots (DH rows, limits, base, tool).
fn kinematic_difference(a: &Robot, b: &Robot) -> f64 {
    if a.dof() != b.dof() || a.convention != b.convention {
        return f64::INFINITY;
    }
    let mut d: f64 = (a.base - b.base)
        .abs()
        .max()
        .max((a.tool - b.tool).abs().max());
    for (x, y) in a.joints.iter().zip(&b.joints) {
        if x.joint_type != y.joint_type {
            return f64::INFINITY;
        }
        for (p, q) in [
            (x.a, y.a),
            (x.d, y.d),
            (x.alpha, y.alpha),
            (x.offset, y.offset),
            (x.qlim[0], y.qlim[0]),
            (x.qlim[1], y.qlim[1]),
        ] {
            d = d.max((p - q).abs());
        }
    }
    d
}

/// The head's frame for the seed's `get_location(angle)`: its centre and axis (signed to point
/// along the world's positive side of it; the seed's head axis is world +y), the horizontal
/// direction towards the robot's side and the upward normal of the two.
pub struct HeadFrame {
    centre: Vector3<f64>,
    axis: Vector3<f64>,
    horiz: Vector3<f64>,
    up: Vector3<f64>,
}

impl HeadFrame {
    /// From the head cylinder's world pose (its axis is its local z) and the robot (its base).
    pub fn new(head: &Matrix4<f64>, robot: &Robot) -> HeadFrame {
        let axis: Vector3<f64> = head.fixed_view::<3, 1>(0, 2).into_owned();
        let axis = if axis.sum() < 0.0 { -axis } else { axis };
        let centre: Vector3<f64> = head.fixed_view::<3, 1>(0, 3).into_owned();
        let base_p: Vector3<f64> = robot.base.fixed_view::<3, 1>(0, 3).into_owned();
        let to_robot = base_p - centre;
        let horiz = (to_robot - axis * axis.dot(&to_robot) - Vector3::z() * to_robot.z).normalize();
        let up = axis.cross(&horiz).normalize();
        let up = if up.z < 0.0 { -up } else { up };
        HeadFrame {
            centre,
            axis,
            horiz,
            up,
        }
    }

    /// The seed's get_location: the tool tip `TIP_FROM_AXIS` from the axis, `angle_deg` above
    /// the horizontal towards the robot and `along` m along the axis, tool z pointing at the
    /// axis, tool x along it.
    pub fn location(&self, angle_deg: f64, along: f64) -> Matrix4<f64> {
        let a = angle_deg.to_radians();
        let radial = self.horiz * a.cos() + self.up * a.sin();
        let tip = self.centre + self.axis * along + radial * TIP_FROM_AXIS;
        let z_t = -radial;
        let x_t = self.axis;
        let y_t = z_t.cross(&x_t);
        let mut t = Matrix4::identity();
        for r in 0..3 {
            t[(r, 0)] = x_t[r];
            t[(r, 1)] = y_t[r];
            t[(r, 2)] = z_t[r];
            t[(r, 3)] = tip[r];
        }
        t
    }
}

/// What the seed's reach and accuracy sweep found.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    /// Tool poses tried (41 × 21).
    pub points: usize,
    /// Reached by a solution within limits and clear of the head.
    pub reached: usize,
    /// No IK solution at all.
    pub unreachable: usize,
    /// Worst encoder position bound over the reached points, m, and where: (bound, along the
    /// axis m, angle deg).
    pub worst_position: (f64, f64, f64),
    /// Mean position bound over the reached points, m (0 when none).
    pub mean_position: f64,
    /// Worst orientation bound over the reached points, rad.
    pub worst_orientation: f64,
}

/// The seed's whole §2.7 study: every 1 cm along the head (±20 cm) and every 5° of arc from 0 to
/// 100°; a point counts as reached when some solution is within limits and clear of the head
/// (first contact ends a check). The `bits`-bit bounds are taken at the clear solution nearest
/// `q_start`.
pub fn reach_sweep(
    robot: &Robot,
    links: &LinkSolids,
    obstacles: &Scene,
    settings: &CollisionSettings,
    q_start: &[f64],
    bits: u32,
    frame: &HeadFrame,
) -> Result<Reach> {
    let opts = IkOptions {
        all: true,
        q0: Some(q_start.to_vec()),
        ..IkOptions::default()
    };
    let (mut points, mut reached, mut unreachable) = (0, 0, 0);
    let mut worst = (0.0_f64, 0.0, 0.0);
    let (mut sum, mut worst_orientation) = (0.0, 0.0_f64);
    let first_settings = CollisionSettings {
        all_contacts: false,
        ..*settings
    };
    for cm in -20..=20 {
        let along = cm as f64 / 100.0;
        for step in 0..21 {
            let angle = 5.0 * step as f64;
            points += 1;
            let target = frame.location(angle, along);
            let sols = match ik::solve(robot, &target, Method::Analytic, &opts) {
                Ok(r) => r.solutions,
                Err(ik::IkError::Unreachable { .. }) => {
                    unreachable += 1;
                    continue;
                }
                Err(e) => return Err(crate::StudyError::at(format!("IK at {cm} cm, {angle}°"), e)),
            };
            let mut best: Option<(f64, &ik::IkSolution)> = None;
            for sol in sols.iter().filter(|s| s.converged && s.within_limits) {
                if check_robot(robot, links, &sol.q, obstacles, &first_settings)?.is_clear() {
                    let d: f64 = sol
                        .q
                        .iter()
                        .zip(q_start)
                        .map(|(a, b)| (a - b).powi(2))
                        .sum();
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, sol));
                    }
                }
            }
            if let Some((_, sol)) = best {
                reached += 1;
                let e = encoder::encoder_error(robot, &sol.q, &vec![bits; robot.dof()])?;
                sum += e.position;
                worst_orientation = worst_orientation.max(e.orientation);
                if e.position > worst.0 {
                    worst = (e.position, along, angle);
                }
            }
        }
    }
    Ok(Reach {
        points,
        reached,
        unreachable,
        worst_position: worst,
        mean_position: if reached > 0 {
            sum / reached as f64
        } else {
            0.0
        },
        worst_orientation,
    })
}

/// The §2.7 configuration a sweep point describes (None: the scene's default).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReachParams {
    /// Encoder bits per joint.
    pub bits: Option<u32>,
    /// The positioner's upper arm and forearm, m.
    pub upper_arm_m: Option<f64>,
    pub forearm_m: Option<f64>,
    /// The robot's base from the head's axis, m.
    pub stand_off_m: Option<f64>,
}

/// [`reach_sweep`] on the library's `surgical_positioner_cell` with `p`, no session: the robot,
/// head, collision mode and start pose as the scene declares them.
pub fn reach(p: &ReachParams) -> Result<Reach> {
    let mut params = Params::new();
    for (name, v) in [
        ("upper_arm", p.upper_arm_m),
        ("forearm", p.forearm_m),
        ("stand_off", p.stand_off_m),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0 && v < 10.0) {
                bail!("{name} {v} m: expected a length in (0, 10) m");
            }
            params = params.si(name, v);
        }
    }
    if let Some(b) = p.bits
        && !(1..=52).contains(&b)
    {
        bail!("encoder bits {b}: expected 1 to 52");
    }
    let (_lib, scene) = crate::common::scene(SCENE, &params)?;
    let placed = scene
        .robots
        .first()
        .ok_or_else(|| crate::StudyError::Message(format!("{SCENE} places no robot")))?;
    let head_item = scene
        .solids
        .iter()
        .find(|i| i.name == "head")
        .ok_or_else(|| crate::StudyError::Message(format!("{SCENE} has no head")))?;
    let head_part = head_item
        .solid
        .parts
        .first()
        .ok_or_else(|| crate::StudyError::Message("the head has no solid".into()))?;
    let robot = &placed.model.robot;
    let frame = HeadFrame::new(&(head_item.placement * head_part.transform), robot);
    let bits = match p.bits {
        Some(b) => b,
        None => scene.effects.encoder.map(|e| e.bits).ok_or_else(|| {
            crate::StudyError::Message(format!("{SCENE} declares no encoder bits"))
        })?,
    };
    let settings = settings_of(&scene);
    let links = link_solids(&placed.model)?;
    let obstacles = obstacles(&scene)?;
    reach_sweep(
        robot, &links, &obstacles, &settings, &placed.q, bits, &frame,
    )
}

/// The scene's declared collision checking (polygon when it names no mode), every contact.
fn settings_of(scene: &SceneModel) -> CollisionSettings {
    CollisionSettings {
        enabled: true,
        self_collision: scene.effects.collision.is_some_and(|c| c.self_collision),
        mode: match scene.effects.collision.map(|c| c.mode) {
            Some(CollisionMode::BBox) => Mode::BBox,
            Some(CollisionMode::Exact) => Mode::Exact,
            _ => Mode::Polygon,
        },
        all_contacts: true,
        continuous: false,
        depth: Some(Default::default()),
    }
}

/// Runs the study in session `session` (a fresh one by default) and writes its report to
/// `out` as it goes: the numbered steps of the module docs, one function each.
pub fn run(session: Option<&str>, out: &mut dyn std::io::Write) -> Result<()> {
    let t_start = Instant::now();
    let name = session
        .map(str::to_owned)
        .unwrap_or_else(|| format!("demo{}", std::process::id()));
    let _guard = SessionGuard {
        name: name.clone(),
        remove_dir: session.is_none(),
    };
    let lib = robosim_library::standard_library()
        .ok_or_else(|| crate::StudyError::Message("the standard library failed to load".into()))?;
    let scene = match lib.evaluate(SCENE, &Params::new()) {
        Ok(Evaluated::Scene(s)) => s,
        Ok(_) => bail!("{SCENE} is not a scene"),
        Err(e) => return Err(crate::StudyError::at(SCENE, e)),
    };
    let placed = scene
        .robots
        .first()
        .ok_or_else(|| crate::StudyError::Message(format!("{SCENE} places no robot")))?;

    let s = start_session(out, &name)?;
    let Mapped {
        mut reader,
        robot,
        arm,
        head,
    } = map_model(out, &s, &scene, placed)?;
    let (frame, target, sols) = aim_at_head(out, &robot, &arm.q, &head)?;
    let checks = Checks::of(out, &scene, &placed.model)?;
    let goal = choose_solution(
        out,
        &robot,
        &checks,
        &sols,
        &arm.q,
        &placed.model.link_names,
    )?;
    let bits = seed_sweep(out, &scene, &robot, &checks, &arm.q, &frame)?;
    let (mut client, last_version) =
        move_there(out, &s, &mut reader, &robot, &arm, &goal, &target)?;
    simulator_state(out, &s, &arm, &goal, last_version)?;
    encoder_study(out, &robot, &goal, bits)?;
    gravity_study(out, lib, &placed.model.frames, &robot, &goal)?;

    say!(
        out,
        "\n== 9. automation: an ECLSS fault with its own sensor failed, alarms, diagnosis (seed §4.3)"
    );
    automation(out)?;

    refuse_bad_input(out, &mut client, &reader, &arm)?;

    say!(
        out,
        "\n== 11. stop the session (demo ran {:.1} s)",
        t_start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Step 1: the session on the scene, with the keeper and the simulator daemon.
fn start_session(out: &mut dyn std::io::Write, name: &str) -> Result<Session> {
    say!(
        out,
        "== 1. session on library scene {SCENE} (seed §2.7): keeper + simulator processes"
    );
    launcher::up(SCENE, &["simulator".to_owned()], Some(name))?;
    Ok(Session::open(Some(name))?)
}

/// What step 2 found in shared memory: the reader, the mapped robot, the arm's objects and
/// joint values, and the head's world pose.
struct Mapped {
    reader: Reader,
    robot: Robot,
    arm: CompiledRobot,
    head: Matrix4<f64>,
}

/// Step 2: a reader maps the model; the mapped robot and the head are checked against the
/// Library Space evaluation of the same scene.
fn map_model(
    out: &mut dyn std::io::Write,
    s: &Session,
    scene: &SceneModel,
    placed: &PlacedRobot,
) -> Result<Mapped> {
    say!(
        out,
        "\n== 2. a reader maps the model from shared memory (nothing is copied)"
    );
    let reader = Reader::attach(s, "demo-reader")?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| crate::StudyError::Message("no snapshot".into()))?;
    say_contents(out, &snap)?;
    let compiled = CompiledScene::of(&snap);
    let robots = compiled.robots();
    let arm = robots
        .iter()
        .find(|r| r.robot.name == placed.name)
        .ok_or_else(|| {
            crate::StudyError::Message(format!("robot {} not in the snapshot", placed.name))
        })?;
    let robot = mapped_robot(&snap, arm, &placed.name)?;
    let diff = kinematic_difference(&robot, &placed.model.robot);
    if diff > 1e-12 {
        bail!("the mapped robot differs from the library's by {diff:e} (DH, limits, base, tool)");
    }
    let (head, radius, length) = mapped_head(scene, &snap)?;
    // The cylinder's axis, signed to point along the world's positive side of it (the seed's
    // head axis is world +y).
    let axis: Vector3<f64> = head.fixed_view::<3, 1>(0, 2).into_owned();
    let axis = if axis.sum() < 0.0 { -axis } else { axis };
    say!(
        out,
        "head: cylinder r {radius:.3} m, length {length:.3} m, axis {} through {}; {}: {} joints at q {}",
        vec_str(axis.as_slice(), 2),
        xyz(&head),
        placed.name,
        robot.dof(),
        vec_str(&arm.q, 3)
    );
    say!(
        out,
        "mapped DH rows, limits, base and tool = the Library Space evaluation (max |Δ| {diff:.1e})"
    );
    Ok(Mapped {
        arm: arm.clone(),
        reader,
        robot,
        head,
    })
}

/// "version v: n objects (…), vertices, convex polygons" for a snapshot.
fn say_contents(out: &mut dyn std::io::Write, snap: &Snapshot) -> Result<()> {
    let polygons: usize = (0..snap.len())
        .filter_map(|i| snap.geometry(i))
        .map(|g| g.polygons.len())
        .sum();
    let kinds: Vec<String> = [
        Kind::Scene,
        Kind::Item,
        Kind::Robot,
        Kind::Link,
        Kind::Solid,
    ]
    .iter()
    .map(|k| {
        let n = (0..snap.len())
            .filter(|&i| snap.object(i).kind() == Some(*k))
            .count();
        format!("{n} {}{}", k.name(), if n == 1 { "" } else { "s" })
    })
    .collect();
    say!(
        out,
        "version {}: {} objects ({}), {} vertices, {} convex polygons",
        snap.version(),
        snap.len(),
        kinds.join(", "),
        snap.vertex_count(),
        polygons
    );
    Ok(())
}

/// The head as the snapshot has it: its (only) solid's world pose (a cylinder along z),
/// checked against the library's, with its radius and length.
fn mapped_head(scene: &SceneModel, snap: &Snapshot) -> Result<(Matrix4<f64>, f64, f64)> {
    let head_item = scene
        .solids
        .iter()
        .find(|i| i.name == "head")
        .ok_or_else(|| crate::StudyError::Message(format!("{SCENE} has no head")))?;
    let head_obj = snap
        .find("head")
        .and_then(|i| (0..snap.len()).find(|&k| snap.rec(k).parent == snap.rec(i).id))
        .ok_or_else(|| crate::StudyError::Message("the snapshot has no head solid".into()))?;
    let head = m4(&snap.world_pose(head_obj));
    let head_part = head_item
        .solid
        .parts
        .first()
        .ok_or_else(|| crate::StudyError::Message("the head has no solid".into()))?;
    let head_lib = head_item.placement * head_part.transform;
    if (head - head_lib).abs().max() > 1e-12 {
        bail!("the head's pose in the snapshot differs from the library's");
    }
    let (radius, length) = match head_part.primitive {
        Primitive::Cylinder { radius, height, .. } => (radius, height),
        _ => bail!("the head is not a cylinder"),
    };
    Ok((head, radius, length))
}

/// Step 3: the tool pose 1 mm off the head and every analytic IK solution for it.
fn aim_at_head(
    out: &mut dyn std::io::Write,
    robot: &Robot,
    q: &[f64],
    head: &Matrix4<f64>,
) -> Result<(HeadFrame, Matrix4<f64>, IkResult)> {
    say!(
        out,
        "\n== 3. kinematics: tool tip {:.1} cm from the head's axis, pointing at it (seed §2.7)",
        TIP_FROM_AXIS * 100.0
    );
    let frame = HeadFrame::new(head, robot);
    let target = frame.location(ARC_DEG, ALONG_AXIS);
    say!(
        out,
        "target: tip at {} ({ARC_DEG}° above horizontal, {ALONG_AXIS} m along the axis), tool z towards the axis",
        xyz(&target)
    );
    let family = ik::family::recognise(robot);
    let opts = IkOptions {
        all: true,
        q0: Some(q.to_vec()),
        ..IkOptions::default()
    };
    let t0 = Instant::now();
    let sols = ik::solve(robot, &target, Method::Analytic, &opts)?;
    let ik_us = t0.elapsed().as_secs_f64() * 1e6;
    let worst = sols
        .solutions
        .iter()
        .map(|s| s.residual.position.max(s.residual.orientation))
        .fold(0.0, f64::max);
    say!(
        out,
        "analytic IK ({} family, all solutions): {} solutions in {ik_us:.0} µs, worst residual {worst:.1e} (m / rad)",
        family.name(),
        sols.solutions.len()
    );
    Ok((frame, target, sols))
}

/// Step 4's collision checking: the scene's declared settings, the arm's link solids and the
/// obstacles.
struct Checks {
    settings: CollisionSettings,
    links: LinkSolids,
    obstacles: Scene,
}

impl Checks {
    /// Says which checking the scene declares and builds it.
    fn of(out: &mut dyn std::io::Write, scene: &SceneModel, model: &RobotModel) -> Result<Checks> {
        say!(
            out,
            "\n== 4. collision ({}, the scene's mode; self {}): each solution's link solids against the head",
            match scene.effects.collision.map(|c| c.mode) {
                Some(CollisionMode::BBox) => "bbox",
                Some(CollisionMode::Exact) => "exact",
                _ => "polygon",
            },
            if scene.effects.collision.is_some_and(|c| c.self_collision) {
                "on"
            } else {
                "off"
            }
        );
        Ok(Checks {
            settings: settings_of(scene),
            links: link_solids(model)?,
            obstacles: obstacles(scene)?,
        })
    }
}

/// Step 4: each solution checked against the head; the nearest clear solution within limits
/// whose MOVEJI path is also clear is the goal (its joint values).
fn choose_solution(
    out: &mut dyn std::io::Write,
    robot: &Robot,
    c: &Checks,
    sols: &IkResult,
    q: &[f64],
    link_names: &[String],
) -> Result<Vec<f64>> {
    let mut clear = Vec::new();
    for sol in &sols.solutions {
        let label = sol.branch.map_or("-".into(), |b| b.label());
        let limits = if sol.within_limits {
            "in limits"
        } else {
            "OUT of limits"
        };
        let v = check_robot(robot, &c.links, &sol.q, &c.obstacles, &c.settings)?;
        let dist: f64 = sol
            .q
            .iter()
            .zip(q)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        say!(
            out,
            "  {label} q {} res {:.0e} m {}, {}",
            vec_str(&sol.q, 2),
            sol.residual.position,
            limits,
            verdict(&v, link_names)
        );
        if v.is_clear() && sol.converged && sol.within_limits {
            clear.push((dist, sol));
        }
    }
    clear.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (dist, sol) in &clear {
        let label = sol.branch.map_or("-".into(), |b| b.label());
        let moved = move_checked(robot, &c.links, q, &sol.q, STEPS, &c.obstacles, &c.settings)?;
        if moved.completed {
            say!(
                out,
                "chosen: {label}, collision-free and nearest to the current q ({dist:.2} rad); its {STEPS}-step MOVEJI path is clear"
            );
            return Ok(sol.q.clone());
        }
        let why = moved
            .stopped_by
            .as_ref()
            .map_or("?".into(), |r| verdict(r, link_names));
        say!(
            out,
            "  {label} rejected: its MOVEJI path stops after step {} of {STEPS}: {why}",
            moved.steps_done
        );
    }
    bail!("no IK solution is collision-free with a clear MOVEJI path");
}

/// Step 4, the seed's whole study (see `reach_sweep`); answers the scene's encoder bits.
fn seed_sweep(
    out: &mut dyn std::io::Write,
    scene: &SceneModel,
    robot: &Robot,
    c: &Checks,
    q: &[f64],
    frame: &HeadFrame,
) -> Result<u32> {
    let bits =
        scene.effects.encoder.map(|e| e.bits).ok_or_else(|| {
            crate::StudyError::Message(format!("{SCENE} declares no encoder bits"))
        })?;
    let t0 = Instant::now();
    let reach = reach_sweep(robot, &c.links, &c.obstacles, &c.settings, q, bits, frame)?;
    let Reach {
        points,
        reached,
        unreachable,
        ..
    } = reach;
    let worst_err = reach.worst_position;
    say!(
        out,
        "seed's sweep, {points} points (±20 cm every 1 cm, 0–100° every 5°) in {:.0} ms: {reached} reached clear of the head, {unreachable} out of reach, {} only colliding or beyond limits",
        t0.elapsed().as_secs_f64() * 1e3,
        points - reached - unreachable
    );
    say!(
        out,
        "  worst {bits}-bit position bound over the reached points: {:.3} mm at {:+.0} cm, {:.0}°",
        worst_err.0 * 1e3,
        worst_err.1 * 100.0,
        worst_err.2
    );
    Ok(bits)
}

/// Step 5: MOVEJI to the goal, each interpolated step one journaled transaction; the reader
/// must see every version in order, naming only the arm's links. Answers the writing client
/// and the last version written.
fn move_there(
    out: &mut dyn std::io::Write,
    s: &Session,
    reader: &mut Reader,
    robot: &Robot,
    arm: &CompiledRobot,
    goal: &[f64],
    target: &Matrix4<f64>,
) -> Result<(Client, u64)> {
    say!(
        out,
        "\n== 5. MOVEJI there: each interpolated step one journaled transaction (joints + link poses)"
    );
    let path = movej_interpolate(robot, &arm.q, goal, STEPS)?;
    let mut client = Client::connect(s, "demo-writer")?;
    let t0 = Instant::now();
    let mut last_version = 0;
    let mut seen = Vec::new();
    for q in &path {
        let tx = joint_tx(robot, &arm.links, q);
        let c = client.transact(&tx)?;
        last_version = c.version;
        // The reader is told what changed: exactly the arm's links, pose aspect only.
        while seen.last().is_none_or(|v: &u64| *v < c.version) {
            for ch in reader.wait_change(Duration::from_secs(5))? {
                if ch.ids != arm.links || ch.aspects != aspect::POSE {
                    bail!(
                        "change {} named {:?} / {:?}, expected the arm's links / pose",
                        ch.version,
                        ch.ids,
                        aspect::names(ch.aspects)
                    );
                }
                seen.push(ch.version);
            }
        }
    }
    let elapsed = t0.elapsed();
    let in_order = seen.windows(2).all(|w| w[1] == w[0] + 1);
    say!(
        out,
        "{STEPS} transactions in {:.1} ms ({:.0} µs each, fsync included); the reader saw {} versions {}..={}{}, each naming only the {} links (pose)",
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_secs_f64() * 1e6 / STEPS as f64,
        seen.len(),
        seen.first().copied().unwrap_or(0),
        seen.last().copied().unwrap_or(0),
        if in_order {
            " in order"
        } else {
            " OUT OF ORDER"
        },
        arm.links.len()
    );
    let snap = reader
        .snapshot()
        .ok_or_else(|| crate::StudyError::Message("no snapshot".into()))?;
    let last_link = arm.links.last().and_then(|id| snap.index_of(*id));
    if let Some(i) = last_link {
        let tool_world = m4(&snap.world_pose(i)) * robot.tool;
        let r = Residual::between(&tool_world, target);
        say!(
            out,
            "snapshot v{}: tool tip at {}, off the target by {:.1e} m / {:.1e} rad",
            snap.version(),
            xyz(&tool_world),
            r.position,
            r.orientation
        );
    }
    Ok((client, last_version))
}

/// Step 6: the simulator daemon's state for the new structure version, against the goal.
fn simulator_state(
    out: &mut dyn std::io::Write,
    s: &Session,
    arm: &CompiledRobot,
    goal: &[f64],
    last_version: u64,
) -> Result<()> {
    say!(
        out,
        "\n== 6. the simulator daemon publishes state for the new structure version"
    );
    let mut state = StateSubscriber::open(s, "simulator", "demo-state")?;
    let deadline = Instant::now() + Duration::from_secs(10);
    let rec = loop {
        let recs = state.wait(Duration::from_millis(200))?;
        if let Some(r) = recs
            .into_iter()
            .rev()
            .find(|r| r.header.structure_version >= last_version)
        {
            break r;
        }
        if Instant::now() > deadline {
            bail!("the simulator published no state for version {last_version} within 10 s");
        }
    };
    let off = arm
        .links
        .iter()
        .zip(goal)
        .map(|(id, q)| {
            rec.joints
                .iter()
                .find(|j| j.id == *id)
                .map_or(f64::INFINITY, |j| (j.q - q).abs())
        })
        .fold(0.0, f64::max);
    say!(
        out,
        "state #{} at t = {:.2} s for version {}: the arm's q differ from the goal by {off:.1e} rad",
        rec.header.seq,
        rec.header.t,
        rec.header.structure_version
    );
    Ok(())
}

/// Step 7: the seed's encoder study at the final pose.
fn encoder_study(
    out: &mut dyn std::io::Write,
    robot: &Robot,
    goal: &[f64],
    bits: u32,
) -> Result<()> {
    say!(
        out,
        "\n== 7. the seed's {bits}-bit encoder study at the final pose (seed §2.7)"
    );
    let e = encoder::encoder_error(robot, goal, &vec![bits; robot.dof()])?;
    say!(
        out,
        "joint resolution {:.2} mrad: tool position error ≤ {:.3} mm (Σ|J|δ, the seed's bound), exact worst case {:.3} mm; orientation ≤ {:.2} mrad",
        e.resolution[0] * 1e3,
        e.position * 1e3,
        e.position_worst_case * 1e3,
        e.orientation * 1e3
    );
    Ok(())
}

/// The robot with each link's mass, centre of mass and inertia from its solids at `density`
/// (kg/m³); `frames` the robot model's placed solids (base first).
fn with_link_masses(robot: &Robot, frames: &[Vec<PlacedSolid>], density: f64) -> Result<Robot> {
    let mut dyn_robot = robot.clone();
    for (j, joint) in dyn_robot.joints.iter_mut().enumerate() {
        let parts = frames.get(j + 1).map_or(&[][..], Vec::as_slice);
        let mut each = Vec::with_capacity(parts.len());
        for p in parts {
            let mp = p
                .polyhedron
                .mass_properties(density)
                .map_err(|e| crate::StudyError::at(p.name.clone(), e))?;
            each.push(mp.transformed(&isometry_from_matrix(&p.transform)));
        }
        if let Some(mp) = MassProperties::combine(&each) {
            joint.mass = mp.mass;
            joint.com = mp.center_of_mass.coords;
            joint.inertia = mp.inertia;
        }
    }
    Ok(dyn_robot)
}

/// Step 8: link masses from the link solids (aluminium), gravity torques at the goal checked
/// against ∂V/∂q, then held by them and unpowered.
fn gravity_study(
    out: &mut dyn std::io::Write,
    lib: &Library,
    frames: &[Vec<PlacedSolid>],
    robot: &Robot,
    goal: &[f64],
) -> Result<()> {
    say!(
        out,
        "\n== 8. dynamics: gravity torques holding the arm at the final pose"
    );
    let density = match lib.evaluate("aluminium", &Params::new()) {
        Ok(Evaluated::Constant { value, .. }) => value,
        _ => bail!("the standard library has no constant `aluminium`"),
    };
    let dyn_robot = with_link_masses(robot, frames, density)?;
    let total: f64 = dyn_robot.joints.iter().map(|j| j.mass).sum();
    let dm = robosim_dynamics::Model::new(&dyn_robot)?;
    let mut data = robosim_dynamics::Data::new(&dm);
    let g = robosim_dynamics::gravity(&dm, &mut data, goal)?
        .as_slice()
        .to_vec();
    say!(
        out,
        "link masses from the link solids at aluminium {density:.0} kg/m³ (the positioner declares none): {total:.3} kg in all"
    );
    // An independent check: g(q) is the gradient of the potential energy (computed by a
    // separate routine), here by central differences.
    let zeros = vec![0.0; robot.dof()];
    let h = 1e-6;
    let mut dv_err: f64 = 0.0;
    for (j, gj) in g.iter().enumerate() {
        let mut qp = goal.to_vec();
        let mut qm = goal.to_vec();
        qp[j] += h;
        qm[j] -= h;
        let vp = robosim_dynamics::energy(&dm, &mut data, &qp, &zeros)?.potential;
        let vm = robosim_dynamics::energy(&dm, &mut data, &qm, &zeros)?.potential;
        dv_err = dv_err.max(((vp - vm) / (2.0 * h) - gj).abs());
    }
    say!(
        out,
        "g(q) = {} N·m; = ∂V/∂q (central differences of the potential energy) to {dv_err:.1e} N·m",
        vec_str(&g, 4)
    );
    let cfg = robosim_dynamics::IntegratorConfig::fixed(robosim_dynamics::Integrator::Rk4, 1e-3);
    let (held, _) = robosim_dynamics::simulate(&dm, cfg, goal, &zeros, &g, &[1.0])?;
    let (fell, _) = robosim_dynamics::simulate(&dm, cfg, goal, &zeros, &zeros, &[0.0, 0.2])?;
    let drift = held.last().map_or(f64::INFINITY, |h| {
        h.q.iter()
            .zip(goal)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    });
    let (e0, e1) = (
        fell.first().map_or(0.0, |s| s.energy),
        fell.last().map_or(0.0, |s| s.energy),
    );
    let fall = fell.last().map_or(0.0, |s| {
        s.q.iter()
            .zip(goal)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    });
    say!(
        out,
        "RK4, 1 ms: held by g(q) for 1 s the arm drifts {drift:.1e} rad; unpowered it falls {fall:.3} rad in 0.2 s, energy change {:.1e} J",
        e1 - e0
    );
    Ok(())
}

/// Step 10: a NaN pose is refused whole, naming the object and field; the model stays.
fn refuse_bad_input(
    out: &mut dyn std::io::Write,
    client: &mut Client,
    reader: &Reader,
    arm: &CompiledRobot,
) -> Result<()> {
    say!(
        out,
        "\n== 10. bad input is refused whole, with the object and field named"
    );
    let mut tx = Transaction::new();
    let mut pose = robosim_instance_space::IDENTITY;
    pose[3] = f64::NAN;
    let first = *arm
        .links
        .first()
        .ok_or_else(|| crate::StudyError::Message("the positioner has no links".into()))?;
    tx.set_joint(first, 0.0).set_pose(first, pose);
    match client.transact(&tx) {
        Err(e) => say!(out, "refused: {e}"),
        Ok(c) => bail!("a NaN pose was accepted as version {}", c.version),
    }
    let v = reader.snapshot().map_or(0, |s| s.version());
    say!(out, "model still at version {v}");
    Ok(())
}

/// Step 9: one ECLSS fault whose own alarm is not allocated (its sensor failed): the alarm
/// sequence is simulated and FSPI/ILM isolate the fault from the downstream alarms alone. Then
/// the limit of it: with two sensors failed, a fault that stays ambiguous.
fn automation(out: &mut dyn std::io::Write) -> Result<()> {
    use robosim_automation::diag::FaultGraph;
    use robosim_automation::model::load_model;
    let m = load_model("eclss")?;
    let g = FaultGraph::new(&m);
    let d = diagnose(&m, &g, "sorbent_bed_failure", &["A_co2_bed"])?;
    say!(
        out,
        "injected {} at t = 0 (seed {SEED}, edge probabilities sampled); sensor A_co2_bed failed: {} of {} alarms reach the diagnoser",
        m.failure_modes[d.fault].path,
        d.trail.len(),
        d.all_alarms
    );
    // The first alarms in full, the rest summarised (candidate counts after each included).
    let shown = d.trail.len().min(3);
    say!(
        out,
        "alarms (→ FSPI single-fault candidates after each): {}",
        d.trail[..shown].join("  ")
    );
    if d.trail.len() > shown {
        let mut counts = d.counts_after[shown..].to_vec();
        counts.sort_unstable();
        counts.dedup();
        let counts: Vec<String> = counts.iter().map(usize::to_string).collect();
        say!(
            out,
            "  … {} more up to t = {:.0} s (candidates after each: {})",
            d.trail.len() - shown,
            d.last_time,
            counts.join(", ")
        );
    }
    say!(
        out,
        "diagnosis (FSPI, ILM to depth {}): {} [components: {}] — {}",
        d.depth,
        d.names.join(", "),
        d.components.join(", "),
        if d.isolated {
            "fault isolated"
        } else {
            "NOT isolated"
        }
    );
    let d2 = diagnose(&m, &g, "valve_stuck", &["A_valve", "A_tank_pressure"])?;
    say!(
        out,
        "limit: valve_stuck with A_valve and A_tank_pressure failed: {} alarms leave {} candidates ({}) — {}; FSCI: {}",
        d2.trail.len(),
        d2.names.len(),
        d2.names
            .iter()
            .map(|n| n.rsplit('.').next().unwrap_or(n))
            .collect::<Vec<_>>()
            .join(", "),
        if d2.isolated { "isolated" } else { "ambiguous" },
        d2.components.join(", ")
    );
    Ok(())
}

/// Seed of the alarm simulator's random stream.
const SEED: u64 = 7;

/// What one diagnosis scenario found.
struct Diagnosis {
    fault: usize,
    all_alarms: usize,
    /// `alarm@time→candidates` for each alarm the diagnoser saw.
    trail: Vec<String>,
    counts_after: Vec<usize>,
    last_time: f64,
    depth: usize,
    names: Vec<String>,
    components: Vec<String>,
    isolated: bool,
}

/// Injects `fault` at t = 0, simulates its alarms (probabilities sampled, seed [`SEED`]), drops
/// the `failed` sensors' alarms, and runs ILM over the rest; then lets the clock run an hour
/// past the last alarm (alarms a candidate should have caused by then rule it out) and takes
/// ILM's best guess.
fn diagnose(
    m: &robosim_automation::model::Model,
    g: &robosim_automation::diag::FaultGraph,
    fault: &str,
    failed: &[&str],
) -> Result<Diagnosis> {
    use robosim_automation::diag::Ilm;
    use robosim_automation::sim::{SimOptions, filter, simulate};
    let fault = m
        .find_failure_mode(fault)
        .map_err(crate::StudyError::Message)?;
    let mut present = vec![true; m.alarms.len()];
    for a in failed {
        present[m.find_alarm(a).map_err(crate::StudyError::Message)?] = false;
    }
    let opts = SimOptions {
        seed: SEED,
        sample_probabilities: true,
        ..SimOptions::default()
    };
    let sim = simulate(g, &[(fault, 0.0)], &opts);
    let seen = filter(&sim.alarms, &present);
    let mut ilm = Ilm::new(m, g, Some(&present));
    let mut trail = Vec::new();
    let mut counts_after = Vec::new();
    for e in &seen {
        ilm.on_alarm(e.alarm, e.time)?;
        ilm.step();
        let n = ilm.diagnoser().candidates().len();
        counts_after.push(n);
        trail.push(format!("{}@{:.0}s→{n}", m.alarms[e.alarm].name, e.time));
    }
    let last_time = seen.last().map_or(0.0, |e| e.time);
    ilm.advance_to(last_time + 3600.0);
    ilm.run_to_completion();
    let Some(guess) = ilm.best_guess() else {
        bail!(
            "{}: no alarm reached the diagnoser",
            m.failure_modes[fault].path
        );
    };
    Ok(Diagnosis {
        fault,
        all_alarms: sim.alarms.len(),
        trail,
        counts_after,
        last_time,
        depth: guess.depth,
        names: guess
            .failure_modes
            .iter()
            .map(|&f| m.failure_modes[f].path.clone())
            .collect(),
        components: guess
            .components
            .iter()
            .map(|&c| m.components[c].name.clone())
            .collect(),
        isolated: guess.failure_modes == [fault] && !guess.multiple,
    })
}
