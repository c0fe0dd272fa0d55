//! Forward dynamics by the articulated-body algorithm (Featherstone 1983; Featherstone 2008,
//! §7.3, Table 7.1): O(n), no mass matrix. Entry point: [`aba`].

use crate::data::{Data, spherical_update_transforms};
use crate::model::{DynamicsError, Model};
use crate::spatial::{Force, Motion};
use crate::spherical::{BallScratch, columns, combine};
use nalgebra::{DVector, Matrix3, Matrix6, Matrix6x3, Vector3, Vector6};

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
    model.check_q(q)?;
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
    if model.spherical {
        return spherical_aba(model, data, q, qd, tau);
    }
    let n = model.dof();
    // a floating root's velocity coordinates come first (r of them; 0 for a fixed base)
    let r = model.root_dims().1;
    data.update_transforms(model, q);
    let v_top = match &model.root {
        Some(root) => {
            let v = root.motion(&qd[..r]);
            data.root.v = v;
            data.root.ia = root.inertia.matrix();
            data.root.pa = v.cross_force(&root.inertia.mul_motion(&v)).to6();
            v
        }
        None => Motion::zero(),
    };
    // pass 1: velocities, velocity-product accelerations, bias forces
    for j in 0..n {
        let link = &model.links[j];
        let vj = link.s.scale(qd[r + j]);
        let v_parent = match link.parent {
            Some(p) => data.v[p],
            None => v_top,
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
                joint: r + j,
                inertia: d,
            });
        }
        let u = tau[r + j] - s6.dot(&data.pa[j]);
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
        } else if model.root.is_some() {
            let ia = data.ia[j] - u6 * u6.transpose() / d;
            let pa: Vector6<f64> = data.pa[j] + ia * data.c[j] + u6 * (u / d);
            let moved = data.x[j].inertia_to_parent(&ia);
            data.root.ia += moved;
            let pf = data.x[j].transpose_force(&Force::from6(&pa));
            data.root.pa += pf.to6();
        }
    }
    // pass 3: accelerations, outward
    let a0 = Motion {
        w: Vector3::zeros(),
        v: -model.gravity_base,
    };
    let a_top = match &model.root {
        Some(root) => root_acceleration(root, data, &tau[..r], &a0)?,
        None => a0,
    };
    for j in 0..n {
        let a_parent = match model.links[j].parent {
            Some(p) => data.a[p],
            None => a_top,
        };
        let a_pre = data.x[j].apply_motion(&a_parent).to6() + data.c[j];
        let qdd = (data.u[j] - data.u6[j].dot(&a_pre)) / data.d[j];
        data.qdd[r + j] = qdd;
        let a = a_pre + model.links[j].s.to6() * qdd;
        data.a[j] = Motion::from6(&a);
    }
    Ok(())
}

/// The root joint's step of the articulated-body algorithm, a joint of several coordinates
/// (Featherstone 2008, Table 7.1 with `S` 6 × k): with `U = Iᴬ S`, `D = Sᵀ U`,
/// `u = τ_root − Sᵀ pᴬ`, the root's q̈ is `D⁻¹ (u − Uᵀ X a₀)` and its acceleration
/// `X a₀ + S q̈` (no velocity-product term: the root hangs from the fixed world). Fills
/// `data.qdd[..k]` and `data.root.a`, returns the acceleration.
pub(crate) fn root_acceleration(
    root: &crate::model::RootBody,
    data: &mut Data,
    tau: &[f64],
    a0: &Motion,
) -> Result<Motion, DynamicsError> {
    let k = root.s.len();
    let a_pre = data.root.x.apply_motion(a0).to6();
    let mut s = Matrix6::zeros();
    for (i, si) in root.s.iter().enumerate() {
        s.set_column(i, &si.to6());
    }
    let u6 = data.root.ia * s;
    let mut d = s.transpose() * u6;
    let mut rhs = Vector6::zeros();
    for i in 0..6 {
        if i < k {
            rhs[i] = tau[i] - s.column(i).dot(&data.root.pa) - u6.column(i).dot(&a_pre);
        } else {
            d[(i, i)] = 1.0;
        }
    }
    let chol = d.cholesky().ok_or(DynamicsError::SingularInertia {
        joint: 0,
        inertia: d.determinant(),
    })?;
    let qdd = chol.solve(&rhs);
    for i in 0..k {
        data.qdd[i] = qdd[i];
    }
    let a = Motion::from6(&(a_pre + s * qdd));
    data.root.a = a;
    Ok(a)
}

/// [`aba_unchecked`] for a model with spherical joints (see [`crate::spherical`]); lengths are the
/// caller's invariant. Fills `data.qdd`.
fn spherical_aba(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<(), DynamicsError> {
    let n = model.dof();
    let r = model.root_dims().1;
    spherical_update_transforms(data, model, q);
    let v_top = match &model.root {
        Some(root) => {
            let v = root.motion(&qd[..r]);
            data.root.v = v;
            data.root.ia = root.inertia.matrix();
            data.root.pa = v.cross_force(&root.inertia.mul_motion(&v)).to6();
            v
        }
        None => Motion::zero(),
    };
    for j in 0..n {
        let link = &model.links[j];
        let (cols, k) = columns(link);
        let vj = combine(&cols, k, qd, link.iv);
        let v_parent = match link.parent {
            Some(p) => data.v[p],
            None => v_top,
        };
        let v = data.x[j].apply_motion(&v_parent).add(&vj);
        data.v[j] = v;
        data.c[j] = v.cross_motion(&vj).to6();
        data.ia[j] = link.inertia.matrix();
        data.pa[j] = v.cross_force(&link.inertia.mul_motion(&v)).to6();
    }
    for j in (0..n).rev() {
        let link = &model.links[j];
        // Iᴬ − U D⁻¹ Uᵀ and pᴬ + Iᵃ c + U D⁻¹ u, handed to the parent
        let (ia, pa) = if link.spherical {
            // S = [1₃; 0]: U is Iᴬ's first three columns, D its top-left block
            let u6: Matrix6x3<f64> = data.ia[j].fixed_view::<6, 3>(0, 0).into_owned();
            let d: Matrix3<f64> =
                u6.fixed_view::<3, 3>(0, 0).into_owned() + Matrix3::identity() * link.motor_inertia;
            let dinv = d
                .cholesky()
                .map(|c| c.inverse())
                .ok_or(DynamicsError::SingularInertia {
                    joint: link.iv,
                    inertia: d.determinant(),
                })?;
            let pa = data.pa[j];
            let u = Vector3::new(
                tau[link.iv] - pa[0],
                tau[link.iv + 1] - pa[1],
                tau[link.iv + 2] - pa[2],
            );
            data.ball[j] = BallScratch { u6, dinv, u };
            let ia = data.ia[j] - u6 * dinv * u6.transpose();
            let pa: Vector6<f64> = pa + ia * data.c[j] + u6 * (dinv * u);
            (ia, pa)
        } else {
            let s6 = link.s.to6();
            let u6 = data.ia[j] * s6;
            let d = s6.dot(&u6) + link.motor_inertia;
            if d.is_nan() || d <= 0.0 || !d.is_finite() {
                return Err(DynamicsError::SingularInertia {
                    joint: link.iv,
                    inertia: d,
                });
            }
            let u = tau[link.iv] - s6.dot(&data.pa[j]);
            data.u6[j] = u6;
            data.d[j] = d;
            data.u[j] = u;
            let ia = data.ia[j] - u6 * u6.transpose() / d;
            let pa: Vector6<f64> = data.pa[j] + ia * data.c[j] + u6 * (u / d);
            (ia, pa)
        };
        let moved = data.x[j].inertia_to_parent(&ia);
        let pf = data.x[j].transpose_force(&Force::from6(&pa)).to6();
        if let Some(p) = link.parent {
            data.ia[p] += moved;
            data.pa[p] += pf;
        } else if model.root.is_some() {
            data.root.ia += moved;
            data.root.pa += pf;
        }
    }
    let a0 = Motion {
        w: Vector3::zeros(),
        v: -model.gravity_base,
    };
    let a_top = match &model.root {
        Some(root) => root_acceleration(root, data, &tau[..r], &a0)?,
        None => a0,
    };
    for j in 0..n {
        let link = &model.links[j];
        let a_parent = match link.parent {
            Some(p) => data.a[p],
            None => a_top,
        };
        let a_pre = data.x[j].apply_motion(&a_parent).to6() + data.c[j];
        let a = if link.spherical {
            let b = &data.ball[j];
            let qdd = b.dinv * (b.u - b.u6.transpose() * a_pre);
            for i in 0..3 {
                data.qdd[link.iv + i] = qdd[i];
            }
            let mut a = a_pre;
            for i in 0..3 {
                a[i] += qdd[i];
            }
            a
        } else {
            let qdd = (data.u[j] - data.u6[j].dot(&a_pre)) / data.d[j];
            data.qdd[link.iv] = qdd;
            a_pre + link.s.to6() * qdd
        };
        data.a[j] = Motion::from6(&a);
    }
    Ok(())
}
