//! "What accuracy costs in time" for collision detection (`robosim report collision`):
//!
//! 1. **Per pair**, per mode (bbox, the seed's polygon algorithm with and without the
//!    containment test, exact): time per pair query and false negatives / false positives
//!    against the exact mode, over random box / sphere / cylinder / cone pairs near contact.
//! 2. **Robot against scene**: the PUMA 560 (all links) against the surgical head (a cylinder,
//!    seed §2.7) at random joint values within the limits, per mode, with broad-phase culling
//!    (robot box, then link boxes) and without it (every link narrow-tested).
//! 3. **Facet count** of a cylinder against volume error and polygon-mode time and misses.
//! 4. **Broad phase**: 10,000 bodies with 1 % moving per step, sweep-and-prune against the BVH
//!    (and brute force as the baseline), plus their scaling with the body count.
//! 5. **Distance tolerance**: error and time at each exact-mode tolerance beside coal's
//!    ([`tolerance`]).
//!
//! The PUMA's link solids are [`LinkSolids::from_dh`] boxes (half-width 4 cm along the DH
//! segments), because the standard library's PUMA solids are not in the tree yet. Timings are
//! wall-clock on a shared, noisy machine: each figure is the median of several repetitions and is
//! also given as a ratio to a baseline measured in the same run.
//!
//! Entry point: [`report_collision`].

use crate::plot::RunError;
use crate::plot::{Plot, Report, Series, Table, percentile, write_report};
use nalgebra::{Isometry3, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_collision::Solid;
use robosim_collision::broad::{BroadPhase, BvhBroadPhase, SweepAndPrune, brute_force_pairs};
use robosim_collision::polygon::{self, PolygonOptions};
use robosim_collision::robot::{
    CheckResult, CollisionSettings, LinkSolids, Scene, check_links, link_poses,
};
use robosim_collision::{ExactOptions, bbox, exact};
use robosim_collision::{Mode, PairResult};
use robosim_geometry::Aabb;
use robosim_kinematics::builtin_robot;
use robosim_kinematics::ik::{self, IkOptions, Method};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

mod tolerance;

/// Seconds per call of `f`: the best (minimum) over `reps` repetitions of `inner` calls each.
/// On a shared machine other processes only ever add time, so the minimum is the least noisy
/// estimate of the cost itself.
fn time_per_call(reps: usize, inner: usize, mut f: impl FnMut()) -> f64 {
    let mut samples: Vec<f64> = (0..reps)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..inner {
                f();
            }
            t.elapsed().as_secs_f64() / inner as f64
        })
        .collect();
    percentile(&mut samples, 0.0)
}

fn random_solid(rng: &mut ChaCha8Rng, facets: Option<usize>) -> Solid {
    let mut s = || rng.random_range(0.1..0.6);
    let (x, y, z) = (s(), s(), s());
    // Every constructor gets positive finite sizes here.
    match rng.random_range(0..4) {
        0 => Solid::cuboid(Vector3::new(x, y, z)),
        1 => Solid::sphere(x / 2.0, facets),
        2 => Solid::cylinder(x / 2.0, y, facets),
        _ => Solid::cone(x / 2.0, y, facets),
    }
    .unwrap_or_else(|_| unreachable!("positive sizes"))
}

fn random_pose(rng: &mut ChaCha8Rng, spread: f64) -> Isometry3<f64> {
    let t = Vector3::new(
        rng.random_range(-spread..spread),
        rng.random_range(-spread..spread),
        rng.random_range(-spread..spread),
    );
    let r = Vector3::new(
        rng.random_range(-3.2..3.2),
        rng.random_range(-3.2..3.2),
        rng.random_range(-3.2..3.2),
    );
    Isometry3::new(t, r)
}

/// Repetitions per timing (best of).
const REPS: usize = 9;

type Pair = (Solid, Isometry3<f64>, Solid, Isometry3<f64>);

#[derive(Clone, Copy)]
enum Variant {
    BBox,
    Polygon,
    PolygonSeed,
    ExactBool,
    Exact,
}

impl Variant {
    fn name(self) -> &'static str {
        match self {
            Variant::BBox => "bbox",
            Variant::Polygon => "polygon",
            Variant::PolygonSeed => "polygon (seed: no containment test)",
            Variant::ExactBool => "exact (boolean only)",
            Variant::Exact => "exact (boolean + depth)",
        }
    }
    fn run(self, p: &Pair) -> PairResult {
        match self {
            Variant::BBox => bbox::collide(&p.0, &p.1, &p.2, &p.3),
            Variant::Polygon => polygon::collide(&p.0, &p.1, &p.2, &p.3, PolygonOptions::default()),
            Variant::PolygonSeed => polygon::collide(
                &p.0,
                &p.1,
                &p.2,
                &p.3,
                PolygonOptions { containment: false },
            ),
            Variant::ExactBool => match exact::intersects(&p.0, &p.1, &p.2, &p.3) {
                Ok(true) => PairResult::Contact {
                    signed_distance: None,
                    witness: None,
                },
                Ok(false) => PairResult::Clear {
                    distance: None,
                    witness: None,
                },
                Err(reason) => PairResult::Unknown { reason },
            },
            Variant::Exact => exact::collide(
                &p.0,
                &p.1,
                &p.2,
                &p.3,
                ExactOptions {
                    distance: false,
                    ..ExactOptions::default()
                },
            ),
        }
    }
}

/// False negatives and false positives of `got` against `truth` (None = unknown, counted apart).
fn confusion(got: &[Option<bool>], truth: &[Option<bool>]) -> (usize, usize, usize) {
    let (mut fneg, mut fpos, mut unknown) = (0, 0, 0);
    for (g, t) in got.iter().zip(truth) {
        match (g, t) {
            (Some(false), Some(true)) => fneg += 1,
            (Some(true), Some(false)) => fpos += 1,
            (None, _) => unknown += 1,
            _ => {}
        }
    }
    (fneg, fpos, unknown)
}

fn row(cells: &[String]) -> Vec<String> {
    cells.to_vec()
}

fn us(s: f64) -> String {
    format!("{:.3}", s * 1e6)
}

/// Writes `collision.csv`, `collision.md` and `collision.png` into `out_dir`. `quick` runs a
/// reduced version (for tests and smoke runs; the figures are then rougher). Returns the paths
/// written, or a message saying what failed. The studies run in a fixed order from one seeded
/// generator (each draws its samples from it in turn): per pair, a robot against the
/// surgical head, the seed's §2.7 study, facet counts, the broad phase.
pub fn report_collision(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, RunError> {
    let mut rng = ChaCha8Rng::seed_from_u64(1988);
    let scale = if quick { 1 } else { 10 };
    let columns = [
        "study",
        "case",
        "variant",
        "samples",
        "time_us",
        "ratio",
        "false_neg",
        "false_pos",
        "unknown",
        "note",
    ];
    let mut table = Table {
        columns: columns.iter().map(|s| s.to_string()).collect(),
        rows: Vec::new(),
    };
    let mut notes = vec![
        "Wall-clock time on a shared 2-core machine under load (load average ≈ 5 during the committed run): best of 9 repetitions for per-pair and per-check times, median over the steps for the broad phase; ratios are to the baseline named in `note`, measured in the same run.".to_owned(),
        "False negatives / positives are counted against the exact mode (parry GJK/EPA on the true primitives).".to_owned(),
    ];
    pair_study(&mut rng, scale, &mut table);
    let ph = PumaHead::new(&mut rng, scale)?;
    let (t_fk, puma_exact_us) = robot_study(&ph, &mut table);
    robot_study_without_culling_and_with_self(&ph, t_fk, &mut table);
    notes.push(format!(
        "PUMA 560 (builtin, Corke/RTB parameters) with assumed link solids: boxes of half-width 4 cm along the DH segments (`LinkSolids::from_dh`). Surgical head: cylinder r = 0.10 m, h = 0.25 m, axis along world y, centre (0.55, −0.15, 0.45) m. Exact-mode check with culling: {puma_exact_us:.2} µs (target 5 µs)."
    ));

    seed_study(&ph, t_fk, &mut table, &mut notes)?;
    let facet_series = facet_study(&mut rng, scale, &mut table);
    let bp_series = broad_phase_study(&mut rng, quick, &mut table, &mut notes)?;
    // Last, from checked-in data: the studies above draw the same samples as before.
    let tolerance_plot = tolerance::tolerance_study(&mut table, &mut notes)?;
    let mut plots = collision_plots(facet_series, bp_series);
    plots.push(tolerance_plot);
    let report = Report {
        name: "collision".into(),
        title: "Collision detection: what accuracy costs in time".into(),
        notes,
        table,
        plots,
    };
    Ok(write_report(out_dir, &report)?)
}

/// 1. Per pair, per mode: random primitive pairs, each mode's verdict and time against exact.
fn pair_study(rng: &mut ChaCha8Rng, scale: usize, table: &mut Table) {
    let n_pairs = 200 * scale;
    let pairs: Vec<Pair> = (0..n_pairs)
        .map(|_| {
            let a = random_solid(rng, None);
            let b = random_solid(rng, None);
            (a, random_pose(rng, 0.05), b, random_pose(rng, 0.45))
        })
        .collect();
    let truth: Vec<Option<bool>> = pairs
        .iter()
        .map(|p| Variant::Exact.run(p).intersects())
        .collect();
    let contacts = truth.iter().filter(|t| **t == Some(true)).count();
    let variants = [
        Variant::BBox,
        Variant::Polygon,
        Variant::PolygonSeed,
        Variant::ExactBool,
        Variant::Exact,
    ];
    let mut base_pair = f64::NAN;
    for v in variants {
        let got: Vec<Option<bool>> = pairs.iter().map(|p| v.run(p).intersects()).collect();
        let (fneg, fpos, unk) = confusion(&got, &truth);
        let t = time_per_call(REPS, 1, || {
            for p in &pairs {
                black_box(v.run(p));
            }
        }) / pairs.len() as f64;
        if matches!(v, Variant::BBox) {
            base_pair = t;
        }
        table.rows.push(row(&[
            "pair".into(),
            format!("random box/sphere/cylinder/cone pairs, default facets, {contacts} of {n_pairs} in contact"),
            v.name().into(),
            n_pairs.to_string(),
            us(t),
            format!("{:.1}", t / base_pair),
            fneg.to_string(),
            fpos.to_string(),
            unk.to_string(),
            "ratio to bbox".into(),
        ]));
    }
}

/// The robot studies' setup: the builtin PUMA 560 with DH link boxes, the surgical head as
/// the scene, and random joint values within limits.
struct PumaHead {
    robot: robosim_kinematics::Robot,
    links: LinkSolids,
    scene: Scene,
    head_pose: Isometry3<f64>,
    qs: Vec<Vec<f64>>,
}

impl PumaHead {
    fn new(rng: &mut ChaCha8Rng, scale: usize) -> Result<PumaHead, RunError> {
        let robot = builtin_robot("puma560").ok_or("the builtin PUMA 560 is missing")?;
        let links = LinkSolids::from_dh(&robot, 0.04).map_err(|source| RunError::LinkSolids {
            what: "the PUMA 560",
            source,
        })?;
        let mut scene = Scene::new();
        let head = Solid::cylinder(0.10, 0.25, None).map_err(|source| RunError::Solid {
            what: "the PUMA's head cylinder",
            source,
        })?;
        let head_pose = Isometry3::new(
            Vector3::new(0.55, -0.15, 0.45),
            Vector3::new(std::f64::consts::FRAC_PI_2, 0.0, 0.0),
        );
        scene.add("head", Arc::new(head), head_pose);
        let n_q = 2000 * scale;
        let qs: Vec<Vec<f64>> = (0..n_q)
            .map(|_| {
                robot
                    .joints
                    .iter()
                    .map(|j| rng.random_range(j.qlim[0]..j.qlim[1]))
                    .collect()
            })
            .collect();
        Ok(PumaHead {
            robot,
            links,
            scene,
            head_pose,
            qs,
        })
    }
}

/// The robot checks' settings in `mode`: no self-collision, the rest the defaults.
fn check_settings(mode: Mode) -> CollisionSettings {
    CollisionSettings {
        mode,
        self_collision: false,
        ..CollisionSettings::default()
    }
}

/// A check's verdict as contact yes / no / unknown.
fn verdict(r: &CheckResult) -> Option<bool> {
    match r {
        CheckResult::Clear => Some(false),
        CheckResult::Contact(_) => Some(true),
        CheckResult::Unknown { .. } => None,
    }
}

/// 2. PUMA against the surgical head: FK alone (the baseline), then each mode with box
/// culling. Answers the FK time per q (s) and the exact mode's time per check (µs).
fn robot_study(ph: &PumaHead, table: &mut Table) -> (f64, f64) {
    let n_q = ph.qs.len();
    let puma_truth: Vec<Option<bool>> = ph
        .qs
        .iter()
        .map(|q| {
            verdict(&check_links(
                &ph.links,
                &link_poses(&ph.robot, &ph.links, q),
                &ph.scene,
                &check_settings(Mode::Exact),
            ))
        })
        .collect();
    let hits = puma_truth.iter().filter(|t| **t == Some(true)).count();
    // Baseline: forward kinematics alone (the check cannot be cheaper than placing the links).
    let t_fk = time_per_call(REPS, 1, || {
        for q in &ph.qs {
            black_box(link_poses(&ph.robot, &ph.links, q));
        }
    }) / n_q as f64;
    table.rows.push(row(&[
        "robot".into(),
        "PUMA 560 link poses only (FK)".into(),
        "-".into(),
        n_q.to_string(),
        us(t_fk),
        "1.0".into(),
        "".into(),
        "".into(),
        "".into(),
        "baseline for this study".into(),
    ]));
    let mut puma_exact_us = f64::NAN;
    for mode in [Mode::BBox, Mode::Polygon, Mode::Exact] {
        let s = check_settings(mode);
        let got: Vec<Option<bool>> = ph
            .qs
            .iter()
            .map(|q| {
                verdict(&check_links(
                    &ph.links,
                    &link_poses(&ph.robot, &ph.links, q),
                    &ph.scene,
                    &s,
                ))
            })
            .collect();
        let (fneg, fpos, unk) = confusion(&got, &puma_truth);
        let t = time_per_call(REPS, 1, || {
            for q in &ph.qs {
                black_box(check_links(
                    &ph.links,
                    &link_poses(&ph.robot, &ph.links, q),
                    &ph.scene,
                    &s,
                ));
            }
        }) / n_q as f64;
        if mode == Mode::Exact {
            puma_exact_us = t * 1e6;
        }
        table.rows.push(row(&[
            "robot".into(),
            format!("PUMA 560 (all links) vs surgical head, random q in limits, {hits} of {n_q} in contact"),
            format!("{} with box culling", mode.name()),
            n_q.to_string(),
            us(t),
            format!("{:.1}", t / t_fk),
            fneg.to_string(),
            fpos.to_string(),
            unk.to_string(),
            "ratio to FK; target < 5 µs per check".into(),
        ]));
    }
    (t_fk, puma_exact_us)
}

/// 2, continued: exact without culling (every link narrow), and exact with self-collision.
fn robot_study_without_culling_and_with_self(ph: &PumaHead, t_fk: f64, table: &mut Table) {
    let n_q = ph.qs.len();
    // Without culling: every link narrow-tested against the head.
    let o = &ph.scene.objects()[0];
    let t_noc = time_per_call(REPS, 1, || {
        for q in &ph.qs {
            let lp = link_poses(&ph.robot, &ph.links, q);
            for (l, p) in ph.links.links.iter().zip(&lp) {
                if let (Some(l), Some(p)) = (l, p) {
                    black_box(exact::intersects(&l.solid, p, &o.solid, &o.pose).ok());
                }
            }
        }
    }) / n_q as f64;
    table.rows.push(row(&[
        "robot".into(),
        "PUMA 560 vs surgical head".into(),
        "exact, no culling (every link narrow)".into(),
        n_q.to_string(),
        us(t_noc),
        format!("{:.1}", t_noc / t_fk),
        "".into(),
        "".into(),
        "".into(),
        "ratio to FK".into(),
    ]));
    let s_self = CollisionSettings {
        self_collision: true,
        ..check_settings(Mode::Exact)
    };
    let t_self = time_per_call(REPS, 1, || {
        for q in &ph.qs {
            black_box(check_links(
                &ph.links,
                &link_poses(&ph.robot, &ph.links, q),
                &ph.scene,
                &s_self,
            ));
        }
    }) / n_q as f64;
    table.rows.push(row(&[
        "robot".into(),
        "PUMA 560 vs surgical head + self-collision".into(),
        "exact with box culling".into(),
        n_q.to_string(),
        us(t_self),
        format!("{:.1}", t_self / t_fk),
        "".into(),
        "".into(),
        "".into(),
        "ratio to FK".into(),
    ]));
}

/// 2b. The seed's surgical-positioner study (§2.7): points around the head, every analytic
/// IK solution checked for collision; is there at least one that does not touch the head?
fn seed_study(
    ph: &PumaHead,
    t_fk: f64,
    table: &mut Table,
    notes: &mut Vec<String>,
) -> Result<(), RunError> {
    let mut probe = ph.robot.clone();
    probe.tool = Isometry3::translation(0.0, 0.0, 0.15).to_homogeneous();
    let probe_links = LinkSolids::from_dh(&probe, 0.02).map_err(|source| RunError::LinkSolids {
        what: "the probe robot",
        source,
    })?;
    let c = ph.head_pose.translation.vector;
    for (standoff, label) in [
        (0.105, "probe tip 5 mm off the head"),
        (0.095, "probe tip 5 mm into the head (all must touch)"),
    ] {
        let Approaches {
            targets,
            reachable,
            free,
            solutions,
            touching,
            mut checks_s,
        } = approaches(ph, &probe, &probe_links, &c, standoff);
        let t_sol = if checks_s.is_empty() {
            f64::NAN
        } else {
            percentile(&mut checks_s, 50.0)
        };
        table.rows.push(row(&[
        "robot".into(),
        format!("seed §2.7 study, {label}: {targets} approach poses, {reachable} reachable, {free} with a collision-free IK solution; {touching} of {solutions} solutions touch"),
        "exact + self-collision, every analytic IK solution".into(),
        solutions.to_string(),
        us(t_sol),
        format!("{:.1}", t_sol / t_fk),
        "".into(),
        "".into(),
        "".into(),
        "median per solution check; ratio to FK".into(),
    ]));
        if standoff > 0.1 {
            notes.push(format!(
        "Seed §2.7 study: PUMA 560 with a 0.15 m probe as tool (link boxes of half-width 2 cm), tool z aimed at the head axis, probe tip 5 mm off the head surface, approach angle 0–105° in 5° steps and 11 positions along the head axis; all analytic IK solutions within limits are checked: {reachable} of {targets} poses reachable, {free} with at least one solution that touches neither the head nor the robot itself."
    ));
        }
    }

    Ok(())
}

/// What the §2.7 sweep found at one standoff: approach poses, reachable ones, ones with a
/// collision-free solution, solutions and touching solutions, and each check's time (s).
struct Approaches {
    targets: usize,
    reachable: usize,
    free: usize,
    solutions: usize,
    touching: usize,
    checks_s: Vec<f64>,
}

/// The §2.7 sweep at one standoff from the head's axis: 11 positions along the axis, approach
/// angles 0–105° in 5° steps, every analytic IK solution within limits checked.
fn approaches(
    ph: &PumaHead,
    probe: &robosim_kinematics::Robot,
    probe_links: &LinkSolids,
    c: &Vector3<f64>,
    standoff: f64,
) -> Approaches {
    let (mut targets, mut reachable, mut free, mut solutions, mut touching) =
        (0usize, 0usize, 0usize, 0usize, 0usize);
    let mut checks_s = Vec::new();
    let s_head = CollisionSettings {
        self_collision: true,
        ..check_settings(Mode::Exact)
    };
    let opts = IkOptions {
        all: true,
        ..IkOptions::default()
    };
    for iy in 0..=10 {
        let y = -0.10 + 0.02 * iy as f64;
        for k in 0..=21 {
            let th = (5.0 * k as f64).to_radians();
            // Tool z points into the head axis; the probe tip stops 5 mm off the surface.
            let z = Vector3::new(th.cos(), 0.0, -th.sin());
            let x = Vector3::y();
            let yv = z.cross(&x);
            let p = c + Vector3::new(0.0, y, 0.0) - z * standoff;
            let mut m = nalgebra::Matrix4::identity();
            m.fixed_view_mut::<3, 1>(0, 0).copy_from(&x);
            m.fixed_view_mut::<3, 1>(0, 1).copy_from(&yv);
            m.fixed_view_mut::<3, 1>(0, 2).copy_from(&z);
            m.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
            targets += 1;
            let Ok(res) = ik::solve(&probe, &m, Method::Analytic, &opts) else {
                continue;
            };
            let good: Vec<_> = res
                .solutions
                .iter()
                .filter(|s| s.converged && s.within_limits)
                .collect();
            if good.is_empty() {
                continue;
            }
            reachable += 1;
            let mut any_free = false;
            for sol in good {
                solutions += 1;
                let t = Instant::now();
                let r = check_links(
                    &probe_links,
                    &link_poses(&probe, &probe_links, &sol.q),
                    &ph.scene,
                    &s_head,
                );
                checks_s.push(t.elapsed().as_secs_f64());
                any_free |= r.is_clear();
                touching += usize::from(!r.is_clear());
            }
            free += usize::from(any_free);
        }
    }
    Approaches {
        targets,
        reachable,
        free,
        solutions,
        touching,
        checks_s,
    }
}

/// 3. Facet count against volume error, time and misses (cylinder pairs, polygon mode).
/// Answers the plots' series: volume error, polygon time, polygon misses.
fn facet_study(rng: &mut ChaCha8Rng, scale: usize, table: &mut Table) -> [Series; 3] {
    let mut vol_series = Series {
        label: "volume error (1 − V_faceted/V)".into(),
        points: Vec::new(),
    };
    let mut time_series = Series {
        label: "polygon mode µs per pair".into(),
        points: Vec::new(),
    };
    let mut miss_series = Series {
        label: "polygon false negatives (%)".into(),
        points: Vec::new(),
    };
    let geo: Vec<(f64, f64, Isometry3<f64>, Isometry3<f64>)> = (0..100 * scale)
        .map(|_| {
            (
                rng.random_range(0.1..0.3),
                rng.random_range(0.2..0.6),
                random_pose(rng, 0.05),
                random_pose(rng, 0.35),
            )
        })
        .collect();
    for n in [6usize, 8, 12, 16, 24, 32, 48, 64, 96, 128, 256] {
        let cyl_pairs: Vec<Pair> = geo
            .iter()
            .map(|(r, h, pa, pb)| {
                let c = Solid::cylinder(*r, *h, Some(n))
                    .unwrap_or_else(|_| unreachable!("valid cylinder"));
                (c.clone(), *pa, c, *pb)
            })
            .collect();
        let vol_err =
            1.0 - cyl_pairs[0].0.faceted_volume() / cyl_pairs[0].0.exact_volume.unwrap_or(f64::NAN);
        let t_truth: Vec<Option<bool>> = cyl_pairs
            .iter()
            .map(|p| Variant::Exact.run(p).intersects())
            .collect();
        let got: Vec<Option<bool>> = cyl_pairs
            .iter()
            .map(|p| Variant::Polygon.run(p).intersects())
            .collect();
        let (fneg, fpos, unk) = confusion(&got, &t_truth);
        let t = time_per_call(REPS, 1, || {
            for p in &cyl_pairs {
                black_box(Variant::Polygon.run(p));
            }
        }) / cyl_pairs.len() as f64;
        let te = time_per_call(REPS, 1, || {
            for p in &cyl_pairs {
                black_box(Variant::Exact.run(p));
            }
        }) / cyl_pairs.len() as f64;
        vol_series.points.push((n as f64, vol_err));
        time_series.points.push((n as f64, t * 1e6));
        miss_series
            .points
            .push((n as f64, 100.0 * fneg as f64 / cyl_pairs.len() as f64));
        table.rows.push(row(&[
            "facets".into(),
            format!("cylinder vs cylinder, {n} facets, volume error {vol_err:.2e}"),
            "polygon".into(),
            cyl_pairs.len().to_string(),
            us(t),
            format!("{:.1}", t / te),
            fneg.to_string(),
            fpos.to_string(),
            unk.to_string(),
            format!("ratio to exact on the true cylinders ({} µs)", us(te)),
        ]));
    }

    [vol_series, time_series, miss_series]
}

/// 4. Broad phase, 1 % moving: sweep-and-prune, BVH and brute force per step at each size.
/// Answers the plot's series (ms per step against bodies).
fn broad_phase_study(
    rng: &mut ChaCha8Rng,
    quick: bool,
    table: &mut Table,
    notes: &mut Vec<String>,
) -> Result<Vec<Series>, RunError> {
    let mut bp_series: Vec<Series> = vec![
        Series {
            label: "sweep-and-prune".into(),
            points: Vec::new(),
        },
        Series {
            label: "bvh".into(),
            points: Vec::new(),
        },
        Series {
            label: "brute force".into(),
            points: Vec::new(),
        },
    ];
    let sizes: &[usize] = if quick {
        &[1000, 10_000]
    } else {
        &[1000, 3000, 10_000, 30_000]
    };
    let steps = if quick { 20 } else { 200 };
    let mut bp10k = (f64::NAN, f64::NAN);
    for &n in sizes {
        let BroadTimes {
            mut per_step,
            t_build_sap,
            t_build_bvh,
        } = broad_phase_at(rng, n, steps)?;
        let med: Vec<f64> = per_step.iter_mut().map(|s| percentile(s, 50.0)).collect();
        for (k, name) in ["sweep-and-prune", "bvh", "brute force"].iter().enumerate() {
            bp_series[k].points.push((n as f64, med[k] * 1e3));
            let build = match k {
                0 => format!("build {:.1} ms (sort)", t_build_sap * 1e3),
                1 => format!("build {:.1} ms (binned SAH)", t_build_bvh * 1e3),
                _ => String::new(),
            };
            table.rows.push(row(&[
                "broad".into(),
                format!("{n} bodies, 1 % moving, {steps} steps"),
                (*name).into(),
                steps.to_string(),
                us(med[k]),
                format!("{:.2}", med[k] / med[2]),
                "0".into(),
                "0".into(),
                "0".into(),
                format!("per step; ratio to brute force; target < 1000 µs at 10,000; {build}"),
            ]));
        }
        if n == 10_000 {
            bp10k = (med[0], med[1]);
        }
    }
    let winner = if bp10k.0 <= bp10k.1 {
        "sweep-and-prune"
    } else {
        "BVH"
    };
    notes.push(format!(
        "Broad phase at 10,000 bodies, 1 % moving: sweep-and-prune {:.0} µs/step, BVH {:.0} µs/step — {winner} wins this workload (both report exactly the brute-force pairs).",
        bp10k.0 * 1e6,
        bp10k.1 * 1e6
    ));

    Ok(bp_series)
}

/// One broad-phase size: the per-step times (s) of sweep-and-prune, BVH and brute force, and
/// the two build times (s).
struct BroadTimes {
    per_step: [Vec<f64>; 3],
    t_build_sap: f64,
    t_build_bvh: f64,
}

/// `n` bodies 0.2–1 m in a cube whose side keeps the density constant, 1 % of them moving for
/// `steps` steps; every step's pairs must agree with brute force.
fn broad_phase_at(rng: &mut ChaCha8Rng, n: usize, steps: usize) -> Result<BroadTimes, RunError> {
    // Bodies 0.2–1 m in a cube whose side keeps the density constant (≈ 10,000 in 50 m).
    let side = 50.0 * (n as f64 / 10_000.0).cbrt();
    let mut boxes: Vec<Aabb> = (0..n)
        .map(|_| Aabb {
            center: Point3::new(
                rng.random_range(0.0..side),
                rng.random_range(0.0..side),
                rng.random_range(0.0..side),
            ),
            half: Vector3::new(
                rng.random_range(0.1..0.5),
                rng.random_range(0.1..0.5),
                rng.random_range(0.1..0.5),
            ),
        })
        .collect();
    let moving: Vec<u32> = (0..n as u32).step_by(100).collect();
    let vel: Vec<Vector3<f64>> = moving
        .iter()
        .map(|_| {
            Vector3::new(
                rng.random_range(-0.05..0.05),
                rng.random_range(-0.05..0.05),
                rng.random_range(-0.05..0.05),
            )
        })
        .collect();
    let t_build_sap = Instant::now();
    let mut sap = SweepAndPrune::from_boxes(&boxes);
    let t_build_sap = t_build_sap.elapsed().as_secs_f64();
    let t_build_bvh = Instant::now();
    let mut bvh = BvhBroadPhase::from_boxes(&boxes);
    let t_build_bvh = t_build_bvh.elapsed().as_secs_f64();
    let mut out = Vec::new();
    let mut per_step = [Vec::new(), Vec::new(), Vec::new()];
    let mut agree = true;
    for _ in 0..steps {
        for (m, v) in moving.iter().zip(&vel) {
            boxes[*m as usize].center += v;
        }
        let t = Instant::now();
        for m in &moving {
            sap.set(*m, &boxes[*m as usize]);
        }
        out.clear();
        sap.pairs_involving(&moving, &mut out);
        per_step[0].push(t.elapsed().as_secs_f64());
        let sap_pairs = out.clone();
        let t = Instant::now();
        for m in &moving {
            bvh.set(*m, &boxes[*m as usize]);
        }
        out.clear();
        bvh.pairs_involving(&moving, &mut out);
        per_step[1].push(t.elapsed().as_secs_f64());
        agree &= out == sap_pairs;
        let t = Instant::now();
        out.clear();
        brute_force_pairs(&boxes, &moving, &mut out);
        per_step[2].push(t.elapsed().as_secs_f64());
        agree &= out == sap_pairs;
    }
    if !agree {
        return Err(format!("broad phases disagree with brute force at n = {n}").into());
    }
    Ok(BroadTimes {
        per_step,
        t_build_sap,
        t_build_bvh,
    })
}

/// The report's plots: the facet series and the broad phase's.
fn collision_plots(facets: [Series; 3], bp_series: Vec<Series>) -> Vec<Plot> {
    let [vol_series, time_series, miss_series] = facets;
    vec![
        Plot {
            title: "Cylinder facets: volume error".into(),
            x_label: "facets".into(),
            y_label: "1 − V_faceted/V".into(),
            log_x: true,
            log_y: true,
            series: vec![vol_series],
        },
        Plot {
            title: "Cylinder facets: polygon-mode time and misses".into(),
            x_label: "facets".into(),
            y_label: "µs per pair / % false negatives".into(),
            log_x: true,
            log_y: false,
            series: vec![time_series, miss_series],
        },
        Plot {
            title: "Broad phase, 1 % moving".into(),
            x_label: "bodies".into(),
            y_label: "ms per step".into(),
            log_x: true,
            log_y: true,
            series: bp_series,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_report_writes_its_files() {
        let dir = tempfile::tempdir().expect("temp dir");
        let paths = report_collision(dir.path(), true).expect("report");
        assert!(
            paths
                .iter()
                .any(|p| p.extension().is_some_and(|e| e == "csv"))
        );
        let md = std::fs::read_to_string(dir.path().join("collision.md")).expect("md");
        assert!(md.contains("sweep-and-prune") && md.contains("PUMA 560"));
    }
}
