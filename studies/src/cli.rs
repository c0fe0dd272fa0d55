//! `robosim study welding|station --out DIR`: the arguments (plain types; the binary parses the
//! command line into them, src/cli/studies.rs) and the runner.

use crate::{Result, StudyError, operations, station, welding};
use robosim_collision::Mode;
use std::path::PathBuf;

#[derive(Debug, Clone)]
pub enum StudyCmd {
    /// The downhand welding cell (seed §2.2): the positioner keeps the weld pool downhand while
    /// the arm follows the seams; CSV, trajectories, summary, plots, frames.
    Welding(WeldingArgs),
    /// The Space Station (seed ch. 4): orbit, sun-tracking arrays, power and battery, an ORU
    /// swap by the servicer with the arrays feathered where it passes; CSV, summary, plots, frames.
    Station(StationArgs),
    /// The operational station (issue 38 item 7): simulator, rules, dataflow and automation as
    /// separate processes on one session, driven headless; CSV, summary, plots.
    Operations(OperationsArgs),
}

#[derive(Debug, Clone)]
pub struct OperationsArgs {
    /// Directory for the outputs (created).
    pub out: PathBuf,
    /// Orbits to run.
    pub orbits: f64,
    /// Session name (default: ops-study-<pid>).
    pub session: Option<String>,
    /// Simulated seconds between the rules' decisions (one output row each).
    pub decide_every: f64,
    /// The scheduler (rules process): on or off.
    pub scheduler: bool,
    /// Faults for the automation plant, FAULT@SECONDS.
    pub fault: Vec<String>,
    /// Leave the session running.
    pub keep: bool,
    /// The station's base load, kW (default: the simulator's 100 kW).
    pub base_load: Option<f64>,
}

#[derive(Debug, Clone)]
pub struct WeldingArgs {
    /// Directory for the outputs (created).
    pub out: PathBuf,
    /// Seams to weld: circle (pipe to flange), saddle (branch to pipe) or both.
    pub seam: String,
    /// Torch travel speed along the seam, mm/s.
    pub speed: f64,
    /// Step, s.
    pub step: f64,
    /// Height of the branch's axis above the flange, m (the scene's `branch_height`, default
    /// 0.18 m): moves the branch, so the saddle seam with it.
    pub branch_height: Option<f64>,
    /// The arm's base along world x, m (default: the scene's −1.1 m).
    pub arm_x: Option<f64>,
    /// Collision mode of the clearance checks.
    pub mode: String,
    /// Frames to render headless (0: none).
    pub frames: usize,
    /// Also write the accuracy-against-time section (runs the study several times).
    pub accuracy: bool,
}

#[derive(Debug, Clone)]
pub struct StationArgs {
    /// Directory for the outputs (created).
    pub out: PathBuf,
    /// Orbit altitude, km (default: the scene's orbit effect, 400 km).
    pub altitude: Option<f64>,
    /// Beta angle, degrees (default: the scene's, 20°).
    pub beta: Option<f64>,
    /// Step, s.
    pub step: f64,
    /// Length of the run in orbits.
    pub orbits: f64,
    /// Keep-out distance between the servicer and an array, m.
    pub keep_out: f64,
    /// The station's base load, kW (the ECLSS subsystems, servicer and experiments beside it).
    pub load: f64,
    /// Battery capacity, kWh.
    pub battery: f64,
    /// When the servicer's ORU swap starts, s.
    pub task_start: f64,
    /// Collision mode of the clearance checks.
    pub mode: String,
    /// Frames to render headless (0: none).
    pub frames: usize,
    /// Also write the accuracy-against-time section (runs the study several times).
    pub accuracy: bool,
    /// Integrate the station's attitude (the scene's `attitude` effect: CMGs, desaturations)
    /// and track the sun in its actual body frame; writes the attitude's accuracy section.
    pub attitude: bool,
    /// `on` or `off` (None: on when this build has CLIPS).
    pub scheduler: Option<String>,
    /// An ECLSS fault, `FAILURE_MODE@SECONDS`.
    pub fault: Option<String>,
}

fn mode(s: &str) -> Result<Mode> {
    Ok(match s {
        "bbox" => Mode::BBox,
        "polygon" => Mode::Polygon,
        "exact" => Mode::Exact,
        other => {
            return Err(StudyError::Message(format!(
                "collision mode {other:?}: bbox, polygon or exact"
            )));
        }
    })
}

/// Runs `robosim study …`, reporting to `log`.
pub fn run(cmd: &StudyCmd, log: &mut dyn std::io::Write) -> Result<()> {
    match cmd {
        StudyCmd::Operations(a) => {
            let p = operations::OpsParams {
                orbits: a.orbits,
                out: a.out.clone(),
                session: a.session.clone(),
                decide_every_s: a.decide_every,
                scheduler: a.scheduler,
                faults: a
                    .fault
                    .iter()
                    .map(|f| operations::parse_fault(f))
                    .collect::<Result<_>>()?,
                keep: a.keep,
                base_load_w: a.base_load.map(|kw| kw * 1e3),
            };
            operations::run(&p, log)?;
            Ok(())
        }
        StudyCmd::Station(a) => {
            let p = station::StationParams {
                altitude_m: a.altitude.map(|km| km * 1e3),
                beta_rad: a.beta.map(f64::to_radians),
                step_s: a.step,
                orbits: a.orbits,
                keep_out_m: a.keep_out,
                load_w: a.load * 1e3,
                battery_j: a.battery * 3.6e6,
                task_start_s: a.task_start,
                mode: mode(&a.mode)?,
                frames: a.frames,
                attitude: a.attitude,
                scheduling: match &a.scheduler {
                    Some(s) => station::scheduler::Scheduling::parse(s)?,
                    None => station::scheduler::Scheduling::default_for_build(),
                },
                fault: a
                    .fault
                    .as_deref()
                    .map(station::faults::FaultSpec::parse)
                    .transpose()?,
                ..station::StationParams::default()
            };
            let run = station::run(&p, &a.out, log)?;
            if a.attitude {
                let s = station::setup(&p)?;
                if let Some(att) = &s.attitude {
                    station::attitude::accuracy(
                        att,
                        &run,
                        &a.out,
                        &[10.0, 5.0, 2.0, 1.0, 0.5],
                        s.orbit,
                        p.theta0,
                    )?;
                    crate::say!(
                        log,
                        "attitude integration against time: {}",
                        a.out.join("station_attitude_accuracy.md").display()
                    );
                }
            }
            if a.accuracy {
                station::accuracy(&p, &a.out, &[60.0, 30.0, 10.0, 5.0])?;
                crate::say!(
                    log,
                    "accuracy against time: {}",
                    a.out.join("station_accuracy.md").display()
                );
            }
            Ok(())
        }
        StudyCmd::Welding(a) => {
            let p = welding::WeldingParams {
                seams: match a.seam.as_str() {
                    "circle" => vec![welding::SeamKind::Circle],
                    "saddle" => vec![welding::SeamKind::Saddle],
                    _ => vec![welding::SeamKind::Circle, welding::SeamKind::Saddle],
                },
                speed_m_s: a.speed * 1e-3,
                step_s: a.step,
                branch_height_m: a.branch_height,
                arm_x_m: a.arm_x,
                mode: mode(&a.mode)?,
                frames: a.frames,
                ..welding::WeldingParams::default()
            };
            welding::run(&p, &a.out, log)?;
            if a.accuracy {
                welding::accuracy(&p, &a.out, &[1.0, 0.5, 0.25, 0.1])?;
                crate::say!(
                    log,
                    "accuracy against time: {}",
                    a.out.join("welding_accuracy.md").display()
                );
            }
            Ok(())
        }
    }
}
