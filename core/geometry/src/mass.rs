//! Mass properties of a closed polyhedron of uniform density: volume, centre of mass and the
//! inertia tensor about the centre of mass.
//!
//! Method: signed tetrahedral decomposition (divergence theorem). Each face is fanned into
//! triangles; each triangle and a reference point r (the bounding-box centre, for accuracy far
//! from the origin) span a tetrahedron whose signed volume, first and second moments are exact
//! (Tonon, "Explicit exact formulas for the 3-D tetrahedron inertia tensor in terms of its vertex
//! coordinates", J. Math. Stat. 2004; the covariance form used by Blow & Binstock, "How to find
//! the inertia tensor (or other mass properties) of a 3D solid body represented by a triangle
//! mesh", 2004). For a tetrahedron r, r+a, r+b, r+c with A = [a b c]:
//! `C = det(A) · A · C₀ · Aᵀ`, `C₀ = (1/120)[[2,1,1],[1,2,1],[1,1,2]]` is the second moment
//! `∫ x xᵀ dV` about r. Summing over faces gives the solid's moments (outward faces make the
//! signed sum equal to the enclosed region's).
//!
//! Entry point: [`Polyhedron::mass_properties`].

use crate::Polyhedron;
use nalgebra::{Matrix3, Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Mass properties in the solid's own frame. SI units: m³, kg, m, kg·m².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MassProperties {
    /// Enclosed volume, m³.
    pub volume: f64,
    /// density × volume, kg.
    pub mass: f64,
    /// Centre of mass, m (solid frame).
    pub center_of_mass: Point3<f64>,
    /// Inertia tensor about the centre of mass, axes of the solid frame, kg·m².
    pub inertia: Matrix3<f64>,
}

/// Why mass properties could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MassError {
    /// The density is negative or not finite.
    #[error("density {density} kg/m³ must be finite and non-negative")]
    BadDensity { density: f64 },
    /// The surface does not enclose a volume (open, or inconsistently oriented).
    #[error(
        "the solid is not closed (some side is not matched by exactly one opposite side): it encloses no volume"
    )]
    NotClosed,
    /// The enclosed volume is zero or negative (inward-facing polygons).
    #[error("the solid's signed volume is {volume:e} m³ (faces point inward or the solid is flat)")]
    NonPositiveVolume { volume: f64 },
}

impl MassProperties {
    /// These properties seen in a frame where the solid's frame sits at rotation `r` and
    /// translation `t` (`x' = R x + t`): the centre moves, the inertia rotates as `R I Rᵀ`.
    pub fn transformed(&self, iso: &nalgebra::Isometry3<f64>) -> Self {
        let r = iso.rotation.to_rotation_matrix();
        MassProperties {
            center_of_mass: iso * self.center_of_mass,
            inertia: r.matrix() * self.inertia * r.matrix().transpose(),
            ..*self
        }
    }

    /// Sums bodies expressed in one frame (parallel-axis theorem). `None` for an empty list.
    /// Bodies of zero mass contribute only their volume.
    pub fn combine(parts: &[MassProperties]) -> Option<MassProperties> {
        if parts.is_empty() {
            return None;
        }
        let volume: f64 = parts.iter().map(|p| p.volume).sum();
        let mass: f64 = parts.iter().map(|p| p.mass).sum();
        let com = if mass > 0.0 {
            Point3::from(
                parts.iter().fold(Vector3::zeros(), |a, p| {
                    a + p.center_of_mass.coords * p.mass
                }) / mass,
            )
        } else if volume > 0.0 {
            Point3::from(
                parts.iter().fold(Vector3::zeros(), |a, p| {
                    a + p.center_of_mass.coords * p.volume
                }) / volume,
            )
        } else {
            Point3::origin()
        };
        let mut inertia = Matrix3::zeros();
        for p in parts {
            let d = p.center_of_mass - com;
            inertia +=
                p.inertia + p.mass * (Matrix3::identity() * d.norm_squared() - d * d.transpose());
        }
        Some(MassProperties {
            volume,
            mass,
            center_of_mass: com,
            inertia,
        })
    }
}

impl Polyhedron {
    /// Volume, mass, centre of mass and inertia about the centre of mass for a uniform
    /// `density` (kg/m³; 1.0 gives the geometric moments). The solid must be closed and its
    /// faces outward ([`Polyhedron::is_closed`]). O(number of polygon sides). No side effects.
    pub fn mass_properties(&self, density: f64) -> Result<MassProperties, MassError> {
        if !(density.is_finite() && density >= 0.0) {
            return Err(MassError::BadDensity { density });
        }
        if !self.is_closed() {
            return Err(MassError::NotClosed);
        }
        let r = self.bbox.center;
        let c0 = Matrix3::new(2.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 1.0, 2.0) / 120.0;
        let mut six_v = 0.0; // Σ det
        let mut first = Vector3::zeros(); // Σ det · (a+b+c)
        let mut second = Matrix3::zeros(); // Σ C (about r)
        for i in 0..self.polygons.len() {
            let ids = self.polygon_indices(i);
            let a = self.vertices[ids[0] as usize] - r;
            for k in 1..ids.len() - 1 {
                let b = self.vertices[ids[k] as usize] - r;
                let c = self.vertices[ids[k + 1] as usize] - r;
                let m = Matrix3::from_columns(&[a, b, c]);
                let det = m.determinant();
                six_v += det;
                first += det * (a + b + c);
                second += det * (m * c0 * m.transpose());
            }
        }
        let volume = six_v / 6.0;
        let scale = self.bbox.half.norm().max(f64::MIN_POSITIVE);
        // vertices are finite (validated), so volume is not NaN
        if volume <= 1e-15 * scale.powi(3) {
            return Err(MassError::NonPositiveVolume { volume });
        }
        // centroid of a tetrahedron r,a,b,c is (a+b+c)/4 about r; weighted by det/6
        let c = first / 24.0 / volume;
        let cov = second - volume * c * c.transpose(); // ∫ (x−c)(x−c)ᵀ dV
        let inertia = density * (Matrix3::identity() * cov.trace() - cov);
        Ok(MassProperties {
            volume,
            mass: density * volume,
            center_of_mass: r + c,
            inertia,
        })
    }
}
