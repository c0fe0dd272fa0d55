//! The dynamics stage: one pipeline step of forward dynamics and integration
//! (`robosim_dynamics::Stepper`) under the commanded torques, or under a computed-torque
//! controller towards joint targets, `τ = RNEA(q, q̇, kp (q* − q) − kd q̇)` (the closed loop is
//! `ë + kd ė + kp e = 0` per joint when the model is exact). Depends on q, q̇ and the command.

use crate::effects::{DynamicsEffect, EffectsError};
use crate::pipeline::{self, Command, Stage, StepError};
use nalgebra::{DVector, Vector3};
use robosim_dynamics::{Data, Integrator, IntegratorConfig, Model, StepSize, Stepper, rnea};
use robosim_kinematics::Robot;

pub struct DynamicsStage {
    model: Model,
    data: Data,
    stepper: Stepper,
    tau: DVector<f64>,
    qdd_des: DVector<f64>,
    kp: f64,
    kd: f64,
    summary: String,
}

impl DynamicsStage {
    pub fn new(robot: &Robot, d: &DynamicsEffect) -> Result<Self, EffectsError> {
        let bad = |field: &str, reason: String| EffectsError {
            field: format!("dynamics.{field}"),
            reason,
        };
        let integrator = Integrator::from_name(&d.integrator).ok_or_else(|| {
            bad(
                "integrator",
                format!(
                    "unknown integrator {:?} (euler | semi_implicit_euler | rk4 | dopri5)",
                    d.integrator
                ),
            )
        })?;
        let mut robot = robot.clone();
        if let Some(g) = d.gravity {
            robot.gravity = Vector3::from(g);
        }
        let model = Model::new(&robot).map_err(|e| bad("robot", e.to_string()))?;
        if !(d.dt > 0.0 && d.dt.is_finite()) {
            return Err(bad(
                "dt",
                format!("must be a positive number of seconds, got {}", d.dt),
            ));
        }
        let step = match (d.rtol, d.atol) {
            (None, None) => StepSize::Fixed(d.dt),
            (r, a) => StepSize::Adaptive {
                rtol: r.unwrap_or(1e-6),
                atol: a.unwrap_or(1e-9),
            },
        };
        let config = IntegratorConfig {
            integrator,
            step,
            joint_stops: false,
            max_steps: 1_000_000,
        };
        let stepper = Stepper::new(&model, config).map_err(|e| bad("integrator", e.to_string()))?;
        if !(d.kp >= 0.0 && d.kd >= 0.0 && d.kp.is_finite() && d.kd.is_finite()) {
            return Err(bad(
                "kp",
                format!(
                    "gains must be finite and non-negative, got kp = {}, kd = {}",
                    d.kp, d.kd
                ),
            ));
        }
        let g = robot.gravity;
        let summary = match step {
            StepSize::Fixed(dt) => format!(
                "{}, dt = {dt} s, gravity [{}, {}, {}]",
                integrator.name(),
                g.x,
                g.y,
                g.z
            ),
            StepSize::Adaptive { rtol, atol } => format!(
                "{}, rtol {rtol:e}, atol {atol:e} within dt = {} s, gravity [{}, {}, {}]",
                integrator.name(),
                d.dt,
                g.x,
                g.y,
                g.z
            ),
        };
        let n = model.dof();
        Ok(DynamicsStage {
            data: Data::new(&model),
            model,
            stepper,
            tau: DVector::zeros(n),
            qdd_des: DVector::zeros(n),
            kp: d.kp,
            kd: d.kd,
            summary,
        })
    }
}

impl Stage for DynamicsStage {
    fn name(&self) -> &'static str {
        "dynamics"
    }
    fn depends_on(&self) -> &'static str {
        "q, qd, command"
    }
    fn describe(&self) -> String {
        self.summary.clone()
    }
    fn run(&mut self, m: &pipeline::Model, d: &mut pipeline::Data) -> Result<(), StepError> {
        match &d.command {
            Command::Idle => self.tau.fill(0.0),
            Command::Torque(t) => self.tau.copy_from(t),
            Command::Target(target) => {
                // computed torque: the desired acceleration through inverse dynamics
                for j in 0..self.qdd_des.len() {
                    self.qdd_des[j] =
                        self.kp * (target[j] - d.state.q[j]) - self.kd * d.state.qd[j];
                }
                let tau = rnea(
                    &self.model,
                    &mut self.data,
                    d.state.q.as_slice(),
                    d.state.qd.as_slice(),
                    self.qdd_des.as_slice(),
                )?;
                self.tau.copy_from(tau);
            }
        }
        let t_next = d.state.t + m.dt;
        match self.stepper.config.step {
            StepSize::Fixed(dt) => {
                self.stepper
                    .step(&self.model, &mut d.state, self.tau.as_slice(), dt)?
            }
            StepSize::Adaptive { .. } => {
                self.stepper
                    .advance_to(&self.model, &mut d.state, self.tau.as_slice(), t_next)?
            }
        }
        d.tau.copy_from(&self.tau);
        Ok(())
    }
}
