//! 5. **Distance tolerance** (issue 37 item 3): for the exact distance of separated convex
//!    pairs, robosim's error and time at each tolerance — certified (a bracket of width
//!    ≤ 1e-11 m) and GJK tolerances 1e-2 … 1e-9 m ([`Tolerance::Gjk`]) — beside coal 3.0.3's at
//!    its `gjk_tolerance`, on the same pairs. Errors of both against robosim's certified
//!    distance; coal's distances and times are checked-in data
//!    (`tools/peers/collision_tolerance_coal.py` writes `testdata/collision/tolerance_*.csv`:
//!    the pairs, coal's distance per pair and tolerance, coal's best-of-15 time per pair and
//!    its Python binding's cost per call, which is subtracted here). FCL 0.7 beside them, the
//!    same way (`tools/peers/collision_tolerance_fcl.py` writes `tolerance_fcl*.csv`), at its
//!    one tolerance: python-fcl 0.7.0.11 cannot set FCL's `distance_tolerance` (default 1e-6).

use super::{REPS, time_per_call};
use crate::plot::{Plot, Series, Table};
use robosim_collision::PairResult;
use robosim_collision::exact::pair_file::{self, Pair};
use robosim_collision::exact::{self, ExactOptions, Tolerance};
use std::collections::BTreeMap;
use std::hint::black_box;

const PAIRS: &str = include_str!("../../../testdata/collision/tolerance_pairs.csv");
const COAL: &str = include_str!("../../../testdata/collision/tolerance_coal.csv");
const COAL_TIME: &str = include_str!("../../../testdata/collision/tolerance_coal_time.csv");
const FCL: &str = include_str!("../../../testdata/collision/tolerance_fcl.csv");
const FCL_TIME: &str = include_str!("../../../testdata/collision/tolerance_fcl_time.csv");

/// The GJK tolerances coal was run at (metres), loosest first.
const TOLERANCES: [f64; 8] = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9];

fn nums(cells: &[&str]) -> Result<Vec<f64>, String> {
    cells
        .iter()
        .map(|c| c.parse::<f64>().map_err(|e| format!("{c}: {e}")))
        .collect()
}

fn distance(p: &Pair, tolerance: Tolerance) -> Option<f64> {
    let opts = ExactOptions {
        tolerance,
        ..ExactOptions::default()
    };
    match exact::collide(&p.a, &p.pa, &p.b, &p.pb, opts) {
        PairResult::Clear { distance, .. } => distance,
        _ => None,
    }
}

/// coal's distance per (class, index, tolerance bits) and time per (class, tolerance bits):
/// (ns per pair, binding ns per call).
type CoalDistances = BTreeMap<(String, usize, u64), f64>;
type CoalTimes = BTreeMap<(String, u64), (f64, f64)>;

/// A peer's distances (`class,index,tolerance,distance`) and times
/// (`class,tolerance,ns_per_pair,binding_ns`), as the peer scripts write them.
fn peer_data(distances: &str, times: &str) -> Result<(CoalDistances, CoalTimes), String> {
    let mut d = BTreeMap::new();
    for l in distances.lines().skip(1).filter(|l| !l.is_empty()) {
        let c: Vec<&str> = l.split(',').collect();
        let v = nums(&c[1..4])?;
        d.insert((c[0].to_owned(), v[0] as usize, v[1].to_bits()), v[2]);
    }
    let mut t = BTreeMap::new();
    for l in times.lines().skip(1).filter(|l| !l.is_empty()) {
        let c: Vec<&str> = l.split(',').collect();
        let v = nums(&c[1..4])?;
        t.insert((c[0].to_owned(), v[0].to_bits()), (v[1], v[2]));
    }
    Ok((d, t))
}

/// A peer at tolerance `tol` on one class's pairs `idx`: (largest error against `reference`,
/// seconds per pair net of the binding, pairs without a distance). A peer answers f64::MAX
/// (coal) or a huge value for a pair it gives up on: counted apart, not in the error.
fn peer_at(
    d: &CoalDistances,
    t: &CoalTimes,
    class: &str,
    tol: f64,
    idx: &[usize],
    reference: &[f64],
) -> Option<(f64, f64, usize)> {
    let errs = idx
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            d.get(&(class.to_string(), k, tol.to_bits()))
                .map(|d| (d - reference[i]).abs())
        })
        .collect::<Option<Vec<f64>>>()?;
    let failed = errs.iter().filter(|e| !(**e < 1.0)).count();
    let err = errs.into_iter().filter(|e| *e < 1.0).fold(0.0, f64::max);
    let (ns, binding) = *t.get(&(class.to_string(), tol.to_bits()))?;
    Some((err, ((ns - binding) * 1e-9).max(1e-9), failed))
}

fn sci(x: f64) -> String {
    format!("{x:.1e}")
}

/// Rows per class and tolerance (robosim and coal), and the error-against-time plot (all
/// classes pooled: the largest error and the mean time per pair at each tolerance).
pub(super) fn tolerance_study(table: &mut Table, notes: &mut Vec<String>) -> Result<Plot, String> {
    let study = Study::load()?;
    let Study { pairs, fcl_tol, .. } = &study;
    let mut classes: Vec<&str> = pairs.iter().map(|p| p.class.as_str()).collect();
    classes.dedup();
    let mut curves = Curves::default();
    for (label, tol, coal_tol) in &settings() {
        let mut sums = SettingSums::default();
        for class in &classes {
            table.rows.push(measure_class(
                &study,
                class,
                label,
                *tol,
                *coal_tol,
                &mut sums,
                &mut curves,
            ));
        }
        let n = pairs.len() as f64;
        let floor = 1e-17;
        // only finite points reach the log axes
        if sums.max_ours.is_finite() {
            curves
                .ours_pts
                .push((sums.t_ours_sum / n * 1e6, sums.max_ours.max(floor)));
        }
        if coal_tol.is_some() && sums.max_coal.is_finite() {
            curves
                .coal_pts
                .push((sums.t_coal_sum / n * 1e6, sums.max_coal.max(floor)));
        }
    }
    let Curves {
        mut ours_pts,
        coal_pts,
        fcl_err,
        fcl_t_sum,
        fcl_n,
        worst_ratio,
    } = curves;
    let fcl_pts = if fcl_n > 0 && fcl_err.is_finite() {
        vec![(fcl_t_sum / fcl_n as f64 * 1e6, fcl_err.max(1e-17))]
    } else {
        Vec::new()
    };
    // the certified point last: the line then runs from the loosest tolerance to certified
    let first = ours_pts.len().min(1);
    ours_pts.rotate_left(first);
    notes.push(format!(
        "Distance tolerance (issue 37 item 3): {} separated pairs in 4 classes from `testdata/collision/tolerance_pairs.csv`; errors against robosim's certified distance (bracket ≤ 1e-11 m); coal 3.0.3's distances and times from `tools/peers/collision_tolerance_coal.py` (best of 15 rounds, its Python binding's cost per call subtracted; robosim's best of {REPS}); FCL 0.7's the same way from `tools/peers/collision_tolerance_fcl.py`, at its default distance_tolerance {fcl_tol:e} only (python-fcl 0.7.0.11 cannot set it; one point on the plot). The largest robosim / coal time ratio at a matched tolerance: {worst_ratio:.2}. robosim's tolerance is GJK's bracket width (absolute); coal's gjk_tolerance enters its own convergence criterion, so equal numbers are not equal accuracy — the plot puts both at their measured error. Errors of 0 are drawn at 1e-17.",
        pairs.len()
    ));
    Ok(Plot {
        title: "Exact distance: largest error against time per tolerance".into(),
        x_label: "µs per pair (mean over the classes)".into(),
        y_label: "largest |error| (m)".into(),
        log_x: true,
        log_y: true,
        series: vec![
            Series {
                label: "robosim (1e-2 … 1e-9 m, then certified)".into(),
                points: ours_pts,
            },
            Series {
                label: "coal 3.0.3 (gjk_tolerance 1e-2 … 1e-9)".into(),
                points: coal_pts,
            },
            Series {
                label: "FCL 0.7 (python-fcl; its fixed distance_tolerance 1e-6)".into(),
                points: fcl_pts,
            },
        ],
    })
}

/// The tolerance pairs, their certified distances, and the peers' data.
struct Study {
    pairs: Vec<Pair>,
    /// Each pair's certified distance.
    reference: Vec<f64>,
    coal_d: CoalDistances,
    coal_t: CoalTimes,
    fcl_d: CoalDistances,
    fcl_t: CoalTimes,
    /// FCL's one tolerance (python-fcl cannot set it).
    fcl_tol: f64,
}

impl Study {
    fn load() -> Result<Self, String> {
        let pairs = pair_file::parse(PAIRS, "tolerance_pairs.csv").map_err(|e| e.to_string())?;
        let (coal_d, coal_t) =
            peer_data(COAL, COAL_TIME).map_err(|e| format!("coal's data: {e}"))?;
        let (fcl_d, fcl_t) = peer_data(FCL, FCL_TIME).map_err(|e| format!("FCL's data: {e}"))?;
        // FCL's one tolerance (python-fcl cannot set it): its row is robosim's at the same value.
        let fcl_tol = fcl_t
            .keys()
            .next()
            .map(|(_, bits)| f64::from_bits(*bits))
            .ok_or("FCL's data: no time rows")?;
        let reference: Vec<f64> = pairs
            .iter()
            .map(|p| distance(p, Tolerance::Certified).ok_or("a tolerance pair is not clear"))
            .collect::<Result<_, _>>()?;
        Ok(Study {
            pairs,
            reference,
            coal_d,
            coal_t,
            fcl_d,
            fcl_t,
            fcl_tol,
        })
    }
}

/// The settings measured: (label, robosim's tolerance, the peers' tolerance); certified first.
fn settings() -> Vec<(String, Tolerance, Option<f64>)> {
    std::iter::once(("certified".to_owned(), Tolerance::Certified, None))
        .chain(
            TOLERANCES
                .iter()
                .map(|&t| (sci(t), Tolerance::Gjk(t), Some(t))),
        )
        .collect()
}

/// Over one setting, all classes: robosim's and coal's largest error and summed time.
#[derive(Default)]
struct SettingSums {
    max_ours: f64,
    max_coal: f64,
    t_ours_sum: f64,
    t_coal_sum: f64,
}

/// Over the whole study: the plot's points, FCL's one point, the worst robosim / coal ratio.
#[derive(Default)]
struct Curves {
    ours_pts: Vec<(f64, f64)>,
    coal_pts: Vec<(f64, f64)>,
    fcl_err: f64,
    fcl_t_sum: f64,
    fcl_n: usize,
    worst_ratio: f64,
}

/// One class at one setting: robosim's largest error and time per pair, coal's and FCL's at
/// the same tolerance; returns the table row.
fn measure_class(
    study: &Study,
    class: &str,
    label: &str,
    tol: Tolerance,
    coal_tol: Option<f64>,
    sums: &mut SettingSums,
    curves: &mut Curves,
) -> Vec<String> {
    let Study {
        pairs,
        reference,
        coal_d,
        coal_t,
        fcl_d,
        fcl_t,
        fcl_tol,
    } = study;
    let Curves {
        fcl_err,
        fcl_t_sum,
        fcl_n,
        worst_ratio,
        ..
    } = curves;
    let idx: Vec<usize> = (0..pairs.len())
        .filter(|&i| pairs[i].class == *class)
        .collect();
    let err_ours = idx
        .iter()
        .map(|&i| distance(&pairs[i], tol).map_or(f64::INFINITY, |d| (d - reference[i]).abs()))
        .fold(0.0, f64::max);
    let t_ours = time_per_call(REPS, 1, || {
        for &i in &idx {
            black_box(distance(&pairs[i], tol));
        }
    }) / idx.len() as f64;
    sums.max_ours = sums.max_ours.max(err_ours);
    sums.t_ours_sum += t_ours * idx.len() as f64;
    let coal = coal_tol.and_then(|ct| peer_at(&coal_d, &coal_t, class, ct, &idx, &reference));
    let fcl = coal_tol
        .filter(|ct| ct.to_bits() == fcl_tol.to_bits())
        .and_then(|ct| peer_at(&fcl_d, &fcl_t, class, ct, &idx, &reference));
    let fcl_note = match fcl {
        Some((e, t, failed)) => {
            *fcl_err = fcl_err.max(e);
            *fcl_t_sum += t * idx.len() as f64;
            *fcl_n += idx.len();
            format!(
                "; FCL 0.7 at its fixed distance_tolerance {label}: max error {} m, {:.3} µs net of its binding, robosim / FCL {:.2}{}",
                sci(e),
                t * 1e6,
                t_ours / t,
                if failed > 0 {
                    format!(", no distance for {failed} pair(s)")
                } else {
                    String::new()
                }
            )
        }
        None => String::new(),
    };
    let (ratio, coal_note) = match coal {
        Some((e, t, failed)) => {
            sums.max_coal = sums.max_coal.max(e);
            sums.t_coal_sum += t * idx.len() as f64;
            *worst_ratio = worst_ratio.max(t_ours / t);
            (
                format!("{:.2}", t_ours / t),
                format!(
                    "; coal at gjk_tolerance {label}: max error {} m, {:.3} µs net of its binding{}",
                    sci(e),
                    t * 1e6,
                    if failed > 0 {
                        format!(", no distance for {failed} pair(s) (coal answered f64::MAX)")
                    } else {
                        String::new()
                    }
                ),
            )
        }
        None => ("".into(), String::new()),
    };
    [
        "tolerance".into(),
        format!("{class}, {} separated pairs (1 mm–0.3 m)", idx.len()),
        format!("exact, tolerance {label}"),
        idx.len().to_string(),
        super::us(t_ours),
        ratio,
        "0".into(),
        "0".into(),
        "0".into(),
        format!(
            "max error {} m against the certified distance{coal_note}{fcl_note}; ratio to coal",
            sci(err_ours)
        ),
    ]
    .to_vec()
}
