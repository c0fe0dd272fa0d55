//! Inverse dynamics by the recursive Newton–Euler algorithm (Luh, Walker & Paul 1980, in the
//! spatial form of Featherstone 2008, §5.3, Table 5.1), with gravity entered as a fictitious base
//! acceleration `a₀ = −g`. Entry points: [`rnea`], [`gravity`], [`coriolis`].

use crate::data::Data;
use crate::model::{DynamicsError, Model};
use crate::spatial::Motion;
use crate::spherical::{columns, combine};
use nalgebra::{DVector, Vector3};

/// Which terms the internal pass includes.
#[derive(Clone, Copy)]
pub(crate) struct Terms {
    pub gravity: bool,
    pub motor: bool,
}

pub(crate) const ALL: Terms = Terms {
    gravity: true,
    motor: true,
};

/// Inverse dynamics `τ = M(q) q̈ + C(q, q̇) q̇ + g(q)` (N·m for revolute, N for prismatic
/// joints), motor inertia included in `M`: Pinocchio's `rnea` (its `armature` is our motor
/// inertia). Joint friction is not in it (issue 36; [`crate::friction`]: `τ_rigid − τ_passive`
/// is the torque a motor supplies when friction acts). Fills and returns `data.tau`. Depends on
/// q, q̇, q̈. Inputs are checked (length, finite).
pub fn rnea<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
) -> Result<&'d DVector<f64>, DynamicsError> {
    model.check_q(q)?;
    model.check_vector("qd", qd)?;
    model.check_vector("qdd", qdd)?;
    data.update_transforms(model, q);
    rnea_pass(model, data, qd, Some(qdd), ALL);
    Model::check_result("tau", data.tau.as_slice())?;
    Ok(&data.tau)
}

/// The gravity torque `g(q)`: the joint torques that hold the arm still at `q` (RNEA with
/// q̇ = q̈ = 0). Fills and returns `data.tau`.
pub fn gravity<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
) -> Result<&'d DVector<f64>, DynamicsError> {
    model.check_q(q)?;
    data.update_transforms(model, q);
    rnea_pass(
        model,
        data,
        &[],
        None,
        Terms {
            gravity: true,
            motor: false,
        },
    );
    Model::check_result("tau", data.tau.as_slice())?;
    Ok(&data.tau)
}

/// The Coriolis and centrifugal torques `C(q, q̇) q̇` (RNEA with gravity off, q̈ = 0, no
/// friction). Fills and returns `data.tau`.
pub fn coriolis<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
) -> Result<&'d DVector<f64>, DynamicsError> {
    model.check_q(q)?;
    model.check_vector("qd", qd)?;
    data.update_transforms(model, q);
    rnea_pass(
        model,
        data,
        qd,
        None,
        Terms {
            gravity: false,
            motor: false,
        },
    );
    Model::check_result("tau", data.tau.as_slice())?;
    Ok(&data.tau)
}

/// The RNEA passes over transforms already in `data.x`. An empty `qd` means q̇ = 0; `None` for
/// `qdd` means q̈ = 0.
pub(crate) fn rnea_pass(
    model: &Model,
    data: &mut Data,
    qd: &[f64],
    qdd: Option<&[f64]>,
    terms: Terms,
) {
    if model.spherical {
        return spherical_rnea_pass(model, data, qd, qdd, terms);
    }
    let n = model.dof();
    let a0 = if terms.gravity {
        Motion {
            w: nalgebra::Vector3::zeros(),
            v: -model.gravity_base,
        }
    } else {
        Motion::zero()
    };
    let nvr = model.root_dims().1;
    // the bodies hanging from the base hang from the root body of a floating robot
    let (v_top, a_top) = match &model.root {
        Some(root) => {
            let v = root.motion(qd.get(..nvr).unwrap_or(&[]));
            // vᵣ × vⱼ vanishes: the root's velocity is its joint velocity
            let a = data
                .root
                .x
                .apply_motion(&a0)
                .add(&root.motion(qdd.map_or(&[][..], |a| &a[..nvr])));
            let iv = root.inertia.mul_motion(&v);
            data.root.f = root.inertia.mul_motion(&a).add(&v.cross_force(&iv));
            data.root.v = v;
            data.root.a = a;
            (v, a)
        }
        None => (Motion::zero(), a0),
    };
    for j in 0..n {
        let link = &model.links[j];
        let x = &data.x[j];
        let (v_parent, a_parent) = match link.parent {
            Some(p) => (data.v[p], data.a[p]),
            None => (v_top, a_top),
        };
        let qdj = qd.get(nvr + j).copied().unwrap_or(0.0);
        let qddj = qdd.map_or(0.0, |a| a[nvr + j]);
        let vj_joint = link.s.scale(qdj);
        let v = x.apply_motion(&v_parent).add(&vj_joint);
        let a = x
            .apply_motion(&a_parent)
            .add(&link.s.scale(qddj))
            .add(&v.cross_motion(&vj_joint));
        let iv = link.inertia.mul_motion(&v);
        data.f[j] = link.inertia.mul_motion(&a).add(&v.cross_force(&iv));
        data.v[j] = v;
        data.a[j] = a;
    }
    for j in (0..n).rev() {
        let link = &model.links[j];
        let mut tau = link.s.dot(&data.f[j]);
        if terms.motor {
            tau += link.motor_inertia * qdd.map_or(0.0, |a| a[nvr + j]);
        }
        data.tau[nvr + j] = tau;
        if let Some(p) = link.parent {
            let fp = data.x[j].transpose_force(&data.f[j]);
            data.f[p] = data.f[p].add(&fp);
        } else if model.root.is_some() {
            let fp = data.x[j].transpose_force(&data.f[j]);
            data.root.f = data.root.f.add(&fp);
        }
    }
    if let Some(root) = &model.root {
        for (i, s) in root.s.iter().enumerate() {
            data.tau[i] = s.dot(&data.root.f);
        }
    }
}

/// [`rnea_pass`] for a model with spherical joints (see [`crate::spherical`]): an empty `qd` is
/// q̇ = 0, `None` for `qdd` is q̈ = 0.
fn spherical_rnea_pass(
    model: &Model,
    data: &mut Data,
    qd: &[f64],
    qdd: Option<&[f64]>,
    terms: Terms,
) {
    let n = model.dof();
    let a0 = if terms.gravity {
        Motion {
            w: Vector3::zeros(),
            v: -model.gravity_base,
        }
    } else {
        Motion::zero()
    };
    let nvr = model.root_dims().1;
    let (v_top, a_top) = match &model.root {
        Some(root) => {
            let v = root.motion(qd.get(..nvr).unwrap_or(&[]));
            let a = data
                .root
                .x
                .apply_motion(&a0)
                .add(&root.motion(qdd.map_or(&[][..], |a| &a[..nvr])));
            let iv = root.inertia.mul_motion(&v);
            data.root.f = root.inertia.mul_motion(&a).add(&v.cross_force(&iv));
            data.root.v = v;
            data.root.a = a;
            (v, a)
        }
        None => (Motion::zero(), a0),
    };
    for j in 0..n {
        let link = &model.links[j];
        let x = &data.x[j];
        let (v_parent, a_parent) = match link.parent {
            Some(p) => (data.v[p], data.a[p]),
            None => (v_top, a_top),
        };
        let (cols, k) = columns(link);
        let vj = combine(&cols, k, qd, link.iv);
        let v = x.apply_motion(&v_parent).add(&vj);
        let a = x
            .apply_motion(&a_parent)
            .add(&combine(&cols, k, qdd.unwrap_or(&[]), link.iv))
            .add(&v.cross_motion(&vj));
        let iv = link.inertia.mul_motion(&v);
        data.f[j] = link.inertia.mul_motion(&a).add(&v.cross_force(&iv));
        data.v[j] = v;
        data.a[j] = a;
    }
    for j in (0..n).rev() {
        let link = &model.links[j];
        let (cols, k) = columns(link);
        for (i, c) in cols.iter().enumerate().take(k) {
            let mut tau = c.dot(&data.f[j]);
            if terms.motor {
                tau += link.motor_inertia * qdd.map_or(0.0, |a| a[link.iv + i]);
            }
            data.tau[link.iv + i] = tau;
        }
        let fp = data.x[j].transpose_force(&data.f[j]);
        if let Some(p) = link.parent {
            data.f[p] = data.f[p].add(&fp);
        } else if model.root.is_some() {
            data.root.f = data.root.f.add(&fp);
        }
    }
    if let Some(root) = &model.root {
        for (i, s) in root.s.iter().enumerate() {
            data.tau[i] = s.dot(&data.root.f);
        }
    }
}
