//! [`Data`]: everything the simulator pipeline changes as it runs (MuJoCo's `mjData`), in one
//! value. The pipeline's stages keep nothing of their own between steps: what a stage
//! remembers (the collision stage's last collision-free q, the integrator's step proposal and
//! counters) lives here, so `data.clone()` saves a step, `==` compares two, and putting a saved
//! value back rewinds the simulation bit for bit.
//!
//! Sized once when the pipeline is built (`robosim_simulator::Pipeline::build`): a field a
//! declared stage fills is `Some`, the others `None` and unallocated; a step allocates nothing.

use nalgebra::{DVector, Matrix4};
use robosim_dynamics::Stepper;
use robosim_kinematics::State;

/// What the robot is told to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// No command: zero joint torque under dynamics, standing still under kinematic motion.
    Idle,
    /// Joint targets (rad or m): kinematic motion at `max_speed`, or the dynamics stage's
    /// gravity-compensated PD controller.
    Target(DVector<f64>),
    /// Joint torques (N·m or N); dynamics only.
    Torque(DVector<f64>),
}

/// What changes as the simulation runs: the state, the command, and the outputs and memories
/// of the declared stages (`None` when the stage that fills them is not in the pipeline).
#[derive(Debug, Clone, PartialEq)]
pub struct Data {
    /// q, q̇, q̈ (rad, m and their rates, `dof` entries) and the time t (s).
    pub state: State,
    pub command: Command,
    /// The torques applied in the last step (dynamics only; zeros otherwise), `dof` entries.
    pub tau: DVector<f64>,
    /// Steps taken.
    pub step: u64,
    /// Link frames `base, 1..n, tool` in the world (link-frames stage), `dof + 2` entries.
    pub frames: Option<Vec<Matrix4<f64>>>,
    /// Quantised joint readings (encoder stage).
    pub q_measured: Option<DVector<f64>>,
    /// Whether the last collision check found a contact (collision stage).
    pub contact: Option<bool>,
    /// Steps whose collision check found a contact (collision stage; 0 otherwise).
    pub contact_steps: u64,
    /// The last collision-free q (collision stage): where `on_contact: stop` puts the robot
    /// back, and where a continuous sweep starts.
    pub q_safe: Option<DVector<f64>>,
    /// The integrator's state and workspace (dynamics stage).
    pub integrator: Option<IntegratorState>,
}

/// The dynamics stage's integrator: its state (the adaptive step proposal, the counters) and
/// its workspace (stage derivatives, the controller's RNEA scratch), preallocated.
///
/// Two values are equal when their state is: configuration, counters and step proposal. The
/// workspace is overwritten before it is read, so it is not compared.
#[derive(Debug, Clone)]
pub struct IntegratorState {
    pub stepper: Stepper,
    /// RNEA workspace of the joint-target controller.
    pub rnea: robosim_dynamics::Data,
    /// The controller's desired accelerations, `dof` entries (workspace).
    pub qdd_des: DVector<f64>,
}

impl PartialEq for IntegratorState {
    fn eq(&self, other: &Self) -> bool {
        self.stepper.config == other.stepper.config
            && self.stepper.stats == other.stepper.stats
            && self.stepper.step_proposal().to_bits() == other.stepper.step_proposal().to_bits()
    }
}
