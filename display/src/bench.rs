//! `robosim bench display`: what the display costs, measured in one run on this machine's
//! adapter (Mesa llvmpipe — a CPU rasterizer — where there is no GPU) and written to
//! `docs/bench/display_frames.{md,csv}` and `docs/bench/display_uploads.{md,csv,png}`.
//!
//! (a) Frame time at 1280×1024 for the Space Station, the PUMA 560 and an empty scene (the
//!     baseline: clearing and resolving the targets), drawn and waited for, with and without
//!     reading the image back; median and p90 of repeated frames.
//! (b) Bytes uploaded per pose update against scene size: scenes of 10² to 10⁵ bodies, one
//!     body moved per update; with the time `sync_changes` (the change-driven path the session
//!     display uses) and the full `sync` comparison take, each with its queue submission, and
//!     the CPU time of a frame after an update (encode and submit, not the rasterization), as
//!     ratios to the 10²-body scene.
//! (c) Tessellation, the display's accuracy knob: a sphere of 0.5 m faceted from 8 to 128
//!     facets per circle, drawn at 800×800 from 2 m; image error against the 256-facet
//!     sphere (pixels without a match, mean channel difference) against frame time.

use crate::Renderer;
use crate::app::{self as display, AppError, Result};
use robosim_instance_space::{Change, IDENTITY, Kind, Snapshot, Store, Transaction, aspect};
use robosim_report::{Plot, Report, Series, Table, percentile, write_report};
use std::path::Path;
use std::time::Instant;

fn median_p90(mut v: Vec<f64>) -> (f64, f64) {
    (percentile(&mut v, 50.0), percentile(&mut v, 90.0))
}

fn frames(r: &mut Renderer, n: usize, readback: bool) -> Result<(f64, f64)> {
    let (w, h) = (1280, 1024);
    for _ in 0..2 {
        r.draw_and_wait(w, h)?;
    }
    let mut t = Vec::with_capacity(n);
    for _ in 0..n {
        let t0 = Instant::now();
        if readback {
            r.render_image(w, h)?;
        } else {
            r.draw_and_wait(w, h)?;
        }
        t.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    Ok(median_p90(t))
}

fn cubes(n: usize) -> Store {
    let mut model = Store::new();
    let mut tx = Transaction::new();
    let side = (n as f64).sqrt().ceil() as usize;
    for k in 0..n {
        let c = tx.create(Kind::Solid, &format!("cube{k}"), None);
        let mut p = IDENTITY;
        p[3] = (k % side) as f64 * 0.3;
        p[7] = (k / side) as f64 * 0.3;
        tx.set_pose(c, p);
        tx.set_geometry(c, Some(robosim_scene::box_geometry([0.2, 0.2, 0.2])));
    }
    // One transaction for the whole scene; apply cannot fail on this well-formed input.
    let _ = model.apply(&tx);
    model
}

/// Scene sizes of the upload measurement (b).
pub const UPLOAD_SIZES: [usize; 4] = [100, 1_000, 10_000, 100_000];
/// The frame of (b): small, so that rasterizing 10⁵ boxes on a CPU adapter stays quick.
const FRAME_SIZE: (u32, u32) = (320, 240);

pub fn run(out: &Path, quick: bool) -> Result<()> {
    let reps = if quick { 5 } else { 30 };
    let r = Renderer::headless()?;
    let adapter = r.gpu().describe();
    let samples = r.samples();
    let frames_report = frame_times(reps, &adapter, samples)?;
    let uploads_report = uploads(quick, &adapter)?;
    let tess_report = tessellation(reps)?;
    for rep in [&frames_report, &uploads_report, &tess_report] {
        for p in write_report(out, rep).map_err(AppError::from)? {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// (a) Frame time: each scene drawn `reps` times, without and with readback, as ratios to the
/// empty scene; the `display_frames` report.
fn frame_times(reps: usize, adapter: &str, samples: u32) -> Result<Report> {
    let mut table = Table {
        columns: [
            "scene",
            "bodies",
            "triangles",
            "draw median (ms)",
            "draw p90 (ms)",
            "draw / empty",
            "draw+readback median (ms)",
            "draw+readback / empty",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    let mut baseline = (f64::NAN, f64::NAN);
    for scene in ["(empty)", "puma560", "space_station"] {
        let model = if scene == "(empty)" {
            Store::new()
        } else {
            display::local_store(&[], scene)?
        };
        let mut rr = Renderer::headless()?;
        rr.sync(&Snapshot::from_store(&model));
        rr.frame_all();
        let draw = frames(&mut rr, reps, false)?;
        let read = frames(&mut rr, reps, true)?;
        if scene == "(empty)" {
            baseline = (draw.0, read.0);
        }
        table.rows.push(vec![
            scene.to_owned(),
            rr.body_count().to_string(),
            rr.triangle_count().to_string(),
            format!("{:.1}", draw.0),
            format!("{:.1}", draw.1),
            format!("{:.2}", draw.0 / baseline.0),
            format!("{:.1}", read.0),
            format!("{:.2}", read.0 / baseline.1),
        ]);
        eprintln!(
            "bench display: {scene}: draw {:.1} ms, with readback {:.1} ms",
            draw.0, read.0
        );
    }
    Ok(Report {
        name: "display_frames".into(),
        title: "Display: frame time at 1280×1024".into(),
        notes: vec![
            format!("Adapter: {adapter}; {samples}× multisampling; {reps} frames after 2 warm-up frames, one run. The machine is shared: compare within the table (the ratio columns), not across runs."),
            "`draw` = encode, submit and wait for the device (a window's frame before presentation); `draw+readback` adds the copy to a buffer and the map (a headless PNG frame, without PNG encoding). The empty scene is the baseline: clearing, resolving and (for readback) copying 1280×1024 pixels.".into(),
            "Regenerate: `cargo run --release -- bench display`.".into(),
        ],
        table,
        plots: Vec::new(),
    })
}

/// (b) Upload per pose update against scene size: one row and one point per series for each
/// of [`UPLOAD_SIZES`], as ratios to the smallest; the `display_uploads` report.
fn uploads(quick: bool, adapter: &str) -> Result<Report> {
    let updates = if quick { 50 } else { 300 };
    let mut table = Table {
        columns: [
            "bodies",
            "updates",
            "bytes per update (mean)",
            "bytes per update (max)",
            "sync_changes median (µs)",
            "sync_changes p90 (µs)",
            "sync_changes / 10²",
            "full sync median (µs)",
            "full sync / 10²",
            "frame CPU median (µs)",
            "frame CPU / 10²",
            "mesh buffers",
            "draws per frame",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    let mut bytes_series = Series {
        label: "bytes uploaded per update".into(),
        points: Vec::new(),
    };
    let mut changes_series = Series {
        label: "sync_changes (µs)".into(),
        points: Vec::new(),
    };
    let mut full_series = Series {
        label: "full sync (µs)".into(),
        points: Vec::new(),
    };
    let mut frame_series = Series {
        label: "frame CPU (µs)".into(),
        points: Vec::new(),
    };
    let mut base = (f64::NAN, f64::NAN, f64::NAN);
    for n in UPLOAD_SIZES {
        let UploadSamples {
            r,
            bytes,
            t_changes,
            t_full,
            t_frame,
        } = upload_samples(n, updates)?;
        let mean = bytes.iter().sum::<f64>() / bytes.len() as f64;
        let max = bytes.iter().copied().fold(0.0, f64::max);
        let (c, c90) = median_p90(t_changes);
        let (f, _) = median_p90(t_full);
        let (fr, _) = median_p90(t_frame);
        if n == UPLOAD_SIZES[0] {
            base = (c, f, fr);
        }
        let (tri_buffers, edge_buffers, draws) = r.mesh_buffers();
        table.rows.push(vec![
            n.to_string(),
            updates.to_string(),
            format!("{mean:.1}"),
            format!("{max:.0}"),
            format!("{c:.1}"),
            format!("{c90:.1}"),
            format!("{:.2}", c / base.0),
            format!("{f:.1}"),
            format!("{:.2}", f / base.1),
            format!("{fr:.1}"),
            format!("{:.2}", fr / base.2),
            format!("{}", tri_buffers + edge_buffers),
            format!("{draws}"),
        ]);
        bytes_series.points.push((n as f64, mean));
        changes_series.points.push((n as f64, c));
        full_series.points.push((n as f64, f));
        frame_series.points.push((n as f64, fr));
        eprintln!(
            "bench display: {n} bodies: {mean:.1} B/update, sync_changes {c:.1} µs, full sync {f:.1} µs, frame CPU {fr:.1} µs"
        );
    }
    Ok(uploads_report(
        adapter,
        table,
        [bytes_series, changes_series, full_series, frame_series],
    ))
}

/// The `display_uploads` report: its notes and plots around the measured `table` and series
/// (bytes, sync_changes, full sync, frame CPU).
fn uploads_report(adapter: &str, table: Table, series: [Series; 4]) -> Report {
    let [bytes_series, changes_series, full_series, frame_series] = series;
    Report {
        name: "display_uploads".into(),
        title: "Display: bytes uploaded per pose update against scene size".into(),
        notes: vec![
            format!("Scenes of N boxes (12 triangles each); each update moves one random box (one pose transaction on a local model), then the renderer is brought up to date: the first half of the updates by `sync_changes` (the change-driven path the session display takes: pose-only records touch only the changed subtrees), the second half by the full `sync` comparison (every body's world pose compared, O(N) by design; alternating the two let the full comparison evict the other's working set from the caches). Each update's snapshot is assembled as a session reader does (`Snapshot::advanced`: the moved body's pose chunk new, everything else shared), not rebuilt from the model. Each update is timed with its submission to the queue (what a frame does). Every tenth update is followed by a frame at {}×{}: its CPU part — the scene bounds (the root of a box tree updated per moved body, O(log N)), encoding, submission — is timed, the rasterization is waited for untimed. Adapter: {adapter}. One run; the machine is shared.", FRAME_SIZE.0, FRAME_SIZE.1),
            "Goal: bytes per update constant in N — one 64-byte transform — and the change-driven update's CPU time flat (within 1.5× from 10² to 10⁵). Every body's mesh lives in a few shared vertex buffers (`mesh buffers`: triangle and edge buffers together; they grow by doubling, not per body), each vertex carrying its body's slot, and a frame draws each buffer's live runs (`draws per frame`: one per run between freed ranges), so neither the GPU resources wgpu tracks per submission nor the draws grow with N. Before this (one vertex buffer per body), the same update cost 16 µs at 10 bodies and 2.2 ms at 10,000.".into(),
            "Regenerate: `cargo run --release -- bench display`.".into(),
        ],
        table,
        plots: vec![
            Plot {
                title: "Bytes uploaded per pose update".into(),
                x_label: "bodies in the scene".into(),
                y_label: "bytes".into(),
                log_x: true,
                log_y: false,
                series: vec![bytes_series],
            },
            Plot {
                title: "CPU time to bring the GPU copy up to date, and of a frame".into(),
                x_label: "bodies in the scene".into(),
                y_label: "µs (median)".into(),
                log_x: true,
                log_y: true,
                series: vec![changes_series, full_series, frame_series],
            },
        ],
    }
}

/// What (b) measured on one scene size: the renderer (for its buffer counts), the bytes
/// uploaded per update, and the times (µs) of the `sync_changes` updates, of the full `sync`
/// updates and of the frames' CPU part.
struct UploadSamples {
    r: Renderer,
    bytes: Vec<f64>,
    t_changes: Vec<f64>,
    t_full: Vec<f64>,
    t_frame: Vec<f64>,
}

/// (b) on a scene of `n` boxes: `updates` pose updates of one random box, the first half
/// brought to the renderer by `sync_changes` (every tenth followed by a frame), the second by
/// the full `sync`.
fn upload_samples(n: usize, updates: usize) -> Result<UploadSamples> {
    // A renderer per size: what it holds is this scene alone.
    let mut r = Renderer::headless()?;
    let mut model = cubes(n);
    let mut snap = Snapshot::from_store(&model);
    let ids: Vec<u64> = snap.objects().iter().map(|o| o.id).collect();
    r.sync(&snap);
    r.frame_all();
    let (mut bytes, mut t_changes, mut t_full, mut t_frame) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut rng = 0x9e37_79b9_7f4a_7c15_u64;
    for u in 0..updates {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        let id = ids[(rng % n as u64) as usize];
        let mut tx = Transaction::new();
        let mut p = IDENTITY;
        p[11] = 0.01 * (u + 1) as f64;
        p[3] = (rng % 97) as f64 * 0.01;
        tx.set_pose(id, p);
        let applied = model.apply(&tx).map_err(AppError::from)?;
        // The next snapshot as a session reader assembles it: the moved body's pose chunk
        // new, every other chunk, the objects and the geometry shared with the last one.
        // (Rebuilding it from the model, O(N), between two timed updates evicted the
        // renderer's working set from the caches and made the update look O(N).)
        let moved = robosim_instance_space::layout::PoseRec {
            id,
            pose: p,
            joint: 0.0,
        };
        snap = snap.advanced(applied.version, &[moved]);
        let change = Change {
            version: applied.version,
            aspects: aspect::POSE,
            ids: vec![id],
            published_ns: 0,
        };
        // Each update is synced and submitted (as the display's frame would submit it),
        // timed together: wgpu does per-submission work of its own. The first half goes
        // the change-driven way, as a session display does; the second half by the full
        // comparison (O(N): run between the others it evicted their working set from the
        // caches).
        if u < updates / 2 {
            let t0 = Instant::now();
            let up = r.sync_changes(&snap, std::slice::from_ref(&change));
            r.flush_uploads();
            t_changes.push(t0.elapsed().as_secs_f64() * 1e6);
            bytes.push(up.total_bytes() as f64);
            // Every tenth update, a frame: its CPU part (bounds, encoding, submission) is
            // timed; the rasterization is waited for outside the timing.
            if u % 10 == 0 {
                let t0 = Instant::now();
                r.submit_frame(FRAME_SIZE.0, FRAME_SIZE.1)?;
                t_frame.push(t0.elapsed().as_secs_f64() * 1e6);
                r.wait_idle()?;
            }
        } else {
            let t0 = Instant::now();
            let up = r.sync(&snap);
            r.flush_uploads();
            t_full.push(t0.elapsed().as_secs_f64() * 1e6);
            bytes.push(up.total_bytes() as f64);
        }
    }
    Ok(UploadSamples {
        r,
        bytes,
        t_changes,
        t_full,
        t_frame,
    })
}

fn sphere_model(facets: usize) -> Result<Store> {
    let poly = robosim_geometry::shapes::sphere(0.5, Some(facets)).map_err(AppError::from)?;
    let mut model = Store::new();
    let mut tx = Transaction::new();
    let s = tx.create(Kind::Solid, "sphere", None);
    tx.set_geometry(
        s,
        Some(robosim_instance_space::GeometryInput::from_polyhedron(
            &poly,
        )),
    );
    tx.set_appearance(
        s,
        robosim_instance_space::Appearance {
            color: [0.8, 0.5, 0.2, 1.0],
            specular: 0.5,
            shininess: 32.0,
            ..Default::default()
        },
    );
    model.apply(&tx).map_err(AppError::from)?;
    Ok(model)
}

fn tessellation(reps: usize) -> Result<Report> {
    use nalgebra::Point3;
    let (w, h) = (800, 800);
    let camera = crate::Camera::looking(Point3::new(-1.4, 1.2, 0.6), Point3::origin());
    let draw = |facets: usize| -> Result<(crate::RgbaImage, usize, f64)> {
        let mut r = Renderer::headless()?;
        r.sync(&Snapshot::from_store(&sphere_model(facets)?));
        r.camera = camera;
        for _ in 0..2 {
            r.draw_and_wait(w, h)?;
        }
        let mut t = Vec::with_capacity(reps);
        for _ in 0..reps {
            let t0 = Instant::now();
            r.draw_and_wait(w, h)?;
            t.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        Ok((r.render_image(w, h)?, r.triangle_count(), median_p90(t).0))
    };
    let (reference, _, _) = draw(robosim_geometry::shapes::MAX_FACETS)?;
    let tol = crate::Tolerance::default();
    let mut table = Table {
        columns: [
            "facets per circle",
            "triangles",
            "chord error (mm)",
            "pixels without a match (%)",
            "mean channel difference",
            "draw median (ms)",
            "draw / 8 facets",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    let mut err_series = Series {
        label: "pixels without a match (%)".into(),
        points: Vec::new(),
    };
    let mut base = f64::NAN;
    for facets in [8usize, 16, 32, 64, 128] {
        let (img, tris, ms) = draw(facets)?;
        let d = crate::compare(&img, &reference, &tol)?;
        if facets == 8 {
            base = ms;
        }
        table.rows.push(vec![
            facets.to_string(),
            tris.to_string(),
            format!(
                "{:.3}",
                robosim_geometry::shapes::chord_error(0.5, facets) * 1e3
            ),
            format!("{:.3}", d.unmatched * 100.0),
            format!("{:.3}", d.mean_abs),
            format!("{ms:.2}"),
            format!("{:.2}", ms / base),
        ]);
        err_series
            .points
            .push((ms, (d.unmatched * 100.0).max(1e-4)));
        eprintln!(
            "bench display: sphere {facets} facets: {tris} triangles, {:.3} % unmatched, {ms:.2} ms",
            d.unmatched * 100.0
        );
    }
    Ok(Report {
        name: "display_tessellation".into(),
        title: "Display: tessellation (accuracy) against frame time".into(),
        notes: vec![
            format!("A 0.5 m sphere from the library's generator, faceted with N facets per circle, flat-shaded, drawn at 800×800 from 2.0 m; error is measured against the 256-facet sphere (the generator's maximum) with the golden-image comparison (a pixel matches if it lies within 24 levels of its 3×3 neighbourhood's range in the other image) and as the mean channel difference. The library's default rule (chord error ≤ 1 mm) gives this sphere {} facets.", robosim_geometry::shapes::default_facets(0.5, 1e-3)),
            "Frame time is draw + wait on the software adapter: at these sizes it is dominated by the per-pixel work, so facets cost little until the triangle count is large. One run; the machine is shared.".into(),
            "Regenerate: `cargo run --release -- bench display`.".into(),
        ],
        table,
        plots: vec![Plot {
            title: "Image error against frame time (sphere, 8 to 128 facets)".into(),
            x_label: "draw median (ms)".into(),
            y_label: "pixels without a match (%)".into(),
            log_x: false,
            log_y: true,
            series: vec![err_series],
        }],
    })
}
