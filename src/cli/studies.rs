//! `robosim study` and `robosim sweep`: the clap arguments of robosim-studies' runners
//! (`robosim_studies::cli`, `robosim_studies::sweep::cli`), each converted to the library's plain argument type.

use std::path::PathBuf;

#[derive(clap::Subcommand, Debug, Clone)]
pub enum StudyCmd {
    /// The downhand welding cell (seed §2.2): the positioner keeps the weld pool downhand while
    /// the arm follows the seams; CSV, trajectories, summary, plots, frames.
    Welding(WeldingArgs),
    /// The Space Station (seed ch. 4): orbit, sun-tracking arrays, power and battery, an ORU
    /// swap by the servicer with the arrays feathered where it passes; CSV, summary, plots, frames.
    Station(StationArgs),
    /// The operational station (issue 38 item 7): `robosim up space_station_ops` with the
    /// simulator, the rules (station_ops.clp), the dataflow (momentum_manager.flow) and the
    /// automation plant as separate processes on one session, driven headless in lock-step;
    /// operations.csv, operations_summary.{md,csv,png}, operations_decisions.csv.
    Operations(OperationsArgs),
}

#[derive(clap::Args, Debug, Clone)]
pub struct OperationsArgs {
    /// Directory for the outputs (created).
    #[arg(long)]
    pub out: PathBuf,
    /// Orbits to run.
    #[arg(long, default_value_t = 1.0)]
    pub orbits: f64,
    /// Session name (default: ops-study-<pid>; an existing one is started fresh).
    #[arg(long)]
    pub session: Option<String>,
    /// Simulated seconds between the rules' decisions (one output row each).
    #[arg(long, default_value_t = 60.0)]
    pub decide_every: f64,
    /// The energy scheduler (the rules process): on, or off to measure what it is worth.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub scheduler: String,
    /// A fault for the ECLSS plant at a simulated time, FAULT@SECONDS (repeatable).
    #[arg(long)]
    pub fault: Vec<String>,
    /// Leave the session running at the end (`robosim down --session S` stops it).
    #[arg(long)]
    pub keep: bool,
    /// The station's base load (avionics, communications, thermal control), kW; default the
    /// simulator's 100 kW. The ECLSS consumers draw beside it.
    #[arg(long)]
    pub base_load: Option<f64>,
}

impl From<OperationsArgs> for robosim_studies::cli::OperationsArgs {
    fn from(a: OperationsArgs) -> Self {
        robosim_studies::cli::OperationsArgs {
            out: a.out,
            orbits: a.orbits,
            session: a.session,
            decide_every: a.decide_every,
            scheduler: a.scheduler == "on",
            fault: a.fault,
            keep: a.keep,
            base_load: a.base_load,
        }
    }
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
    /// The station's base load (avionics, communications, thermal control), kW; the ECLSS
    /// subsystems, the servicer and the experiments draw beside it.
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
    /// Integrate the station's attitude (the scene's `attitude` effect: CMG momentum,
    /// desaturations by thrusters) and track the sun in its actual body frame; also writes the
    /// attitude integration's accuracy section.
    #[arg(long)]
    pub attitude: bool,
    /// The station's energy scheduler (station_power.clp in the CLIPS engine): on or off
    /// (default: on when this build has CLIPS); when on, the same run with it off is reported
    /// beside it.
    #[arg(long, value_parser = ["on", "off"])]
    pub scheduler: Option<String>,
    /// An ECLSS fault injected: FAILURE_MODE@SECONDS (e.g. pump_failure@3000); its alarms are
    /// diagnosed and its spare brought on line by eclss_guard.clp. Or array_oru@SECONDS: the
    /// serviced array's power-system ORU fails and oru_swap.clp plans the ORU swap.
    #[arg(long)]
    pub fault: Option<String>,
}

impl From<StudyCmd> for robosim_studies::cli::StudyCmd {
    fn from(a: StudyCmd) -> Self {
        match a {
            StudyCmd::Welding(x) => robosim_studies::cli::StudyCmd::Welding(x.into()),
            StudyCmd::Station(x) => robosim_studies::cli::StudyCmd::Station(x.into()),
            StudyCmd::Operations(x) => robosim_studies::cli::StudyCmd::Operations(x.into()),
        }
    }
}

impl From<WeldingArgs> for robosim_studies::cli::WeldingArgs {
    fn from(a: WeldingArgs) -> Self {
        robosim_studies::cli::WeldingArgs {
            out: a.out,
            seam: a.seam,
            speed: a.speed,
            step: a.step,
            branch_height: a.branch_height,
            arm_x: a.arm_x,
            mode: a.mode,
            frames: a.frames,
            accuracy: a.accuracy,
        }
    }
}

impl From<StationArgs> for robosim_studies::cli::StationArgs {
    fn from(a: StationArgs) -> Self {
        robosim_studies::cli::StationArgs {
            out: a.out,
            altitude: a.altitude,
            beta: a.beta,
            step: a.step,
            orbits: a.orbits,
            keep_out: a.keep_out,
            load: a.load,
            battery: a.battery,
            task_start: a.task_start,
            mode: a.mode,
            frames: a.frames,
            accuracy: a.accuracy,
            attitude: a.attitude,
            scheduler: a.scheduler,
            fault: a.fault,
        }
    }
}
#[derive(clap::Args, Debug, Clone)]
pub struct SweepArgs {
    /// The study: surgical (seed §2.7 reach and encoder accuracy), welding, or station
    /// (docs/studies.md lists each one's parameters and result columns).
    pub study: String,
    /// A swept parameter, NAME=A:B:N (N values evenly from A to B, both included) or
    /// NAME=V1,V2,… (numbers in the parameter's unit, or words for a choice). Repeat for more
    /// parameters: every combination is run, the first parameter varying slowest.
    #[arg(long = "param", value_name = "NAME=RANGE")]
    pub params: Vec<String>,
    /// Worker processes on this machine [default: one per core]. 0 with --remote: only
    /// remote workers.
    #[arg(long)]
    pub workers: Option<usize>,
    /// Workers on another machine: the Zenoh endpoint where `robosim sweep-host` listens
    /// there, e.g. tcp/10.0.0.2:7448; as many workers as that host runs. Repeat for more hosts.
    #[arg(long = "remote", value_name = "ENDPOINT")]
    pub remote: Vec<String>,
    /// Key prefix of the sweep hosts on the Zenoh network (their --key).
    #[arg(long, default_value = "robosim", value_name = "PREFIX")]
    pub remote_key: String,
    /// How long to wait for a --remote host, seconds: at the start for each to answer, and
    /// later, when every worker left is on a host whose link lapsed, for one to come back.
    #[arg(long, default_value_t = 15.0, value_name = "SECONDS")]
    pub remote_wait: f64,
    /// The CSV to write: the parameters' columns, then the study's result columns, then
    /// `error` (empty for a job that ran), one row per point in job order.
    #[arg(long)]
    pub out: PathBuf,
    /// How many times a job is tried when its worker dies running it.
    #[arg(long, default_value_t = 3)]
    pub attempts: u32,
    /// Kill a worker whose job runs longer than this many seconds (counted as a death: the
    /// job is redone) [default: no limit].
    #[arg(long, value_name = "SECONDS")]
    pub job_timeout: Option<f64>,
}

impl From<SweepArgs> for robosim_studies::sweep::cli::SweepArgs {
    fn from(a: SweepArgs) -> Self {
        robosim_studies::sweep::cli::SweepArgs {
            study: a.study,
            params: a.params,
            workers: a.workers,
            remote: a.remote,
            remote_key: a.remote_key,
            remote_wait: a.remote_wait,
            out: a.out,
            attempts: a.attempts,
            job_timeout: a.job_timeout,
        }
    }
}
