//! `robosim study welding|station --out DIR`: the clap arguments and the runner (src/main.rs
//! only forwards here).

use crate::{Result, StudyError, station, welding};
use robosim_collision::Mode;
use std::path::PathBuf;

#[derive(clap::Subcommand, Debug, Clone)]
pub enum StudyCmd {
    /// The downhand welding cell (seed §2.2): the positioner keeps the weld pool downhand while
    /// the arm follows the seams; CSV, trajectories, summary, plots, frames.
    Welding(WeldingArgs),
    /// The Space Station (seed ch. 4): orbit, sun-tracking arrays, power and battery, an ORU
    /// swap by the servicer with the arrays feathered where it passes; CSV, summary, plots, frames.
    Station(StationArgs),
}

#[derive(clap::Args, Debug, Clone)]
pub struct WeldingArgs {
    /// Directory for the outputs (created).
    #[arg(long)]
    pub out: PathBuf,
    /// Seams to weld: circle (pipe to flange), saddle (branch to pipe) or both.
    #[arg(long, default_value = "both", value_parser = ["circle", "saddle", "both"])]
    pub seam: String,
    /// Torch travel speed along the seam, mm/s.
    #[arg(long, allow_hyphen_values = true, default_value_t = 8.0)]
    pub speed: f64,
    /// Step, s.
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.25)]
    pub step: f64,
    /// Height of the branch's axis above the flange, m (the scene's `branch_height`, default
    /// 0.18 m): moves the branch, so the saddle seam with it.
    #[arg(long, allow_hyphen_values = true)]
    pub branch_height: Option<f64>,
    /// The arm's base along world x, m (default: the scene's −1.1 m).
    #[arg(long, allow_hyphen_values = true)]
    pub arm_x: Option<f64>,
    /// Collision mode of the clearance checks.
    #[arg(long, default_value = "exact", value_parser = ["bbox", "polygon", "exact"])]
    pub mode: String,
    /// Frames to render headless (0: none).
    #[arg(long, default_value_t = 12)]
    pub frames: usize,
    /// Also write the accuracy-against-time section (runs the study several times).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub accuracy: bool,
}

#[derive(clap::Args, Debug, Clone)]
pub struct StationArgs {
    /// Directory for the outputs (created).
    #[arg(long)]
    pub out: PathBuf,
    /// Orbit altitude, km (default: the scene's orbit effect, 400 km).
    #[arg(long, allow_hyphen_values = true)]
    pub altitude: Option<f64>,
    /// Beta angle, degrees (default: the scene's, 20°).
    #[arg(long, allow_hyphen_values = true)]
    pub beta: Option<f64>,
    /// Step, s.
    #[arg(long, default_value_t = 10.0)]
    pub step: f64,
    /// Length of the run in orbits.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1.0)]
    pub orbits: f64,
    /// Keep-out distance between the servicer and an array, m.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1.0)]
    pub keep_out: f64,
    /// Constant station load, kW.
    #[arg(long, allow_hyphen_values = true, default_value_t = 100.0)]
    pub load: f64,
    /// Battery capacity, kWh.
    #[arg(long, allow_hyphen_values = true, default_value_t = 150.0)]
    pub battery: f64,
    /// When the servicer's ORU swap starts, s.
    #[arg(long, allow_hyphen_values = true, default_value_t = 300.0)]
    pub task_start: f64,
    /// Collision mode of the clearance checks.
    #[arg(long, default_value = "exact", value_parser = ["bbox", "polygon", "exact"])]
    pub mode: String,
    /// Frames to render headless (0: none).
    #[arg(long, default_value_t = 12)]
    pub frames: usize,
    /// Also write the accuracy-against-time section (runs the study several times).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub accuracy: bool,
}

fn mode(s: &str) -> Result<Mode> {
    Ok(match s {
        "bbox" => Mode::BBox,
        "polygon" => Mode::Polygon,
        "exact" => Mode::Exact,
        other => {
            return Err(StudyError(format!(
                "collision mode {other:?}: bbox, polygon or exact"
            )));
        }
    })
}

/// Runs `robosim study …`, reporting to `log`.
pub fn run(cmd: &StudyCmd, log: &mut dyn std::io::Write) -> Result<()> {
    match cmd {
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
                ..station::StationParams::default()
            };
            station::run(&p, &a.out, log)?;
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
