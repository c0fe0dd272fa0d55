//! Readers follow every valid transaction (issue 34 item 4): a keeper (in a thread of this
//! process, on its own session and home) commits creates and deletes across pose and object
//! chunk boundaries, and a live [`Reader`] that follows every version must hold, at each one,
//! what the keeper holds. Deleting the newest object (or undoing a create, which is that
//! delete) used to leave its pose chunk shorter than the chunk the keeper had published under
//! the same generation, and readers exited with "a published segment is malformed: section 1
//! is out of bounds".

use robosim_instance_space::journal::decode_store;
use robosim_instance_space::layout::{OBJECT_CHUNK, OBJECT_PATCH_MAX, POSE_CHUNK};
use robosim_instance_space::{
    Client, IDENTITY, Id, KeeperOptions, Kind, Reader, Snapshot, ThreadKeeper, Transaction,
};
use std::time::{Duration, Instant};

/// A keeper stepping in a thread of this process on session `t<tag><pid>` of its own
/// (stopped, its home and shared memory removed, when dropped).
fn thread_keeper(tag: &str) -> ThreadKeeper {
    iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
    let name = format!("t{tag}{}", std::process::id());
    ThreadKeeper::start(&name, KeeperOptions::default(), Duration::from_secs(30))
        .expect("the keeper started")
}

/// Asserts that the reader's snapshot is the keeper's model at the same version: every
/// object's record, name, pose and geometry size.
fn assert_same(got: &Snapshot, model: &robosim_instance_space::Store, what: &str) {
    let want = Snapshot::from_store(model);
    assert_eq!(got.version(), want.version(), "{what}: version");
    assert_eq!(got.len(), want.len(), "{what}: object count");
    assert_eq!(got.objects(), want.objects(), "{what}: object records");
    assert_eq!(got.poses(), want.poses(), "{what}: pose records");
    for i in 0..want.len() {
        assert_eq!(got.name(i), want.name(i), "{what}: name of object {i}");
        assert_eq!(got.pose(i), want.pose(i), "{what}: pose of object {i}");
        assert_eq!(
            got.geometry(i).map(|g| g.vertices.len()),
            want.geometry(i).map(|g| g.vertices.len()),
            "{what}: geometry of object {i}"
        );
    }
}

/// Commits `tx`, has `r` follow it (every version in turn: nothing else commits), and checks
/// that what `r` holds is what the keeper holds. Returns the ids created.
fn commit_and_follow(c: &mut Client, r: &mut Reader, tx: &Transaction, what: &str) -> Vec<Id> {
    let done = c
        .transact(tx)
        .unwrap_or_else(|e| panic!("{what}: commit: {e}"));
    let deadline = Instant::now() + Duration::from_secs(30);
    while r.snapshot().is_none_or(|s| s.version() < done.version) {
        r.wait_change(Duration::from_millis(200))
            .unwrap_or_else(|e| panic!("{what}: the reader stopped following: {e}"));
        assert!(
            Instant::now() < deadline,
            "{what}: the reader never saw version {}",
            done.version
        );
    }
    let snap = r.snapshot().expect("snapshot");
    assert_eq!(
        snap.version(),
        done.version,
        "{what}: followed every version"
    );
    let model = decode_store(&c.snapshot().expect("the keeper's model").model).expect("decode");
    assert_same(&snap, &model, what);
    assert_eq!(
        r.reattachments(),
        0,
        "{what}: the reader followed without having to reattach"
    );
    done.created
}

/// `n` solids under `parent`, each at its own place (so that every pose record differs).
fn solids(parent: Id, from: usize, n: usize) -> Transaction {
    let mut tx = Transaction::new();
    for k in from..from + n {
        let o = tx.create(Kind::Solid, &format!("body{k}"), Some(parent.into()));
        let mut pose = IDENTITY;
        pose[3] = k as f64;
        tx.set_pose(o, pose);
    }
    tx
}

#[test]
fn deleting_the_newest_object_keeps_readers_following() {
    let k = thread_keeper("newest");
    let mut c = Client::connect(k.session(), "writer").expect("connect");
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    let scene = c.transact(&tx).expect("scene").created[0];
    let mut r = Reader::attach(k.session(), "follower").expect("attach");
    assert_eq!(
        POSE_CHUNK, OBJECT_CHUNK,
        "one partition for poses and objects"
    );

    // One partly full chunk: the scene and three solids; the newest deleted.
    let mut ids = commit_and_follow(&mut c, &mut r, &solids(scene, 0, 3), "three solids");
    let mut tx = Transaction::new();
    tx.delete(ids[2], false);
    commit_and_follow(
        &mut c,
        &mut r,
        &tx,
        "delete the newest of a partly full chunk",
    );
    ids.pop();

    // Undoing a create: create, then delete what was created (the editor's undo).
    let made = commit_and_follow(&mut c, &mut r, &solids(scene, 3, 1), "create");
    let mut tx = Transaction::new();
    tx.delete(made[0], false);
    commit_and_follow(&mut c, &mut r, &tx, "undo of the create");

    // Two full chunks (the scene, two solids kept, and the rest up to 2 × chunk).
    let n = 1 + ids.len();
    let more = 2 * OBJECT_CHUNK - n;
    ids.extend(commit_and_follow(
        &mut c,
        &mut r,
        &solids(scene, 10, more),
        "fill two chunks",
    ));
    assert_eq!(r.snapshot().map(|s| s.len()), Some(2 * OBJECT_CHUNK));
    let mut tx = Transaction::new();
    tx.delete(ids.pop().expect("newest"), false);
    commit_and_follow(&mut c, &mut r, &tx, "delete the newest of a full chunk");

    // The newest alone in its chunk: 2 × chunk + 1 objects, then the newest deleted (the
    // chunk goes away).
    ids.extend(commit_and_follow(
        &mut c,
        &mut r,
        &solids(scene, 1_000, 2),
        "one past two chunks",
    ));
    assert_eq!(r.snapshot().map(|s| s.len()), Some(2 * OBJECT_CHUNK + 1));
    let mut tx = Transaction::new();
    tx.delete(ids.pop().expect("newest"), false);
    commit_and_follow(&mut c, &mut r, &tx, "delete the newest, alone in its chunk");

    // The newest two across a chunk boundary in one transaction, then undoing a create of a
    // chunk's worth.
    ids.extend(commit_and_follow(
        &mut c,
        &mut r,
        &solids(scene, 2_000, 1),
        "one past two chunks again",
    ));
    let mut tx = Transaction::new();
    tx.delete(ids.pop().expect("newest"), false);
    tx.delete(ids.pop().expect("second newest"), false);
    commit_and_follow(
        &mut c,
        &mut r,
        &tx,
        "delete the newest two across a boundary",
    );
    let made = commit_and_follow(
        &mut c,
        &mut r,
        &solids(scene, 3_000, OBJECT_CHUNK + 3),
        "create a chunk's worth",
    );
    let mut tx = Transaction::new();
    for &id in made.iter().rev() {
        tx.delete(id, false);
    }
    commit_and_follow(&mut c, &mut r, &tx, "undo of the chunk's worth");

    // Further edits after all that: a move of the last object, a rename, a create.
    let last = *ids.last().expect("last");
    let mut tx = Transaction::new();
    let mut pose = IDENTITY;
    pose[7] = 2.5;
    tx.set_pose(last, pose);
    commit_and_follow(&mut c, &mut r, &tx, "move the last object");
    let mut tx = Transaction::new();
    tx.set_name(last, "renamed");
    commit_and_follow(&mut c, &mut r, &tx, "rename the last object");
    commit_and_follow(&mut c, &mut r, &solids(scene, 4_000, 1), "create after");

    // A late joiner reads the same.
    let late = Reader::attach(k.session(), "late").expect("late joiner");
    let model = decode_store(&c.snapshot().expect("model").model).expect("decode");
    assert_same(&late.snapshot().expect("snapshot"), &model, "late joiner");
}

/// A follower views the object chunks an objects head carries in the head's sample instead of
/// copying them out (issue 37 item 6): snapshots held across structural changes — colours,
/// geometry, renames, in one chunk after another and in the same chunk again — must still read
/// their own versions when newer heads have come (an iceoryx2 sample is not reused while held),
/// and a reader holding as many older snapshots as it may (`MAX_HELD_SNAPSHOTS`, 4) must not
/// run out of the head subscription's borrowed samples: without the cap on the samples viewed
/// it does, with `TooManySnapshotsHeld`. The follower never asks for an objects base.
#[test]
fn snapshots_held_across_structural_changes_read_their_own_versions() {
    const OLDER: usize = 4;
    const CHUNKS: usize = 5;
    let k = thread_keeper("views");
    let mut c = Client::connect(k.session(), "writer").expect("connect");
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    let scene = c.transact(&tx).expect("scene").created[0];
    let mut r = Reader::attach(k.session(), "follower").expect("attach");
    let ids = commit_and_follow(
        &mut c,
        &mut r,
        &solids(scene, 0, CHUNKS * OBJECT_CHUNK - 1),
        "five chunks",
    );
    let asked = r.objects_bases_asked();
    let cube = |s: f64| {
        let p = robosim_geometry::shapes::cuboid(s, s, s).expect("a cube");
        robosim_instance_space::GeometryInput::from_polyhedron(&p)
    };
    // (snapshot, the keeper's model at its version)
    let mut held: std::collections::VecDeque<(std::rc::Rc<Snapshot>, Snapshot)> =
        Default::default();
    for step in 0..48 {
        // Chunks 0, 0, 1, 1, 2, 2, … : each chunk changed twice running, then left alone.
        let chunk = (step / 2) % CHUNKS;
        let id = ids[chunk * OBJECT_CHUNK + 7 + step % 3];
        let mut tx = Transaction::new();
        match step % 3 {
            0 => {
                let mut look = robosim_instance_space::Appearance::default();
                look.color = [step as f32 / 48.0, 0.5, 0.25, 1.0];
                tx.set_appearance(id, look);
            }
            1 => {
                tx.set_geometry(id, Some(cube(0.1 + step as f64 * 0.01)));
            }
            _ => {
                tx.set_name(id, &format!("renamed{step}"));
            }
        }
        let what = format!("step {step} (chunk {chunk})");
        commit_and_follow(&mut c, &mut r, &tx, &what);
        let model = decode_store(&c.snapshot().expect("model").model).expect("decode");
        held.push_back((
            r.snapshot().expect("snapshot"),
            Snapshot::from_store(&model),
        ));
        if held.len() > OLDER + 1 {
            held.pop_front();
        }
        for (got, want) in &held {
            let what = format!("{what}: the snapshot of version {}", want.version());
            assert_eq!(got.version(), want.version(), "{what}");
            assert_eq!(got.objects(), want.objects(), "{what}: object records");
            for i in 0..want.len() {
                assert_eq!(got.name(i), want.name(i), "{what}: name of object {i}");
                assert_eq!(
                    got.geometry(i).map(|g| g.vertices.to_vec()),
                    want.geometry(i).map(|g| g.vertices.to_vec()),
                    "{what}: geometry of object {i}"
                );
            }
        }
    }
    assert_eq!(
        r.objects_bases_asked(),
        asked,
        "following asked for the objects base"
    );
}

/// Every object's record, name and geometry (vertices) of `got` against `want`.
fn assert_same_geometry(got: &Snapshot, want: &Snapshot, what: &str) {
    assert_eq!(got.version(), want.version(), "{what}: version");
    assert_eq!(got.len(), want.len(), "{what}: object count");
    assert_eq!(got.objects(), want.objects(), "{what}: object records");
    for i in 0..want.len() {
        assert_eq!(got.name(i), want.name(i), "{what}: name of object {i}");
        assert_eq!(
            got.geometry(i)
                .map(|g| (g.vertices.to_vec(), g.indices.to_vec())),
            want.geometry(i)
                .map(|g| (g.vertices.to_vec(), g.indices.to_vec())),
            "{what}: geometry of object {i}"
        );
    }
}

/// A one-body geometry change patches the object's record in its cached chunk and the
/// follower takes the changed chunk from the objects head, keeping the rest (issue 37 item 6):
/// a record patched at the wrong index, a geometry table matched to the wrong record or a chunk
/// kept under a stale generation shows here. Random geometry edits (seeded, reproducible) —
/// new boxes of distinct sizes, geometry removed and given again, one to three objects per
/// transaction in different chunks, now and then a box created after the last — over a model
/// of four chunks where some objects have geometry and some not; at every version the
/// follower's snapshot must be the keeper's model (vertices compared), and every ten a reader
/// attached fresh (from the bases) must read what the follower reads. The follower never asks
/// for an objects base.
#[test]
fn random_geometry_edits_across_chunks_read_as_a_fresh_reader_does() {
    let k = thread_keeper("georand");
    let mut c = Client::connect(k.session(), "writer").expect("connect");
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    let scene = c.transact(&tx).expect("scene").created[0];
    let cube = |s: f64| {
        let p = robosim_geometry::shapes::cuboid(s, s * 1.5, s * 2.0).expect("a box");
        robosim_instance_space::GeometryInput::from_polyhedron(&p)
    };
    // A small linear congruential generator: the same edits on every run.
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = move |n: usize| {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((seed >> 33) as usize) % n
    };
    let n = 4 * OBJECT_CHUNK - 20;
    let mut tx = solids(scene, 0, n);
    let mut ids: Vec<Id> = Vec::new();
    let made = c.transact(&tx).expect("the solids").created;
    // Geometry on about two objects in three, in one transaction.
    tx = Transaction::new();
    for (j, &id) in made.iter().enumerate() {
        if next(3) != 0 {
            tx.set_geometry(id, Some(cube(0.01 + j as f64 * 1e-4)));
        }
    }
    c.transact(&tx).expect("the geometry");
    ids.extend(made);
    let mut r = Reader::attach(k.session(), "follower").expect("attach");
    let asked = r.objects_bases_asked();
    let mut size = 1.0;
    for step in 0..80 {
        let mut tx = Transaction::new();
        let mut touched = Vec::new();
        for _ in 0..1 + next(3) {
            let id = ids[next(ids.len())];
            if touched.contains(&id) {
                continue;
            }
            touched.push(id);
            size += 0.013;
            if next(4) == 0 {
                tx.set_geometry(id, None);
            } else {
                tx.set_geometry(id, Some(cube(size)));
            }
        }
        if step % 10 == 9 {
            let b = tx.create(Kind::Solid, &format!("added{step}"), Some(scene.into()));
            size += 0.013;
            tx.set_geometry(b, Some(cube(size)));
        }
        let what = format!("step {step}");
        let done = c
            .transact(&tx)
            .unwrap_or_else(|e| panic!("{what}: commit: {e}"));
        ids.extend(done.created.iter().copied());
        let deadline = Instant::now() + Duration::from_secs(30);
        while r.snapshot().is_none_or(|s| s.version() < done.version) {
            r.wait_change(Duration::from_millis(200))
                .unwrap_or_else(|e| panic!("{what}: the reader stopped following: {e}"));
            assert!(Instant::now() < deadline, "{what}: never followed");
        }
        let got = r.snapshot().expect("snapshot");
        let model = decode_store(&c.snapshot().expect("model").model).expect("decode");
        assert_same_geometry(&got, &Snapshot::from_store(&model), &what);
        if step % 10 == 9 {
            let fresh = Reader::attach(k.session(), &format!("fresh{step}")).expect("attach");
            let snap = fresh.snapshot().expect("the fresh reader's snapshot");
            assert_same_geometry(&got, &snap, &format!("{what}: the fresh reader"));
        }
    }
    assert_eq!(r.reattachments(), 0, "the follower never reattached");
    assert_eq!(
        r.objects_bases_asked(),
        asked,
        "following asked for the objects base"
    );
}

/// [`assert_same_geometry`], and every record read in place ([`Snapshot::rec`], where a
/// patched record is read through its chunk's patches) and found by id.
fn assert_same_records(got: &Snapshot, want: &Snapshot, what: &str) {
    assert_same_geometry(got, want, what);
    for i in 0..want.len() {
        let rec = want.rec(i);
        assert_eq!(got.rec(i), rec, "{what}: record of object {i}, in place");
        assert_eq!(got.index_of(rec.id), Some(i), "{what}: object {i} by id");
    }
}

/// A chunk whose records alone changed since an objects head last carried it whole goes as
/// those records, and readers put them on the chunk they hold (issue 37 item 6): a patch put
/// at the wrong index, on a chunk of another lineage, read through the wrong list, or a
/// geometry table kept for a patched record whose geometry changed shows here. Seeded random
/// edits over three chunks — colours (a patch whatever the object), geometry replaced (a
/// patch when the object had some), geometry removed or given to an object without (the chunk
/// goes whole), renames (whole), a box created now and then — then one chunk painted record by
/// record past [`OBJECT_PATCH_MAX`] (the keeper carries it whole again and a new lineage
/// starts). A follower compared with the keeper's model at every version (records in place
/// and as one array, names, ids, vertices), a lagging reader that takes several heads at once
/// (patches resolved on a whole chunk a head it did not assemble brought), snapshots held
/// across the edits still reading their own versions, and freshly attached readers.
#[test]
fn record_patches_read_as_the_model_and_a_fresh_reader_do() {
    let k = thread_keeper("patches");
    let mut c = Client::connect(k.session(), "writer").expect("connect");
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    let scene = c.transact(&tx).expect("scene").created[0];
    let cube = |s: f64| {
        let p = robosim_geometry::shapes::cuboid(s, s * 1.5, s * 2.0).expect("a box");
        robosim_instance_space::GeometryInput::from_polyhedron(&p)
    };
    let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move |n: usize| {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((seed >> 33) as usize) % n
    };
    let n = 3 * OBJECT_CHUNK - 10;
    let ids: Vec<Id> = c
        .transact(&solids(scene, 0, n))
        .expect("the solids")
        .created;
    let mut tx = Transaction::new();
    for (j, &id) in ids.iter().enumerate() {
        if next(3) != 0 {
            tx.set_geometry(id, Some(cube(0.01 + j as f64 * 1e-4)));
        }
    }
    c.transact(&tx).expect("the geometry");
    let mut ids = ids;
    let mut r = Reader::attach(k.session(), "follower").expect("attach");
    let mut lag = Reader::attach(k.session(), "lagging").expect("attach");
    let asked = r.objects_bases_asked();
    let model_now = |c: &mut Client| {
        let m = decode_store(&c.snapshot().expect("model").model).expect("decode");
        Snapshot::from_store(&m)
    };
    // Snapshots the follower took, held, and the model at their versions.
    let mut held: Vec<(std::rc::Rc<Snapshot>, Snapshot)> = Vec::new();
    let mut size = 1.0;
    let colour = |x: f32| robosim_instance_space::Appearance {
        color: [x, 1.0 - x, 0.5, 1.0],
        ..Default::default()
    };
    // The random edits, then chunk 1 painted object by object.
    let painted = OBJECT_PATCH_MAX + 4;
    for step in 0..100 + painted {
        let mut tx = Transaction::new();
        if step < 100 {
            let mut touched = Vec::new();
            for _ in 0..1 + next(3) {
                // Now and then the same few objects again (a patch list that does not grow).
                let id = if next(4) == 0 {
                    ids[OBJECT_CHUNK + next(3)]
                } else {
                    ids[next(ids.len())]
                };
                if touched.contains(&id) {
                    continue;
                }
                touched.push(id);
                size += 0.013;
                match next(20) {
                    0..=9 => {
                        tx.set_appearance(id, colour(next(1000) as f32 / 1000.0));
                    }
                    10..=16 => {
                        tx.set_geometry(id, Some(cube(size)));
                    }
                    17 | 18 => {
                        tx.set_geometry(id, None);
                    }
                    _ => {
                        tx.set_name(id, &format!("renamed{step}"));
                    }
                }
            }
            if step % 25 == 24 {
                let b = tx.create(Kind::Solid, &format!("added{step}"), Some(scene.into()));
                tx.set_geometry(b, Some(cube(size)));
            }
        } else {
            let j = step - 100;
            tx.set_appearance(ids[OBJECT_CHUNK + 3 * j], colour(j as f32 / 64.0));
        }
        let what = format!("step {step}");
        let done = c
            .transact(&tx)
            .unwrap_or_else(|e| panic!("{what}: commit: {e}"));
        ids.extend(done.created.iter().copied());
        let deadline = Instant::now() + Duration::from_secs(30);
        while r.snapshot().is_none_or(|s| s.version() < done.version) {
            r.wait_change(Duration::from_millis(200))
                .unwrap_or_else(|e| panic!("{what}: the reader stopped following: {e}"));
            assert!(Instant::now() < deadline, "{what}: never followed");
        }
        let want = model_now(&mut c);
        let got = r.snapshot().expect("snapshot");
        assert_same_records(&got, &want, &what);
        if step % 7 == 6 {
            while lag.snapshot().is_none_or(|s| s.version() < done.version) {
                lag.refresh()
                    .unwrap_or_else(|e| panic!("{what}: the lagging reader: {e}"));
                assert!(
                    Instant::now() < deadline,
                    "{what}: the lagging reader never followed"
                );
            }
            let l = lag.snapshot().expect("snapshot");
            assert_same_records(&l, &want, &format!("{what}: the lagging reader"));
        }
        if step % 13 == 12 {
            if held.len() == 3 {
                held.remove(0);
            }
            held.push((got, want));
        }
        for (h, at) in &held {
            assert_same_records(
                h,
                at,
                &format!("{what}: a snapshot held since {}", at.version()),
            );
        }
        if step % 20 == 19 || step == 99 + painted {
            let fresh = Reader::attach(k.session(), &format!("fresh{step}")).expect("attach");
            let snap = fresh.snapshot().expect("the fresh reader's snapshot");
            let got = r.snapshot().expect("snapshot");
            assert_same_records(&got, &snap, &format!("{what}: the fresh reader"));
        }
    }
    assert_eq!(r.reattachments(), 0, "the follower never reattached");
    assert_eq!(
        lag.reattachments(),
        0,
        "the lagging reader never reattached"
    );
    assert_eq!(
        r.objects_bases_asked(),
        asked,
        "following asked for the objects base"
    );
    assert!(
        r.patched_chunks_followed() >= painted as u64,
        "the follower took chunks as patches ({} times)",
        r.patched_chunks_followed()
    );
    assert!(
        lag.patched_chunks_followed() > 0,
        "the lagging reader took chunks as patches"
    );
}
