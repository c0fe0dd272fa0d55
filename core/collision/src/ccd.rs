//! Continuous collision checking along one joint-space step of a linked arm — the second miss
//! the seed admits (§2.6: "this algorithm does not detect collisions in the volume swept by an
//! object moving between positions").
//!
//! Method: conservative advancement with a motion bound per link (Schwarzer, Saha & Latombe,
//! "Exact collision checking of robot paths", 2002). Along `q(s) = q0 + s (q1 − q0)`,
//! s ∈ [0, 1], no point of link j's solid moves farther than `s · B_j` ([`motion_bounds`]):
//! a revolute joint i turning by |Δq_i| moves a point at distance R from its axis by at most
//! R |Δq_i| (arc length), a prismatic one by |Δq_i|, and the displacements add. R is bounded by
//! the chain lengths |translation of A_k| from joint i's axis to frame j (constant for revolute
//! joints, largest at an end of the step for prismatic ones) plus the solid's radius about its
//! frame. For each pair the exact distance d(s) is taken and s advances by (d − ε)/B, where B is
//! the bound of the pair's relative motion (B_j for a static object, B_i + B_j for two links).
//!
//! **Guarantee.** [`Sweep::Clear`] means every checked pair keeps an exact-mode distance larger
//! than ε = `tolerance / 2` over the whole step (up to the accuracy of parry's distance, far
//! below ε). [`Sweep::Contact`] gives the first s found where the distance is ≤ `tolerance`: a
//! true contact or a near miss closer than `tolerance`, never later than the true first contact.
//! Hitting `max_iterations` (a pair grazing at a distance just above the tolerance)
//! gives [`Sweep::Unknown`], never a silent clear.
//!
//! **Kinematics.** The link poses of every advancement step come from the robot's compiled
//! [`KinematicModel`] (one FK pass into a reused buffer, no allocation per step):
//! [`sweep_robot_compiled`] takes one compiled by the caller (MOVEJI's steps, the simulator's
//! collision stage), [`sweep_robot`] compiles one per sweep. The poses, and so the answers, are
//! those of `fk::link_frames` on the `Robot` bit for bit (test
//! `compiled_sweep_answers_as_the_robot_sweep_does`).
//!
//! Entry points: [`sweep_robot`], [`sweep_robot_compiled`], [`motion_bounds`].

use crate::bodies::{
    Body, CheckError, Collision, LinkSolids, Scene, check_link_count, isometry_from_matrix,
};
use crate::exact::{self, ExactOptions};
use crate::outcome::PairResult;
use crate::solid::Solid;
use nalgebra::{Isometry3, Matrix4};
use robosim_kinematics::{Convention, JointType, KinematicModel, Robot, fk};

/// Tolerances of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepOptions {
    /// Distance (m) at or below which a pair counts as in contact.
    pub tolerance: f64,
    /// Advancement steps per pair before giving up with `Unknown`.
    pub max_iterations: usize,
    /// How closely each distance is computed. A GJK tolerance t gives distances up to t too
    /// large; the sweep subtracts t before using one, so it stays conservative (a near miss
    /// closer than `tolerance + t` may then count as a contact).
    pub distance: exact::Tolerance,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            tolerance: 1e-6,
            max_iterations: 10_000,
            distance: exact::Tolerance::Certified,
        }
    }
}

/// The result of sweeping one step.
#[derive(Debug, Clone, PartialEq)]
pub enum Sweep {
    Clear,
    /// First contact at fraction `s` of the step.
    Contact {
        s: f64,
        collision: Collision,
    },
    Unknown {
        a: Body,
        b: Body,
        reason: String,
    },
}

/// `B_j` (m) for every entry of `links.links`: the largest distance any point of link j's solid
/// travels along the whole step q0 → q1 (0 for the base and for links without a solid).
pub fn motion_bounds(robot: &Robot, links: &LinkSolids, q0: &[f64], q1: &[f64]) -> Vec<f64> {
    let n = robot.dof();
    // |o_k − o_{k−1}| for k = 1..=n: the translation length of A_k, largest at an end of the step.
    let tnorm: Vec<f64> = (0..n)
        .map(|k| {
            let j = &robot.joints[k];
            let a = fk::link_transform(robot.convention, j, q0[k]);
            let b = fk::link_transform(robot.convention, j, q1[k]);
            let t = |m: &nalgebra::Matrix4<f64>| {
                (m[(0, 3)].powi(2) + m[(1, 3)].powi(2) + m[(2, 3)].powi(2)).sqrt()
            };
            t(&a).max(t(&b))
        })
        .collect();
    let mut out = vec![0.0; links.links.len()];
    for (jl, l) in links.links.iter().enumerate().skip(1) {
        let Some(l) = l else { continue };
        let bb = &l.solid.bbox;
        let mut rho: f64 = 0.0;
        for c in 0..8 {
            let s = |bit: usize| if c >> bit & 1 == 1 { 1.0 } else { -1.0 };
            let corner = bb.center
                + nalgebra::Vector3::new(s(0) * bb.half.x, s(1) * bb.half.y, s(2) * bb.half.z);
            rho = rho.max((l.offset * corner).coords.norm());
        }
        rho += l.solid.tessellation_error;
        let mut b = 0.0;
        for i in 1..=jl.min(n) {
            let dq = (q1[i - 1] - q0[i - 1]).abs();
            if dq == 0.0 {
                continue;
            }
            match robot.joints[i - 1].joint_type {
                JointType::Prismatic => b += dq,
                JointType::Revolute => {
                    // Standard DH: joint i turns about z_{i−1} through o_{i−1}; modified: about
                    // z_i through o_i.
                    let first = match robot.convention {
                        Convention::Standard => i,
                        Convention::Modified => i + 1,
                    };
                    let chain: f64 = (first..=jl).map(|k| tnorm[k - 1]).sum();
                    b += dq * (chain + rho);
                }
            }
        }
        out[jl] = b;
    }
    out
}

/// `q0 + (q1 − q0) s` into `out`.
fn lerp_into(q0: &[f64], q1: &[f64], s: f64, out: &mut Vec<f64>) {
    out.clear();
    out.extend(q0.iter().zip(q1).map(|(a, b)| a + (b - a) * s));
}

/// Where the link frames come from: the compiled model (a frames buffer reused every step),
/// or — tests only, the path before — `fk::link_frames` on the `Robot`.
enum Frames<'a> {
    Compiled {
        kin: &'a KinematicModel,
        frames: Vec<Matrix4<f64>>,
    },
    #[cfg(test)]
    Robot(&'a Robot),
}

impl<'a> Frames<'a> {
    /// The link frames from `kin`, into a buffer of its own.
    fn compiled(kin: &'a KinematicModel) -> Self {
        Frames::Compiled {
            kin,
            frames: vec![Matrix4::identity(); kin.dof() + 2],
        }
    }

    /// Every link solid's world pose at `q` into `out` (`None`: no solid), as
    /// [`crate::bodies::link_poses`].
    fn poses(&mut self, links: &LinkSolids, q: &[f64], out: &mut Vec<Option<Isometry3<f64>>>) {
        let frames: &[Matrix4<f64>] = match self {
            Frames::Compiled { kin, frames } => {
                kin.link_frames_into(q, frames);
                frames
            }
            #[cfg(test)]
            Frames::Robot(robot) => {
                out.clear();
                out.extend(crate::bodies::link_poses(robot, links, q));
                return;
            }
        };
        out.clear();
        out.extend(links.links.iter().enumerate().map(|(j, l)| {
            l.as_ref()
                .map(|l| isometry_from_matrix(&frames[j]) * l.offset)
        }));
    }
}

enum Target<'a> {
    Object(usize, &'a Solid, Isometry3<f64>),
    Link(usize),
}

/// Sweeps the robot from `q0` to `q1` (one MOVEJI step) against the in-use objects of `scene`
/// and, if `self_collision`, its own non-adjacent link pairs; exact-mode distances throughout,
/// whatever mode the discrete checks use. See the module docs for what is guaranteed. Compiles
/// the robot for the sweep; a caller sweeping the same robot again and again compiles it once
/// and calls [`sweep_robot_compiled`].
pub fn sweep_robot(
    robot: &Robot,
    links: &LinkSolids,
    q0: &[f64],
    q1: &[f64],
    scene: &Scene,
    self_collision: bool,
    opts: &SweepOptions,
) -> Result<Sweep, CheckError> {
    let kin = KinematicModel::new(robot);
    sweep_robot_compiled(&kin, robot, links, q0, q1, scene, self_collision, opts)
}

/// [`sweep_robot`] with the link frames from `kin`, compiled from `robot` once
/// ([`KinematicModel::new`]; `robot` is read for the q and link-count checks and the motion
/// bounds): the same answers, bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn sweep_robot_compiled(
    kin: &KinematicModel,
    robot: &Robot,
    links: &LinkSolids,
    q0: &[f64],
    q1: &[f64],
    scene: &Scene,
    self_collision: bool,
    opts: &SweepOptions,
) -> Result<Sweep, CheckError> {
    let frames = Frames::compiled(kin);
    sweep(frames, robot, links, q0, q1, scene, self_collision, opts)
}

#[allow(clippy::too_many_arguments)]
fn sweep(
    mut frames: Frames<'_>,
    robot: &Robot,
    links: &LinkSolids,
    q0: &[f64],
    q1: &[f64],
    scene: &Scene,
    self_collision: bool,
    opts: &SweepOptions,
) -> Result<Sweep, CheckError> {
    robot.check_q(q0)?;
    robot.check_q(q1)?;
    check_link_count(robot, links)?;
    let bounds = motion_bounds(robot, links, q0, q1);
    let mut p0 = Vec::with_capacity(links.links.len());
    frames.poses(links, q0, &mut p0);
    let mut pairs: Vec<(usize, Target)> = Vec::new();
    let mut cand = Vec::new();
    for (j, l) in links.links.iter().enumerate() {
        let (Some(l), Some(p)) = (l, &p0[j]) else {
            continue;
        };
        let mut b = crate::bbox::world_box(&l.solid.bbox, p);
        b.half += nalgebra::Vector3::repeat(bounds[j] + l.solid.tessellation_error);
        cand.clear();
        scene.candidates(&b, &mut cand);
        for &oi in &cand {
            let o = &scene.objects()[oi];
            pairs.push((j, Target::Object(oi, &o.solid, o.pose)));
        }
    }
    if self_collision {
        for (i, j) in links.self_pairs() {
            pairs.push((j, Target::Link(i)));
        }
    }
    let mut first: Option<(f64, Collision)> = None;
    let eps = opts.tolerance * 0.5;
    // A GJK tolerance's distances are upper ends: their lower ends are safe to advance by.
    let slack = match opts.distance {
        exact::Tolerance::Certified => 0.0,
        t @ exact::Tolerance::Gjk(_) => t.width(),
    };
    let (mut q, mut lp) = (
        Vec::with_capacity(q0.len()),
        Vec::with_capacity(links.links.len()),
    );
    for (j, target) in &pairs {
        let Some(lj) = &links.links[*j] else { continue };
        let (bound, body_b) = match target {
            Target::Object(oi, _, _) => (
                bounds[*j],
                Body::Object {
                    index: *oi,
                    name: scene.objects()[*oi].name.clone(),
                },
            ),
            Target::Link(i) => (bounds[*j] + bounds[*i], Body::Link(*i)),
        };
        // Only a contact earlier than the best so far matters.
        let s_end = first.as_ref().map_or(1.0, |(s, _)| *s);
        let mut s = 0.0;
        let mut iterations = 0;
        loop {
            iterations += 1;
            if iterations > opts.max_iterations {
                return Ok(Sweep::Unknown {
                    a: Body::Link(*j),
                    b: body_b,
                    reason: format!(
                        "conservative advancement stopped after {} iterations at s = {s:.6}",
                        opts.max_iterations
                    ),
                });
            }
            lerp_into(q0, q1, s, &mut q);
            frames.poses(links, &q, &mut lp);
            let Some(pj) = lp[*j] else { break };
            let (solid_b, pose_b) = match target {
                Target::Object(_, so, po) => (*so, *po),
                Target::Link(i) => match (&links.links[*i], lp[*i]) {
                    (Some(li), Some(pi)) => (&*li.solid, pi),
                    _ => break,
                },
            };
            let r = exact::collide(
                &lj.solid,
                &pj,
                solid_b,
                &pose_b,
                ExactOptions {
                    distance: true,
                    depth: true,
                    tolerance: opts.distance,
                },
            );
            let (d, witness) = match r {
                PairResult::Clear {
                    distance: Some(d),
                    witness,
                } => (d - slack, witness),
                PairResult::Clear { distance: None, .. } => {
                    return Ok(Sweep::Unknown {
                        a: Body::Link(*j),
                        b: body_b,
                        reason: "no distance from the exact mode".into(),
                    });
                }
                PairResult::Contact { witness, .. } => (0.0, witness),
                PairResult::Unknown { reason } => {
                    return Ok(Sweep::Unknown {
                        a: Body::Link(*j),
                        b: body_b,
                        reason,
                    });
                }
            };
            if d <= opts.tolerance {
                if first.as_ref().is_none_or(|(s0, _)| s < *s0) {
                    first = Some((
                        s,
                        Collision {
                            a: Body::Link(*j),
                            b: body_b.clone(),
                            signed_distance: Some(d),
                            witness,
                        },
                    ));
                }
                break;
            }
            if bound <= 0.0 {
                break; // neither body moves: the distance stays d > tolerance
            }
            s += (d - eps) / bound;
            if s >= s_end {
                break;
            }
        }
    }
    Ok(match first {
        Some((s, collision)) => Sweep::Contact { s, collision },
        None => Sweep::Clear,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use robosim_kinematics::{BUILTIN_NAMES, builtin_robot};
    use std::sync::Arc;

    /// The sweep on the compiled model ([`sweep_robot`], [`sweep_robot_compiled`]) answers as
    /// the sweep on `fk::link_frames` of the `Robot` (the path before) does, `==` and bit for
    /// bit (Debug text: every f64 in its shortest round-trip form): the built-in robots (DH
    /// standard and modified), random steps against balls and boxes, with and without
    /// self-collision, certified and at a GJK tolerance. Both contact and clear sweeps occur.
    #[test]
    fn compiled_sweep_answers_as_the_robot_sweep_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        let (mut contacts, mut clears) = (0, 0);
        for name in BUILTIN_NAMES {
            let robot = builtin_robot(name).expect("builtin");
            let links = LinkSolids::from_dh(&robot, 0.04).expect("links");
            let kin = KinematicModel::new(&robot);
            for i in 0..24 {
                let mut scene = Scene::new();
                for k in 0..3 {
                    let p = Isometry3::from_parts(
                        Translation3::new(
                            rng.random_range(-0.8..0.8),
                            rng.random_range(-0.8..0.8),
                            rng.random_range(-0.3..0.9),
                        ),
                        nalgebra::UnitQuaternion::identity(),
                    );
                    let solid = if k % 2 == 0 {
                        Solid::sphere(rng.random_range(0.05..0.2), None).expect("ball")
                    } else {
                        Solid::cuboid(Vector3::repeat(rng.random_range(0.1..0.3))).expect("box")
                    };
                    scene.add(format!("o{k}"), Arc::new(solid), p);
                }
                let q0: Vec<f64> = (0..robot.dof())
                    .map(|_| rng.random_range(-2.0..2.0))
                    .collect();
                let q1: Vec<f64> = q0.iter().map(|q| q + rng.random_range(-1.0..1.0)).collect();
                let opts = SweepOptions {
                    distance: if i % 2 == 0 {
                        exact::Tolerance::Certified
                    } else {
                        exact::Tolerance::Gjk(1e-6)
                    },
                    ..SweepOptions::default()
                };
                let self_collision = i % 3 == 0;
                let on = |frames: Frames| {
                    sweep(
                        frames,
                        &robot,
                        &links,
                        &q0,
                        &q1,
                        &scene,
                        self_collision,
                        &opts,
                    )
                    .expect("sweep")
                };
                let before = on(Frames::Robot(&robot));
                // What sweep_robot_compiled runs, on the one model compiled for all the steps.
                let compiled = on(Frames::compiled(&kin));
                let now = sweep_robot(&robot, &links, &q0, &q1, &scene, self_collision, &opts)
                    .expect("sweep");
                assert!(
                    now == before,
                    "{name} {q0:?} -> {q1:?}: {now:?} vs {before:?}"
                );
                assert_eq!(format!("{now:?}"), format!("{before:?}"));
                assert_eq!(format!("{compiled:?}"), format!("{before:?}"));
                match now {
                    Sweep::Contact { .. } => contacts += 1,
                    Sweep::Clear => clears += 1,
                    Sweep::Unknown { .. } => {}
                }
            }
        }
        assert!(
            contacts >= 5 && clears >= 5,
            "{contacts} contact, {clears} clear"
        );
    }
}
