//! Inverse kinematics behind one trait, chosen per robot (the seed's SET_INV, §2.4–2.5).
//!
//! One solver per file, a dispatcher on top (the parry `QueryDispatcher` shape):
//! * [`newton`] — Newton–Raphson with LU solves, the seed's default (§2.5);
//! * [`dls`] — damped least squares (Levenberg–Marquardt with Sugihara's error-adaptive
//!   damping), joint limits, seeded random restarts, per-axis tolerances;
//! * [`analytic`] — all (up to 8) closed-form solutions of 6R arms with a spherical wrist (the
//!   PUMA 560 family, any link lengths and twist signs) and of RRP arms with a spherical wrist
//!   (the Stanford arm), branch-labelled; [`parallel`] — the same for the UR type (axes 2, 3, 4
//!   parallel);
//! * [`hybrid`] — the seed's five-joints-analytic, one-numeric method for wrists with offsets;
//! * [`family`] — recognising which closed form fits a robot (the seed's proposed extension),
//!   from DH rows or, through [`equivalent`], from general joints' placements and axes.
//!
//! Entry points: [`solve`] with a [`Method`] (use [`Method::Auto`] to let the geometry
//! decide), the [`IkSolver`] trait, [`IkOptions`], [`IkResult`], [`IkError`].

pub mod analytic;
mod closed_form;
pub mod dls;
pub mod equivalent;
pub mod family;
pub mod hybrid;
pub mod newton;
pub mod parallel;

use crate::kinematic_model::KinematicModel;
use crate::model::{JointType, ModelError, Robot};
use crate::pose::{Residual, Tolerances, is_rigid, pose_error, to_target_frame};
use nalgebra::Matrix4;
use std::f64::consts::PI;

/// Which solver to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    Analytic,
    Newton,
    Dls,
    Hybrid,
    /// Analytic if the geometry fits a spherical-wrist family (PUMA-like 6R or Stanford-like
    /// RRP), hybrid if it fits the offset-wrist family, damped least squares otherwise.
    Auto,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Analytic => "analytic",
            Method::Newton => "newton",
            Method::Dls => "dls",
            Method::Hybrid => "hybrid",
            Method::Auto => "auto",
        }
    }

    pub fn parse(s: &str) -> Option<Method> {
        Some(match s {
            "analytic" => Method::Analytic,
            "newton" => Method::Newton,
            "dls" => Method::Dls,
            "hybrid" => Method::Hybrid,
            "auto" => Method::Auto,
            _ => return None,
        })
    }
}

/// What the caller asks of a solve. `Default` gives 1e-9 m / 1e-9 rad, one solution, 30
/// iterations per start, 200 restarts, seed 0, limits respected.
#[derive(Debug, Clone, PartialEq)]
pub struct IkOptions {
    pub tolerances: Tolerances,
    /// Start (numeric) or reference (analytic: picks the single answer, the free joint at a
    /// singularity, and the 2π-equivalent of each revolute joint). Length `robot.dof()`.
    pub q0: Option<Vec<f64>>,
    /// Return every solution (closed-form and hybrid methods); otherwise the best one.
    pub all: bool,
    /// Iterations per start (numeric methods).
    pub max_iterations: usize,
    /// Random restarts after the first start (damped least squares).
    pub restarts: usize,
    /// Seed of the restart generator (ChaCha8): equal seeds give equal answers.
    pub seed: u64,
    /// Keep numeric iterates within the joint limits (damped least squares).
    pub respect_limits: bool,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            tolerances: Tolerances::default(),
            q0: None,
            all: false,
            max_iterations: 30,
            restarts: 200,
            seed: 0,
            respect_limits: true,
        }
    }
}

/// Shoulder branch: `Right` is θ1 = ψ + asin(k), the wrist centre ahead of the waist axis in
/// frame 1's x direction; `Left` the other (Corke's `r`/`l` for the PUMA 560).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Shoulder {
    Left,
    Right,
}

/// Elbow branch (Corke's `u`/`d` for the PUMA 560); see [`analytic`] for the rule. For an RRP
/// (Stanford) arm, `Up` is the boom extended forwards (d3 + d4 ≥ 0), `Down` reversed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Elbow {
    Up,
    Down,
}

/// Wrist branch (Corke's `n`/`f`): `Flip` is the solution (θ4 + π, −θ5, θ6 + π) of `NoFlip`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wrist {
    NoFlip,
    Flip,
}

/// The branch of a closed-form solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Branch {
    pub shoulder: Shoulder,
    pub elbow: Elbow,
    pub wrist: Wrist,
}

impl Branch {
    /// All eight, in Corke's order l/r, u/d, n/f.
    pub const ALL: [Branch; 8] = {
        use Elbow::*;
        use Shoulder::*;
        use Wrist::*;
        [
            Branch {
                shoulder: Left,
                elbow: Up,
                wrist: NoFlip,
            },
            Branch {
                shoulder: Left,
                elbow: Up,
                wrist: Flip,
            },
            Branch {
                shoulder: Left,
                elbow: Down,
                wrist: NoFlip,
            },
            Branch {
                shoulder: Left,
                elbow: Down,
                wrist: Flip,
            },
            Branch {
                shoulder: Right,
                elbow: Up,
                wrist: NoFlip,
            },
            Branch {
                shoulder: Right,
                elbow: Up,
                wrist: Flip,
            },
            Branch {
                shoulder: Right,
                elbow: Down,
                wrist: NoFlip,
            },
            Branch {
                shoulder: Right,
                elbow: Down,
                wrist: Flip,
            },
        ]
    };

    /// Corke's three-letter label, e.g. `"lun"`.
    pub fn label(&self) -> String {
        let s = match self.shoulder {
            Shoulder::Left => 'l',
            Shoulder::Right => 'r',
        };
        let e = match self.elbow {
            Elbow::Up => 'u',
            Elbow::Down => 'd',
        };
        let w = match self.wrist {
            Wrist::NoFlip => 'n',
            Wrist::Flip => 'f',
        };
        [s, e, w].iter().collect()
    }
}

/// Something a solver had to decide or round, stated with the solution.
#[derive(Debug, Clone, PartialEq)]
pub enum Note {
    /// sin θ5 ≈ 0: only θ4 ± θ6 is determined. Convention: θ4 is taken from the reference
    /// (`q0`, else 0; +π for the flipped branch) and θ6 absorbs the rest.
    WristSingular,
    /// The wrist centre is on the waist axis (and there is no shoulder offset): θ1 is free.
    /// Convention: θ1 from the reference (`q0`, else 0; +π for the left branch).
    ShoulderSingular,
    /// The elbow equation's cosine was |K| = 1 + `excess` > 1 by rounding (elbow straight or
    /// folded, target on the workspace boundary) and was clamped to ±1.
    ElbowClamped { excess: f64 },
    /// The shoulder equation's sine was clamped to ±1 by `excess` (wrist centre at the offset
    /// distance from the waist axis).
    ShoulderClamped { excess: f64 },
}

/// One joint vector that reaches (or, if `converged` is false, best approaches) the target.
#[derive(Debug, Clone, PartialEq)]
pub struct IkSolution {
    /// Joint values, rad or m, `robot.dof()` of them.
    pub q: Vec<f64>,
    /// Closed-form branch, when the method has branches.
    pub branch: Option<Branch>,
    /// FK(q) against the target.
    pub residual: Residual,
    /// Whether the residual is within the requested per-axis tolerances.
    pub converged: bool,
    /// Whether every joint is within its limits (revolute joints are first moved by 2π into
    /// their limits where that is possible; [`LIMIT_SLACK`] allowed for rounding).
    pub within_limits: bool,
    /// Iterations spent (0 for closed forms; the scalar root-finder's for the hybrid).
    pub iterations: usize,
    pub notes: Vec<Note>,
}

/// The answer of a solve.
#[derive(Debug, Clone, PartialEq)]
pub struct IkResult {
    /// The method that produced the solutions (never `Auto`).
    pub method: Method,
    pub solutions: Vec<IkSolution>,
}

/// Why a solve produced no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    /// The robot or `q0` is invalid.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// The target is not a finite rigid transform.
    #[error(
        "target pose is not a rigid transform (finite, orthonormal rotation, last row 0 0 0 1)"
    )]
    BadTarget,
    /// An option is out of range.
    #[error("option `{field}`: {reason}")]
    BadOptions { field: &'static str, reason: String },
    /// The geometry proves the pose cannot be reached (closed-form and hybrid methods).
    #[error("unreachable: {reason}")]
    Unreachable { reason: String },
    /// The method does not apply to this robot (e.g. analytic on a 7-DOF arm).
    #[error("{method} does not apply to this robot: {reason}")]
    NotApplicable {
        method: &'static str,
        reason: String,
    },
    /// A numeric method ran out of iterations and restarts; `best` is the closest it came.
    #[error("{method} did not converge after {starts} start(s); best residual {:.3e} m, {:.3e} rad",
            best.residual.position, best.residual.orientation)]
    NotConverged {
        method: &'static str,
        starts: usize,
        best: Box<IkSolution>,
    },
}

/// An inverse-kinematics method. Implementations are stateless or hold per-robot precomputation.
pub trait IkSolver {
    fn method(&self) -> Method;
    /// Solves for `target` (world frame, `T_ee` convention of DESIGN.md). The robot is assumed
    /// validated; `target` and `options` are checked by [`solve`].
    fn solve(
        &self,
        robot: &Robot,
        target: &Matrix4<f64>,
        options: &IkOptions,
    ) -> Result<IkResult, IkError>;
}

/// Checks inputs, picks the solver for `method` and solves.
pub fn solve(
    robot: &Robot,
    target: &Matrix4<f64>,
    method: Method,
    options: &IkOptions,
) -> Result<IkResult, IkError> {
    robot.validate()?;
    robot.refuse_spherical("inverse kinematics")?;
    if !is_rigid(target) {
        return Err(IkError::BadTarget);
    }
    if let Some(q0) = &options.q0 {
        robot.check_q(q0)?;
    }
    for t in options.tolerances.as_array() {
        if t.is_nan() || t <= 0.0 {
            return Err(IkError::BadOptions {
                field: "tolerances",
                reason: format!("{t} is not a positive tolerance"),
            });
        }
    }
    match method {
        Method::Analytic => analytic::Analytic.solve(robot, target, options),
        Method::Hybrid => hybrid::Hybrid.solve(robot, target, options),
        Method::Newton => newton::Newton.solve(robot, target, options),
        Method::Dls => dls::Dls::default().solve(robot, target, options),
        Method::Auto => match family::recognise(robot) {
            family::Family::SphericalWrist(_)
            | family::Family::BoomWrist(_)
            | family::Family::ThreeParallel(_) => analytic::Analytic.solve(robot, target, options),
            family::Family::OffsetWrist(_) => hybrid::Hybrid.solve(robot, target, options),
            family::Family::General(_) => dls::Dls::default().solve(robot, target, options),
        },
    }
}

/// Builds a solution record for `q`: residual by FK (on `model`, `robot` compiled once per
/// solve), convergence by the tolerances, limits after moving revolute joints by 2π towards
/// `reference` and into their limits where possible.
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish(
    robot: &Robot,
    model: &KinematicModel,
    target: &Matrix4<f64>,
    options: &IkOptions,
    mut q: Vec<f64>,
    branch: Option<Branch>,
    iterations: usize,
    notes: Vec<Note>,
) -> IkSolution {
    let within_limits = fit_limits(robot, &mut q, options.q0.as_deref());
    let t = model.forward(&q);
    let e = pose_error(&t, target);
    let residual = Residual {
        position: e.fixed_rows::<3>(0).norm(),
        orientation: e.fixed_rows::<3>(3).norm(),
    };
    let converged = options.tolerances.accept(&to_target_frame(&e, target));
    IkSolution {
        residual,
        converged,
        within_limits,
        q,
        branch,
        iterations,
        notes,
    }
}

/// Slack on joint limits for values that rounding put a hair outside (rad or m).
pub const LIMIT_SLACK: f64 = 1e-12;

/// Moves each revolute joint by multiples of 2π: into its limits if possible, and then as close
/// to `reference` as the limits allow (or into (−π, π] without a reference). Returns whether
/// every joint ends within limits.
pub(crate) fn fit_limits(robot: &Robot, q: &mut [f64], reference: Option<&[f64]>) -> bool {
    let mut ok = true;
    for (j, (joint, qj)) in robot.joints.iter().zip(q.iter_mut()).enumerate() {
        let [lo, hi] = [joint.qlim[0] - LIMIT_SLACK, joint.qlim[1] + LIMIT_SLACK];
        if joint.joint_type == JointType::Revolute {
            let r = reference.map_or(0.0, |r| r[j]);
            // The 2π-equivalent nearest the reference, then the nearest inside the limits.
            let mut best = *qj + ((r - *qj) / (2.0 * PI)).round() * 2.0 * PI;
            if !(lo..=hi).contains(&best) {
                let mut candidate = None;
                let k0 = ((lo - *qj) / (2.0 * PI)).ceil() as i64;
                let k1 = ((hi - *qj) / (2.0 * PI)).floor() as i64;
                // Bounded: at most a handful of turns for finite limits; limits wider than 64
                // turns are treated as unlimited for the search.
                for k in k0.max(-64)..=k1.min(64) {
                    let c = *qj + k as f64 * 2.0 * PI;
                    if candidate.is_none_or(|b: f64| (c - r).abs() < (b - r).abs()) {
                        candidate = Some(c);
                    }
                }
                if let Some(c) = candidate {
                    best = c;
                }
            }
            *qj = best;
        }
        if !(lo..=hi).contains(qj) {
            ok = false;
        }
    }
    ok
}

/// Wraps an angle into (−π, π].
pub(crate) fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
}
