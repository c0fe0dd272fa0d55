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
