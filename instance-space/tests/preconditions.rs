//! Preconditions (`Op::Expect`, issue 34 item 3) are decided once, by the keeper that commits
//! the transaction: the journal holds it without them, so a keeper restarted from a checkpoint
//! — which takes every object as changed at the checkpoint's version — replays it instead of
//! refusing it (which would cut recovery at that record).

use robosim_instance_space::{
    IDENTITY, Keeper, KeeperOptions, Kind, Session, Transaction, TxError, aspect, remove_shm_files,
};

#[test]
fn a_committed_precondition_replays_after_a_checkpoint() {
    let home = tempfile::tempdir().expect("temp dir");
    let name = format!("pre{}", std::process::id());
    let session = Session::open_in(home.path(), Some(&name)).expect("session");
    let moved = |x: f64| {
        let mut p = IDENTITY;
        p[3] = x;
        p
    };
    let (a, last) = {
        let (mut k, _) = Keeper::start(&session, KeeperOptions::default()).expect("keeper");
        let mut tx = Transaction::new();
        tx.create(Kind::Item, "a", None);
        tx.create(Kind::Item, "b", None);
        let created = k.commit_local(&tx).expect("create").created;
        let (a, b) = (created[0], created[1]);
        let read = k.store().version;
        let mut tx = Transaction::new();
        tx.set_pose(b, moved(5.0));
        k.commit_local(&tx).expect("move b");
        k.checkpoint().expect("checkpoint");
        // Read before the checkpoint, `a` unchanged since: committed here.
        let mut tx = Transaction::new();
        tx.expect(a, aspect::POSE, read).set_pose(a, moved(1.0));
        k.commit_local(&tx).expect("a unchanged since the read");
        // And the same read again is now stale.
        let mut tx = Transaction::new();
        tx.expect(a, aspect::POSE, read).set_pose(a, moved(2.0));
        assert!(matches!(
            k.commit_local(&tx),
            Err(TxError::Conflict { id, .. }) if id == a
        ));
        (a, k.store().version)
    };
    let (k, report) = Keeper::start(&session, KeeperOptions::default()).expect("restart");
    assert!(report.problems.is_empty(), "{:?}", report.problems);
    assert_eq!(k.store().version, last, "every committed record replayed");
    assert_eq!(k.store().get(a).map(|o| o.pose[3]), Some(1.0));
    drop(k);
    remove_shm_files(&name);
}
