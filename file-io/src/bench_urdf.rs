//! `robosim bench urdf`: what bringing a URDF robot in costs, stage by stage, and as the one
//! command a user runs (`robosim import urdf` into a running session), against a baseline
//! measured in the same run: `robosim import mesh` of a 12-triangle cube into the same session
//! (a process start, a session attach and one small transaction — everything but the URDF).
//!
//! Rows, interleaved repetitions, medians:
//! * parse: the URDF to the model (`import_urdf_tree`: XML, tree, inertials; no mesh read);
//! * transaction: every mesh read (Collada visuals, STL collisions), collision hulls (or their
//!   decomposition), the objects built (`urdf_tx`);
//! * keeper side: that transaction applied to an empty store (validation, planes, edges);
//! * `robosim import urdf` into a running session, end to end (a child process);
//! * the baseline, `robosim import mesh` of a cube, end to end.

use crate::urdf_import::UrdfError;
use crate::urdf_session::{UrdfPlacement, urdf_tx};
use robosim_instance_space::{IDENTITY, Store, TxError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Why the bench did not run to its end.
#[derive(Debug, thiserror::Error)]
pub enum BenchUrdfError {
    /// The URDF (or a mesh it names) could not be read or turned into a transaction.
    #[error(transparent)]
    Urdf(#[from] UrdfError),
    /// The URDF's geometry made no transaction (a mesh's triangles, …).
    #[error(transparent)]
    Tx(#[from] crate::urdf_session::UrdfTxError),
    /// The keeper's store refused the URDF's transaction.
    #[error("the URDF's transaction on an empty store: {0}")]
    Apply(#[from] TxError),
    /// A file or directory of the bench (`path`) could not be written, or the binary started.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A `robosim` command of the end-to-end rows failed (its arguments, its stderr).
    #[error("robosim {args:?}: {stderr}")]
    Command { args: Vec<String>, stderr: String },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BenchUrdfError + '_ {
    move |source| BenchUrdfError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn run_cli(me: &Path, args: &[&str]) -> Result<f64, BenchUrdfError> {
    let t = Instant::now();
    let o = Command::new(me).args(args).output().map_err(io(me))?;
    if !o.status.success() {
        return Err(BenchUrdfError::Command {
            args: args.iter().map(|a| a.to_string()).collect(),
            stderr: String::from_utf8_lossy(&o.stderr).trim().to_string(),
        });
    }
    Ok(t.elapsed().as_secs_f64())
}

/// Runs the bench on the URDF at `urdf` (its meshes where it names them), writing urdf.md and
/// urdf.csv to `out`; `me` is the robosim binary (the end-to-end rows run it). The error is
/// the text of [`measure`]'s typed one with its causes (the binary's `CliError` takes text
/// for this call).
pub fn run(out: &Path, quick: bool, me: &Path, urdf: &Path) -> Result<Vec<PathBuf>, String> {
    measure(out, quick, me, urdf).map_err(|e| robosim_instance_space::error_chain(&e))
}

/// [`run`] with the typed error.
pub fn measure(
    out: &Path,
    quick: bool,
    me: &Path,
    urdf: &Path,
) -> Result<Vec<PathBuf>, BenchUrdfError> {
    let reps = if quick { 3 } else { 9 };
    let u = crate::urdf_import::import_urdf_tree(urdf)?;
    let place = |name: String| UrdfPlacement {
        name,
        pose: IDENTITY,
        parent: None,
        visuals: true,
        mimic: false,
    };
    let first = urdf_tx(&u, &place("probe".into()))?;
    let dir = robosim_instance_space::home().join(format!("bench-urdf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let cube = dir.join("cube.obj");
    std::fs::write(
        &cube,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .map_err(io(&cube))?;
    let session = format!("bench-urdf-{}", std::process::id());
    let urdf_s = urdf.to_string_lossy().into_owned();
    let cube_s = cube.to_string_lossy().into_owned();
    run_cli(me, &["up", "demo", "--session", &session])?;
    let names = [
        "parse (import_urdf_tree, no mesh)",
        "transaction (meshes read, hulls, objects)",
        "keeper side: the transaction applied to an empty store",
        "robosim import urdf into a running session",
        "baseline: robosim import mesh (a cube) into the same session",
    ];
    let mut t: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let measured = (|| -> Result<(), BenchUrdfError> {
        for k in 0..reps {
            let s = Instant::now();
            let parsed = crate::urdf_import::import_urdf_tree(urdf)?;
            t[0].push(s.elapsed().as_secs_f64());
            let s = Instant::now();
            let imp = urdf_tx(&parsed, &place(format!("r{k}")))?;
            t[1].push(s.elapsed().as_secs_f64());
            let s = Instant::now();
            Store::new().apply(&imp.tx)?;
            t[2].push(s.elapsed().as_secs_f64());
            let name = format!("panda{k}");
            t[3].push(run_cli(
                me,
                &[
                    "import",
                    "urdf",
                    &urdf_s,
                    "--as",
                    &name,
                    "--session",
                    &session,
                ],
            )?);
            let name = format!("cube{k}");
            t[4].push(run_cli(
                me,
                &[
                    "import",
                    "mesh",
                    &cube_s,
                    "--as",
                    &name,
                    "--session",
                    &session,
                ],
            )?);
        }
        Ok(())
    })();
    let _ = run_cli(me, &["down", "--session", &session]);
    let _ = std::fs::remove_dir_all(&dir);
    measured?;
    let med: Vec<f64> = t.iter_mut().map(|v| median(v)).collect();
    std::fs::create_dir_all(out).map_err(io(out))?;
    let build = if cfg!(debug_assertions) {
        "the dev profile (opt-level 1 for workspace crates, 2 for dependencies)"
    } else {
        "the release profile"
    };
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "?".into());
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# URDF import: {} ({} joints, {} visuals, {} collision solids, {} mesh triangles)\n\n`robosim bench urdf{}` — one run, {reps} interleaved repetitions, medians; built with {build}; load average {load} at the start. Baseline: `robosim import mesh` of a 12-triangle cube into the same running session (process start, attach, one small transaction).\n",
        urdf.display(),
        first.joints,
        first.visuals,
        first.solids,
        first.triangles,
        if quick { " --quick" } else { "" },
    );
    let _ = writeln!(md, "| stage | median | × baseline |\n|---|---:|---:|");
    let mut csv = String::from("stage,median_s,ratio_to_baseline\n");
    for (i, n) in names.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {n} | {:.1} ms | {:.2} |",
            med[i] * 1e3,
            med[i] / med[4]
        );
        let _ = writeln!(csv, "{n},{:.6},{:.3}", med[i], med[i] / med[4]);
    }
    let md_path = out.join("urdf.md");
    let csv_path = out.join("urdf.csv");
    std::fs::write(&md_path, md).map_err(io(&md_path))?;
    std::fs::write(&csv_path, csv).map_err(io(&csv_path))?;
    Ok(vec![md_path, csv_path])
}
