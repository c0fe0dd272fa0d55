//! What a scene declares it needs (DESIGN.md, "Scenes declare their effects"): kinematics, joint
//! limits, collision (mode, self-collision, continuous), dynamics (integrator, step, gravity),
//! encoder quantisation, signal logging. [`crate::Pipeline::build`] turns a declaration into the
//! per-step pipeline; nothing undeclared is built.
//!
//! JSON form (every field optional; unknown fields are refused):
//! ```json
//! {"dt": 0.001, "max_speed": 1.0,
//!  "kinematics": true, "joint_limits": true,
//!  "collision": {"enabled": true, "mode": "bbox"|"polygon"|"exact", "self": true,
//!                "continuous": false, "on_contact": "stop"|"report", "link_radius": 0.05},
//!  "dynamics": {"integrator": "euler"|"semi_implicit_euler"|"rk4"|"dopri5", "dt": 0.001,
//!               "rtol": null, "atol": null, "gravity": [0, 0, -9.81], "kp": 100, "kd": 20},
//!  "encoder": {"bits": 12},
//!  "logging": {"signals": ["t", "q", "qd", "qdd", "tau", "q_measured", "contact"],
//!              "every": 1, "path": "run.csv"}}
//! ```
//! Entry points: [`SceneEffects`], [`SceneEffects::from_json`].

use robosim_collision::Mode;
use serde::Deserialize;
use std::path::PathBuf;

/// A scene's effect declaration. `Default` declares nothing (the robot stands still).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneEffects {
    /// The step (s) when dynamics is not declared (kinematic motion); dynamics brings its own.
    pub dt: f64,
    /// Kinematic motion: joint speed limit (rad/s or m/s) towards a joint target.
    pub max_speed: f64,
    /// Kinematic motion towards joint targets and the link frames every step.
    pub kinematics: bool,
    /// Inelastic stops at the joint limits (`robosim_dynamics::apply_joint_stops`).
    pub joint_limits: bool,
    pub collision: Option<CollisionEffect>,
    pub dynamics: Option<DynamicsEffect>,
    pub encoder: Option<EncoderEffect>,
    pub logging: Option<LoggingEffect>,
}

impl Default for SceneEffects {
    fn default() -> Self {
        SceneEffects {
            dt: 1e-3,
            max_speed: 1.0,
            kinematics: false,
            joint_limits: false,
            collision: None,
            dynamics: None,
            encoder: None,
            logging: None,
        }
    }
}

/// What the collision stage does when it finds a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum OnContact {
    /// Put the robot back where it was at the start of the step, at rest (the seed's MOVEJ
    /// stops at the last safe step).
    #[default]
    Stop,
    /// Count and log the contact; the motion goes on.
    Report,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CollisionEffect {
    /// `false`: declared off — not in the pipeline at all.
    pub enabled: bool,
    pub mode: Mode,
    /// Self-collision between non-adjacent links.
    #[serde(rename = "self")]
    pub self_collision: bool,
    /// Sweep the motion of each step (conservative advancement, exact distances) instead of
    /// checking only its end.
    pub continuous: bool,
    pub on_contact: OnContact,
    /// Radius (m) of the DH-segment link solids used when the robot has no link geometry.
    pub link_radius: f64,
}

impl Default for CollisionEffect {
    fn default() -> Self {
        CollisionEffect {
            enabled: true,
            mode: Mode::BBox,
            self_collision: true,
            continuous: false,
            on_contact: OnContact::Stop,
            link_radius: 0.05,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsEffect {
    /// `euler`, `semi_implicit_euler`, `rk4` or `dopri5`.
    pub integrator: String,
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
            integrator: "semi_implicit_euler".into(),
            dt: 1e-3,
            rtol: None,
            atol: None,
            gravity: None,
            kp: 100.0,
            kd: 20.0,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderEffect {
    /// Counts per revolution (revolute) or per joint range (prismatic) = 2^bits.
    pub bits: u32,
}

/// A signal the logging stage can record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Signal {
    /// Simulation time: always logged, as the first column `t_s` (declaring it adds nothing).
    T,
    Q,
    Qd,
    Qdd,
    Tau,
    QMeasured,
    Contact,
}

impl Signal {
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
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoggingEffect {
    pub signals: Vec<Signal>,
    /// Log every `every`-th step.
    pub every: u32,
    /// CSV file to write; `None` keeps the rows in memory ([`crate::Pipeline::log`]).
    pub path: Option<PathBuf>,
}

impl Default for LoggingEffect {
    fn default() -> Self {
        LoggingEffect {
            signals: vec![Signal::T, Signal::Q],
            every: 1,
            path: None,
        }
    }
}

/// A declaration that cannot be built: `field` names it (`dynamics.dt`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("scene effects, `{field}`: {reason}")]
pub struct EffectsError {
    pub field: String,
    pub reason: String,
}

impl SceneEffects {
    /// Parses the JSON form; the error names line and column (from serde_json) or the field.
    pub fn from_json(text: &str) -> Result<SceneEffects, EffectsError> {
        let effects: SceneEffects = serde_json::from_str(text).map_err(|e| EffectsError {
            field: format!("line {} column {}", e.line(), e.column()),
            reason: e.to_string(),
        })?;
        Ok(effects)
    }
}
