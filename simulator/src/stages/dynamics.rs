//! The dynamics stage: one pipeline step of forward dynamics and integration
//! (`robosim_dynamics::Stepper`) under the commanded torques, or under a computed-torque
//! controller towards joint targets, `τ = RNEA(q, q̇, kp (q* − q) − kd q̇)` (the closed loop is
//! `ë + kd ė + kp e = 0` per joint when the model is exact). Depends on q, q̇ and the command.
//! The integrator's state (its step proposal, its counters) and workspace live in
//! `Data::integrator`.
//!
//! A floating robot (`Robot::root`) integrates its whole state, root on the manifold
//! (`robosim_dynamics::Stepper`, the same as the query protocol's `simulate`): q is
//! `[q_root, q_joints]`, q̇ and τ are `[v_root, joints]`; a torque command gives the joints'
//! torques and the root's stay 0 (no motor acts on it); a joint target is refused
//! (`Pipeline::set_command`).

use crate::model::{BuildError, DynamicsModel, Model, StepError};
use nalgebra::{DVector, Vector3};
use robosim_dynamics::{IntegratorConfig, StepSize, Stepper, rnea};
use robosim_kinematics::Robot;
use robosim_model::{
    Command, Data, DynamicsEffect, IntegratorState, JointFrictionEffect, OptionsError,
};

pub const NAME: &str = "dynamics";
pub const DEPENDS_ON: &str = "q, qd, command";

/// The stage's model part and the integrator's initial state, from the declared effect; with a
/// declared joint friction effect the stepper applies the robot's friction data
/// (`Stepper::with_friction`), else the step is the rigid-body equations alone.
pub fn build(
    robot: &Robot,
    d: &DynamicsEffect,
    friction: Option<&JointFrictionEffect>,
) -> Result<(DynamicsModel, IntegratorState), BuildError> {
    let bad = |field: &str, reason: String| {
        BuildError::Options(OptionsError {
            field: format!("dynamics.{field}"),
            reason,
        })
    };
    let mut robot = robot.clone();
    if let Some(g) = d.gravity {
        robot.gravity = Vector3::from(g);
    }
    let model = robosim_dynamics::Model::new(&robot).map_err(|source| BuildError::Dynamics {
        field: "dynamics.robot",
        source,
    })?;
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
        integrator: d.integrator,
        step,
        joint_stops: false,
        max_steps: 1_000_000,
    };
    let mut stepper = Stepper::new(&model, config).map_err(|source| BuildError::Dynamics {
        field: "dynamics.integrator",
        source,
    })?;
    if let Some(f) = friction {
        stepper = stepper
            .with_friction(&model, f.to_dynamics())
            .map_err(|source| BuildError::Dynamics {
                field: "joint_friction",
                source,
            })?;
    }
    let friction_note = match stepper.friction() {
        Some(f) => format!(", joint friction {f:?}"),
        None => String::new(),
    };
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
            d.integrator.name(),
            g.x,
            g.y,
            g.z
        ),
        StepSize::Adaptive { rtol, atol } => format!(
            "{}, rtol {rtol:e}, atol {atol:e} within dt = {} s, gravity [{}, {}, {}]",
            d.integrator.name(),
            d.dt,
            g.x,
            g.y,
            g.z
        ),
    };
    let summary = summary + &friction_note;
    let state = IntegratorState {
        stepper,
        rnea: robosim_dynamics::Data::new(&model),
        qdd_des: DVector::zeros(model.dof()),
    };
    Ok((
        DynamicsModel {
            model,
            kp: d.kp,
            kd: d.kd,
            summary,
        },
        state,
    ))
}

pub fn describe(dy: &DynamicsModel) -> String {
    dy.summary.clone()
}

/// One pipeline step: the torques (commanded, or the controller's towards the target) into
/// `d.tau`, then the integrator over `m.dt` (fixed, or adaptive steps up to the step's end).
pub fn run(m: &Model, dy: &DynamicsModel, d: &mut Data) -> Result<(), StepError> {
    // the builder fills `integrator` whenever it declares this stage
    let Some(integ) = d.integrator.as_mut() else {
        return Ok(());
    };
    match &d.command {
        Command::Idle => d.tau.fill(0.0),
        // one torque per joint; a floating root is not actuated (its nv entries stay 0)
        Command::Torque(t) => {
            let root_nv = m.robot.root_nv();
            d.tau.rows_mut(0, root_nv).fill(0.0);
            d.tau.rows_mut(root_nv, t.len()).copy_from(t);
        }
        Command::Target(target) => {
            // computed torque: the desired acceleration through inverse dynamics
            for j in 0..integ.qdd_des.len() {
                integ.qdd_des[j] = dy.kp * (target[j] - d.state.q[j]) - dy.kd * d.state.qd[j];
            }
            let tau = rnea(
                &dy.model,
                &mut integ.rnea,
                d.state.q.as_slice(),
                d.state.qd.as_slice(),
                integ.qdd_des.as_slice(),
            )?;
            d.tau.copy_from(tau);
        }
    }
    let t_next = d.state.t + m.dt;
    match integ.stepper.config.step {
        StepSize::Fixed(dt) => integ
            .stepper
            .step(&dy.model, &mut d.state, d.tau.as_slice(), dt)?,
        StepSize::Adaptive { .. } => {
            integ
                .stepper
                .advance_to(&dy.model, &mut d.state, d.tau.as_slice(), t_next)?
        }
    }
    Ok(())
}
