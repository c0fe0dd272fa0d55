//! Recognising the closed-form family a robot belongs to (the seed's proposed extension, §2.4:
//! "recognition of the ... configurations for which exact solutions exist").
//!
//! Both families are 6R arms whose first three joints are a waist (α1 = ±π/2), a shoulder and an
//! elbow with parallel axes (α2 = 0), then α3 = ±π/2 and α4 = ±π/2 with a4 = 0:
//! * [`Family::SphericalWrist`] — also α5 = ±π/2, a5 = d5 = a6 = 0: axes 4, 5, 6 meet in one point
//!   (PUMA 560, most industrial 6R arms). Solved in closed form by [`super::analytic`].
//! * [`Family::OffsetWrist`] — the wrist has offsets (a5, d5, a6, any α5): solved by
//!   [`super::hybrid`], five joints analytic and θ6 numeric.
//!
//! * [`Family::BoomWrist`] — an RRP arm (waist, shoulder, prismatic boom with α3 = 0) with a
//!   spherical wrist: the Stanford arm. Closed form by [`super::analytic`].
//! * [`Family::ThreeParallel`] — the UR type: a 6R arm with α1 = ±π/2, α2 = α3 = 0 (axes 2, 3
//!   and 4 parallel, same direction), α4 = ±π/2, α5 = ±π/2, a5 = 0, a2 and a3 not 0 (UR3/5/10,
//!   many cobots). Closed form (up to 8) by [`super::parallel`].
//!
//! A robot with general joints (placement and axis, as from a URDF) is first rewritten as its
//! equivalent standard-DH chain ([`super::equivalent::equivalent_dh`]) and recognised with the
//! tolerance [`super::equivalent::RECOVERED_TOLERANCE`] (1e-9 rad, 1e-9 × the arm's size)
//! instead of 1e-12; [`recognised_from_axes`] tells which way a robot was recognised.
//!
//! Modified-DH robots are first rewritten as the equivalent standard chain
//! ([`StandardChain::from_robot`]); the joint values are the same.

use crate::model::{Convention, Joint, JointType, Robot};
use crate::pose::{rot_x, trans};
use nalgebra::Matrix4;
use std::f64::consts::FRAC_PI_2;

/// A robot rewritten in standard DH: `T_ee = prefix · A_1 ⋯ A_n · tool` with the standard
/// `A_j`. For a modified-DH robot, `prefix = base · Rx(α_0) Tx(a_0)` and the standard row j
/// takes the modified row j+1's a and α (the last row none); joint values are unchanged.
#[derive(Debug, Clone, PartialEq)]
pub struct StandardChain {
    pub prefix: Matrix4<f64>,
    pub joints: Vec<Joint>,
    pub tool: Matrix4<f64>,
}

impl StandardChain {
    pub fn from_robot(robot: &Robot) -> StandardChain {
        match robot.convention {
            Convention::Standard => StandardChain {
                prefix: robot.base,
                joints: robot.joints.clone(),
                tool: robot.tool,
            },
            Convention::Modified => {
                let n = robot.joints.len();
                let (a0, alpha0) = robot.joints.first().map_or((0.0, 0.0), |j| (j.a, j.alpha));
                let joints = (0..n)
                    .map(|j| {
                        let (a, alpha) = robot
                            .joints
                            .get(j + 1)
                            .map_or((0.0, 0.0), |next| (next.a, next.alpha));
                        Joint {
                            a,
                            alpha,
                            ..robot.joints[j].clone()
                        }
                    })
                    .collect();
                // Rx and Tx commute (same axis), so Rx(α0) Tx(a0) = the modified prefix.
                StandardChain {
                    prefix: robot.base * rot_x(alpha0) * trans(a0, 0.0, 0.0),
                    joints,
                    tool: robot.tool,
                }
            }
        }
    }
}

/// The arm part shared by both families, in standard DH.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmGeometry {
    pub chain: StandardChain,
    /// sin α1, sin α3, sin α4 (each ±1).
    pub s1: f64,
    pub s3: f64,
    pub s4: f64,
    /// Lateral (shoulder) offset d2 + d3 along the parallel shoulder/elbow axes.
    pub lateral: f64,
}

/// An RRP arm (the Stanford arm's family) in standard DH: waist, shoulder, a prismatic boom
/// along the shoulder's z (α3 = 0), then a spherical wrist.
#[derive(Debug, Clone, PartialEq)]
pub struct BoomGeometry {
    pub chain: StandardChain,
    /// sin α1, sin α2, sin α4 (each ±1).
    pub s1: f64,
    pub s2: f64,
    pub s4: f64,
}

/// A 6R arm of the UR type in standard DH (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ParallelGeometry {
    pub chain: StandardChain,
    /// sin α1, sin α4, sin α5 (each ±1).
    pub s1: f64,
    pub s4: f64,
    pub s5: f64,
}

/// Which closed form fits.
#[derive(Debug, Clone, PartialEq)]
pub enum Family {
    SphericalWrist(ArmGeometry),
    /// RRP arm with a spherical wrist (Stanford arm): closed form by [`super::analytic`].
    BoomWrist(BoomGeometry),
    OffsetWrist(ArmGeometry),
    /// The UR type (three parallel middle axes): closed form by [`super::parallel`].
    ThreeParallel(ParallelGeometry),
    /// No closed form: the reason the first test failed.
    General(String),
}

impl Family {
    /// A stable name for the family (what the Instance Space records as a robot's solver):
    /// `spherical_wrist`, `rrp_spherical_wrist`, `offset_wrist`, `three_parallel` or `general`.
    pub fn name(&self) -> &'static str {
        match self {
            Family::SphericalWrist(_) => "spherical_wrist",
            Family::BoomWrist(_) => "rrp_spherical_wrist",
            Family::OffsetWrist(_) => "offset_wrist",
            Family::ThreeParallel(_) => "three_parallel",
            Family::General(_) => "general",
        }
    }

    /// The method [`super::Method::Auto`] uses for this family.
    pub fn method(&self) -> super::Method {
        match self {
            Family::SphericalWrist(_) | Family::BoomWrist(_) | Family::ThreeParallel(_) => {
                super::Method::Analytic
            }
            Family::OffsetWrist(_) => super::Method::Hybrid,
            Family::General(_) => super::Method::Dls,
        }
    }
}

fn is_within(angle: f64, target: f64, tol: f64) -> bool {
    (angle - target).abs() <= tol || (angle - target).abs() <= tol * target.abs()
}

fn sign_within(angle: f64, tol: f64) -> Option<f64> {
    if is_within(angle, FRAC_PI_2, tol) {
        Some(1.0)
    } else if is_within(angle, -FRAC_PI_2, tol) {
        Some(-1.0)
    } else {
        None
    }
}

/// Whether [`recognise`] reads `robot`'s geometry from its joint placements and axes (some
/// joint is general) rather than from its DH rows.
pub fn recognised_from_axes(robot: &Robot) -> bool {
    robot.joints.iter().any(Joint::is_general)
}

/// Classifies `robot` (see the module docs). Length "zeros" are relative to the robot's size
/// (1e-12 × the sum of |a| and |d|), so a 1 mm arm and a 1 km arm classify alike. A robot with
/// general joints is classified by its equivalent DH chain with the looser
/// [`super::equivalent::RECOVERED_TOLERANCE`]; the family's chain is then that DH chain.
pub fn recognise(robot: &Robot) -> Family {
    if robot.dof() != 6 {
        return Family::General(format!(
            "{} joints; the closed forms are for 6",
            robot.dof()
        ));
    }
    if recognised_from_axes(robot) {
        return match super::equivalent::equivalent_dh(robot) {
            Some(dh) => classify(&dh, super::equivalent::RECOVERED_TOLERANCE),
            None => Family::General("the joint axes have no equivalent DH chain".into()),
        };
    }
    classify(robot, 1e-12)
}

fn classify(robot: &Robot, tol: f64) -> Family {
    let is = |angle: f64, target: f64| is_within(angle, target, tol);
    let sign_of_right_angle = |angle: f64| sign_within(angle, tol);
    let chain = StandardChain::from_robot(robot);
    let jt = &chain.joints;
    let scale: f64 = jt
        .iter()
        .map(|j| j.a.abs() + j.d.abs())
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let zero = |x: f64| x.abs() <= tol * scale;
    let prismatic: Vec<usize> = robot
        .joints
        .iter()
        .enumerate()
        .filter(|(_, j)| j.joint_type == JointType::Prismatic)
        .map(|(i, _)| i)
        .collect();
    if prismatic == [2] {
        return recognise_boom(&chain, &zero, tol);
    }
    if let Some(j) = prismatic.first() {
        return Family::General(format!(
            "joint {j} is prismatic; the closed forms are for 6R arms and RRP arms"
        ));
    }
    let Some(s1) = sign_of_right_angle(jt[0].alpha) else {
        return Family::General("α1 is not ±π/2 (waist not perpendicular to shoulder)".into());
    };
    if !is(jt[1].alpha, 0.0) {
        return Family::General("α2 is not 0 (shoulder and elbow axes not parallel)".into());
    }
    if is(jt[2].alpha, 0.0) {
        return recognise_parallel(&chain, s1, &zero, tol);
    }
    let Some(s3) = sign_of_right_angle(jt[2].alpha) else {
        return Family::General("α3 is neither ±π/2 nor 0".into());
    };
    let Some(s4) = sign_of_right_angle(jt[3].alpha) else {
        return Family::General("α4 is not ±π/2".into());
    };
    if !zero(jt[3].a) {
        return Family::General("a4 is not 0 (wrist axes 4 and 5 do not meet)".into());
    }
    if zero(jt[1].a) || (zero(jt[2].a) && zero(jt[3].d)) {
        return Family::General("upper arm or forearm has zero length".into());
    }
    let arm = ArmGeometry {
        s1,
        s3,
        s4,
        lateral: jt[1].d + jt[2].d,
        chain: chain.clone(),
    };
    let spherical = sign_of_right_angle(jt[4].alpha).is_some()
        && zero(jt[4].a)
        && zero(jt[4].d)
        && zero(jt[5].a);
    if spherical {
        Family::SphericalWrist(arm)
    } else {
        Family::OffsetWrist(arm)
    }
}

/// The UR type, after α1 = ±π/2 and α2 = α3 = 0 have been seen.
fn recognise_parallel(
    chain: &StandardChain,
    s1: f64,
    zero: &dyn Fn(f64) -> bool,
    tol: f64,
) -> Family {
    let jt = &chain.joints;
    let Some(s4) = sign_within(jt[3].alpha, tol) else {
        return Family::General("axes 2, 3, 4 parallel but α4 is not ±π/2".into());
    };
    let Some(s5) = sign_within(jt[4].alpha, tol) else {
        return Family::General("axes 2, 3, 4 parallel but α5 is not ±π/2".into());
    };
    if !zero(jt[4].a) {
        return Family::General("axes 2, 3, 4 parallel but a5 is not 0".into());
    }
    if zero(jt[1].a) || zero(jt[2].a) {
        return Family::General("axes 2, 3, 4 parallel but a2 or a3 is 0".into());
    }
    Family::ThreeParallel(ParallelGeometry {
        chain: chain.clone(),
        s1,
        s4,
        s5,
    })
}

fn recognise_boom(chain: &StandardChain, zero: &dyn Fn(f64) -> bool, tol: f64) -> Family {
    let is = |angle: f64, target: f64| is_within(angle, target, tol);
    let sign_of_right_angle = |angle: f64| sign_within(angle, tol);
    let jt = &chain.joints;
    let Some(s1) = sign_of_right_angle(jt[0].alpha) else {
        return Family::General("RRP arm: α1 is not ±π/2".into());
    };
    let Some(s2) = sign_of_right_angle(jt[1].alpha) else {
        return Family::General(
            "RRP arm: α2 is not ±π/2 (boom not perpendicular to the shoulder axis)".into(),
        );
    };
    if !is(jt[2].alpha, 0.0) {
        return Family::General("RRP arm: α3 is not 0".into());
    }
    let Some(s4) = sign_of_right_angle(jt[3].alpha) else {
        return Family::General("RRP arm: α4 is not ±π/2".into());
    };
    let spherical = sign_of_right_angle(jt[4].alpha).is_some()
        && zero(jt[3].a)
        && zero(jt[4].a)
        && zero(jt[4].d)
        && zero(jt[5].a);
    if !spherical {
        return Family::General("RRP arm without a spherical wrist".into());
    }
    Family::BoomWrist(BoomGeometry {
        chain: chain.clone(),
        s1,
        s2,
        s4,
    })
}
