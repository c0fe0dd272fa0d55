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
