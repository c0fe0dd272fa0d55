//! The kinematic model compiled once (Pinocchio's `Model` for FK): every joint's constant
//! geometry — sin and cos of a DH twist, the placement as a rigid transform, the axis classified
//! as ±x, ±y, ±z or general — worked out when the model is built, so FK and the Jacobian do per
//! joint one `sin_cos` of the joint angle, a closed-form link transform specialised to the joint
//! kind, and one rigid-transform product (rotation 3×3 and translation, no 4×4 product).
//!
//! Entry points: [`crate::KinematicModel::new`] (build once from a [`Robot`]), then
//! [`crate::KinematicModel::link_frames_into`], [`crate::KinematicModel::forward`],
//! [`crate::KinematicModel::fk_and_jacobian_into`], [`crate::KinematicModel::link_jacobian_into`]
//! (or [`crate::Data`]'s `*_compiled` methods). None allocates.
//!
//! The `&Robot` functions of [`crate::fk`] and [`crate::jacobian`] run the same kernels,
//! compiling each joint on the fly (one more `sin_cos` per DH joint than the cached model): a
//! robot's fields are public and are changed in place by callers, so a cache inside `Robot`
//! could go stale, and a new field would change its wire format (bincode) and every struct
//! literal. A `KinematicModel` is a snapshot: build it again after changing the robot.
//!
//! # Same numbers as the 4×4 products
//!
//! The closed forms below are, entry by entry, the products `P · (M · T)` of
//! [`crate::JointGeometry::transform`] with the terms that are exactly 0 or 1 left out, and the
//! rigid product sums its terms in the order nalgebra's 4×4 product does; so link frames, tool
//! pose and Jacobian equal the 4×4 path's to the last bit (a zero may differ in sign), which the
//! tests check with `==` on every builtin robot, modified-DH and prismatic variants and general
//! joints (axes along and off the coordinate axes, chains and trees). For an axis along ±x, ±y
//! or ±z the Jacobian's world axis is `R_parent · (R_P · u)` with `R_P · u` (a column of `R_P`)
//! folded; for any other axis it keeps the 4×4 path's `(R_parent · R_P) · u`, which rounds
//! differently.

use crate::model::{Convention, Joint, JointType, Robot, axis_rotation};
use crate::root::RootKind;
use nalgebra::{ArrayStorage, Dyn, Matrix4, OMatrix, U6, Vector3};

/// A 6 × n Jacobian (rows vx vy vz ωx ωy ωz: see [`crate::jacobian`]), as the kernels fill it.
pub type Jacobian = OMatrix<f64, U6, Dyn>;

/// A rigid transform: rotation `r` stored column-major (`r[col][row]`, as nalgebra stores a
/// `Matrix3`) and translation `t` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Se3 {
    pub r: [[f64; 3]; 3],
    pub t: [f64; 3],
}

impl Se3 {
    /// The top three rows of a homogeneous transform (its last row is assumed 0 0 0 1).
    pub(crate) fn from_matrix(m: &Matrix4<f64>) -> Se3 {
        let c = &m.data.0;
        Se3 {
            r: [
                [c[0][0], c[0][1], c[0][2]],
                [c[1][0], c[1][1], c[1][2]],
                [c[2][0], c[2][1], c[2][2]],
            ],
            t: [c[3][0], c[3][1], c[3][2]],
        }
    }

    /// As a 4×4 homogeneous transform.
    fn to_matrix(self) -> Matrix4<f64> {
        let [c0, c1, c2] = self.r;
        let t = self.t;
        Matrix4::from_data(ArrayStorage([
            [c0[0], c0[1], c0[2], 0.0],
            [c1[0], c1[1], c1[2], 0.0],
            [c2[0], c2[1], c2[2], 0.0],
            [t[0], t[1], t[2], 1.0],
        ]))
    }
}

/// `f · a` for a rigid `f` (4×4, last row 0 0 0 1) and `a`: entry (i, c) is
/// `((f_i0 a_0c + f_i1 a_1c) + f_i2 a_2c)`, the translation adds `f`'s last; the order of
/// nalgebra's 4×4 product, whose remaining terms are exact zeros and ones.
#[inline(always)]
fn compose(f: &Matrix4<f64>, a: &Se3) -> Matrix4<f64> {
    let f = &f.data.0;
    let col = |v: &[f64; 3]| {
        [
            f[0][0] * v[0] + f[1][0] * v[1] + f[2][0] * v[2],
            f[0][1] * v[0] + f[1][1] * v[1] + f[2][1] * v[2],
            f[0][2] * v[0] + f[1][2] * v[1] + f[2][2] * v[2],
        ]
    };
    let [c0, c1, c2] = [col(&a.r[0]), col(&a.r[1]), col(&a.r[2])];
    let t = col(&a.t);
    Matrix4::from_data(ArrayStorage([
        [c0[0], c0[1], c0[2], 0.0],
        [c1[0], c1[1], c1[2], 0.0],
        [c2[0], c2[1], c2[2], 0.0],
        [t[0] + f[3][0], t[1] + f[3][1], t[2] + f[3][2], 1.0],
    ]))
}

/// `R(f) · v`.
#[inline(always)]
fn rotate(f: &Matrix4<f64>, v: &[f64; 3]) -> Vector3<f64> {
    let f = &f.data.0;
    Vector3::new(
        f[0][0] * v[0] + f[1][0] * v[1] + f[2][0] * v[2],
        f[0][1] * v[0] + f[1][1] * v[1] + f[2][1] * v[2],
        f[0][2] * v[0] + f[1][2] * v[1] + f[2][2] * v[2],
    )
}

/// `f · p` for a point `p`.
#[inline(always)]
fn transform_point(f: &Matrix4<f64>, p: &[f64; 3]) -> Vector3<f64> {
    let c = &f.data.0;
    rotate(f, p) + Vector3::new(c[3][0], c[3][1], c[3][2])
}

/// How a general joint (or a modified-DH prismatic one) moves: `A = P · M(x)`.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    /// Revolute about coordinate axis `I` (0 = x, 1 = y, 2 = z) times `sign` (±1): two rows of
    /// the placement's rotation mix, exactly as `axis_rotation` does.
    AlignedX(f64),
    AlignedY(f64),
    AlignedZ(f64),
    /// Revolute about a general unit axis (Rodrigues, [`axis_rotation`]).
    Revolute([f64; 3]),
    /// Translation along a unit axis.
    Prismatic([f64; 3]),
}

/// The link transform `A_j(x)`, `x = q + offset`, with its constants folded (see the module
/// docs for the DH closed forms and why they equal the 4×4 products).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// Standard DH revolute, `Rz(x) Tz(d) Tx(a) Rx(α)`.
    StdRevolute { a: f64, d: f64, ca: f64, sa: f64 },
    /// Standard DH prismatic, `Rz(θ) Tz(x) Tx(a) Rx(α)`: a constant rotation `Rz(θ) Rx(α)` and
    /// translation `(cθ a, sθ a, x)`.
    StdPrismatic { r: [[f64; 3]; 3], ax: f64, ay: f64 },
    /// Modified DH revolute, `Rx(α) Tx(a) Rz(x) Tz(d)`.
    ModRevolute { a: f64, d: f64, ca: f64, sa: f64 },
    /// `P · M(x)`: general joints and modified-DH prismatic ones (`P = Rx(α) Tx(a) Rz(θ)`);
    /// `None`: `P` is the identity.
    Placed { p: Option<Se3>, motion: Motion },
}

/// One joint compiled (see the module docs): its link transform and, for the Jacobian, its axis
/// and the joint frame's origin in the frame it hangs from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CompiledJoint {
    kind: Kind,
    offset: f64,
    pub(crate) revolute: bool,
    /// The joint axis in the parent link frame, `R_P · u`.
    axis_in_parent: [f64; 3],
    /// The joint frame's origin in the parent link frame (`P`'s translation); `None`: the
    /// parent's origin.
    origin_in_parent: Option<[f64; 3]>,
    /// A general joint's axis `u` when it is not ±x, ±y or ±z and the placement `P` is not
    /// the identity: the Jacobian's world axis is then formed as `(R_parent · R_P) · u`, as the
    /// 4×4 path did (`R_parent · (R_P · u)` rounds differently).
    unaligned_axis: Option<[f64; 3]>,
}

impl CompiledJoint {
    /// `joint` compiled under the robot's `convention` (which matters only for a DH row).
    pub(crate) fn new(joint: &Joint, convention: Convention) -> CompiledJoint {
        let revolute = joint.joint_type == JointType::Revolute;
        let (sa, ca) = joint.alpha.sin_cos();
        let mut unaligned = false;
        let (kind, axis_in_parent, origin_in_parent) = match (&joint.origin, convention) {
            (Some(o), _) => {
                let u = [o.axis.x, o.axis.y, o.axis.z];
                let aligned = |i: usize| {
                    o.axis[i].abs() == 1.0
                        && o.axis[(i + 1) % 3] == 0.0
                        && o.axis[(i + 2) % 3] == 0.0
                };
                unaligned = !(aligned(0) || aligned(1) || aligned(2));
                let motion = if revolute {
                    if aligned(0) {
                        Motion::AlignedX(o.axis.x)
                    } else if aligned(1) {
                        Motion::AlignedY(o.axis.y)
                    } else if aligned(2) {
                        Motion::AlignedZ(o.axis.z)
                    } else {
                        Motion::Revolute(u)
                    }
                } else {
                    Motion::Prismatic(u)
                };
                let p =
                    (o.placement != Matrix4::identity()).then(|| Se3::from_matrix(&o.placement));
                // R_P · u in the 4×4 product's order (exact for a coordinate axis).
                let axis = match &p {
                    Some(p) => rotate_se3(p, &u),
                    None => u,
                };
                let origin = p.map(|p| p.t).filter(|t| *t != [0.0; 3]);
                (Kind::Placed { p, motion }, axis, origin)
            }
            (None, Convention::Standard) if revolute => (
                Kind::StdRevolute {
                    a: joint.a,
                    d: joint.d,
                    ca,
                    sa,
                },
                [0.0, 0.0, 1.0],
                None,
            ),
            (None, Convention::Standard) => {
                let (st, ct) = joint.theta.sin_cos();
                // Rz(θ) · Tx(a) Rx(α), the products' single terms.
                let r = [
                    [ct, st, 0.0],
                    [-st * ca, ct * ca, sa],
                    [st * sa, -ct * sa, ca],
                ];
                (
                    Kind::StdPrismatic {
                        r,
                        ax: ct * joint.a,
                        ay: st * joint.a,
                    },
                    [0.0, 0.0, 1.0],
                    None,
                )
            }
            (None, Convention::Modified) if revolute => (
                Kind::ModRevolute {
                    a: joint.a,
                    d: joint.d,
                    ca,
                    sa,
                },
                [0.0, -sa, ca],
                Some([joint.a, 0.0, 0.0]).filter(|t| *t != [0.0; 3]),
            ),
            (None, Convention::Modified) => {
                // P = Rx(α) Tx(a) Rz(θ), formed as the 4×4 path forms it.
                let g = joint.geometry(convention);
                let p = g.placement.map(|m| Se3::from_matrix(&m));
                let axis = match &p {
                    Some(p) => rotate_se3(p, &[0.0, 0.0, 1.0]),
                    None => [0.0, 0.0, 1.0],
                };
                let origin = p.map(|p| p.t).filter(|t| *t != [0.0; 3]);
                (
                    Kind::Placed {
                        p,
                        motion: Motion::Prismatic([0.0, 0.0, 1.0]),
                    },
                    axis,
                    origin,
                )
            }
        };
        let unaligned_axis = match (&kind, &joint.origin) {
            (Kind::Placed { p: Some(_), .. }, Some(o)) if unaligned => {
                Some([o.axis.x, o.axis.y, o.axis.z])
            }
            _ => None,
        };
        CompiledJoint {
            kind,
            offset: joint.offset,
            revolute,
            axis_in_parent,
            origin_in_parent,
            unaligned_axis,
        }
    }

    /// The link transform `A_j` at joint value `q` (rad or m).
    #[inline(always)]
    pub(crate) fn transform(&self, q: f64) -> Se3 {
        let x = q + self.offset;
        match self.kind {
            Kind::StdRevolute { a, d, ca, sa } => {
                let (s, c) = x.sin_cos();
                Se3 {
                    r: [[c, s, 0.0], [-s * ca, c * ca, sa], [s * sa, -c * sa, ca]],
                    t: [c * a, s * a, d],
                }
            }
            Kind::StdPrismatic { r, ax, ay } => Se3 { r, t: [ax, ay, x] },
            Kind::ModRevolute { a, d, ca, sa } => {
                let (s, c) = x.sin_cos();
                Se3 {
                    r: [[c, ca * s, sa * s], [-s, ca * c, sa * c], [0.0, -sa, ca]],
                    t: [a, -sa * d, ca * d],
                }
            }
            Kind::Placed { p, motion } => placed(p.as_ref(), motion, x),
        }
    }

    /// The link transform as a 4×4 matrix.
    pub(crate) fn matrix(&self, q: f64) -> Matrix4<f64> {
        self.transform(q).to_matrix()
    }
}

/// `R(p) · v`, summed in the 4×4 product's order.
fn rotate_se3(p: &Se3, v: &[f64; 3]) -> [f64; 3] {
    let r = &p.r;
    [
        r[0][0] * v[0] + r[1][0] * v[1] + r[2][0] * v[2],
        r[0][1] * v[0] + r[1][1] * v[1] + r[2][1] * v[2],
        r[0][2] * v[0] + r[1][2] * v[1] + r[2][2] * v[2],
    ]
}

/// `P · M(x)` (`p` `None`: `M(x)`).
#[inline(always)]
fn placed(p: Option<&Se3>, motion: Motion, x: f64) -> Se3 {
    match motion {
        Motion::AlignedX(sign) => aligned::<0>(p, sign, x),
        Motion::AlignedY(sign) => aligned::<1>(p, sign, x),
        Motion::AlignedZ(sign) => aligned::<2>(p, sign, x),
        Motion::Revolute(u) => {
            let m = axis_rotation(&Vector3::from(u), x);
            let m = [
                [m[(0, 0)], m[(1, 0)], m[(2, 0)]],
                [m[(0, 1)], m[(1, 1)], m[(2, 1)]],
                [m[(0, 2)], m[(1, 2)], m[(2, 2)]],
            ];
            match p {
                Some(p) => Se3 {
                    r: [
                        rotate_se3(p, &m[0]),
                        rotate_se3(p, &m[1]),
                        rotate_se3(p, &m[2]),
                    ],
                    t: p.t,
                },
                None => Se3 { r: m, t: [0.0; 3] },
            }
        }
        Motion::Prismatic(u) => {
            let v = [u[0] * x, u[1] * x, u[2] * x];
            match p {
                Some(p) => {
                    let rv = rotate_se3(p, &v);
                    Se3 {
                        r: p.r,
                        t: [rv[0] + p.t[0], rv[1] + p.t[1], rv[2] + p.t[2]],
                    }
                }
                None => Se3 {
                    r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                    t: v,
                },
            }
        }
    }
}

/// `P · R_I(sign · x)`, the rotation about coordinate axis `I` as [`axis_rotation`] builds it
/// (`R[j][k] = −s`, `R[k][j] = s`, `s = sin x · sign`, j, k the next axes): column `I` of `P`
/// unchanged, the other two mixed with their terms in ascending row order (the 4×4 product's).
#[inline(always)]
fn aligned<const I: usize>(p: Option<&Se3>, sign: f64, x: f64) -> Se3 {
    let (s, c) = x.sin_cos();
    let s = s * sign;
    let (j, k) = ((I + 1) % 3, (I + 2) % 3);
    // m[col][row] of the motion's rotation.
    let mut m = [[0.0; 3]; 3];
    m[I][I] = 1.0;
    m[j][j] = c;
    m[k][k] = c;
    m[k][j] = -s;
    m[j][k] = s;
    let Some(p) = p else {
        return Se3 { r: m, t: [0.0; 3] };
    };
    let (lo, hi) = if j < k { (j, k) } else { (k, j) };
    let mix = |col: usize| {
        let (a, b) = (m[col][lo], m[col][hi]);
        [
            p.r[lo][0] * a + p.r[hi][0] * b,
            p.r[lo][1] * a + p.r[hi][1] * b,
            p.r[lo][2] * a + p.r[hi][2] * b,
        ]
    };
    let mut r = [[0.0; 3]; 3];
    r[I] = p.r[I];
    r[j] = mix(j);
    r[k] = mix(k);
    Se3 { r, t: p.t }
}

/// The link transform `A_j = P_j · M_j(q + offset_j) · T_j` of joint `j` at joint value `q`
/// (rad or m): equal to [`Joint::geometry`]`(convention).transform(q)`, formed in closed form
/// per joint kind (the module docs). Public as `fk::link_transform`.
pub fn link_transform(convention: Convention, joint: &Joint, q: f64) -> Matrix4<f64> {
    CompiledJoint::new(joint, convention).matrix(q)
}

/// What the kernels read of a robot: [`crate::KinematicModel`] (compiled once) or a [`Robot`]
/// compiled joint by joint on the fly ([`OnTheFly`]).
pub(crate) trait Joints {
    type J: std::borrow::Borrow<CompiledJoint>;
    fn len(&self) -> usize;
    fn joint(&self, j: usize) -> Self::J;
    fn revolute(&self, j: usize) -> bool;
    fn parents(&self) -> &[usize];
    fn is_chain(&self) -> bool;
    fn base(&self) -> &Matrix4<f64>;
    fn tool(&self) -> Se3;
    fn root(&self) -> Option<RootKind>;
}

/// Link frame 0 in the world (`base`, times the root joint's motion for a floating robot) and
/// the joints' part of q.
#[inline(always)]
fn rooted_base<'q>(k: &impl Joints, q: &'q [f64]) -> (Matrix4<f64>, &'q [f64]) {
    match k.root() {
        None => (*k.base(), q),
        Some(kind) => {
            let nq = kind.nq().min(q.len());
            let (qr, qj) = q.split_at(nq);
            let m = if qr.len() == kind.nq() {
                kind.transform(qr)
            } else {
                Matrix4::identity()
            };
            (k.base() * m, qj)
        }
    }
}

/// A [`Robot`] read by the kernels, each joint compiled when it is reached.
pub(crate) struct OnTheFly<'a>(pub &'a Robot);

impl Joints for OnTheFly<'_> {
    type J = CompiledJoint;
    #[inline(always)]
    fn len(&self) -> usize {
        self.0.joints.len()
    }
    #[inline(always)]
    fn joint(&self, j: usize) -> CompiledJoint {
        CompiledJoint::new(&self.0.joints[j], self.0.convention)
    }
    #[inline(always)]
    fn revolute(&self, j: usize) -> bool {
        self.0.joints[j].joint_type == JointType::Revolute
    }
    fn parents(&self) -> &[usize] {
        &self.0.parents
    }
    fn is_chain(&self) -> bool {
        self.0.is_chain()
    }
    fn base(&self) -> &Matrix4<f64> {
        &self.0.base
    }
    fn tool(&self) -> Se3 {
        Se3::from_matrix(&self.0.tool)
    }
    fn root(&self) -> Option<RootKind> {
        self.0.root.as_ref().map(|r| r.kind)
    }
}

/// The link frames `base, 1..n, tool` into `frames` (n + 2 entries; panics if fewer). Joints
/// past `q`'s end are left as they were (q must have n entries).
#[inline(always)]
pub(crate) fn frames_kernel(k: impl Joints, q: &[f64], frames: &mut [Matrix4<f64>]) {
    use std::borrow::Borrow;
    let n = k.len();
    assert!(
        frames.len() >= n + 2,
        "link_frames_into: {} frames for {n} joints (needs n + 2)",
        frames.len()
    );
    let (base, q) = rooted_base(&k, q);
    frames[0] = base;
    let parents = k.parents();
    for (j, &qj) in q.iter().enumerate().take(n) {
        let parent = parents.get(j).copied().unwrap_or(j);
        frames[j + 1] = compose(&frames[parent], &k.joint(j).borrow().transform(qj));
    }
    frames[n + 1] = compose(&frames[n], &k.tool());
}

/// The tool pose `base · A_1 ⋯ A_n · tool` (along the last joint's support path for a tree).
#[inline(always)]
pub(crate) fn forward_kernel(k: impl Joints, q: &[f64]) -> Matrix4<f64> {
    use std::borrow::Borrow;
    let (mut t, q) = rooted_base(&k, q);
    walk_support(&k, k.len(), &mut |j| {
        if let Some(&qj) = q.get(j) {
            t = compose(&t, &k.joint(j).borrow().transform(qj));
        }
    });
    compose(&t, &k.tool())
}

/// Tool pose and base-frame Jacobian (the tool hangs from the last joint's link frame).
#[inline(always)]
pub(crate) fn fk_and_jacobian_kernel(
    k: impl Joints,
    q: &[f64],
    jac: &mut Jacobian,
) -> Matrix4<f64> {
    let tool = k.tool();
    jacobian_kernel(&k, q, k.len(), Some(&tool), jac)
}

/// Pose and base-frame Jacobian of link frame `link` (0 = base, k = the end of joint k−1) in
/// one pass along its support path: each joint's world axis and joint-frame origin come from
/// the running frame before its motion (the frame it hangs from) and are parked in its column;
/// the revolute columns are then finished against the link's origin: revolute
/// `[u × (p_e − o); u]`, prismatic `[u; 0]`. Columns off the path are zero.
#[inline(always)]
pub(crate) fn link_jacobian_kernel(
    k: &impl Joints,
    q: &[f64],
    link: usize,
    jac: &mut Jacobian,
) -> Matrix4<f64> {
    jacobian_kernel(k, q, link, None, jac)
}

/// [`link_jacobian_kernel`], or with `tool` the pose and Jacobian of the tool frame hung from
/// link frame `link`.
#[inline(always)]
fn jacobian_kernel(
    k: &impl Joints,
    q: &[f64],
    link: usize,
    tool: Option<&Se3>,
    jac: &mut Jacobian,
) -> Matrix4<f64> {
    use std::borrow::Borrow;
    assert!(
        link <= k.len(),
        "link_jacobian: link frame {link} of {}",
        k.len()
    );
    if link < k.len() || !k.is_chain() {
        jac.fill(0.0);
    }
    let (mut t, q) = rooted_base(k, q);
    let root = k.root();
    let nv_root = root.map_or(0, RootKind::nv);
    let frame0 = t;
    walk_support(k, link, &mut |j| {
        let joint = k.joint(j);
        let joint = joint.borrow();
        park(joint, &t, jac, nv_root + j);
        if let Some(&qj) = q.get(j) {
            t = compose(&t, &joint.transform(qj));
        }
    });
    if let Some(tool) = tool {
        t = compose(&t, tool);
    }
    let c = &t.data.0;
    let pe = Vector3::new(c[3][0], c[3][1], c[3][2]);
    if let Some(kind) = root {
        root_columns(kind, &frame0, &pe, jac);
    }
    walk_support(k, link, &mut |j| {
        if k.revolute(j) {
            let mut col = jac.column_mut(nv_root + j);
            let o: Vector3<f64> = col.fixed_rows::<3>(0).into_owned();
            let u: Vector3<f64> = col.fixed_rows::<3>(3).into_owned();
            col.fixed_rows_mut::<3>(0).copy_from(&u.cross(&(pe - o)));
        }
    });
    t
}

/// The root joint's columns (the first `kind.nv()`): its velocity is link frame 0's own, so
/// a linear coordinate along axis `e_i` of link frame 0 gives `[R₀ e_i; 0]` and a rotation
/// about it `[R₀ e_i × (p_e − p₀); R₀ e_i]`.
pub(crate) fn root_columns(
    kind: RootKind,
    frame0: &Matrix4<f64>,
    pe: &Vector3<f64>,
    jac: &mut Jacobian,
) {
    let c = &frame0.data.0;
    let p0 = Vector3::new(c[3][0], c[3][1], c[3][2]);
    let axis = |i: usize| Vector3::new(c[i][0], c[i][1], c[i][2]);
    let mut put = |col: usize, lin: Vector3<f64>, ang: Vector3<f64>| {
        let mut col = jac.column_mut(col);
        col.fixed_rows_mut::<3>(0).copy_from(&lin);
        col.fixed_rows_mut::<3>(3).copy_from(&ang);
    };
    let zero = Vector3::zeros();
    match kind {
        RootKind::FreeFlyer => {
            for i in 0..3 {
                let u = axis(i);
                put(i, u, zero);
                put(3 + i, u.cross(&(pe - p0)), u);
            }
        }
        RootKind::Planar => {
            put(0, axis(0), zero);
            put(1, axis(1), zero);
            let u = axis(2);
            put(2, u.cross(&(pe - p0)), u);
        }
    }
}

/// Column `j` from `parent`, the world frame joint `j` hangs from: revolute, the joint frame's
/// origin (rows 0..3, finished later) and the world axis (rows 3..6); prismatic, the final
/// `[u; 0]`.
#[inline(always)]
fn park(joint: &CompiledJoint, parent: &Matrix4<f64>, jac: &mut Jacobian, j: usize) {
    let u = match (&joint.unaligned_axis, &joint.kind) {
        (Some(u), Kind::Placed { p: Some(p), .. }) => {
            let w = [
                rotate(parent, &p.r[0]),
                rotate(parent, &p.r[1]),
                rotate(parent, &p.r[2]),
            ];
            w[0] * u[0] + w[1] * u[1] + w[2] * u[2]
        }
        _ => rotate(parent, &joint.axis_in_parent),
    };
    let mut col = jac.column_mut(j);
    if joint.revolute {
        let c = &parent.data.0;
        let o = match &joint.origin_in_parent {
            Some(p) => transform_point(parent, p),
            None => Vector3::new(c[3][0], c[3][1], c[3][2]),
        };
        col.fixed_rows_mut::<3>(0).copy_from(&o);
        col.fixed_rows_mut::<3>(3).copy_from(&u);
    } else {
        col.fixed_rows_mut::<3>(0).copy_from(&u);
        col.fixed_rows_mut::<3>(3).fill(0.0);
    }
}

/// Calls `f` on the joints of link frame `link`'s support path, root first, without allocating
/// (for a tree the path is climbed once per joint on it: trees are shallow).
#[inline(always)]
fn walk_support(k: &impl Joints, link: usize, f: &mut impl FnMut(usize)) {
    if k.is_chain() {
        (0..link).for_each(f);
        return;
    }
    let parents = k.parents();
    let parent = |j: usize| parents.get(j).copied().unwrap_or(j);
    let mut depth = 0;
    let mut l = link;
    while l > 0 {
        depth += 1;
        l = parent(l - 1);
    }
    for level in (0..depth).rev() {
        let mut l = link;
        for _ in 0..level {
            l = parent(l - 1);
        }
        f(l - 1);
    }
}

#[cfg(test)]
mod tests {
    //! The compiled kernels against the 4×4 products they replace (the previous FK and Jacobian,
    //! kept here as the reference): equal with `==` (to the last bit; zeros may differ in sign).
    use super::*;
    use crate::KinematicModel;
    use crate::chain::to_general;
    use crate::jacobian::{fk_and_jacobian_into, link_jacobian_into};
    use crate::model::Origin;
    use crate::pose::{rot_x, rot_z, trans, translation};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn rot_y(angle: f64) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&axis_rotation(&Vector3::y(), angle));
        m
    }

    fn reference_frames(robot: &Robot, q: &[f64]) -> Vec<Matrix4<f64>> {
        let n = robot.dof();
        let mut frames = vec![robot.base; n + 2];
        for (j, joint) in robot.joints.iter().enumerate() {
            frames[j + 1] =
                frames[robot.parent(j)] * joint.geometry(robot.convention).transform(q[j]);
        }
        frames[n + 1] = frames[n] * robot.tool;
        frames
    }

    /// The previous `link_jacobian_into`: frames by 4×4 products, `W_j = F_parent · P_j`.
    /// With `tool`, the tool frame's (hung from link frame n; `link` must be n).
    fn reference_jacobian(
        robot: &Robot,
        q: &[f64],
        link: usize,
        tool: bool,
    ) -> (Matrix4<f64>, Jacobian) {
        let mut frames = reference_frames(robot, q);
        if tool {
            frames[link] = frames[robot.dof()] * robot.tool;
        }
        let pe = translation(&frames[link]);
        let mut jac = Jacobian::zeros(robot.dof());
        for j in robot.support(link) {
            let g = robot.joints[j].geometry(robot.convention);
            let parent = &frames[robot.parent(j)];
            let w = match &g.placement {
                Some(p) => parent * p,
                None => *parent,
            };
            let z = w.fixed_view::<3, 3>(0, 0) * g.axis;
            let o = translation(&w);
            let (v, om) = match g.joint_type {
                JointType::Revolute => (z.cross(&(pe - o)), z),
                JointType::Prismatic => (z, Vector3::zeros()),
            };
            for i in 0..3 {
                jac[(i, j)] = v[i];
                jac[(i + 3, j)] = om[i];
            }
        }
        (frames[link], jac)
    }

    fn load(file: &str) -> Robot {
        let path = format!(
            "{}/../../testdata/dynamics/robots/{file}",
            env!("CARGO_MANIFEST_DIR")
        );
        let text = std::fs::read_to_string(&path).expect("fixture");
        crate::json::robot_from_json(&serde_json::from_str(&text).expect("JSON")).expect("robot")
    }

    /// General joints about every coordinate axis and sign, prismatic ones, identity and
    /// non-identity placements, one unaligned axis (`unaligned`), and a tree when `tree`.
    fn general_robot(unaligned: bool, tree: bool) -> Robot {
        let axes = [
            Vector3::z(),
            -Vector3::x(),
            Vector3::y(),
            -Vector3::z(),
            Vector3::x(),
            -Vector3::y(),
            Vector3::new(0.0, 0.6, -0.8),
        ];
        let placements = [
            trans(0.1, -0.2, 0.3) * rot_x(0.4),
            Matrix4::identity(),
            rot_z(-1.1) * rot_y(0.3),
            trans(0.0, 0.0, 0.25),
            trans(0.05, 0.1, 0.0) * rot_y(-0.7) * rot_x(2.0),
            rot_x(std::f64::consts::FRAC_PI_2),
            trans(0.2, 0.0, -0.1) * rot_z(0.9),
        ];
        let mut joints: Vec<Joint> = axes
            .iter()
            .zip(&placements)
            .enumerate()
            .map(|(j, (axis, placement))| Joint {
                joint_type: if j == 3 || j == 6 {
                    JointType::Prismatic
                } else {
                    JointType::Revolute
                },
                offset: 0.1 * j as f64,
                origin: Some(Origin {
                    placement: *placement,
                    axis: *axis,
                }),
                ..Joint::default()
            })
            .collect();
        if unaligned {
            joints[2].origin = Some(Origin {
                placement: placements[2],
                axis: Vector3::new(0.48, 0.6, 0.64),
            });
        }
        Robot {
            name: "general".into(),
            joints,
            parents: if tree {
                vec![0, 1, 1, 3, 2, 5, 4]
            } else {
                Vec::new()
            },
            base: trans(0.3, 0.2, 0.1) * rot_z(0.5) * rot_x(-0.2),
            tool: trans(0.0, 0.01, 0.12) * rot_y(0.3),
            ..Robot::default()
        }
    }

    fn robots() -> Vec<(String, Robot)> {
        let mut out = Vec::new();
        for name in crate::BUILTIN_NAMES {
            let r = crate::builtin_robot(name).expect("builtin");
            out.push((format!("{name} (general)"), to_general(&r)));
            out.push((name.to_string(), r));
        }
        for file in ["synthetic_standard.json", "synthetic_modified.json"] {
            out.push((file.to_string(), load(file)));
        }
        out.push(("general chain".into(), general_robot(false, false)));
        out.push(("general tree".into(), general_robot(false, true)));
        out
    }

    fn random_q(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
        (0..n).map(|_| rng.random_range(-3.0..3.0)).collect()
    }

    #[test]
    fn compiled_frames_equal_the_4x4_products_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        for (name, robot) in robots() {
            robot.validate().expect("valid");
            let model = KinematicModel::new(&robot);
            let n = robot.dof();
            let mut frames = vec![Matrix4::zeros(); n + 2];
            let mut compiled = vec![Matrix4::zeros(); n + 2];
            for _ in 0..200 {
                let q = random_q(&mut rng, n);
                let expected = reference_frames(&robot, &q);
                crate::fk::link_frames_into(&robot, &q, &mut frames);
                model.link_frames_into(&q, &mut compiled);
                assert_eq!(frames, expected, "{name} at {q:?}");
                assert_eq!(compiled, expected, "{name} at {q:?}");
                for (j, joint) in robot.joints.iter().enumerate() {
                    assert_eq!(
                        crate::fk::link_transform(robot.convention, joint, q[j]),
                        joint.geometry(robot.convention).transform(q[j]),
                        "{name} joint {j}"
                    );
                }
                let last = if robot.is_chain() {
                    expected[n + 1]
                } else {
                    crate::fk::link_pose(&robot, &q, n) * robot.tool
                };
                assert_eq!(crate::fk::forward(&robot, &q), last, "{name}");
                assert_eq!(model.forward(&q), last, "{name}");
            }
        }
    }

    #[test]
    fn compiled_jacobians_equal_the_4x4_path_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(38);
        for (name, robot) in robots() {
            let model = KinematicModel::new(&robot);
            let n = robot.dof();
            let mut jac = Jacobian::zeros(n);
            for _ in 0..100 {
                let q = random_q(&mut rng, n);
                for link in 0..=n {
                    let (pose, expected) = reference_jacobian(&robot, &q, link, false);
                    jac.fill(f64::NAN);
                    assert_eq!(link_jacobian_into(&robot, &q, link, &mut jac), pose);
                    assert_eq!(jac, expected, "{name} link {link} at {q:?}");
                    jac.fill(f64::NAN);
                    assert_eq!(model.link_jacobian_into(&q, link, &mut jac), pose);
                    assert_eq!(jac, expected, "{name} link {link} at {q:?}");
                }
                let (tee, expected) = reference_jacobian(&robot, &q, n, true);
                jac.fill(f64::NAN);
                assert_eq!(fk_and_jacobian_into(&robot, &q, &mut jac), tee, "{name}");
                assert_eq!(jac, expected, "{name} at {q:?}");
                jac.fill(f64::NAN);
                assert_eq!(model.fk_and_jacobian_into(&q, &mut jac), tee, "{name}");
                assert_eq!(jac, expected, "{name} at {q:?}");
            }
        }
    }

    /// An axis off the coordinate axes (joint 2 here, besides the prismatic joint 6): frames
    /// and Jacobian still equal the 4×4 path's.
    #[test]
    fn unaligned_axes_equal_the_4x4_path_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(39);
        for tree in [false, true] {
            let robot = general_robot(true, tree);
            robot.validate().expect("valid");
            let model = KinematicModel::new(&robot);
            let n = robot.dof();
            let mut frames = vec![Matrix4::zeros(); n + 2];
            let mut jac = Jacobian::zeros(n);
            for _ in 0..200 {
                let q = random_q(&mut rng, n);
                model.link_frames_into(&q, &mut frames);
                assert_eq!(frames, reference_frames(&robot, &q));
                let (tee, expected) = reference_jacobian(&robot, &q, n, true);
                assert_eq!(model.fk_and_jacobian_into(&q, &mut jac), tee);
                assert_eq!(jac, expected, "tree {tree}");
            }
        }
    }

    /// A model is a snapshot: a changed robot needs a new one (the `&Robot` functions always
    /// see the robot as it is).
    #[test]
    fn a_changed_robot_is_seen_by_the_robot_functions_and_a_rebuilt_model() {
        let mut robot = crate::builtin_robot("puma560").expect("builtin");
        let q = [0.1, -0.5, 0.4, 0.2, -0.3, 0.7];
        let before = KinematicModel::new(&robot);
        robot.joints[2].a += 0.1;
        robot.tool = trans(0.0, 0.0, 0.2);
        let after = KinematicModel::new(&robot);
        let expected = reference_frames(&robot, &q)[7];
        assert_eq!(crate::fk::forward(&robot, &q), expected);
        assert_eq!(after.forward(&q), expected);
        assert_ne!(before.forward(&q), expected);
    }
}
