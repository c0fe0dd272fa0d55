//! Joint friction, apart from the rigid-body algorithms (issue 36 item 3; DESIGN.md, "Dynamics
//! contract"): [`crate::rnea`], [`crate::aba`], [`crate::crba`] and [`crate::fd_cholesky`] are
//! Pinocchio's rigid-body equations `M(q) q̈ + C(q, q̇) q̇ + g(q) = τ` and never read a joint's
//! `viscous` / `coulomb` data. Friction acts only where it is asked for: a scene's
//! `joint_friction` effect (the stepper's [`crate::Stepper::with_friction`]) or a query's
//! `"passive": true`.
//!
//! Entry points: [`JointFriction`] (which terms, which Coulomb model), [`passive_torque`] (the
//! torque friction applies at q̇, for inverse dynamics), [`friction_torque`] (the torque it
//! applies in forward dynamics, sticking included), [`aba_with_friction`].
//!
//! Coulomb models:
//! * [`Coulomb::Regularised`]: `−c tanh(q̇ / v)`, smooth; a joint under a torque below `c`
//!   creeps at `|q̇| < v · atanh(τ / c)` instead of stopping.
//! * [`Coulomb::StickSlip`] (Karnopp 1985, with the joints coupled through `M`): a joint with
//!   `|q̇| ≤ v` is *stuck* while the torque needed to hold it (`q̈_j = 0`, the other joints free)
//!   is within `±c`: friction supplies exactly that torque, so a joint at rest under a torque
//!   below its Coulomb limit stays at rest. A joint whose holding torque would exceed `c` slips,
//!   with `−c sign(r)` against the net torque `r`; faster joints feel `−c sign(q̇)`. The stuck
//!   set is found by releasing the worst-violating joint and solving again (at most n solves of
//!   the free block of `M`).
//!
//! Viscous damping `−b q̇` is added to both when [`JointFriction::viscous`] is on. Sign
//! convention: the returned torques are what friction *applies* to the joint (opposing motion);
//! the torque a motor must supply in inverse dynamics is `τ_rigid − τ_passive`.

use crate::crba::{cholesky_in_place, crba_pass};
use crate::data::Data;
use crate::model::{DynamicsError, Model};
use crate::rnea::{Terms, rnea_pass};
use nalgebra::{DMatrix, DVector};

/// How Coulomb friction is modelled (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coulomb {
    /// No Coulomb term.
    Off,
    /// `−c tanh(q̇ / velocity)`; `velocity` in rad/s or m/s, > 0.
    Regularised { velocity: f64 },
    /// Stick below `velocity` (rad/s or m/s, ≥ 0) while the holding torque is within `±c`.
    StickSlip { velocity: f64 },
}

/// Which of a joint's friction data act (the robot's `viscous` and `coulomb` per joint).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointFriction {
    /// Viscous damping `−b q̇`.
    pub viscous: bool,
    pub coulomb: Coulomb,
}

impl Default for JointFriction {
    /// Viscous on, Coulomb stick–slip with a 1e-6 rad/s (m/s) sticking band.
    fn default() -> Self {
        JointFriction {
            viscous: true,
            coulomb: Coulomb::StickSlip { velocity: 1e-6 },
        }
    }
}

impl JointFriction {
    /// Refuses a non-finite or non-positive regularisation velocity, a negative or non-finite
    /// sticking band.
    pub fn validate(&self) -> Result<(), DynamicsError> {
        let bad = |reason: String| DynamicsError::BadOption {
            field: "joint_friction.velocity",
            reason,
        };
        match self.coulomb {
            Coulomb::Regularised { velocity } if !(velocity > 0.0 && velocity.is_finite()) => {
                Err(bad(format!(
                    "the regularised model needs a positive velocity, got {velocity}"
                )))
            }
            Coulomb::StickSlip { velocity } if !(velocity >= 0.0 && velocity.is_finite()) => {
                Err(bad(format!(
                    "the sticking band must be finite and ≥ 0, got {velocity}"
                )))
            }
            _ => Ok(()),
        }
    }

    /// Whether `model` has any friction data these settings would apply.
    pub fn acts_on(&self, model: &Model) -> bool {
        model.links.iter().any(|l| {
            (self.viscous && l.viscous != 0.0) || (self.coulomb != Coulomb::Off && l.coulomb != 0.0)
        })
    }
}

/// The friction torque at velocity `qd` of a joint that is not stuck: `−b q̇ − c s(q̇)`, with
/// `s = sign` (stick–slip outside its band; `sign(0) = 0`) or `tanh(q̇ / v)` (regularised).
fn sliding(b: f64, c: f64, qd: f64, friction: &JointFriction) -> f64 {
    let viscous = if friction.viscous { -b * qd } else { 0.0 };
    let coulomb = match friction.coulomb {
        Coulomb::Off => 0.0,
        Coulomb::Regularised { velocity } => -c * (qd / velocity).tanh(),
        Coulomb::StickSlip { .. } => {
            if qd > 0.0 {
                -c
            } else if qd < 0.0 {
                c
            } else {
                0.0
            }
        }
    };
    viscous + coulomb
}

/// The torque friction applies at joint velocities `qd` (N·m or N per joint), for inverse
/// dynamics (`"passive": true`): viscous and Coulomb as [`JointFriction`] says, a joint at rest
/// feeling no Coulomb term (static friction is indeterminate at rest: it is whatever holds the
/// joint, see [`friction_torque`]). Writes `out` (length dof). Inputs checked.
pub fn passive_torque(
    model: &Model,
    qd: &[f64],
    friction: &JointFriction,
    out: &mut [f64],
) -> Result<(), DynamicsError> {
    model.check_vector("qd", qd)?;
    model.robot.refuse_spherical("joint friction")?;
    if out.len() != model.nv() {
        return Err(DynamicsError::WrongLength {
            field: "passive",
            expected: model.nv(),
            got: out.len(),
        });
    }
    // a floating root has no friction
    let r = model.root_dims().1;
    out[..r].fill(0.0);
    for ((o, link), &v) in out[r..].iter_mut().zip(&model.links).zip(&qd[r..]) {
        *o = sliding(link.viscous, link.coulomb, v, friction);
    }
    Ok(())
}

/// The torque friction applies in forward dynamics at (q, q̇) under the applied torques `tau`
/// (see the module docs: stuck joints get exactly their holding torque). Fills and returns
/// `data.passive`; overwrites `data.mass_matrix`, `data.tau` (the bias) and the Cholesky scratch
/// when a joint may stick. Lengths are the caller's invariant (checked by the public entry
/// points).
pub(crate) fn friction_torque_unchecked<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    friction: &JointFriction,
) -> Result<&'d DVector<f64>, DynamicsError> {
    // velocity coordinates: a floating root's r first (no friction), then the joints'
    let r = model.root_dims().1;
    let n = model.nv();
    let band = match friction.coulomb {
        Coulomb::StickSlip { velocity } => Some(velocity),
        _ => None,
    };
    let mut stuck: Vec<usize> = Vec::new();
    data.passive.as_mut_slice()[..r].fill(0.0);
    for j in r..n {
        let link = &model.links[j - r];
        match band {
            Some(v) if link.coulomb > 0.0 && qd[j].abs() <= v => {
                data.passive[j] = if friction.viscous {
                    -link.viscous * qd[j]
                } else {
                    0.0
                };
                stuck.push(j);
            }
            _ => data.passive[j] = sliding(link.viscous, link.coulomb, qd[j], friction),
        }
    }
    if stuck.is_empty() {
        return Ok(&data.passive);
    }
    // M and the bias h = C q̇ + g at (q, q̇); motor inertia is in M (crba_pass)
    data.update_transforms(model, q);
    crba_pass(model, data);
    rnea_pass(
        model,
        data,
        qd,
        None,
        Terms {
            gravity: true,
            motor: false,
        },
    );
    let root_nv = r;
    loop {
        // the net torque on each joint (applied + friction so far − bias); the stuck joints'
        // `passive` holds their viscous part only
        let net = DVector::from_fn(n, |j, _| tau[j] + data.passive[j] - data.tau[j]);
        let free: Vec<usize> = (0..n).filter(|j| !stuck.contains(j)).collect();
        let qdd_free = solve_free(&data.mass_matrix, &free, &net)?;
        // the torque each stuck joint needs to stay at q̈ = 0: r = net − M_SF q̈_F
        let mut worst: Option<(usize, f64, f64)> = None;
        let mut hold = Vec::with_capacity(stuck.len());
        for (k, &j) in stuck.iter().enumerate() {
            let mut r = net[j];
            for (i, &f) in free.iter().enumerate() {
                r -= data.mass_matrix[(j, f)] * qdd_free[i];
            }
            let excess = r.abs() - model.links[j - root_nv].coulomb;
            if excess > 0.0 && worst.is_none_or(|(_, e, _)| excess > e) {
                worst = Some((k, excess, r));
            }
            hold.push(r);
        }
        match worst {
            None => {
                for (&j, r) in stuck.iter().zip(hold) {
                    data.passive[j] -= r;
                }
                return Ok(&data.passive);
            }
            Some((k, _, r)) => {
                // it slips: kinetic friction against the net torque
                let j = stuck.remove(k);
                data.passive[j] -= model.links[j - root_nv].coulomb * r.signum();
            }
        }
    }
}

/// Solves `M_FF x = net_F` for the free joints `free` (x in the order of `free`).
fn solve_free(
    m: &DMatrix<f64>,
    free: &[usize],
    net: &DVector<f64>,
) -> Result<DVector<f64>, DynamicsError> {
    let nf = free.len();
    let mff = DMatrix::from_fn(nf, nf, |a, b| m[(free[a], free[b])]);
    let mut l = DMatrix::zeros(nf, nf);
    cholesky_in_place(&mff, &mut l)?;
    let mut x = DVector::from_fn(nf, |a, _| net[free[a]]);
    crate::crba::cholesky_solve_in_place(&l, &mut x);
    Ok(x)
}

/// [`friction_torque_unchecked`] with the inputs checked: the torque friction applies at
/// (q, q̇) under `tau` (N·m or N per joint). Fills and returns `data.passive`.
pub fn friction_torque<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    friction: &JointFriction,
) -> Result<&'d DVector<f64>, DynamicsError> {
    model.check_q(q)?;
    model.check_vector("qd", qd)?;
    model.check_vector("tau", tau)?;
    friction.validate()?;
    model.robot.refuse_spherical("joint friction")?;
    friction_torque_unchecked(model, data, q, qd, tau, friction)
}

/// Forward dynamics with joint friction: `q̈ = ABA(q, q̇, τ + τ_friction)` with the friction
/// torque of [`friction_torque`]. Fills and returns `data.qdd` (and `data.passive`).
pub fn aba_with_friction<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    friction: &JointFriction,
) -> Result<&'d DVector<f64>, DynamicsError> {
    friction_torque(model, data, q, qd, tau, friction)?;
    let total: Vec<f64> = tau
        .iter()
        .zip(data.passive.iter())
        .map(|(t, f)| t + f)
        .collect();
    crate::aba::aba(model, data, q, qd, &total)
}
