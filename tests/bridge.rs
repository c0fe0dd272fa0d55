//! `robosim bridge` (issue 18 §1): two sessions — each with its own home, session name and
//! shared memory — connected only through Zenoh over TCP on localhost. Real processes: a
//! keeper and a primary bridge on one side, a replica bridge (which is that side's keeper) on
//! the other, writers on both, bridges killed with -9 and restarted. Equality is checked two
//! ways after each change: the model digest (file-io, what `robosim info` prints) and the
//! whole encoded model including ids and version (the keepers' snapshot answers).
//!
//! The two-host version (network namespaces, a veth pair, the link cut and restored) is
//! `a_cut_link_between_two_network_namespaces_resynchronises`; it needs root and iproute2
//! (CI has both) and says why it did not run otherwise.

use crate::common;

use common::{Hosts, Procs, wait_for};
use robosim_instance_space::{
    Client, ClientError, Id, Kind, ObjRef, Session, Transaction, TxError,
};
use std::process::Command;

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

fn kill9(pid: u32) {
    let _ = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status();
}

/// The session's whole model as its keeper encodes it (ids, version and all).
fn model_bytes(s: &Session) -> Vec<u8> {
    let mut c = Client::connect(s, "probe").expect("connect");
    c.snapshot().expect("snapshot").model
}

fn version(s: &Session) -> u64 {
    let m = model_bytes(s);
    robosim_instance_space::journal::decode_store(&m)
        .expect("decodes")
        .version
}

fn digest(s: &Session) -> String {
    let model = robosim_file_io::session::read_session(s).expect("read session");
    robosim_file_io::digest::digest(&model)
        .expect("valid model")
        .to_string()
}

/// Waits until both sessions hold the same model, then checks the digests agree too.
fn assert_equal(a: &Session, b: &Session) -> u64 {
    wait_for("the replica to equal the primary", || {
        (model_bytes(a) == model_bytes(b)).then_some(())
    });
    assert_eq!(digest(a), digest(b), "equal models, different digests");
    version(a)
}

fn create_solid(c: &mut Client, name: &str, parent: Id) -> Result<Id, ClientError> {
    let mut tx = Transaction::new();
    tx.create(Kind::Solid, name, Some(ObjRef::Id(parent)));
    c.transact(&tx).map(|a| a.created[0])
}

fn scene(c: &mut Client) -> Id {
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    c.transact(&tx).expect("scene").created[0]
}

fn move_to(c: &mut Client, id: Id, x: f64) -> Result<u64, ClientError> {
    let mut tx = Transaction::new();
    let mut pose = robosim_instance_space::IDENTITY;
    pose[3] = x;
    tx.set_pose(ObjRef::Id(id), pose);
    c.transact(&tx).map(|a| a.version)
}

struct Pair {
    p: Procs,
    r: Procs,
    endpoint: String,
    primary_bridge: u32,
    replica_bridge: u32,
}

impl Pair {
    fn start(tag: &str, primary_flags: &[&str]) -> Pair {
        Pair::start_keeping(tag, &["--no-sync"], primary_flags)
    }
    /// [`Pair::start`] with the primary's keeper started with `keeper_flags`.
    fn start_keeping(tag: &str, keeper_flags: &[&str], primary_flags: &[&str]) -> Pair {
        let mut p = Procs::new(&format!("{tag}p"));
        let r = Procs::new(&format!("{tag}r"));
        p.start_keeper(keeper_flags);
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let mut pair = Pair {
            p,
            r,
            endpoint,
            primary_bridge: 0,
            replica_bridge: 0,
        };
        pair.start_primary(primary_flags);
        pair.start_replica();
        pair
    }
    fn start_primary(&mut self, flags: &[&str]) {
        let mut args = vec![
            "bridge",
            "--listen",
            &self.endpoint,
            "--heartbeat-ms",
            "100",
        ];
        args.extend_from_slice(flags);
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        self.primary_bridge = self.p.spawn(&args);
    }
    fn start_replica(&mut self) {
        let endpoint = self.endpoint.clone();
        self.replica_bridge =
            self.r
                .spawn(&["bridge", "--connect", &endpoint, "--tx-timeout-ms", "2000"]);
        let s = self.r.session();
        wait_for("the replica's keeper", || Client::connect(&s, "probe").ok());
    }
}

#[test]
fn writers_on_both_sides_see_one_model_and_read_their_own_writes() {
    let pair = Pair::start("brw", &[]);
    let (ps, rs) = (pair.p.session(), pair.r.session());
    let mut pw = Client::connect(&ps, "writer").expect("primary writer");
    let mut rw = Client::connect(&rs, "writer").expect("replica writer");
    let root = scene(&mut pw);
    assert_equal(&ps, &rs);
    for k in 0..5 {
        // A write on the replica is committed by the primary's keeper, and the replica has
        // it when the writer is answered (read your own write).
        let id = create_solid(&mut rw, &format!("from-replica-{k}"), root).expect("replica write");
        let at = move_to(&mut rw, id, k as f64).expect("replica pose");
        assert!(
            version(&rs) >= at,
            "the replica answered before it had version {at}"
        );
        assert!(version(&ps) >= at, "the primary does not have version {at}");
        assert_equal(&ps, &rs);
        let id = create_solid(&mut pw, &format!("from-primary-{k}"), root).expect("primary write");
        move_to(&mut pw, id, -(k as f64)).expect("primary pose");
        assert_equal(&ps, &rs);
    }
    // A transaction the primary refuses is refused on the replica, with the keeper's error,
    // and changes nothing on either side.
    let before = version(&ps);
    let err = move_to(&mut rw, 999_999, 1.0).expect_err("no such object");
    assert!(
        matches!(
            err,
            ClientError::Refused(TxError::UnknownObject { id: 999_999, .. })
        ),
        "{err}"
    );
    assert_eq!(version(&ps), before);
    assert_eq!(assert_equal(&ps, &rs), before);
}

#[test]
fn a_read_only_primary_refuses_remote_writers_by_name() {
    let pair = Pair::start("bro", &["--read-only"]);
    let (ps, rs) = (pair.p.session(), pair.r.session());
    let mut pw = Client::connect(&ps, "writer").expect("primary writer");
    let root = scene(&mut pw);
    assert_equal(&ps, &rs);
    let mut rw = Client::connect(&rs, "writer").expect("replica writer");
    let err = create_solid(&mut rw, "refused", root).expect_err("read-only");
    let text = err.to_string();
    assert!(
        matches!(err, ClientError::Refused(TxError::Forward { .. })) && text.contains("read-only"),
        "{text}"
    );
    assert_eq!(assert_equal(&ps, &rs), 1);
}

#[test]
fn killed_bridges_come_back_and_nothing_acknowledged_is_lost() {
    let mut pair = Pair::start("brk", &[]);
    let (ps, rs) = (pair.p.session(), pair.r.session());
    let mut pw = Client::connect(&ps, "writer").expect("primary writer");
    let root = scene(&mut pw);
    let mut acknowledged = Vec::new();
    {
        let mut rw = Client::connect(&rs, "writer").expect("replica writer");
        acknowledged.push(create_solid(&mut rw, "before", root).expect("write"));
    }
    assert_equal(&ps, &rs);

    // The primary's bridge dies: the replica keeps its model (readers go on), its writers
    // get a clear error, the primary's writers go on; a new bridge serves the same history
    // (it is the keeper's log) and the replica catches up without a snapshot.
    kill9(pair.primary_bridge);
    let mut rw = Client::connect(&rs, "writer").expect("replica writer");
    let err = create_solid(&mut rw, "while-down", root).expect_err("no primary");
    assert!(
        matches!(err, ClientError::Refused(TxError::Forward { .. })),
        "{err}"
    );
    for k in 0..3 {
        acknowledged
            .push(create_solid(&mut pw, &format!("down-{k}"), root).expect("primary write"));
    }
    pair.start_primary(&[]);
    assert_equal(&ps, &rs);
    acknowledged.push(create_solid(&mut rw, "after", root).expect("replica write after restart"));
    assert_equal(&ps, &rs);

    // The replica's bridge (its session's keeper) dies and is restarted: it starts from a new
    // snapshot, so writes made while it was away are there.
    kill9(pair.replica_bridge);
    drop(rw);
    for k in 0..3 {
        acknowledged
            .push(create_solid(&mut pw, &format!("away-{k}"), root).expect("primary write"));
    }
    pair.start_replica();
    assert_equal(&ps, &rs);
    let mut rw = Client::connect(&rs, "writer").expect("replica writer");
    acknowledged.push(create_solid(&mut rw, "last", root).expect("write"));
    assert_equal(&ps, &rs);

    // Every acknowledged create is in the model.
    let model = robosim_instance_space::journal::decode_store(&model_bytes(&ps)).expect("model");
    for id in acknowledged {
        assert!(
            model.get(id).is_some(),
            "acknowledged object {id} is missing"
        );
    }
}

/// `robosim ARGS --session` of `p`, inside network namespace `ns`.
fn spawn_in(p: &mut Procs, ns: &str, args: &[&str]) -> u32 {
    let dir = p.home.path().join("logs");
    std::fs::create_dir_all(&dir).expect("log dir");
    let log = dir.join(format!("{ns}-{}.log", args[0]));
    p.spawn_wrapped(&["ip", "netns", "exec", ns], args, &log)
}

#[test]
fn a_cut_link_between_two_network_namespaces_resynchronises() {
    let hosts = match Hosts::make("br") {
        Ok(h) => h,
        Err(why) => {
            // CI runs as root with iproute2 installed: there, not running is a failure.
            assert!(
                std::env::var_os("CI").is_none(),
                "the two-host bridge test could not make its hosts: {why}"
            );
            eprintln!("skipped: cannot make network namespaces here ({why})");
            return;
        }
    };
    let mut p = Procs::new("brnp");
    let mut r = Procs::new("brnr");
    // The keepers' shared memory stays on each side's own session; only the bridges' TCP link
    // crosses between the namespaces.
    p.start_keeper(&["--no-sync"]);
    spawn_in(
        &mut p,
        &hosts.a,
        &[
            "bridge",
            "--listen",
            "tcp/10.77.0.1:7447",
            "--heartbeat-ms",
            "100",
        ],
    );
    spawn_in(
        &mut r,
        &hosts.b,
        &[
            "bridge",
            "--connect",
            "tcp/10.77.0.1:7447",
            "--tx-timeout-ms",
            "1500",
        ],
    );
    let (ps, rs) = (p.session(), r.session());
    wait_for("the replica's keeper", || {
        Client::connect(&rs, "probe").ok()
    });
    let mut pw = Client::connect(&ps, "writer").expect("primary writer");
    let mut rw = Client::connect(&rs, "writer").expect("replica writer");
    let root = scene(&mut pw);
    let mut acknowledged = vec![create_solid(&mut rw, "before-cut", root).expect("replica write")];
    assert_equal(&ps, &rs);

    // Cut the link while both sides write: the primary's writes commit; the replica's are
    // refused (no answer) — none of them is acknowledged, so none may be relied on.
    hosts.link(false);
    let mut refused = 0;
    for k in 0..6 {
        acknowledged
            .push(create_solid(&mut pw, &format!("cut-p{k}"), root).expect("primary write"));
        if k % 3 == 0 {
            match create_solid(&mut rw, &format!("cut-r{k}"), root) {
                Err(ClientError::Refused(TxError::Forward { .. })) => refused += 1,
                Err(e) => panic!("unexpected error while the link is down: {e}"),
                Ok(id) => acknowledged.push(id),
            }
        }
    }
    assert!(refused > 0, "a write through a cut link was acknowledged");
    hosts.link(true);
    assert_equal(&ps, &rs);
    acknowledged.push(create_solid(&mut rw, "after-cut", root).expect("replica write after"));
    let v = assert_equal(&ps, &rs);
    let model = robosim_instance_space::journal::decode_store(&model_bytes(&ps)).expect("model");
    assert_eq!(model.version, v);
    for id in acknowledged {
        assert!(
            model.get(id).is_some(),
            "acknowledged object {id} is missing"
        );
    }
}

#[test]
fn the_library_and_the_simulators_state_cross_too() {
    use robosim_instance_space::state::{JointStateRec, StatePublisher, StateSubscriber};
    let pair = Pair::start("brs", &[]);
    let (ps, rs) = (pair.p.session(), pair.r.session());
    // The Library Space: the replica's readers get the primary's source files.
    let mut pr = robosim_instance_space::Reader::attach(&ps, "probe").expect("reader");
    let mut rr = robosim_instance_space::Reader::attach(&rs, "probe").expect("reader");
    let files = pr.library_files().expect("primary library");
    assert!(!files.is_empty());
    assert_eq!(rr.library_files().expect("replica library"), files);
    // ... and the checked library beside them, so they read it instead of parsing it.
    let (lib, from) = robosim_scene::session_library_from(&mut rr).expect("replica library");
    assert_eq!(from, robosim_scene::LibraryFrom::Checked);
    assert!(lib.declarations().iter().any(|d| d.name == "puma560"));

    // State: records published on the primary's `state/simulator` reach the replica's, at
    // most --state-hz a second, the newest one last.
    let mut publisher = StatePublisher::create(&ps, "simulator").expect("state service");
    let joint = |q: f64| JointStateRec {
        id: 7,
        q,
        qd: 0.5,
        effort: -1.0,
    };
    let mut sub = wait_for("the replica's state service", || {
        publisher
            .publish(3, 0.0, &[joint(0.0)], &[])
            .expect("publish");
        StateSubscriber::open(&rs, "simulator", "probe").ok()
    });
    let got = wait_for("the newest state on the replica", || {
        publisher
            .publish(3, 1.25, &[joint(0.75)], &[])
            .expect("publish");
        sub.wait(std::time::Duration::from_millis(100))
            .expect("state")
            .into_iter()
            .find(|r| r.header.t == 1.25)
    });
    assert_eq!(got.joints, vec![joint(0.75)]);
    assert_eq!(got.header.structure_version, 3);
}

/// Issue 34 item 18: kill -9 of the primary's keeper made the primary's bridge exit, and the
/// replica stayed stale until a person restarted the bridge. The bridge now waits for the
/// keeper to come back (`robosim space` on the same session), reattaches by itself, and the
/// replica follows what is committed after — the same bridge process all along.
#[test]
fn a_killed_primary_keeper_restarted_is_followed_by_the_same_bridge() {
    // A durable keeper: what it acknowledged survives its kill -9.
    let mut pair = Pair::start_keeping("bkk", &[], &[]);
    let (ps, rs) = (pair.p.session(), pair.r.session());
    let keeper = ps
        .processes()
        .iter()
        .find(|p| p.role == "space")
        .map(|p| p.pid)
        .expect("the primary's keeper");
    let mut pw = Client::connect(&ps, "writer").expect("primary writer");
    let root = scene(&mut pw);
    let before = create_solid(&mut pw, "before", root).expect("write");
    assert_equal(&ps, &rs);
    drop(pw);

    kill9(keeper);
    wait_for("the keeper gone", || {
        (!robosim_instance_space::pid_alive(keeper)).then_some(())
    });
    pair.p.start_keeper(&[]);
    let mut pw = Client::connect(&ps, "writer").expect("primary writer after the restart");
    let after = create_solid(&mut pw, "after", root).expect("write after the restart");
    // The replica has it without the bridge having been restarted.
    let v = assert_equal(&ps, &rs);
    let model = robosim_instance_space::journal::decode_store(&model_bytes(&rs)).expect("model");
    assert!(model.get(before).is_some() && model.get(after).is_some());
    // Writes from the replica go through the reattached bridge too.
    let mut rw = Client::connect(&rs, "writer").expect("replica writer");
    create_solid(&mut rw, "from-replica", root).expect("replica write after the restart");
    assert!(assert_equal(&ps, &rs) > v);
    let bridge = pair
        .p
        .children
        .iter_mut()
        .find(|c| c.id() == pair.primary_bridge)
        .expect("the primary's bridge");
    assert!(
        bridge.try_wait().expect("try_wait").is_none(),
        "the same primary bridge still runs"
    );
}
