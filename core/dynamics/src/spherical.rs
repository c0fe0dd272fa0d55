//! RNEA, CRBA, ABA and energy of a robot with spherical (ball) joints
//! (`robosim_kinematics::Joint::spherical`; layout in `robosim_kinematics::spherical`: q a unit
//! quaternion `qx qy qz qw`, v the angular velocity in the child frame — Pinocchio's
//! `JointModelSpherical`).
//!
//! The same recursions as [`crate::rnea`], [`crate::crba`] and [`crate::aba`] with a joint's
//! motion subspace `S_j` of k columns (k = 1, or 3 for a spherical joint: the child frame's unit
//! rotations `[e_i; 0]`, constant in the child frame, so the joint's velocity-product term is 0)
//! and its coordinates at `Link::iv` in v (Featherstone 2008, Tables 5.1, 6.2 and 7.1 with
//! multi-DOF joints; ABA's `D = Sᵀ Iᴬ S` is 3 × 3 and inverted by Cholesky). Motor inertia
//! (armature) adds to each of a spherical joint's three diagonal entries, as Pinocchio's and
//! MuJoCo's armature does. A model without spherical joints never comes here (the passes check
//! one flag), so its numbers and speed are those of the one-coordinate code.

use crate::data::Data;
use crate::energy::Energy;
use crate::model::{DynamicsError, Link, Model};
use crate::rnea::Terms;
use crate::spatial::{Force, Motion, Xform};
use nalgebra::{Matrix3, Matrix6x3, Vector3, Vector6};
use robosim_kinematics::spherical::quat_rotation;

/// A spherical joint's ABA quantities: `U = Iᴬ S` (6 × 3), `D⁻¹` and `u = τ − Sᵀ pᴬ`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct BallScratch {
    pub u6: Matrix6x3<f64>,
    pub dinv: Matrix3<f64>,
    pub u: Vector3<f64>,
}

/// The motion subspace's columns of `link` (the first `k` of the array are used).
#[inline]
fn columns(link: &Link) -> ([Motion; 3], usize) {
    if link.spherical {
        let e = |i: usize| Motion {
            w: Vector3::ith(i, 1.0),
            v: Vector3::zeros(),
        };
        ([e(0), e(1), e(2)], 3)
    } else {
        ([link.s, Motion::zero(), Motion::zero()], 1)
    }
}

/// `Σ S_i x[i]` over the link's columns (an `x` too short reads as zeros).
#[inline]
fn combine(cols: &[Motion; 3], k: usize, x: &[f64], at: usize) -> Motion {
    let mut m = Motion::zero();
    for (i, c) in cols.iter().enumerate().take(k) {
        m = m.add(&c.scale(x.get(at + i).copied().unwrap_or(0.0)));
    }
    m
}

/// The parent-to-child transforms at `q` (q's layout: the root's, then each joint's 1 or 4).
pub(crate) fn update_transforms(data: &mut Data, model: &Model, q: &[f64]) {
    if let Some(root) = &model.root {
        let (r, t) = root.kind.rotation_translation(&q[..root.kind.nq()]);
        data.root.x = Xform {
            e: r.transpose(),
            r: t,
        };
    }
    for (x, link) in data.x.iter_mut().zip(&model.links) {
        let qj = &q[link.iq..];
        if link.spherical {
            // child in parent: R_c · R(quat), so e = R(quat)ᵀ e_c
            x.e = quat_rotation(qj).transpose() * link.e_c;
            x.r = link.r_c;
        } else {
            let t = qj[0] + link.offset;
            match link.motor {
                crate::model::Motor::Prismatic => {
                    x.e = link.e_c;
                    x.r = link.r_c + link.e_c.tr_mul(&link.axis) * t;
                }
                _ => {
                    x.e = robosim_kinematics::axis_rotation(&link.axis, t).transpose() * link.e_c;
                    x.r = link.r_c;
                }
            }
        }
    }
}

/// RNEA over transforms already in `data.x` (see [`crate::rnea`]): an empty `qd` is q̇ = 0,
/// `None` for `qdd` is q̈ = 0.
pub(crate) fn rnea_pass(
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

/// CRBA over transforms already in `data.x` (see [`crate::crba`]).
pub(crate) fn crba_pass(model: &Model, data: &mut Data) {
    let n = model.dof();
    data.mass_matrix.fill(0.0);
    for j in 0..n {
        data.ic[j] = model.links[j].inertia;
    }
    if let Some(root) = &model.root {
        data.root.ic = root.inertia;
    }
    for j in (0..n).rev() {
        let link = &model.links[j];
        if let Some(p) = link.parent {
            let moved = data.ic[j].in_parent(&data.x[j]);
            data.ic[p] = data.ic[p].add(&moved);
        } else if model.root.is_some() {
            let moved = data.ic[j].in_parent(&data.x[j]);
            data.root.ic = data.root.ic.add(&moved);
        }
        let (cols, kj) = columns(link);
        for (i, si) in cols.iter().enumerate().take(kj) {
            let col = link.iv + i;
            let mut f = data.ic[j].mul_motion(si);
            // the joint's own block, symmetric by construction (upper from the lower)
            for (b, sb) in cols.iter().enumerate().take(i + 1) {
                let m = sb.dot(&f);
                data.mass_matrix[(link.iv + b, col)] = m;
                data.mass_matrix[(col, link.iv + b)] = m;
            }
            data.mass_matrix[(col, col)] += link.motor_inertia;
            // up the support path; entries of joints on other branches stay 0
            let mut k = j;
            while let Some(p) = model.links[k].parent {
                f = data.x[k].transpose_force(&f);
                k = p;
                let lk = &model.links[k];
                let (ck, nk) = columns(lk);
                for (b, sb) in ck.iter().enumerate().take(nk) {
                    let m = sb.dot(&f);
                    data.mass_matrix[(lk.iv + b, col)] = m;
                    data.mass_matrix[(col, lk.iv + b)] = m;
                }
            }
            if let Some(root) = &model.root {
                let f0 = data.x[k].transpose_force(&f);
                for (b, s) in root.s.iter().enumerate() {
                    let m = s.dot(&f0);
                    data.mass_matrix[(b, col)] = m;
                    data.mass_matrix[(col, b)] = m;
                }
            }
        }
    }
    if let Some(root) = &model.root {
        for (a, sa) in root.s.iter().enumerate() {
            let f = data.root.ic.mul_motion(sa);
            for (b, sb) in root.s.iter().enumerate() {
                data.mass_matrix[(b, a)] = sb.dot(&f);
            }
        }
    }
}

/// ABA (see [`crate::aba`]); lengths are the caller's invariant. Fills `data.qdd`.
pub(crate) fn aba(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<(), DynamicsError> {
    let n = model.dof();
    let r = model.root_dims().1;
    update_transforms(data, model, q);
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
        Some(root) => crate::aba::root_acceleration(root, data, &tau[..r], &a0)?,
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

/// Kinetic and potential energy (see [`crate::energy`]).
pub(crate) fn energy(model: &Model, data: &mut Data, q: &[f64], qd: &[f64]) -> Energy {
    update_transforms(data, model, q);
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
