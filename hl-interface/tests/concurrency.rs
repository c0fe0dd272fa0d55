//! Concurrent read-modify-write edits (issue 34 item 3): N writers, each with its own reader
//! and transaction client over the session's real shared memory (threads of this process, a
//! keeper stepping in another), race relative edits on one object and one joint. Every edit
//! is acknowledged and every one lands: the sums are exact. Before `Op::Expect` and
//! `Client::transact_fresh`, 12 `posttranslate`s of 1 mm moved the object 3 mm.

use robosim_hl_interface::session::Ops;
use robosim_instance_space::{Client, KeeperOptions, Reader, Session, ThreadKeeper};
use serde_json::json;
use std::sync::Barrier;
use std::time::Duration;

/// Writers racing; more than the default 16 clients of a session (the keeper here allows more).
const WRITERS: usize = 17;
/// Edits each writer makes.
const EDITS: usize = 3;

/// A keeper stepping in a thread of this process on session `c<tag><pid>` of its own (home,
/// shared memory removed when dropped).
fn thread_keeper(tag: &str, opts: KeeperOptions) -> ThreadKeeper {
    let name = format!("c{tag}{}", std::process::id());
    ThreadKeeper::start(&name, opts, Duration::from_secs(60)).expect("the keeper started")
}

/// A keeper holding the built-in `demo` scene (a table at x = 0.8 m, the two-joint arm2).
fn demo_session(tag: &str) -> ThreadKeeper {
    let opts = KeeperOptions {
        max_clients: WRITERS + 4,
        max_readers: WRITERS + 4,
        ..KeeperOptions::default()
    };
    let k = thread_keeper(tag, opts);
    let lib = robosim_library::standard_library().expect("the standard library");
    let mut c = Client::connect(k.session(), "setup").expect("connect");
    for tx in robosim_scene::load_from(lib, "demo").expect("demo scene") {
        c.transact(&tx).expect("demo committed");
    }
    k
}

/// `WRITERS` threads, each attached on its own (reader + client) before any starts, run
/// `edit(writer, ops)` `EDITS` times at once.
fn race(session: &Session, edit: impl Fn(usize, &mut Ops) + Sync) {
    let start = Barrier::new(WRITERS);
    std::thread::scope(|s| {
        for w in 0..WRITERS {
            let (start, edit) = (&start, &edit);
            s.spawn(move || {
                let mut ops = Ops::attach(session).expect("attach a writer");
                start.wait();
                for _ in 0..EDITS {
                    edit(w, &mut ops);
                }
            });
        }
    });
}

fn snapshot(session: &Session) -> std::rc::Rc<robosim_instance_space::Snapshot> {
    let mut r = Reader::attach(session, "check").expect("reader");
    r.refresh().expect("refresh");
    r.snapshot().expect("snapshot")
}

#[test]
fn concurrent_relative_edits_all_land() {
    let k = demo_session("rel");
    let step = 0.001;
    race(k.session(), |w, ops| {
        // Half the writers translate in the parent's frame, half in the table's own: with the
        // table unrotated both add `step` along x.
        let op = if w % 2 == 0 {
            "posttranslate"
        } else {
            "pretranslate"
        };
        let a = ops
            .dispatch(op, &json!({"object": "table", "by": [step, 0.0, 0.0]}))
            .expect("a session op")
            .unwrap_or_else(|e| panic!("writer {w}: {op} refused: {e}"));
        assert!(a["version"].as_u64().is_some(), "acknowledged: {a}");
    });
    let snap = snapshot(k.session());
    let i = snap.find("table").expect("the table");
    let x = snap.pose(i).pose[3];
    let want = 0.8 + (WRITERS * EDITS) as f64 * step;
    assert!(
        (x - want).abs() < 1e-12,
        "{} edits of {step} m: the table is at x = {x}, not {want} ({:.1} edits lost)",
        WRITERS * EDITS,
        (want - x) / step
    );
}

#[test]
fn concurrent_relative_joint_moves_all_land() {
    let k = demo_session("joint");
    let step = 0.01;
    race(k.session(), |w, ops| {
        // Writers of joint 0 and of joint 1 race on the same robot: each writes the whole q
        // (and the link poses), so a stale read of the other joint would undo its moves.
        let j = w % 2;
        ops.update_joints("arm2", |q| {
            q[j] += step;
            Ok(())
        })
        .unwrap_or_else(|e| panic!("writer {w}: joint {j} refused: {e}"));
    });
    let snap = snapshot(k.session());
    let q: Vec<f64> = ["link1", "link2"]
        .iter()
        .map(|l| snap.pose(snap.find(l).expect("a link")).joint)
        .collect();
    let moves = |j: usize| ((0..WRITERS).filter(|w| w % 2 == j).count() * EDITS) as f64;
    let want = [moves(0) * step, moves(1) * step];
    for j in 0..2 {
        assert!(
            (q[j] - want[j]).abs() < 1e-12,
            "joint {j}: {} moves of {step} rad: q = {}, not {} ({:.1} moves lost)",
            moves(j),
            q[j],
            want[j],
            (want[j] - q[j]) / step
        );
    }
}

/// `postrotate` / `prerotate` about an axis of any finite non-zero length turn the object by
/// the angle (issue 34 item 9): `[1e200, 0, 0]` committed a no-op (its norm overflowed) and
/// `[1e-200, 0, 0]` was refused as "all zero"; a zero or non-finite axis is refused, naming it.
#[test]
fn rotate_about_a_huge_or_tiny_axis_turns_the_object() {
    let k = demo_session("axis");
    let mut ops = Ops::attach(k.session()).expect("attach");
    let quarter = std::f64::consts::FRAC_PI_2;
    for (op, axis) in [
        ("postrotate", 1e200),
        ("prerotate", 1e-200),
        ("postrotate", 5e-324),
    ] {
        let a = ops
            .dispatch(
                op,
                &json!({"object": "table", "axis": [axis, 0.0, 0.0], "angle": quarter}),
            )
            .expect("a session op")
            .unwrap_or_else(|e| panic!("{op} about [{axis:e}, 0, 0] refused: {e}"));
        assert!(a["version"].as_u64().is_some(), "{a}");
    }
    // Three quarter turns about x: the rotation part is [[1,0,0],[0,0,1],[0,-1,0]].
    let snap = snapshot(k.session());
    let p = snap.pose(snap.find("table").expect("the table")).pose;
    let want = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0];
    let got = [p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]];
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 1e-12, "rotation {got:?}, want {want:?}");
    }
    for axis in [
        json!([0.0, 0.0, 0.0]),
        json!([1.0, 0.0]),
        json!([1e308, "x", 0.0]),
    ] {
        let e = ops
            .dispatch(
                "postrotate",
                &json!({"object": "table", "axis": axis, "angle": 1.0}),
            )
            .expect("a session op")
            .expect_err("no direction");
        assert_eq!(e.kind.as_str(), "bad_request", "{e}");
    }
}

/// A session serves 16 readers and 16 writers by default; the 17th `robosim query` died on a
/// raw iceoryx2 error with no answer. Now the reader or writer beyond the limit gets a typed
/// error naming the session, the limit and how to raise it, and `serve` answers each session
/// op with a `session` error saying so.
#[test]
fn clients_beyond_the_limit_get_a_typed_session_error() {
    use robosim_hl_interface::session::{AttachError, serve};
    use robosim_instance_space::{ClientError, ReaderError};
    let opts = KeeperOptions::default();
    let limit = opts.max_clients;
    assert_eq!(
        (limit, opts.max_readers),
        (16, 16),
        "the documented defaults"
    );
    let k = thread_keeper("limit", opts);
    let held: Vec<Ops> = (0..limit)
        .map(|n| Ops::attach(k.session()).unwrap_or_else(|e| panic!("attach {n}: {e}")))
        .collect();
    let e = Ops::attach(k.session())
        .err()
        .expect("the 17th reader is refused");
    let said = e.to_string();
    assert!(
        matches!(
            e,
            AttachError::Reader(ReaderError::TooManyReaders { limit: 16, .. })
        ),
        "{said}"
    );
    assert!(
        said.contains("limit of 16 readers") && said.contains("ROBOSIM_MAX_CLIENTS"),
        "{said}"
    );
    let e = Client::connect(k.session(), "extra")
        .err()
        .expect("the 17th writer is refused");
    assert!(
        matches!(e, ClientError::TooManyClients { limit: 16, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("limit of 16 writers"), "{e}");
    let input = concat!(
        r#"{"id": 1, "op": "posttranslate", "object": "table", "by": [0.001, 0, 0]}"#,
        "\n",
        r#"{"id": 2, "op": "get_robot", "robot": "arm2"}"#,
        "\n"
    );
    let mut out = Vec::new();
    let served = serve(k.session(), input.as_bytes(), &mut out);
    assert!(served.is_err(), "the stream ends with the attach error");
    let answers: Vec<serde_json::Value> = String::from_utf8_lossy(&out)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON answer"))
        .collect();
    assert_eq!(answers.len(), 2, "one answer per request: {answers:?}");
    for a in &answers {
        assert_eq!(a["ok"], false, "{a}");
        assert_eq!(a["error"]["kind"], "session", "{a}");
        let m = a["error"]["message"].as_str().unwrap_or("");
        assert!(m.contains("limit of 16"), "{a}");
    }
    drop(held);
}

/// The limit is the keeper's option (`ROBOSIM_MAX_CLIENTS` for a session's keeper): raised to
/// 17, a 17th reader and writer attach.
#[test]
fn raising_the_client_limit_lets_a_17th_in() {
    let opts = KeeperOptions {
        max_clients: 17,
        max_readers: 17,
        ..KeeperOptions::default()
    };
    let k = thread_keeper("raised", opts);
    let held: Vec<Ops> = (0..17)
        .map(|n| Ops::attach(k.session()).unwrap_or_else(|e| panic!("attach {n}: {e}")))
        .collect();
    assert_eq!(held.len(), 17);
}

/// A transaction larger than a request may be is refused before any shared memory is asked
/// for, naming its size and the limit (it said "iceoryx2 loan request: OutOfMemory").
#[test]
fn an_oversized_transaction_names_its_size_and_the_limit() {
    use robosim_instance_space::{ClientError, MAX_REQUEST_BYTES};
    let k = thread_keeper("big", KeeperOptions::default());
    let mut c = Client::connect(k.session(), "big").expect("connect");
    // Zeroed pages from the allocator: never touched, so this costs no memory.
    let bytes = vec![0u8; MAX_REQUEST_BYTES + 1];
    let e = c.submit_raw(&bytes).err().expect("refused");
    assert!(
        matches!(e, ClientError::TooLarge { bytes, limit } if bytes == MAX_REQUEST_BYTES + 1 && limit == MAX_REQUEST_BYTES),
        "{e}"
    );
    let said = e.to_string();
    assert!(
        said.contains(&(MAX_REQUEST_BYTES + 1).to_string())
            && said.contains(&MAX_REQUEST_BYTES.to_string()),
        "{said}"
    );
}
