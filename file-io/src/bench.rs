//! `robosim bench files`: what saving and loading a 10⁶-vertex model costs, against copying
//! the same bytes with `cp` (the physical limit: one read and one write of the file), measured
//! in interleaved repetitions of one run on the device that holds the sessions
//! (`robosim_instance_space::home()`), reported as medians and ratios to `cp`.
//!
//! Rows: save (encode + write, no sync; and as `robosim save` does it, with fsync, against
//! `cp` + `sync FILE`), load (read + decode + structure check), the JSON form both ways, the
//! digest, and the keeper's side of a load done in-process (the transaction built and applied
//! to an empty store: validation and the derived planes, penalty planes and edges).

use crate::format::{self, Encoding};
use crate::model::SavedModel;
use robosim_instance_space::{ObjectData, Store};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn err<E: std::fmt::Display>(what: &'static str) -> impl FnOnce(E) -> String {
    move |e| format!("{what}: {e}")
}

/// A model of `solids` cylinders of `facets` facets each (2 × facets vertices per solid),
/// under one item under one scene.
pub fn big_model(solids: usize, facets: usize) -> Result<SavedModel, String> {
    let cyl =
        robosim_geometry::shapes::cylinder(0.1, 0.5, Some(facets)).map_err(err("cylinder"))?;
    let g = robosim_instance_space::GeometryInput::from_polyhedron(&cyl);
    let base = |id: u64, kind, parent: u64, name: String| ObjectData {
        id,
        kind,
        parent,
        name,
        pose: robosim_instance_space::IDENTITY,
        joint: 0.0,
        appearance: robosim_instance_space::Appearance::default(),
        kinematics: None,
        dynamics: None,
        geometry: None,
        geom_gen: 0,
        origin: String::new(),
    };
    let mut objects = vec![
        base(1, robosim_instance_space::Kind::Scene, 0, "bench".into()),
        base(2, robosim_instance_space::Kind::Item, 1, "cylinders".into()),
    ];
    for k in 0..solids {
        let mut o = base(
            3 + k as u64,
            robosim_instance_space::Kind::Solid,
            2,
            format!("c{k}"),
        );
        o.pose[3] = (k % 100) as f64 * 0.3;
        o.pose[7] = (k / 100) as f64 * 0.3;
        o.geometry = Some(g.clone());
        objects.push(o);
    }
    Ok(SavedModel {
        version: 1,
        objects,
        library: Vec::new(),
    })
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn cp(src: &Path, dst: &Path, sync: bool) -> Result<f64, String> {
    let t = Instant::now();
    let st = std::process::Command::new("cp")
        .arg(src)
        .arg(dst)
        .status()
        .map_err(err("cp"))?;
    if sync {
        std::process::Command::new("sync")
            .arg(dst)
            .status()
            .map_err(err("sync"))?;
    }
    let s = t.elapsed().as_secs_f64();
    if !st.success() {
        return Err("cp failed".into());
    }
    Ok(s)
}

/// Runs the bench and writes `files.md` and `files.csv` under `out`; returns their paths.
pub fn run(out: &Path, quick: bool) -> Result<Vec<PathBuf>, String> {
    let (solids, facets, reps) = if quick { (100, 500, 3) } else { (1000, 500, 7) };
    let model = big_model(solids, facets)?;
    let vertices = model.vertex_count();
    let dir = robosim_instance_space::home().join(format!("bench-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(err("bench directory"))?;
    let bin = dir.join("model.rsm");
    let json = dir.join("model.json");
    let copy = dir.join("copy.rsm");
    let copy_json = dir.join("copy.json");
    format::write(&model, &bin, Encoding::Binary).map_err(err("save"))?;
    format::write(&model, &json, Encoding::Json).map_err(err("save json"))?;
    let bin_bytes = std::fs::metadata(&bin).map_err(err("stat"))?.len();
    let json_bytes = std::fs::metadata(&json).map_err(err("stat"))?.len();

    let names = [
        "cp (binary bytes)",
        "save binary (encode + write)",
        "cp + sync FILE",
        "save binary with fsync (robosim save)",
        "read binary (bytes only)",
        "load binary (read + decode + check)",
        "cp (JSON bytes)",
        "save JSON",
        "load JSON",
        "digest",
        "keeper side: build + apply the load transaction",
    ];
    let mut t: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for _ in 0..reps {
        // Interleaved: each repetition measures every row once, so the machine's noise falls
        // on all rows alike.
        t[0].push(cp(&bin, &copy, false)?);
        let s = Instant::now();
        let bytes = format::encode_binary(&model);
        std::fs::write(&copy, &bytes).map_err(err("write"))?;
        t[1].push(s.elapsed().as_secs_f64());
        t[2].push(cp(&bin, &copy, true)?);
        let s = Instant::now();
        format::write(&model, &copy, Encoding::Binary).map_err(err("save"))?;
        t[3].push(s.elapsed().as_secs_f64());
        let s = Instant::now();
        let bytes = std::fs::read(&bin).map_err(err("read"))?;
        t[4].push(s.elapsed().as_secs_f64());
        drop(bytes);
        let s = Instant::now();
        let back = format::read(&bin).map_err(err("load"))?;
        t[5].push(s.elapsed().as_secs_f64());
        if back != model {
            return Err("the loaded model differs from the saved one".into());
        }
        t[6].push(cp(&json, &copy_json, false)?);
        let s = Instant::now();
        let bytes = format::encode_json(&model, &copy_json).map_err(err("json"))?;
        std::fs::write(&copy_json, &bytes).map_err(err("write"))?;
        t[7].push(s.elapsed().as_secs_f64());
        let s = Instant::now();
        let back = format::read(&json).map_err(err("load json"))?;
        t[8].push(s.elapsed().as_secs_f64());
        if back != model {
            return Err("the JSON model differs from the saved one".into());
        }
        let s = Instant::now();
        let d = crate::digest(&model);
        t[9].push(s.elapsed().as_secs_f64());
        if d.is_none() {
            return Err("no digest".into());
        }
        let s = Instant::now();
        let plan = model.to_transaction(&[]).map_err(err("plan"))?;
        let mut store = Store::new();
        store.apply(&plan.tx).map_err(err("apply"))?;
        t[10].push(s.elapsed().as_secs_f64());
    }
    let _ = std::fs::remove_dir_all(&dir);
    let med: Vec<f64> = t.iter_mut().map(|v| median(v)).collect();
    let base = |i: usize| match i {
        2 | 3 => med[2],
        6..=8 => med[6],
        _ => med[0],
    };
    std::fs::create_dir_all(out).map_err(err("output directory"))?;
    let mut csv = String::from("measure,median_s,baseline,ratio_to_baseline\n");
    let mut md = String::new();
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "?".into());
    let build = if cfg!(debug_assertions) {
        "the dev profile (opt-level 1 for workspace crates, 2 for dependencies)"
    } else {
        "the release profile"
    };
    let _ = writeln!(
        md,
        "# Model files: save and load against `cp`\n\n`robosim bench files{}` — one run, {reps} interleaved repetitions, medians; built with {build}; load average {load} at the start. Model: {} solids (cylinders of {facets} facets), {vertices} vertices; binary file {:.1} MB, JSON {:.1} MB. Directory: the sessions' device (`$ROBOSIM_HOME`). Baseline: `cp` of the same file (one read, one write: the physical limit), started as a process like any copy; with fsync rows, `cp` followed by `sync FILE`.\n",
        if quick { " --quick" } else { "" },
        solids,
        bin_bytes as f64 / 1e6,
        json_bytes as f64 / 1e6
    );
    let _ = writeln!(md, "| measure | median | × baseline |\n|---|---:|---:|");
    for (i, n) in names.iter().enumerate() {
        let b = base(i);
        let bn = names[match i {
            2 | 3 => 2,
            6..=8 => 6,
            _ => 0,
        }];
        let _ = writeln!(csv, "{n},{:.6},{bn},{:.3}", med[i], med[i] / b);
        let _ = writeln!(md, "| {n} | {:.1} ms | {:.2} |", med[i] * 1e3, med[i] / b);
    }
    let _ = writeln!(
        md,
        "\nThe load rows stop at the file: a load into a session also sends the transaction to the keeper, which validates it (the last row, done here in-process), journals it and publishes it (docs/bench/ipc.md, docs/bench/journal.md)."
    );
    let md_path = out.join("files.md");
    let csv_path = out.join("files.csv");
    std::fs::write(&md_path, md).map_err(err("files.md"))?;
    std::fs::write(&csv_path, csv).map_err(err("files.csv"))?;
    Ok(vec![md_path, csv_path])
}
