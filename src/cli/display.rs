//! `robosim render` and `robosim display`: the clap arguments of robosim-display's commands
//! (`robosim_display::app`) and the parsers of their camera options, each converted to the
//! library's plain argument type.

use std::path::PathBuf;

/// Camera and style options shared by `render` and `display`.
#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// LOOK-FROM x,y,z (m, world). Default: from the seed's viewing direction, framing the model.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub from: Option<[f64; 3]>,
    /// LOOK-AT x,y,z (m, world). Default: the centre of the model's bounding box.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub at: Option<[f64; 3]>,
    /// Camera up vector.
    #[arg(long, value_parser = parse_vec3, default_value = "0,0,1", allow_hyphen_values = true)]
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    pub fov: f64,
    /// Orthographic projection (default perspective).
    #[arg(long)]
    pub ortho: bool,
    /// Draw polygon edges over the shading.
    #[arg(long)]
    pub edges: bool,
    /// Image size WxH (pixels).
    #[arg(long, value_parser = parse_size, default_value = "1024x768")]
    pub size: (u32, u32),
    /// Draw objects in contact (each robot against itself and the rest) in the collision colour.
    #[arg(long)]
    pub collisions: bool,
}

#[derive(clap::Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("output").required(true).multiple(true).args(["out", "frames", "record"])))]
pub struct RenderArgs {
    /// A scene or robot of the library (`robosim lib list`), `demo`, or a URDF file
    /// (`FILE.urdf`: its robot with visuals, at the origin).
    pub scene: String,
    /// The PNG to write (one image).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Joint values ROBOT=q1,q2,… (degrees for revolute joints, metres for prismatic); repeatable.
    #[arg(long = "joints", value_name = "ROBOT=Q,…")]
    pub joints: Vec<String>,
    /// Play a trajectory file into a robot, ROBOT=FILE (MD's file mode); repeatable. Needs --frames.
    #[arg(long, value_name = "ROBOT=FILE")]
    pub play: Vec<String>,
    /// With --play: the directory for frame-NNNNN.png, one per sample.
    #[arg(long)]
    pub frames: Option<PathBuf>,
    /// With --play: also record the playback to this MCAP file — joint states and link poses of
    /// every sample (not only every Nth), at the trajectory's dt — for Foxglove and other tools.
    #[arg(long, value_name = "FILE.mcap", requires = "play")]
    pub record: Option<PathBuf>,
    /// With --play: draw every Nth sample.
    #[arg(long, default_value_t = 1)]
    pub every: usize,
    /// Leave out every object of this name (and what is attached to it); repeatable.
    #[arg(long, value_name = "NAME")]
    pub hide: Vec<String>,
    /// Draw the ground grid (z = 0) and the world axes (x red, y green, z blue).
    #[arg(long)]
    pub grid: bool,
    /// Library files to add to the standard library.
    #[arg(long)]
    pub library: Vec<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct DisplayArgs {
    /// Draw to PNG files instead of a window (the default when there is no display server).
    #[arg(long)]
    pub headless: bool,
    /// Headless: the directory for latest.png and frames.jsonl (default <session>/display).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Headless: also keep every frame as frame-<version>.png (frame-<version>-sim<seq>.png
    /// when it shows the simulator's state).
    #[arg(long)]
    pub every_frame: bool,
    /// Stop after this many frames (headless) or presented frames (window).
    #[arg(long)]
    pub max_frames: Option<u64>,
    /// Play trajectory files into the session's robots, ROBOT=FILE; repeatable.
    #[arg(long, value_name = "ROBOT=FILE")]
    pub play: Vec<String>,
    /// Replay input: in a window `left`, `right`, `tab`, `1`–`9`, `e`, `o`, `f`, `g`,
    /// `click:X,Y`; headless `click:X,Y` (pixels of the --size image), one step after each
    /// drawn frame — a click commits the pick as the session's selection.
    #[arg(long)]
    pub script: Vec<String>,
    /// Leave out the ground grid and world axes (drawn by default; `G` toggles them in the
    /// window).
    #[arg(long)]
    pub no_grid: bool,
    #[command(flatten)]
    pub view: ViewArgs,
}

impl From<ViewArgs> for robosim_display::app::ViewArgs {
    fn from(a: ViewArgs) -> Self {
        robosim_display::app::ViewArgs {
            from: a.from,
            at: a.at,
            up: a.up,
            fov: a.fov,
            ortho: a.ortho,
            edges: a.edges,
            size: a.size,
            collisions: a.collisions,
        }
    }
}

impl From<RenderArgs> for robosim_display::app::RenderArgs {
    fn from(a: RenderArgs) -> Self {
        robosim_display::app::RenderArgs {
            scene: a.scene,
            out: a.out,
            view: a.view.into(),
            joints: a.joints,
            play: a.play,
            frames: a.frames,
            record: a.record,
            every: a.every,
            hide: a.hide,
            grid: a.grid,
            library: a.library,
            poses: Default::default(),
        }
    }
}

impl From<DisplayArgs> for robosim_display::app::DisplayArgs {
    fn from(a: DisplayArgs) -> Self {
        robosim_display::app::DisplayArgs {
            session: Default::default(),
            headless: a.headless,
            out: a.out,
            every_frame: a.every_frame,
            max_frames: a.max_frames,
            play: a.play,
            script: a.script,
            no_grid: a.no_grid,
            view: a.view.into(),
        }
    }
}

fn parse_vec3(s: &str) -> std::result::Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|f| {
            f.trim()
                .parse::<f64>()
                .map_err(|_| format!("{f:?} is not a number"))
        })
        .collect::<std::result::Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("{s:?}: three finite numbers x,y,z expected")),
    }
}

fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: WxH expected, e.g. 1280x1024"))?;
    let p = |t: &str| {
        t.trim()
            .parse::<u32>()
            .ok()
            .filter(|v| (1..=8192).contains(v))
            .ok_or_else(|| format!("{s:?}: sizes are 1..=8192 pixels"))
    };
    Ok((p(w)?, p(h)?))
}
