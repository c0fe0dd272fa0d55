//! Mimic joints (URDF's `<mimic joint multiplier offset>`, Pinocchio's `JointModelMimic`): a
//! **follower** joint whose coordinate is not free but `q_f = multiplier · q_leader + offset`,
//! so leader and follower are **one coordinate**.
//!
//! # Design: a coupling beside the robot
//!
//! The [`Robot`] stays the *full* model — every movable joint a coordinate, mimic joints
//! included (Pinocchio's `buildModel(…, mimic=False)` layout), so every algorithm over a
//! `Robot` (FK, Jacobians, IK, RNEA/CRBA/ABA, the simulator, the query protocol) is unchanged,
//! bit for bit and at the same cost, for every robot. A [`Coupling`] says which full
//! coordinates follow which: it maps a **reduced** coordinate vector (the free coordinates, in
//! full-q order) to the full one,
//!
//! ```text
//! q = φ(q_r)        q_f = m·q_l + c  (a follower),  q_i = q_r[k]  (a free coordinate)
//! q̇ = G q̇_r         G: full × reduced, one non-zero (1 or m) per follower's and free row
//! ```
//!
//! and the algorithms over the reduced coordinates are the full ones composed with it:
//! `T(q_r) = T(φ(q_r))`, `J_r = J G`, and (in `robosim_dynamics::mimic`) `τ_r = Gᵀ τ(φ(q_r),
//! G q̇_r, G q̈_r)`, `M_r = Gᵀ M G`. A follower whose leader is not part of the robot (held
//! at 0 by a chain import) is **fixed** at its offset: a zero row of G.
//!
//! A follower of a follower is resolved to the free coordinate at the end
//! (`q = m₁(m₂ q_l + c₂) + c₁`); a cycle is refused ([`MimicError::Cycle`]).
//!
//! Entry points: [`Coupling::new`] (from [`Mimic`] relations), [`Coupling::expand_q`],
//! [`Coupling::expand_v`], [`Coupling::reduce_force`], [`Coupling::reduce_columns`],
//! [`Coupling::reduce_matrix`], [`Coupling::matrix`]; [`forward`], [`link_jacobian`],
//! [`jacobian`] — FK and Jacobians at a reduced q.
//!
//! Mimic relations are between joints (revolute and prismatic: one coordinate each); a floating
//! base's coordinates ([`Robot::root`], [`Coupling::with_root`]) come first in every full and
//! reduced vector and pass through unchanged (G is the identity on them).

use crate::jacobian::{Frame, Jacobian, link_jacobian_into, to_tool_frame};
use crate::model::Robot;
use nalgebra::{DMatrix, DVector, Matrix4};

/// One `<mimic>` relation, by full coordinate index: `q[follower] = multiplier · q[leader] +
/// offset`; `leader: None` — the leader is not a coordinate of the robot (held at 0), so the
/// follower is fixed at `offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mimic {
    pub follower: usize,
    pub leader: Option<usize>,
    pub multiplier: f64,
    pub offset: f64,
}

/// Why a set of mimic relations was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MimicError {
    /// A follower or leader index is not a coordinate of the robot.
    #[error("mimic joint index {index} is not one of the robot's {dof} coordinates")]
    OutOfRange { index: usize, dof: usize },
    /// The same coordinate follows two relations.
    #[error("coordinate {0} mimics two joints")]
    TwoLeaders(usize),
    /// A coordinate follows itself, directly or through other followers.
    #[error("coordinate {0} mimics itself (through a cycle of mimic joints)")]
    Cycle(usize),
    /// A multiplier or offset is NaN or infinite.
    #[error("coordinate {follower}: mimic {field} is not finite ({value})")]
    NonFinite {
        follower: usize,
        field: &'static str,
        value: f64,
    },
    /// A vector given to the coupling has the wrong length.
    #[error("`{field}` has {got} values, expected {expected}")]
    WrongLength {
        field: &'static str,
        expected: usize,
        got: usize,
    },
    /// The robot has a spherical joint: the coupling's coordinates are one per joint.
    #[error("{0}")]
    Spherical(crate::ModelError),
}

/// How one full coordinate is obtained from the reduced vector.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// The reduced coordinate `k` itself.
    Free(usize),
    /// `multiplier · q_r[reduced] + offset`.
    Follows {
        reduced: usize,
        multiplier: f64,
        offset: f64,
    },
    /// A constant (a follower of a joint that is not a coordinate).
    Fixed(f64),
}

/// The map from reduced to full coordinates (see the module docs). Cheap to apply: one entry
/// per full coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Coupling {
    source: Vec<Source>,
    /// The full index of each reduced coordinate, increasing.
    free: Vec<usize>,
    /// A floating base's coordinates ([`Robot::root`]: `root_nq` in q, `root_nv` in v), first
    /// in every full and reduced vector and passed through unchanged.
    root_nq: usize,
    root_nv: usize,
}

impl Coupling {
    /// The coupling of a robot with `dof` coordinates under `mimics`. Every coordinate not a
    /// follower is free; followers of followers are resolved; refused: an index past `dof`, a
    /// coordinate with two leaders, a cycle, a non-finite multiplier or offset.
    pub fn new(dof: usize, mimics: &[Mimic]) -> Result<Coupling, MimicError> {
        let mut rel: Vec<Option<Mimic>> = vec![None; dof];
        for m in mimics {
            for index in std::iter::once(m.follower).chain(m.leader) {
                if index >= dof {
                    return Err(MimicError::OutOfRange { index, dof });
                }
            }
            for (field, value) in [("multiplier", m.multiplier), ("offset", m.offset)] {
                if !value.is_finite() {
                    return Err(MimicError::NonFinite {
                        follower: m.follower,
                        field,
                        value,
                    });
                }
            }
            if rel[m.follower].replace(*m).is_some() {
                return Err(MimicError::TwoLeaders(m.follower));
            }
        }
        let free: Vec<usize> = (0..dof).filter(|&i| rel[i].is_none()).collect();
        let mut reduced_of = vec![usize::MAX; dof];
        for (k, &i) in free.iter().enumerate() {
            reduced_of[i] = k;
        }
        let mut source = Vec::with_capacity(dof);
        for i in 0..dof {
            // follow the leaders to a free coordinate (or a fixed one), composing the affine maps
            let (mut m, mut c, mut at, mut steps) = (1.0, 0.0, i, 0);
            let s = loop {
                match rel[at] {
                    None => {
                        break if at == i {
                            Source::Free(reduced_of[i])
                        } else {
                            Source::Follows {
                                reduced: reduced_of[at],
                                multiplier: m,
                                offset: c,
                            }
                        };
                    }
                    Some(r) => {
                        // q_at = r.m · q_leader + r.c, and q_i = m · q_at + c
                        c += m * r.offset;
                        m *= r.multiplier;
                        match r.leader {
                            None => break Source::Fixed(c),
                            Some(l) => at = l,
                        }
                    }
                }
                steps += 1;
                if steps > dof {
                    return Err(MimicError::Cycle(i));
                }
            };
            source.push(s);
        }
        Ok(Coupling {
            source,
            free,
            root_nq: 0,
            root_nv: 0,
        })
    }

    /// This coupling for a robot with a root joint of `root_nq` position and `root_nv`
    /// velocity coordinates (a free-flyer: 7 and 6; [`Robot::root_nq`], [`Robot::root_nv`]):
    /// they come first in every full and reduced vector and pass through unchanged.
    pub fn with_root(mut self, root_nq: usize, root_nv: usize) -> Coupling {
        self.root_nq = root_nq;
        self.root_nv = root_nv;
        self
    }

    /// The identity coupling of `dof` coordinates (no mimic joint).
    pub fn identity(dof: usize) -> Coupling {
        Coupling {
            source: (0..dof).map(Source::Free).collect(),
            free: (0..dof).collect(),
            root_nq: 0,
            root_nv: 0,
        }
    }

    /// Number of joint coordinates of the full model (the robot's `dof()`, the root's not
    /// counted).
    pub fn full_dof(&self) -> usize {
        self.source.len()
    }

    /// Number of reduced (free) joint coordinates (the root's not counted).
    pub fn reduced_dof(&self) -> usize {
        self.free.len()
    }

    /// Length of the full q (the robot's `nq()`).
    pub fn full_nq(&self) -> usize {
        self.root_nq + self.full_dof()
    }

    /// Length of the full v, τ (the robot's `nv()`).
    pub fn full_nv(&self) -> usize {
        self.root_nv + self.full_dof()
    }

    /// Length of the reduced q: the root's coordinates and the free joints'.
    pub fn reduced_nq(&self) -> usize {
        self.root_nq + self.reduced_dof()
    }

    /// Length of the reduced v, τ.
    pub fn reduced_nv(&self) -> usize {
        self.root_nv + self.reduced_dof()
    }

    /// The joint index (0-based, the root not counted) of each reduced joint coordinate, in
    /// order.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// Whether full coordinate `i` is a follower (of a coordinate or fixed).
    pub fn is_follower(&self, i: usize) -> bool {
        !matches!(self.source.get(i), Some(Source::Free(_)) | None)
    }

    fn check(&self, field: &'static str, expected: usize, got: usize) -> Result<(), MimicError> {
        if expected == got {
            Ok(())
        } else {
            Err(MimicError::WrongLength {
                field,
                expected,
                got,
            })
        }
    }

    /// `q = φ(q_r)` into `q` (full length, [`Coupling::full_nq`]).
    pub fn expand_q_into(&self, qr: &[f64], q: &mut [f64]) -> Result<(), MimicError> {
        self.check("q_r", self.reduced_nq(), qr.len())?;
        self.check("q", self.full_nq(), q.len())?;
        let (root, qr) = qr.split_at(self.root_nq);
        let (q_root, q) = q.split_at_mut(self.root_nq);
        q_root.copy_from_slice(root);
        for (x, s) in q.iter_mut().zip(&self.source) {
            *x = match *s {
                Source::Free(k) => qr[k],
                Source::Follows {
                    reduced,
                    multiplier,
                    offset,
                } => multiplier * qr[reduced] + offset,
                Source::Fixed(c) => c,
            };
        }
        Ok(())
    }

    /// The full q of a reduced one.
    pub fn expand_q(&self, qr: &[f64]) -> Result<Vec<f64>, MimicError> {
        let mut q = vec![0.0; self.full_nq()];
        self.expand_q_into(qr, &mut q)?;
        Ok(q)
    }

    /// `q̇ = G q̇_r` (a velocity or an acceleration: no offset) into `v` (full length,
    /// [`Coupling::full_nv`]).
    pub fn expand_v_into(&self, vr: &[f64], v: &mut [f64]) -> Result<(), MimicError> {
        self.check("v_r", self.reduced_nv(), vr.len())?;
        self.check("v", self.full_nv(), v.len())?;
        let (root, vr) = vr.split_at(self.root_nv);
        let (v_root, v) = v.split_at_mut(self.root_nv);
        v_root.copy_from_slice(root);
        for (x, s) in v.iter_mut().zip(&self.source) {
            *x = match *s {
                Source::Free(k) => vr[k],
                Source::Follows {
                    reduced,
                    multiplier,
                    ..
                } => multiplier * vr[reduced],
                Source::Fixed(_) => 0.0,
            };
        }
        Ok(())
    }

    /// The full velocity (or acceleration) of a reduced one.
    pub fn expand_v(&self, vr: &[f64]) -> Result<Vec<f64>, MimicError> {
        let mut v = vec![0.0; self.full_nv()];
        self.expand_v_into(vr, &mut v)?;
        Ok(v)
    }

    /// The reduced coordinates of a full vector: its free entries (no check that the followers
    /// agree).
    pub fn restrict(&self, q: &[f64]) -> Result<Vec<f64>, MimicError> {
        self.check("q", self.full_nq(), q.len())?;
        let (root, q) = q.split_at(self.root_nq);
        Ok(root
            .iter()
            .copied()
            .chain(self.free.iter().map(|&i| q[i]))
            .collect())
    }

    /// `Gᵀ τ`: a full generalised force (torques) as the reduced one — each follower's torque
    /// added to its leader's, times the multiplier (virtual work).
    pub fn reduce_force(&self, tau: &[f64]) -> Result<DVector<f64>, MimicError> {
        self.check("tau", self.full_nv(), tau.len())?;
        let r = self.root_nv;
        let mut out = DVector::zeros(self.reduced_nv());
        out.rows_mut(0, r).copy_from_slice(&tau[..r]);
        for (t, s) in tau[r..].iter().zip(&self.source) {
            match *s {
                Source::Free(k) => out[r + k] += t,
                Source::Follows {
                    reduced,
                    multiplier,
                    ..
                } => out[r + reduced] += multiplier * t,
                Source::Fixed(_) => {}
            }
        }
        Ok(out)
    }

    /// `A G`: the columns of a matrix over the full coordinates (a 6 × n Jacobian, …) combined
    /// into the reduced ones.
    pub fn reduce_columns(&self, a: &DMatrix<f64>) -> Result<DMatrix<f64>, MimicError> {
        self.check("columns", self.full_nv(), a.ncols())?;
        let r = self.root_nv;
        let mut out = DMatrix::zeros(a.nrows(), self.reduced_nv());
        out.columns_mut(0, r).copy_from(&a.columns(0, r));
        for (i, s) in self.source.iter().enumerate() {
            let (k, m) = match *s {
                Source::Free(k) => (k, 1.0),
                Source::Follows {
                    reduced,
                    multiplier,
                    ..
                } => (reduced, multiplier),
                Source::Fixed(_) => continue,
            };
            let col = a.column(r + i) * m;
            let mut dst = out.column_mut(r + k);
            dst += col;
        }
        Ok(out)
    }

    /// `Gᵀ M G`: a full symmetric matrix (the mass matrix) in the reduced coordinates.
    pub fn reduce_matrix(&self, m: &DMatrix<f64>) -> Result<DMatrix<f64>, MimicError> {
        self.check("rows", self.full_nv(), m.nrows())?;
        let mg = self.reduce_columns(m)?;
        let gt_mg = self.reduce_columns(&mg.transpose())?;
        Ok(gt_mg.transpose())
    }

    /// `G` itself (`full_nv × reduced_nv`; the identity on a root's velocities).
    pub fn matrix(&self) -> DMatrix<f64> {
        let r = self.root_nv;
        let mut g = DMatrix::zeros(self.full_nv(), self.reduced_nv());
        for k in 0..r {
            g[(k, k)] = 1.0;
        }
        for (i, s) in self.source.iter().enumerate() {
            match *s {
                Source::Free(k) => g[(r + i, r + k)] = 1.0,
                Source::Follows {
                    reduced,
                    multiplier,
                    ..
                } => g[(r + i, r + reduced)] = multiplier,
                Source::Fixed(_) => {}
            }
        }
        g
    }

    /// Checks that this coupling is `robot`'s: one source per joint, and the root's
    /// dimensions.
    fn check_robot(&self, robot: &Robot) -> Result<(), MimicError> {
        robot
            .refuse_spherical("the mimic coupling")
            .map_err(MimicError::Spherical)?;
        self.check("robot joints", robot.dof(), self.full_dof())?;
        self.check("robot nq", robot.nq(), self.full_nq())?;
        self.check("robot nv", robot.nv(), self.full_nv())
    }
}

/// The tool pose at the reduced `qr`: [`crate::fk::forward`] at `φ(qr)`.
pub fn forward(robot: &Robot, coupling: &Coupling, qr: &[f64]) -> Result<Matrix4<f64>, MimicError> {
    coupling.check_robot(robot)?;
    Ok(crate::fk::forward(robot, &coupling.expand_q(qr)?))
}

/// The pose of link frame `link` (0 = base, k = the end of joint k−1) and its Jacobian over the
/// reduced coordinates (6 × reduced, rows vx vy vz ωx ωy ωz in `frame`): the full Jacobian at
/// `φ(qr)` times G. Panics if `link > robot.dof()`, as [`crate::jacobian::link_jacobian`].
pub fn link_jacobian(
    robot: &Robot,
    coupling: &Coupling,
    qr: &[f64],
    link: usize,
    frame: Frame,
) -> Result<(Matrix4<f64>, DMatrix<f64>), MimicError> {
    coupling.check_robot(robot)?;
    let q = coupling.expand_q(qr)?;
    let mut jac = Jacobian::zeros(robot.nv());
    let pose = link_jacobian_into(robot, &q, link, &mut jac);
    if frame == Frame::Tool {
        to_tool_frame(&mut jac, &pose);
    }
    let full = DMatrix::from_column_slice(6, robot.nv(), jac.as_slice());
    Ok((pose, coupling.reduce_columns(&full)?))
}

/// The tool's Jacobian over the reduced coordinates (6 × reduced) in `frame`.
pub fn jacobian(
    robot: &Robot,
    coupling: &Coupling,
    qr: &[f64],
    frame: Frame,
) -> Result<DMatrix<f64>, MimicError> {
    coupling.check_robot(robot)?;
    let q = coupling.expand_q(qr)?;
    let jac = crate::jacobian::jacobian(robot, &q, frame);
    let full = DMatrix::from_column_slice(6, robot.nv(), jac.as_slice());
    coupling.reduce_columns(&full)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(follower: usize, leader: Option<usize>, multiplier: f64, offset: f64) -> Mimic {
        Mimic {
            follower,
            leader,
            multiplier,
            offset,
        }
    }

    #[test]
    fn expansion_composes_followers_and_fixes_an_absent_leader() {
        // q = [a, 2a + 1, b, -(2a + 1) + 0.5, 0.25]: 3 follows 1 which follows 0; 4 fixed
        let c = Coupling::new(
            5,
            &[
                m(3, Some(1), -1.0, 0.5),
                m(1, Some(0), 2.0, 1.0),
                m(4, None, 3.0, 0.25),
            ],
        )
        .expect("valid");
        assert_eq!((c.full_dof(), c.reduced_dof()), (5, 2));
        assert_eq!(c.free(), [0, 2]);
        let q = c.expand_q(&[0.3, -0.7]).expect("q");
        let want = [0.3, 1.6, -0.7, -1.6 + 0.5, 0.25];
        for (a, b) in q.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{q:?}");
        }
        let g = c.matrix();
        let v = c.expand_v(&[1.0, 2.0]).expect("v");
        assert_eq!(v, [1.0, 2.0, 2.0, -2.0, 0.0]);
        assert_eq!(
            g * DVector::from_row_slice(&[1.0, 2.0]),
            DVector::from_row_slice(&v)
        );
        // Gᵀ τ and Gᵀ M G against the explicit G
        let tau = [1.0, 2.0, 3.0, 4.0, 5.0];
        let gt = c.matrix().transpose() * DVector::from_row_slice(&tau);
        assert_eq!(c.reduce_force(&tau).expect("tau"), gt);
        let mm = DMatrix::from_fn(5, 5, |i, j| {
            (1 + i + j) as f64 + if i == j { 10.0 } else { 0.0 }
        });
        let want = c.matrix().transpose() * &mm * c.matrix();
        assert!((c.reduce_matrix(&mm).expect("M") - want).abs().max() < 1e-12);
        assert_eq!(c.restrict(&q).expect("restrict"), [0.3, -0.7]);
    }

    /// A free-flyer's 7 q / 6 v come first and pass through; G is the identity on them.
    #[test]
    fn a_root_passes_through() {
        let c = Coupling::new(3, &[m(2, Some(0), -1.0, 0.5)])
            .expect("valid")
            .with_root(7, 6);
        assert_eq!(
            (c.full_nq(), c.full_nv(), c.reduced_nq(), c.reduced_nv()),
            (10, 9, 9, 8)
        );
        let root_q = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0];
        let qr: Vec<f64> = root_q.iter().copied().chain([0.3, -0.2]).collect();
        let q = c.expand_q(&qr).expect("q");
        assert_eq!(q, [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0, 0.3, -0.2, 0.2]);
        assert_eq!(c.restrict(&q).expect("restrict"), qr);
        let vr: Vec<f64> = (1..=8).map(f64::from).collect();
        let v = c.expand_v(&vr).expect("v");
        assert_eq!(
            DVector::from_row_slice(&v),
            c.matrix() * DVector::from_row_slice(&vr)
        );
        let tau: Vec<f64> = (1..=9).map(|k| f64::from(k) * 0.5).collect();
        let gt = c.matrix().transpose() * DVector::from_row_slice(&tau);
        assert_eq!(c.reduce_force(&tau).expect("tau"), gt);
        let mm = DMatrix::from_fn(9, 9, |i, j| {
            (1 + i * j) as f64 + if i == j { 20.0 } else { 0.0 }
        });
        let want = c.matrix().transpose() * &mm * c.matrix();
        assert!((c.reduce_matrix(&mm).expect("M") - want).abs().max() < 1e-12);
    }

    #[test]
    fn bad_relations_are_refused_by_name() {
        assert_eq!(
            Coupling::new(2, &[m(0, Some(1), 1.0, 0.0), m(1, Some(0), 1.0, 0.0)]),
            Err(MimicError::Cycle(0))
        );
        assert_eq!(
            Coupling::new(2, &[m(0, Some(2), 1.0, 0.0)]),
            Err(MimicError::OutOfRange { index: 2, dof: 2 })
        );
        assert_eq!(
            Coupling::new(3, &[m(0, Some(1), 1.0, 0.0), m(0, Some(2), 1.0, 0.0)]),
            Err(MimicError::TwoLeaders(0))
        );
        assert!(matches!(
            Coupling::new(2, &[m(0, Some(1), f64::NAN, 0.0)]),
            Err(MimicError::NonFinite {
                field: "multiplier",
                ..
            })
        ));
        let c = Coupling::identity(3);
        assert!(matches!(
            c.expand_q(&[1.0]),
            Err(MimicError::WrongLength {
                expected: 3,
                got: 1,
                ..
            })
        ));
    }
}
