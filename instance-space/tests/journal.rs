//! Durability without processes: a torn or corrupt journal tail is detected by its checksum,
//! reported, and cut off; nothing before it is lost; checkpoints compact the journal.

use robosim_instance_space::journal::{Journal, recover};
use robosim_instance_space::{Kind, Store, Transaction};
use std::io::Write;

fn commit(model: &mut Store, journal: &mut Journal, name: &str) {
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, name, None);
    let a = model.apply(&tx).expect("valid");
    journal.append(a.version, &tx.encode()).expect("append");
    journal.sync().expect("sync");
}

fn journal_file(dir: &std::path::Path) -> std::path::PathBuf {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .expect("dir")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "log"))
        .collect();
    v.sort();
    v.pop().expect("a journal")
}

#[test]
fn torn_tail_is_reported_and_dropped_and_nothing_before_it_is_lost() {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover(dir.path()).expect("fresh");
    for k in 0..5 {
        commit(&mut model, &mut journal, &format!("s{k}"));
    }
    drop(journal);
    // A record torn in the middle: header and half its payload.
    let path = journal_file(dir.path());
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&path)
        .expect("open");
    f.write_all(&[40, 0, 0, 0, 1, 2, 3, 4, 6, 0, 0, 0, 0, 0, 0, 0, 9, 9])
        .expect("write");
    drop(f);
    let (model2, mut journal2, report) = recover(dir.path()).expect("recovered");
    assert_eq!(model2.version, 5);
    assert_eq!(model2.len(), 5);
    assert_eq!(report.replayed, 5);
    assert!(
        report.problems.iter().any(|p| p.contains("torn record")),
        "{:?}",
        report.problems
    );
    // Appending continues after the cut.
    let mut m = model2;
    commit(&mut m, &mut journal2, "s5");
    drop(journal2);
    let (model3, _, report3) = recover(dir.path()).expect("again");
    assert_eq!(model3.version, 6);
    assert!(report3.problems.is_empty(), "{:?}", report3.problems);
}

#[test]
fn a_flipped_bit_fails_the_checksum_and_only_the_tail_from_there_is_dropped() {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover(dir.path()).expect("fresh");
    for k in 0..4 {
        commit(&mut model, &mut journal, &format!("scene-{k}"));
    }
    drop(journal);
    let path = journal_file(dir.path());
    let mut bytes = std::fs::read(&path).expect("read");
    // Flip a bit in the name of the third record's payload.
    let pos = bytes
        .windows(7)
        .position(|w| w == b"scene-2")
        .expect("third record");
    bytes[pos] ^= 0x20;
    std::fs::write(&path, &bytes).expect("write");
    let (model2, _, report) = recover(dir.path()).expect("recovered");
    assert_eq!(model2.version, 2, "records 1 and 2 survive");
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.contains("checksum mismatch")),
        "{:?}",
        report.problems
    );
}

#[test]
fn checkpoint_compacts_and_recovery_resumes_from_it() {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover(dir.path()).expect("fresh");
    for k in 0..10 {
        commit(&mut model, &mut journal, &format!("a{k}"));
    }
    journal.checkpoint(&model).expect("checkpoint");
    for k in 0..3 {
        commit(&mut model, &mut journal, &format!("b{k}"));
    }
    drop(journal);
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names.iter().filter(|n| n.starts_with("journal-")).count(),
        1,
        "old journal removed: {names:?}"
    );
    let (m2, _, report) = recover(dir.path()).expect("recovered");
    assert_eq!(
        (
            report.checkpoint_version,
            report.replayed,
            m2.version,
            m2.len()
        ),
        (10, 3, 13, 13)
    );
    assert_eq!(m2.next_id(), model.next_id(), "ids continue");
}

/// Flips one bit in the payload of the record of `version` in the journal file `path`.
fn flip(path: &std::path::Path, version: u64) {
    let mut bytes = std::fs::read(path).expect("read");
    let (records, _) = robosim_instance_space::journal::scan_records(&bytes, 8);
    let r = records
        .iter()
        .find(|r| r.version == version)
        .expect("record");
    bytes[r.offset + 16 + r.len / 2] ^= 0x04;
    std::fs::write(path, &bytes).expect("write");
}

/// Issue #20 item 9 (`journal_mirror_repairs_a_flipped_record`): with two copies, a record
/// damaged in the journal is read from the mirror and repaired on disk; nothing is lost and
/// every later record is replayed. Damage in the mirror alone costs nothing either.
#[test]
fn journal_mirror_repairs_a_flipped_record_and_nothing_is_lost() {
    use robosim_instance_space::journal::recover_copies;
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover_copies(dir.path(), 2).expect("fresh");
    assert_eq!(journal.copies(), 2);
    for k in 0..50 {
        commit(&mut model, &mut journal, &format!("s{k}"));
    }
    drop(journal);
    let path = journal_file(dir.path());
    let mirror = path.with_extension("mirror");
    assert_eq!(
        std::fs::read(&path).expect("journal"),
        std::fs::read(&mirror).expect("mirror"),
        "the mirror holds the same bytes"
    );
    flip(&path, 20);
    flip(&mirror, 35);
    let (model2, mut journal2, report) = recover_copies(dir.path(), 2).expect("recovered");
    assert_eq!(model2.version, 50, "{:?}", report.problems);
    assert!(report.lost.is_empty(), "{:?}", report.lost);
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.contains("checksum mismatch") && p.contains("version 20 was repaired")),
        "{:?}",
        report.problems
    );
    // Repaired on disk, and the mirror was rewritten from the journal.
    let (records, damaged) =
        robosim_instance_space::journal::scan_records(&std::fs::read(&path).expect("j"), 8);
    assert_eq!((records.len(), damaged), (50, 0));
    assert_eq!(std::fs::read(&path).ok(), std::fs::read(&mirror).ok());
    let mut m = model2;
    commit(&mut m, &mut journal2, "after");
    drop(journal2);
    let (model3, _, report3) = recover_copies(dir.path(), 2).expect("again");
    assert_eq!(model3.version, 51);
    assert!(report3.problems.is_empty(), "{:?}", report3.problems);
}

/// Issue #20 item 9: the same record damaged in both copies is a loss. The cut is kept as a
/// journal of its own under `lost/`, the report counts the readable records it holds (the
/// acknowledged transactions that were not replayed) and says so in its message.
#[test]
fn a_record_damaged_in_both_copies_is_a_loss_reported_with_its_kept_copy() {
    use robosim_instance_space::journal::recover_copies;
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover_copies(dir.path(), 2).expect("fresh");
    for k in 0..50 {
        commit(&mut model, &mut journal, &format!("s{k}"));
    }
    drop(journal);
    let path = journal_file(dir.path());
    flip(&path, 20);
    flip(&path.with_extension("mirror"), 20);
    let (model2, _, report) = recover_copies(dir.path(), 2).expect("recovered");
    assert_eq!(model2.version, 19);
    assert_eq!(report.lost.len(), 1, "{:?}", report.lost);
    let l = &report.lost[0];
    assert_eq!(
        (l.first_version, l.last_version, l.readable_records),
        (20, Some(50), 30)
    );
    assert!(l.damaged_bytes > 0);
    assert!(l.copy.starts_with(dir.path().join("lost")));
    let msg = report.lost_message();
    assert!(
        msg.contains("versions 20..=50 not replayed: 30 readable record(s)")
            && msg.contains(&l.copy.display().to_string()),
        "{msg}"
    );
    // The kept copy reads as a journal: the 30 records after the damaged one.
    let mut listing = Vec::new();
    robosim_instance_space::journal::inspect(&l.copy, &mut listing).expect("inspect");
    let listing = String::from_utf8(listing).expect("utf-8");
    assert!(listing.contains("30 readable record(s)"), "{listing}");
    assert!(
        listing.contains("version 21 (") && listing.contains("create Scene \"s49\""),
        "{listing}"
    );
}

/// A torn last record with nothing readable after it was never acknowledged: it is cut and
/// reported as a problem, but it is not a loss and no copy is kept.
#[test]
fn a_torn_last_record_is_not_a_loss() {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover(dir.path()).expect("fresh");
    for k in 0..3 {
        commit(&mut model, &mut journal, &format!("s{k}"));
    }
    drop(journal);
    let path = journal_file(dir.path());
    let len = std::fs::metadata(&path).expect("meta").len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&path)
        .expect("open")
        .set_len(len - 3)
        .expect("tear");
    let (model2, _, report) = recover(dir.path()).expect("recovered");
    assert_eq!(model2.version, 2);
    assert!(report.lost.is_empty(), "{:?}", report.lost);
    assert!(
        !dir.path().join("lost").exists()
            || std::fs::read_dir(dir.path().join("lost"))
                .expect("dir")
                .next()
                .is_none()
    );
}

/// The selection is part of what recovery restores: from a checkpoint (written after the
/// objects) and from the journal records after it.
#[test]
fn the_selection_survives_a_checkpoint_and_the_journal_after_it() {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover(dir.path()).expect("fresh");
    commit(&mut model, &mut journal, "a");
    commit(&mut model, &mut journal, "b");
    let (a, b) = (1, 2);
    let mut tx = Transaction::new();
    tx.select(Some(a.into()), None);
    let v = model.apply(&tx).expect("select").version;
    journal.append(v, &tx.encode()).expect("append");
    journal.checkpoint(&model).expect("checkpoint");
    drop(journal);
    let (mut model, mut journal, _) = recover(dir.path()).expect("recover from the checkpoint");
    assert_eq!(model.selection().map(|s| s.object), Some(a));
    assert_eq!(model.version, v);
    let mut tx = Transaction::new();
    tx.select(Some(b.into()), None);
    let v = model.apply(&tx).expect("select b").version;
    journal.append(v, &tx.encode()).expect("append");
    journal.sync().expect("sync");
    drop(journal);
    let (m3, _, _) = recover(dir.path()).expect("recover");
    assert_eq!(m3.selection().map(|s| s.object), Some(b));
    assert_eq!(m3.version, model.version);
}

// ---------------------------------------------------------------------------------------------
// Issue 34 item 1: recovery takes the longest valid prefix over both copies of the journal.

use robosim_instance_space::journal::{
    CONTROL_FILE, JournalError, RecoveryReport, encode_store, recover_copies, scan_records,
};
use std::path::{Path, PathBuf};

/// A small two-copy journal after a checkpoint, as the keeper leaves it: the files' bytes and
/// the model at every version.
struct Fixture {
    /// (file name, bytes) of everything in the data directory.
    files: Vec<(String, Vec<u8>)>,
    log: String,
    mirror: String,
    /// Each record of the journal: (offset, version, total length).
    records: Vec<(usize, u64, usize)>,
    /// `encode_store` of the model at each version, from the checkpoint's on.
    models: std::collections::BTreeMap<u64, Vec<u8>>,
    checkpoint: u64,
    last: u64,
}

fn fixture() -> Fixture {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover_copies(dir.path(), 2).expect("fresh");
    commit(&mut model, &mut journal, "base");
    commit(&mut model, &mut journal, "b2");
    journal.checkpoint(&model).expect("checkpoint");
    let checkpoint = model.version;
    let mut models = std::collections::BTreeMap::new();
    models.insert(model.version, encode_store(&model));
    // Three records of different kinds and sizes after the checkpoint.
    commit(&mut model, &mut journal, "scene-three");
    models.insert(model.version, encode_store(&model));
    let mut tx = Transaction::new();
    tx.set_name(1, "renamed");
    let v = model.apply(&tx).expect("rename").version;
    journal.append(v, &tx.encode()).expect("append");
    journal.sync().expect("sync");
    models.insert(model.version, encode_store(&model));
    commit(&mut model, &mut journal, "s5");
    models.insert(model.version, encode_store(&model));
    drop(journal);
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir.path())
        .expect("dir")
        .flatten()
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).expect("read"),
            )
        })
        .collect();
    files.sort();
    let log = files
        .iter()
        .find(|f| f.0.ends_with(".log"))
        .expect("log")
        .0
        .clone();
    let mirror = log.replace(".log", ".mirror");
    let bytes = &files.iter().find(|f| f.0 == log).expect("log").1;
    assert_eq!(
        Some(bytes),
        files.iter().find(|f| f.0 == mirror).map(|f| &f.1),
        "two identical copies"
    );
    let (recs, damaged) = scan_records(bytes, 8);
    assert_eq!(damaged, 0);
    Fixture {
        records: recs
            .iter()
            .map(|r| (r.offset, r.version, 16 + r.len))
            .collect(),
        files,
        log,
        mirror,
        models,
        checkpoint,
        last: model.version,
    }
}

#[derive(Debug, Clone, Copy)]
enum Fault {
    Truncate(usize),
    Xor(usize, u8),
    Delete,
}

fn apply_fault(bytes: &[u8], f: Fault) -> Option<Vec<u8>> {
    match f {
        Fault::Truncate(n) => Some(bytes[..n].to_vec()),
        Fault::Xor(at, x) => {
            let mut b = bytes.to_vec();
            b[at] ^= x;
            Some(b)
        }
        Fault::Delete => None,
    }
}

/// Every version whose record is in `copy` at its place, intact.
fn intact(fx: &Fixture, copy: Option<&[u8]>, original: &[u8]) -> Vec<u64> {
    fx.records
        .iter()
        .filter(|&&(off, _, len)| {
            copy.and_then(|c| c.get(off..off + len)) == Some(&original[off..off + len])
        })
        .map(|r| r.1)
        .collect()
}

/// The readable versions of every file recovery kept under `lost/`.
fn kept_versions(dir: &Path) -> std::collections::BTreeSet<u64> {
    std::fs::read_dir(dir.join("lost"))
        .into_iter()
        .flatten()
        .flatten()
        .flat_map(|e| {
            let b = std::fs::read(e.path()).expect("kept file");
            let (r, _) = scan_records(&b, 8.min(b.len()));
            r.into_iter().map(|r| r.version).collect::<Vec<_>>()
        })
        .collect()
}

/// Runs one recovery of the fixture with `faults` applied to (log, mirror) and checks the
/// journal's promise. Returns a description of the outcome for the tally.
fn check_case(base: &Path, k: usize, fx: &Fixture, faults: [Option<Fault>; 2]) -> &'static str {
    let dir = base.join(format!("case{k}"));
    std::fs::create_dir(&dir).expect("case dir");
    let orig = &fx.files.iter().find(|f| f.0 == fx.log).expect("log").1;
    let mut copies: [Option<Vec<u8>>; 2] = [Some(orig.clone()), Some(orig.clone())];
    for (name, bytes) in &fx.files {
        let which = [&fx.log, &fx.mirror].iter().position(|n| *n == name);
        let b = match which {
            Some(i) => match faults[i] {
                Some(f) => apply_fault(bytes, f),
                None => Some(bytes.clone()),
            },
            None => Some(bytes.clone()),
        };
        if let Some(i) = which {
            copies[i] = b.clone();
        }
        if let Some(b) = b {
            std::fs::write(dir.join(name), b).expect("write");
        }
    }
    let what = format!("faults {faults:?}");
    let before = snapshot(&dir);
    let one_copy = faults.iter().filter(|f| f.is_some()).count() == 1;
    let available: std::collections::BTreeSet<u64> = intact(fx, copies[0].as_deref(), orig)
        .into_iter()
        .chain(intact(fx, copies[1].as_deref(), orig))
        .collect();
    // The longest prefix of records intact in one copy or the other.
    let mut prefix = fx.checkpoint;
    while available.contains(&(prefix + 1)) {
        prefix += 1;
    }
    let outcome = match recover_copies(&dir, 2) {
        Err(e) => {
            // Refusing is allowed only for damage to both copies' headers, or both copies gone,
            // and then nothing may have changed.
            let headers_both = faults
                .iter()
                .all(|f| matches!(f, Some(Fault::Xor(at, _)) if *at < 8));
            let both_gone = faults.iter().all(|f| matches!(f, Some(Fault::Delete)));
            assert!(
                (headers_both && matches!(e, JournalError::Headers { .. }))
                    || (both_gone && matches!(e, JournalError::Missing { .. })),
                "{what}: refused: {e}"
            );
            let msg = e.to_string();
            assert!(msg.contains(&fx.log), "{what}: {msg}");
            assert_eq!(snapshot(&dir), before, "{what}: a refusal changes nothing");
            "refused, nothing changed"
        }
        Ok((model, journal, report)) => {
            drop(journal);
            let v = model.version;
            assert_eq!(
                Some(&encode_store(&model)),
                fx.models.get(&v),
                "{what}: the model at version {v} is not the one acknowledged at {v}: {:?}",
                report.problems
            );
            assert!(
                v >= prefix,
                "{what}: recovered {v}, but versions up to {prefix} were intact in a copy: {:?}",
                report.problems
            );
            if one_copy {
                assert_eq!(
                    v, fx.last,
                    "{what}: one damaged copy loses nothing: {:?}",
                    report.problems
                );
            }
            if v == fx.last {
                assert!(report.lost.is_empty(), "{what}: {:?}", report.lost);
            } else {
                check_loss(fx, &dir, &what, &report, v, &available, &copies, orig);
            }
            // Every fault shows (a whole-record truncation of both copies aside: nothing on
            // disk tells it from a crash before those records were written).
            let invisible = faults.iter().all(|f| match f {
                Some(Fault::Truncate(n)) => {
                    *n == fx
                        .records
                        .iter()
                        .map(|r| r.0)
                        .find(|&o| o >= *n)
                        .unwrap_or(orig.len())
                }
                _ => false,
            });
            assert!(
                invisible || !report.problems.is_empty(),
                "{what}: a fault no one was told about (recovered {v})"
            );
            // The copies now agree and hold exactly what was recovered; a second recovery
            // finds nothing to say.
            let log = std::fs::read(dir.join(&fx.log)).expect("log after");
            assert_eq!(
                std::fs::read(dir.join(&fx.mirror)).ok().as_ref(),
                Some(&log),
                "{what}"
            );
            let (recs, damaged) = scan_records(&log, 8);
            assert_eq!(damaged, 0, "{what}");
            assert_eq!(
                recs.last().map_or(fx.checkpoint, |r| r.version),
                v,
                "{what}"
            );
            let (m2, j2, r2) = recover_copies(&dir, 2).expect("second recovery");
            drop(j2);
            assert_eq!(m2.version, v, "{what}");
            assert!(
                r2.problems.is_empty() && r2.lost.is_empty(),
                "{what}: second recovery: {:?}",
                r2.problems
            );
            if v == fx.last {
                "every record recovered"
            } else if report.lost.is_empty() {
                "torn tail of both copies cut"
            } else {
                "loss reported exactly"
            }
        }
    };
    std::fs::remove_dir_all(&dir).expect("remove case");
    outcome
}

#[allow(clippy::too_many_arguments)]
fn check_loss(
    fx: &Fixture,
    dir: &Path,
    what: &str,
    report: &RecoveryReport,
    v: u64,
    available: &std::collections::BTreeSet<u64>,
    copies: &[Option<Vec<u8>>; 2],
    orig: &[u8],
) {
    let rest: Vec<u64> = available.range(v + 1..).copied().collect();
    // The first record not recovered: altered in a copy that still holds its bytes, or gone.
    let (off, _, len) = *fx
        .records
        .iter()
        .find(|r| r.1 == v + 1)
        .expect("a record after the recovered version");
    let altered = copies.iter().flatten().any(|c| {
        c.get(off..off + len)
            .is_some_and(|b| b != &orig[off..off + len])
    });
    if rest.is_empty() && !altered {
        // Torn in both copies (truncated): a crash while writing looks the same.
        assert!(report.lost.is_empty(), "{what}: {:?}", report.lost);
        if copies.iter().flatten().any(|c| c.len() > off) {
            assert!(
                report.problems.iter().any(|p| p.contains("torn record")),
                "{what}: {:?}",
                report.problems
            );
        }
        return;
    }
    assert_eq!(report.lost.len(), 1, "{what}: {:?}", report.problems);
    let l = &report.lost[0];
    assert_eq!(l.first_version, v + 1, "{what}: {l:?}");
    assert_eq!(l.readable_records, rest.len() as u64, "{what}: {l:?}");
    assert_eq!(l.last_version, rest.last().copied(), "{what}: {l:?}");
    let msg = report.lost_message();
    assert!(
        msg.contains(&format!("recovered only up to version {v}")),
        "{what}: {msg}"
    );
    let kept = kept_versions(dir);
    for r in &rest {
        assert!(
            kept.contains(r),
            "{what}: version {r} deleted, kept: {kept:?}"
        );
    }
}

/// (name, length, bytes) of every file under `dir`.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("dir").flatten() {
            if e.path().is_dir() {
                stack.push(e.path());
            } else {
                out.push((e.path(), std::fs::read(e.path()).expect("read")));
            }
        }
    }
    out.sort();
    out
}

/// A scratch directory on tmpfs when there is one: every case syncs its files.
fn scratch() -> tempfile::TempDir {
    let shm = Path::new("/dev/shm");
    if shm.is_dir()
        && let Ok(d) = tempfile::Builder::new()
            .prefix("robosim-journal-test")
            .tempdir_in(shm)
    {
        return d;
    }
    tempfile::tempdir().expect("temp")
}

/// Issue 34 item 1, shown exhaustively as SQLite tests its journal: a two-copy journal of
/// three records after a checkpoint; every truncation offset of the log, of the mirror and of
/// both; every single-byte corruption (each bit flipped, and all eight) of each copy and of both at the same
/// offset; each copy deleted, and both. Each recovery either has every acknowledged record
/// back, or reports the exact loss (first lost version, the readable records after it, all
/// kept under `lost/`), or — both copies' headers damaged, both copies gone — refuses and
/// changes nothing. A truncation of both copies inside a record is reported as a torn record;
/// one at a record boundary cannot be told from a crash before the records were written
/// (docs/instance-space.md, "Journal").
#[test]
fn journal_recovery_takes_the_longest_valid_prefix_over_both_copies_exhaustively() {
    let started = std::time::Instant::now();
    let fx = fixture();
    let len = fx
        .files
        .iter()
        .find(|f| f.0 == fx.log)
        .expect("log")
        .1
        .len();
    let base = scratch();
    let mut cases: Vec<[Option<Fault>; 2]> = Vec::new();
    for n in 0..len {
        let t = Some(Fault::Truncate(n));
        cases.extend([[t, None], [None, t], [t, t]]);
    }
    for at in 0..len {
        for x in [0xFF, 0x01, 0x02, 0x04, 0x08, 0x10, 0x20, 0x40, 0x80] {
            let c = Some(Fault::Xor(at, x));
            cases.extend([[c, None], [None, c], [c, c]]);
        }
    }
    let d = Some(Fault::Delete);
    cases.extend([[d, None], [None, d], [d, d]]);
    // Mixed double faults: the log cut short and the mirror damaged, and the other way round.
    for &(off, _, rlen) in &fx.records {
        let mid = off + rlen / 2;
        cases.push([Some(Fault::Truncate(off)), Some(Fault::Xor(mid, 0x10))]);
        cases.push([Some(Fault::Xor(mid, 0x10)), Some(Fault::Truncate(off))]);
    }
    let mut tally: std::collections::BTreeMap<&str, usize> = Default::default();
    for (k, faults) in cases.iter().enumerate() {
        *tally
            .entry(check_case(base.path(), k, &fx, *faults))
            .or_default() += 1;
    }
    eprintln!(
        "{} recoveries of a {len}-byte journal ({} records after checkpoint {}) in {:?}: {tally:?}",
        cases.len(),
        fx.records.len(),
        fx.checkpoint,
        started.elapsed()
    );
    assert!(
        tally
            .get("every record recovered")
            .is_some_and(|&n| n > cases.len() / 2)
    );
    assert!(tally.contains_key("loss reported exactly"));
}

/// A journal of `n` scene records in two copies; the path of its log.
fn two_copy_journal(dir: &Path, n: usize) -> (Store, PathBuf) {
    let (mut model, mut journal, _) = recover_copies(dir, 2).expect("fresh");
    for k in 0..n {
        commit(&mut model, &mut journal, &format!("s{k}"));
    }
    drop(journal);
    (model, journal_file(dir))
}

/// Issue 34 item 1 (the reported case): the log cut to half after a crash, the mirror intact.
/// Recovery had taken the log's 57 records of 201 and said nothing, and the checkpoint at the
/// next stop deleted the mirror. Now every record comes back from the mirror, the repair is
/// reported, and a checkpoint after it (what `down` writes) holds all 201.
#[test]
fn journal_recovery_keeps_records_only_the_mirror_holds() {
    let dir = tempfile::tempdir().expect("temp");
    let (want, log) = two_copy_journal(dir.path(), 201);
    let len = std::fs::metadata(&log).expect("log").len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&log)
        .expect("open")
        .set_len(len / 2)
        .expect("cut");
    let (model, mut journal, report) = recover_copies(dir.path(), 2).expect("recovered");
    assert_eq!(model.version, 201, "{:?}", report.problems);
    assert_eq!(encode_store(&model), encode_store(&want));
    assert!(report.lost.is_empty(), "{:?}", report.lost);
    assert!(
        report.problems.iter().any(|p| p.contains(".log: ")
            && p.contains("were repaired from the mirror")
            && p.contains("..=201)")),
        "the disagreement is reported: {:?}",
        report.problems
    );
    assert_eq!(
        std::fs::read(&log).ok(),
        std::fs::read(log.with_extension("mirror")).ok(),
        "the log is repaired"
    );
    // The stop's checkpoint, then a restart: nothing lost.
    journal.checkpoint(&model).expect("checkpoint");
    drop(journal);
    let (again, _, r2) = recover_copies(dir.path(), 2).expect("again");
    assert_eq!((again.version, r2.checkpoint_version), (201, 201));
}

/// Issue 34 item 1: a log one record shorter than its mirror (the replay stopped at the
/// log's end and never looked at the mirror's last record).
#[test]
fn a_log_one_record_shorter_than_the_mirror_loses_nothing() {
    let dir = tempfile::tempdir().expect("temp");
    let (want, log) = two_copy_journal(dir.path(), 20);
    let bytes = std::fs::read(&log).expect("log");
    let (recs, _) = scan_records(&bytes, 8);
    let last = recs.last().expect("records");
    std::fs::write(&log, &bytes[..last.offset]).expect("cut one record");
    let (model, _, report) = recover_copies(dir.path(), 2).expect("recovered");
    assert_eq!(model.version, 20);
    assert_eq!(encode_store(&model), encode_store(&want));
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.contains("the record of version 20 was repaired from the mirror")),
        "{:?}",
        report.problems
    );
}

/// Issue 34 item 1: a log replaced by garbage (same length, and longer) while the mirror is
/// intact was refused ("bad magic"); it is repaired from the mirror. Garbage past the
/// mirror's end is kept under `lost/` and named (it holds no readable record).
#[test]
fn a_log_replaced_by_garbage_is_repaired_from_the_mirror() {
    for extra in [0usize, 100] {
        let dir = tempfile::tempdir().expect("temp");
        let (want, log) = two_copy_journal(dir.path(), 10);
        let len = std::fs::metadata(&log).expect("log").len() as usize + extra;
        let garbage: Vec<u8> = (0..len).map(|i| (i * 7 + 13) as u8).collect();
        std::fs::write(&log, &garbage).expect("garbage");
        let (model, _, report) = recover_copies(dir.path(), 2).expect("repaired, not refused");
        assert_eq!(model.version, 10, "{:?}", report.problems);
        assert_eq!(encode_store(&model), encode_store(&want));
        assert!(
            report.problems.iter().any(|p| p.contains("damaged header")
                && p.contains("10 records (versions 1..=10) were repaired from the mirror")),
            "{:?}",
            report.problems
        );
        assert_eq!(
            std::fs::read(&log).ok(),
            std::fs::read(log.with_extension("mirror")).ok()
        );
        if extra > 0 {
            // The log's bytes past the mirror's end hold no readable record: like a record
            // torn by a crash, they are dropped, and said so.
            assert!(
                report
                    .problems
                    .iter()
                    .any(|p| p.contains("mirror: ends at byte")
                        && p.contains(&format!("dropped the tail ({extra} bytes)"))),
                "{:?}",
                report.problems
            );
            assert!(report.lost.is_empty(), "{:?}", report.lost);
        }
    }
}

/// Issue 34 item 1: both journal files deleted (the checkpoint, the scene note kept) restarted
/// silently at version 1. The control file names the journal and its first version, so
/// recovery refuses — naming the files and versions — and changes nothing; so it does when
/// the checkpoint the journal follows is gone, or the control file itself is damaged. Moving
/// the control file aside accepts the loss.
#[test]
fn a_vanished_journal_is_refused_naming_the_files_and_versions() {
    let dir = tempfile::tempdir().expect("temp");
    let (mut model, mut journal, _) = recover_copies(dir.path(), 2).expect("fresh");
    for k in 0..5 {
        commit(&mut model, &mut journal, &format!("a{k}"));
    }
    journal.checkpoint(&model).expect("checkpoint at 5");
    for k in 0..3 {
        commit(&mut model, &mut journal, &format!("b{k}"));
    }
    drop(journal);
    let log = journal_file(dir.path());
    assert!(log.ends_with("journal-00000000000000000006.log"));
    let control = std::fs::read_to_string(dir.path().join(CONTROL_FILE)).expect("control");
    assert!(
        control.contains("journal-00000000000000000006.log"),
        "{control}"
    );

    // Both copies gone.
    let keep = tempfile::tempdir().expect("keep");
    for p in [log.clone(), log.with_extension("mirror")] {
        std::fs::rename(&p, keep.path().join(p.file_name().expect("name"))).expect("move");
    }
    let before = snapshot(dir.path());
    let e = match recover_copies(dir.path(), 2) {
        Err(e) => e,
        Ok((m, ..)) => panic!("recovered to version {} without the journal", m.version),
    };
    let msg = e.to_string();
    assert!(matches!(e, JournalError::Missing { .. }), "{msg}");
    for want in [
        "journal-00000000000000000006.log is missing",
        "journal-00000000000000000006.mirror",
        "from version 6 on",
        "acknowledged since version 5 would be lost",
        "up to version 5",
        CONTROL_FILE,
    ] {
        assert!(msg.contains(want), "{want:?} in: {msg}");
    }
    assert_eq!(snapshot(dir.path()), before, "nothing changed");

    // The checkpoint gone (journal back).
    for p in [log.clone(), log.with_extension("mirror")] {
        std::fs::rename(keep.path().join(p.file_name().expect("name")), &p).expect("back");
    }
    let ck = dir.path().join("checkpoint-00000000000000000005.bin");
    std::fs::rename(&ck, keep.path().join("ck")).expect("move checkpoint");
    let e = recover_copies(dir.path(), 2).err().expect("refused");
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            JournalError::Behind {
                needed: 5,
                found: 0,
                ..
            }
        ) && msg.contains("checkpoint-00000000000000000005.bin"),
        "{msg}"
    );
    std::fs::rename(keep.path().join("ck"), &ck).expect("checkpoint back");

    // A damaged control file.
    std::fs::write(
        dir.path().join(CONTROL_FILE),
        b"robosim journal control 1\njournal x\n",
    )
    .expect("damage");
    let e = recover_copies(dir.path(), 2).err().expect("refused");
    assert!(matches!(e, JournalError::Control { .. }), "{e}");
    std::fs::remove_file(dir.path().join(CONTROL_FILE)).expect("move aside");

    // Without it (what an older robosim left, or a loss accepted), recovery goes on.
    let (m, _, r) = recover_copies(dir.path(), 2).expect("recovered");
    assert_eq!(m.version, 8, "{:?}", r.problems);
    assert!(
        dir.path().join(CONTROL_FILE).exists(),
        "and writes a control file"
    );
}

/// Issue 35 item 4: a model encoding whose body does not decode is refused with bincode's own
/// error kept as the source (not flattened into text), under the same message as before.
#[test]
fn a_body_that_does_not_decode_keeps_the_decoders_error_as_its_source() {
    use robosim_instance_space::journal::{
        Corruption, StoreDecodeError, decode_store, encode_store,
    };
    use std::error::Error as _;
    let mut model = Store::new();
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "s", None);
    model.apply(&tx).expect("valid");
    let good = encode_store(&model);
    // the magic, then the body cut to one byte under a checksum that matches it
    let body = &good[12..13];
    let mut bytes = good[..8].to_vec();
    bytes.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
    bytes.extend_from_slice(body);
    let e = decode_store(&bytes).err().expect("refused");
    let text = e.to_string();
    assert!(text.starts_with("model encoding is corrupt: "), "{text}");
    let StoreDecodeError::Corrupt(inner) = &e else {
        panic!("not Corrupt: {e:?}");
    };
    assert!(matches!(inner, Corruption::Decode(_)), "{inner:?}");
    let cause = e
        .source()
        .and_then(|c| c.source())
        .expect("the decoder's error as the source of the corruption");
    assert!(
        cause
            .downcast_ref::<bincode::error::DecodeError>()
            .is_some(),
        "{cause:?}"
    );
    // a wrong checksum is its own variant, same text as ever
    let mut flipped = good.clone();
    flipped[8] ^= 1;
    let e = decode_store(&flipped).err().expect("refused");
    assert!(
        matches!(e, StoreDecodeError::Corrupt(Corruption::Checksum)),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "model encoding is corrupt: checksum mismatch"
    );
}
