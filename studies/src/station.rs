//! `robosim study station`: the Space Station of seed chapter 4 in a circular orbit, its solar
//! arrays tracking the sun, its power and battery, and the mobile servicer swapping an orbital
//! replacement unit (ORU) while the arrays turn. The scene is the library's
//! `space_station_study`; the orbit, sun tracking and power are effects it declares (no other
//! scene pays for them). Model choices are stated in docs/studies.md and in the report notes.
//!
//! Per step (default 10 s): the orbit angle, the sun in the body frame (LVLH hold, [`orbit`]),
//! eclipse from the geometry; each array's gimbals set to face the sun (a 1-D closed form per
//! joint, the outboard's alpha angle refined by golden-section search to the tracking
//! tolerance); the servicer at its planned joint values; its clearance to every array part
//! (exact distances); where it is inside the keep-out distance the array is feathered — set to
//! the best-powered angle that clears — and the power lost is the difference; an angle must
//! also clear the servicer's planned sweep over the steps on either side of the sample, so the
//! keep-out holds between the samples too (checked there, [`between_samples`]). Power = Σ over the
//! panels of area × efficiency × flux × cos⁺(incidence), zero in eclipse; the battery integrates
//! power minus load with charge and discharge efficiencies.
//!
//! With `--attitude` ([`StationParams::attitude`], the scene's declared `attitude { … }`
//! effect, [`attitude`]): the station's attitude is integrated between the steps (held in
//! LVLH or a torque-equilibrium attitude by its CMGs, desaturated by thrusters) and the arrays
//! track the sun in the body frame of the actual attitude, their gimbals rate-limited.
//!
//! The loads (issue 38 items 3–4, [`loads`]): the station's consumers with priorities (the
//! ECLSS subsystems of seed §4.3, the base load, the servicer) and experiments, served each
//! interval through the battery's ledger (produced = served + shunted + Δstored + losses); the
//! scheduler ([`scheduler`], `--scheduler on`: `station_power.clp` in the CLIPS engine) sheds,
//! reduces, starts and moves them from the energy it predicts over the coming orbit, the
//! predicted desaturations and the docking events; an ECLSS fault ([`faults`], `--fault`)
//! rings alarms that `eclss_guard.clp` diagnoses and repairs, its consumer's demand changing
//! meanwhile. Every decision is recorded with its rule and reason.
//!
//! Entry points: [`StationParams`], [`run`], [`simulate`].

pub mod attitude;
pub mod faults;
pub mod loads;
pub mod oru_plan;
pub mod power_report;
pub mod scheduler;

use crate::common::{self, Body, Csv, Posed};
use crate::{Result, StudyError, bail, say};
use nalgebra::{Isometry3, Point3, Vector3};
use robosim_collision::Mode;
use robosim_collision::robot::isometry_from_matrix;
use robosim_library::{Params, SceneModel};
use robosim_simulator::orbit::Orbit;
use robosim_simulator::power::{self, Battery, SolarArray};
use std::path::Path;

/// The library scene of the study.
pub const SCENE: &str = "space_station_study";
pub use robosim_simulator::power::SOLAR_FLUX;

/// The default docking event, [start, end] s (assumed: a visiting vehicle's final approach
/// and capture, 40 min in the fifth orbit).
pub const DOCKING: [f64; 2] = [24_000.0, 26_400.0];

/// The study's parameters (defaults in [`StationParams::default`], stated in docs/studies.md).
#[derive(Debug, Clone, PartialEq)]
pub struct StationParams {
    /// Orbit altitude, m (None: the scene's declared `orbit` effect, 400 km).
    pub altitude_m: Option<f64>,
    /// Beta angle, rad (None: the scene's, 20°).
    pub beta_rad: Option<f64>,
    /// Step, s.
    pub step_s: f64,
    /// Length of the run in orbits (≥ 1 for the command; tests use less).
    pub orbits: f64,
    /// Orbit angle at t = 0, rad from orbit noon.
    pub theta0: f64,
    /// Keep-out distance between the servicer and an array, m.
    pub keep_out_m: f64,
    /// Tracking tolerance of the 2-axis search, rad.
    pub tracking_tol: f64,
    /// Collision mode of the clearance checks.
    pub mode: Mode,
    /// Battery: usable capacity (J), initial state of charge (0–1), charge and discharge
    /// efficiencies.
    pub battery_j: f64,
    pub soc0: f64,
    pub charge_eff: f64,
    pub discharge_eff: f64,
    /// The station's base load (avionics, communications, thermal control: vital), W; the
    /// ECLSS subsystems, the servicer and the experiments draw beside it ([`loads`]).
    pub load_w: f64,
    /// Whether `station_power.clp` schedules the loads ([`scheduler::Scheduling`]; default on
    /// when this build has CLIPS).
    pub scheduling: scheduler::Scheduling,
    /// The experiments asked for ([`robosim_simulator::consumers::default_experiments`]).
    pub experiments: Vec<robosim_simulator::consumers::Experiment>,
    /// Docking events, [start, end] s (seed §4.2 constraint 2).
    pub dockings: Vec<[f64; 2]>,
    /// The battery reserve the scheduler keeps over the coming orbit, and the margin above it
    /// before anything shed is restored, shares of the capacity.
    pub reserve: f64,
    pub margin: f64,
    /// An ECLSS fault injected ([`faults::FaultSpec`]), or the array ORU's
    /// ([`oru_plan::FAULT`]: the swap is then planned by rules, [`oru_plan`]).
    pub fault: Option<faults::FaultSpec>,
    /// Obstacles the planned swap's steps are checked against ([`oru_plan::Obstacle`]).
    pub oru_obstacles: Vec<oru_plan::Obstacle>,
    /// With the scheduler on, [`run`] also runs the same study with it off and reports what
    /// is lost without it.
    pub compare_off: bool,
    /// When the servicer task starts, s.
    pub task_start_s: f64,
    /// Frames to render headless (0: none).
    pub frames: usize,
    /// Integrate the station's attitude (the scene's `attitude` effect) and track the sun in
    /// its actual body frame.
    pub attitude: bool,
    /// The attitude integration's largest substep, s.
    pub attitude_step_s: f64,
}

impl Default for StationParams {
    fn default() -> Self {
        let b = Battery::default();
        StationParams {
            altitude_m: None,
            beta_rad: None,
            step_s: 10.0,
            orbits: 1.0,
            theta0: 0.0,
            keep_out_m: 1.0,
            tracking_tol: 1e-4,
            mode: Mode::Exact,
            battery_j: b.capacity_j,
            soc0: b.soc,
            charge_eff: b.charge_eff,
            discharge_eff: b.discharge_eff,
            load_w: b.load_w,
            scheduling: scheduler::Scheduling::default_for_build(),
            experiments: robosim_simulator::consumers::default_experiments(),
            dockings: vec![DOCKING],
            reserve: 0.25,
            margin: 0.05,
            fault: None,
            oru_obstacles: Vec::new(),
            compare_off: true,
            task_start_s: 300.0,
            frames: 12,
            attitude: false,
            attitude_step_s: 1.0,
        }
    }
}

impl StationParams {
    /// Refuses what has no meaning, naming it.
    pub fn check(&self) -> Result<()> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !pos(self.step_s) {
            bail!("step {} s: expected a positive finite step", self.step_s);
        }
        if !pos(self.orbits) || self.orbits > 100.0 {
            bail!("orbits {}: expected a number in (0, 100]", self.orbits);
        }
        if !self.theta0.is_finite() {
            bail!("start angle {}: expected a finite angle", self.theta0);
        }
        if !(self.keep_out_m.is_finite() && self.keep_out_m >= 0.0) {
            bail!(
                "keep-out {} m: expected a finite distance ≥ 0",
                self.keep_out_m
            );
        }
        if !pos(self.tracking_tol) {
            bail!(
                "tracking tolerance {}: expected a positive angle",
                self.tracking_tol
            );
        }
        if !pos(self.battery_j) || !(0.0..=1.0).contains(&self.soc0) {
            bail!(
                "battery {} J at state of charge {}: expected a positive capacity and a charge in [0, 1]",
                self.battery_j,
                self.soc0
            );
        }
        for (n, e) in [
            ("charge", self.charge_eff),
            ("discharge", self.discharge_eff),
        ] {
            if !(e > 0.0 && e <= 1.0) {
                bail!("{n} efficiency {e}: expected a value in (0, 1]");
            }
        }
        if !(self.load_w.is_finite() && self.load_w >= 0.0) {
            bail!("load {} W: expected a finite power ≥ 0", self.load_w);
        }
        if !((0.0..1.0).contains(&self.reserve) && (0.0..1.0).contains(&self.margin)) {
            bail!(
                "reserve {} and margin {}: expected shares of the capacity in [0, 1)",
                self.reserve,
                self.margin
            );
        }
        for d in &self.dockings {
            if !(d[0].is_finite() && d[1].is_finite() && d[0] < d[1]) {
                bail!(
                    "docking {} to {} s: expected a finite start before its end",
                    d[0],
                    d[1]
                );
            }
        }
        for e in &self.experiments {
            let ok = e.power_w.is_finite()
                && e.power_w >= 0.0
                && e.duration_s.is_finite()
                && e.duration_s > 0.0
                && e.every_s.is_finite()
                && e.every_s > 0.0
                && e.first_s.is_finite()
                && e.first_s >= 0.0;
            if !ok {
                bail!(
                    "experiment {}: expected a power ≥ 0, a positive duration and period, a start ≥ 0",
                    e.name
                );
            }
        }
        if self.attitude && !(pos(self.attitude_step_s) && self.attitude_step_s <= self.step_s) {
            bail!(
                "attitude substep {} s: expected a positive step no longer than the study's {} s",
                self.attitude_step_s,
                self.step_s
            );
        }
        if !(self.task_start_s.is_finite() && self.task_start_s >= 0.0) {
            bail!("task start {} s: expected a time ≥ 0", self.task_start_s);
        }
        if let Some(h) = self.altitude_m
            && !(h.is_finite() && h > 0.0)
        {
            bail!("altitude {h} m: expected a positive altitude (above 100 km for an orbit)");
        }
        if let Some(b) = self.beta_rad
            && !(b.is_finite() && b.abs() <= std::f64::consts::FRAC_PI_2)
        {
            bail!(
                "beta {} deg: expected an angle in [-90, 90] deg",
                b.to_degrees()
            );
        }
        Ok(())
    }
}

/// A solar array: a placed robot (`body`) whose link carries the cell panels.
pub struct Array {
    pub body: usize,
    pub cells: SolarArray,
}

/// The study set up from the scene: bodies, arrays, the servicer, fixed structure, orbit.
pub struct Setup {
    pub scene: SceneModel,
    pub bodies: Vec<Body>,
    pub arrays: Vec<Array>,
    pub servicer: usize,
    pub fixed: Vec<common::Part>,
    pub orbit: Orbit,
    pub efficiency: f64,
    pub oru: OruSetup,
    /// The attitude's model inputs (with `--attitude`).
    pub attitude: Option<attitude::AttitudeSetup>,
}

/// The two ORUs of the swap the scene declares (`oru_swap`): the plan's view of them
/// ([`Swap`]: the failed one on an array's link, the spare on the truss) and their boxes, taken
/// out of the bodies' and the fixed structure's parts: where they are is the swap's state
/// ([`OruState`]), and they are checked for clearance wherever they are.
pub struct OruSetup {
    /// The boxes of the failed ORU and of the spare (named so), their offsets given in the
    /// ORU's own frame (the grapple fixture: the top face's centre, z out of the box).
    pub parts: [common::Part; 2],
    /// The array (index into `Setup::arrays`) carrying the failed ORU.
    pub array: usize,
    /// The plan's model of the swap (shared with the simulator daemon's swap stage).
    pub swap: Swap,
}

pub use robosim_simulator::swap::{
    GRAPPLE_M, Held, OruEvent, OruState, Plan, STOW_OFFSET, Swap, Waypoint, servicer_at,
    servicer_speed,
};

/// Finds the ORUs of the scene's declared swap ([`Swap::from_scene`]) and takes them out of
/// `bodies` and `fixed`.
fn oru_setup(
    scene: &SceneModel,
    bodies: &mut [Body],
    arrays: &[Array],
    fixed: &mut Vec<common::Part>,
) -> Result<OruSetup> {
    let Some(fx) = &scene.effects.oru_swap else {
        bail!("{SCENE} declares no oru_swap effect");
    };
    let swap = Swap::from_scene(&scene.parts(), fx).map_err(StudyError::from)?;
    let Some(ai) = arrays.iter().position(|a| a.body == swap.array) else {
        bail!(
            "{}: the robot carrying the failed ORU is not a solar array",
            scene.robots[swap.array].name
        );
    };
    let body = &mut bodies[swap.array];
    let name = &swap.failed_part;
    let k = body
        .parts
        .iter()
        .position(|p| &p.name == name && p.link == swap.link)
        .ok_or_else(|| StudyError::Message(format!("{}: ORU part {name} not found", body.name)))?;
    let mut failed = body.parts.remove(k);
    failed.offset = swap.mount.inverse() * failed.offset;
    failed.link = 0;
    failed.name = "failed ORU".into();
    let prefix = format!("{}/", fx.spare);
    let Some(k) = fixed.iter().position(|p| p.name.starts_with(&prefix)) else {
        bail!("{SCENE}: the spare ORU is not among the fixed parts");
    };
    let mut spare_part = fixed.remove(k);
    spare_part.offset = swap.spare.inverse() * spare_part.offset;
    spare_part.name = "spare ORU".into();
    Ok(OruSetup {
        parts: [failed, spare_part],
        array: ai,
        swap,
    })
}

/// Builds the setup: the scene evaluated with the orbit parameters, its arrays found by their
/// panels (box parts named `panel…` or `blanket…`: area = the two large sides, normal = the
/// thin axis).
pub fn setup(p: &StationParams) -> Result<Setup> {
    p.check()?;
    let mut params = Params::new();
    if let Some(h) = p.altitude_m {
        params = params.si("altitude", h);
    }
    if let Some(b) = p.beta_rad {
        params = params.si("beta", b);
    }
    let (_lib, scene) = common::scene(SCENE, &params)?;
    let fx = &scene.effects;
    let Some(o) = fx.orbit else {
        bail!("{SCENE} declares no orbit effect");
    };
    if !fx.sun_tracking {
        bail!("{SCENE} does not declare sun_tracking");
    }
    let Some(power) = fx.power else {
        bail!("{SCENE} declares no power effect");
    };
    let orbit = Orbit::new(o.altitude_m, o.beta_rad)?;
    let bodies: Vec<Body> = scene.robots.iter().map(Body::of).collect::<Result<_>>()?;
    let mut arrays = Vec::new();
    for (i, (b, placed)) in bodies.iter().zip(&scene.robots).enumerate() {
        if let Some(cells) = power::solar_array(&placed.model.box_parts()) {
            if cells.link == 0 {
                bail!("array {}: its panels are fixed to the base", b.name);
            }
            arrays.push(Array { body: i, cells });
        }
    }
    if arrays.is_empty() {
        bail!("{SCENE} has no solar arrays (parts named panel… or blanket…)");
    }
    let mut fixed = common::fixed_parts(&scene)?;
    let mut bodies = bodies;
    let oru = oru_setup(&scene, &mut bodies, &arrays, &mut fixed)?;
    let servicer = oru.swap.servicer;
    let mut s = Setup {
        scene,
        bodies,
        arrays,
        servicer,
        fixed,
        orbit,
        efficiency: power.efficiency,
        oru,
        attitude: None,
    };
    if p.attitude {
        s.attitude = Some(attitude::setup(&s)?);
    }
    Ok(s)
}

/// The cell normal of array `a` in the body frame at `q`.
fn normal_at(s: &Setup, a: &Array, q: &[f64]) -> Vector3<f64> {
    a.cells.normal_at(&s.bodies[a.body].robot, q)
}

use robosim_simulator::power::wrap;

/// Sun tracking for one array ([`power::track`]): gimbal angles facing the sun, and the cos
/// of the incidence.
pub fn track(s: &Setup, a: &Array, prev: &[f64], sun: &Vector3<f64>, tol: f64) -> (Vec<f64>, f64) {
    power::track(&s.bodies[a.body].robot, &a.cells, prev, sun, tol)
}

/// The sites of the swap (body frame, m): the failed ORU's frame with its array parked at the
/// service angle, the spare's, and where the failed one is stowed ([`Swap::sites`]).
pub fn sites(s: &Setup) -> [Point3<f64>; 3] {
    s.oru.swap.sites()
}

/// The servicer's waypoints ([`Swap::task`]).
pub fn task(s: &Setup) -> Result<Vec<Waypoint>> {
    s.oru.swap.task().map_err(StudyError::from)
}

/// The task as a timed [`Plan`] starting at `start` (s) ([`Swap::schedule`]).
pub fn schedule(s: &Setup, start: f64) -> Result<Plan> {
    s.oru.swap.schedule(start).map_err(StudyError::from)
}

/// The swap's state at `t` ([`Swap::state`]).
pub fn oru_state(s: &Setup, plan: &Plan, t: f64) -> OruState {
    s.oru.swap.state(plan, t)
}

/// The world frame of an ORU held as `h` ([`Swap::frame`]).
pub fn oru_frame(s: &Setup, h: Held, q_array: &[f64], q_servicer: &[f64]) -> Isometry3<f64> {
    s.oru.swap.frame(h, q_array, q_servicer)
}

/// Where the servicer let go of the spare against where its mount is (m): the distance of the
/// spare's frame in the effector just before it is bolted from the mount's frame with the array
/// parked. `None` when the run ends before the spare is bolted.
pub fn install_error(s: &Setup, run: &Run) -> Option<f64> {
    let plan = Plan {
        points: run.schedule.clone(),
        events: run.events.clone(),
    };
    let t_end = run.steps.last()?.t;
    let (te, _) = run
        .events
        .iter()
        .find(|(t, e)| *e == OruEvent::InstallSpare && *t <= t_end)?;
    let before = oru_state(s, &plan, te - 1e-6);
    let sq = servicer_at(&plan.points, *te).0;
    let held = oru_frame(s, before.spare, &s.oru.swap.service_q, &sq);
    let mount = oru_frame(s, Held::OnArray, &s.oru.swap.service_q, &sq);
    Some((held.translation.vector - mount.translation.vector).norm())
}

/// The ORU box posed at ORU frame `w`.
fn posed_oru<'a>(part: &'a common::Part, w: &Isometry3<f64>) -> Posed<'a> {
    let pose = w * part.offset;
    Posed {
        part,
        pose,
        centre: pose * part.centre,
    }
}

/// One step's record.
#[derive(Debug, Clone)]
pub struct Step {
    pub t: f64,
    pub theta: f64,
    pub sun: Vector3<f64>,
    pub eclipse: bool,
    /// Per array: joint values, cos incidence, feathered.
    pub arrays: Vec<(Vec<f64>, f64, bool)>,
    pub power_w: f64,
    pub tracked_power_w: f64,
    pub soc: f64,
    pub servicer_q: Vec<f64>,
    pub activity: &'static str,
    /// Smallest servicer × array distance, m, and the pair.
    pub clearance_arrays: f64,
    pub clearance_pair: (String, String),
    /// Smallest servicer × fixed structure distance, m, and the pair.
    pub clearance_structure: f64,
    pub structure_pair: (String, String),
    /// The servicer within the keep-out of an array even feathered (a contact if ≤ 0).
    pub blocked: bool,
    /// Between the previous step and this one (servicer and arrays interpolated in joint
    /// space, checked at [`between_samples`] points): the smallest servicer × array distance,
    /// m, and the pair (∞ at the first step).
    pub between_clearance: f64,
    pub between_pair: (String, String),
    /// Where the ORUs are (the swap's state) and their frames' positions (body frame, m):
    /// failed, spare.
    pub oru: OruState,
    pub oru_at: [Point3<f64>; 2],
    /// The array carrying the failed ORU is parked at its service angle for the servicer
    /// (no keep-out: the servicer works on it); the clearance servicer (with what it carries)
    /// × that array (with the ORU on it), m — ∞ when not parked.
    pub clearance_serviced: f64,
    /// The attitude at this step (with `--attitude`).
    pub attitude: Option<attitude::AttStep>,
    /// The loads from this step to the next: demanded, served, modes, the energy's flows.
    pub loads: loads::LoadStep,
    /// The desaturation window the scheduler was given at this step ([start, end] s).
    pub desat_window: Option<(f64, f64)>,
}

/// A run's outcome.
#[derive(Debug, Clone)]
pub struct Run {
    pub steps: Vec<Step>,
    pub period_s: f64,
    pub eclipses: Vec<[f64; 2]>,
    pub schedule: Vec<(f64, Vec<f64>, &'static str)>,
    pub events: Vec<(f64, OruEvent)>,
    /// Energy delivered by the arrays, J, and energy lost to feathering and to parking the
    /// serviced array, J.
    pub energy_j: f64,
    pub lost_j: f64,
    /// Load not served because the battery was empty, J.
    pub unserved_j: f64,
    pub wall_s: f64,
    /// The attitude over the run (with `--attitude`).
    pub attitude: Option<attitude::AttRun>,
    /// The loads at the end (names, experiments' runs) and the energy's totals.
    pub loads: loads::Loads,
    pub totals: loads::Totals,
    /// Every decision of the rules, in order.
    pub decisions: Vec<scheduler::Decision>,
    pub scheduling: scheduler::Scheduling,
    /// Whether a rule engine ran (the loads scheduled, or a fault handled).
    pub rules_ran: bool,
    /// The injected fault at the end (its diagnoses, when it was isolated and replaced).
    pub fault: Option<faults::EclssFault>,
    /// The desaturation windows the scheduler was given, as first predicted: (start, end) s.
    pub predicted_windows: Vec<(f64, f64)>,
    /// The swap planned by rules (with `--fault array_oru@T`, [`oru_plan`]).
    pub swap: Option<oru_plan::SwapRun>,
}

/// Clearance of the servicer parts (with what it carries) to array `ai` at `q`, with the ORUs
/// that `oru` has on its mount.
fn array_clearance(
    s: &Setup,
    ai: usize,
    q: &[f64],
    servicer: &[Posed<'_>],
    oru: &OruState,
    mode: Mode,
) -> Option<common::Clearance> {
    let b = &s.bodies[s.arrays[ai].body];
    let frames = b.frames(q);
    let mut posed = b.posed(&frames);
    if ai == s.oru.array {
        let mount = isometry_from_matrix(&frames[s.oru.swap.link]) * s.oru.swap.mount;
        for (h, part) in [oru.failed, oru.spare].iter().zip(&s.oru.parts) {
            if *h == Held::OnArray {
                posed.push(posed_oru(part, &mount));
            }
        }
    }
    common::clearance(servicer, &posed, mode)
}

/// The servicer's parts at `q` with the ORUs it carries.
fn servicer_posed<'a>(s: &'a Setup, q: &[f64], oru: &OruState) -> Vec<Posed<'a>> {
    let sb = &s.bodies[s.servicer];
    let mut posed = sb.posed(&sb.frames(q));
    for (h, part) in [oru.failed, oru.spare].iter().zip(&s.oru.parts) {
        if let Held::Carried(_) = h {
            posed.push(posed_oru(part, &oru_frame(s, *h, &[], q)));
        }
    }
    posed
}

/// Runs the study's time loop.
pub fn simulate(s: &Setup, p: &StationParams) -> Result<Run> {
    let t0 = std::time::Instant::now();
    let mut sim = Sim::start(s, p)?;
    for k in 0..=sim.n {
        sim.step(k)?;
    }
    Ok(sim.finish(t0))
}

/// The time loop's state, carried from step to step.
struct Sim<'s> {
    s: &'s Setup,
    p: &'s StationParams,
    period: f64,
    t_end: f64,
    /// The last step's index (steps 0..=n).
    n: usize,
    /// How far ahead the scheduler looks, s (one orbit).
    horizon: f64,
    /// The swap's planner (after an array ORU fault; else the declared timetable).
    planner: Option<oru_plan::Planner>,
    plan: Plan,
    /// Each array's joint values at the previous step.
    prev: Vec<Vec<f64>>,
    /// The fixed structure, posed.
    fixed: Vec<Posed<'s>>,
    battery: Battery,
    /// Energy delivered, lost to feathering and parking, and not served, J.
    energy: f64,
    lost: f64,
    unserved: f64,
    loads: loads::Loads,
    /// The servicer's consumer (index into the loads' consumers).
    servicer_load: Option<usize>,
    rules: scheduler::Scheduler,
    totals: loads::Totals,
    /// The eclipses to the end of the run and one horizon beyond.
    eclipses_ahead: Vec<[f64; 2]>,
    predicted_windows: Vec<(f64, f64)>,
    steps: Vec<Step>,
    /// The attitude (with `--attitude`).
    att: Option<attitude::Running>,
}

/// The sun at one step.
struct Light {
    /// The step's index and time, s.
    k: usize,
    t: f64,
    /// The sun in the body frame (of the actual attitude when it is integrated, else LVLH),
    /// and in the commanded attitude's.
    sun: Vector3<f64>,
    sun_cmd: Vector3<f64>,
    eclipse: bool,
}

/// The servicer at one step: its joint values on the plan, where the ORUs are, its parts posed.
struct ServicerNow<'s> {
    q: Vec<f64>,
    activity: &'static str,
    oru: OruState,
    posed: Vec<Posed<'s>>,
}

/// The servicer's planned sweep around a step: (where the ORUs are, its parts posed) at each
/// of [`sweep_times`].
type Sweep<'s> = Vec<(OruState, Vec<Posed<'s>>)>;

/// The arrays at one step: the angles chosen and what they give.
struct ArraysNow {
    /// Per array: joint values, cos incidence, feathered.
    arrays: Vec<(Vec<f64>, f64, bool)>,
    /// Delivered and tracked (the ideal's) power, W.
    power: f64,
    tracked: f64,
    /// Smallest servicer × array distance outside the serviced array, m, and the pair.
    clear_min: (f64, (String, String)),
    blocked: bool,
    /// The servicer × the parked serviced array, m (∞ when not parked).
    serviced: f64,
    /// Per array: delivered and expected power (W, the failed ORU's share), parked.
    observed: Vec<(f64, f64, bool)>,
    /// Power lost to the actual attitude and to the gimbals' rate, W.
    attitude_loss_w: f64,
    gimbal_loss_w: f64,
}

impl<'s> Sim<'s> {
    /// The state at t = 0: the swap's plan, the arrays at their initial angles, the battery,
    /// the loads and their scheduler (with the fault), the attitude.
    fn start(s: &'s Setup, p: &'s StationParams) -> Result<Sim<'s>> {
        let period = s.orbit.period_s();
        let t_end = p.orbits * period;
        let n = common::step_count(
            t_end / p.step_s,
            &format!(
                "the station study ({} orbit(s) of {:.0} s at a step of {} s)",
                p.orbits, period, p.step_s
            ),
        )?;
        // the swap: planned by rules after an array ORU fault, else the declared timetable
        let planner = oru_plan::Planner::new(s, p)?;
        let plan = match &planner {
            Some(_) => Plan {
                points: vec![(0.0, s.oru.swap.servicer_q0.clone(), "start, stowed")],
                events: Vec::new(),
            },
            None => schedule(s, p.task_start_s)?,
        };
        let prev: Vec<Vec<f64>> = s
            .arrays
            .iter()
            .map(|a| s.bodies[a.body].q0.clone())
            .collect();
        let battery = Battery {
            capacity_j: p.battery_j,
            soc: p.soc0,
            charge_eff: p.charge_eff,
            discharge_eff: p.discharge_eff,
            load_w: p.load_w,
        };
        // the loads, their scheduler and the fault (issue 38 items 3-4)
        let loads = loads::Loads::new(
            robosim_simulator::consumers::default_consumers(p.load_w),
            p.experiments.clone(),
        );
        let servicer_load = loads
            .consumers
            .iter()
            .position(|c| c.subsystem == "servicer");
        let fault = p
            .fault
            .as_ref()
            .filter(|f| !oru_plan::is_array_fault(f))
            .map(|f| faults::EclssFault::new(f, &loads.consumers))
            .transpose()?;
        let rules = scheduler::Scheduler::new(p.scheduling, fault)?;
        // the scheduler looks one orbit ahead
        let horizon = period;
        let eclipses_ahead = s
            .orbit
            .eclipse_intervals(p.theta0, t_end + horizon, p.step_s);
        // the attitude (declared effect, with --attitude): started in the configuration at t = 0
        let att = match &s.attitude {
            Some(a) => Some(attitude::Running::start(
                s,
                a,
                p,
                &body_qs(s, &prev, &servicer_at(&plan.points, 0.0).0),
            )?),
            None => None,
        };
        Ok(Sim {
            s,
            p,
            period,
            t_end,
            n,
            horizon,
            planner,
            plan,
            prev,
            fixed: common::pose_fixed(&s.fixed),
            battery,
            energy: 0.0,
            lost: 0.0,
            unserved: 0.0,
            loads,
            servicer_load,
            rules,
            totals: loads::Totals::default(),
            eclipses_ahead,
            predicted_windows: Vec::new(),
            steps: Vec::with_capacity(n + 1),
            att,
        })
    }

    /// Step `k`: the sun, the servicer, the arrays' angles, the energy over the step just
    /// ended, the attitude, the swap's planner, the loads' schedule; its record pushed.
    fn step(&mut self, k: usize) -> Result<()> {
        let (s, p) = (self.s, self.p);
        let t = (k as f64 * p.step_s).min(self.t_end);
        let theta = s.orbit.angle(p.theta0, t);
        let light = self.light(k, t, theta);
        let sv = self.servicer_now(t)?;
        let structure = self.structure_clearance(&sv);
        let sweep = self.servicer_sweep(k, t);
        let prev_arrays = self.prev.clone();
        let now = self.place_arrays(&light, &sv, &sweep);
        self.settle_step_ended(t);
        // the configuration of this step (arrays, servicer) for the attitude's next interval
        let att_step = match (self.att.as_mut(), &s.attitude) {
            (Some(r), Some(a)) => {
                let qs: Vec<Vec<f64>> = now.arrays.iter().map(|x| x.0.clone()).collect();
                r.reconfigure(s, a, &body_qs(s, &qs, &sv.q))?;
                Some(r.record(now.attitude_loss_w, now.gimbal_loss_w))
            }
            _ => None,
        };
        // the swap's planner: observes this step, its steps executed from the next
        if let Some(o) = self.planner.as_mut() {
            o.step(s, p, t, light.eclipse, &now.observed, &mut self.plan)?;
        }
        let desat_window =
            self.schedule_loads(t, now.power, light.eclipse, sv.activity, att_step.as_ref())?;
        let load_step = self.loads.record();
        let soc = self.battery.soc;
        // between the samples: the servicer may sweep more than the keep-out in one step
        let between = match self.steps.last() {
            Some(last) => {
                let q_now: Vec<Vec<f64>> = now.arrays.iter().map(|a| a.0.clone()).collect();
                between_clearance(s, p, &self.plan, last.t, t, &prev_arrays, &q_now)
            }
            None => (f64::INFINITY, Default::default()),
        };
        let q_oru_array = &now.arrays[s.oru.array].0;
        let ost = sv.oru;
        let oru_at = [ost.failed, ost.spare]
            .map(|h| Point3::from(oru_frame(s, h, q_oru_array, &sv.q).translation.vector));
        self.steps.push(Step {
            t,
            theta,
            sun: light.sun,
            eclipse: light.eclipse,
            oru: ost,
            oru_at,
            clearance_serviced: now.serviced,
            between_clearance: between.0,
            between_pair: between.1,
            arrays: now.arrays,
            power_w: now.power,
            tracked_power_w: now.tracked,
            soc,
            servicer_q: sv.q,
            activity: sv.activity,
            clearance_arrays: now.clear_min.0,
            clearance_pair: now.clear_min.1,
            clearance_structure: structure.as_ref().map_or(f64::INFINITY, |c| c.distance),
            structure_pair: structure.map(|c| (c.a, c.b)).unwrap_or_default(),
            blocked: now.blocked,
            attitude: att_step,
            loads: load_step,
            desat_window,
        });
        Ok(())
    }

    /// The sun at step `k` (time `t`, orbit angle `theta`): the attitude advanced to `t` first
    /// when it is integrated.
    fn light(&mut self, k: usize, t: f64, theta: f64) -> Light {
        let (s, p) = (self.s, self.p);
        // the sun in the body frame: of the actual attitude when it is integrated, else LVLH
        let (sun, sun_cmd) = match self.att.as_mut() {
            Some(r) => {
                r.advance(t, p.attitude_step_s);
                (r.model.sun_body(), r.model.sun_commanded(t))
            }
            None => {
                let sun = s.orbit.sun_body(theta);
                (sun, sun)
            }
        };
        Light {
            k,
            t,
            sun,
            sun_cmd,
            eclipse: s.orbit.eclipse_at(theta),
        }
    }

    /// The servicer at `t` on the plan (its joint values checked against its limits).
    fn servicer_now(&self, t: f64) -> Result<ServicerNow<'s>> {
        let s = self.s;
        let (sq, activity) = servicer_at(&self.plan.points, t);
        let sb = &s.bodies[s.servicer];
        sb.robot
            .check_q(&sq)
            .map_err(|e| StudyError::at(format!("servicer at t = {t} s"), e))?;
        let ost = oru_state(s, &self.plan, t);
        let sposed = servicer_posed(s, &sq, &ost);
        Ok(ServicerNow {
            q: sq,
            activity,
            oru: ost,
            posed: sposed,
        })
    }

    /// The servicer's clearance to the fixed structure with the ORUs set down on it.
    fn structure_clearance(&self, sv: &ServicerNow) -> Option<common::Clearance> {
        let mut fixed_now = self.fixed.clone();
        for (h, part) in [sv.oru.failed, sv.oru.spare].iter().zip(&self.s.oru.parts) {
            if let Held::Fixed(w) = h {
                fixed_now.push(posed_oru(part, w));
            }
        }
        common::clearance(&sv.posed, &fixed_now, self.p.mode)
    }

    /// The servicer's planned sweep over the steps on either side of step `k` (with what it
    /// carries then): an array angle chosen here must clear all of it, so that the motion
    /// between two samples — the servicer on its schedule, the array between two angles that
    /// each clear it — keeps the keep-out (the step is not a blind spot).
    fn servicer_sweep(&self, k: usize, t: f64) -> Sweep<'s> {
        let (s, p, n) = (self.s, self.p, self.n);
        let sched = &self.plan.points;
        let t_prev = k.checked_sub(1).map(|j| j as f64 * p.step_s);
        let t_next = (k < n).then(|| ((k + 1) as f64 * p.step_s).min(self.t_end));
        let sweep_states: Vec<(f64, OruState)> = sweep_times(s, p, sched, t, t_prev, t_next)
            .into_iter()
            .map(|tu| (tu, oru_state(s, &self.plan, tu)))
            .collect();
        sweep_states
            .iter()
            .map(|(tu, o)| (*o, servicer_posed(s, &servicer_at(sched, *tu).0, o)))
            .collect()
    }

    /// Each array's angles at this step: the serviced array parked, the others tracking the
    /// sun, feathered where the servicer comes within the keep-out (here or over its sweep),
    /// rate-limited in the actual attitude; what they deliver.
    fn place_arrays(&mut self, l: &Light, sv: &ServicerNow, sweep: &Sweep) -> ArraysNow {
        let (s, p) = (self.s, self.p);
        let mut now = ArraysNow {
            arrays: Vec::with_capacity(s.arrays.len()),
            power: 0.0,
            tracked: 0.0,
            clear_min: (f64::INFINITY, (String::new(), String::new())),
            blocked: false,
            serviced: f64::INFINITY,
            observed: Vec::with_capacity(s.arrays.len()),
            attitude_loss_w: 0.0,
            gimbal_loss_w: 0.0,
        };
        let (sun, eclipse) = (&l.sun, l.eclipse);
        for (ai, a) in s.arrays.iter().enumerate() {
            let share = self.planner.as_ref().map_or(1.0, |o| o.share(s, ai, l.t));
            let (q, c) = track(s, a, &self.prev[ai], sun, p.tracking_tol);
            let ideal = a.cells.power_w(s.efficiency, c);
            if sv.oru.parked && ai == s.oru.array {
                self.park_serviced(&mut now, l, sv, ai, share, ideal);
                continue;
            }
            let mut chosen = (q.clone(), c, false);
            let cl = array_clearance(s, ai, &q, &sv.posed, &sv.oru, p.mode);
            let mut cl_d = cl.as_ref().map_or(f64::INFINITY, |c| c.distance);
            let mut pair = cl.map(|c| (c.a, c.b)).unwrap_or_default();
            if cl_d < p.keep_out_m || !swept_clear(s, p, sweep, ai, &q) {
                match feather(s, p, ai, &q, sun, sv, sweep) {
                    Some((qq, cc, d2, pair2)) => {
                        cl_d = d2;
                        pair = pair2;
                        chosen = (qq, cc, true);
                    }
                    None => now.blocked = true,
                }
            }
            let mut ideal = ideal;
            if self.att.is_some() && !chosen.2 {
                // tracking in the actual attitude: the gimbals follow at their rate; what this
                // and the attitude cost is against the commanded attitude's ideal
                let dt = if l.k > 0 { p.step_s } else { f64::INFINITY };
                let qa = attitude::rate_limited(&self.prev[ai], &chosen.0, dt);
                let ca = normal_at(s, a, &qa).dot(sun);
                let (_, c_cmd) = track(s, a, &self.prev[ai], &l.sun_cmd, p.tracking_tol);
                chosen = (qa, ca, false);
                let reached = a.cells.power_w(s.efficiency, ca);
                if !eclipse {
                    now.attitude_loss_w += a.cells.power_w(s.efficiency, c_cmd) - reached;
                    now.gimbal_loss_w += ideal - reached;
                }
                ideal = reached;
            }
            let got = a.cells.power_w(s.efficiency, chosen.1);
            let w = if eclipse { 0.0 } else { got };
            now.observed.push((w * share, w, false));
            if !eclipse {
                now.power += got * share;
                now.tracked += ideal * share;
            }
            if cl_d < now.clear_min.0 {
                now.clear_min = (cl_d, pair);
            }
            self.prev[ai] = chosen.0.clone();
            now.arrays.push(chosen);
        }
        now
    }

    /// The serviced array `ai` parked for the servicer: no tracking, no keep-out (it is worked
    /// on), but its clearance is watched for a contact.
    fn park_serviced(
        &mut self,
        now: &mut ArraysNow,
        l: &Light,
        sv: &ServicerNow,
        ai: usize,
        share: f64,
        ideal: f64,
    ) {
        let (s, p) = (self.s, self.p);
        let a = &s.arrays[ai];
        let qs = s.oru.swap.service_q.clone();
        let cs = normal_at(s, a, &qs).dot(&l.sun);
        now.serviced = array_clearance(s, ai, &qs, &sv.posed, &sv.oru, p.mode)
            .map_or(f64::INFINITY, |c| c.distance);
        let w = if l.eclipse {
            0.0
        } else {
            a.cells.power_w(s.efficiency, cs)
        };
        now.observed.push((w * share, w, true));
        if !l.eclipse {
            now.power += w * share;
            now.tracked += ideal * share;
        }
        self.prev[ai] = qs.clone();
        now.arrays.push((qs, cs, false));
    }

    /// The battery, energy and loads over the step that ended at `t` (the previous step's
    /// power held over it), and the attitude's losses over it.
    fn settle_step_ended(&mut self, t: f64) {
        if self.steps.is_empty() {
            return;
        }
        let p = self.p;
        let dt = t - self.steps.last().map_or(0.0, |s: &Step| s.t);
        let last = self.steps.last().map_or(0.0, |s: &Step| s.power_w);
        let last_tracked = self.steps.last().map_or(0.0, |s: &Step| s.tracked_power_w);
        self.energy += last * dt;
        self.lost += (last_tracked - last) * dt;
        if let Some(prev_step) = self.steps.last_mut() {
            // a sensitive experiment running through a desaturation or a docking is disturbed
            let disturbed = prev_step.attitude.is_some_and(|a| a.dumping)
                || p.dockings
                    .iter()
                    .any(|d| d[0] <= prev_step.t && prev_step.t < d[1]);
            let flow = self.loads.serve(
                &mut prev_step.loads,
                &mut self.battery,
                last,
                dt,
                disturbed,
                &mut self.totals,
            );
            self.unserved += flow.unserved_j;
        }
        if let (Some(r), Some(la)) = (
            self.att.as_mut(),
            self.steps.last().and_then(|s: &Step| s.attitude),
        ) {
            r.run.lost_j += la.attitude_loss_w * dt;
            r.run.gimbal_lost_j += la.gimbal_loss_w * dt;
        }
    }

    /// The loads from `t` to the next step: asked for (the servicer drawing while it works),
    /// then scheduled by the rules from the energy forecast and the docking and predicted
    /// desaturation windows; the desaturation window given to them.
    fn schedule_loads(
        &mut self,
        t: f64,
        power: f64,
        eclipse: bool,
        activity: &'static str,
        att_step: Option<&attitude::AttStep>,
    ) -> Result<Option<(f64, f64)>> {
        let (s, p, horizon) = (self.s, self.p, self.horizon);
        self.loads.ask(t);
        if let Some(i) = self.servicer_load {
            let active = !matches!(activity, "waiting" | "done");
            let w = if active {
                self.loads.consumers[i].full_w
            } else {
                0.0
            };
            self.loads.full_w[i] = w;
            self.loads.reduced_w[i] = w;
        }
        let mut forecast = loads::Forecast::new(
            t,
            horizon,
            &self.eclipses_ahead,
            predicted_sun_w(&self.steps, power, eclipse, t, self.period),
        );
        if let Some(o) = self.planner.as_mut() {
            forecast = o.forecast(s, p, t, forecast);
        }
        let mut windows: Vec<(&'static str, f64, f64)> = p
            .dockings
            .iter()
            .filter(|d| d[1] > t && d[0] < t + horizon)
            .map(|d| ("docking", d[0], d[1]))
            .collect();
        let mut desat_window = None;
        if let (Some(r), Some(a)) = (self.att.as_ref(), att_step)
            && let Some(w) = attitude::predict_desaturation(&self.steps, a, r, t, self.period)
            && w.0 < t + horizon
        {
            desat_window = Some(w);
            windows.push(("desaturation", w.0, w.1));
            if self.predicted_windows.last().is_none_or(|l| w.0 > l.1) {
                self.predicted_windows.push(w);
            }
        }
        let battery = &self.battery;
        self.rules.step(
            &scheduler::PlanFacts {
                t,
                step_s: p.step_s,
                energy_j: battery.energy_j(),
                capacity_j: battery.capacity_j,
                charge_eff: battery.charge_eff,
                discharge_eff: battery.discharge_eff,
                reserve_j: p.reserve * battery.capacity_j,
                margin_j: p.margin * battery.capacity_j,
                forecast: &forecast,
                windows: &windows,
            },
            &mut self.loads,
        )?;
        Ok(desat_window)
    }

    /// The run's outcome: the steps, the rules' and the swap planner's decisions in time order.
    fn finish(self, t0: std::time::Instant) -> Run {
        let (s, p) = (self.s, self.p);
        let rules_ran = self.rules.has_engine();
        let (mut decisions, fault) = self.rules.finish();
        let swap = self.planner.map(oru_plan::Planner::finish);
        if let Some(r) = &swap {
            decisions.extend(r.decisions.iter().cloned());
            decisions.sort_by(|a, b| a.t.total_cmp(&b.t));
        }
        Run {
            steps: self.steps,
            period_s: self.period,
            eclipses: s.orbit.eclipse_intervals(p.theta0, self.t_end, p.step_s),
            schedule: self.plan.points.clone(),
            events: self.plan.events.clone(),
            energy_j: self.energy,
            lost_j: self.lost,
            unserved_j: self.unserved,
            wall_s: t0.elapsed().as_secs_f64(),
            attitude: self.att.map(attitude::Running::finish),
            loads: self.loads,
            totals: self.totals,
            decisions,
            scheduling: p.scheduling,
            rules_ran,
            fault,
            predicted_windows: self.predicted_windows,
            swap,
        }
    }
}

/// Whether array `ai` at `q` clears the keep-out over the servicer's whole `sweep` (where the
/// serviced array is parked then it is worked on: no keep-out, as between the steps).
fn swept_clear(s: &Setup, p: &StationParams, sweep: &Sweep, ai: usize, q: &[f64]) -> bool {
    sweep.iter().all(|(o, posed)| {
        // parked then: worked on, no keep-out (as between the steps)
        (o.parked && ai == s.oru.array)
            || array_clearance(s, ai, q, posed, o, p.mode)
                .is_none_or(|c| c.distance >= p.keep_out_m)
    })
}

/// Array `ai` feathered from its tracking angles `q`: the best-powered candidate angle (5° grid
/// on the panel joint, then 10° on both) within its limits that clears the keep-out here and
/// over the servicer's sweep — (angles, cos incidence, clearance m, pair), None when none does.
fn feather(
    s: &Setup,
    p: &StationParams,
    ai: usize,
    q: &[f64],
    sun: &Vector3<f64>,
    sv: &ServicerNow,
    sweep: &Sweep,
) -> Option<(Vec<f64>, f64, f64, (String, String))> {
    let a = &s.arrays[ai];
    let mut cands: Vec<(f64, Vec<f64>)> = Vec::new();
    let j = q.len() - 1;
    for k in 0..72 {
        let mut qq = q.to_vec();
        qq[j] = wrap(k as f64 * 5f64.to_radians());
        cands.push((normal_at(s, a, &qq).dot(sun), qq));
    }
    if q.len() > 1 {
        for k0 in 0..36 {
            for k1 in 0..36 {
                let mut qq = q.to_vec();
                qq[0] = wrap(k0 as f64 * 10f64.to_radians());
                qq[j] = wrap(k1 as f64 * 10f64.to_radians());
                cands.push((normal_at(s, a, &qq).dot(sun), qq));
            }
        }
    }
    cands.sort_by(|x, y| y.0.total_cmp(&x.0));
    for (cc, qq) in cands {
        let lim_ok = s.bodies[a.body].robot.outside_limits(&qq).is_none();
        if !lim_ok {
            continue;
        }
        let c2 = array_clearance(s, ai, &qq, &sv.posed, &sv.oru, p.mode);
        if c2.as_ref().is_none_or(|c2| c2.distance >= p.keep_out_m)
            && swept_clear(s, p, sweep, ai, &qq)
        {
            let (d2, pair2) = c2.map_or((f64::INFINITY, Default::default()), |c| {
                (c.distance, (c.a, c.b))
            });
            return Some((qq, cc, d2, pair2));
        }
    }
    None
}

/// The sunlit power the power model predicts: the mean delivered over the sunlit steps of the
/// last orbit and now (persistence), W; 0 before any sunlit step.
fn predicted_sun_w(steps: &[Step], now_w: f64, eclipse: bool, t: f64, period: f64) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for st in steps.iter().rev().take_while(|st| st.t >= t - period) {
        if !st.eclipse {
            sum += st.power_w;
            n += 1;
        }
    }
    if !eclipse {
        sum += now_w;
        n += 1;
    }
    if n > 0 { sum / n as f64 } else { 0.0 }
}

/// Every body's joint values: the arrays' `arrays` (in `Setup::arrays` order), the servicer's
/// `servicer`, the others' initial ones.
fn body_qs(s: &Setup, arrays: &[Vec<f64>], servicer: &[f64]) -> Vec<Vec<f64>> {
    s.bodies
        .iter()
        .enumerate()
        .map(|(bi, b)| {
            if bi == s.servicer {
                servicer.to_vec()
            } else if let Some(ai) = s.arrays.iter().position(|a| a.body == bi) {
                arrays[ai].clone()
            } else {
                b.q0.clone()
            }
        })
        .collect()
}

/// How many points inside a step of the servicer from `qa` to `qb` are checked: enough that
/// no link origin of the servicer moves more than half the keep-out between two checks (at
/// least one, the midpoint).
pub fn between_samples(s: &Setup, p: &StationParams, qa: &[f64], qb: &[f64]) -> usize {
    let sb = &s.bodies[s.servicer];
    let (fa, fb) = (sb.frames(qa), sb.frames(qb));
    let moved = fa
        .iter()
        .zip(&fb)
        .map(|(a, b)| (a.fixed_view::<3, 1>(0, 3) - b.fixed_view::<3, 1>(0, 3)).norm())
        .fold(0.0, f64::max);
    let h = (0.5 * p.keep_out_m).max(0.05);
    ((moved / h).ceil() as usize).clamp(1, 64)
}

/// The times of the servicer's sweep an array angle chosen at the sample `t` must clear: the
/// neighbouring samples `t_prev` and `t_next` (where there are) and the points between each of
/// them and `t` that [`between_samples`] takes — the same density as the between-step check.
fn sweep_times(
    s: &Setup,
    p: &StationParams,
    sched: &[(f64, Vec<f64>, &'static str)],
    t: f64,
    t_prev: Option<f64>,
    t_next: Option<f64>,
) -> Vec<f64> {
    let mut out = Vec::new();
    for other in [t_prev, t_next].into_iter().flatten() {
        let n = between_samples(s, p, &servicer_at(sched, t).0, &servicer_at(sched, other).0);
        out.extend((1..=n + 1).map(|k| t + (other - t) * k as f64 / (n + 1) as f64));
    }
    out
}

/// The smallest servicer × array distance strictly between two steps at `ta` and `tb`: the
/// servicer on its schedule, each array linearly (the short way round) from `qa` to `qb`.
fn between_clearance(
    s: &Setup,
    p: &StationParams,
    plan: &Plan,
    ta: f64,
    tb: f64,
    qa: &[Vec<f64>],
    qb: &[Vec<f64>],
) -> (f64, (String, String)) {
    let sched = &plan.points;
    let n = between_samples(s, p, &servicer_at(sched, ta).0, &servicer_at(sched, tb).0);
    let mut best = (f64::INFINITY, (String::new(), String::new()));
    for k in 1..=n {
        let u = k as f64 / (n + 1) as f64;
        let tu = ta + u * (tb - ta);
        let sq = servicer_at(sched, tu).0;
        let ost = oru_state(s, plan, tu);
        let posed = servicer_posed(s, &sq, &ost);
        for ai in 0..s.arrays.len() {
            if ost.parked && ai == s.oru.array {
                // worked on: no keep-out (its contacts are checked at the steps)
                continue;
            }
            let q: Vec<f64> = qa[ai]
                .iter()
                .zip(&qb[ai])
                .map(|(x, y)| x + u * wrap(y - x))
                .collect();
            if let Some(c) = array_clearance(s, ai, &q, &posed, &ost, p.mode)
                && c.distance < best.0
            {
                best = (c.distance, (c.a, c.b));
            }
        }
    }
    best
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::BBox => "bbox",
        Mode::Polygon => "polygon",
        Mode::Exact => "exact",
    }
}

/// Runs the study and writes its outputs into `dir`: `station.csv` (per step), trajectory
/// files per robot, `station_summary.{md,csv,png}`, `station_accuracy.{md,csv,png}` and
/// `frames/`. Progress and the summary go to `log`.
pub fn run(p: &StationParams, dir: &Path, log: &mut dyn std::io::Write) -> Result<Run> {
    let s = setup(p)?;
    std::fs::create_dir_all(dir).map_err(|e| StudyError::io(dir, e))?;
    say!(
        log,
        "station study: {} km, beta {:.1}°, period {:.1} min, closed-form eclipse {:.1} % of the orbit; step {} s over {} orbit(s)",
        s.orbit.altitude_m / 1e3,
        s.orbit.beta_rad.to_degrees(),
        s.orbit.period_s() / 60.0,
        100.0 * s.orbit.eclipse_fraction_closed_form(),
        p.step_s,
        p.orbits
    );
    let run = simulate(&s, p)?;
    write_station_csv(&s, p, &run, dir)?;
    write_trajectories(&s, p, &run, dir)?;
    // --- summary
    power_report::write_decisions(dir, &run)?;
    // the same run without the scheduler: what the rule base is worth
    let off = if p.scheduling == scheduler::Scheduling::On && p.compare_off {
        say!(log, "the same run with the scheduler off, for comparison");
        Some(simulate(
            &s,
            &StationParams {
                scheduling: scheduler::Scheduling::Off,
                frames: 0,
                ..p.clone()
            },
        )?)
    } else {
        None
    };
    if !run.rules_ran && !robosim_rules::BUILT_WITH_CLIPS {
        say!(
            log,
            "*** the station's energy scheduler (station_power.clp) did not run: {} ***",
            robosim_rules::NOT_BUILT
        );
    }
    let summary = summarise_with(&s, p, &run, off.as_ref());
    for line in &summary.notes {
        say!(log, "{line}");
    }
    robosim_report::write_report(dir, &summary)?;
    // --- frames
    if p.frames > 0 {
        // the robots' trajectories and the ORUs where the swap has them at each step
        let args = frame_args(&s, &run, dir, p.frames);
        robosim_display::app::cmd_render(&args)
            .map_err(|e| StudyError::Message(format!("frames: {}", e.0)))?;
        say!(log, "frames: {}", dir.join("frames").display());
    }
    say!(log, "wrote {}", dir.display());
    Ok(run)
}

/// `station.csv`: one row per step ([`station_columns`], [`station_row`]).
fn write_station_csv(s: &Setup, p: &StationParams, run: &Run, dir: &Path) -> Result<()> {
    let mut csv = Csv::create(&dir.join("station.csv"), &station_columns(s, run))?;
    for st in &run.steps {
        csv.row(&station_row(s, p, run, st))?;
    }
    csv.finish()?;
    Ok(())
}

/// The columns of `station.csv`: time, orbit and sun; each array's joints, incidence and
/// feathering; the servicer's joints; power, battery, clearances and the ORUs; the attitude's
/// (with `--attitude`); the loads' ([`power_report::columns`]).
fn station_columns(s: &Setup, run: &Run) -> Vec<String> {
    let mut cols: Vec<String> = [
        "t_s",
        "orbit_angle_deg",
        "sun_x",
        "sun_y",
        "sun_z",
        "sun_from_zenith_deg",
        "eclipse",
    ]
    .iter()
    .map(|c| c.to_string())
    .collect();
    for a in &s.arrays {
        let b = &s.bodies[a.body];
        for ln in &b.link_names {
            cols.push(format!("{}_{}_deg", b.name, ln));
        }
        cols.push(format!("{}_incidence_deg", b.name));
        cols.push(format!("{}_feathered", b.name));
    }
    let sb = &s.bodies[s.servicer];
    for (ln, j) in sb.link_names.iter().zip(&sb.robot.joints) {
        cols.push(match j.joint_type {
            robosim_kinematics::JointType::Prismatic => format!("servicer_{ln}_m"),
            robosim_kinematics::JointType::Revolute => format!("servicer_{ln}_deg"),
        });
    }
    for c in [
        "power_kw",
        "tracked_power_kw",
        "power_lost_kw",
        "battery_soc",
        "battery_kwh",
        "clearance_arrays_m",
        "clearance_between_steps_m",
        "clearance_structure_m",
        "blocked",
        "parked",
        "clearance_serviced_m",
        "failed_oru_x_m",
        "failed_oru_y_m",
        "failed_oru_z_m",
        "spare_oru_x_m",
        "spare_oru_y_m",
        "spare_oru_z_m",
    ] {
        cols.push(c.into());
    }
    if run.attitude.is_some() {
        for c in [
            "attitude_error_deg",
            "cmg_momentum_nms",
            "cmg_capacity_fraction",
            "desaturating",
            "lab_disturbance_ug",
            "inertia_min_kgm2",
            "inertia_mid_kgm2",
            "inertia_max_kgm2",
            "drag_area_m2",
            "attitude_power_loss_kw",
        ] {
            cols.push(c.into());
        }
    }
    cols.extend(power_report::columns(run));
    cols
}

/// One step's row of `station.csv` (infinite clearances written as 1e9).
fn station_row(s: &Setup, p: &StationParams, run: &Run, st: &Step) -> Vec<f64> {
    let finite = |v: f64| if v.is_finite() { v } else { 1e9 };
    let sb = &s.bodies[s.servicer];
    let mut row = vec![
        st.t,
        st.theta.to_degrees(),
        st.sun.x,
        st.sun.y,
        st.sun.z,
        st.sun.z.clamp(-1.0, 1.0).acos().to_degrees(),
        st.eclipse as u8 as f64,
    ];
    for (q, c, f) in &st.arrays {
        row.extend(q.iter().map(|v| v.to_degrees()));
        row.push(c.clamp(-1.0, 1.0).acos().to_degrees());
        row.push(*f as u8 as f64);
    }
    for (v, j) in st.servicer_q.iter().zip(&sb.robot.joints) {
        row.push(match j.joint_type {
            robosim_kinematics::JointType::Prismatic => *v,
            robosim_kinematics::JointType::Revolute => v.to_degrees(),
        });
    }
    row.extend([
        st.power_w / 1e3,
        st.tracked_power_w / 1e3,
        (st.tracked_power_w - st.power_w) / 1e3,
        st.soc,
        st.soc * p.battery_j / 3.6e6,
        finite(st.clearance_arrays),
        finite(st.between_clearance),
        finite(st.clearance_structure),
        st.blocked as u8 as f64,
        st.oru.parked as u8 as f64,
        finite(st.clearance_serviced),
    ]);
    for at in &st.oru_at {
        row.extend([at.x, at.y, at.z]);
    }
    if let Some(a) = &st.attitude {
        row.extend([
            a.error_deg,
            a.h_nms,
            a.h_fraction,
            a.dumping as u8 as f64,
            a.accel_ug,
            a.inertia[0],
            a.inertia[1],
            a.inertia[2],
            a.drag_area_m2,
            a.attitude_loss_w / 1e3,
        ]);
    }
    row.extend(power_report::row(run, st));
    row
}

/// A trajectory file (display file mode) for every robot: the servicer's and the arrays'
/// joint values at each step, the others' held.
fn write_trajectories(s: &Setup, p: &StationParams, run: &Run, dir: &Path) -> Result<()> {
    for (bi, b) in s.bodies.iter().enumerate() {
        let samples: Vec<Vec<f64>> = run
            .steps
            .iter()
            .map(|st| {
                if bi == s.servicer {
                    st.servicer_q.clone()
                } else if let Some(ai) = s.arrays.iter().position(|a| a.body == bi) {
                    st.arrays[ai].0.clone()
                } else {
                    b.q0.clone()
                }
            })
            .collect();
        let path = dir.join(format!("{}.traj", b.name));
        common::write_trajectory(&path, &b.robot, p.step_s, &samples)?;
    }
    Ok(())
}

/// The ORUs' world poses at every step of `run` as the display's pose tracks: each ORU object
/// where the swap has it at that step (on its array's mount at the array's angle, in the
/// servicer's grip, or set down) — what the headless frames draw.
pub fn frame_poses(s: &Setup, run: &Run) -> Vec<robosim_display::app::PoseTrack> {
    (0..2)
        .map(|i| {
            let (object, in_oru) = &s.oru.swap.objects[i];
            let world = run
                .steps
                .iter()
                .map(|st| {
                    let h = if i == 0 { st.oru.failed } else { st.oru.spare };
                    let w = oru_frame(s, h, &st.arrays[s.oru.array].0, &st.servicer_q) * in_oru;
                    let m = w.to_homogeneous();
                    let mut out = [0.0; 12];
                    for r in 0..3 {
                        for c in 0..4 {
                            out[r * 4 + c] = m[(r, c)];
                        }
                    }
                    out
                })
                .collect();
            robosim_display::app::PoseTrack {
                object: object.clone(),
                world,
            }
        })
        .collect()
}

/// The headless frames' request: the scene, every robot's trajectory file in `dir` (as [`run`]
/// writes them), `count` frames into `dir/frames`, the ORUs moved per step ([`frame_poses`]).
pub fn frame_args(
    s: &Setup,
    run: &Run,
    dir: &Path,
    count: usize,
) -> robosim_display::app::RenderArgs {
    let plays: Vec<(String, std::path::PathBuf)> = s
        .bodies
        .iter()
        .map(|b| (b.name.clone(), dir.join(format!("{}.traj", b.name))))
        .collect();
    common::render_args(
        SCENE,
        &plays,
        run.steps.len(),
        count,
        &dir.join("frames"),
        Some([34.0, -4.0, 22.0]),
        Some([4.0, 16.0, 0.0]),
        frame_poses(s, run),
    )
}

/// The summary report: key numbers (table), notes (model and findings), time plots.
pub fn summarise(s: &Setup, p: &StationParams, run: &Run) -> robosim_report::Report {
    summarise_with(s, p, run, None)
}

/// [`summarise`] with the same run's outcome with the scheduler off beside it (`off`).
pub fn summarise_with(
    s: &Setup,
    p: &StationParams,
    run: &Run,
    off: Option<&Run>,
) -> robosim_report::Report {
    use robosim_report::Report;
    let x = Extremes::of(s, p, run);
    let mut table = summary_table(s, p, run, &x);
    let mut notes = model_notes(s, p, run);
    notes.extend(clearance_notes(p, run, &x));
    notes.extend(feathering_notes(p, run, &x));
    notes.extend(parked_note(s, run, &x));
    notes.extend(oru_notes(s, run));
    notes.extend(task_notes(s, run));
    notes.extend(run.swap.iter().flat_map(oru_plan::notes));
    let mut plots = summary_plots(s, run);
    if let Some(a) = &run.attitude {
        // before the wall-time row, which stays last
        let wall = table.rows.pop();
        table.rows.extend(
            attitude::rows(run, a)
                .into_iter()
                .map(|(q, v, u)| vec![q.to_owned(), v, u.to_owned()]),
        );
        table.rows.extend(wall);
        notes.extend(attitude::notes(run, a));
        plots.extend(attitude::plots(run));
    }
    // the loads, before the wall-time row
    let wall = table.rows.pop();
    table.rows.extend(
        power_report::rows(run)
            .into_iter()
            .map(|(q, v, u)| vec![q, v, u.to_owned()]),
    );
    table.rows.extend(wall);
    notes.extend(power_report::notes(run, off));
    plots.push(power_report::plot(run));
    Report {
        name: "station_summary".into(),
        title: "Space Station study: orbit, sun tracking, power, ORU swap".into(),
        notes,
        table,
        plots,
    }
}

/// The run's extremes and totals that the summary's table and notes quote.
struct Extremes<'r> {
    t_end: f64,
    /// Time in the Earth's shadow, s.
    shadow: f64,
    feathered_steps: usize,
    /// Times of the steps blocked (keep-out broken even feathered).
    blocked: Vec<f64>,
    /// Closest servicer–array approach: distance, time, pair.
    min_cl: Option<(f64, f64, &'r (String, String))>,
    /// Closest servicer–array approach between steps: distance, time, pair.
    min_between: Option<(f64, f64, &'r (String, String))>,
    /// Times of the steps with the keep-out broken between samples.
    between_breaks: Vec<f64>,
    serviced_min: f64,
    min_struct: f64,
    /// Worst tracking incidence, deg.
    worst_inc: f64,
    soc_min: f64,
    task_end: f64,
    /// Array panel area, m².
    area: f64,
}

impl<'r> Extremes<'r> {
    fn of(s: &Setup, p: &StationParams, run: &'r Run) -> Extremes<'r> {
        let t_end = run.steps.last().map_or(0.0, |st| st.t);
        let shadow: f64 = run.eclipses.iter().map(|[a, b]| b - a).sum();
        let feathered_steps = run
            .steps
            .iter()
            .filter(|st| st.arrays.iter().any(|a| a.2))
            .count();
        let blocked: Vec<f64> = run
            .steps
            .iter()
            .filter(|st| st.blocked)
            .map(|st| st.t)
            .collect();
        let min_cl = run
            .steps
            .iter()
            .map(|st| (st.clearance_arrays, st.t, &st.clearance_pair))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let min_between = run
            .steps
            .iter()
            .map(|st| (st.between_clearance, st.t, &st.between_pair))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let between_breaks: Vec<f64> = run
            .steps
            .iter()
            .filter(|st| st.between_clearance < p.keep_out_m)
            .map(|st| st.t)
            .collect();
        let serviced_min = run
            .steps
            .iter()
            .map(|st| st.clearance_serviced)
            .fold(f64::INFINITY, f64::min);
        let min_struct = run
            .steps
            .iter()
            .map(|st| st.clearance_structure)
            .fold(f64::INFINITY, f64::min);
        let worst_inc = run
            .steps
            .iter()
            .flat_map(|st| {
                st.arrays
                    .iter()
                    .enumerate()
                    // neither feathered nor parked for the servicer: tracking
                    .filter(|(ai, a)| !(a.2 || (st.oru.parked && *ai == s.oru.array)))
                    .map(|(_, a)| a.1)
            })
            .fold(1.0f64, f64::min)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        let soc_min = run.steps.iter().map(|st| st.soc).fold(1.0, f64::min);
        let task_end = run.schedule.last().map_or(0.0, |w| w.0);
        let area: f64 = s.arrays.iter().map(|a| a.cells.area_m2).sum();
        Extremes {
            t_end,
            shadow,
            feathered_steps,
            blocked,
            min_cl,
            min_between,
            between_breaks,
            serviced_min,
            min_struct,
            worst_inc,
            soc_min,
            task_end,
            area,
        }
    }
}

/// The summary's table: quantity, value, unit.
fn summary_table(s: &Setup, p: &StationParams, run: &Run, x: &Extremes) -> robosim_report::Table {
    let t_end = x.t_end;
    let shadow = x.shadow;
    let feathered_steps = x.feathered_steps;
    let blocked = &x.blocked;
    let min_cl = x.min_cl;
    let min_between = x.min_between;
    let between_breaks = &x.between_breaks;
    let serviced_min = x.serviced_min;
    let min_struct = x.min_struct;
    let worst_inc = x.worst_inc;
    let soc_min = x.soc_min;
    let task_end = x.task_end;
    let area = x.area;
    let rows = vec![
        (
            "orbit altitude",
            format!("{:.1}", s.orbit.altitude_m / 1e3),
            "km",
        ),
        (
            "beta angle",
            format!("{:.2}", s.orbit.beta_rad.to_degrees()),
            "deg",
        ),
        (
            "period (closed form 2π√(a³/μ))",
            format!("{:.2}", run.period_s / 60.0),
            "min",
        ),
        ("run length", format!("{:.2}", t_end / 60.0), "min"),
        ("step", format!("{}", p.step_s), "s"),
        (
            "eclipse fraction, closed form",
            format!("{:.4}", s.orbit.eclipse_fraction_closed_form()),
            "1",
        ),
        (
            "eclipse fraction, geometry over the run",
            format!("{:.4}", if t_end > 0.0 { shadow / t_end } else { 0.0 }),
            "1",
        ),
        ("array panel area", format!("{area:.0}"), "m²"),
        (
            "peak power",
            format!(
                "{:.1}",
                run.steps.iter().map(|st| st.power_w).fold(0.0, f64::max) / 1e3
            ),
            "kW",
        ),
        (
            "orbit-average power",
            format!("{:.1}", run.energy_j / t_end.max(1e-9) / 1e3),
            "kW",
        ),
        (
            "energy from the arrays",
            format!("{:.1}", run.energy_j / 3.6e6),
            "kWh",
        ),
        (
            "energy lost to feathering and parking",
            format!("{:.2}", run.lost_j / 3.6e6),
            "kWh",
        ),
        (
            "steps with an array feathered",
            format!("{feathered_steps}"),
            "1",
        ),
        (
            "worst tracking incidence (neither feathered nor parked)",
            format!("{worst_inc:.3}"),
            "deg",
        ),
        (
            "battery state of charge, minimum",
            format!("{soc_min:.3}"),
            "1",
        ),
        (
            "load not served",
            format!("{:.2}", run.unserved_j / 3.6e6),
            "kWh",
        ),
        (
            "minimum servicer–array clearance",
            min_cl.map_or("none".into(), |c| format!("{:.3}", c.0)),
            "m",
        ),
        (
            "minimum servicer–array clearance between steps",
            min_between.map_or("none".into(), |c| format!("{:.3}", c.0)),
            "m",
        ),
        (
            "steps with the keep-out broken between samples",
            format!("{}", between_breaks.len()),
            "1",
        ),
        (
            "minimum servicer–serviced array clearance (parked, no keep-out)",
            format!("{serviced_min:.3}"),
            "m",
        ),
        (
            "minimum servicer–structure clearance",
            format!("{min_struct:.3}"),
            "m",
        ),
        (
            "steps blocked (keep-out broken even feathered)",
            format!("{}", blocked.len()),
            "1",
        ),
        (
            "ORU task",
            format!("{:.1} to {:.1}", p.task_start_s / 60.0, task_end / 60.0),
            "min",
        ),
        ("wall time of the run", format!("{:.2}", run.wall_s), "s"),
    ];
    robosim_report::Table {
        columns: vec!["quantity".into(), "value".into(), "unit".into()],
        rows: rows
            .into_iter()
            .map(|(a, b, c)| vec![a.to_owned(), b, c.to_owned()])
            .collect(),
    }
}

/// The scene and model the run used, and its eclipses.
fn model_notes(s: &Setup, p: &StationParams, run: &Run) -> Vec<String> {
    let notes = vec![
        format!(
            "Scene `{SCENE}` (effects: kinematics, joint limits, collision {}, orbit, sun tracking, power). Model: circular orbit about a spherical Earth (μ = 3.986004418e14 m³/s², R = 6378.137 km), sun fixed and infinitely far, cylindrical shadow, LVLH hold (body x ram, y orbit normal along the truss, z zenith); power = Σ panel area × {} × {SOLAR_FLUX} W/m² × cos⁺ incidence, 0 in eclipse; battery {:.0} kWh, charge/discharge efficiency {}/{}, constant load {:.0} kW. See docs/studies.md.",
            mode_name(p.mode),
            s.efficiency,
            p.battery_j / 3.6e6,
            p.charge_eff,
            p.discharge_eff,
            p.load_w / 1e3
        ),
        format!(
            "Eclipses from the geometry: {}.",
            if run.eclipses.is_empty() {
                no_eclipse_reason(&s.orbit, p.orbits)
            } else {
                run.eclipses
                    .iter()
                    .map(|[a, b]| format!("{:.1}–{:.1} min", a / 60.0, b / 60.0))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ),
    ];
    notes
}

/// Why a run saw no eclipse: β beyond the critical angle `asin(R/(R+h))` (the orbit never
/// enters the shadow), or — below it — a run too short to reach the shadow (the quick variant's
/// quarter orbit at β = 20°).
pub fn no_eclipse_reason(orbit: &Orbit, orbits: f64) -> String {
    let r = robosim_simulator::orbit::EARTH_RADIUS_M;
    let critical = (r / (r + orbit.altitude_m)).asin();
    let (beta, crit) = (orbit.beta_rad.abs().to_degrees(), critical.to_degrees());
    if orbit.beta_rad.abs() >= critical {
        format!(
            "none (β = {beta:.1}° is beyond the critical angle {crit:.1}°: this orbit never enters the shadow)"
        )
    } else {
        format!(
            "none in this run (β = {beta:.1}° is below the critical angle {crit:.1}°, so the orbit has eclipses, {:.0}% of it in shadow; the {orbits} orbit{} run does not reach the shadow)",
            100.0 * orbit.eclipse_fraction_closed_form(),
            if orbits == 1.0 { "" } else { "s" }
        )
    }
}

/// The servicer's closest approaches: to an array at the samples and between them, and to the
/// fixed structure.
fn clearance_notes(p: &StationParams, run: &Run, x: &Extremes) -> Vec<String> {
    let mut notes = Vec::new();
    let min_cl = x.min_cl;
    let min_between = x.min_between;
    let between_breaks = &x.between_breaks;
    if let Some((d, t, pair)) = min_cl {
        notes.push(format!(
            "Closest approach of the servicer to an array: {d:.3} m at t = {:.1} min ({} × {}); keep-out {} m.",
            t / 60.0,
            pair.0,
            pair.1,
            p.keep_out_m
        ));
    }
    if let Some((d, t, pair)) = min_between {
        notes.push(format!(
            "Between the samples (servicer on its schedule and arrays interpolated in joint space, checked at points no more than half the keep-out of servicer motion apart): closest approach {d:.3} m in the step ending at t = {:.1} min ({} × {}); {}. How the keep-out is ensured between samples: each array's angle at a sample is chosen (tracking, else the best-powered feathered angle) to clear the keep-out against the servicer's planned sweep over the steps on either side of the sample, at the same points, so the array is feathered a step early where the arm will pass; this check verifies it.",
            t / 60.0,
            pair.0,
            pair.1,
            if between_breaks.is_empty() {
                "the keep-out holds between every pair of steps".to_owned()
            } else {
                format!(
                    "the keep-out is still broken between samples in {} step(s), first in the step ending at {:.1} min (an array swings between two clear angles through the arm's path)",
                    between_breaks.len(),
                    between_breaks[0] / 60.0
                )
            }
        ));
    }
    if let Some(st) = run
        .steps
        .iter()
        .min_by(|a, b| a.clearance_structure.total_cmp(&b.clearance_structure))
    {
        notes.push(format!(
            "Closest approach of the servicer to the fixed structure: {:.3} m at t = {:.1} min ({} × {}){}.",
            st.clearance_structure,
            st.t / 60.0,
            st.structure_pair.0,
            st.structure_pair.1,
            if st.clearance_structure <= 0.0 { " — a CONTACT" } else { "" }
        ));
    }
    notes
}

/// The spans with an array feathered for the servicer, and the steps blocked even so.
fn feathering_notes(p: &StationParams, run: &Run, x: &Extremes) -> Vec<String> {
    let mut notes = Vec::new();
    let blocked = &x.blocked;
    // feathered spans
    let mut spans: Vec<(f64, f64, f64)> = Vec::new();
    for st in &run.steps {
        let f = st.arrays.iter().any(|a| a.2);
        let lost = (st.tracked_power_w - st.power_w) / 1e3;
        match spans.last_mut() {
            Some(sp) if f && (st.t - sp.1 - p.step_s).abs() < 1e-6 => {
                sp.1 = st.t;
                sp.2 = sp.2.max(lost);
            }
            _ if f => spans.push((st.t, st.t, lost)),
            _ => {}
        }
    }
    for (a, b, l) in &spans {
        notes.push(format!(
            "Array feathered for the servicer from {:.1} to {:.1} min: up to {l:.1} kW lost.",
            a / 60.0,
            b / 60.0
        ));
    }
    if !blocked.is_empty() {
        notes.push(format!(
            "The servicer is inside the keep-out of an array even with it feathered at {} step(s), first at {:.1} min.",
            blocked.len(),
            blocked[0] / 60.0
        ));
    }
    notes
}

/// The serviced array parked at its service angle: when, the energy lost, its clearance.
fn parked_note(s: &Setup, run: &Run, x: &Extremes) -> Vec<String> {
    let mut notes = Vec::new();
    let serviced_min = x.serviced_min;
    // the parked spans and the ORUs' journey
    let parked: Vec<f64> = run
        .steps
        .iter()
        .filter(|st| st.oru.parked)
        .map(|st| st.t)
        .collect();
    if let (Some(a), Some(b)) = (parked.first(), parked.last()) {
        let name = &s.bodies[s.arrays[s.oru.array].body].name;
        let lost: f64 = run
            .steps
            .windows(2)
            .filter(|w| w[0].oru.parked)
            .map(|w| (w[0].tracked_power_w - w[0].power_w) * (w[1].t - w[0].t))
            .sum();
        notes.push(format!(
            "{name} parked at its service angle (the ORU's grapple up) from {:.1} to {:.1} min while the servicer works on it: {:.2} kWh lost; closest approach to it {:.3} m{}.",
            a / 60.0,
            b / 60.0,
            lost / 3.6e6,
            serviced_min,
            if serviced_min <= 0.0 { " — a CONTACT" } else { " (no keep-out: it is worked on)" }
        ));
    }
    notes
}

/// The ORUs' journey: where each was grasped, set down and bolted, and where they ended.
fn oru_notes(s: &Setup, run: &Run) -> Vec<String> {
    let mut notes = Vec::new();
    let plan = Plan {
        points: run.schedule.clone(),
        events: run.events.clone(),
    };
    for (te, e) in &run.events {
        // where the ORU is at the event (after it), the array parked
        let ost = oru_state(s, &plan, *te);
        let sq = servicer_at(&plan.points, *te).0;
        let where_ = |i: usize| {
            let h = if i == 0 { ost.failed } else { ost.spare };
            let p = oru_frame(s, h, &s.oru.swap.service_q, &sq)
                .translation
                .vector;
            format!(" at ({:.3}, {:.3}, {:.3}) m", p.x, p.y, p.z)
        };
        let what = match e {
            OruEvent::Park => continue,
            OruEvent::Unpark => continue,
            OruEvent::GraspFailed => format!("the failed ORU grasped{}", where_(0)),
            OruEvent::StowFailed => format!("the failed ORU set down{}", where_(0)),
            OruEvent::GraspSpare => format!("the spare grasped{}", where_(1)),
            OruEvent::InstallSpare => format!("the spare bolted on the mount{}", where_(1)),
        };
        notes.push(format!("ORU {:.1} min: {what}.", te / 60.0));
    }
    if let (Some(last), Some(install)) = (run.steps.last(), install_error(s, run))
        && matches!(last.oru.failed, Held::Fixed(_))
    {
        let [_, _, stow] = sites(s);
        notes.push(format!(
            "At the end: the spare bolted {:.2} mm from the failed unit's mount (where the servicer let go of it, against the mount), the failed unit {:.2} mm from its stowage.",
            install * 1e3,
            (last.oru_at[0] - stow).norm() * 1e3
        ));
    }
    notes
}

/// The servicer's task, waypoint by waypoint, with the effector's position.
fn task_notes(s: &Setup, run: &Run) -> Vec<String> {
    let mut notes = Vec::new();
    for w in &run.schedule {
        let sb = &s.bodies[s.servicer];
        let tip = robosim_kinematics::fk::forward(&sb.robot, &w.1);
        notes.push(format!(
            "Task {:.1} min: {} (effector at ({:.2}, {:.2}, {:.2}) m).",
            w.0 / 60.0,
            w.2,
            tip[(0, 3)],
            tip[(1, 3)],
            tip[(2, 3)]
        ));
    }
    notes
}

/// Array power, battery and eclipse, the gimbal angles and the servicer's clearances against
/// time.
fn summary_plots(s: &Setup, run: &Run) -> Vec<robosim_report::Plot> {
    use robosim_report::{Plot, Series};
    let series = |label: &str, f: &dyn Fn(&Step) -> f64| Series {
        label: label.into(),
        points: run.steps.iter().map(|st| (st.t / 60.0, f(st))).collect(),
    };
    let mut angle_series = Vec::new();
    for (ai, a) in s.arrays.iter().enumerate() {
        let b = &s.bodies[a.body];
        for (j, ln) in b.link_names.iter().enumerate() {
            let mut points: Vec<(f64, f64)> = run
                .steps
                .iter()
                .map(|st| (st.t / 60.0, st.arrays[ai].0[j].to_degrees()))
                .collect();
            // A gimbal passing ±180° is a continuous turn, not a vertical line.
            robosim_report::plot::unwrap_degrees(&mut points);
            angle_series.push(Series {
                label: format!("{} {ln}", b.name),
                points,
            });
        }
    }
    let plots = vec![
        Plot {
            title: "Array power".into(),
            x_label: "t (min)".into(),
            y_label: "power (kW)".into(),
            series: vec![
                series("delivered", &|st| st.power_w / 1e3),
                series("tracking without feathering", &|st| {
                    st.tracked_power_w / 1e3
                }),
            ],
            ..Plot::default()
        },
        Plot {
            title: "Battery and eclipse".into(),
            x_label: "t (min)".into(),
            y_label: "state of charge / eclipse flag (1)".into(),
            series: vec![
                series("state of charge", &|st| st.soc),
                series("eclipse", &|st| st.eclipse as u8 as f64),
            ],
            ..Plot::default()
        },
        Plot {
            title: "Array gimbal angles (sun tracking)".into(),
            x_label: "t (min)".into(),
            y_label: "angle (deg)".into(),
            series: angle_series,
            ..Plot::default()
        },
        Plot {
            title: "Servicer clearance".into(),
            x_label: "t (min)".into(),
            y_label: "distance (m)".into(),
            series: vec![
                series("to the arrays", &|st| st.clearance_arrays.min(30.0)),
                series("to the arrays between steps", &|st| {
                    st.between_clearance.min(30.0)
                }),
                series("to the fixed structure", &|st| {
                    st.clearance_structure.min(30.0)
                }),
            ],
            ..Plot::default()
        },
    ];
    plots
}

/// "What accuracy costs in time": the study run at several steps and collision modes, each
/// against the finest exact run; written as `station_accuracy.{md,csv,png}`.
pub fn accuracy(p: &StationParams, dir: &Path, steps: &[f64]) -> Result<robosim_report::Report> {
    let s = setup(p)?;
    let mut rows = Vec::new();
    let fine_step = steps.iter().copied().fold(f64::INFINITY, f64::min);
    let reference = simulate(
        &s,
        &StationParams {
            step_s: fine_step,
            frames: 0,
            ..p.clone()
        },
    )?;
    let mut time_pts = Vec::new();
    let mut energy_pts = Vec::new();
    for (mode, tol) in [
        (Mode::Exact, p.tracking_tol),
        (Mode::BBox, p.tracking_tol),
        (Mode::Exact, 1e-2),
    ] {
        for &h in steps {
            let r = simulate(
                &s,
                &StationParams {
                    step_s: h,
                    mode,
                    tracking_tol: tol,
                    frames: 0,
                    ..p.clone()
                },
            )?;
            let de = (r.energy_j - reference.energy_j).abs() / reference.energy_j.max(1.0);
            let ms = r.wall_s * 1e3;
            let label = format!("{} tol {:.0e}", mode_name(mode), tol);
            time_pts.push((label.clone(), h, ms));
            energy_pts.push((label.clone(), h, de));
            rows.push(accuracy_row(&s, p, &r, (mode, tol, h), de));
        }
    }
    let report = accuracy_report(p, fine_step, rows, &energy_pts, &time_pts);
    robosim_report::write_report(dir, &report)?;
    Ok(report)
}

/// One row of the accuracy table: the run `r` at (collision mode, tracking tolerance, step),
/// its energy's relative error `de` against the finest run; its eclipse (sampled fraction,
/// entry seen late), clearances at and between the steps, feathered and blocked steps, wall
/// time.
fn accuracy_row(
    s: &Setup,
    p: &StationParams,
    r: &Run,
    (mode, tol, h): (Mode, f64, f64),
    de: f64,
) -> Vec<String> {
    // the eclipse entry as the steps see it (first step in shadow) against the bisected one
    let entry_err = |r: &Run| {
        let first = r.steps.iter().find(|x| x.eclipse).map(|x| x.t);
        match (first, r.eclipses.first()) {
            (Some(t), Some(iv)) => (t - iv[0]).abs(),
            _ => 0.0,
        }
    };
    let min_cl = |r: &Run| {
        r.steps
            .iter()
            .map(|st| st.clearance_arrays)
            .fold(f64::INFINITY, f64::min)
    };
    let min_between = |r: &Run| {
        r.steps
            .iter()
            .map(|st| st.between_clearance)
            .fold(f64::INFINITY, f64::min)
    };
    let sampled_eclipse =
        r.steps.iter().filter(|st| st.eclipse).count() as f64 / r.steps.len().max(1) as f64;
    let ms = r.wall_s * 1e3;
    vec![
        mode_name(mode).to_owned(),
        format!("{tol:.0e}"),
        format!("{h}"),
        format!("{}", r.steps.len()),
        format!("{de:.2e}"),
        format!(
            "{:.2e}",
            (sampled_eclipse - s.orbit.eclipse_fraction_closed_form()).abs()
        ),
        format!("{:.1}", entry_err(r)),
        format!("{:.3}", min_cl(r)),
        format!("{:.3}", min_between(r)),
        format!(
            "{}",
            r.steps
                .iter()
                .filter(|st| st.between_clearance < p.keep_out_m)
                .count()
        ),
        format!(
            "{}",
            r.steps
                .iter()
                .filter(|st| st.arrays.iter().any(|a| a.2))
                .count()
        ),
        format!("{}", r.steps.iter().filter(|st| st.blocked).count()),
        format!("{ms:.1}"),
    ]
}

/// The accuracy report: its note, the table of `rows`, energy error and wall time against
/// the step (one series per mode and tolerance).
fn accuracy_report(
    p: &StationParams,
    fine_step: f64,
    rows: Vec<Vec<String>>,
    energy_pts: &[(String, f64, f64)],
    time_pts: &[(String, f64, f64)],
) -> robosim_report::Report {
    use robosim_report::{Plot, Report, Series, Table};
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
    Report {
        name: "station_accuracy".into(),
        title: "Space Station study: what accuracy costs in time".into(),
        notes: vec![format!(
            "Each row is the whole study ({} orbit(s)) at one step, collision mode and tracking tolerance. Energy error is against the finest exact run (step {fine_step} s). The sampled eclipse fraction (share of steps in shadow) is compared with the closed form, and the first step in shadow with the eclipse entry found by bisection (which does not depend on the step). Clearances are checked at the steps (where feathering acts) and between them (servicer on its schedule, arrays interpolated; points no more than half the keep-out of servicer motion apart): a break between steps is what a controller sampling at that step would not see. bbox gives no distances: its clearance is a bounding-sphere lower bound when the boxes are apart and 0 when they meet, so it cannot prove most feathered angles clear — those steps are reported blocked (the arm would have to wait) where exact finds a clear angle.",
            p.orbits
        )],
        table: Table {
            columns: vec![
                "collision mode".into(),
                "tracking tol (rad)".into(),
                "step (s)".into(),
                "steps".into(),
                "energy rel. error".into(),
                "sampled eclipse fraction error".into(),
                "eclipse entry seen late by (s)".into(),
                "min clearance (m)".into(),
                "min clearance between steps (m)".into(),
                "keep-out broken between steps".into(),
                "feathered steps".into(),
                "blocked steps".into(),
                "wall time (ms)".into(),
            ],
            rows,
        },
        plots: vec![
            Plot {
                title: "Energy error against step".into(),
                x_label: "step (s)".into(),
                y_label: "relative error".into(),
                log_x: true,
                log_y: true,
                series: group(energy_pts),
            },
            Plot {
                title: "Wall time against step".into(),
                x_label: "step (s)".into(),
                y_label: "wall time (ms)".into(),
                log_x: true,
                log_y: true,
                series: group(time_pts),
            },
        ],
    }
}
