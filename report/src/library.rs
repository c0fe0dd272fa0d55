//! The Library Space benchmark: parse and evaluate the Space Station scene (seed §4.1) at
//! several facet counts. Evaluation builds every polygon of every solid, so its time should
//! grow linearly with the polygon count; the report shows time per polygon staying flat.
//!
//! Entry point: [`report_library`] (wired as `robosim report library`).

use crate::plot::RunError;
use crate::plot::{Plot, Report, Series, Table, percentile, write_report};
use robosim_library::{EvalOptions, Evaluated, Library, Params};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Polygons and vertices of an evaluated scene.
fn size(e: &Evaluated) -> (usize, usize) {
    let mut polys = 0;
    let mut verts = 0;
    let mut add = |p: &robosim_geometry::Polyhedron| {
        polys += p.polygons.len();
        verts += p.vertices.len();
    };
    if let Evaluated::Scene(s) = e {
        for i in &s.solids {
            i.solid.parts.iter().for_each(|p| add(&p.polyhedron));
        }
        for r in &s.robots {
            r.model
                .frames
                .iter()
                .flatten()
                .for_each(|p| add(&p.polyhedron));
        }
    }
    (polys, verts)
}

/// Runs the benchmark and writes `library.csv`, `library.md`, `library.png` into `out_dir`.
/// `quick`: fewer facet counts and repetitions (a smoke run). Times are wall-clock on a shared
/// machine; the report gives ratios against the smallest facet count measured in the same run.
pub fn report_library(out_dir: &Path, quick: bool) -> Result<Vec<PathBuf>, RunError> {
    let facets: &[usize] = if quick {
        &[8, 16, 32, 64]
    } else {
        &[8, 16, 32, 64, 128, 256, 512]
    };
    let reps = if quick { 3 } else { 15 };
    // parse + check of the station's files (independent of the facet override)
    let src = "include \"std/materials.rsl\"\ninclude \"std/station.rsl\"\n";
    let mut parse_ms = Vec::new();
    let mut lib = None;
    for _ in 0..reps {
        let t = Instant::now();
        let l = Library::from_source("space station", src).map_err(|source| RunError::Library {
            what: "the space station source",
            source,
        })?;
        parse_ms.push(t.elapsed().as_secs_f64() * 1e3);
        lib = Some(l);
    }
    let lib = lib.ok_or("no repetitions")?;
    let parse_med = percentile(&mut parse_ms, 50.0);
    let mut rows = Vec::new();
    let mut time_pts = Vec::new();
    let mut per_poly_pts = Vec::new();
    let mut base: Option<(f64, usize)> = None;
    for &n in facets {
        let opts = EvalOptions {
            facets: Some(n),
            max_polygons: None,
        };
        let mut ms = Vec::with_capacity(reps);
        let mut dims = (0, 0);
        for _ in 0..reps {
            let t = Instant::now();
            let e = lib
                .evaluate_with("space_station", &Params::new(), &opts)
                .map_err(|source| RunError::Evaluate {
                    what: "space_station",
                    source,
                })?;
            ms.push(t.elapsed().as_secs_f64() * 1e3);
            dims = size(&e);
        }
        // The minimum is the least disturbed run on a shared machine; the median and 90th
        // percentile show the spread.
        let min = percentile(&mut ms, 0.0);
        let med = percentile(&mut ms, 50.0);
        let p90 = percentile(&mut ms, 90.0);
        let (b_ms, b_polys) = *base.get_or_insert((min, dims.0));
        let us_per_poly = min * 1e3 / dims.0 as f64;
        rows.push(vec![
            n.to_string(),
            dims.0.to_string(),
            dims.1.to_string(),
            format!("{min:.2}"),
            format!("{med:.2}"),
            format!("{p90:.2}"),
            format!("{:.2}", min / b_ms),
            format!("{:.2}", dims.0 as f64 / b_polys as f64),
            format!("{us_per_poly:.3}"),
        ]);
        time_pts.push((dims.0 as f64, min));
        per_poly_pts.push((n as f64, us_per_poly));
    }
    // least-squares line t = a + b·P over the medians, and its R²
    let n = time_pts.len() as f64;
    let (sx, sy) = time_pts
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = time_pts.iter().map(|&(x, _)| (x - mx).powi(2)).sum();
    let sxy: f64 = time_pts.iter().map(|&(x, y)| (x - mx) * (y - my)).sum();
    let slope = sxy / sxx;
    let icpt = my - slope * mx;
    let ss_res: f64 = time_pts
        .iter()
        .map(|&(x, y)| (y - icpt - slope * x).powi(2))
        .sum();
    let ss_tot: f64 = time_pts.iter().map(|&(_, y)| (y - my).powi(2)).sum();
    let r2 = 1.0 - ss_res / ss_tot;
    let report = Report {
        name: "library".into(),
        title: "Library Space: parse and evaluate the Space Station against facet count".into(),
        notes: vec![
            format!("Parse + load-time check of std/materials.rsl and std/station.rsl (every declaration evaluated at its defaults): median {parse_med:.2} ms over {reps} runs."),
            "Evaluation of `space_station` with every round primitive forced to `facets` (EvalOptions); boxes are unaffected. Minimum (the least disturbed run: the machine is shared), median and 90th percentile wall-clock over the repetitions; ratios, the fit and the plots use the minimum.".into(),
            format!("Least-squares line through the minima: time = {icpt:.2} ms + {:.3} µs × polygons, R² = {r2:.4} (a fixed cost per evaluation plus a constant cost per polygon: linear).", slope * 1e3),
            "time ratio and polygon ratio are against the smallest facet count in the same run (shared, noisy machine: compare ratios, not absolute times). Spheres make the polygon count grow with facets².".into(),
            format!(
                "{} run, {} build.",
                if quick { "quick" } else { "full" },
                if cfg!(debug_assertions) { "dev-profile (opt-level 1, dependencies opt-level 2)" } else { "release" }
            ),
        ],
        table: Table {
            columns: ["facets",
                "polygons",
                "vertices",
                "eval_ms_min",
                "eval_ms_median",
                "eval_ms_p90", "time_ratio", "polygon_ratio", "us_per_polygon"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rows,
        },
        plots: vec![
            Plot {
                title: "Evaluation time against polygon count".into(),
                x_label: "polygons in the evaluated scene".into(),
                y_label: "minimum time, ms".into(),
                log_x: true,
                log_y: true,
                series: vec![Series { label: "space_station".into(), points: time_pts }],
            },
            Plot {
                title: "Time per polygon (flat = linear)".into(),
                x_label: "facets per round primitive".into(),
                y_label: "µs per polygon".into(),
                log_x: true,
                log_y: false,
                series: vec![Series { label: "space_station".into(), points: per_poly_pts }],
            },
        ],
    };
    Ok(write_report(out_dir, &report)?)
}
