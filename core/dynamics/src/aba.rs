//! Forward dynamics by the articulated-body algorithm (Featherstone 1983; Featherstone 2008,
//! §7.3, Table 7.1): O(n), no mass matrix. Entry point: [`aba`].

use crate::data::Data;
use crate::model::{DynamicsError, Model};
use crate::spatial::{Force, Motion};
use nalgebra::{DVector, Vector3, Vector6};

/// Joint accelerations `q̈` (rad/s² or m/s²) under joint torques `τ` at state (q, q̇), with
/// gravity and motor inertia as the model says: Pinocchio's `aba`, the rigid-body equations
/// (no joint friction: [`crate::friction::aba_with_friction`]). Fills and returns `data.qdd`. Fails
/// with [`DynamicsError::SingularInertia`] when a joint has no inertia about its axis.
pub fn aba<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<&'d DVector<f64>, DynamicsError> {
    model.check_vector("q", q)?;
    model.check_vector("qd", qd)?;
    model.check_vector("tau", tau)?;
    aba_unchecked(model, data, q, qd, tau)?;
    Model::check_result("qdd", data.qdd.as_slice())?;
    Ok(&data.qdd)
}

/// [`aba`] without the input checks: lengths must equal `model.dof()` (the integrators' invariant).
pub(crate) fn aba_unchecked(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<(), DynamicsError> {
    let n = model.dof();
    data.update_transforms(model, q);
    // pass 1: velocities, velocity-product accelerations, bias forces
    for j in 0..n {
        let link = &model.links[j];
        let vj = link.s.scale(qd[j]);
        let v_parent = match link.parent {
            Some(p) => data.v[p],
            None => Motion::zero(),
        };
        let v = data.x[j].apply_motion(&v_parent).add(&vj);
        data.v[j] = v;
        data.c[j] = v.cross_motion(&vj).to6();
        data.ia[j] = link.inertia.matrix();
        data.pa[j] = v.cross_force(&link.inertia.mul_motion(&v)).to6();
    }
    // pass 2: articulated inertias, inward
    for j in (0..n).rev() {
        let link = &model.links[j];
        let s6 = link.s.to6();
        let u6 = data.ia[j] * s6;
        let d = s6.dot(&u6) + link.motor_inertia;
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return Err(DynamicsError::SingularInertia {
                joint: j,
                inertia: d,
            });
        }
        let u = tau[j] - s6.dot(&data.pa[j]);
        data.u6[j] = u6;
        data.d[j] = d;
        data.u[j] = u;
        if let Some(p) = link.parent {
            let ia = data.ia[j] - u6 * u6.transpose() / d;
            let pa: Vector6<f64> = data.pa[j] + ia * data.c[j] + u6 * (u / d);
            let moved = data.x[j].inertia_to_parent(&ia);
            data.ia[p] += moved;
            let pf = data.x[j].transpose_force(&Force::from6(&pa));
            data.pa[p] += pf.to6();
        }
    }
    // pass 3: accelerations, outward
    let a0 = Motion {
        w: Vector3::zeros(),
        v: -model.gravity_base,
    };
    for j in 0..n {
        let a_parent = match model.links[j].parent {
            Some(p) => data.a[p],
            None => a0,
        };
        let a_pre = data.x[j].apply_motion(&a_parent).to6() + data.c[j];
        let qdd = (data.u[j] - data.u6[j].dot(&a_pre)) / data.d[j];
        data.qdd[j] = qdd;
        let a = a_pre + model.links[j].s.to6() * qdd;
        data.a[j] = Motion::from6(&a);
    }
    Ok(())
}
