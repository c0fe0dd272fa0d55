//! The joint-space inertia matrix by the composite-rigid-body algorithm (Walker & Orin 1982;
//! Featherstone 2008, §6.2, Table 6.2), and forward dynamics through it with a Cholesky solve —
//! the cross-check for [`crate::aba`]. Entry points: [`crba`], [`fd_cholesky`].

use crate::data::Data;
use crate::model::{DynamicsError, Model};
use crate::rnea::{ALL, rnea_pass};
use crate::spherical::columns;
use nalgebra::DMatrix;

/// `M(q)` (kg·m², kg, or kg·m for mixed entries), motor inertia on the diagonal. Fills and
/// returns `data.mass_matrix` (symmetric, both triangles). Depends only on q.
pub fn crba<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
) -> Result<&'d DMatrix<f64>, DynamicsError> {
    model.check_q(q)?;
    data.update_transforms(model, q);
    crba_pass(model, data);
    Ok(&data.mass_matrix)
}

pub(crate) fn crba_pass(model: &Model, data: &mut Data) {
    if model.spherical {
        return spherical_crba_pass(model, data);
    }
    let n = model.dof();
    // a floating root's coordinates come first (r of them; 0 for a fixed base)
    let r = model.root_dims().1;
    if !model.robot.is_chain() {
        data.mass_matrix.fill(0.0);
    }
    for j in 0..n {
        data.ic[j] = model.links[j].inertia;
    }
    if let Some(root) = &model.root {
        data.root.ic = root.inertia;
    }
    for j in (0..n).rev() {
        if let Some(p) = model.links[j].parent {
            let moved = data.ic[j].in_parent(&data.x[j]);
            data.ic[p] = data.ic[p].add(&moved);
        } else if model.root.is_some() {
            let moved = data.ic[j].in_parent(&data.x[j]);
            data.root.ic = data.root.ic.add(&moved);
        }
        let mut f = data.ic[j].mul_motion(&model.links[j].s);
        data.mass_matrix[(r + j, r + j)] = model.links[j].s.dot(&f) + model.links[j].motor_inertia;
        // Up the support path; entries of joints on other branches stay 0.
        let mut k = j;
        while let Some(p) = model.links[k].parent {
            f = data.x[k].transpose_force(&f);
            k = p;
            let mkj = model.links[k].s.dot(&f);
            data.mass_matrix[(r + k, r + j)] = mkj;
            data.mass_matrix[(r + j, r + k)] = mkj;
        }
        if let Some(root) = &model.root {
            // joint j's column continues into the root body (link frame 0)
            let f0 = data.x[k].transpose_force(&f);
            for (i, s) in root.s.iter().enumerate() {
                let m = s.dot(&f0);
                data.mass_matrix[(i, r + j)] = m;
                data.mass_matrix[(r + j, i)] = m;
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

/// Forward dynamics `q̈ = M⁻¹ (τ − C q̇ − g)` (rigid body, as [`crate::aba`]) by CRBA, RNEA (for the bias) and an
/// in-place Cholesky factorisation. O(n³); use [`crate::aba`] in loops. Fills `data.qdd` (and
/// `data.mass_matrix`, `data.tau` = the bias) and returns `data.qdd`.
pub fn fd_cholesky<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
) -> Result<&'d nalgebra::DVector<f64>, DynamicsError> {
    model.check_q(q)?;
    model.check_vector("qd", qd)?;
    model.check_vector("tau", tau)?;
    data.update_transforms(model, q);
    crba_pass(model, data);
    rnea_pass(model, data, qd, None, ALL);
    let n = model.nv();
    for i in 0..n {
        data.rhs[i] = tau[i] - data.tau[i];
    }
    cholesky_in_place(&data.mass_matrix, &mut data.chol)?;
    // forward then back substitution: L y = b, Lᵀ x = y
    for i in 0..n {
        let mut s = data.rhs[i];
        for k in 0..i {
            s -= data.chol[(i, k)] * data.rhs[k];
        }
        data.rhs[i] = s / data.chol[(i, i)];
    }
    for i in (0..n).rev() {
        let mut s = data.rhs[i];
        for k in i + 1..n {
            s -= data.chol[(k, i)] * data.qdd[k];
        }
        data.qdd[i] = s / data.chol[(i, i)];
    }
    Model::check_result("qdd", data.qdd.as_slice())?;
    Ok(&data.qdd)
}

/// Lower Cholesky factor of symmetric `m` into `l` (no allocation). Fails with
/// [`DynamicsError::SingularInertia`] naming the first joint whose pivot is not positive.
pub(crate) fn cholesky_in_place(
    m: &DMatrix<f64>,
    l: &mut DMatrix<f64>,
) -> Result<(), DynamicsError> {
    let n = m.nrows();
    for j in 0..n {
        let mut d = m[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 0.0 {
            return Err(DynamicsError::SingularInertia {
                joint: j,
                inertia: d,
            });
        }
        let dj = d.sqrt();
        l[(j, j)] = dj;
        for i in j + 1..n {
            let mut s = m[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / dj;
        }
    }
    Ok(())
}

/// Solves `L Lᵀ x = b` in place (`b` becomes `x`) with the lower factor from
/// [`cholesky_in_place`].
pub(crate) fn cholesky_solve_in_place(l: &DMatrix<f64>, b: &mut nalgebra::DVector<f64>) {
    let n = l.nrows();
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
}

/// [`crba_pass`] for a model with spherical joints (see [`crate::spherical`]), over transforms
/// already in `data.x`.
fn spherical_crba_pass(model: &Model, data: &mut Data) {
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
