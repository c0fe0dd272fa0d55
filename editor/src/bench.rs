//! `robosim bench editor`: what one edit costs in the Space Station model (issue 13: "an edit of
//! one object in the Space Station model commits and reaches the display in under 1 ms of
//! keeper time").
//!
//! For each keeper configuration (the journal synced before each acknowledgement, as a user's
//! session runs, and not synced), in one run, against a keeper process of its own started on
//! the `space_station` library scene:
//!
//! * **empty transaction** (the baseline): a transaction with no operations, refused by the
//!   keeper — the request/response round trip with nothing applied, journaled or published;
//! * **one pose op**: a raw client moves the module (one `SetPose`), acknowledged;
//! * **editor translate, model object**: `translate PATH X=±1 cm` through the editor's
//!   command interpreter ([`crate::commands::execute`]) on the same module — parse, find the
//!   object, one transaction, acknowledged;
//! * **editor translate, design object**: the same on a box of an editor design (the
//!   transaction also rewrites the object's editor record);
//! * **… reaches a reader**: from just before the command to the moment a reader of the session
//!   (this process's [`Reader`], as the display's) holds the new version;
//! * **… announced**: from just before the command to the keeper's publication of the change
//!   (its `published_ns`, CLOCK_MONOTONIC, comparable across processes).
//!
//! The keeper's own time for an edit is estimated as the edit's round trip minus the empty
//! transaction's (the keeper publishes no timing of its own for one transaction).

use crate::cli::{RunError, follow};
use crate::commands::{CommandError, Prompt, execute};
use crate::session::Editor;
use robosim_instance_space::{
    Client, ClientError, Kind, Reader, ScratchKeeper, Transaction, TxError,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Why the bench stopped. A variant that wraps a lower error keeps it; the message says which
/// step (keeper, reader, editor line, file) failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// What the bench shares with `robosim edit` ([`RunError`], whole): the keeper did not
    /// start, a version did not arrive or an edit was lost (`Refused`, the message), a raw
    /// client's connection or transaction failed, the session could not be read, the editor
    /// could not start on its design or its prompt could not follow the session.
    #[error(transparent)]
    Session(RunError),
    /// An editor line was refused (`line`: the line).
    #[error("{line}: {source}")]
    Command { line: String, source: CommandError },
    /// A report file was not written.
    #[error("{}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// A refusal (`String`, `&str`) or a client, reader or editor error, as [`RunError`] holds it.
impl<E: Into<RunError>> From<E> for BenchError {
    fn from(e: E) -> Self {
        BenchError::Session(e.into())
    }
}

/// One editor line, its refusal kept with the line.
fn line<S: crate::session::Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    line: &str,
) -> Result<(), BenchError> {
    execute(ed, p, line).map_err(|source| BenchError::Command {
        line: line.to_owned(),
        source,
    })?;
    Ok(())
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    v[rank.saturating_sub(1).min(v.len() - 1)]
}

/// p50, p99 and mean of samples (µs).
fn stats(mut v: Vec<f64>) -> (f64, f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (percentile(&mut v, 50.0), percentile(&mut v, 99.0), mean)
}

fn us(from_ns: u64, to_ns: u64) -> f64 {
    to_ns.saturating_sub(from_ns) as f64 / 1e3
}

struct Row {
    keeper: &'static str,
    measure: &'static str,
    objects: usize,
    p50: f64,
    p99: f64,
    mean: f64,
}

/// Waits until `reader` holds `version`; the CLOCK_MONOTONIC time it did.
fn reach(reader: &mut Reader, version: u64) -> Result<u64, BenchError> {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        reader.refresh()?;
        if reader.snapshot().is_some_and(|s| s.version() >= version) {
            return Ok(robosim_instance_space::monotonic_ns());
        }
        if Instant::now() > deadline {
            return Err(format!("no reader saw version {version} within 10 s").into());
        }
        reader.wait_change(Duration::from_millis(50))?;
    }
}

/// The keeper's publication time of `version`.
fn published(reader: &mut Reader, version: u64) -> Result<u64, BenchError> {
    reader
        .changes_since(version - 1)?
        .into_iter()
        .find(|c| c.version == version)
        .map(|c| c.published_ns)
        .ok_or_else(|| format!("no change record for version {version}").into())
}

/// Runs the bench and writes `editor.md` and `editor.csv` into `out`. `exe`: the robosim
/// binary (started as the keeper).
pub fn run(out: &Path, quick: bool, exe: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let reps = if quick { 200 } else { 2_000 };
    let warm = if quick { 20 } else { 200 };
    let pid = std::process::id();
    let mut rows = Vec::new();
    let mut module = String::new();
    for durable in [true, false] {
        let keeper = if durable {
            "journal synced"
        } else {
            "journal not synced"
        };
        let args: &[&str] = if durable {
            &["--scene", "space_station"]
        } else {
            &["--scene", "space_station", "--no-sync"]
        };
        let name = format!("be{pid}{}", durable as u8);
        let kp = ScratchKeeper::start(exe, &name, args, Duration::from_secs(120))?;
        let mut raw = Client::connect(kp.session(), "bench-raw")?;
        let mut reader = Reader::attach(kp.session(), "bench-reader")?;
        reach(&mut reader, 1)?;
        // The module edited: the first item of the scene with geometry below it, by path.
        let snap = reader.snapshot().ok_or("no model")?;
        let target = (0..snap.len())
            .find(|&i| {
                snap.object(i).kind() == Some(Kind::Item)
                    && snap.children(snap.rec(i).id).next().is_some()
            })
            .or_else(|| (0..snap.len()).find(|&i| snap.geometry(i).is_some()))
            .ok_or("the space_station scene has no item to move")?;
        let id = snap.rec(target).id;
        module = snap.path(target);
        let pose0 = snap.pose(target).pose;
        drop(snap);
        let client = Client::connect(kp.session(), "bench-editor")?;
        let mut ed = Editor::new(client, "bench")?;
        let mut p = Prompt::default();
        follow(&mut reader, &ed, &mut p, ed.version)?;
        line(&mut ed, &mut p, "box b X=10 Y=10 Z=10")?;
        let objects = reader.snapshot().map_or(0, |s| s.len());

        let mut empty = Vec::with_capacity(reps);
        let mut pose = Vec::with_capacity(reps);
        let mut model_rtt = Vec::with_capacity(reps);
        let mut model_pub = Vec::with_capacity(reps);
        let mut model_seen = Vec::with_capacity(reps);
        let mut design_rtt = Vec::with_capacity(reps);
        let mut design_seen = Vec::with_capacity(reps);
        for k in 0..warm + reps {
            let keep = k >= warm;
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            // the baseline: refused, nothing applied
            let t0 = robosim_instance_space::monotonic_ns();
            match raw.transact(&Transaction::new()) {
                Err(ClientError::Refused(TxError::Empty)) => {}
                other => return Err(format!("the empty transaction: {other:?}").into()),
            }
            let t1 = robosim_instance_space::monotonic_ns();
            // one pose op, raw
            let mut tx = Transaction::new();
            let mut q = pose0;
            q[3] += sign * 1e-3;
            tx.set_pose(id, q);
            let t2 = robosim_instance_space::monotonic_ns();
            let v = raw.transact(&tx)?.version;
            let t3 = robosim_instance_space::monotonic_ns();
            reach(&mut reader, v)?;
            // the editor on the module (its prompt first reads the session, as at a prompt)
            follow(&mut reader, &ed, &mut p, v)?;
            let translate = format!("translate {module} X={} cm", sign);
            let t4 = robosim_instance_space::monotonic_ns();
            line(&mut ed, &mut p, &translate)?;
            let t5 = robosim_instance_space::monotonic_ns();
            let t6 = reach(&mut reader, ed.version)?;
            let pub_ns = published(&mut reader, ed.version)?;
            // the editor on a design object
            follow(&mut reader, &ed, &mut p, ed.version)?;
            let t7 = robosim_instance_space::monotonic_ns();
            line(&mut ed, &mut p, &format!("translate b X={sign} cm"))?;
            let t8 = robosim_instance_space::monotonic_ns();
            let t9 = reach(&mut reader, ed.version)?;
            if keep {
                empty.push(us(t0, t1));
                pose.push(us(t2, t3));
                model_rtt.push(us(t4, t5));
                model_pub.push(us(t4, pub_ns));
                model_seen.push(us(t4, t6));
                design_rtt.push(us(t7, t8));
                design_seen.push(us(t7, t9));
            }
        }
        // Last round: the raw op put the module at x0 ± 1 mm, the editor moved it ± 1 cm more.
        let sign = if (warm + reps - 1) % 2 == 0 {
            1.0
        } else {
            -1.0
        };
        let expect = pose0[3] + sign * 1e-3 + sign * 0.01;
        let snap = reader.snapshot().ok_or("no model")?;
        let i = snap.index_of(id).ok_or("the module is gone")?;
        let x = snap.pose(i).pose[3];
        if (x - expect).abs() > 1e-9 {
            return Err(format!(
                "the module ended at x = {x} m, not at {expect} m: an edit was lost"
            )
            .into());
        }
        for (measure, v) in [
            ("empty transaction (baseline)", empty),
            ("one pose op, raw client", pose),
            ("editor translate, model object: acknowledged", model_rtt),
            ("editor translate, model object: announced", model_pub),
            (
                "editor translate, model object: reaches a reader",
                model_seen,
            ),
            ("editor translate, design object: acknowledged", design_rtt),
            (
                "editor translate, design object: reaches a reader",
                design_seen,
            ),
        ] {
            let (p50, p99, mean) = stats(v);
            rows.push(Row {
                keeper,
                measure,
                objects,
                p50,
                p99,
                mean,
            });
        }
    }
    write(out, quick, reps, &module, &rows)
}

fn write(
    out: &Path,
    quick: bool,
    reps: usize,
    module: &str,
    rows: &[Row],
) -> Result<Vec<PathBuf>, BenchError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| BenchError::Write { path, source }
    };
    std::fs::create_dir_all(out).map_err(io(out))?;
    let mut csv = String::from("keeper,measure,objects,p50_us,p99_us,mean_us,p50_over_empty\n");
    let mut md =
        String::from("# Editor: one edit in the Space Station model (`robosim bench editor`)\n\n");
    let _ = writeln!(
        md,
        "{reps} repetitions per measure{}, after warm-up, one run; the module moved is `{module}`. \
         Times from CLOCK_MONOTONIC in µs. The ratio column is the p50 over the empty \
         transaction's p50 of the same keeper, same run.\n",
        if quick { " (--quick)" } else { "" }
    );
    md.push_str("| keeper | measure | objects | p50 (µs) | p99 (µs) | mean (µs) | p50 / empty |\n");
    md.push_str("|---|---|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let base = rows
            .iter()
            .find(|b| b.keeper == r.keeper && b.measure.starts_with("empty"))
            .map_or(f64::NAN, |b| b.p50);
        let _ = writeln!(
            csv,
            "{},{},{},{:.1},{:.1},{:.1},{:.2}",
            r.keeper,
            r.measure,
            r.objects,
            r.p50,
            r.p99,
            r.mean,
            r.p50 / base
        );
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.2} |",
            r.keeper,
            r.measure,
            r.objects,
            r.p50,
            r.p99,
            r.mean,
            r.p50 / base
        );
    }
    for r in rows
        .iter()
        .filter(|r| r.measure.ends_with("model object: acknowledged"))
    {
        let base = rows
            .iter()
            .find(|b| b.keeper == r.keeper && b.measure.starts_with("empty"))
            .map_or(f64::NAN, |b| b.p50);
        let _ = writeln!(
            md,
            "\nKeeper time of one editor edit ({}), estimated as acknowledged − empty at p50: {:.1} µs.",
            r.keeper,
            r.p50 - base
        );
    }
    let md_path = out.join("editor.md");
    let csv_path = out.join("editor.csv");
    std::fs::write(&md_path, md).map_err(io(&md_path))?;
    std::fs::write(&csv_path, csv).map_err(io(&csv_path))?;
    Ok(vec![md_path, csv_path])
}
