//! Mechanical energy, for drift studies of the integrators. Entry point: [`energy`].

use crate::data::{Data, spherical_update_transforms};
use crate::model::{DynamicsError, Model};
use crate::spatial::Motion;
use crate::spherical::{columns, combine};

/// Kinetic, potential and total energy (J).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Energy {
    /// `½ Σ vⱼᵀ Iⱼ vⱼ + ½ Σ I_motor q̇²`.
    pub kinetic: f64,
    /// `−Σ mⱼ g · cⱼ` with `cⱼ` each link's centre of mass in the world (zero at the world origin).
    pub potential: f64,
}

impl Energy {
    pub fn total(&self) -> f64 {
        self.kinetic + self.potential
    }
}

/// The mechanical energy at (q, q̇). Depends on q and q̇; writes scratch in `data`.
pub fn energy(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
) -> Result<Energy, DynamicsError> {
    model.check_q(q)?;
    model.check_vector("qd", qd)?;
    Ok(energy_unchecked(model, data, q, qd))
}

pub(crate) fn energy_unchecked(model: &Model, data: &mut Data, q: &[f64], qd: &[f64]) -> Energy {
    if model.spherical {
        return spherical_energy(model, data, q, qd);
    }
    data.update_transforms(model, q);
    let base = &model.robot.base;
    let base_rot = base.fixed_view::<3, 3>(0, 0).into_owned();
    let base_pos = base.fixed_view::<3, 1>(0, 3).into_owned();
    let g = model.robot.gravity;
    let (mut kinetic, mut potential) = (0.0, 0.0);
    let r = model.root_dims().1;
    // the bodies hanging from the base hang from a floating robot's root body
    let (v_top, rot_top, pos_top) = match &model.root {
        Some(root) => {
            let x = &data.root.x;
            let v = root.motion(&qd[..r]);
            kinetic += 0.5 * v.dot(&root.inertia.mul_motion(&v));
            let pos = base_pos + base_rot * x.r;
            let rot = base_rot * x.e.transpose();
            potential -= g.dot(&(rot * root.inertia.h + pos * root.inertia.m));
            (v, rot, pos)
        }
        None => (Motion::zero(), base_rot, base_pos),
    };
    for j in 0..model.dof() {
        let link = &model.links[j];
        let x = &data.x[j];
        let (v_parent, rot_p, pos_p) = match link.parent {
            Some(p) => (data.v[p], data.world[p].0, data.world[p].1),
            None => (v_top, rot_top, pos_top),
        };
        let qdj = qd[r + j];
        let v = x.apply_motion(&v_parent).add(&link.s.scale(qdj));
        kinetic += 0.5 * v.dot(&link.inertia.mul_motion(&v)) + 0.5 * link.motor_inertia * qdj * qdj;
        // world pose of body j: R_j = R_parent Eᵀ, p_j = p_parent + R_parent r
        let pos = pos_p + rot_p * x.r;
        let rot = rot_p * x.e.transpose();
        potential -= g.dot(&(rot * link.inertia.h + pos * link.inertia.m));
        data.v[j] = v;
        data.world[j] = (rot, pos);
    }
    Energy { kinetic, potential }
}

/// `∂T/∂q` at fixed q̇ (N·m or N): the configuration gradient of the kinetic energy, needed by the
/// momentum-form symplectic Euler step. O(n): with `hᶜⱼ` the spatial momentum of the subtree
/// outboard of joint j, `∂T/∂qⱼ = (vⱼ ×ₘ Sⱼ) · hᶜⱼ` (from `∂Sₖ/∂qⱼ = Sⱼ ×ₘ Sₖ` for k > j,
/// Featherstone 2008 §3.5; the link inertias rotate with the joint too). Fills and returns
/// `data.tau`; also leaves the generalized momentum `M q̇` in `data.rhs`.
pub fn kinetic_gradient<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
) -> Result<&'d nalgebra::DVector<f64>, DynamicsError> {
    model.check_q(q)?;
    model.check_vector("qd", qd)?;
    model
        .robot
        .refuse_spherical("the kinetic-energy gradient")?;
    data.update_transforms(model, q);
    kinetic_gradient_pass(model, data, qd);
    Ok(&data.tau)
}

/// [`kinetic_gradient`] over transforms already in `data.x`; motor inertia adds only momentum.
pub(crate) fn kinetic_gradient_pass(model: &Model, data: &mut Data, qd: &[f64]) {
    let n = model.dof();
    let r = model.root_dims().1;
    let v_top = match &model.root {
        Some(root) => {
            let v = root.motion(&qd[..r]);
            data.root.v = v;
            data.root.f = root.inertia.mul_motion(&v);
            v
        }
        None => Motion::zero(),
    };
    for j in 0..n {
        let link = &model.links[j];
        let v_parent = match link.parent {
            Some(p) => data.v[p],
            None => v_top,
        };
        let v = data.x[j]
            .apply_motion(&v_parent)
            .add(&link.s.scale(qd[r + j]));
        data.v[j] = v;
        data.f[j] = link.inertia.mul_motion(&v);
    }
    for j in (0..n).rev() {
        let link = &model.links[j];
        let hc = data.f[j];
        data.tau[r + j] = data.v[j].cross_motion(&link.s).dot(&hc);
        data.rhs[r + j] = link.s.dot(&hc) + link.motor_inertia * qd[r + j];
        if let Some(p) = link.parent {
            let moved = data.x[j].transpose_force(&hc);
            data.f[p] = data.f[p].add(&moved);
        } else if model.root.is_some() {
            let moved = data.x[j].transpose_force(&hc);
            data.root.f = data.root.f.add(&moved);
        }
    }
    // the root's coordinates: the same formula with its unit twists; in the root's own
    // (body) velocity this is the Euler–Poincaré term −v ×* h of a floating body
    if let Some(root) = &model.root {
        let (v, hc) = (data.root.v, data.root.f);
        for (i, s) in root.s.iter().enumerate() {
            data.tau[i] = v.cross_motion(s).dot(&hc);
            data.rhs[i] = s.dot(&hc);
        }
    }
}

/// [`energy_unchecked`] for a model with spherical joints (see [`crate::spherical`]).
fn spherical_energy(model: &Model, data: &mut Data, q: &[f64], qd: &[f64]) -> Energy {
    spherical_update_transforms(data, model, q);
    let base = &model.robot.base;
    let base_rot = base.fixed_view::<3, 3>(0, 0).into_owned();
    let base_pos = base.fixed_view::<3, 1>(0, 3).into_owned();
    let g = model.robot.gravity;
    let (mut kinetic, mut potential) = (0.0, 0.0);
    let r = model.root_dims().1;
    let (v_top, rot_top, pos_top) = match &model.root {
        Some(root) => {
            let x = &data.root.x;
            let v = root.motion(&qd[..r]);
            kinetic += 0.5 * v.dot(&root.inertia.mul_motion(&v));
            let pos = base_pos + base_rot * x.r;
            let rot = base_rot * x.e.transpose();
            potential -= g.dot(&(rot * root.inertia.h + pos * root.inertia.m));
            (v, rot, pos)
        }
        None => (Motion::zero(), base_rot, base_pos),
    };
    for j in 0..model.dof() {
        let link = &model.links[j];
        let x = &data.x[j];
        let (v_parent, rot_p, pos_p) = match link.parent {
            Some(p) => (data.v[p], data.world[p].0, data.world[p].1),
            None => (v_top, rot_top, pos_top),
        };
        let (cols, k) = columns(link);
        let v = x
            .apply_motion(&v_parent)
            .add(&combine(&cols, k, qd, link.iv));
        let motor: f64 = qd[link.iv..link.iv + k].iter().map(|w| w * w).sum();
        kinetic += 0.5 * v.dot(&link.inertia.mul_motion(&v)) + 0.5 * link.motor_inertia * motor;
        let pos = pos_p + rot_p * x.r;
        let rot = rot_p * x.e.transpose();
        potential -= g.dot(&(rot * link.inertia.h + pos * link.inertia.m));
        data.v[j] = v;
        data.world[j] = (rot, pos);
    }
    Energy { kinetic, potential }
}
