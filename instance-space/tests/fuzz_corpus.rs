//! The `journal` fuzz target's body (`fuzz/src/journal.rs`) over every file of its corpus
//! (`fuzz/seeds/journal/`: real journals and checkpoints, and each input the fuzzer once
//! crashed on), on stable, so `cargo test` re-checks them without nightly. See
//! `docs/fuzzing.md`.
//!
//! `regenerate_journal_seeds` (ignored) rewrites the seeds with this crate's journal code.

#[path = "../../fuzz/src/journal.rs"]
mod body;
#[path = "../../fuzz/src/replay.rs"]
mod replay;

use robosim_instance_space::journal::Journal;
use robosim_instance_space::{Appearance, Kind, MassProps, Store, Transaction};
use std::path::Path;

#[test]
fn journal_fuzz_corpus_replays() {
    replay::replay(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz"),
        "journal",
        body::run,
    );
}

/// Four transactions as a keeper commits them: create a scene, a solid with a pose, a mass
/// and a cube's geometry, a robot with a link; move the solid and the joint; add, rename and
/// attach a marker; delete it.
fn transactions() -> Vec<Transaction> {
    let mut a = Transaction::new();
    let scene = a.create(Kind::Scene, "cell", None);
    let solid = a.create(Kind::Solid, "crate", Some(scene));
    a.set_pose(
        solid,
        [1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, -0.2, 0.0, 0.0, 1.0, 0.1],
    );
    a.set_appearance(
        solid,
        Appearance {
            color: [0.8, 0.2, 0.1, 1.0],
            diffuse: 0.7,
            specular: 0.2,
            shininess: 16.0,
        },
    );
    a.set_dynamics(
        solid,
        Some(MassProps {
            mass: 2.0,
            com: [0.0, 0.0, 0.05],
            inertia: [0.01, 0.01, 0.01, 0.0, 0.0, 0.0],
        }),
    );
    let robot = a.create(Kind::Robot, "arm", Some(scene));
    let _link = a.create(Kind::Link, "upper", Some(robot));
    let cube = robosim_geometry::shapes::cuboid(0.1, 0.1, 0.1).expect("a cube");
    a.set_geometry(
        solid,
        Some(robosim_instance_space::GeometryInput::from_polyhedron(
            &cube,
        )),
    );
    let mut b = Transaction::new();
    b.set_pose(
        2u64,
        [1.0, 0.0, 0.0, 0.6, 0.0, 1.0, 0.0, -0.2, 0.0, 0.0, 1.0, 0.1],
    );
    b.set_joint(4u64, 0.25);
    let mut c = Transaction::new();
    let extra = c.create(Kind::Item, "marker", None);
    c.set_name(extra, "marker-1").attach(extra, 1u64);
    let mut d = Transaction::new();
    d.delete(5u64, false)
        .set_origin(2u64, "{\"decl\":\"crate\"}");
    vec![a, b, c, d]
}

#[test]
#[ignore = "writes fuzz/seeds/journal/; run by hand when the journal format changes"]
fn regenerate_journal_seeds() {
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/journal");
    std::fs::create_dir_all(&out).expect("seeds dir");
    let txs = transactions();
    // a journal of four records, no checkpoint
    let dir = tempfile::tempdir().expect("tempdir");
    let mut j = Journal::create(dir.path(), 1).expect("journal");
    let mut store = Store::new();
    for (k, tx) in txs.iter().enumerate() {
        store.apply(tx).unwrap_or_else(|e| panic!("tx {k}: {e}"));
        j.append(store.version, &tx.encode()).expect("append");
    }
    j.sync().expect("sync");
    let journal = std::fs::read(dir.path().join("journal-00000000000000000001.log")).expect("read");
    std::fs::write(
        out.join("journal-4-records"),
        body::pack(None, &journal, false),
    )
    .expect("write");
    // the same, torn in the middle of the last record
    let torn = &journal[..journal.len() - 7];
    std::fs::write(out.join("journal-torn-tail"), body::pack(None, torn, false)).expect("write");
    // a checkpoint after two records, then a journal of the other two
    let dir = tempfile::tempdir().expect("tempdir");
    let mut j = Journal::create(dir.path(), 1).expect("journal");
    let mut store = Store::new();
    for (k, tx) in txs.iter().enumerate() {
        store.apply(tx).unwrap_or_else(|e| panic!("tx {k}: {e}"));
        j.append(store.version, &tx.encode()).expect("append");
        if k == 1 {
            j.checkpoint(&store).expect("checkpoint");
        }
    }
    j.sync().expect("sync");
    let ck = std::fs::read(dir.path().join("checkpoint-00000000000000000002.bin")).expect("read");
    let journal = std::fs::read(dir.path().join("journal-00000000000000000003.log")).expect("read");
    std::fs::write(
        out.join("checkpoint-and-journal"),
        body::pack(Some(&ck), &journal, false),
    )
    .expect("write");
    // the same with checksums to be fixed by the harness (what mutations start from)
    std::fs::write(
        out.join("checkpoint-and-journal-fixcrc"),
        body::pack(Some(&ck), &journal, true),
    )
    .expect("write");
}

#[test]
fn issue_20_checkpoint_claiming_a_huge_string_is_skipped_not_an_abort() {
    // Found by the `journal` fuzz target (out of memory): a checkpoint with a valid checksum
    // whose first object's name claims 2^62 bytes. bincode allocated the claimed size before
    // reading it; recovery now refuses the checkpoint (and starts from the journal alone).
    let mut body = vec![5, 1, 1]; // version 5, next id 1, one object
    body.extend_from_slice(&[1, 0, 0]); // id 1, kind (variant 0), parent 0
    body.push(253); // varint marker: a u64 follows
    body.extend_from_slice(&(1u64 << 62).to_le_bytes()); // name length
    body.extend_from_slice(b"crate");
    let mut ck = b"RSCKPT01".to_vec();
    ck.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    ck.extend_from_slice(&body);
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("checkpoint-00000000000000000005.bin"), &ck).expect("write");
    let (store, _journal, report) =
        robosim_instance_space::journal::recover(dir.path()).expect("recovery goes on");
    assert_eq!(store.version, 0);
    assert_eq!(report.problems.len(), 1, "{:?}", report.problems);
    assert!(
        report.problems[0].starts_with("skipped checkpoint: ")
            && report.problems[0].contains("checkpoint is corrupt"),
        "{:?}",
        report.problems
    );
}
