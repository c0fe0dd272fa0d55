//! `robosim bench journal`: what the journal's second copy costs (issue #20 item 9). One
//! process, the keeper's own [`Journal`] on the device that holds the sessions
//! (`robosim_instance_space::home()`), one and two copies measured in interleaved blocks of
//! the same run so that the machine's noise falls on both alike:
//!
//! * **group-commit latency**: one ~100-byte record appended and synced per group — what a
//!   lone writer's transaction waits for before its acknowledgement;
//! * **throughput**: groups of 64 records, one sync each (a pipelined writer);
//! * **recovery**: replaying a journal of N records at keeper start (with two copies the
//!   mirror is also checked and rewritten).

use robosim_instance_space::journal::{Journal, recover_copies};
use robosim_instance_space::{Kind, Store, Transaction};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn err<E: std::fmt::Display>(what: &'static str) -> impl FnOnce(E) -> String {
    move |e| format!("{what}: {e}")
}

/// A store with one scene, and the transactions that rename it (each ~100 bytes encoded).
fn scene() -> (Store, robosim_instance_space::Id) {
    let mut store = Store::default();
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    let id = store.apply(&tx).map(|a| a.created[0]).unwrap_or(1);
    (store, id)
}

fn rename(id: robosim_instance_space::Id, k: u64) -> Vec<u8> {
    let mut tx = Transaction::new();
    tx.set_name(
        id,
        &format!("scene renamed for the journal bench, number {k:012}"),
    );
    tx.encode()
}

/// Nanoseconds per group of `per_group` records, `groups` groups, in a fresh journal.
fn groups(dir: &Path, copies: u8, groups: usize, per_group: usize) -> Result<Vec<f64>, String> {
    let mut j = Journal::create_copies(dir, 1, copies).map_err(err("create journal"))?;
    let tx = rename(1, 0);
    let mut v = 1u64;
    let mut out = Vec::with_capacity(groups);
    for _ in 0..groups {
        let t = Instant::now();
        for _ in 0..per_group {
            j.append(v, &tx).map_err(err("append"))?;
            v += 1;
        }
        j.sync().map_err(err("sync"))?;
        out.push(t.elapsed().as_nanos() as f64);
    }
    Ok(out)
}

/// Writes `journal.md` and `journal.csv` under `out`; returns their paths.
pub fn run(out: &Path, quick: bool) -> Result<Vec<PathBuf>, String> {
    let home = robosim_instance_space::home();
    std::fs::create_dir_all(&home).map_err(err("session home"))?;
    let (blocks, lat_per_block, thr_per_block, recover_n) = if quick {
        (4, 50, 10, 2_000u64)
    } else {
        (10, 200, 40, 50_000u64)
    };
    let mut lat = [Vec::new(), Vec::new()];
    let mut thr = [Vec::new(), Vec::new()];
    for b in 0..blocks {
        // ABAB…, then BABA…: neither copy count always runs first.
        let order: [u8; 2] = if b % 2 == 0 { [1, 2] } else { [2, 1] };
        for c in order {
            let dir = tempfile::tempdir_in(&home).map_err(err("temp dir"))?;
            lat[c as usize - 1].extend(groups(dir.path(), c, lat_per_block, 1)?);
            thr[c as usize - 1].extend(groups(dir.path(), c, thr_per_block, 64)?);
        }
    }
    // Recovery of a journal of `recover_n` records, each copy count on its own journal.
    let mut rec = [0.0f64; 2];
    for c in [1u8, 2] {
        let dir = tempfile::tempdir_in(&home).map_err(err("temp dir"))?;
        let (mut store, id) = scene();
        let mut j = Journal::create_copies(dir.path(), 1, c).map_err(err("create journal"))?;
        let mut tx = Transaction::new();
        tx.create(Kind::Scene, "scene", None);
        j.append(1, &tx.encode()).map_err(err("append"))?;
        for k in 0..recover_n {
            let mut tx = Transaction::new();
            tx.set_name(
                id,
                &format!("scene renamed for the journal bench, number {k:012}"),
            );
            let a = store.apply(&tx).map_err(err("apply"))?;
            j.append(a.version, &tx.encode()).map_err(err("append"))?;
        }
        j.sync().map_err(err("sync"))?;
        drop(j);
        let t = Instant::now();
        let (m, _, report) = recover_copies(dir.path(), c).map_err(err("recover"))?;
        rec[c as usize - 1] = t.elapsed().as_secs_f64() * 1e3;
        if m.version != recover_n + 1 || !report.problems.is_empty() {
            return Err(format!(
                "recovery bench: version {} (expected {}), problems {:?}",
                m.version,
                recover_n + 1,
                report.problems
            ));
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let pct = |v: &[f64], p: f64| crate::percentile(&mut v.to_vec(), p);
    let rows: Vec<(String, [f64; 2], &str)> = vec![
        (
            "group commit, 1 record: mean".into(),
            [mean(&lat[0]) / 1e3, mean(&lat[1]) / 1e3],
            "µs",
        ),
        (
            "group commit, 1 record: p50".into(),
            [pct(&lat[0], 50.0) / 1e3, pct(&lat[1], 50.0) / 1e3],
            "µs",
        ),
        (
            "group commit, 1 record: p99".into(),
            [pct(&lat[0], 99.0) / 1e3, pct(&lat[1], 99.0) / 1e3],
            "µs",
        ),
        (
            "groups of 64 records: throughput".into(),
            [64e9 / mean(&thr[0]), 64e9 / mean(&thr[1])],
            "records/s",
        ),
        (format!("recovery of {recover_n} records"), rec, "ms"),
    ];
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "unknown".into());
    let mut md = format!(
        "# The journal's second copy (`robosim bench journal{}`)\n\n\
         What `--journal-copies 2` (the default) costs against one copy, measured in one run on \
         this shared 2-core machine in {blocks} interleaved blocks (1,2 then 2,1), on the device of \
         the session home ({}). Records are ~100-byte rename transactions; a group is appended and \
         then synced (fdatasync; with two copies both files are synced together, on two threads). \
         The second copy is what lets recovery read a damaged record (a flipped bit, a bad sector) \
         from the mirror instead of cutting every record after it \
         (`instance-space/tests/journal.rs`, `tests/space.rs`).\n\n\
         Load average at the start: {load}. The absolute figures are the disk's state during the \
         run (other processes' builds write to the same device); the 2 / 1 column is the finding.\n\n\
         | measure | 1 copy | 2 copies | 2 / 1 |\n|---|---|---|---|\n",
        if quick { " --quick" } else { "" },
        home.display()
    );
    let mut csv = String::from("measure,copies_1,copies_2,ratio,unit\n");
    for (name, [a, b], unit) in &rows {
        let _ = writeln!(md, "| {name} ({unit}) | {a:.1} | {b:.1} | {:.2} |", b / a);
        let _ = writeln!(csv, "{name},{a:.3},{b:.3},{:.4},{unit}", b / a);
    }
    let _ = writeln!(
        md,
        "\nSamples: {} single-record groups and {} groups of 64 per copy count.",
        lat[0].len(),
        thr[0].len()
    );
    std::fs::create_dir_all(out).map_err(err("output directory"))?;
    let (mdp, csvp) = (out.join("journal.md"), out.join("journal.csv"));
    std::fs::write(&mdp, md).map_err(err("journal.md"))?;
    std::fs::write(&csvp, csv).map_err(err("journal.csv"))?;
    Ok(vec![mdp, csvp])
}
