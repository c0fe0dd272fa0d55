//! Rigid-body dynamics of a robot with mimic joints, over the **reduced** coordinates of a
//! [`Coupling`] (`robosim_kinematics::mimic`: the robot stays the full model, the coupling maps
//! the free coordinates to all of them, `q = φ(q_r)`, `q̇ = G q̇_r`). Each algorithm is the
//! full one composed with the coupling (virtual work):
//!
//! ```text
//! τ_r = Gᵀ τ(φ(q_r), G q̇_r, G q̈_r)       (rnea_mimic)
//! g_r = Gᵀ g(φ(q_r))                       (gravity_mimic)
//! M_r = Gᵀ M(φ(q_r)) G                     (crba_mimic)
//! q̈_r = M_r⁻¹ (τ_r − Gᵀ b),  b = τ(φ(q_r), G q̇_r, 0)   (aba_mimic)
//! ```
//!
//! The velocity-product term needs no extra piece: `G` is constant (a mimic relation is
//! affine), so `q̈ = G q̈_r` exactly. These are Pinocchio 4.1's answers with
//! `buildModel(…, mimic=True)` for RNEA and CRBA; its ABA refuses mimic joints, so the forward
//! dynamics here is solved through the reduced mass matrix (a Cholesky factorisation, O(n³)),
//! not by the articulated-body recursion. Entry points: [`rnea_mimic`], [`gravity_mimic`],
//! [`crba_mimic`], [`aba_mimic`]. A floating base's coordinates (`Coupling::with_root`) come
//! first and pass through (G is the identity on them).

use crate::data::Data;
use crate::model::{DynamicsError, Model};
use crate::{crba, gravity, rnea};
use nalgebra::{DMatrix, DVector};
use robosim_kinematics::mimic::{Coupling, MimicError};

/// A coupling error as a dynamics input error (the coupling only refuses lengths here).
fn length_error(e: MimicError) -> DynamicsError {
    match e {
        MimicError::WrongLength {
            field,
            expected,
            got,
        } => DynamicsError::WrongLength {
            field,
            expected,
            got,
        },
        // Coupling::expand_* and reduce_* refuse only lengths.
        _ => DynamicsError::WrongLength {
            field: "coupling",
            expected: 0,
            got: 0,
        },
    }
}

/// Checks that the coupling is the model's (one entry per joint, the root's dimensions) and
/// that a reduced vector has the coupling's length (`reduced_nq` for q, `reduced_nv` for the
/// others) and is finite.
fn check(
    model: &Model,
    coupling: &Coupling,
    field: &'static str,
    x: &[f64],
) -> Result<(), DynamicsError> {
    model.robot.refuse_spherical("the mimic coupling")?;
    for (what, expected, got) in [
        ("coupling joints", model.dof(), coupling.full_dof()),
        ("coupling nq", model.nq(), coupling.full_nq()),
        ("coupling nv", model.nv(), coupling.full_nv()),
    ] {
        if expected != got {
            return Err(DynamicsError::WrongLength {
                field: what,
                expected,
                got,
            });
        }
    }
    let expected = if field == "q" {
        coupling.reduced_nq()
    } else {
        coupling.reduced_nv()
    };
    if x.len() != expected {
        return Err(DynamicsError::WrongLength {
            field,
            expected,
            got: x.len(),
        });
    }
    if let Some((index, &value)) = x.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(DynamicsError::NonFinite {
            field,
            index,
            value,
        });
    }
    Ok(())
}

/// Inverse dynamics over the reduced coordinates: `τ_r = Gᵀ τ(φ(q_r), G q̇_r, G q̈_r)` (N·m or
/// N per free coordinate; a leader's torque carries its followers', times their
/// multipliers). Uses `data` as [`rnea`] does.
pub fn rnea_mimic(
    model: &Model,
    data: &mut Data,
    coupling: &Coupling,
    qr: &[f64],
    vr: &[f64],
    ar: &[f64],
) -> Result<DVector<f64>, DynamicsError> {
    check(model, coupling, "q", qr)?;
    check(model, coupling, "qd", vr)?;
    check(model, coupling, "qdd", ar)?;
    let q = coupling.expand_q(qr).map_err(length_error)?;
    let v = coupling.expand_v(vr).map_err(length_error)?;
    let a = coupling.expand_v(ar).map_err(length_error)?;
    let tau = rnea(model, data, &q, &v, &a)?;
    coupling.reduce_force(tau.as_slice()).map_err(length_error)
}

/// The gravity torque over the reduced coordinates, `Gᵀ g(φ(q_r))`.
pub fn gravity_mimic(
    model: &Model,
    data: &mut Data,
    coupling: &Coupling,
    qr: &[f64],
) -> Result<DVector<f64>, DynamicsError> {
    check(model, coupling, "q", qr)?;
    let q = coupling.expand_q(qr).map_err(length_error)?;
    let g = gravity(model, data, &q)?;
    coupling.reduce_force(g.as_slice()).map_err(length_error)
}

/// The mass matrix over the reduced coordinates, `Gᵀ M(φ(q_r)) G` (symmetric).
pub fn crba_mimic(
    model: &Model,
    data: &mut Data,
    coupling: &Coupling,
    qr: &[f64],
) -> Result<DMatrix<f64>, DynamicsError> {
    check(model, coupling, "q", qr)?;
    let q = coupling.expand_q(qr).map_err(length_error)?;
    let m = crba(model, data, &q)?;
    coupling.reduce_matrix(m).map_err(length_error)
}

/// Forward dynamics over the reduced coordinates: `q̈_r` solving
/// `M_r q̈_r = τ_r − Gᵀ b(φ(q_r), G q̇_r)` by Cholesky. Fails with
/// [`DynamicsError::SingularInertia`] (naming the reduced coordinate) when `M_r` is not
/// positive definite.
pub fn aba_mimic(
    model: &Model,
    data: &mut Data,
    coupling: &Coupling,
    qr: &[f64],
    vr: &[f64],
    tau_r: &[f64],
) -> Result<DVector<f64>, DynamicsError> {
    check(model, coupling, "tau", tau_r)?;
    let zero = vec![0.0; coupling.reduced_nv()];
    let bias = rnea_mimic(model, data, coupling, qr, vr, &zero)?;
    let m = crba_mimic(model, data, coupling, qr)?;
    let rhs = DVector::from_column_slice(tau_r) - bias;
    let Some(chol) = m.clone().cholesky() else {
        // the reduced coordinate with the smallest diagonal entry names it (its joint index;
        // a root's coordinates, which come first, as 0)
        let (k, inertia) = (0..m.nrows())
            .map(|k| (k, m[(k, k)]))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let r = coupling.reduced_nv() - coupling.reduced_dof();
        return Err(DynamicsError::SingularInertia {
            joint: k
                .checked_sub(r)
                .and_then(|j| coupling.free().get(j).copied())
                .unwrap_or(0),
            inertia,
        });
    };
    let qdd = chol.solve(&rhs);
    Model::check_result("qdd", qdd.as_slice())?;
    Ok(qdd)
}
