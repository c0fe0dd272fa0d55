//! `robosim render` and `robosim display`: the display crate wired to the Library Space and to
//! sessions.
//!
//! * `render SCENE` evaluates a library scene or robot into a process-local model (no session,
//!   no other process) and draws it to PNG — one image, or with `--play` one frame per
//!   trajectory sample (MD's file mode).
//! * `display --session S` attaches to a running session and redraws on every change
//!   notification, uploading only what changed: headless (PNG frames and a JSON line of
//!   upload counters per frame) or in a window. With `--play` it is also a writer: it plays
//!   the trajectory files into the Instance Space at `--rate`.
//!
//! Robots and the collision highlight come from robosim-scene's [`CompiledScene`]: the session
//! display compiles once per structure version and follows joint changes in place.
//!
//! Entry points: [`cmd_render`], [`cmd_display`], [`local_store`], [`RenderArgs`],
//! [`DisplayArgs`], [`AppError`].

/// An error of the display's commands: what failed and where, for the command line.
#[derive(Debug)]
pub struct AppError(pub String);

impl std::fmt::Display for AppError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// The error's message and its causes down the `source()` chain, each said once.
impl<E: std::error::Error> From<E> for AppError {
    fn from(e: E) -> Self {
        AppError(robosim_instance_space::error_chain(&e))
    }
}

/// Results of the display's commands.
pub type Result<T> = std::result::Result<T, AppError>;

macro_rules! bail {
    ($($t:tt)*) => { return Err(AppError(format!($($t)*))) };
}

use crate::renderer::scene_bounds;
use crate::trajectory::Trajectory;
use crate::trajectory::to_si;
use crate::window::{Host, WindowOptions};
use crate::{Camera, Hit, Projection, Renderer, Style};
use nalgebra::{Point3, Vector3};
use robosim_instance_space::{Client, FollowTrouble, Kind, Reader, Session, Snapshot, Store};
use robosim_scene::{CompiledRobot, CompiledScene, joint_tx};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Camera and style options shared by `render` and `display`.
#[derive(Debug, Clone)]
pub struct ViewArgs {
    /// LOOK-FROM x,y,z (m, world). Default: from the seed's viewing direction, framing the model.
    pub from: Option<[f64; 3]>,
    /// LOOK-AT x,y,z (m, world). Default: the centre of the model's bounding box.
    pub at: Option<[f64; 3]>,
    /// Camera up vector.
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov: f64,
    /// Orthographic projection (default perspective).
    pub ortho: bool,
    /// Draw polygon edges over the shading.
    pub edges: bool,
    /// Image size WxH (pixels).
    pub size: (u32, u32),
    /// Draw objects in contact (each robot against itself and the rest) in the collision colour.
    pub collisions: bool,
}

impl ViewArgs {
    /// The style these options ask for; `grid`: the ground grid and world axes.
    fn style(&self, grid: bool) -> Style {
        Style {
            edges: self.edges,
            grid,
            ..Style::default()
        }
    }

    /// True when the camera is placed by the user (LOOK-FROM or LOOK-AT given): the display
    /// then never re-frames it by itself.
    fn placed(&self) -> bool {
        self.from.is_some() || self.at.is_some()
    }

    /// The camera these options ask for, around a scene with bounding sphere `bounds`: framed
    /// from the default direction at the asked field of view, then LOOK-AT and LOOK-FROM
    /// where given.
    fn camera(&self, bounds: (Point3<f64>, f64)) -> Result<Camera> {
        let mut cam = Camera::framing_fov(bounds.0, bounds.1, self.fov);
        if let Some(at) = self.at {
            let offset = cam.from - cam.at;
            cam.at = Point3::from(at);
            cam.from = cam.at + offset;
        }
        if let Some(from) = self.from {
            cam.from = Point3::from(from);
        }
        cam.up = Vector3::from(self.up);
        cam.projection = if self.ortho {
            Projection::Orthographic
        } else {
            Projection::Perspective
        };
        cam.validate().map_err(AppError)?;
        Ok(cam)
    }

    fn apply(&self, r: &mut Renderer, grid: bool) -> Result<()> {
        r.style = self.style(grid);
        r.camera = self.camera(r.bounds())?;
        Ok(())
    }
}

#[derive(Debug, Clone)]
pub struct RenderArgs {
    /// A scene or robot of the library (`robosim lib list`), `demo`, or a URDF file
    /// (`FILE.urdf`: its robot with visuals, at the origin).
    pub scene: String,
    /// The PNG to write (one image).
    pub out: Option<PathBuf>,
    pub view: ViewArgs,
    /// Joint values ROBOT=q1,q2,… (degrees for revolute joints, metres for prismatic); repeatable.
    pub joints: Vec<String>,
    /// Play a trajectory file into a robot, ROBOT=FILE (MD's file mode); repeatable. Needs --frames.
    pub play: Vec<String>,
    /// With --play: the directory for frame-NNNNN.png, one per sample.
    pub frames: Option<PathBuf>,
    /// With --play: also record the playback to this MCAP file — joint states and link poses of
    /// every sample (not only every Nth), at the trajectory's dt — for Foxglove and other tools.
    pub record: Option<PathBuf>,
    /// With --play: draw every Nth sample.
    pub every: usize,
    /// Leave out every object of this name (and what is attached to it); repeatable.
    pub hide: Vec<String>,
    /// Draw the ground grid (z = 0) and the world axes (x red, y green, z blue).
    pub grid: bool,
    /// Library files to add to the standard library.
    pub library: Vec<PathBuf>,
    /// With --play: objects moved per sample beside the robots' joints (no command-line form;
    /// programs such as `robosim study station` set them, for what no joint carries — an ORU
    /// in a manipulator's grip). One pose per trajectory sample.
    pub poses: Vec<PoseTrack>,
}

/// An object's world pose per played sample ([`RenderArgs::poses`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseTrack {
    /// The object's names from below the scene down to it, `/`-separated: `spare_oru`,
    /// `port_solar/gimbal/oru0`.
    pub object: String,
    /// Its world pose at each sample, 3×4 row-major [R | t].
    pub world: Vec<[f64; 12]>,
}

/// The index of the object at `path` (names from below the scene, `/`-separated:
/// [`Snapshot::find_path`]).
pub fn find_path(snap: &Snapshot, path: &str) -> Option<usize> {
    snap.find_path(path)
}

/// `a⁻¹` of a 3×4 row-major rigid transform.
fn invert(a: &[f64; 12]) -> [f64; 12] {
    let mut out = [0.0; 12];
    for r in 0..3 {
        for c in 0..3 {
            out[r * 4 + c] = a[c * 4 + r];
        }
        out[r * 4 + 3] = -(0..3).map(|k| a[k * 4 + r] * a[k * 4 + 3]).sum::<f64>();
    }
    out
}

/// Pose tracks resolved against the model: (object id, parent id, world poses).
struct Posed(Vec<(u64, u64, Vec<[f64; 12]>)>);

impl Posed {
    fn resolve(tracks: &[PoseTrack], snap: &Snapshot, samples: usize) -> Result<Posed> {
        let mut out = Vec::new();
        for t in tracks {
            let Some(i) = find_path(snap, &t.object) else {
                bail!("pose track: no object {:?} in the scene", t.object);
            };
            if t.world.len() != samples {
                bail!(
                    "pose track {}: {} poses for {samples} trajectory samples",
                    t.object,
                    t.world.len()
                );
            }
            if let Some(k) = t
                .world
                .iter()
                .position(|w| w.iter().any(|v| !v.is_finite()))
            {
                bail!("pose track {}: sample {} is not finite", t.object, k + 1);
            }
            let o = snap.rec(i);
            out.push((o.id, o.parent, t.world.clone()));
        }
        Ok(Posed(out))
    }

    /// Moves every tracked object to its world pose at sample `k` (after the robots' joints of
    /// that sample: its parent may ride on one).
    fn apply(&self, model: &mut Store, k: usize) -> Result<()> {
        if self.0.is_empty() {
            return Ok(());
        }
        let snap = Snapshot::from_store(model);
        let mut tx = robosim_instance_space::Transaction::new();
        for (id, parent, world) in &self.0 {
            let parent_world = match snap.index_of(*parent) {
                Some(p) => snap.world_pose(p),
                None => [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            };
            let w = &world[k.min(world.len().saturating_sub(1))];
            tx.set_pose(
                *id,
                robosim_instance_space::compose(&invert(&parent_world), w),
            );
        }
        model
            .apply(&tx)
            .map_err(|e| AppError(format!("pose tracks at sample {k}: {e}")))?;
        Ok(())
    }
}

/// The model `render` draws for played sample `k` of `a` (its `--joints`, `--hide`, the played
/// trajectories' joints and the pose tracks at that sample): what frame `k` shows, without a
/// GPU.
pub fn played_snapshot(a: &RenderArgs, k: usize) -> Result<Snapshot> {
    let mut model = prepared_model(a, local_store(&a.library, &a.scene)?)?;
    let snap = Snapshot::from_store(&model);
    let player = Player::load(&a.play, &snap)?;
    let posed = Posed::resolve(&a.poses, &snap, player.len())?;
    for (r, q) in player.at(k) {
        set_local(&mut model, r, &q)?;
    }
    posed.apply(&mut model, k)?;
    Ok(Snapshot::from_store(&model))
}

/// The scene `name` of the standard library (plus `library` files) as a local model.
pub fn local_store(library: &[PathBuf], name: &str) -> Result<Store> {
    let lib = robosim_scene::build_library(library)?;
    let mut model = Store::new();
    for tx in robosim_scene::load_from(&lib, name)? {
        model
            .apply(&tx)
            .map_err(|e| AppError(format!("scene {name}: {e}")))?;
    }
    Ok(model)
}

/// The robot called `name` in `snap`, with its links.
fn robot<'a>(robots: &'a [CompiledRobot], name: &str) -> Result<&'a CompiledRobot> {
    robots.iter().find(|r| r.robot.name == name).ok_or_else(|| {
        let names: Vec<&str> = robots.iter().map(|r| r.robot.name.as_str()).collect();
        AppError(format!(
            "no robot named {name:?}; robots here: {}",
            if names.is_empty() {
                "none".to_owned()
            } else {
                names.join(", ")
            }
        ))
    })
}

/// `ROBOT=q1,q2,…` in ROBOSIM units (degrees / metres): the robot and q in SI.
fn parse_joints<'a>(
    spec: &str,
    robots: &'a [CompiledRobot],
) -> Result<(&'a CompiledRobot, Vec<f64>)> {
    let (name, values) = spec
        .split_once('=')
        .ok_or_else(|| AppError(format!("--joints {spec:?}: ROBOT=q1,q2,… expected")))?;
    let r = robot(robots, name.trim())?;
    let vals: Vec<f64> = values
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| AppError(format!("--joints {spec:?}: {v:?} is not a finite number")))
        })
        .collect::<Result<_>>()?;
    let q = to_si(&vals, &prismatic(&r.robot), false);
    check_q(&r.robot, &q).map_err(|e| AppError(format!("--joints {spec:?}: {}", e.0)))?;
    Ok((r, q))
}

/// `q` is a configuration `robot` can take: right length, finite, inside every joint's limits.
fn check_q(robot: &robosim_kinematics::Robot, q: &[f64]) -> Result<()> {
    robot.check_q(q).map_err(AppError::from)?;
    if let Some((j, v, [lo, hi])) = robot.outside_limits(q) {
        let unit = |x: f64| match robot.joints[j].joint_type {
            robosim_kinematics::JointType::Prismatic => format!("{x} m"),
            _ => format!("{:.2}°", x.to_degrees()),
        };
        bail!(
            "joint {} at {} is outside its limits [{}, {}]",
            j + 1,
            unit(v),
            unit(lo),
            unit(hi)
        );
    }
    Ok(())
}

fn prismatic(robot: &robosim_kinematics::Robot) -> Vec<bool> {
    robot
        .joints
        .iter()
        .map(|j| j.joint_type == robosim_kinematics::JointType::Prismatic)
        .collect()
}

/// Puts robot `r` of a local model at `q` (SI). The robot's links keep their ids, so the
/// robot found once serves every update.
fn set_local(model: &mut Store, r: &CompiledRobot, q: &[f64]) -> Result<()> {
    model
        .apply(&joint_tx(&r.robot, &r.links, q))
        .map_err(|e| AppError(format!("moving {}: {e}", r.robot.name)))?;
    Ok(())
}

/// Trajectory tracks `ROBOT=FILE`, checked against the robots' joint counts and limits.
struct Player {
    tracks: Vec<(CompiledRobot, Trajectory, Vec<bool>)>,
}

impl Player {
    fn load(specs: &[String], snap: &Snapshot) -> Result<Player> {
        let scene = CompiledScene::of(snap);
        let robots = scene.robots();
        let mut tracks = Vec::new();
        for spec in specs {
            let (name, file) = spec
                .split_once('=')
                .ok_or_else(|| AppError(format!("--play {spec:?}: ROBOT=FILE expected")))?;
            let r = robot(robots, name.trim())?;
            let t = Trajectory::load(Path::new(file.trim()))?;
            if t.columns() != r.robot.dof() {
                bail!(
                    "{}: {} columns, but robot {} has {} joints",
                    file.trim(),
                    t.columns(),
                    name.trim(),
                    r.robot.dof()
                );
            }
            let p = prismatic(&r.robot);
            for k in 0..t.samples.len() {
                check_q(&r.robot, &t.sample_si(k, &p))
                    .map_err(|e| AppError(format!("{}: sample {}: {}", file.trim(), k + 1, e.0)))?;
            }
            tracks.push((r.clone(), t, p));
        }
        Ok(Player { tracks })
    }

    fn len(&self) -> usize {
        self.tracks
            .iter()
            .map(|t| t.1.samples.len())
            .max()
            .unwrap_or(0)
    }

    /// (robot, q) of every track at sample `k` (a finished track holds its last sample).
    fn at(&self, k: usize) -> Vec<(&CompiledRobot, Vec<f64>)> {
        self.tracks
            .iter()
            .map(|(r, t, p)| (r, t.sample_si(k, p)))
            .collect()
    }
}

/// `render --play … --record FILE.mcap`: every sample of every track as joint states and link
/// poses (robosim-record's channels, the simulator's too), at the tracks' common dt.
fn record_playback(path: &Path, player: &Player, snap: &Snapshot) -> Result<()> {
    let dt = player.tracks.first().map_or(1.0 / 30.0, |t| t.1.dt);
    if let Some((r, t, _)) = player.tracks.iter().find(|t| t.1.dt != dt) {
        bail!(
            "--record: the tracks' sample periods differ ({} has dt {} s, the first {dt} s); \
             one recording has one clock",
            r.robot.name,
            t.dt
        );
    }
    let names: Vec<Vec<String>> = player
        .tracks
        .iter()
        .map(|(r, _, _)| {
            r.link_index
                .iter()
                .map(|&i| snap.name(i).to_owned())
                .collect()
        })
        .collect();
    let samples: Vec<Vec<Vec<f64>>> = player
        .tracks
        .iter()
        .map(|(_, t, p)| (0..t.samples.len()).map(|k| t.sample_si(k, p)).collect())
        .collect();
    let tracks: Vec<robosim_record::playback::Track<'_>> = player
        .tracks
        .iter()
        .zip(names.iter().zip(&samples))
        .map(
            |((r, _, _), (names, samples))| robosim_record::playback::Track {
                name: &r.robot.name,
                robot: &r.robot,
                joint_names: names,
                samples,
            },
        )
        .collect();
    let counts =
        robosim_record::playback::record_playback(path, &tracks, dt, 1).map_err(AppError::from)?;
    let total: u64 = counts.values().sum();
    println!(
        "recorded {} samples ({total} messages) → {}",
        player.len(),
        path.display()
    );
    Ok(())
}

fn highlight(r: &mut Renderer, scene: &CompiledScene, on: bool) {
    if on {
        r.set_highlight(scene.colliding_ids());
    }
}

/// The local model of `render`: the scene with `--joints` set and `--hide` objects removed.
fn prepared_model(a: &RenderArgs, mut model: Store) -> Result<Store> {
    let snap = Snapshot::from_store(&model);
    let scene = CompiledScene::of(&snap);
    let robots = scene.robots();
    let settings: Vec<(&CompiledRobot, Vec<f64>)> = a
        .joints
        .iter()
        .map(|s| parse_joints(s, robots))
        .collect::<Result<_>>()?;
    for (r, q) in &settings {
        set_local(&mut model, r, q)?;
    }
    for name in &a.hide {
        let snap = Snapshot::from_store(&model);
        let ids: Vec<_> = (0..snap.len())
            .filter(|&i| snap.name(i) == name)
            .map(|i| snap.rec(i).id)
            .collect();
        if ids.is_empty() {
            let mut names: Vec<&str> = (0..snap.len()).map(|i| snap.name(i)).collect();
            names.sort_unstable();
            names.dedup();
            bail!(
                "--hide {name:?}: no object of that name in {}; names: {}",
                a.scene,
                names.join(", ")
            );
        }
        let mut tx = robosim_instance_space::Transaction::new();
        for id in ids {
            tx.delete(id, true);
        }
        model
            .apply(&tx)
            .map_err(|e| AppError(format!("--hide {name:?}: {e}")))?;
    }
    Ok(model)
}

/// `robosim render SCENE …`
pub fn cmd_render(a: &RenderArgs) -> Result<()> {
    cmd_render_store(a, local_store(&a.library, &a.scene)?)
}

/// `robosim render` of a model built elsewhere (`model`; `a.scene` only names it in messages):
/// how `robosim render FILE.urdf` draws a URDF robot the file interface imported.
pub fn cmd_render_store(a: &RenderArgs, model: Store) -> Result<()> {
    if a.out.is_none() && a.frames.is_none() && a.record.is_none() {
        bail!(
            "nothing to write: give --out FILE.png, or --play ROBOT=FILE with --frames DIR \
             and/or --record FILE.mcap"
        );
    }
    if a.play.is_empty() != (a.frames.is_none() && a.record.is_none()) {
        bail!("--play goes with --frames DIR and/or --record FILE.mcap");
    }
    if a.every == 0 {
        bail!("--every must be at least 1");
    }
    if !a.poses.is_empty() && a.play.is_empty() {
        bail!("pose tracks go with --play");
    }
    let mut model = prepared_model(a, model)?;
    let mut r = Renderer::headless()?;
    let snap = Snapshot::from_store(&model);
    let mut scene = CompiledScene::new();
    if a.view.collisions {
        scene.sync(&snap);
    }
    highlight(&mut r, &scene, a.view.collisions);
    r.sync(&snap);
    a.view.apply(&mut r, a.grid)?;
    let (w, h) = a.view.size;
    if let Some(out) = &a.out {
        let t0 = Instant::now();
        r.render_image(w, h)?.save_png(out)?;
        println!(
            "{}: {} bodies, {} triangles, {w}×{h} on {} ({:.0} ms)",
            out.display(),
            r.body_count(),
            r.triangle_count(),
            r.gpu().describe(),
            t0.elapsed().as_secs_f64() * 1e3
        );
    }
    if let Some(path) = &a.record {
        record_playback(path, &Player::load(&a.play, &snap)?, &snap)?;
    }
    if let Some(dir) = &a.frames {
        let player = Player::load(&a.play, &snap)?;
        let posed = Posed::resolve(&a.poses, &snap, player.len())?;
        let mut upload = crate::UploadStats::default();
        let meshes_before = r.total_upload().meshes;
        let mut written = 0;
        for k in (0..player.len()).step_by(a.every) {
            for (r, q) in player.at(k) {
                set_local(&mut model, r, &q)?;
            }
            posed.apply(&mut model, k)?;
            let snap = Snapshot::from_store(&model);
            if a.view.collisions {
                scene.sync(&snap);
            }
            highlight(&mut r, &scene, a.view.collisions);
            upload.add(&r.sync(&snap));
            r.render_image(w, h)?
                .save_png(&dir.join(format!("frame-{k:05}.png")))?;
            written += 1;
        }
        println!(
            "{written} frames → {}; uploads per frame: {:.1} transforms, {:.0} B; meshes re-uploaded: {}",
            dir.display(),
            upload.transforms as f64 / written.max(1) as f64,
            upload.total_bytes() as f64 / written.max(1) as f64,
            r.total_upload().meshes - meshes_before
        );
    }
    Ok(())
}

#[derive(Debug)]
pub struct DisplayArgs {
    /// The session to attach to: the binary's global `--session` (ROBOSIM_SESSION) fills it.
    pub session: Option<String>,
    /// Draw to PNG files instead of a window (the default when there is no display server).
    pub headless: bool,
    /// Headless: the directory for latest.png and frames.jsonl (default <session>/display).
    pub out: Option<PathBuf>,
    /// Headless: also keep every frame as frame-<version>.png (frame-<version>-sim<seq>.png
    /// when it shows the simulator's state).
    pub every_frame: bool,
    /// Stop after this many frames (headless) or presented frames (window).
    pub max_frames: Option<u64>,
    /// Play trajectory files into the session's robots, ROBOT=FILE; repeatable.
    pub play: Vec<String>,
    /// Replay input: in a window `left`, `right`, `tab`, `1`–`9`, `e`, `o`, `f`, `g`,
    /// `click:X,Y`; headless `click:X,Y` (pixels of the --size image), one step after each
    /// drawn frame — a click commits the pick as the session's selection.
    pub script: Vec<String>,
    /// Leave out the ground grid and world axes (drawn by default; `G` toggles them in the
    /// window).
    pub no_grid: bool,
    pub view: ViewArgs,
}

/// The session side of the display: its reader and, for knob moves and playback, a client.
struct SessionHost {
    reader: Reader,
    /// The reader's errors, said once: the display keeps the last version it drew and tries
    /// again (a malformed segment makes the reader attach again; issue 34 item 4).
    trouble: FollowTrouble,
    session: Session,
    client: Option<Client>,
    collisions: bool,
    snap: Option<std::rc::Rc<Snapshot>>,
    /// Robots (and their solids, for the highlight) of `snap`, compiled per structure version.
    scene: CompiledScene,
    /// The simulator's published state, when a simulator runs (opened lazily, retried).
    sim: SimFollower,
    /// The last update drew the simulator's state (not only the committed model).
    showing_sim: bool,
    /// With `collisions` and a simulator: the robots at the simulator's joint values, for the
    /// contacts of what is drawn (the simulator does not publish its contacts).
    sim_scene: CompiledScene,
}

/// Follows the simulator's high-rate state (`state/simulator`): the latest record, drawn over
/// the committed model — the links where the simulator has them.
struct SimFollower {
    sub: Option<robosim_instance_space::state::StateSubscriber>,
    next_try: Instant,
    latest: Option<robosim_instance_space::state::StateRecord>,
    /// Records applied to the drawing (0: the committed model is drawn as it is).
    applied: u64,
}

impl SimFollower {
    fn new() -> Self {
        SimFollower {
            sub: None,
            next_try: Instant::now(),
            latest: None,
            applied: 0,
        }
    }

    /// Takes any new records; true when a newer one arrived.
    fn poll(&mut self, session: &Session) -> bool {
        if self.sub.is_none() && Instant::now() >= self.next_try {
            // The service exists only while a simulator runs; look again once a second.
            self.sub = robosim_instance_space::state::StateSubscriber::open(
                session,
                "simulator",
                "display",
            )
            .ok();
            self.next_try = Instant::now() + Duration::from_secs(1);
        }
        let Some(sub) = self.sub.as_mut() else {
            return false;
        };
        match sub.drain() {
            Ok(recs) => match recs.into_iter().last() {
                Some(r) => {
                    self.latest = Some(r);
                    true
                }
                None => false,
            },
            Err(_) => {
                self.sub = None;
                false
            }
        }
    }

    /// The snapshot to draw: `snap` with the simulator's link poses, when its latest record is
    /// for this structure (a record for an older structure may name links that changed).
    fn drawn(&mut self, snap: &Snapshot) -> Option<Snapshot> {
        let rec = self.latest.as_ref()?;
        if rec.header.structure_version < snap.structure_version() {
            return None;
        }
        self.applied += 1;
        Some(snap.with_poses(&rec.bodies))
    }
}

impl SessionHost {
    fn new(reader: Reader, session: Session, collisions: bool) -> SessionHost {
        SessionHost {
            reader,
            trouble: FollowTrouble::default(),
            session,
            client: None,
            collisions,
            snap: None,
            scene: CompiledScene::new(),
            sim: SimFollower::new(),
            showing_sim: false,
            sim_scene: CompiledScene::new(),
        }
    }

    /// The simulator's state drawn, as the overlay shows it: time (s) and record number, then
    /// one line per robot with its joint values (degrees for revolute joints, metres for
    /// prismatic ones). `None` when the committed model alone is drawn.
    fn sim_status(&self) -> Option<String> {
        if !self.showing_sim {
            return None;
        }
        let rec = self.sim.latest.as_ref()?;
        let mut text = format!(
            "simulator  t = {:.3} s  (record {})",
            rec.header.t, rec.header.seq
        );
        for r in self.scene.robots() {
            let values: Vec<String> = r
                .links
                .iter()
                .zip(&r.robot.joints)
                .filter_map(|(id, joint)| {
                    let q = rec.joints.iter().find(|j| j.id == *id)?.q;
                    Some(match joint.joint_type {
                        robosim_kinematics::JointType::Prismatic => format!("{q:.3} m"),
                        _ => format!("{:.1}°", q.to_degrees()),
                    })
                })
                .collect();
            if !values.is_empty() {
                text.push_str(&format!("\n{}  {}", r.robot.name, values.join("  ")));
            }
        }
        Some(text)
    }

    fn client(&mut self) -> Result<&mut Client> {
        if self.client.is_none() {
            self.client = Some(Client::connect(&self.session, "display-writer")?);
        }
        self.client
            .as_mut()
            .ok_or_else(|| AppError("no client".into()))
    }

    fn write_q(&mut self, name: &str, q: &[f64]) -> Result<u64> {
        if self.snap.is_none() {
            bail!("no model yet");
        }
        let r = robot(self.scene.robots(), name)?;
        check_q(&r.robot, q).map_err(|e| AppError(format!("{name}: {}", e.0)))?;
        let tx = joint_tx(&r.robot, &r.links, q);
        Ok(self.client()?.transact(&tx)?.version)
    }
}

impl Host for SessionHost {
    fn update(&mut self, r: &mut Renderer) -> std::result::Result<bool, String> {
        // `wait_change` may already have advanced the reader: compare versions, not
        // `refresh`'s answer.
        self.trouble.refresh("display", &mut self.reader);
        let Some(snap) = self.reader.snapshot() else {
            return Ok(false);
        };
        let new_state = self.sim.poll(&self.session);
        if !new_state
            && self
                .snap
                .as_ref()
                .is_some_and(|s| (s.version(), s.epoch()) == (snap.version(), snap.epoch()))
        {
            return Ok(false);
        }
        self.scene.sync(&snap);
        // A running simulator's state is drawn over the committed model (full comparison:
        // the state's link poses are not in the change records), with the contacts at that
        // state.
        if let Some(drawn) = self.sim.drawn(&snap) {
            if self.collisions
                && let Some(rec) = &self.sim.latest
            {
                self.sim_scene.sync(&snap);
                let q: Vec<(robosim_instance_space::Id, f64)> =
                    rec.joints.iter().map(|j| (j.id, j.q)).collect();
                self.sim_scene.set_joints(&q);
                r.set_highlight(self.sim_scene.colliding_ids());
            }
            r.sync(&drawn);
            self.snap = Some(snap);
            self.showing_sim = true;
            return Ok(true);
        }
        self.showing_sim = false;
        highlight(r, &self.scene, self.collisions);
        // The change records since the last drawn version drive the update; without them
        // (a reader that joined late, a keeper restart) the full comparison runs.
        match self.reader.changes_since(r.version()) {
            Ok(mut changes) => {
                changes.retain(|c| c.version <= snap.version());
                r.sync_changes(&snap, &changes)
            }
            Err(_) => r.sync(&snap),
        };
        self.snap = Some(snap);
        Ok(true)
    }

    fn robots(&self) -> Vec<(String, usize)> {
        self.scene
            .robots()
            .iter()
            .map(|r| (r.robot.name.clone(), r.robot.dof()))
            .collect()
    }

    fn jog(
        &mut self,
        robot_index: usize,
        joint: usize,
        delta: f64,
    ) -> std::result::Result<String, String> {
        (|| -> Result<String> {
            let r = self
                .scene
                .robots()
                .get(robot_index)
                .ok_or_else(|| AppError("no robot to move".into()))?;
            let mut q = r.q.clone();
            let Some(qj) = q.get_mut(joint) else {
                bail!("{} has no joint {}", r.robot.name, joint + 1);
            };
            *qj += delta;
            let name = r.robot.name.clone();
            let shown = q[joint].to_degrees();
            self.write_q(&name, &q)
                .map(|v| format!("{name} joint {} = {shown:.1}° (version {v})", joint + 1))
        })()
        .map_err(|e| e.0)
    }

    fn status(&self) -> Option<String> {
        self.sim_status()
    }

    fn select(&mut self, hit: Option<&Hit>) -> std::result::Result<u64, String> {
        let mut tx = robosim_instance_space::Transaction::new();
        tx.select(hit.map(|h| h.id.into()), hit.map(|h| h.polygon));
        (|| -> Result<u64> { Ok(self.client()?.transact(&tx)?.version) })().map_err(|e| e.0)
    }

    fn describe(&self, hit: &Hit) -> String {
        let Some(snap) = &self.snap else {
            return format!("object {}", hit.id);
        };
        let Some(i) = snap.index_of(hit.id) else {
            return format!("object {}", hit.id);
        };
        let mut link = None;
        let mut parent = snap.rec(i).parent;
        let mut path = snap.name(i).to_owned();
        while let Some(k) = (parent != 0).then(|| snap.index_of(parent)).flatten() {
            if link.is_none() && snap.object(k).kind() == Some(Kind::Link) {
                link = Some(snap.name(k).to_owned());
            }
            path = format!("{}/{path}", snap.name(k));
            parent = snap.rec(k).parent;
        }
        let p = hit.point;
        format!(
            "{path}{}, polygon {} at ({:.3}, {:.3}, {:.3}) m",
            link.map(|l| format!(" (link {l})")).unwrap_or_default(),
            hit.polygon,
            p.x,
            p.y,
            p.z
        )
    }
}

/// One line of frames.jsonl.
#[derive(serde::Serialize)]
struct FrameRecord {
    version: u64,
    bodies: usize,
    triangles: usize,
    upload: crate::UploadStats,
    upload_bytes: u64,
    render_ms: f64,
    png: Option<String>,
    /// The simulator's state drawn in this frame (its record sequence number and time), if a
    /// simulator runs.
    sim_seq: Option<u64>,
    sim_t: Option<f64>,
    /// The status overlay drawn in this frame's top-left corner, if any.
    status: Option<String>,
}

/// `robosim display --session S …`: attaches to the session, waits for its first model, then
/// shows it in a window, or renders it headless frame by frame into the output directory
/// (also playing `--play` trajectories into the session and replaying `--script` clicks).
pub fn cmd_display(a: &DisplayArgs) -> Result<()> {
    let session = Session::open(a.session.as_deref())?;
    let headless = a.headless || std::env::var_os("DISPLAY").is_none();
    let signals = session.node("display-signals", true)?;
    // SIGTERM/SIGINT (`robosim down`) end the display cleanly.
    let stopped = || signals.wait(Duration::ZERO).is_err();
    let reader = Reader::attach(&session, "display")?;
    let _reg = register_display(&session)?;
    let mut host = SessionHost::new(reader, session.clone(), a.view.collisions);
    if !wait_for_first_model(&mut host, &session, &stopped)? {
        return Ok(());
    }
    host.snap = host.reader.snapshot();
    let player = match &host.snap {
        Some(s) if !a.play.is_empty() => Some(Player::load(&a.play, s)?),
        _ => None,
    };
    if !headless {
        return show_in_window(host, player.is_some(), a, &session);
    }
    render_headless(host, player, a, &session, &stopped)
}

/// Registers the display with the session (`robosim ps`), naming the services it reads.
fn register_display(session: &Session) -> Result<robosim_instance_space::Registration> {
    Ok(session.register(
        "display",
        &[
            "space/objects",
            "space/poses",
            "space/changes",
            "space/geometry/*",
        ],
    )?)
}

/// Waits up to 30 s for the session's first model; false when a signal stopped the wait.
fn wait_for_first_model(
    host: &mut SessionHost,
    session: &Session,
    stopped: &dyn Fn() -> bool,
) -> Result<bool> {
    let deadline = Instant::now() + Duration::from_secs(30);
    while host.reader.snapshot().is_none() {
        if let Err(e) = host.reader.wait_change(Duration::from_millis(100)) {
            if stopped() {
                return Ok(false);
            }
            return Err(e.into());
        }
        host.reader.refresh()?;
        if Instant::now() > deadline {
            bail!("session {}: no model published within 30 s", session.name());
        }
    }
    Ok(true)
}

/// The display in a window, its camera framed on the first model (`playing`: `--play` was
/// given, which a window refuses).
fn show_in_window(
    mut host: SessionHost,
    playing: bool,
    a: &DisplayArgs,
    session: &Session,
) -> Result<()> {
    let bounds = host
        .snap
        .as_deref()
        .map_or((Point3::origin(), 1.0), scene_bounds);
    let camera = a.view.camera(bounds)?;
    host.snap = None;
    if playing {
        bail!(
            "--play in a window: play headless into the session and watch it in a second `robosim display`"
        );
    }
    let opts = WindowOptions {
        size: a.view.size,
        title: format!("robosim — session {}", session.name()),
        exit_after_frames: a.max_frames,
        script: a.script.clone(),
        frame_first_bodies: !a.view.placed(),
        ..WindowOptions::default()
    };
    Ok(crate::window::run(
        Box::new(host),
        Some(camera),
        a.view.style(!a.no_grid),
        opts,
    )?)
}

/// Where the headless display writes: its directory (latest.png, frames) and frames.jsonl.
struct HeadlessOutput {
    dir: PathBuf,
    log_path: PathBuf,
    log: std::fs::File,
}

/// Opens the headless output. Everything the session display writes is private (0700 / 0600),
/// as the rest of the session; the session's own display/ directory is tightened if an older
/// run made it wider.
fn open_headless_output(a: &DisplayArgs, session: &Session) -> Result<HeadlessOutput> {
    let dir = a
        .out
        .clone()
        .unwrap_or_else(|| session.dir().join("display"));
    crate::private::private_dir(&dir, a.out.is_none())?;
    let log_path = dir.join("frames.jsonl");
    let log = crate::private::append_file(&log_path)?;
    Ok(HeadlessOutput { dir, log_path, log })
}

/// `--play`: the trajectories' samples, written into the session at their own rate.
struct Playback {
    player: Option<Player>,
    sample: usize,
    next_sample: Instant,
}

impl Playback {
    /// Writes the next sample's joint values once a model is drawn and its time has come.
    fn write_due_sample(&mut self, host: &mut SessionHost) -> Result<()> {
        let Some(p) = &self.player else {
            return Ok(());
        };
        if host.snap.is_none() || self.sample >= p.len() || Instant::now() < self.next_sample {
            return Ok(());
        }
        for (r, q) in p.at(self.sample) {
            host.write_q(&r.robot.name, &q)?;
        }
        let dt = p
            .tracks
            .iter()
            .map(|t| t.1.dt)
            .fold(f64::INFINITY, f64::min);
        self.next_sample = Instant::now() + Duration::from_secs_f64(dt);
        self.sample += 1;
        Ok(())
    }
}

/// The headless display: one frame per model change, until a signal or `--max-frames`.
fn render_headless(
    mut host: SessionHost,
    player: Option<Player>,
    a: &DisplayArgs,
    session: &Session,
    stopped: &dyn Fn() -> bool,
) -> Result<()> {
    let mut out = open_headless_output(a, session)?;
    let clicks = a
        .script
        .iter()
        .map(|step| parse_click(step))
        .collect::<Result<Vec<_>>>()?;
    let mut next_click = 0usize;
    let mut r = Renderer::headless()?;
    eprintln!(
        "display: headless on {} → {}",
        r.gpu().describe(),
        out.dir.display()
    );
    let mut playback = Playback {
        player,
        sample: 0,
        next_sample: Instant::now(),
    };
    let mut frames = 0u64;
    // The camera is framed on the first frame; if that frame has nothing to draw (an empty
    // session), again on the first frame that has, and on the bodies added to the model
    // later — unless the user placed it.
    let mut framed = false;
    // The bodies of the last frame: bodies added since are framed (unless the user placed
    // the camera).
    let mut shown = std::collections::BTreeSet::new();
    host.snap = None;
    while !stopped() {
        playback.write_due_sample(&mut host)?;
        if !host.update(&mut r).map_err(AppError)? {
            if host.wait_for_change(stopped) {
                break;
            }
            continue;
        }
        place_camera(&mut r, a, &mut framed, &shown)?;
        shown = r.body_ids();
        write_frame(&mut r, &host, a, &mut out)?;
        frames += 1;
        if a.max_frames.is_some_and(|m| frames >= m) {
            break;
        }
        // Scripted input: one click after each drawn frame, through the pick the window uses
        // (same camera, same image size); the selection it commits brings the next frame.
        if let Some(&(x, y)) = clicks.get(next_click) {
            next_click += 1;
            click_headless(&mut host, &r, x, y, a.view.size);
        }
    }
    Ok(())
}

impl SessionHost {
    /// Waits briefly for a model change after an update that drew nothing; true when a signal
    /// (SIGTERM/SIGINT, `robosim down`) interrupted the wait. Any other error is said once;
    /// the display keeps its last frame and follows on.
    fn wait_for_change(&mut self, stopped: &dyn Fn() -> bool) -> bool {
        let waited = self.reader.wait_change(Duration::from_millis(20));
        if waited.is_err() && stopped() {
            return true;
        }
        if !self
            .trouble
            .note("display", &self.reader, waited.map(|_| ()))
        {
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }
}

/// Frames the camera on the first frame with bodies, then on bodies added to the model on
/// screen (an instance, an imported robot) alone, as the first bodies were (issue 39 item 8)
/// — unless the user placed it.
fn place_camera(
    r: &mut Renderer,
    a: &DisplayArgs,
    framed: &mut bool,
    shown: &std::collections::BTreeSet<robosim_instance_space::Id>,
) -> Result<()> {
    if !*framed {
        a.view.apply(r, !a.no_grid)?;
        *framed = r.body_count() > 0 || a.view.placed();
    } else if !a.view.placed()
        && let Some(added) = r.added_since(shown)
        && let Some(bounds) = r.bounds_of(&added)
    {
        r.camera = a.view.camera(bounds)?;
    }
    Ok(())
}

/// Renders one frame: latest.png (replaced atomically), with `--every-frame` a numbered PNG,
/// and its line in frames.jsonl.
fn write_frame(
    r: &mut Renderer,
    host: &SessionHost,
    a: &DisplayArgs,
    out: &mut HeadlessOutput,
) -> Result<()> {
    let (w, h) = a.view.size;
    let status = host.status();
    r.set_status(status.as_deref());
    let upload = r.last_upload();
    let t0 = Instant::now();
    let img = r.render_image(w, h)?;
    let render_ms = t0.elapsed().as_secs_f64() * 1e3;
    let tmp = out.dir.join("latest.png.tmp");
    img.save_png_private(&tmp)?;
    std::fs::rename(&tmp, out.dir.join("latest.png"))
        .map_err(|e| AppError(format!("{}: {e}", out.dir.display())))?;
    let png = if a.every_frame {
        // Frames of the simulator's state share the model version: the record's sequence
        // number tells them apart.
        let name = match host.sim.latest.as_ref().filter(|_| host.sim.applied > 0) {
            Some(l) => format!("frame-{:08}-sim{:08}.png", r.version(), l.header.seq),
            None => format!("frame-{:08}.png", r.version()),
        };
        img.save_png_private(&out.dir.join(&name))?;
        Some(name)
    } else {
        None
    };
    let rec = FrameRecord {
        version: r.version(),
        bodies: r.body_count(),
        triangles: r.triangle_count(),
        upload,
        upload_bytes: upload.total_bytes(),
        render_ms,
        png,
        sim_seq: (host.sim.applied > 0)
            .then(|| host.sim.latest.as_ref().map(|l| l.header.seq))
            .flatten(),
        sim_t: (host.sim.applied > 0)
            .then(|| host.sim.latest.as_ref().map(|l| l.header.t))
            .flatten(),
        status,
    };
    let line = serde_json::to_string(&rec).map_err(AppError::from)?;
    writeln!(out.log, "{line}")
        .map_err(|e| AppError(format!("{}: {e}", out.log_path.display())))?;
    out.log.flush().map_err(AppError::from)?;
    Ok(())
}

/// A scripted click on the headless frame: the pick described and committed as the selection.
fn click_headless(host: &mut SessionHost, r: &Renderer, x: f64, y: f64, (w, h): (u32, u32)) {
    let hit = r.pick(x, y, w, h);
    let what = match &hit {
        Some(h) => host.describe(h),
        None => "nothing there".into(),
    };
    match host.select(hit.as_ref()) {
        Ok(v) => println!("pick: {what} — selected (version {v})"),
        Err(e) => println!("pick: {what} — not selected: {e}"),
    }
}

/// A headless script step: `click:X,Y` (pixels from the top-left corner).
fn parse_click(step: &str) -> Result<(f64, f64)> {
    step.strip_prefix("click:")
        .and_then(|xy| xy.split_once(','))
        .and_then(|(x, y)| Some((x.trim().parse().ok()?, y.trim().parse().ok()?)))
        .ok_or_else(|| {
            AppError(format!(
                "--script {step:?}: headless, a step is click:X,Y (pixels); keys need a window"
            ))
        })
}
