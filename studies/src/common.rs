//! What the studies share: robots in the world from a library scene, a library primitive as
//! collision solids ([`collision_solids`], through the model; the surgical study's too), parts as collision bodies
//! with bounding spheres, clearances between parts, trajectory files in the display's
//! file-mode format, the headless frames, and the CSV writer.

use crate::{Result, StudyError};
use nalgebra::{Isometry3, Matrix4, Point3};
use robosim_collision::robot::isometry_from_matrix;
use robosim_collision::{Mode, PairResult, Solid, collide};
use robosim_kinematics::{JointType, Robot, fk};
use robosim_library::{Evaluated, Library, Params, PlacedRobot, PlacedSolid, SceneModel};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The standard library's scene `name` evaluated with `params`.
pub fn scene(name: &str, params: &Params) -> Result<(&'static Library, SceneModel)> {
    let lib = robosim_library::standard_library()
        .ok_or_else(|| StudyError::Message("the standard library failed to load".into()))?;
    let scene = match lib.evaluate(name, params) {
        Ok(Evaluated::Scene(s)) => s,
        Ok(_) => return Err(StudyError::Message(format!("{name} is not a scene"))),
        Err(e) => return Err(StudyError::at(format!("scene {name}"), e)),
    };
    Ok((lib, scene))
}

/// A library solid's collision solids in its own frame, from the one model builder
/// ([`robosim_model::GeometryObject::collision_parts`] of its [`PlacedSolid::shape`]): the
/// exact primitive where the collision crate has one (with the library's facet count, so both
/// faceted forms agree), a `from_urdf` hull as a convex solid, other polyhedra as a mesh.
/// `what` names whose solid it is in the error.
pub(crate) fn collision_solids(p: &PlacedSolid, what: &str) -> Result<Vec<Solid>> {
    geometry_object(p, 0)
        .collision_parts()
        .map_err(|e| StudyError::at(what, e))
}

/// `p` as a collision object of the model on `frame`, at its placement.
fn geometry_object(p: &PlacedSolid, frame: usize) -> robosim_model::GeometryObject {
    robosim_model::GeometryObject {
        name: p.name.clone(),
        frame,
        placement: p.transform,
        shape: p.shape(),
        role: robosim_model::Role::Collision,
        rgba: None,
    }
}

/// The centre (mean of the vertices) and radius of a placed solid's bounding sphere, in its
/// frame.
fn bounding_sphere(p: &PlacedSolid) -> (Point3<f64>, f64) {
    let vs = &p.polyhedron.vertices;
    let n = vs.len().max(1) as f64;
    let c = vs
        .iter()
        .fold(nalgebra::Vector3::zeros(), |a, v| a + v.coords)
        / n;
    let radius = vs.iter().map(|v| (v.coords - c).norm()).fold(0.0, f64::max);
    (Point3::from(c), radius)
}

/// One collision part: the link it rides on (0 = base), its pose in that link's frame, the
/// solid, and a bounding sphere (centre in the part frame, radius) for culling.
#[derive(Clone)]
pub struct Part {
    pub name: String,
    pub link: usize,
    pub offset: Isometry3<f64>,
    pub solid: Arc<Solid>,
    pub centre: Point3<f64>,
    pub radius: f64,
}

/// A placed robot in the world: its kinematics (the base includes the placement) and parts.
#[derive(Clone)]
pub struct Body {
    pub name: String,
    pub declaration: Option<String>,
    pub robot: Robot,
    pub link_names: Vec<String>,
    pub parts: Vec<Part>,
    pub q0: Vec<f64>,
}

impl Body {
    pub fn of(p: &PlacedRobot) -> Result<Body> {
        // the evaluated robot's base already includes the scene placement
        let robot = p.model.robot.clone();
        // Each placed solid as the collision object `RobotModel::model` makes of it, on its
        // link's frame: the object gives the solids, the placed solid its vertices. (Paired by
        // link and solid, not by position in the model's object list.)
        let mut parts = Vec::new();
        for (link, s) in p
            .model
            .frames
            .iter()
            .enumerate()
            .flat_map(|(link, solids)| solids.iter().map(move |s| (link, s)))
        {
            let o = geometry_object(s, link);
            let (centre, radius) = bounding_sphere(s);
            let solids = o
                .collision_parts()
                .map_err(|e| StudyError::at(format!("robot {}", p.name), e))?;
            for solid in solids {
                parts.push(Part {
                    name: s.name.clone(),
                    link,
                    offset: isometry_from_matrix(&o.placement),
                    solid: Arc::new(solid),
                    centre,
                    radius,
                });
            }
        }
        Ok(Body {
            name: p.name.clone(),
            declaration: p.declaration.clone(),
            robot,
            link_names: p.model.link_names.clone(),
            parts,
            q0: p.q.clone(),
        })
    }

    /// World poses of the link frames (0 = base) at `q`.
    pub fn frames(&self, q: &[f64]) -> Vec<Matrix4<f64>> {
        fk::link_frames(&self.robot, q)
    }

    /// The parts posed in the world at link frames `frames`.
    pub fn posed<'a>(&'a self, frames: &[Matrix4<f64>]) -> Vec<Posed<'a>> {
        self.parts
            .iter()
            .map(|p| {
                let pose = isometry_from_matrix(&frames[p.link]) * p.offset;
                Posed {
                    part: p,
                    centre: pose * p.centre,
                    pose,
                }
            })
            .collect()
    }
}

/// A part at its world pose.
#[derive(Clone, Copy)]
pub struct Posed<'a> {
    pub part: &'a Part,
    pub pose: Isometry3<f64>,
    pub centre: Point3<f64>,
}

/// The fixed solids of a scene as posed parts (link 0 of no robot).
pub fn fixed_parts(scene: &SceneModel) -> Result<Vec<Part>> {
    let mut out = Vec::new();
    for it in &scene.solids {
        for s in &it.solid.parts {
            let (centre, radius) = bounding_sphere(s);
            for solid in collision_solids(s, &it.name)? {
                out.push(Part {
                    name: format!("{}/{}", it.name, s.name),
                    link: 0,
                    offset: isometry_from_matrix(&(it.placement * s.transform)),
                    solid: Arc::new(solid),
                    centre,
                    radius,
                });
            }
        }
    }
    Ok(out)
}

/// Fixed parts posed (their offsets are world poses).
pub fn pose_fixed(parts: &[Part]) -> Vec<Posed<'_>> {
    parts
        .iter()
        .map(|p| Posed {
            part: p,
            pose: p.offset,
            centre: p.offset * p.centre,
        })
        .collect()
}

/// The smallest distance between any part of `a` and any part of `b` (m; ≤ 0 in contact) in
/// `mode`, with the pair's names; pairs whose bounding spheres are farther apart than the
/// best found so far are skipped. `None` when either list is empty. A mode that gives no
/// distance (bbox, polygon) answers 0 for a contact and, when clear, the sphere lower bound
/// (at least 1e-9 m, so clear stays > 0), flagged by `exact == false`.
pub fn clearance(a: &[Posed<'_>], b: &[Posed<'_>], mode: Mode) -> Option<Clearance> {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::with_capacity(a.len() * b.len());
    for (i, pa) in a.iter().enumerate() {
        for (j, pb) in b.iter().enumerate() {
            let lb = (pa.centre - pb.centre).norm() - pa.part.radius - pb.part.radius;
            pairs.push((lb, i, j));
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut best: Option<Clearance> = None;
    for (lb, i, j) in pairs {
        if best.as_ref().is_some_and(|c| lb >= c.distance) {
            break;
        }
        let (pa, pb) = (&a[i], &b[j]);
        let r = collide(&pa.part.solid, &pa.pose, &pb.part.solid, &pb.pose, mode);
        let (d, exact) = match r {
            PairResult::Contact {
                signed_distance, ..
            } => (
                signed_distance.unwrap_or(0.0).min(0.0),
                signed_distance.is_some(),
            ),
            PairResult::Clear { distance, .. } => match distance {
                Some(d) => (d, true),
                // clear, distance unknown: the sphere lower bound, kept above zero
                None => (lb.max(1e-9), false),
            },
            // not decided: counted as touching, so that it is looked at
            PairResult::Unknown { .. } => (0.0, false),
        };
        if best.as_ref().is_none_or(|c| d < c.distance) {
            best = Some(Clearance {
                distance: d,
                a: pa.part.name.clone(),
                b: pb.part.name.clone(),
                exact,
            });
        }
    }
    best
}

/// The closest pair found by [`clearance`].
#[derive(Debug, Clone, PartialEq)]
pub struct Clearance {
    pub distance: f64,
    pub a: String,
    pub b: String,
    pub exact: bool,
}

/// Writes a trajectory file in the display's file-mode format (seed §2.2: degrees for revolute
/// joints, metres for prismatic ones, `# dt:` the seconds between samples).
pub fn write_trajectory(path: &Path, robot: &Robot, dt: f64, samples: &[Vec<f64>]) -> Result<()> {
    let mut s = String::new();
    s.push_str(&format!(
        "# {} trajectory: one sample per line, degrees (revolute) / metres (prismatic)\n# dt: {dt}\n",
        robot.name
    ));
    for q in samples {
        let cols: Vec<String> = q
            .iter()
            .zip(&robot.joints)
            .map(|(v, j)| match j.joint_type {
                JointType::Revolute => format!("{:.6}", v.to_degrees()),
                JointType::Prismatic => format!("{v:.6}"),
            })
            .collect();
        s.push_str(&cols.join(" "));
        s.push('\n');
    }
    robosim_input::write_file_atomic(path, s.as_bytes()).map_err(StudyError::from)
}

/// A CSV file written row by row; every value finite (a NaN is a bug, refused by name).
pub struct Csv {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    columns: Vec<String>,
}

impl Csv {
    pub fn create(path: &Path, columns: &[String]) -> Result<Csv> {
        let f = std::fs::File::create(path).map_err(|e| StudyError::io(path, e))?;
        let mut out = std::io::BufWriter::new(f);
        writeln!(out, "{}", columns.join(",")).map_err(|e| StudyError::io(path, e))?;
        Ok(Csv {
            path: path.to_owned(),
            out,
            columns: columns.to_vec(),
        })
    }

    pub fn row(&mut self, values: &[f64]) -> Result<()> {
        if values.len() != self.columns.len() {
            return Err(StudyError::Message(format!(
                "{}: a row of {} values for {} columns",
                self.path.display(),
                values.len(),
                self.columns.len()
            )));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(StudyError::Message(format!(
                "{}: column {} is not finite ({})",
                self.path.display(),
                self.columns[i],
                values[i]
            )));
        }
        let cells: Vec<String> = values.iter().map(|v| format!("{v}")).collect();
        writeln!(self.out, "{}", cells.join(",")).map_err(|e| StudyError::io(&self.path, e))
    }

    pub fn finish(mut self) -> Result<PathBuf> {
        self.out
            .flush()
            .map_err(|e| StudyError::io(&self.path, e))?;
        Ok(self.path)
    }
}

/// Renders `count` frames of the trajectories headless (the display's `render --play`) into
/// `dir`, seen from `from` towards `at` (None: the display frames the model).
#[allow(clippy::too_many_arguments)]
pub fn render_frames(
    scene: &str,
    plays: &[(String, PathBuf)],
    samples: usize,
    count: usize,
    dir: &Path,
    from: Option<[f64; 3]>,
    at: Option<[f64; 3]>,
    poses: Vec<robosim_display::app::PoseTrack>,
) -> Result<()> {
    if count == 0 || samples == 0 {
        return Ok(());
    }
    let args = render_args(scene, plays, samples, count, dir, from, at, poses);
    robosim_display::app::cmd_render(&args)
        .map_err(|e| StudyError::Message(format!("frames: {}", e.0)))
}

/// What [`render_frames`] asks the display to draw: the scene, the played trajectories, every
/// `samples / count`-th sample, the camera, objects moved per sample (`poses`).
#[allow(clippy::too_many_arguments)]
pub fn render_args(
    scene: &str,
    plays: &[(String, PathBuf)],
    samples: usize,
    count: usize,
    dir: &Path,
    from: Option<[f64; 3]>,
    at: Option<[f64; 3]>,
    poses: Vec<robosim_display::app::PoseTrack>,
) -> robosim_display::app::RenderArgs {
    robosim_display::app::RenderArgs {
        scene: scene.to_owned(),
        out: None,
        view: robosim_display::app::ViewArgs {
            from,
            at,
            up: [0.0, 0.0, 1.0],
            fov: 40.0,
            ortho: false,
            edges: false,
            size: (800, 600),
            collisions: false,
        },
        joints: vec![],
        play: plays
            .iter()
            .map(|(r, p)| format!("{r}={}", p.display()))
            .collect(),
        frames: Some(dir.to_owned()),
        record: None,
        every: samples.div_ceil(count.max(1)).max(1),
        hide: vec![],
        grid: false,
        library: vec![],
        poses,
    }
}

/// Elapsed seconds of a closure's run, with its value.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = std::time::Instant::now();
    let v = f();
    (v, t.elapsed().as_secs_f64())
}

/// The most time steps one study run may take by default (a planner's `--step 0.000001`
/// asked for 2.7 TB of samples); [`STEP_BUDGET_ENV`] raises it.
pub const STEP_BUDGET: usize = 2_000_000;
/// The environment variable that sets another step budget for `robosim study`.
pub const STEP_BUDGET_ENV: &str = "ROBOSIM_STUDY_MAX_STEPS";

/// The number of steps `steps` (a real count: span / step, rounded up) when it is within the
/// step budget ([`STEP_BUDGET`], or [`STEP_BUDGET_ENV`] when set); otherwise a refusal naming
/// `what` is stepped, the count, the budget and how to raise it — before anything is allocated.
pub fn step_count(steps: f64, what: &str) -> crate::Result<usize> {
    let budget = std::env::var(STEP_BUDGET_ENV)
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .unwrap_or(STEP_BUDGET);
    let n = steps.ceil();
    if n.is_finite() && n >= 0.0 && n <= budget as f64 {
        Ok(n as usize)
    } else {
        Err(StudyError::Message(format!(
            "{what} would take {n:e} time steps, over the budget of {budget} \
             (give a larger --step or a shorter run, or set {STEP_BUDGET_ENV} to raise it)"
        )))
    }
}
