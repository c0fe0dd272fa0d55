//! Inertials another tool loads, shared by the URDF and MJCF exports ([`crate::urdf`],
//! [`crate::mjcf_export`]): MuJoCo refuses a moving body without mass or inertia and an inertia
//! whose principal moments break A + B ≥ C, so an export writes [`loadable_inertial`] of each
//! moving link — the tensor made physical ([`physical_inertia`]), a massless link given
//! [`TINY_MASS`], one without inertia [`TINY_INERTIA`] — and returns each change as a note.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// The mass given to a moving link without mass (kg): MuJoCo refuses a body with joints and
/// no mass ("mass and inertia of moving bodies must be larger than mjMINVAL").
pub const TINY_MASS: f64 = 1e-9;
/// Its principal moments (kg·m²).
pub const TINY_INERTIA: f64 = 1e-12;

/// A link's inertia as another tool will accept it: the tensor itself when its principal
/// moments are non-negative and satisfy the triangle inequalities (A + B ≥ C for every
/// ordering), else the nearest such tensor with the same principal axes — negative moments set
/// to 0, then the two smaller moments raised by half the deficit each — and a sentence saying
/// which inequality was broken and by how much. Deficits below 1e-9 of C (rounding in the
/// data) are fixed without a note.
pub fn physical_inertia(inertia: &Matrix3<f64>, what: &str) -> (Matrix3<f64>, Option<String>) {
    let e = SymmetricEigen::new(*inertia);
    let mut m: Vec<(f64, usize)> = e
        .eigenvalues
        .iter()
        .enumerate()
        .map(|(i, &v)| (v.max(0.0), i))
        .collect();
    m.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (a, b, c) = (m[0].0, m[1].0, m[2].0);
    let negative = e.eigenvalues.min() < 0.0;
    // A margin of a few ulps of C: the loader re-diagonalises what is written.
    let deficit = c - a - b;
    if deficit < -1e-12 * c && !negative {
        return (*inertia, None);
    }
    let raise = deficit.max(0.0) / 2.0 + 1e-12 * c;
    let mut d = Vector3::zeros();
    d[m[0].1] = a + raise;
    d[m[1].1] = b + raise;
    d[m[2].1] = c;
    let fixed = e.eigenvectors * Matrix3::from_diagonal(&d) * e.eigenvectors.transpose();
    let fixed = (fixed + fixed.transpose()) / 2.0;
    let note = (deficit > 1e-9 * c || negative).then(|| {
        format!(
            "{what}: principal moments {a:e}, {b:e}, {c:e} kg·m² break A + B ≥ C by {deficit:e}{}; written with the two smaller raised by {raise:e} each",
            if negative {
                " (a negative moment was set to 0)"
            } else {
                ""
            }
        )
    });
    (fixed, note)
}

/// The mass and inertia written for a moving link: [`physical_inertia`] of its own, then a
/// link without mass gets [`TINY_MASS`] (its inertia kept when it has one: the PUMA's link 1 is
/// massless with a rotor-side inertia about its axis) and a link without inertia
/// [`TINY_INERTIA`] about each axis. Each change is a note (MuJoCo refuses a body with a joint
/// and no mass or inertia).
pub fn loadable_inertial(
    mass: f64,
    inertia: &Matrix3<f64>,
    what: &str,
    notes: &mut Vec<String>,
) -> (f64, Matrix3<f64>) {
    let (mut i, note) = physical_inertia(inertia, what);
    notes.extend(note);
    if i.trace() <= 0.0 {
        i = Matrix3::identity() * TINY_INERTIA;
    }
    if mass > 0.0 {
        if inertia.trace() <= 0.0 {
            notes.push(format!(
                "{what}: a point mass (no inertia); written with {TINY_INERTIA:e} kg·m² about each axis (MuJoCo refuses a moving body without inertia)"
            ));
        }
        (mass, i)
    } else {
        notes.push(format!(
            "{what}: no mass; written as {TINY_MASS:e} kg{} (MuJoCo refuses a moving body without mass)",
            if inertia.trace() > 0.0 {
                ", its inertia kept".to_string()
            } else {
                format!(" with {TINY_INERTIA:e} kg·m² about each axis")
            }
        ));
        (TINY_MASS, i)
    }
}
