//! [`Options`]: what a scene declares it needs (DESIGN.md, "Scenes declare their effects"), typed
//! once at the edge (MuJoCo's `mjOption`). Two readers fill it — the Library Space's `effects
//! { … }` block and the simulator's JSON form ([`Options::from_json`]) — and everything after
//! reads the typed fields: the simulator pipeline (kinematics, joint limits, collision, dynamics,
//! encoder, logging), the daemon's scene-level stages (orbit, sun tracking, power, ORU swap) and
//! `robosim up` (automation). What is not declared is `None`/`false` and costs nothing.
//!
//! JSON form (every field optional; unknown fields are refused):
//! ```json
//! {"dt": 0.001, "max_speed": 1.0,
//!  "kinematics": true, "joint_limits": true,
//!  "collision": {"enabled": true, "mode": "bbox"|"polygon"|"exact", "self": true,
//!                "continuous": false, "on_contact": "stop"|"report", "link_radius": 0.05,
//!                "tolerance": "certified"|1e-6},
//!  "dynamics": {"integrator": "euler"|"semi_implicit_euler"|"rk4"|"dopri5", "dt": 0.001,
//!               "rtol": null, "atol": null, "gravity": [0, 0, -9.81], "kp": 100, "kd": 20},
//!  "encoder": {"bits": 12},
//!  "logging": {"signals": ["t", "q", "qd", "qdd", "tau", "q_measured", "contact"],
//!              "every": 1, "path": "run.csv"},
//!  "orbit": {"altitude_m": 400000, "beta_rad": 0}, "sun_tracking": false,
//!  "power": {"efficiency": 0.14}, "oru_swap": {"servicer": "s", "spare": "x", "start_s": 0},
//!  "automation": {"model": "eclss", "time_scale": 1},
//!  "attitude": {"cmgs": 4, "cmg_momentum_nms": 4760, "cmg_torque_nm": 258, "saturation": 0.8,
//!               "dump_to": 0.2, "hold": "lvlh"|"tea", "drag_coefficient": 2.2}}
//! ```

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The collision mode: the collision core's enum (`bbox`, `polygon`, `exact`).
pub use robosim_collision::Mode as CollisionMode;
/// The exact mode's distance tolerance: the collision core's type.
pub use robosim_collision::Tolerance as CollisionTolerance;
/// The integrator of the dynamics effect: the dynamics core's enum, the one type for it
/// (its names: `euler`, `semi_implicit_euler`, `rk4`, `dopri5`).
pub use robosim_dynamics::Integrator;

/// A scene's effect declaration. `Default` declares nothing (the robot stands still); the
/// Library Space starts from kinematics on (a scene has kinematics unless it says `off`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Options {
    /// The step (s) when dynamics is not declared (kinematic motion); dynamics brings its own.
    /// The library's `kinematics { step: 100 ms }`.
    pub dt: f64,
    /// Kinematic motion: joint speed limit (rad/s or m/s) towards a joint target.
    pub max_speed: f64,
    /// Kinematic motion towards joint targets and the link frames every step.
    pub kinematics: bool,
    /// Inelastic stops at the joint limits (`robosim_dynamics::apply_joint_stops`).
    pub joint_limits: bool,
    pub collision: Option<CollisionEffect>,
    pub dynamics: Option<DynamicsEffect>,
    /// Encoder quantisation of the joint readings (seed §2.7).
    pub encoder: Option<EncoderEffect>,
    pub logging: Option<LoggingEffect>,
    /// A circular Earth orbit the scene flies (the sun vector and eclipses follow from it).
    pub orbit: Option<OrbitEffect>,
    /// Solar arrays turn their gimbals to face the sun (needs `orbit`).
    pub sun_tracking: bool,
    /// Electrical power from the arrays and a battery (needs `orbit`).
    pub power: Option<PowerEffect>,
    /// The automation layer's plant (a fault model whose faults ring alarms), run beside the
    /// simulator as its own process (`robosim automation`, started by `robosim up`).
    pub automation: Option<AutomationEffect>,
    /// A manipulator task: the servicer swaps an orbital replacement unit (ORU).
    pub oru_swap: Option<OruSwapEffect>,
    /// The station's attitude and momentum: rigid-body dynamics under gravity-gradient and
    /// drag torques, held by a control moment gyroscope cluster, desaturated by thrusters
    /// (needs `orbit`; `robosim_simulator::attitude`).
    pub attitude: Option<AttitudeEffect>,
    /// Joint friction in the dynamics stage (issue 36): the robot's per-joint viscous and
    /// Coulomb data act only when declared (`robosim_dynamics::friction`).
    pub joint_friction: Option<JointFrictionEffect>,
    /// The station's loads as consumers with priorities (ECLSS, experiments, servicer;
    /// `robosim_simulator::consumers`) drawing on the `power` effect's battery, each served,
    /// reduced or shed as commanded (`consumers: on`; needs `power`; the simulator daemon's
    /// operations stage, issue 38 item 7).
    pub consumers: bool,
}

/// The joint friction effect: which of the robot's friction data act in the dynamics stage.
/// `Default`: viscous on, Coulomb stick–slip with a 1e-6 rad/s (m/s) band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointFrictionEffect {
    pub viscous: bool,
    pub coulomb: CoulombModel,
    /// The stick–slip band or the regularisation velocity (rad/s or m/s).
    pub velocity: f64,
}

impl Default for JointFrictionEffect {
    fn default() -> Self {
        JointFrictionEffect {
            viscous: true,
            coulomb: CoulombModel::StickSlip,
            velocity: 1e-6,
        }
    }
}

/// The Coulomb model of [`JointFrictionEffect`] (`robosim_dynamics::Coulomb`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CoulombModel {
    Off,
    Regularised,
    StickSlip,
}

impl JointFrictionEffect {
    /// The dynamics crate's settings.
    pub fn to_dynamics(&self) -> robosim_dynamics::JointFriction {
        use robosim_dynamics::Coulomb;
        robosim_dynamics::JointFriction {
            viscous: self.viscous,
            coulomb: match self.coulomb {
                CoulombModel::Off => Coulomb::Off,
                CoulombModel::Regularised => Coulomb::Regularised {
                    velocity: self.velocity,
                },
                CoulombModel::StickSlip => Coulomb::StickSlip {
                    velocity: self.velocity,
                },
            },
        }
    }
}

impl Default for Options {
    fn default() -> Self {
        Options {
            dt: 1e-3,
            max_speed: 1.0,
            kinematics: false,
            joint_limits: false,
            collision: None,
            dynamics: None,
            encoder: None,
            logging: None,
            orbit: None,
            sun_tracking: false,
            power: None,
            automation: None,
            oru_swap: None,
            attitude: None,
            joint_friction: None,
            consumers: false,
        }
    }
}

/// What the collision stage does when it finds a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum OnContact {
    /// Put the robot back where it was at the start of the step, at rest (the seed's MOVEJ
    /// stops at the last safe step).
    #[default]
    Stop,
    /// Count and log the contact; the motion goes on.
    Report,
}

impl OnContact {
    pub fn name(self) -> &'static str {
        match self {
            OnContact::Stop => "stop",
            OnContact::Report => "report",
        }
    }
}

/// The collision effect. `Default` is the simulator JSON form's (bbox, self on); the library's
/// `collision: on` is polygon with self-collision off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CollisionEffect {
    /// `false`: declared off — not in the pipeline at all.
    pub enabled: bool,
    pub mode: CollisionMode,
    /// Self-collision between non-adjacent links of one robot.
    #[serde(rename = "self")]
    pub self_collision: bool,
    /// Sweep the motion of each step (conservative advancement, exact distances) instead of
    /// checking only its end.
    pub continuous: bool,
    pub on_contact: OnContact,
    /// Radius (m) of the DH-segment link solids used when the robot has no link geometry.
    pub link_radius: f64,
    /// How closely exact distances are computed (the continuous sweep's): `"certified"` or a
    /// GJK tolerance in metres (`robosim_collision::Tolerance`). Verdicts stay certified.
    pub tolerance: CollisionTolerance,
}

impl Default for CollisionEffect {
    fn default() -> Self {
        CollisionEffect {
            enabled: true,
            mode: CollisionMode::BBox,
            self_collision: true,
            continuous: false,
            on_contact: OnContact::Stop,
            link_radius: 0.05,
            tolerance: CollisionTolerance::Certified,
        }
    }
}

/// The dynamics effect. `Default` is the simulator JSON form's (semi-implicit Euler, the
/// robot's gravity); the library's `dynamics: on` is RK4 with gravity −9.81 m/s² along z.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsEffect {
    #[serde(with = "integrator_name")]
    pub integrator: Integrator,
    /// The pipeline step (s). With `rtol`/`atol` (dopri5) the integrator takes its own steps
    /// inside each pipeline step.
    pub dt: f64,
    pub rtol: Option<f64>,
    pub atol: Option<f64>,
    /// Overrides the robot's gravity (m/s², world frame).
    pub gravity: Option<[f64; 3]>,
    /// Joint-target controller (computed torque): `τ = RNEA(q, q̇, kp (q* − q) − kd q̇)`, gains in
    /// 1/s² and 1/s (defaults: natural frequency 10 rad/s, critically damped).
    pub kp: f64,
    pub kd: f64,
}

impl Default for DynamicsEffect {
    fn default() -> Self {
        DynamicsEffect {
            integrator: Integrator::SemiImplicitEuler,
            dt: 1e-3,
            rtol: None,
            atol: None,
            gravity: None,
            kp: 100.0,
            kd: 20.0,
        }
    }
}

/// The integrator by its name (`Integrator::name`), in JSON and in the library's encoding.
mod integrator_name {
    use super::Integrator;
    use serde::{Deserialize, Deserializer, Serializer, de::Error};

    pub fn serialize<S: Serializer>(i: &Integrator, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(i.name())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Integrator, D::Error> {
        let name = String::deserialize(d)?;
        Integrator::from_name(&name).ok_or_else(|| {
            D::Error::custom(format!(
                "unknown integrator {name:?} (euler | semi_implicit_euler | rk4 | dopri5)"
            ))
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderEffect {
    /// Counts per revolution (revolute) or per joint range (prismatic) = 2^bits.
    pub bits: u32,
}

/// A signal the logging stage can record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Signal {
    /// Simulation time: always logged, as the first column `t_s` (declaring it adds nothing).
    T,
    Q,
    Qd,
    Qdd,
    Tau,
    QMeasured,
    /// The collision verdict (the library language also says `contacts`).
    #[serde(alias = "contacts")]
    Contact,
}

impl Signal {
    pub const ALL: [Signal; 7] = [
        Signal::T,
        Signal::Q,
        Signal::Qd,
        Signal::Qdd,
        Signal::Tau,
        Signal::QMeasured,
        Signal::Contact,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Signal::T => "t",
            Signal::Q => "q",
            Signal::Qd => "qd",
            Signal::Qdd => "qdd",
            Signal::Tau => "tau",
            Signal::QMeasured => "q_measured",
            Signal::Contact => "contact",
        }
    }

    /// Inverse of [`Signal::name`]; `contacts` is `contact` too.
    pub fn from_name(name: &str) -> Option<Signal> {
        match name {
            "contacts" => Some(Signal::Contact),
            _ => Signal::ALL.into_iter().find(|s| s.name() == name),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoggingEffect {
    pub signals: Vec<Signal>,
    /// Log every `every`-th step.
    pub every: u32,
    /// CSV file to write; `None` keeps the rows in memory (the simulator daemon puts a
    /// declared scene's log in the session's run directory).
    pub path: Option<PathBuf>,
    /// Signals the scene asked for that the simulator does not log (the library language
    /// takes any name, e.g. `energy`): said as a warning when the pipelines are built.
    pub unsupported: Vec<String>,
}

impl LoggingEffect {
    /// Every signal name the declaration gave: the logged ones, then the unsupported ones.
    pub fn names(&self) -> Vec<&str> {
        let logged = self.signals.iter().map(|s| s.name());
        logged
            .chain(self.unsupported.iter().map(String::as_str))
            .collect()
    }
}

impl Default for LoggingEffect {
    fn default() -> Self {
        LoggingEffect {
            signals: vec![Signal::T, Signal::Q],
            every: 1,
            path: None,
            unsupported: Vec::new(),
        }
    }
}

/// `oru_swap { servicer: "servicer", spare: "spare_oru", start: 300 s }`: the placed robot
/// `servicer` takes the failed ORU (the box part named `oru…` on a robot's link) off its robot,
/// sets it down beside the placed solid `spare`, and bolts the spare in its place, starting at
/// `start` (the plan: `robosim_simulator::swap`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OruSwapEffect {
    /// The place name of the manipulator doing the swap.
    pub servicer: String,
    /// The place name of the spare ORU (a solid with a box part named `oru…`).
    pub spare: String,
    /// When the task starts, s (≥ 0).
    pub start_s: f64,
}

/// `automation { model: "eclss", time_scale: 60 }` (or `automation: on`, the ECLSS at the wall
/// clock's pace): the scene's fault-monitoring plant. Not a simulator stage: `robosim up SCENE`
/// starts `robosim automation --model MODEL --time-scale X` as one more component process.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AutomationEffect {
    /// The fault model: a shipped name (`eclss`) or a model file (`robosim diag check`).
    pub model: String,
    /// Plant seconds per wall-clock second (> 0).
    pub time_scale: f64,
}

impl Default for AutomationEffect {
    fn default() -> Self {
        AutomationEffect {
            model: "eclss".into(),
            time_scale: 1.0,
        }
    }
}

/// `orbit { altitude: 400 km, beta: 0 deg }`: a circular orbit about a spherical Earth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitEffect {
    /// Height above the Earth's mean equatorial radius, m (> 0).
    pub altitude_m: f64,
    /// Angle between the orbit plane and the sun vector, rad, in [−90°, 90°].
    pub beta_rad: f64,
}

/// `power { efficiency: 0.14 }`: array power = Σ projected area × efficiency × solar flux.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowerEffect {
    /// Solar-cell efficiency, in (0, 1].
    pub efficiency: f64,
}

/// The attitude the CMGs hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum AttitudeHold {
    /// The local-vertical local-horizontal frame (body x ram, y orbit normal, z zenith).
    #[default]
    Lvlh,
    /// A torque-equilibrium attitude: LVLH pitched about the orbit normal so that the
    /// secular (orbit-normal) torque of gravity gradient and drag vanishes at the start.
    Tea,
}

impl AttitudeHold {
    pub fn name(self) -> &'static str {
        match self {
            AttitudeHold::Lvlh => "lvlh",
            AttitudeHold::Tea => "tea",
        }
    }
}

/// `attitude { cmgs: 4, cmg_momentum: 4760 kg*m^2/s, saturation: 0.8, hold: lvlh }`: the
/// station's attitude and CMG momentum. Defaults: the ISS's four double-gimbal CMGs of
/// 4,760 N·m·s and 258 N·m each, desaturation at 80 % of the cluster's capacity down to 20 %,
/// LVLH hold, drag coefficient 2.2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AttitudeEffect {
    /// Number of CMGs in the cluster (≥ 1).
    pub cmgs: u32,
    /// Angular momentum of one CMG's wheel, N·m·s (> 0).
    pub cmg_momentum_nms: f64,
    /// Largest output torque of one CMG, N·m (> 0).
    pub cmg_torque_nm: f64,
    /// Fraction of the cluster's capacity at which a desaturation starts, in (0, 1).
    pub saturation: f64,
    /// Fraction of the capacity a desaturation dumps the momentum down to, in [0, saturation).
    pub dump_to: f64,
    pub hold: AttitudeHold,
    /// Drag coefficient of the projected area (free molecular flow), > 0.
    pub drag_coefficient: f64,
}

impl Default for AttitudeEffect {
    fn default() -> Self {
        AttitudeEffect {
            cmgs: 4,
            cmg_momentum_nms: 4760.0,
            cmg_torque_nm: 258.0,
            saturation: 0.8,
            dump_to: 0.2,
            hold: AttitudeHold::Lvlh,
            drag_coefficient: 2.2,
        }
    }
}

/// A declaration that cannot be built: `field` names it (`dynamics.dt`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("scene effects, `{field}`: {reason}")]
pub struct OptionsError {
    pub field: String,
    pub reason: String,
}

impl Options {
    /// Parses the JSON form; the error names the field (`dynamics.integrator`; `.` for the
    /// top level) and serde_json's reason with its line and column.
    pub fn from_json(text: &str) -> Result<Options, OptionsError> {
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| OptionsError {
            field: e.path().to_string(),
            reason: e.inner().to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_json_form_types_the_integrator_once_and_refuses_an_unknown_one() {
        let o = Options::from_json(r#"{"dynamics": {"integrator": "rk4", "dt": 0.002}}"#)
            .expect("parses");
        let d = o.dynamics.expect("declared");
        assert_eq!((d.integrator, d.dt), (Integrator::Rk4, 0.002));
        let e =
            Options::from_json(r#"{"dynamics": {"integrator": "leapfrog"}}"#).expect_err("refused");
        assert!(e.reason.contains("unknown integrator \"leapfrog\""), "{e}");
        assert_eq!(e.field, "dynamics.integrator", "{e}");
        assert!(e.reason.contains("line 1 column"), "{e}");
    }

    #[test]
    fn options_read_back_what_they_wrote() {
        let o = Options {
            kinematics: true,
            collision: Some(CollisionEffect {
                mode: CollisionMode::Polygon,
                ..CollisionEffect::default()
            }),
            dynamics: Some(DynamicsEffect {
                integrator: Integrator::Dopri5,
                rtol: Some(1e-8),
                gravity: Some([0.0, 0.0, -1.62]),
                ..DynamicsEffect::default()
            }),
            encoder: Some(EncoderEffect { bits: 12 }),
            logging: Some(LoggingEffect {
                signals: vec![Signal::Q, Signal::Contact],
                unsupported: vec!["energy".into()],
                ..LoggingEffect::default()
            }),
            orbit: Some(OrbitEffect {
                altitude_m: 400e3,
                beta_rad: 0.25,
            }),
            oru_swap: Some(OruSwapEffect {
                servicer: "s".into(),
                spare: "x".into(),
                start_s: 3.0,
            }),
            ..Options::default()
        };
        let text = serde_json::to_string(&o).expect("writes");
        assert_eq!(Options::from_json(&text), Ok(o));
    }

    #[test]
    fn signals_read_their_library_names() {
        for s in Signal::ALL {
            assert_eq!(Signal::from_name(s.name()), Some(s));
        }
        assert_eq!(Signal::from_name("contacts"), Some(Signal::Contact));
        assert_eq!(Signal::from_name("energy"), None);
    }
}
