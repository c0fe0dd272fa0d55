//! Spatial (6-D) vector algebra in the 3-vector form of Featherstone, *Rigid Body Dynamics
//! Algorithms* (2008), ch. 2: a motion vector is `(ω, v)` with `v` the velocity of the body point
//! at the frame origin; a force vector is `(n, f)` with `n` the moment about the frame origin.
//! 6-vectors and 6×6 matrices (used by the articulated-body algorithm) order the angular part
//! first. Everything here is `Copy` and lives on the stack.

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

/// A spatial motion vector (velocity or acceleration): angular `w`, linear `v` at the origin.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Motion {
    pub w: Vector3<f64>,
    pub v: Vector3<f64>,
}

/// A spatial force vector: moment `n` about the origin, force `f`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Force {
    pub n: Vector3<f64>,
    pub f: Vector3<f64>,
}

impl Motion {
    pub fn zero() -> Self {
        Motion {
            w: Vector3::zeros(),
            v: Vector3::zeros(),
        }
    }
    pub fn scale(&self, s: f64) -> Motion {
        Motion {
            w: self.w * s,
            v: self.v * s,
        }
    }
    pub fn add(&self, o: &Motion) -> Motion {
        Motion {
            w: self.w + o.w,
            v: self.v + o.v,
        }
    }
    /// `self ×ₘ m` (motion cross product, Featherstone eq. 2.31).
    pub fn cross_motion(&self, m: &Motion) -> Motion {
        Motion {
            w: self.w.cross(&m.w),
            v: self.w.cross(&m.v) + self.v.cross(&m.w),
        }
    }
    /// `self ×* f` (force cross product, Featherstone eq. 2.32).
    pub fn cross_force(&self, f: &Force) -> Force {
        Force {
            n: self.w.cross(&f.n) + self.v.cross(&f.f),
            f: self.w.cross(&f.f),
        }
    }
    /// The power pairing `m · f`.
    pub fn dot(&self, f: &Force) -> f64 {
        self.w.dot(&f.n) + self.v.dot(&f.f)
    }
    pub fn to6(self) -> Vector6<f64> {
        Vector6::new(self.w.x, self.w.y, self.w.z, self.v.x, self.v.y, self.v.z)
    }
    pub fn from6(x: &Vector6<f64>) -> Motion {
        Motion {
            w: Vector3::new(x[0], x[1], x[2]),
            v: Vector3::new(x[3], x[4], x[5]),
        }
    }
}

impl Force {
    pub fn zero() -> Self {
        Force {
            n: Vector3::zeros(),
            f: Vector3::zeros(),
        }
    }
    pub fn add(&self, o: &Force) -> Force {
        Force {
            n: self.n + o.n,
            f: self.f + o.f,
        }
    }
    pub fn to6(self) -> Vector6<f64> {
        Vector6::new(self.n.x, self.n.y, self.n.z, self.f.x, self.f.y, self.f.z)
    }
    pub fn from6(x: &Vector6<f64>) -> Force {
        Force {
            n: Vector3::new(x[0], x[1], x[2]),
            f: Vector3::new(x[3], x[4], x[5]),
        }
    }
}

/// The coordinate transform from a parent frame to a child frame, `ᶜX_p`: `e` rotates parent
/// coordinates into child coordinates, `r` is the child origin in parent coordinates. Built from
/// a DH link transform `A = (R, p)` (child in parent) as `e = Rᵀ`, `r = p`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Xform {
    pub e: Matrix3<f64>,
    pub r: Vector3<f64>,
}

impl Default for Xform {
    fn default() -> Self {
        Xform {
            e: Matrix3::identity(),
            r: Vector3::zeros(),
        }
    }
}

impl Xform {
    /// Motion in parent coordinates → child coordinates.
    pub fn apply_motion(&self, m: &Motion) -> Motion {
        Motion {
            w: self.e * m.w,
            v: self.e * (m.v - self.r.cross(&m.w)),
        }
    }
    /// Force in child coordinates → parent coordinates (`Xᵀ f`).
    pub fn transpose_force(&self, f: &Force) -> Force {
        let fp = self.e.tr_mul(&f.f);
        Force {
            n: self.e.tr_mul(&f.n) + self.r.cross(&fp),
            f: fp,
        }
    }
    /// `Xᵀ I X` for a symmetric 6×6 (articulated) inertia `I` given in child coordinates: the
    /// same inertia in parent coordinates. Blockwise with `I = [[A, B], [Bᵀ, C]]`, rotated
    /// blocks `A' = EᵀAE`, … and `R = r×`: `[[A' + R B'ᵀ − B'R − R C' R, B' + R C'], [·, C']]`
    /// — about 60 % of the multiplications of the two 6×6 products.
    pub fn inertia_to_parent(&self, ia: &Matrix6<f64>) -> Matrix6<f64> {
        let et = self.e.transpose();
        let a = et * ia.fixed_view::<3, 3>(0, 0) * self.e;
        let b = et * ia.fixed_view::<3, 3>(0, 3) * self.e;
        let c = et * ia.fixed_view::<3, 3>(3, 3) * self.e;
        let r = skew(&self.r);
        let rc = r * c;
        let nb = b + rc;
        let na = a + r * b.transpose() - nb * r;
        let mut out = Matrix6::zeros();
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&na);
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&nb);
        out.fixed_view_mut::<3, 3>(3, 0).copy_from(&nb.transpose());
        out.fixed_view_mut::<3, 3>(3, 3).copy_from(&c);
        out
    }

    /// The 6×6 motion transform `[[E, 0], [−E r×, E]]` (tests check the 3-vector forms by it).
    #[cfg(test)]
    pub fn matrix(&self) -> Matrix6<f64> {
        let mut x = Matrix6::zeros();
        let erx = -self.e * skew(&self.r);
        x.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.e);
        x.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.e);
        x.fixed_view_mut::<3, 3>(3, 0).copy_from(&erx);
        x
    }
}

/// The skew-symmetric matrix with `skew(a) b = a × b`.
pub(crate) fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// A rigid-body spatial inertia about the frame origin: mass `m` (kg), first moment `h = m c`
/// (kg·m, `c` the centre of mass) and rotational inertia `ibar` about the origin (kg·m²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RigidInertia {
    pub m: f64,
    pub h: Vector3<f64>,
    pub ibar: Matrix3<f64>,
}

impl RigidInertia {
    pub fn zero() -> Self {
        RigidInertia {
            m: 0.0,
            h: Vector3::zeros(),
            ibar: Matrix3::zeros(),
        }
    }

    /// From mass, centre of mass and inertia about the centre of mass (parallel-axis theorem).
    pub fn from_com(m: f64, c: &Vector3<f64>, ic: &Matrix3<f64>) -> Self {
        let cx = skew(c);
        RigidInertia {
            m,
            h: c * m,
            ibar: ic - cx * cx * m,
        }
    }

    /// `I · m` (Featherstone eq. 2.63 in 3-vector form).
    pub fn mul_motion(&self, x: &Motion) -> Force {
        Force {
            n: self.ibar * x.w + self.h.cross(&x.v),
            f: x.v * self.m - self.h.cross(&x.w),
        }
    }

    pub fn add(&self, o: &RigidInertia) -> RigidInertia {
        RigidInertia {
            m: self.m + o.m,
            h: self.h + o.h,
            ibar: self.ibar + o.ibar,
        }
    }

    /// This inertia, given in child coordinates, expressed in parent coordinates (`Xᵀ I X`).
    pub fn in_parent(&self, x: &Xform) -> RigidInertia {
        let rot = x.e.transpose();
        let y = rot * self.h;
        let px = skew(&x.r);
        let yx = skew(&y);
        RigidInertia {
            m: self.m,
            h: y + x.r * self.m,
            ibar: rot * self.ibar * x.e - yx * px - px * yx - px * px * self.m,
        }
    }

    /// The 6×6 matrix `[[Ī, h×], [−h×, m 1]]`.
    pub fn matrix(&self) -> Matrix6<f64> {
        let mut out = Matrix6::zeros();
        let hx = skew(&self.h);
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.ibar);
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&hx);
        out.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-hx));
        out.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Matrix3::identity() * self.m));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xf() -> Xform {
        let e = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 0.7).into_inner();
        Xform {
            e,
            r: Vector3::new(0.2, -0.5, 0.9),
        }
    }

    #[test]
    fn three_vector_forms_match_the_six_by_six_matrices() {
        let x = xf();
        let m = Motion {
            w: Vector3::new(1.0, 2.0, -0.5),
            v: Vector3::new(-0.3, 0.4, 2.0),
        };
        let f = Force {
            n: Vector3::new(0.7, -1.0, 0.1),
            f: Vector3::new(2.0, 0.5, -1.5),
        };
        assert!((x.apply_motion(&m).to6() - x.matrix() * m.to6()).norm() < 1e-14);
        assert!((x.transpose_force(&f).to6() - x.matrix().transpose() * f.to6()).norm() < 1e-14);
        let i = RigidInertia::from_com(
            3.0,
            &Vector3::new(0.1, 0.2, -0.3),
            &Matrix3::new(0.5, 0.01, 0.02, 0.01, 0.4, 0.03, 0.02, 0.03, 0.3),
        );
        assert!((i.mul_motion(&m).to6() - i.matrix() * m.to6()).norm() < 1e-13);
        let xm = x.matrix();
        assert!((i.in_parent(&x).matrix() - xm.transpose() * i.matrix() * xm).norm() < 1e-13);
        // an articulated inertia (symmetric, not rigid-body shaped)
        let mut ia = i.matrix();
        ia += Matrix6::from_fn(|r, c| {
            0.1 * ((r * 7 + c * 3) % 5) as f64 + 0.1 * ((c * 7 + r * 3) % 5) as f64
        });
        assert!((x.inertia_to_parent(&ia) - xm.transpose() * ia * xm).norm() < 1e-12);
        // power is frame-invariant: (X m)·f_child == m·(Xᵀ f_child)
        assert!((x.apply_motion(&m).dot(&f) - m.dot(&x.transpose_force(&f))).abs() < 1e-13);
    }
}
