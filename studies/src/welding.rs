//! `robosim study welding`: the downhand welding cell of seed §2.2 welding the seams of a real
//! workpiece — a pipe on a flange (a circle fillet) and a branch set into the pipe (a saddle).
//! The scene is the library's `downhand_welding_study`; the seams are computed from the
//! workpiece's evaluated parts (flange, pipe, branch), so they follow what is drawn and collided.
//!
//! The 8-DOF coordination, each step:
//! 1. the seam point at arc length v·t (constant travel speed relative to the work), its
//!    tangent t and seam normal n (the bisector of the two surfaces' outward normals);
//! 2. the positioner from the downhand condition: tilt and table turn so that n points up —
//!    for each tilt on a 2.5° scan the best table angle in closed form, then golden-section
//!    search on the tilt; of the two mirror solutions the one nearest the previous step;
//!    the table angle is the 2π-equivalent nearest the previous within its ±360°;
//! 3. the torch pose: approach a = −cos τ·n + sin τ·t (travel angle τ, push), the tip the
//!    standoff back along a; the roll about a is free (a 5-D task) and is chosen with the IK
//!    branch: rolls within ±2°…±30° of the previous roll, then round the turn, every analytic
//!    solution (spherical wrist), the one within limits and keeping the minimum clearance that
//!    is nearest the previous joint values (branch and roll kept continuous);
//! 4. checks: joint limits, joint speeds against the stated limits, clearances arm ×
//!    (positioner + workpiece) in the chosen collision mode, downhand error, torch angles
//!    measured from the FK of the joint values actually used.
//!
//! A step with no IK solution, no downhand pose or a contact is infeasible; consecutive
//! infeasible steps are reported as a section with where (seam %) and why.
//!
//! Entry points: [`WeldingParams`], [`run`], [`simulate`], [`accuracy`].

use crate::common::{self, Body, Csv};
use crate::{Result, StudyError, bail, say};
use nalgebra::{Matrix4, Point3, Vector3};
use robosim_collision::Mode;
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::{Robot, fk};
use robosim_library::{Params, PlacedSolid, Primitive};
use std::f64::consts::{PI, TAU};
use std::path::Path;

pub const SCENE: &str = "downhand_welding_study";
/// The approach pose before each seam: this far back along the torch axis, m.
const APPROACH_M: f64 = 0.08;

/// Which seam.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeamKind {
    /// The pipe-to-flange fillet (a circle).
    Circle,
    /// The branch-to-pipe joint (a saddle curve).
    Saddle,
}

impl SeamKind {
    pub fn name(self) -> &'static str {
        match self {
            SeamKind::Circle => "circle",
            SeamKind::Saddle => "saddle",
        }
    }
}

/// The study's parameters; defaults stated in docs/studies.md.
#[derive(Debug, Clone, PartialEq)]
pub struct WeldingParams {
    pub seams: Vec<SeamKind>,
    /// Travel speed of the torch relative to the work, m/s.
    pub speed_m_s: f64,
    pub step_s: f64,
    /// Saddle: height of the branch axis above the flange top, m (None: the scene's 0.18 m).
    /// A scene parameter: it moves the branch that is drawn and collided, and the seam with it.
    pub branch_height_m: Option<f64>,
    /// The arm's base x, m (None: the scene's).
    pub arm_x_m: Option<f64>,
    pub mode: Mode,
    pub frames: usize,
    /// Travel (push) angle, rad; contact-tip-to-work distance, m.
    pub travel_angle: f64,
    pub standoff_m: f64,
    /// Downhand tolerance: the seam normal within this of vertical, rad.
    pub downhand_tol: f64,
    /// Search tolerance of the positioner's downhand solve, rad.
    pub positioner_tol: f64,
    /// Clearance the arm's solution is chosen to keep from positioner and work, m.
    pub min_clearance_m: f64,
    /// Joint speed limits, rad/s: arm (6), positioner (2).
    pub arm_speed: [f64; 6],
    pub positioner_speed: [f64; 2],
}

impl Default for WeldingParams {
    fn default() -> Self {
        let d = f64::to_radians;
        WeldingParams {
            seams: vec![SeamKind::Circle, SeamKind::Saddle],
            speed_m_s: 8e-3,
            step_s: 0.25,
            branch_height_m: None,
            arm_x_m: None,
            mode: Mode::Exact,
            frames: 12,
            travel_angle: d(10.0),
            standoff_m: 0.015,
            downhand_tol: d(5.0),
            positioner_tol: 1e-6,
            min_clearance_m: 0.005,
            // IRB 1400 class data sheet order: 110°/s on the main axes, 280°/s on the wrist
            arm_speed: [d(110.0), d(110.0), d(110.0), d(280.0), d(280.0), d(280.0)],
            // a two-axis positioner's order: 60°/s tilt, 90°/s table
            positioner_speed: [d(60.0), d(90.0)],
        }
    }
}

impl WeldingParams {
    pub fn check(&self) -> Result<()> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if self.seams.is_empty() {
            bail!("no seam chosen: circle, saddle or both");
        }
        if !pos(self.speed_m_s) || self.speed_m_s > 0.1 {
            bail!(
                "travel speed {} mm/s: expected a speed in (0, 100] mm/s",
                self.speed_m_s * 1e3
            );
        }
        if !pos(self.step_s) || self.step_s > 10.0 {
            bail!("step {} s: expected a step in (0, 10] s", self.step_s);
        }
        if let Some(h) = self.branch_height_m
            && !h.is_finite()
        {
            bail!("branch height {h} m: expected a finite height");
        }
        if let Some(x) = self.arm_x_m
            && !(x.is_finite() && x.abs() < 100.0)
        {
            bail!("arm x {x} m: expected a finite position within 100 m");
        }
        if !(self.travel_angle.is_finite() && self.travel_angle.abs() < PI / 3.0) {
            bail!(
                "travel angle {} deg: expected |angle| < 60 deg",
                self.travel_angle.to_degrees()
            );
        }
        if !(self.standoff_m.is_finite() && self.standoff_m >= 0.0 && self.standoff_m < 0.1) {
            bail!("standoff {} m: expected [0, 0.1) m", self.standoff_m);
        }
        if !(self.min_clearance_m.is_finite() && self.min_clearance_m >= 0.0) {
            bail!(
                "minimum clearance {} m: expected a finite distance ≥ 0",
                self.min_clearance_m
            );
        }
        if !pos(self.downhand_tol) || !pos(self.positioner_tol) {
            bail!("tolerances must be positive angles");
        }
        if !self
            .arm_speed
            .iter()
            .chain(&self.positioner_speed)
            .all(|v| pos(*v))
        {
            bail!("joint speed limits must be positive");
        }
        Ok(())
    }
}

/// A seam sampled by arc length in the table's link frame.
#[derive(Debug, Clone)]
pub struct Seam {
    pub kind: SeamKind,
    /// Cumulative arc length, m, at each sample.
    pub s: Vec<f64>,
    pub points: Vec<Point3<f64>>,
    pub tangents: Vec<Vector3<f64>>,
    /// Seam normals (unit bisector of the two surface normals, out of the joint).
    pub normals: Vec<Vector3<f64>>,
    /// Half the opening angle between the two surfaces (the work angle to hold), rad.
    pub half_opening: Vec<f64>,
}

impl Seam {
    pub fn length(&self) -> f64 {
        self.s.last().copied().unwrap_or(0.0)
    }

    /// Point, tangent, normal and half opening at arc length `s` (linear between samples,
    /// directions renormalised).
    pub fn at(&self, s: f64) -> (Point3<f64>, Vector3<f64>, Vector3<f64>, f64) {
        let s = s.clamp(0.0, self.length());
        let i = match self.s.binary_search_by(|x| x.total_cmp(&s)) {
            Ok(i) => i.min(self.s.len() - 2),
            Err(i) => i.saturating_sub(1).min(self.s.len() - 2),
        };
        let u = ((s - self.s[i]) / (self.s[i + 1] - self.s[i]).max(1e-15)).clamp(0.0, 1.0);
        let p = self.points[i] + (self.points[i + 1] - self.points[i]) * u;
        let t = (self.tangents[i] * (1.0 - u) + self.tangents[i + 1] * u).normalize();
        let n = (self.normals[i] * (1.0 - u) + self.normals[i + 1] * u).normalize();
        let h = self.half_opening[i] * (1.0 - u) + self.half_opening[i + 1] * u;
        (p, t, n, h)
    }
}

/// A cylinder part of the workpiece in the table link frame: axis point (centre), axis,
/// radius, height.
#[derive(Debug, Clone, Copy)]
struct Cyl {
    centre: Point3<f64>,
    axis: Vector3<f64>,
    radius: f64,
    height: f64,
}

fn cyl(parts: &[PlacedSolid], leaf: &str) -> Result<Cyl> {
    let p = parts
        .iter()
        .find(|p| p.name.rsplit('/').next() == Some(leaf))
        .ok_or_else(|| StudyError::Message(format!("the workpiece has no part `{leaf}`")))?;
    let Primitive::Cylinder { radius, height, .. } = p.primitive else {
        bail!("workpiece part `{leaf}` is not a cylinder");
    };
    let t = p.transform;
    Ok(Cyl {
        centre: Point3::new(t[(0, 3)], t[(1, 3)], t[(2, 3)]),
        axis: Vector3::new(t[(0, 2)], t[(1, 2)], t[(2, 2)]).normalize(),
        radius,
        height,
    })
}

/// Distance of `p` from the lateral surface of `c` (m), and whether its axial position lies on
/// the cylinder.
fn off_surface(c: &Cyl, p: &Point3<f64>) -> (f64, bool) {
    let d = p - c.centre;
    let along = d.dot(&c.axis);
    let radial = (d - along * c.axis).norm();
    (
        (radial - c.radius).abs(),
        along.abs() <= c.height / 2.0 + 1e-9,
    )
}

/// The seams of the workpiece on link `table` of the positioner (`parts`: that link's solids).
pub fn seams(parts: &[PlacedSolid], kinds: &[SeamKind]) -> Result<Vec<Seam>> {
    let flange = cyl(parts, "flange")?;
    let pipe = cyl(parts, "pipe")?;
    let up = flange.axis;
    let top = flange.centre + up * (flange.height / 2.0);
    let foot = pipe.centre - pipe.axis * (pipe.height / 2.0);
    if (foot - top).norm() > 1e-6 || (pipe.axis - up).norm() > 1e-9 {
        bail!("the workpiece's pipe does not stand on its flange (no circle seam there)");
    }
    // in-plane axes
    let u = {
        let x = Vector3::x();
        (x - up * x.dot(&up)).normalize()
    };
    let v = up.cross(&u);
    let mut out = Vec::new();
    for &kind in kinds {
        let n = 720;
        let (mut pts, mut ts, mut ns, mut hs) = (vec![], vec![], vec![], vec![]);
        match kind {
            SeamKind::Circle => {
                if pipe.radius >= flange.radius {
                    bail!(
                        "the pipe (radius {} m) is wider than the flange: no fillet seam",
                        pipe.radius
                    );
                }
                for k in 0..=n {
                    let phi = TAU * k as f64 / n as f64;
                    let radial = phi.cos() * u + phi.sin() * v;
                    pts.push(top + pipe.radius * radial);
                    ts.push(-phi.sin() * u + phi.cos() * v);
                    ns.push((up + radial).normalize());
                    hs.push(up.angle(&radial) / 2.0);
                }
            }
            SeamKind::Saddle => {
                let branch = cyl(parts, "branch")?;
                let b = branch.axis;
                // the branch axis meets the pipe axis at this height above the flange
                let h = (branch.centre - top).dot(&up);
                let rb = branch.radius;
                if h - rb < 0.0 || h + rb > pipe.height {
                    bail!(
                        "saddle seam at height {h:.3} m: off the workpiece (the branch of radius {rb} m must lie on the pipe, 0 to {:.3} m above the flange)",
                        pipe.height
                    );
                }
                if rb >= pipe.radius {
                    bail!(
                        "the branch (radius {rb} m) is not narrower than the pipe: no saddle seam"
                    );
                }
                let w = up.cross(&b).normalize();
                let origin = top + up * h;
                for k in 0..=n {
                    let psi = TAU * k as f64 / n as f64;
                    let yy = rb * psi.cos();
                    let zz = rb * psi.sin();
                    let xx = (pipe.radius * pipe.radius - yy * yy).sqrt();
                    let p = origin + b * xx + w * yy + up * zz;
                    // on both surfaces: pipe lateral and branch lateral
                    let (dp, onp) = off_surface(&pipe, &p);
                    let (db, onb) = off_surface(&branch, &p);
                    if dp > 1e-6 || db > 1e-3 || !onp || !onb {
                        bail!(
                            "saddle seam point {k} at ({:.3}, {:.3}, {:.3}) m (table frame) is off the workpiece: {:.1} mm from the branch's surface{}",
                            p.x,
                            p.y,
                            p.z,
                            db * 1e3,
                            if onb { "" } else { ", beyond its ends" }
                        );
                    }
                    let dy = -rb * psi.sin();
                    let dz = rb * psi.cos();
                    let dx = -yy * dy / xx;
                    let t = (b * dx + w * dy + up * dz).normalize();
                    let n_pipe = {
                        let d = p - pipe.centre;
                        (d - pipe.axis * d.dot(&pipe.axis)).normalize()
                    };
                    let n_branch = {
                        let d = p - branch.centre;
                        (d - b * d.dot(&b)).normalize()
                    };
                    pts.push(p);
                    ts.push(t);
                    ns.push((n_pipe + n_branch).normalize());
                    hs.push(n_pipe.angle(&n_branch) / 2.0);
                }
            }
        }
        let mut s = vec![0.0];
        for k in 1..pts.len() {
            s.push(s[k - 1] + (pts[k] - pts[k - 1]).norm());
        }
        out.push(Seam {
            kind,
            s,
            points: pts,
            tangents: ts,
            normals: ns,
            half_opening: hs,
        });
    }
    Ok(out)
}

/// The cell set up from the scene.
pub struct Setup {
    pub arm: Body,
    pub positioner: Body,
    pub seams: Vec<Seam>,
    /// The positioner's link carrying the workpiece.
    pub table_link: usize,
}

pub fn setup(p: &WeldingParams) -> Result<Setup> {
    p.check()?;
    let mut params = Params::new();
    if let Some(x) = p.arm_x_m {
        params = params.si("arm_x", x);
    }
    if let Some(h) = p.branch_height_m {
        params = params.si("branch_height", h);
    }
    let (_lib, scene) = common::scene(SCENE, &params)?;
    let find = |decl: &str| {
        scene
            .robots
            .iter()
            .find(|r| r.declaration.as_deref() == Some(decl))
            .ok_or_else(|| StudyError::Message(format!("{SCENE} places no {decl}")))
    };
    let arm_p = find("weld_arm")?;
    let pos_p = find("weld_study_positioner")?;
    let table_link = pos_p.model.frames.len() - 1;
    let seams = seams(&pos_p.model.frames[table_link], &p.seams)?;
    Ok(Setup {
        arm: Body::of(arm_p)?,
        positioner: Body::of(pos_p)?,
        seams,
        table_link,
    })
}

/// The table link's world pose at positioner joints `qp`.
fn table_pose(s: &Setup, qp: &[f64]) -> Matrix4<f64> {
    s.positioner.frames(qp)[s.table_link]
}

fn rot(m: &Matrix4<f64>) -> nalgebra::Matrix3<f64> {
    m.fixed_view::<3, 3>(0, 0).into_owned()
}

/// Positioner joints putting the table-frame direction `n` up (downhand), nearest `prev`.
/// Returns the joints and the remaining angle from vertical.
pub fn downhand(s: &Setup, n: &Vector3<f64>, prev: &[f64], tol: f64) -> (Vec<f64>, f64) {
    let robot = &s.positioner.robot;
    let lim = [robot.joints[0].qlim, robot.joints[1].qlim];
    let up = Vector3::z();
    let score = |q: &[f64]| (rot(&table_pose(s, q)) * n).dot(&up);
    // best table angle for a tilt, closed form (n·up = A + B cos q2 + C sin q2), the
    // 2π-equivalent nearest the previous one within the limits
    let best_table = |q1: f64| -> (f64, f64) {
        let f = |q2: f64| score(&[q1, q2]);
        let (f0, f1, f2) = (f(0.0), f(PI / 2.0), f(PI));
        let b = 0.5 * (f0 - f2);
        let c = f1 - 0.5 * (f0 + f2);
        let base = c.atan2(b);
        let k = ((prev[1] - base) / TAU).round();
        let mut best = None::<(f64, f64)>;
        for dk in [-1.0, 0.0, 1.0] {
            let q2 = base + (k + dk) * TAU;
            if q2 >= lim[1][0] && q2 <= lim[1][1] {
                let d = (q2 - prev[1]).abs();
                if best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((q2, d));
                }
            }
        }
        let q2 = best.map_or(base.clamp(lim[1][0], lim[1][1]), |b| b.0);
        (q2, f(q2))
    };
    // scan the tilt, keep near-best candidates, refine each, take the nearest to prev
    let nscan = 108;
    let mut scan = Vec::with_capacity(nscan + 1);
    for k in 0..=nscan {
        let q1 = lim[0][0] + (lim[0][1] - lim[0][0]) * k as f64 / nscan as f64;
        scan.push((q1, best_table(q1).1));
    }
    let h = (lim[0][1] - lim[0][0]) / nscan as f64;
    let mut cands: Vec<(Vec<f64>, f64)> = Vec::new();
    for k in 0..scan.len() {
        let left = if k > 0 {
            scan[k - 1].1
        } else {
            f64::NEG_INFINITY
        };
        let right = scan.get(k + 1).map_or(f64::NEG_INFINITY, |x| x.1);
        if scan[k].1 < left || scan[k].1 < right {
            continue;
        }
        let q1 = robosim_simulator::numeric::golden_max(
            |x| best_table(x).1,
            (scan[k].0 - h).max(lim[0][0]),
            (scan[k].0 + h).min(lim[0][1]),
            tol,
        );
        let (q2, v) = best_table(q1);
        cands.push((vec![q1, q2], v));
    }
    let top = cands.iter().map(|c| c.1).fold(f64::NEG_INFINITY, f64::max);
    let chosen = cands
        .into_iter()
        .filter(|c| c.1 >= top - 1e-9)
        .min_by(|a, b| {
            let da = (a.0[0] - prev[0]).abs() + (a.0[1] - prev[1]).abs();
            let db = (b.0[0] - prev[0]).abs() + (b.0[1] - prev[1]).abs();
            da.total_cmp(&db)
        })
        .map(|c| c.0)
        .unwrap_or_else(|| prev.to_vec());
    let err = score(&chosen).clamp(-1.0, 1.0).acos();
    (chosen, err)
}

/// The torch target: tip position and approach in the world for a seam frame in the world.
fn torch_target(
    p: &WeldingParams,
    point: &Point3<f64>,
    t: &Vector3<f64>,
    n: &Vector3<f64>,
    roll: f64,
) -> Matrix4<f64> {
    let a = (-p.travel_angle.cos() * n + p.travel_angle.sin() * t).normalize();
    let x0 = (t - a * t.dot(&a)).normalize();
    let y0 = a.cross(&x0);
    let x = roll.cos() * x0 + roll.sin() * y0;
    let y = a.cross(&x);
    let tip = point - a * p.standoff_m;
    let mut m = Matrix4::identity();
    for r in 0..3 {
        m[(r, 0)] = x[r];
        m[(r, 1)] = y[r];
        m[(r, 2)] = a[r];
        m[(r, 3)] = tip[r];
    }
    m
}

/// The arm's joints (and the torch roll) for the torch at the seam frame: rolls near the
/// previous one first, then round the turn; every analytic solution within limits; of these, the nearest to `prev` (weighted by the joint speed limits)
/// whose arm keeps `min_clearance_m` from the positioner and workpiece at `qp` — or, when none
/// does, the one with the most clearance.
#[allow(clippy::too_many_arguments)]
fn arm_ik(
    s: &Setup,
    p: &WeldingParams,
    point: &Point3<f64>,
    t: &Vector3<f64>,
    n: &Vector3<f64>,
    prev: &[f64],
    qp: &[f64],
    standoff: f64,
    prev_roll: f64,
) -> std::result::Result<(Vec<f64>, f64), String> {
    let opts = IkOptions {
        all: true,
        q0: Some(prev.to_vec()),
        ..IkOptions::default()
    };
    let mut cands: Vec<(f64, Vec<f64>, f64)> = Vec::new();
    let mut why = String::from("unreachable at every torch roll");
    let q = WeldingParams {
        standoff_m: standoff,
        ..p.clone()
    };
    // rolls near the previous one first (continuity), then around the whole turn
    let offsets = [
        0.0, 2.0, -2.0, 5.0, -5.0, 10.0, -10.0, 20.0, -20.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0,
        120.0, -120.0, 150.0, -150.0, 180.0,
    ];
    for off in offsets {
        let roll = prev_roll + f64::to_radians(off);
        let target = torch_target(&q, point, t, n, roll);
        match ik::solve(&s.arm.robot, &target, Method::Analytic, &opts) {
            Ok(r) => {
                for sol in r.solutions {
                    if !sol.within_limits || !sol.converged {
                        why = "every solution is outside the joint limits".into();
                        continue;
                    }
                    let d = sol
                        .q
                        .iter()
                        .zip(prev)
                        .zip(&p.arm_speed)
                        .map(|((a, b), v)| ((a - b) / v).abs())
                        .fold(0.0, f64::max);
                    cands.push((d, sol.q, roll));
                }
            }
            Err(ik::IkError::Unreachable { reason }) => {
                if cands.is_empty() && why.starts_with("unreachable") {
                    why = format!("unreachable: {reason}");
                }
            }
            Err(e) => return Err(e.to_string()),
        }
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut roomiest: Option<(f64, &Vec<f64>, f64)> = None;
    // bbox and polygon tell clear from contact but give no distance
    let enough = if p.mode == Mode::Exact {
        p.min_clearance_m
    } else {
        1e-9
    };
    for (_, c, roll) in &cands {
        let cl = clearance(s, p, c, qp).0;
        if cl >= enough {
            return Ok((c.clone(), *roll));
        }
        if roomiest.is_none_or(|r| cl > r.0) {
            roomiest = Some((cl, c, *roll));
        }
    }
    roomiest.map(|r| (r.1.clone(), r.2)).ok_or(why)
}

/// One step's record.
#[derive(Debug, Clone)]
pub struct Step {
    pub t: f64,
    pub seam: usize,
    /// Arc length along the seam, m (negative: a repositioning move, not welding).
    pub s: f64,
    pub q_arm: Vec<f64>,
    pub q_pos: Vec<f64>,
    pub downhand_err: f64,
    pub work_angle: f64,
    pub work_err: f64,
    pub travel_angle: f64,
    pub travel_err: f64,
    pub tip_err: f64,
    /// Largest |Δq|/dt over the limit, arm and positioner.
    pub arm_speed_ratio: f64,
    pub pos_speed_ratio: f64,
    pub clearance: f64,
    pub clearance_pair: (String, String),
    /// Why this step cannot be welded as asked (empty: it can).
    pub problem: String,
}

/// A run's outcome.
#[derive(Debug, Clone)]
pub struct Run {
    pub steps: Vec<Step>,
    pub wall_s: f64,
    /// Mid-step checks (joint interpolation between steps): worst downhand error and tip
    /// error, rad / m.
    pub mid_downhand: f64,
    pub mid_tip: f64,
}

/// Measured torch angles for a step (from FK): (downhand err, work angle, work err, travel
/// angle, travel err, tip err).
fn measure(
    s: &Setup,
    p: &WeldingParams,
    seam: &Seam,
    sarc: f64,
    qa: &[f64],
    qp: &[f64],
) -> [f64; 6] {
    let (pt, t, n, half) = seam.at(sarc);
    let tp = table_pose(s, qp);
    let r = rot(&tp);
    let nw = r * n;
    let tw = r * t;
    let pw = tp.transform_point(&pt);
    let tool = fk::forward(&s.arm.robot, qa);
    let a = Vector3::new(tool[(0, 2)], tool[(1, 2)], tool[(2, 2)]);
    let tip = Point3::new(tool[(0, 3)], tool[(1, 3)], tool[(2, 3)]);
    let downhand = nw.dot(&Vector3::z()).clamp(-1.0, 1.0).acos();
    let travel = a.dot(&tw).clamp(-1.0, 1.0).asin();
    // work angle: in the plane ⟂ t, the torch axis (work → torch, −a) from the bisector n
    let d = -a;
    let dp = d - tw * d.dot(&tw);
    let b = tw.cross(&nw);
    let work_err = dp.dot(&b).atan2(dp.dot(&nw));
    let want_tip = pw - a * p.standoff_m;
    [
        downhand,
        half + work_err,
        work_err,
        travel,
        travel - p.travel_angle,
        (tip - want_tip).norm(),
    ]
}

/// Runs the coordination over the chosen seams (a joint-space repositioning move at the speed
/// limits before each seam, from the scene's start pose).
pub fn simulate(s: &Setup, p: &WeldingParams) -> Result<Run> {
    let t0 = std::time::Instant::now();
    let mut w = Welder {
        s,
        p,
        steps: Vec::new(),
        qa: s.arm.q0.clone(),
        qp: s.positioner.q0.clone(),
        t: 0.0,
        roll: 0.0,
        mid_dh: 0.0,
        mid_tip: 0.0,
    };
    for (si, seam) in s.seams.iter().enumerate() {
        w.reposition(si, seam)?;
        w.weld(si, seam)?;
    }
    Ok(Run {
        steps: w.steps,
        wall_s: t0.elapsed().as_secs_f64(),
        mid_downhand: w.mid_dh,
        mid_tip: w.mid_tip,
    })
}

/// The largest joint speed from `b` to `a` over `dt` as a fraction of the limits `v`.
fn speed_ratio(a: &[f64], b: &[f64], v: &[f64], dt: f64) -> f64 {
    a.iter()
        .zip(b)
        .zip(v)
        .map(|((x, y), v)| (x - y).abs() / dt / v)
        .fold(0.0, f64::max)
}

/// The cell as the run leaves it step by step: the steps so far, the joint values, the
/// clock, the torch roll kept for continuity, the worst mid-step errors.
struct Welder<'s> {
    s: &'s Setup,
    p: &'s WeldingParams,
    steps: Vec<Step>,
    /// The arm's and the positioner's joint values now.
    qa: Vec<f64>,
    qp: Vec<f64>,
    /// The time now, s.
    t: f64,
    /// The torch roll about its axis of the last IK solution, rad.
    roll: f64,
    /// The worst downhand error and tip error at mid-step (of steps without a problem).
    mid_dh: f64,
    mid_tip: f64,
}

impl Welder<'_> {
    /// Moves to seam `si`'s first weld pose in joint space at the speed limits: the arm back
    /// to a retracted pose, the positioner to the seam's first downhand pose, the arm to a
    /// pose 80 mm back along the torch axis, then in to the weld start (no move where the arm
    /// reaches neither pose).
    fn reposition(&mut self, si: usize, seam: &Seam) -> Result<()> {
        let (s, p) = (self.s, self.p);
        // the first weld pose
        let (pt0, t0v, n0, _) = seam.at(0.0);
        let (qp1, _) = downhand(s, &n0, &self.qp, p.positioner_tol);
        let tp = table_pose(s, &qp1);
        let r = rot(&tp);
        let start_arm = arm_ik(
            s,
            p,
            &tp.transform_point(&pt0),
            &(r * t0v),
            &(r * n0),
            &s.arm.q0,
            &qp1,
            p.standoff_m,
            0.0,
        );
        let approach = start_arm
            .as_ref()
            .map_err(Clone::clone)
            .and_then(|(_, roll)| {
                arm_ik(
                    s,
                    p,
                    &tp.transform_point(&pt0),
                    &(r * t0v),
                    &(r * n0),
                    &s.arm.q0,
                    &qp1,
                    p.standoff_m + APPROACH_M,
                    *roll,
                )
            });
        if let Ok((_, r0)) = &start_arm {
            self.roll = *r0;
        }
        if let (Ok((qa1, _)), Ok((qa_app, _))) = (&start_arm, &approach) {
            let safe = retract(s, p, &self.qp, &qp1);
            let segments: [(Vec<f64>, Vec<f64>); 4] = [
                (safe.clone(), self.qp.clone()),
                (safe, qp1.clone()),
                (qa_app.clone(), qp1.clone()),
                (qa1.clone(), qp1.clone()),
            ];
            for (qa_to, qp_to) in segments {
                self.move_to(si, &qa_to, &qp_to)?;
            }
        }
        Ok(())
    }

    /// One repositioning move to (`qa_to`, `qp_to`), interpolated in joint space over as many
    /// steps as the slowest joint at its speed limit needs; each step's clearance checked.
    fn move_to(&mut self, si: usize, qa_to: &[f64], qp_to: &[f64]) -> Result<()> {
        let (s, p) = (self.s, self.p);
        let dur = self
            .qa
            .iter()
            .zip(qa_to)
            .zip(&p.arm_speed)
            .chain(self.qp.iter().zip(qp_to).zip(&p.positioner_speed))
            .map(|((a, b), v)| (b - a).abs() / v)
            .fold(0.0, f64::max);
        if dur == 0.0 {
            return Ok(());
        }
        let n = common::step_count(
            dur / p.step_s,
            &format!("a {dur:.1} s move at a step of {} s", p.step_s),
        )?
        .max(1);
        let (qa0, qp0) = (self.qa.clone(), self.qp.clone());
        for k in 1..=n {
            let u = k as f64 / n as f64;
            let qa_k: Vec<f64> = qa0
                .iter()
                .zip(qa_to)
                .map(|(a, b)| a + u * (b - a))
                .collect();
            let qp_k: Vec<f64> = qp0
                .iter()
                .zip(qp_to)
                .map(|(a, b)| a + u * (b - a))
                .collect();
            self.t += p.step_s;
            let (cl, pair) = clearance(s, p, &qa_k, &qp_k);
            self.steps.push(Step {
                t: self.t,
                seam: si,
                s: -1.0,
                arm_speed_ratio: speed_ratio(&qa_k, &self.qa, &p.arm_speed, p.step_s),
                pos_speed_ratio: speed_ratio(&qp_k, &self.qp, &p.positioner_speed, p.step_s),
                q_arm: qa_k.clone(),
                q_pos: qp_k.clone(),
                downhand_err: 0.0,
                work_angle: 0.0,
                work_err: 0.0,
                travel_angle: 0.0,
                travel_err: 0.0,
                tip_err: 0.0,
                problem: if cl <= 0.0 {
                    format!("repositioning: contact {} × {}", pair.0, pair.1)
                } else {
                    String::new()
                },
                clearance: cl,
                clearance_pair: pair,
            });
            self.qa = qa_k;
            self.qp = qp_k;
        }
        Ok(())
    }

    /// Welds seam `si` at the travel speed: a step every `step_s` along it, the last one on
    /// its end.
    fn weld(&mut self, si: usize, seam: &Seam) -> Result<()> {
        let p = self.p;
        let len = seam.length();
        let n = common::step_count(
            len / p.speed_m_s / p.step_s,
            &format!(
                "a {len:.3} m seam at {} m/s and a step of {} s",
                p.speed_m_s, p.step_s
            ),
        )?
        .max(1);
        let mut s_prev = 0.0;
        for k in 0..=n {
            let sarc = (k as f64 * p.speed_m_s * p.step_s).min(len);
            if k > 0 {
                self.t += p.step_s;
            }
            self.weld_step(si, seam, k, s_prev, sarc);
            s_prev = sarc;
        }
        Ok(())
    }

    /// Weld step `k` at arc length `sarc` (the previous step's at `s_prev`): the positioner
    /// downhand, the arm's IK near the last roll, the mid-step check, the clearance and the
    /// joint speeds; the first problem found is recorded with the step.
    fn weld_step(&mut self, si: usize, seam: &Seam, k: usize, s_prev: f64, sarc: f64) {
        let (s, p) = (self.s, self.p);
        let (pt, tv, nv, _) = seam.at(sarc);
        let (qp_k, dh) = downhand(s, &nv, &self.qp, p.positioner_tol);
        let mut problem = String::new();
        if dh > p.downhand_tol {
            problem = format!(
                "not downhand: the positioner's limits leave the seam normal {:.1}° from vertical (tolerance {:.1}°)",
                dh.to_degrees(),
                p.downhand_tol.to_degrees()
            );
        }
        let tp = table_pose(s, &qp_k);
        let r = rot(&tp);
        let qa_k = match arm_ik(
            s,
            p,
            &tp.transform_point(&pt),
            &(r * tv),
            &(r * nv),
            &self.qa,
            &qp_k,
            p.standoff_m,
            self.roll,
        ) {
            Ok((q, r1)) => {
                self.roll = r1;
                q
            }
            Err(why) => {
                if problem.is_empty() {
                    problem = format!("arm: {why}");
                }
                self.qa.clone()
            }
        };
        // mid-step check of the joint interpolation (accuracy between steps)
        if k > 0 {
            let qa_m: Vec<f64> = self
                .qa
                .iter()
                .zip(&qa_k)
                .map(|(a, b)| 0.5 * (a + b))
                .collect();
            let qp_m: Vec<f64> = self
                .qp
                .iter()
                .zip(&qp_k)
                .map(|(a, b)| 0.5 * (a + b))
                .collect();
            // the seam point half way between the two samples (the last step of a seam is
            // shortened to end on the seam's end, so not sarc − v·h/2)
            let s_m = 0.5 * (s_prev + sarc);
            let m = measure(s, p, seam, s_m, &qa_m, &qp_m);
            if problem.is_empty() {
                self.mid_dh = self.mid_dh.max(m[0]);
                self.mid_tip = self.mid_tip.max(m[5]);
            }
        }
        let m = measure(s, p, seam, sarc, &qa_k, &qp_k);
        let (cl, pair) = clearance(s, p, &qa_k, &qp_k);
        if problem.is_empty() && cl <= 0.0 {
            problem = format!("contact: {} × {}", pair.0, pair.1);
        }
        let (ar, pr) = if k > 0 {
            (
                speed_ratio(&qa_k, &self.qa, &p.arm_speed, p.step_s),
                speed_ratio(&qp_k, &self.qp, &p.positioner_speed, p.step_s),
            )
        } else {
            (0.0, 0.0)
        };
        if problem.is_empty() && (ar > 1.0 || pr > 1.0) {
            problem = format!(
                "joint speed over the limit ({:.0} % arm, {:.0} % positioner) at {:.1} mm/s",
                ar * 100.0,
                pr * 100.0,
                p.speed_m_s * 1e3
            );
        }
        self.steps.push(Step {
            t: self.t,
            seam: si,
            s: sarc,
            q_arm: qa_k.clone(),
            q_pos: qp_k.clone(),
            downhand_err: m[0],
            work_angle: m[1],
            work_err: m[2],
            travel_angle: m[3],
            travel_err: m[4],
            tip_err: m[5],
            arm_speed_ratio: ar,
            pos_speed_ratio: pr,
            clearance: cl,
            clearance_pair: pair,
            problem,
        });
        self.qa = qa_k;
        self.qp = qp_k;
    }
}

/// The retracted arm pose for repositioning: the scene's start pose with the shoulder and elbow
/// lifted, on a 10° grid, the one with the largest clearance at both positioner poses.
fn retract(s: &Setup, p: &WeldingParams, qp_a: &[f64], qp_b: &[f64]) -> Vec<f64> {
    let mut best = (f64::NEG_INFINITY, s.arm.q0.clone());
    let lim = &s.arm.robot.joints;
    for k2 in 0..=8 {
        for k3 in 0..=8 {
            let mut q = s.arm.q0.clone();
            q[1] = (-70.0 + 10.0 * k2 as f64).to_radians();
            q[2] = (-60.0 + 10.0 * k3 as f64).to_radians();
            if q[1] < lim[1].qlim[0]
                || q[1] > lim[1].qlim[1]
                || q[2] < lim[2].qlim[0]
                || q[2] > lim[2].qlim[1]
            {
                continue;
            }
            let c = clearance(s, p, &q, qp_a).0.min(clearance(s, p, &q, qp_b).0);
            if c > best.0 {
                best = (c, q);
            }
        }
    }
    best.1
}

/// Clearance arm × (positioner + workpiece) in the chosen mode, with the closest pair. The
/// torch's own tip region is part of the arm: a weld has the torch near the work by design, so
/// the torch body's distance is what is reported (the wire and the arc are not bodies).
fn clearance(s: &Setup, p: &WeldingParams, qa: &[f64], qp: &[f64]) -> (f64, (String, String)) {
    let fa = s.arm.frames(qa);
    let fp = s.positioner.frames(qp);
    let a = s.arm.posed(&fa);
    let b = s.positioner.posed(&fp);
    match common::clearance(&a, &b, p.mode) {
        Some(c) => (
            c.distance,
            (format!("arm/{}", c.a), format!("positioner/{}", c.b)),
        ),
        None => (f64::INFINITY, (String::new(), String::new())),
    }
}

/// Consecutive infeasible weld steps: (seam, from %, to %, reason).
pub fn sections(s: &Setup, run: &Run) -> Vec<(String, f64, f64, String)> {
    let mut out: Vec<(String, f64, f64, String)> = Vec::new();
    let mut last: Option<(usize, String)> = None;
    for st in &run.steps {
        if st.problem.is_empty() {
            last = None;
            continue;
        }
        let seam = &s.seams[st.seam];
        let pct = if st.s < 0.0 {
            0.0
        } else {
            100.0 * st.s / seam.length()
        };
        let reason = st
            .problem
            .split(" (")
            .next()
            .unwrap_or(&st.problem)
            .to_owned();
        match (&last, out.last_mut()) {
            (Some((ls, lr)), Some(sec)) if *ls == st.seam && *lr == reason => {
                sec.2 = pct;
            }
            _ => {
                out.push((seam.kind.name().to_owned(), pct, pct, st.problem.clone()));
                last = Some((st.seam, reason));
            }
        }
    }
    out
}

/// Runs the study and writes `welding.csv`, `arm.traj`, `positioner.traj`,
/// `welding_summary.{md,csv,png}` and `frames/` into `dir`.
pub fn run(p: &WeldingParams, dir: &Path, log: &mut dyn std::io::Write) -> Result<Run> {
    let s = setup(p)?;
    std::fs::create_dir_all(dir).map_err(|e| StudyError::io(dir, e))?;
    say!(
        log,
        "welding study: {} seam(s) ({}), {:.1} mm/s, step {} s",
        s.seams.len(),
        s.seams
            .iter()
            .map(|x| format!("{} {:.0} mm", x.kind.name(), x.length() * 1e3))
            .collect::<Vec<_>>()
            .join(", "),
        p.speed_m_s * 1e3,
        p.step_s
    );
    let run = simulate(&s, p)?;
    let mut cols: Vec<String> = ["t_s", "seam", "welding", "seam_s_m", "seam_pct"]
        .iter()
        .map(|c| c.to_string())
        .collect();
    cols.extend(
        [
            "downhand_error_deg",
            "work_angle_deg",
            "work_angle_error_deg",
            "travel_angle_deg",
            "travel_angle_error_deg",
            "tip_error_mm",
        ]
        .map(String::from),
    );
    cols.extend(s.arm.link_names.iter().map(|n| format!("arm_{n}_deg")));
    cols.extend(
        s.positioner
            .link_names
            .iter()
            .map(|n| format!("positioner_{n}_deg")),
    );
    cols.extend(
        [
            "arm_speed_ratio",
            "positioner_speed_ratio",
            "clearance_m",
            "feasible",
        ]
        .map(String::from),
    );
    let mut csv = Csv::create(&dir.join("welding.csv"), &cols)?;
    for st in &run.steps {
        let seam = &s.seams[st.seam];
        let welding = st.s >= 0.0;
        let mut row = vec![
            st.t,
            st.seam as f64,
            welding as u8 as f64,
            st.s.max(0.0),
            if welding {
                100.0 * st.s / seam.length()
            } else {
                0.0
            },
            st.downhand_err.to_degrees(),
            st.work_angle.to_degrees(),
            st.work_err.to_degrees(),
            st.travel_angle.to_degrees(),
            st.travel_err.to_degrees(),
            st.tip_err * 1e3,
        ];
        row.extend(st.q_arm.iter().map(|v| v.to_degrees()));
        row.extend(st.q_pos.iter().map(|v| v.to_degrees()));
        row.extend([
            st.arm_speed_ratio,
            st.pos_speed_ratio,
            if st.clearance.is_finite() {
                st.clearance
            } else {
                1e9
            },
            st.problem.is_empty() as u8 as f64,
        ]);
        csv.row(&row)?;
    }
    csv.finish()?;
    let arm_traj = dir.join("arm.traj");
    let pos_traj = dir.join("positioner.traj");
    let qa: Vec<Vec<f64>> = run.steps.iter().map(|st| st.q_arm.clone()).collect();
    let qp: Vec<Vec<f64>> = run.steps.iter().map(|st| st.q_pos.clone()).collect();
    common::write_trajectory(&arm_traj, &s.arm.robot, p.step_s, &qa)?;
    common::write_trajectory(&pos_traj, &s.positioner.robot, p.step_s, &qp)?;
    let summary = summarise(&s, p, &run);
    for n in &summary.notes {
        say!(log, "{n}");
    }
    robosim_report::write_report(dir, &summary)?;
    if p.frames > 0 {
        if p.arm_x_m.is_some() || p.branch_height_m.is_some() {
            say!(
                log,
                "frames: not drawn (the display draws the scene at its default arm_x and branch_height)"
            );
        } else {
            common::render_frames(
                SCENE,
                &[
                    (s.arm.name.clone(), arm_traj),
                    (s.positioner.name.clone(), pos_traj),
                ],
                run.steps.len(),
                p.frames,
                &dir.join("frames"),
                Some([-0.4, -2.2, 1.6]),
                Some([-0.4, 0.0, 0.8]),
                vec![],
            )?;
            say!(log, "frames: {}", dir.join("frames").display());
        }
    }
    say!(log, "wrote {}", dir.display());
    Ok(run)
}

fn weld_steps(run: &Run) -> impl Iterator<Item = &Step> {
    run.steps.iter().filter(|st| st.s >= 0.0)
}

/// The summary: per seam coverage, worst errors, clearance, cycle time; sections; plots.
pub fn summarise(s: &Setup, p: &WeldingParams, run: &Run) -> robosim_report::Report {
    use robosim_report::{Report, Table};
    let rows = summary_rows(s, run);
    let notes = summary_notes(s, p, run);
    let plots = summary_plots(s, run);
    Report {
        name: "welding_summary".into(),
        title: "Downhand welding study: seams, torch angles, clearances, cycle time".into(),
        notes,
        table: Table {
            columns: vec![
                "seam".into(),
                "length (mm)".into(),
                "covered (%)".into(),
                "worst downhand error (deg)".into(),
                "worst work angle error (deg)".into(),
                "worst travel angle error (deg)".into(),
                "worst tip error (mm)".into(),
                "min clearance (mm)".into(),
                "worst speed / limit".into(),
                "time (s)".into(),
            ],
            rows,
        },
        plots,
    }
}

/// The summary table's rows: per seam (length, covered, worst errors, clearance, speed,
/// time), then the cell's.
fn summary_rows(s: &Setup, run: &Run) -> Vec<Vec<String>> {
    let mut rows = Vec::new();
    for (si, seam) in s.seams.iter().enumerate() {
        let st: Vec<&Step> = weld_steps(run).filter(|x| x.seam == si).collect();
        let ok: Vec<&&Step> = st.iter().filter(|x| x.problem.is_empty()).collect();
        let worst = |f: &dyn Fn(&Step) -> f64| ok.iter().map(|x| f(x).abs()).fold(0.0, f64::max);
        let min_cl = st.iter().map(|x| x.clearance).fold(f64::INFINITY, f64::min);
        let t_a = st.first().map_or(0.0, |x| x.t);
        let t_b = st.last().map_or(0.0, |x| x.t);
        rows.push(vec![
            seam.kind.name().to_owned(),
            format!("{:.1}", seam.length() * 1e3),
            format!("{:.1}", 100.0 * ok.len() as f64 / st.len().max(1) as f64),
            format!("{:.3}", worst(&|x| x.downhand_err).to_degrees()),
            format!("{:.3}", worst(&|x| x.work_err).to_degrees()),
            format!("{:.3}", worst(&|x| x.travel_err).to_degrees()),
            format!("{:.3}", worst(&|x| x.tip_err) * 1e3),
            format!("{:.3}", min_cl * 1e3),
            format!(
                "{:.2}",
                worst(&|x| x.arm_speed_ratio.max(x.pos_speed_ratio))
            ),
            format!("{:.1}", t_b - t_a),
        ]);
    }
    let cycle = run.steps.last().map_or(0.0, |x| x.t);
    let all_ok = weld_steps(run).filter(|x| x.problem.is_empty()).count();
    let all = weld_steps(run).count();
    rows.push(vec![
        "cell (all seams + repositioning)".into(),
        format!(
            "{:.1}",
            s.seams.iter().map(|x| x.length()).sum::<f64>() * 1e3
        ),
        format!("{:.1}", 100.0 * all_ok as f64 / all.max(1) as f64),
        String::new(),
        String::new(),
        String::new(),
        String::new(),
        format!(
            "{:.3}",
            run.steps
                .iter()
                .map(|x| x.clearance)
                .fold(f64::INFINITY, f64::min)
                * 1e3
        ),
        String::new(),
        format!("{cycle:.1}"),
    ]);
    rows
}
/// The summary's notes: the scene and the coordination, the mid-step errors, the infeasible
/// sections.
fn summary_notes(s: &Setup, p: &WeldingParams, run: &Run) -> Vec<String> {
    let mut notes = vec![format!(
        "Scene `{SCENE}` (effects: kinematics, joint limits, collision {}). Coordination per step: positioner from the downhand condition (seam normal up; tilt scan + golden section, table angle in closed form), then the arm's analytic IK over torch rolls (near the previous roll first), the collision-free solution nearest the previous step kept (branch continuity). Targets: travel (push) angle {:.0}°, work angle along the joint's bisector, standoff {:.0} mm, downhand tolerance {:.0}°; speed limits arm {:?}°/s, positioner {:?}°/s. See docs/studies.md.",
        match p.mode {
            Mode::BBox => "bbox",
            Mode::Polygon => "polygon",
            Mode::Exact => "exact",
        },
        p.travel_angle.to_degrees(),
        p.standoff_m * 1e3,
        p.downhand_tol.to_degrees(),
        p.arm_speed.map(|v| v.to_degrees().round()),
        p.positioner_speed.map(|v| v.to_degrees().round())
    )];
    notes.push(format!(
        "Between steps (joint interpolation, checked at mid-step): worst downhand error {:.3}°, worst tip error {:.3} mm.",
        run.mid_downhand.to_degrees(),
        run.mid_tip * 1e3
    ));
    let secs = sections(s, run);
    if secs.is_empty() {
        notes.push("Every step of every seam can be welded downhand as asked.".into());
    }
    for (seam, a, b, why) in secs {
        notes.push(format!("Infeasible: {seam} seam {a:.1}–{b:.1} %: {why}."));
    }
    notes
}
/// The summary's plots against time: torch and downhand errors, joint values, clearance,
/// joint speed against the limits.
fn summary_plots(s: &Setup, run: &Run) -> Vec<robosim_report::Plot> {
    use robosim_report::{Plot, Series};
    let series = |label: &str, f: &dyn Fn(&Step) -> f64| Series {
        label: label.into(),
        points: weld_steps(run).map(|st| (st.t, f(st))).collect(),
    };
    let mut joints = Vec::new();
    for (j, n) in s.arm.link_names.iter().enumerate() {
        joints.push(Series {
            label: format!("arm {n}"),
            points: run
                .steps
                .iter()
                .map(|st| (st.t, st.q_arm[j].to_degrees()))
                .collect(),
        });
    }
    for (j, n) in s.positioner.link_names.iter().enumerate() {
        joints.push(Series {
            label: format!("positioner {n}"),
            points: run
                .steps
                .iter()
                .map(|st| (st.t, st.q_pos[j].to_degrees()))
                .collect(),
        });
    }
    vec![
        Plot {
            title: "Torch angle and downhand errors (welding steps)".into(),
            x_label: "t (s)".into(),
            y_label: "error (deg)".into(),
            series: vec![
                series("downhand", &|st| st.downhand_err.to_degrees()),
                series("work angle", &|st| st.work_err.to_degrees()),
                series("travel angle", &|st| st.travel_err.to_degrees()),
            ],
            ..Plot::default()
        },
        Plot {
            title: "Joint values".into(),
            x_label: "t (s)".into(),
            y_label: "angle (deg)".into(),
            series: joints,
            ..Plot::default()
        },
        Plot {
            title: "Clearance arm × positioner and workpiece".into(),
            x_label: "t (s)".into(),
            y_label: "distance (mm)".into(),
            series: vec![Series {
                label: "minimum".into(),
                points: run
                    .steps
                    .iter()
                    .map(|st| (st.t, st.clearance.min(1.0) * 1e3))
                    .collect(),
            }],
            ..Plot::default()
        },
        Plot {
            title: "Joint speed against the limits".into(),
            x_label: "t (s)".into(),
            y_label: "max |q̇|/limit".into(),
            series: vec![
                series("arm", &|st| st.arm_speed_ratio),
                series("positioner", &|st| st.pos_speed_ratio),
            ],
            ..Plot::default()
        },
    ]
}

/// "What accuracy costs in time": the study at each of `steps` (s) in three collision modes,
/// and in exact mode with a coarse positioner tolerance; written as
/// `welding_accuracy.{md,csv,png}` (`robosim study welding` uses 1, 0.5, 0.25, 0.1 s).
pub fn accuracy(p: &WeldingParams, dir: &Path, steps: &[f64]) -> Result<robosim_report::Report> {
    use robosim_report::{Plot, Report, Series, Table};
    let s = setup(p)?;
    let mut rows = Vec::new();
    let mut err_pts: Vec<(String, f64, f64)> = Vec::new();
    let mut time_pts: Vec<(String, f64, f64)> = Vec::new();
    for (mode, tol) in [
        (Mode::Exact, p.positioner_tol),
        (Mode::Polygon, p.positioner_tol),
        (Mode::BBox, p.positioner_tol),
        (Mode::Exact, 1e-2),
    ] {
        let label = format!(
            "{} tol {tol:.0e}",
            match mode {
                Mode::BBox => "bbox",
                Mode::Polygon => "polygon",
                Mode::Exact => "exact",
            }
        );
        for &h in steps {
            let q = WeldingParams {
                step_s: h,
                mode,
                positioner_tol: tol,
                frames: 0,
                ..p.clone()
            };
            let r = simulate(&s, &q)?;
            let worst_dh = weld_steps(&r)
                .filter(|x| x.problem.is_empty())
                .map(|x| x.downhand_err)
                .fold(0.0, f64::max);
            let min_cl = r
                .steps
                .iter()
                .map(|x| x.clearance)
                .fold(f64::INFINITY, f64::min);
            let ok = weld_steps(&r).filter(|x| x.problem.is_empty()).count();
            let all = weld_steps(&r).count();
            err_pts.push((label.clone(), h, r.mid_downhand.to_degrees().max(1e-9)));
            time_pts.push((label.clone(), h, r.wall_s * 1e3));
            rows.push(vec![
                label.clone(),
                format!("{h}"),
                format!("{}", r.steps.len()),
                format!("{:.2e}", worst_dh.to_degrees()),
                format!("{:.3}", r.mid_downhand.to_degrees()),
                format!("{:.3}", r.mid_tip * 1e3),
                format!("{:.2}", min_cl * 1e3),
                format!("{:.1}", 100.0 * ok as f64 / all.max(1) as f64),
                format!("{:.0}", r.wall_s * 1e3),
            ]);
        }
    }
    let group = |pts: &[(String, f64, f64)]| {
        let mut labels: Vec<String> = pts.iter().map(|p| p.0.clone()).collect();
        labels.dedup();
        labels
            .into_iter()
            .map(|l| Series {
                label: l.clone(),
                points: pts
                    .iter()
                    .filter(|p| p.0 == l)
                    .map(|p| (p.1, p.2))
                    .collect(),
            })
            .collect::<Vec<_>>()
    };
    let report = Report {
        name: "welding_accuracy".into(),
        title: "Downhand welding study: what accuracy costs in time".into(),
        notes: vec![
            "Each row is the whole study at one step, collision mode and positioner-solve tolerance. At the steps the solve is exact to its tolerance; between steps the joints are interpolated, so the mid-step downhand and tip errors grow with the step — what a controller sampling at that step would weld. bbox and polygon give no separation distance: their clearance is the bounding-sphere lower bound when clear (0 for any contact).".into(),
        ],
        table: Table {
            columns: vec![
                "mode / positioner tol".into(),
                "step (s)".into(),
                "steps".into(),
                "worst downhand error at steps (deg)".into(),
                "worst downhand error mid-step (deg)".into(),
                "worst tip error mid-step (mm)".into(),
                "min clearance (mm)".into(),
                "covered (%)".into(),
                "wall time (ms)".into(),
            ],
            rows,
        },
        plots: vec![
            Plot {
                title: "Mid-step downhand error against step".into(),
                x_label: "step (s)".into(),
                y_label: "error (deg)".into(),
                log_x: true,
                log_y: true,
                series: group(&err_pts),
            },
            Plot {
                title: "Wall time against step".into(),
                x_label: "step (s)".into(),
                y_label: "wall time (ms)".into(),
                log_x: true,
                log_y: true,
                series: group(&time_pts),
            },
        ],
    };
    robosim_report::write_report(dir, &report)?;
    Ok(report)
}

/// The robots' names and joints for tests and the CLI.
pub fn robots(s: &Setup) -> (&Robot, &Robot) {
    (&s.arm.robot, &s.positioner.robot)
}
