//! Cross-process tests of the Instance Space: real `robosim space` keepers, real reader and
//! writer processes (this test binary re-executed in a child role), real shared memory, real
//! `kill -9`. Each test has its own session name and its own ROBOSIM_HOME, and stops what it
//! started.

use robosim_instance_space::{
    Client, ClientError, IDENTITY, Id, Kind, Reader, Session, Transaction, TxError,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const ROBOSIM: &str = env!("CARGO_BIN_EXE_robosim");

/// A session with a private home directory; kills its processes and removes its shared
/// memory when dropped.
struct TestSession {
    home: tempfile::TempDir,
    name: String,
    children: Vec<Child>,
}

impl TestSession {
    fn new(tag: &str) -> Self {
        // iceoryx2 warns when a reader outlives a killed keeper; that is what these tests do.
        iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
        let home = tempfile::tempdir().expect("temp dir");
        TestSession {
            home,
            name: format!("t{}{}", tag, std::process::id()),
            children: Vec::new(),
        }
    }
    fn session(&self) -> Session {
        Session::open_in(self.home.path(), Some(&self.name)).expect("session")
    }
    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("ROBOSIM_HOME", self.home.path())
            .env("IOX2_LOG_LEVEL", "Error");
        c
    }
    fn start_keeper(&mut self) -> u32 {
        let child = self
            .command(ROBOSIM)
            .args(["space", "--session", &self.name])
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start keeper");
        let pid = child.id();
        self.children.push(child);
        let s = self.session();
        let start = Instant::now();
        loop {
            let ok = with_home(self.home.path(), || Client::connect(&s, "probe").is_ok());
            if ok {
                return pid;
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "keeper did not come up"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    /// Starts `robosim simulator` on this session and returns its pid once it has registered.
    fn start_simulator(&mut self) -> u32 {
        let child = self
            .command(ROBOSIM)
            .args(["simulator", "--session", &self.name])
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start simulator");
        let pid = child.id();
        self.children.push(child);
        let s = self.session();
        let start = Instant::now();
        while !s.processes().iter().any(|p| p.role == "simulator") {
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "simulator did not register"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        pid
    }
    /// This test binary in a child role.
    fn child(&mut self, role: &str, args: &[&str]) -> u32 {
        let exe = std::env::current_exe().expect("test exe");
        let child = self
            .command(exe.to_str().expect("utf-8 path"))
            .args([
                "--exact",
                "space::child_process_entry",
                "--nocapture",
                "--test-threads=1",
            ])
            .env("ROBOSIM_CHILD", role)
            .env("ROBOSIM_CHILD_SESSION", &self.name)
            .env("ROBOSIM_CHILD_ARGS", args.join(" "))
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn child");
        let pid = child.id();
        self.children.push(child);
        pid
    }
    fn wait_child(&mut self, pid: u32, timeout: Duration) -> bool {
        let start = Instant::now();
        let i = self
            .children
            .iter()
            .position(|c| c.id() == pid)
            .expect("our child");
        loop {
            if let Some(status) = self.children[i].try_wait().expect("try_wait") {
                return status.success();
            }
            assert!(
                start.elapsed() < timeout,
                "child {pid} still running after {timeout:?}"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    fn file(&self, name: &str) -> PathBuf {
        self.home.path().join(name)
    }
    /// `kill -9` of child `pid` (one this session started), and waits for it to be gone.
    fn kill9_and_reap(&mut self, pid: u32) {
        kill9(pid);
        let i = self
            .children
            .iter()
            .position(|c| c.id() == pid)
            .expect("ours");
        let _ = self.children[i].wait();
    }
    /// Runs `robosim ARGS` in this session's home to the end.
    fn robosim(&self, args: &[&str]) -> Output {
        self.command(ROBOSIM)
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("run robosim {args:?}: {e}"))
    }
    /// A guard that runs `robosim down` on this session when dropped: stops what `up`
    /// started, whatever the test's outcome.
    fn down_when_dropped(&self) -> Down {
        let mut down = self.command(ROBOSIM);
        down.args(["down", "--session", &self.name]);
        Down(down)
    }
}

/// See [`TestSession::down_when_dropped`].
struct Down(Command);

impl Drop for Down {
    fn drop(&mut self) {
        let _ = self.0.output();
    }
}

impl Drop for TestSession {
    fn drop(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
        robosim_instance_space::remove_shm_files(&self.name);
    }
}

/// Runs `f` (kept as a seam: sessions are opened with an explicit home, so nothing here
/// touches the process environment).
fn with_home<T>(_home: &Path, f: impl FnOnce() -> T) -> T {
    f()
}

fn kill9(pid: u32) {
    let _ = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status();
}

/// Commits a new `Kind::Scene` object named "scene"; its id.
fn create_scene(c: &mut Client) -> Id {
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "scene", None);
    c.transact(&tx).expect("scene").created[0]
}

/// Renames `scene` `n` times, to n0, n1, …, one transaction each.
fn rename_scene(c: &mut Client, scene: Id, n: usize) {
    for k in 0..n {
        let mut tx = Transaction::new();
        tx.set_name(scene, &format!("n{k}"));
        c.transact(&tx).expect("rename");
    }
}

fn scene_tx() -> Transaction {
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "scene", None);
    for k in 0..3 {
        tx.create(Kind::Solid, &format!("body{k}"), Some(scene));
    }
    tx
}

/// Reads "version ids…" lines.
fn read_log(path: &Path) -> Vec<(u64, Vec<u64>)> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let mut it = l
                .split_whitespace()
                .map(|x| x.parse::<u64>().expect("number"));
            let v = it.next().expect("version");
            (v, it.collect())
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// Child roles (this binary re-executed with ROBOSIM_CHILD set). Without it this entry point
// returns at once; it is not a test of anything by itself.

#[test]
fn child_process_entry() {
    let Ok(role) = std::env::var("ROBOSIM_CHILD") else {
        return;
    };
    let name = std::env::var("ROBOSIM_CHILD_SESSION").expect("session");
    let args: Vec<String> = std::env::var("ROBOSIM_CHILD_ARGS")
        .unwrap_or_default()
        .split_whitespace()
        .map(str::to_owned)
        .collect();
    let session = Session::open(Some(&name)).expect("session");
    match role.as_str() {
        // reader OUT UNTIL: record every change (version ids…) until version UNTIL.
        "reader" => {
            let out = PathBuf::from(&args[0]);
            let until: u64 = args[1].parse().expect("until");
            let mut r = Reader::attach(&session, "test-reader").expect("attach");
            let mut f = std::fs::File::create(&out).expect("log");
            let snap = r.snapshot().expect("snapshot");
            writeln!(
                f,
                "# attached at {} with {} objects",
                snap.version(),
                snap.len()
            )
            .expect("write");
            let mut last = snap.version();
            while last < until {
                for c in r.wait_change(Duration::from_secs(20)).expect("wait") {
                    let ids: Vec<String> = c.ids.iter().map(u64::to_string).collect();
                    writeln!(f, "{} {}", c.version, ids.join(" ")).expect("write");
                    last = c.version;
                }
            }
            // The snapshot must agree with the last change: same version.
            let snap = r.snapshot().expect("snapshot");
            writeln!(f, "# final {} {}", snap.version(), snap.len()).expect("write");
        }
        // writer OUT N: N transactions, each moving one of the scene's bodies; log acks.
        "writer" => {
            let out = PathBuf::from(&args[0]);
            let n: usize = args[1].parse().expect("n");
            let bodies: Vec<u64> = args[2..].iter().map(|a| a.parse().expect("id")).collect();
            let mut c = Client::connect(&session, "test-writer").expect("connect");
            let mut f = std::fs::File::create(&out).expect("log");
            for k in 0..n {
                let mut tx = Transaction::new();
                let mut pose = IDENTITY;
                pose[3] = k as f64;
                let id = bodies[k % bodies.len()];
                tx.set_pose(id, pose);
                if k % 7 == 3 {
                    // Some transactions touch two objects.
                    tx.set_pose(bodies[(k + 1) % bodies.len()], pose);
                }
                let a = c.transact(&tx).expect("commit");
                let ids: Vec<String> = a.changes.iter().map(|x| x.0.to_string()).collect();
                writeln!(f, "{} {}", a.version, ids.join(" ")).expect("write");
            }
        }
        // burst OUT N: pipeline N creates; log "version k" for each acknowledged one, flushed
        // line by line; stop quietly when the keeper goes away.
        "burst" => {
            let out = PathBuf::from(&args[0]);
            let n: usize = args[1].parse().expect("n");
            let scene: u64 = args[2].parse().expect("scene");
            let mut c = Client::connect(&session, "test-burst").expect("connect");
            let mut f = std::fs::File::create(&out).expect("log");
            let mut q = std::collections::VecDeque::new();
            for k in 0..n {
                if q.len() >= 32 {
                    let (kk, p) = q.pop_front().expect("non-empty");
                    match c.wait(p) {
                        Ok(Ok(a)) => {
                            writeln!(f, "{} {kk}", a.version).expect("write");
                            f.flush().expect("flush");
                        }
                        Ok(Err(e)) => panic!("refused: {e}"),
                        Err(_) => return,
                    }
                }
                let mut tx = Transaction::new();
                tx.create(Kind::Solid, &format!("k{k}"), Some(scene.into()));
                match c.submit(&tx) {
                    Ok(p) => q.push_back((k, p)),
                    Err(_) => return,
                }
            }
            while let Some((kk, p)) = q.pop_front() {
                match c.wait(p) {
                    Ok(Ok(a)) => writeln!(f, "{} {kk}", a.version).expect("write"),
                    _ => return,
                }
            }
        }
        // idle: attach as a reader and wait to be killed.
        "idle" => {
            let _r = Reader::attach(&session, "test-idle").expect("attach");
            println!("attached");
            std::thread::sleep(Duration::from_secs(600));
        }
        other => panic!("unknown child role {other}"),
    }
}

// ---------------------------------------------------------------------------------------

#[test]
fn writer_and_two_readers_one_late_observe_every_version_in_order() {
    let mut t = TestSession::new("rw");
    t.start_keeper();
    let s = t.session();
    let mut c = with_home(t.home.path(), || Client::connect(&s, "setup")).expect("connect");
    let a = c.transact(&scene_tx()).expect("scene");
    let bodies: Vec<String> = a.created[1..].iter().map(u64::to_string).collect();
    let n = 400u64;
    let until = a.version + n;
    let (early_log, late_log, writer_log) = (
        t.file("early.log"),
        t.file("late.log"),
        t.file("writer.log"),
    );
    let early = t.child(
        "reader",
        &[early_log.to_str().expect("path"), &until.to_string()],
    );
    // The early reader must be attached before the writer starts: wait for its header line.
    let start = Instant::now();
    while std::fs::read_to_string(&early_log).map_or(true, |s| s.is_empty()) {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "early reader did not attach"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let mut wargs = vec![writer_log.to_str().expect("path").to_owned(), n.to_string()];
    wargs.extend(bodies.iter().cloned());
    let wargs: Vec<&str> = wargs.iter().map(String::as_str).collect();
    let writer = t.child("writer", &wargs);
    // Start the late reader once the writer is part-way through.
    while read_log(&writer_log).len() < (n / 2) as usize {
        assert!(start.elapsed() < Duration::from_secs(120), "writer stalled");
        std::thread::sleep(Duration::from_millis(5));
    }
    let late = t.child(
        "reader",
        &[late_log.to_str().expect("path"), &until.to_string()],
    );
    assert!(
        t.wait_child(writer, Duration::from_secs(120)),
        "writer failed"
    );
    assert!(
        t.wait_child(early, Duration::from_secs(60)),
        "early reader failed"
    );
    assert!(
        t.wait_child(late, Duration::from_secs(60)),
        "late reader failed"
    );

    let written = read_log(&writer_log);
    assert_eq!(written.len(), n as usize);
    let versions: Vec<u64> = written.iter().map(|w| w.0).collect();
    assert_eq!(
        versions,
        ((a.version + 1)..=until).collect::<Vec<_>>(),
        "versions are consecutive"
    );
    let early_seen = read_log(&early_log);
    assert_eq!(
        early_seen, written,
        "the early reader saw every version, in order, with the writer's change sets"
    );
    let late_text = std::fs::read_to_string(&late_log).expect("late log");
    let attached_at: u64 = late_text
        .lines()
        .next()
        .and_then(|l| l.split_whitespace().nth(3))
        .and_then(|v| v.parse().ok())
        .expect("attach line");
    assert!(
        attached_at >= a.version + n / 2,
        "late reader attached late ({attached_at})"
    );
    let late_seen = read_log(&late_log);
    let expected: Vec<_> = written
        .iter()
        .filter(|w| w.0 > attached_at)
        .cloned()
        .collect();
    assert_eq!(
        late_seen, expected,
        "the late reader saw the model at once and every later version in order"
    );
    assert!(
        late_text.contains(&format!("# final {until} 4")),
        "late reader's final snapshot is the last version: {late_text}"
    );
}

#[test]
fn kill_9_of_the_keeper_mid_burst_loses_nothing_acknowledged() {
    let mut t = TestSession::new("k9");
    let keeper = t.start_keeper();
    let s = t.session();
    let scene = {
        let mut c = with_home(t.home.path(), || Client::connect(&s, "setup")).expect("connect");
        create_scene(&mut c)
    };
    let mut reader = with_home(t.home.path(), || Reader::attach(&s, "survivor")).expect("attach");
    let log = t.file("burst.log");
    let burst = t.child(
        "burst",
        &[log.to_str().expect("path"), "10000", &scene.to_string()],
    );
    let start = Instant::now();
    while read_log(&log).len() < 1500 {
        assert!(start.elapsed() < Duration::from_secs(120), "burst stalled");
        std::thread::sleep(Duration::from_millis(2));
    }
    kill9(keeper);
    t.wait_child(burst, Duration::from_secs(60));
    let acked = read_log(&log);
    assert!(
        acked.len() >= 1500 && acked.len() < 10000,
        "killed mid-burst ({} acked)",
        acked.len()
    );
    let last_acked = acked.iter().map(|a| a.0).max().expect("acks");

    t.start_keeper();
    // Every acknowledged create is there after recovery.
    let mut fresh = with_home(t.home.path(), || Reader::attach(&s, "after")).expect("attach");
    let snap = fresh.snapshot().expect("snapshot");
    assert!(
        snap.version() >= last_acked,
        "recovered version {} < last acknowledged {last_acked}",
        snap.version()
    );
    let names: std::collections::HashSet<&str> = (0..snap.len()).map(|i| snap.name(i)).collect();
    for (_, k) in &acked {
        assert!(
            names.contains(format!("k{}", k[0]).as_str()),
            "acknowledged create k{} lost",
            k[0]
        );
    }
    // Versions continue, and the reader that outlived the old keeper follows the new one.
    let mut c = with_home(t.home.path(), || Client::connect(&s, "after")).expect("connect");
    let mut tx = Transaction::new();
    tx.set_name(scene, "renamed");
    let a = c.transact(&tx).expect("commit after restart");
    assert_eq!(a.version, snap.version() + 1);
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let _ = reader
            .wait_change(Duration::from_millis(200))
            .expect("wait");
        if reader.snapshot().is_some_and(|s| s.version() >= a.version) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "surviving reader never saw version {}",
            a.version
        );
    }
    let snap = reader.snapshot().expect("snapshot");
    assert_eq!(snap.name(snap.index_of(scene).expect("scene")), "renamed");
    assert!(fresh.refresh().is_ok());
}

/// The files of this session's iceoryx2 service configs.
fn service_files(t: &TestSession) -> std::collections::BTreeSet<PathBuf> {
    std::fs::read_dir(t.home.path().join(&t.name).join("iox2").join("services"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "service"))
        .collect()
}

/// A keeper killed while it makes a service (here: the pose chunk its 257th object needs)
/// leaves that service's config half-made — the file iceoryx2 creates first, still mode
/// 0600 — and iceoryx2 0.10 answers `HangsInCreation` to everyone who opens it after. The
/// restarted keeper used to die on it ("create service of pose chunk 6: HangsInCreation",
/// the kill -9 test's rare failure); now it removes the stalled config, makes the service
/// anew and serves every acknowledged object.
#[test]
fn a_keeper_killed_while_making_a_service_does_not_stop_the_next_one() {
    use std::os::unix::fs::PermissionsExt;
    let mut t = TestSession::new("hic");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = with_home(t.home.path(), || Client::connect(&s, "setup")).expect("connect");
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "scene", None);
    for k in 0..100 {
        tx.create(Kind::Solid, &format!("a{k}"), Some(scene));
    }
    let built = c.transact(&tx).expect("first objects");
    let before = service_files(&t);
    let mut tx = Transaction::new();
    for k in 0..300 {
        tx.create(Kind::Solid, &format!("b{k}"), Some(built.created[0].into()));
    }
    let last = c
        .transact(&tx)
        .expect("objects of a second pose chunk")
        .version;
    drop(c);
    let made: Vec<PathBuf> = service_files(&t).difference(&before).cloned().collect();
    assert!(!made.is_empty(), "a second pose chunk makes a service");
    kill9(keeper);
    // What a keeper killed between making the config file and finishing it leaves.
    for f in &made {
        std::fs::set_permissions(f, std::fs::Permissions::from_mode(0o600)).expect("chmod");
    }
    std::thread::sleep(Duration::from_millis(600));
    t.start_keeper();
    let mut r = with_home(t.home.path(), || Reader::attach(&s, "after")).expect("attach");
    let snap = r.snapshot().expect("snapshot");
    assert_eq!(snap.version(), last);
    assert_eq!(snap.len(), 401, "the scene and its 400 solids");
    for k in [0, 255, 299] {
        let i = snap.find(&format!("b{k}")).expect("acknowledged object");
        assert!(snap.rec(i).id > 0);
    }
    assert!(r.refresh().is_ok());
}

/// Issue #20 item 3 (`keeper_gone_fails_fast`): after `kill -9` of the keeper a writer's
/// queued requests used to wait out the 30 s timeout one by one ("no answer within 30s").
/// Now every pending request fails with `KeeperGone` (the keeper's iceoryx2 node is `Dead`),
/// and so does every later one. The client keeps its 30 s timeout: a `Timeout` here fails.
#[test]
fn keeper_gone_fails_fast_for_every_pending_request_after_kill_9() {
    let mut t = TestSession::new("kg");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "writer").expect("connect");
    let scene = c.transact(&scene_tx()).expect("scene").created[0];
    kill9(keeper);
    // Reap it: SIGKILL is asynchronous, and the test must not race the kernel.
    let i = t
        .children
        .iter()
        .position(|c| c.id() == keeper)
        .expect("ours");
    let _ = t.children[i].wait();
    let mut pending = Vec::new();
    let mut refused_at_submit = 0;
    for k in 0..5 {
        let mut tx = Transaction::new();
        tx.set_name(scene, &format!("after{k}"));
        match c.submit(&tx) {
            Ok(p) => pending.push(p),
            Err(ClientError::KeeperGone) => refused_at_submit += 1,
            Err(e) => panic!("submit {k}: {e}"),
        }
    }
    for (k, p) in pending.into_iter().enumerate() {
        match c.wait(p) {
            Err(ClientError::KeeperGone) => {}
            other => panic!("pending request {k}: expected KeeperGone, got {other:?}"),
        }
    }
    // The client knows now: the next request fails without waiting.
    let mut tx = Transaction::new();
    tx.set_name(scene, "later");
    assert!(
        matches!(c.transact(&tx), Err(ClientError::KeeperGone)),
        "a request after the keeper's death ({refused_at_submit} refused at submit)"
    );
}

#[test]
fn kill_9_of_a_reader_or_the_simulator_leaves_the_keeper_and_others_running() {
    let mut t = TestSession::new("kr");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = with_home(t.home.path(), || Client::connect(&s, "setup")).expect("connect");
    let a = c.transact(&scene_tx()).expect("scene");
    let sim_pid = t.start_simulator();
    let idle = t.child("idle", &[]);
    let mut other = with_home(t.home.path(), || Reader::attach(&s, "other")).expect("attach");
    std::thread::sleep(Duration::from_millis(300));
    kill9(idle);
    kill9(sim_pid);
    t.wait_child(idle, Duration::from_secs(10));
    let mut tx = Transaction::new();
    tx.set_pose(a.created[1], IDENTITY);
    let b = c.transact(&tx).expect("keeper still serves");
    let changes = other.wait_change(Duration::from_secs(10)).expect("wait");
    assert_eq!(
        changes.last().map(|c| c.version),
        Some(b.version),
        "the other reader carries on"
    );
    assert!(robosim_instance_space::pid_alive(keeper));
    // SIGKILL is delivered asynchronously: wait until the simulator is really gone.
    let start = Instant::now();
    while robosim_instance_space::pid_alive(sim_pid) {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "simulator survived SIGKILL"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(
        !s.processes().iter().any(|p| p.role == "simulator"),
        "the dead simulator is gone from ps"
    );
    // A new reader can still attach after peers died uncleanly.
    let late =
        with_home(t.home.path(), || Reader::attach(&s, "late")).expect("attach after deaths");
    assert_eq!(late.snapshot().expect("snapshot").version(), b.version);
}

/// Ctrl-Z and `fg` (SIGSTOP, SIGCONT), a debugger or strace attaching: a stopped and continued
/// process has its blocking wait fail with EINTR. The keeper took that for a fatal iceoryx2
/// error and exited ("wait for requests: InterruptSignal"), losing the session's writer.
#[test]
fn stop_and_continue_of_the_keeper_and_the_simulator_is_not_an_error() {
    let mut t = TestSession::new("sc");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = with_home(t.home.path(), || Client::connect(&s, "setup")).expect("connect");
    let a = c.transact(&scene_tx()).expect("scene");
    let sim_pid = t.start_simulator();
    let mut reader = with_home(t.home.path(), || Reader::attach(&s, "watch")).expect("attach");
    let signal = |sig: &str, pid: u32| {
        let ok = Command::new("kill")
            .args([sig, &pid.to_string()])
            .status()
            .expect("kill")
            .success();
        assert!(ok, "kill {sig} {pid}");
    };
    for k in 0..3 {
        for pid in [keeper, sim_pid] {
            signal("-STOP", pid);
        }
        for pid in [keeper, sim_pid] {
            signal("-CONT", pid);
        }
        let mut tx = Transaction::new();
        let mut pose = IDENTITY;
        pose[3] = k as f64 + 1.0;
        tx.set_pose(a.created[1], pose);
        let b = c.transact(&tx).unwrap_or_else(|e| {
            panic!("cycle {k}: the keeper no longer serves after SIGCONT: {e}")
        });
        let seen = reader.wait_change(Duration::from_secs(10)).expect("wait");
        assert_eq!(seen.last().map(|c| c.version), Some(b.version), "cycle {k}");
    }
    // Both still run: not exited (a dead child would be a zombie, so ask try_wait, not kill 0).
    for child in &mut t.children {
        assert!(
            child.try_wait().expect("try_wait").is_none(),
            "process {} exited after stop/continue",
            child.id()
        );
    }
    assert!(
        s.processes().iter().any(|p| p.role == "simulator"),
        "the simulator is still registered"
    );
}

#[test]
fn bad_transactions_through_the_keeper_get_typed_errors_and_change_nothing() {
    let mut t = TestSession::new("bad");
    t.start_keeper();
    let s = t.session();
    let mut c = with_home(t.home.path(), || Client::connect(&s, "w")).expect("connect");
    let a = c.transact(&scene_tx()).expect("scene");
    let mut r = with_home(t.home.path(), || Reader::attach(&s, "r")).expect("attach");
    let body = a.created[1];
    let mut pose = IDENTITY;
    pose[5] = f64::INFINITY;
    let mut tx = Transaction::new();
    tx.set_pose(body, pose);
    assert!(
        matches!(c.transact(&tx), Err(ClientError::Refused(TxError::NonFinite { op: 0, id, .. })) if id == body)
    );
    let mut tx = Transaction::new();
    tx.set_pose(123_456, IDENTITY);
    assert!(matches!(
        c.transact(&tx),
        Err(ClientError::Refused(TxError::UnknownObject {
            id: 123_456,
            ..
        }))
    ));
    let p = c.submit_raw(b"\xff\xff\xff garbage").expect("sent");
    assert!(matches!(
        c.wait(p).expect("answer"),
        Err(TxError::Malformed { .. })
    ));
    // A wire message claiming 10^12 vertices.
    let mut tx = Transaction::new();
    tx.set_geometry(
        body,
        Some(robosim_instance_space::GeometryInput {
            vertices: vec![[0.0; 3]],
            polygons: vec![],
        }),
    );
    let bytes = tx.encode();
    let pos = bytes
        .windows(25)
        .position(|w| w[0] == 1 && w[1..].iter().all(|b| *b == 0))
        .expect("count");
    let mut evil = bytes[..pos].to_vec();
    evil.push(0xFD);
    evil.extend_from_slice(&1_000_000_000_000u64.to_le_bytes());
    evil.extend_from_slice(&bytes[pos + 1..]);
    let p = c.submit_raw(&evil).expect("sent");
    assert!(matches!(
        c.wait(p).expect("answer"),
        Err(TxError::TooLarge { .. })
    ));
    // Nothing changed, nothing was announced.
    assert!(
        r.wait_change(Duration::from_millis(300))
            .expect("wait")
            .is_empty()
    );
    assert_eq!(r.snapshot().expect("snapshot").version(), a.version);
}

/// The keeper answers from a fixed pool of 4 KiB responses (a resizable pool costs ~200 MB of
/// bookkeeping per client connection); a larger answer — here 3,000 created ids — arrives
/// whole in parts, also when several are in flight at once, and a continuation naming no
/// answer is refused with an error, not a hang.
#[test]
fn large_answers_arrive_whole_in_parts() {
    let mut t = TestSession::new("big");
    t.start_keeper();
    let s = t.session();
    let mut c = with_home(t.home.path(), || Client::connect(&s, "w")).expect("connect");
    let big = |tag: usize| {
        let mut tx = Transaction::new();
        for k in 0..3000 {
            tx.create(Kind::Scene, &format!("s{tag}_{k}"), None);
        }
        tx
    };
    let a = c.transact(&big(0)).expect("committed");
    assert_eq!(a.created.len(), 3000);
    assert_eq!(a.changes.len(), 3000);
    let pending: Vec<_> = (1..=3)
        .map(|k| c.submit(&big(k)).expect("submit"))
        .collect();
    let mut versions = Vec::new();
    for p in pending {
        let b = c.wait(p).expect("answer").expect("committed");
        assert_eq!(b.created.len(), 3000);
        assert!(b.created.iter().all(|id| !a.created.contains(id)));
        versions.push(b.version);
    }
    assert_eq!(versions, vec![a.version + 1, a.version + 2, a.version + 3]);
    let mut evil = vec![0xFF, b'M', b'O', b'R', b'E'];
    evil.extend_from_slice(&u64::MAX.to_le_bytes());
    let p = c.submit_raw(&evil).expect("sent");
    assert!(matches!(c.wait(p), Err(ClientError::Ipc { .. })));
    // The client still works.
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "after", None);
    assert_eq!(c.transact(&tx).expect("committed").version, a.version + 4);
    // The whole model (12,001 objects, hundreds of parts fetched 16 at a time) equals what a
    // reader of the same version sees.
    let snap = c.snapshot().expect("snapshot");
    assert!(snap.model.len() > 100 * 4096, "{} bytes", snap.model.len());
    let model = robosim_instance_space::journal::decode_store(&snap.model).expect("decode");
    assert_eq!(model.version, a.version + 4);
    let r = with_home(t.home.path(), || Reader::attach(&s, "r")).expect("attach");
    let rs = r.snapshot().expect("snapshot");
    assert_eq!(rs.version(), model.version);
    assert_eq!(rs.len(), model.objects().count());
    assert!(
        model
            .objects()
            .all(|o| rs.index_of(o.id).is_some_and(|i| rs.name(i) == o.name))
    );
}

#[test]
fn sessions_are_isolated_and_private_to_the_user() {
    let mut a = TestSession::new("isoa");
    let b = TestSession::new("isob");
    a.start_keeper();
    let sa = a.session();
    let sb = b.session();
    // Session b has no keeper: a reader there must not find session a's.
    assert!(matches!(
        with_home(b.home.path(), || Reader::attach(&sb, "r")),
        Err(robosim_instance_space::ReaderError::NoKeeper { .. })
    ));
    let mut c = with_home(a.home.path(), || Client::connect(&sa, "w")).expect("connect");
    c.transact(&scene_tx()).expect("commit");
    let _r = with_home(a.home.path(), || Reader::attach(&sa, "r")).expect("attach");
    use std::os::unix::fs::PermissionsExt;
    let files = sa.shm_files();
    assert!(files.len() > 5, "session a has shared memory: {files:?}");
    for (path, mode) in &files {
        assert_eq!(mode & 0o077, 0, "{} is mode {mode:o}", path.display());
    }
    // Session b's failed attach made only its own (private) node files.
    for (path, mode) in sb.shm_files() {
        assert_eq!(mode & 0o077, 0, "{} is mode {mode:o}", path.display());
        assert!(!files.iter().any(|(p, _)| *p == path));
    }
    for dir in [sa.dir().to_owned(), sa.data_dir(), sa.run_dir()] {
        let mode = std::fs::metadata(&dir).expect("dir").permissions().mode() & 0o777;
        assert_eq!(mode, 0o700, "{} is mode {mode:o}", dir.display());
    }
    for e in std::fs::read_dir(sa.data_dir())
        .expect("data dir")
        .flatten()
    {
        let mode = e.metadata().expect("meta").permissions().mode() & 0o777;
        assert_eq!(mode, 0o600, "{} is mode {mode:o}", e.path().display());
    }
}

#[test]
fn a_held_snapshot_keeps_its_version_and_changes_since_answers_from_the_log() {
    let mut t = TestSession::new("snap");
    t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "w").expect("connect");
    let a = c.transact(&scene_tx()).expect("scene");
    let body = a.created[1];
    let mut r = Reader::attach(&s, "r").expect("attach");
    let old = r.snapshot().expect("snapshot");
    let i = old.index_of(body).expect("body");
    let mut versions = Vec::new();
    for k in 1..=5 {
        let mut pose = IDENTITY;
        pose[3] = k as f64;
        let mut tx = Transaction::new();
        tx.set_pose(body, pose);
        versions.push(c.transact(&tx).expect("commit").version);
    }
    while r.snapshot().expect("snapshot").version() < *versions.last().expect("v") {
        r.wait_change(Duration::from_secs(5)).expect("wait");
    }
    let new = r.snapshot().expect("snapshot");
    // The old snapshot still shows its own version, in the same shared memory.
    assert_eq!(old.version(), a.version);
    assert_eq!(old.poses()[i].pose[3], 0.0);
    assert_eq!(new.poses()[i].pose[3], 5.0);
    let since = r.changes_since(versions[1]).expect("changes since");
    assert_eq!(
        since.iter().map(|c| c.version).collect::<Vec<_>>(),
        versions[2..].to_vec()
    );
    assert!(
        since
            .iter()
            .all(|c| c.ids == vec![body] && c.aspects == robosim_instance_space::aspect::POSE)
    );
    assert!(
        matches!(
            r.changes_since(0),
            Err(robosim_instance_space::ReaderError::ChangesLost { .. })
        ),
        "versions before the reader attached are not claimed"
    );
}

#[test]
fn up_ps_down_start_only_the_named_components_and_state_names_its_structure_version() {
    let t = TestSession::new("up");
    let run = |args: &[&str]| {
        let out = t.command(ROBOSIM).args(args).output().expect("run robosim");
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned()
                + &String::from_utf8_lossy(&out.stderr),
        )
    };
    // Only what this build has is offered (issue #19 item 11).
    let (ok, text) = run(&["up", "demo", "--with", "editor", "--session", &t.name]);
    assert!(
        !ok && text.contains("invalid value 'editor'") && text.contains("simulator, display"),
        "{text}"
    );
    let (ok, text) = run(&["up", "demo", "--with", "simulator", "--session", &t.name]);
    assert!(ok, "{text}");
    let (ok, ps) = run(&["ps", "--session", &t.name]);
    assert!(ok);
    let roles: Vec<&str> = ps
        .lines()
        .skip(2)
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert_eq!(roles, vec!["space", "simulator"], "{ps}");
    let s = t.session();
    let mut c = Client::connect(&s, "w").expect("connect");
    let r = Reader::attach(&s, "r").expect("attach");
    let snap = r.snapshot().expect("snapshot");
    let link = snap.find("link1").expect("demo scene has link1");
    let mut tx = Transaction::new();
    tx.set_joint(snap.rec(link).id, 0.5);
    let v = c.transact(&tx).expect("commit").version;
    let mut state =
        robosim_instance_space::state::StateSubscriber::open(&s, "simulator", "test-state")
            .expect("state service");
    let deadline = Instant::now() + Duration::from_secs(20);
    let rec = loop {
        if let Some(rec) = state
            .wait(Duration::from_millis(100))
            .expect("state")
            .into_iter()
            .find(|r| r.header.structure_version >= v)
        {
            break rec;
        }
        assert!(Instant::now() < deadline, "no state for version {v}");
    };
    let j = rec
        .joints
        .iter()
        .find(|j| j.id == snap.rec(link).id)
        .expect("link1 state");
    assert_eq!(j.q, 0.5);
    let (ok, text) = run(&["down", "--session", &t.name]);
    assert!(ok, "{text}");
    assert!(
        text.contains("stopped simulator") && text.contains("stopped space"),
        "{text}"
    );
    assert!(
        text.find("stopped simulator") < text.find("stopped space"),
        "components stop before the keeper: {text}"
    );
    let (_, ps) = run(&["ps", "--session", &t.name]);
    assert_eq!(ps.lines().count(), 2, "nothing left running: {ps}");
}

/// Issue #20 item 9 (`journal_bit_flip_is_said_aloud_and_kept`): one flipped bit in the
/// middle of the journal made recovery cut every later record, and `up` said only "model
/// version 299" (the note was in `run/space.log`). Now the cut is kept as a journal file of its
/// own, `up` says on its own stderr what was lost (versions, count, where the copy is), and
/// `robosim journal inspect` lists the kept records. Nothing before the flip is lost.
#[test]
fn journal_bit_flip_is_said_aloud_by_up_and_the_cut_is_kept() {
    let mut t = TestSession::new("jf");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "writer").expect("connect");
    let scene = create_scene(&mut c); // version 1
    for chunk in (1..=600)
        .collect::<Vec<u32>>()
        .chunks(Client::MAX_IN_FLIGHT)
    {
        let pending: Vec<_> = chunk
            .iter()
            .map(|k| {
                let mut tx = Transaction::new();
                tx.set_name(scene, &format!("n{k}")); // version k + 1
                c.submit(&tx).expect("submit")
            })
            .collect();
        for p in pending {
            c.wait(p).expect("answer").expect("committed");
        }
    }
    drop(c);
    t.kill9_and_reap(keeper);

    // Flip one bit in the payload of the record of version 300.
    let journal = std::fs::read_dir(s.data_dir())
        .expect("data dir")
        .flatten()
        .map(|e| e.path())
        .find(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("journal-"))
        })
        .expect("a journal");
    let mut bytes = std::fs::read(&journal).expect("read journal");
    let (records, damaged) = robosim_instance_space::journal::scan_records(&bytes, 8);
    assert_eq!(
        (records.len(), damaged),
        (601, 0),
        "versions 1..=601, intact"
    );
    let r = records
        .iter()
        .find(|r| r.version == 300)
        .expect("version 300");
    bytes[r.offset + 16 + r.len / 2] ^= 0x10;
    std::fs::write(&journal, &bytes).expect("write journal");
    // The keeper keeps two copies by default; damage the mirror's copy of the same record
    // too (with one copy damaged, recovery repairs it: instance-space/tests/journal.rs).
    let mirror = journal.with_extension("mirror");
    let mut m = std::fs::read(&mirror).expect("the journal's mirror");
    m[r.offset + 16 + r.len / 2] ^= 0x10;
    std::fs::write(&mirror, &m).expect("write mirror");

    let _down = t.down_when_dropped();
    let out = t.robosim(&["up", "demo", "--session", &t.name]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    for want in [
        "RECOVERY LOST DATA",
        "recovered only up to version 299",
        "versions 300..=601 not replayed: 301 readable record(s)",
        "robosim journal inspect",
    ] {
        assert!(
            err.contains(want),
            "`up` must say {want:?}; it said:\n{err}"
        );
    }
    let copy = err
        .lines()
        .find_map(|l| l.trim().strip_prefix("The cut is kept in "))
        .map(PathBuf::from)
        .expect("the copy's path");
    assert!(
        copy.starts_with(s.data_dir().join("lost")),
        "{}",
        copy.display()
    );
    let inspect = t
        .command(ROBOSIM)
        .args(["journal", "inspect"])
        .arg(&copy)
        .output()
        .expect("run journal inspect");
    let listing = String::from_utf8_lossy(&inspect.stdout);
    assert!(inspect.status.success(), "{listing}");
    assert!(listing.contains("301 readable record(s)"), "{listing}");
    assert!(
        listing.contains(": version 301 (") && listing.contains(": version 601 ("),
        "{listing}"
    );
    assert!(
        listing.contains("set_name"),
        "operations are named: {listing}"
    );

    // Everything before the flip is there.
    let r = Reader::attach(&s, "after").expect("attach");
    let snap = r.snapshot().expect("snapshot");
    assert_eq!(snap.version(), 299);
    assert_eq!(snap.name(snap.index_of(scene).expect("scene")), "n298");
}

/// Issue 18 §3: the poses are published in chunks of `POSE_CHUNK` objects. A one-body pose
/// transaction republishes only its chunk (and the small head); a reader's new snapshot reuses
/// the samples of the chunks that did not change (the very same shared memory), a held
/// snapshot keeps its own poses, a late joiner gets the whole state, and an object added at
/// the end touches only the last chunk.
#[test]
fn a_pose_change_republishes_only_its_chunk_and_readers_reuse_the_others() {
    use robosim_instance_space::layout::POSE_CHUNK;
    let mut t = TestSession::new("chunks");
    t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "w").expect("connect");
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "scene", None);
    // Three chunks, the last one partly full.
    let n = 2 * POSE_CHUNK + 88;
    for k in 0..n {
        tx.create(Kind::Solid, &format!("body{k}"), Some(scene));
    }
    let built = c.transact(&tx).expect("build");
    let mut r = Reader::attach(&s, "r").expect("attach");
    let old = r.snapshot().expect("snapshot");
    assert_eq!(old.len(), n + 1);
    // A body in the middle chunk.
    let body = built.created[POSE_CHUNK + 10];
    let i = old.index_of(body).expect("body");
    assert_eq!(i / POSE_CHUNK, 1, "the body is in the middle chunk");
    let mut pose = IDENTITY;
    pose[3] = 7.0;
    let mut tx = Transaction::new();
    tx.set_pose(body, pose);
    let moved = c.transact(&tx).expect("move");
    while r.snapshot().expect("snapshot").version() < moved.version {
        r.wait_change(Duration::from_secs(5)).expect("wait");
    }
    let new = r.snapshot().expect("snapshot");
    assert_eq!(new.version(), moved.version);
    assert_eq!(
        old.pose(i).pose[3],
        0.0,
        "a held snapshot keeps its version"
    );
    assert_eq!(new.pose(i).pose[3], 7.0);
    assert_eq!(new.world_pose(i)[3], 7.0);
    // Unchanged chunks are the same samples; the changed one is new.
    let first = 0;
    let last = n; // the last object (index n: the scene is index 0)
    assert!(std::ptr::eq(old.pose(first), new.pose(first)));
    assert!(std::ptr::eq(old.pose(last), new.pose(last)));
    assert!(!std::ptr::eq(old.pose(i), new.pose(i)));
    // The whole-array view agrees with the per-record one.
    let all = new.poses();
    assert_eq!(all.len(), n + 1);
    assert!((0..=n).all(|k| all[k] == *new.pose(k)));
    assert_eq!(new.object(i).pose.pose[3], 7.0);
    // A late joiner gets the whole state of the newest version.
    // It reads them from one pose base, subscribing to no chunk service.
    let mut late = Reader::attach(&s, "late").expect("late joiner");
    let ls = late.snapshot().expect("snapshot");
    assert_eq!(ls.version(), moved.version);
    assert_eq!(ls.poses(), new.poses());
    assert_eq!(
        late.pose_chunks_followed(),
        0,
        "attach opened chunk services"
    );
    // A change in one chunk: the late joiner follows that chunk alone and keeps the others
    // from its base (the same shared memory as in its first snapshot).
    let mut tx = Transaction::new();
    pose[3] = 9.0;
    tx.set_pose(body, pose);
    let again = c.transact(&tx).expect("move again");
    while late.snapshot().expect("snapshot").version() < again.version {
        late.wait_change(Duration::from_secs(5)).expect("wait");
    }
    let ls2 = late.snapshot().expect("snapshot");
    assert_eq!(ls2.pose(i).pose[3], 9.0);
    assert_eq!(ls.pose(i).pose[3], 7.0, "the late joiner's held snapshot");
    assert_eq!(late.pose_chunks_followed(), 1);
    assert!(std::ptr::eq(ls.pose(first), ls2.pose(first)));
    assert!(std::ptr::eq(ls.pose(last), ls2.pose(last)));
    let all2 = ls2.poses();
    assert!((0..=n).all(|k| all2[k] == *ls2.pose(k)));
    while r.snapshot().expect("snapshot").version() < again.version {
        r.wait_change(Duration::from_secs(5)).expect("wait");
    }
    let r2 = r.snapshot().expect("snapshot");
    assert_eq!(r2.poses(), all2);
    drop((late, ls, ls2));
    // An object added at the end (the largest id sorts last) touches only the last chunk.
    let mut tx = Transaction::new();
    tx.create(Kind::Solid, "appended", Some(built.created[0].into()));
    let added = c.transact(&tx).expect("append");
    while r.snapshot().expect("snapshot").version() < added.version {
        r.wait_change(Duration::from_secs(5)).expect("wait");
    }
    let grown = r.snapshot().expect("snapshot");
    assert_eq!(grown.len(), n + 2);
    assert_eq!(grown.pose(i).pose[3], 9.0);
    assert!(std::ptr::eq(new.pose(first), grown.pose(first)));
    assert!(std::ptr::eq(r2.pose(i), grown.pose(i)));
    assert!(!std::ptr::eq(new.pose(last), grown.pose(last)));
    assert_eq!(grown.name(n + 1), "appended");
}

/// A late joiner of a large model takes the pose base an earlier joiner had the keeper publish,
/// and opens the service of the one chunk that moved since, rather than have the keeper copy
/// every pose again (at 10⁵ bodies 11 MB, milliseconds); when more than a few chunks moved
/// since, it asks for a fresh base. Either way its snapshot is the newest version, equal to a
/// follower's.
#[test]
fn a_late_joiner_reuses_a_published_pose_base_and_opens_only_the_chunks_moved_since() {
    use robosim_instance_space::layout::POSE_CHUNK;
    let mut t = TestSession::new("stalebase");
    t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "w").expect("connect");
    let scene = create_scene(&mut c);
    // More records than a chunk service's open is worth (the reader's RECORDS_PER_OPEN, 16384):
    // 17,000 bodies, 67 chunks.
    let n = 17_000;
    let mut bodies = Vec::with_capacity(n);
    for k in 0..n / 1_000 {
        let mut tx = Transaction::new();
        for j in 0..1_000 {
            tx.create(
                Kind::Solid,
                &format!("b{}", k * 1_000 + j),
                Some(scene.into()),
            );
        }
        bodies.extend(c.transact(&tx).expect("build").created);
    }
    let mut follower = Reader::attach(&s, "follower").expect("attach");
    assert_eq!(
        follower.pose_bases_asked(),
        1,
        "the first joiner asks for a base"
    );
    let follow = |r: &mut Reader, v: u64| {
        while r.snapshot().expect("snapshot").version() < v {
            r.wait_change(Duration::from_secs(5)).expect("wait");
        }
        r.snapshot().expect("snapshot")
    };
    let move_to = |c: &mut Client, which: &[u64], x: f64| {
        let mut tx = Transaction::new();
        for &b in which {
            let mut pose = IDENTITY;
            pose[3] = x;
            tx.set_pose(b, pose);
        }
        c.transact(&tx).expect("move").version
    };
    // One body moves: one chunk differs from the published base.
    let one = bodies[5 * POSE_CHUNK + 3];
    let v = move_to(&mut c, &[one], 4.0);
    let late = Reader::attach(&s, "late").expect("late joiner");
    let ls = late.snapshot().expect("snapshot");
    assert_eq!(ls.version(), v);
    assert_eq!(late.pose_bases_asked(), 0, "the published base served");
    assert_eq!(
        late.pose_chunks_followed(),
        1,
        "only the moved chunk is opened"
    );
    assert_eq!(ls.pose(ls.index_of(one).expect("body")).pose[3], 4.0);
    let fs = follow(&mut follower, v);
    assert_eq!(ls.poses(), fs.poses());
    // Ten bodies in ten chunks move: more than a reader opens services for; a new joiner asks
    // for a fresh base and follows no chunk.
    let ten: Vec<u64> = (0..10).map(|k| bodies[k * 6 * POSE_CHUNK + 1]).collect();
    let v = move_to(&mut c, &ten, -2.0);
    let later = Reader::attach(&s, "later").expect("later joiner");
    let ls = later.snapshot().expect("snapshot");
    assert_eq!(ls.version(), v);
    assert_eq!(later.pose_bases_asked(), 1);
    assert_eq!(later.pose_chunks_followed(), 0);
    let fs = follow(&mut follower, v);
    assert_eq!(ls.poses(), fs.poses());
    assert!(
        ten.iter()
            .all(|&b| ls.pose(ls.index_of(b).expect("body")).pose[3] == -2.0)
    );
    assert_eq!(ls.pose(ls.index_of(one).expect("body")).pose[3], 4.0);
}

/// A structural change — a rename, a colour, the selection, a delete, an object appended —
/// republishes the object chunks it changed, not the whole objects segment: a following reader
/// keeps every other chunk as the same memory, and asks for the objects base only to attach;
/// what it assembles is what a late joiner reads from a base.
#[test]
fn a_structural_change_republishes_only_its_object_chunk_and_readers_reuse_the_others() {
    use robosim_instance_space::layout::OBJECT_CHUNK;
    let mut t = TestSession::new("ochunks");
    t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "w").expect("connect");
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "scene", None);
    // Four chunks, the last one partly full.
    let n = 3 * OBJECT_CHUNK + 40;
    for k in 0..n {
        tx.create(Kind::Solid, &format!("body{k}"), Some(scene));
    }
    let built = c.transact(&tx).expect("build");
    // Nothing but the build since: the objects head a late joiner finds carries every chunk.
    let mut r = Reader::attach(&s, "r").expect("attach");
    let asked = r.objects_bases_asked();
    assert_eq!(asked, 0, "the build's objects head carried every chunk");
    let old = r.snapshot().expect("snapshot");
    assert_eq!(old.len(), n + 1);
    let body = built.created[OBJECT_CHUNK + 10];
    let i = old.index_of(body).expect("body");
    assert_eq!(i / OBJECT_CHUNK, 1, "the body is in the second chunk");
    let (first, last) = (0, n);
    // A rename in the second chunk.
    let mut tx = Transaction::new();
    tx.set_name(body, "renamed");
    let renamed = follow_tx(&mut r, &mut c, &tx);
    assert_eq!(renamed.name(i), "renamed");
    // (created[0] is the scene)
    assert_eq!(
        old.name(i),
        format!("body{}", OBJECT_CHUNK + 9),
        "a held snapshot"
    );
    assert_eq!(renamed.find("renamed"), Some(i));
    assert!(std::ptr::eq(old.rec(first), renamed.rec(first)));
    assert!(std::ptr::eq(old.rec(last), renamed.rec(last)));
    assert!(!std::ptr::eq(old.rec(i), renamed.rec(i)));
    // No pose moved: every pose chunk is the same memory (the last, partly full one was
    // republished by every structural change until stop 35).
    assert!(std::ptr::eq(old.pose(last), renamed.pose(last)));
    assert!(std::ptr::eq(old.pose(i), renamed.pose(i)));
    // A colour in the last chunk.
    let mut tx = Transaction::new();
    let mut look = robosim_instance_space::Appearance::default();
    look.color = [0.1, 0.2, 0.3, 1.0];
    tx.set_appearance(built.created[n], look);
    let coloured = follow_tx(&mut r, &mut c, &tx);
    assert_eq!(coloured.rec(last).color, [0.1, 0.2, 0.3, 1.0]);
    assert!(std::ptr::eq(renamed.rec(i), coloured.rec(i)));
    assert!(!std::ptr::eq(renamed.rec(last), coloured.rec(last)));
    // The selection: the header alone.
    let mut tx = Transaction::new();
    tx.select(Some(body.into()), None);
    let selected = follow_tx(&mut r, &mut c, &tx);
    assert_eq!(selected.selection().map(|s| s.object), Some(body));
    assert!(
        (0..=n)
            .step_by(97)
            .all(|k| std::ptr::eq(coloured.rec(k), selected.rec(k)))
    );
    assert_eq!(
        r.objects_bases_asked(),
        asked,
        "following asked for the objects base"
    );
    // A late joiner takes the chunks the last heads did not carry from one objects base, and
    // reads what the follower assembled.
    let mut late = Reader::attach(&s, "late").expect("late joiner");
    assert_eq!(late.objects_bases_asked(), 1);
    let same = |a: &robosim_instance_space::Snapshot, b: &robosim_instance_space::Snapshot| {
        assert_eq!(a.version(), b.version());
        assert_eq!(a.objects(), b.objects());
        assert!((0..a.len()).all(|k| a.name(k) == b.name(k) && a.rec(k) == b.rec(k)));
        assert_eq!(a.selection(), b.selection());
    };
    same(&late.snapshot().expect("snapshot"), &selected);
    // A delete in the first chunk shifts every object after it: every chunk is new, and the
    // follower still reads what the keeper holds.
    let mut tx = Transaction::new();
    tx.delete(built.created[3], false);
    let shrunk = follow_tx(&mut r, &mut c, &tx);
    assert_eq!(shrunk.len(), n);
    assert_eq!(shrunk.index_of(built.created[3]), None);
    assert_eq!(shrunk.name(shrunk.index_of(body).expect("body")), "renamed");
    // An object appended (the largest id sorts last) touches only the last chunk.
    let mut tx = Transaction::new();
    tx.create(Kind::Solid, "appended", Some(built.created[0].into()));
    let grown = follow_tx(&mut r, &mut c, &tx);
    assert_eq!(grown.len(), n + 1);
    assert_eq!(grown.name(n), "appended");
    assert!(std::ptr::eq(shrunk.rec(first), grown.rec(first)));
    assert!(std::ptr::eq(
        shrunk.rec(2 * OBJECT_CHUNK),
        grown.rec(2 * OBJECT_CHUNK)
    ));
    assert_eq!(
        r.objects_bases_asked(),
        asked,
        "following asked for the objects base"
    );
    let late = follow(&mut late, grown.version());
    same(&late, &grown);
    let fresh = Reader::attach(&s, "fresh").expect("fresh");
    same(&fresh.snapshot().expect("snapshot"), &grown);
}

/// Commits `tx` through `c` and waits until `r` has its version.
fn follow_tx(
    r: &mut Reader,
    c: &mut Client,
    tx: &Transaction,
) -> std::rc::Rc<robosim_instance_space::Snapshot> {
    let v = c.transact(tx).expect("commit").version;
    let snap = follow(r, v);
    assert_eq!(snap.version(), v);
    snap
}

/// An axis-aligned box of half-size `h`, as a transaction's geometry.
fn cube(h: f64) -> robosim_instance_space::GeometryInput {
    robosim_scene::box_geometry([2.0 * h, 2.0 * h, 2.0 * h])
}

/// Waits until `r` has a snapshot of `version` or newer.
fn follow(r: &mut Reader, version: u64) -> std::rc::Rc<robosim_instance_space::Snapshot> {
    let deadline = Instant::now() + Duration::from_secs(20);
    while r.snapshot().is_none_or(|s| s.version() < version) {
        let _ = r.wait_change(Duration::from_millis(200)).expect("wait");
        assert!(
            Instant::now() < deadline,
            "reader never saw version {version}"
        );
    }
    r.snapshot().expect("snapshot")
}

/// The largest |coordinate| of object `i`'s vertices (a cube's half-size).
fn half_size(snap: &robosim_instance_space::Snapshot, i: usize) -> f64 {
    let g = snap.geometry(i).expect("geometry");
    g.vertices
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()))
}

#[test]
fn geometry_arrives_by_one_base_then_by_updates_and_survives_a_keeper_restart() {
    let mut t = TestSession::new("geom");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "w").expect("connect");
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "scene", None);
    for k in 0..40 {
        let b = tx.create(Kind::Solid, &format!("box{k}"), Some(scene));
        tx.set_geometry(b, Some(cube(0.5 + k as f64 * 0.01)));
    }
    let built = c.transact(&tx).expect("build");
    // A late joiner takes every geometry from one base (no service per object).
    let mut r = Reader::attach(&s, "r").expect("attach");
    assert_eq!(r.geometry_bases_asked(), 1);
    let first = r.snapshot().expect("snapshot");
    for k in 0..40 {
        let i = first.find(&format!("box{k}")).expect("box");
        assert_eq!(half_size(&first, i), 0.5 + k as f64 * 0.01);
        assert_eq!(
            first.geometry(i).expect("g").header.id,
            built.created[k + 1]
        );
    }
    // One geometry changed: it comes by the update, the others stay where they were.
    let changed = built.created[5];
    let mut tx = Transaction::new();
    tx.set_geometry(changed, Some(cube(2.0)));
    let a = c.transact(&tx).expect("regrow");
    let second = follow(&mut r, a.version);
    let i = second.index_of(changed).expect("changed");
    assert_eq!(half_size(&second, i), 2.0);
    assert_eq!(
        half_size(&first, i),
        0.5 + 4.0 * 0.01,
        "a held snapshot keeps its geometry"
    );
    let j = second.find("box20").expect("box20");
    assert!(std::ptr::eq(
        first.geometry(j).expect("g").vertices,
        second.geometry(j).expect("g").vertices
    ));
    assert_eq!(r.geometry_bases_asked(), 1, "an update was enough");
    // A pose-only change keeps every geometry.
    let mut tx = Transaction::new();
    tx.set_pose(changed, IDENTITY);
    let moved = c.transact(&tx).expect("move");
    let third = follow(&mut r, moved.version);
    assert!(std::ptr::eq(
        second.geometry(i).expect("g").vertices,
        third.geometry(i).expect("g").vertices
    ));
    // A change too large for an update (1,000 boxes ≈ 1.5 MiB): the reader asks for a base.
    let mut tx = Transaction::new();
    for k in 0..1000 {
        let b = tx.create(
            Kind::Solid,
            &format!("more{k}"),
            Some(built.created[0].into()),
        );
        tx.set_geometry(b, Some(cube(0.25)));
    }
    let grown = c.transact(&tx).expect("grow");
    let fourth = follow(&mut r, grown.version);
    assert_eq!(r.geometry_bases_asked(), 2);
    assert_eq!(fourth.len(), 1041);
    let with_geometry = (0..fourth.len())
        .filter(|&i| fourth.geometry(i).is_some())
        .count();
    assert_eq!(with_geometry, 1040);
    assert_eq!(
        half_size(&fourth, fourth.find("more999").expect("more")),
        0.25
    );
    assert_eq!(
        half_size(&fourth, fourth.index_of(changed).expect("c")),
        2.0
    );
    // Deleting an object with geometry, and removing another's geometry.
    let mut tx = Transaction::new();
    tx.delete(built.created[7], false);
    tx.set_geometry(built.created[8], None);
    let cut = c.transact(&tx).expect("cut");
    let fifth = follow(&mut r, cut.version);
    assert!(fifth.index_of(built.created[7]).is_none());
    assert!(
        fifth
            .geometry(fifth.index_of(built.created[8]).expect("8"))
            .is_none()
    );
    assert_eq!(r.geometry_bases_asked(), 2);
    drop((first, second, third, fourth, fifth));
    // A keeper restart: the surviving reader takes the new keeper's base.
    kill9(keeper);
    t.start_keeper();
    let mut c = Client::connect(&s, "after").expect("connect");
    let mut tx = Transaction::new();
    tx.set_geometry(changed, Some(cube(3.0)));
    let after = c.transact(&tx).expect("after restart");
    let sixth = follow(&mut r, after.version);
    assert_eq!(half_size(&sixth, sixth.index_of(changed).expect("c")), 3.0);
    assert_eq!(
        half_size(&sixth, sixth.find("box20").expect("b")),
        0.5 + 0.2
    );
    assert_eq!(r.geometry_bases_asked(), 3);
}

/// The journal's log and mirror of a session (the newest journal).
fn journal_copies(s: &Session) -> (PathBuf, PathBuf) {
    let mut logs: Vec<PathBuf> = std::fs::read_dir(s.data_dir())
        .expect("data dir")
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("journal-"))
                && p.extension().is_some_and(|x| x == "log")
        })
        .collect();
    logs.sort();
    let log = logs.pop().expect("a journal");
    let mirror = log.with_extension("mirror");
    (log, mirror)
}

/// "model version N" from `robosim up`'s stdout.
fn up_version(stdout: &str) -> u64 {
    stdout
        .split("model version ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no model version in: {stdout}"))
}

/// Issue 34 item 1, across processes: after `kill -9` of the keeper, the journal's `.log` cut
/// to half, the `.mirror` intact. `up` recovered to version 57 of 201, said nothing, and the
/// checkpoint `down` wrote deleted the mirror: 144 acknowledged records gone. Now `up` has all
/// 201, says the log was repaired from the mirror, and after `down` and another `up` all 201
/// are still there.
#[test]
fn half_truncated_journal_log_after_kill9_loses_nothing_through_up_and_down() {
    let mut t = TestSession::new("jh");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "writer").expect("connect");
    let scene = create_scene(&mut c);
    rename_scene(&mut c, scene, 200);
    drop(c);
    t.kill9_and_reap(keeper);
    let (log, mirror) = journal_copies(&s);
    let len = std::fs::metadata(&log).expect("log").len();
    assert_eq!(std::fs::metadata(&mirror).expect("mirror").len(), len);
    std::fs::OpenOptions::new()
        .write(true)
        .open(&log)
        .expect("open log")
        .set_len(len / 2)
        .expect("cut the log");

    let _down = t.down_when_dropped();
    let up = |t: &TestSession| {
        let out = t.robosim(&["up", "demo", "--session", &t.name]);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{err}");
        (up_version(&String::from_utf8_lossy(&out.stdout)), err)
    };
    let (v, err) = up(&t);
    assert_eq!(v, 201, "every acknowledged version: {err}");
    assert!(
        err.contains("were repaired from the mirror") && err.contains("..=201)"),
        "`up` says the copies disagreed and what was repaired:\n{err}"
    );
    assert!(!err.contains("RECOVERY LOST DATA"), "{err}");
    let out = t.robosim(&["down", "--session", &t.name]);
    assert!(out.status.success());
    let (v, err) = up(&t);
    assert_eq!(v, 201, "after down and up: {err}");
}

/// Issue 34 item 2: two keepers started at the same instant on a fresh session. The loser died
/// on a raw iceoryx2 error, and the survivor wrote its mirror into a file the loser had
/// replaced (the mirror on disk stayed 8 bytes while writes were acknowledged). Now one keeper
/// runs, the other says which pid holds the session's keeper lock, and the mirror on disk
/// grows with the log.
#[test]
fn two_keepers_started_at_once_one_runs_and_the_other_names_the_holder() {
    let mut t = TestSession::new("k2");
    let logs: Vec<PathBuf> = (0..2).map(|k| t.file(&format!("keeper{k}.err"))).collect();
    let pids: Vec<u32> = logs
        .iter()
        .map(|log| {
            let child = t
                .command(ROBOSIM)
                .args(["space", "--session", &t.name])
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(log).expect("log"))
                .spawn()
                .expect("start keeper");
            let pid = child.id();
            t.children.push(child);
            pid
        })
        .collect();
    // Exactly one exits, with an error; the other serves.
    let start = Instant::now();
    let loser = loop {
        let exited: Vec<usize> = (0..2)
            .filter(|&k| {
                let c = t
                    .children
                    .iter_mut()
                    .find(|c| c.id() == pids[k])
                    .expect("ours");
                c.try_wait().expect("try_wait").is_some()
            })
            .collect();
        if let [k] = exited[..] {
            break k;
        }
        assert!(exited.len() < 2, "both keepers exited");
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "neither keeper refused to start"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let winner = pids[1 - loser];
    let err = std::fs::read_to_string(&logs[loser]).expect("loser's stderr");
    assert!(
        err.contains(&format!("already has a keeper (pid {winner}")) && err.contains("keeper.lock"),
        "the loser names the holder {winner}:\n{err}"
    );
    assert!(!err.contains("iceoryx2"), "no raw iceoryx2 error:\n{err}");
    let s = t.session();
    let start = Instant::now();
    let mut c = loop {
        if let Ok(c) = Client::connect(&s, "writer") {
            break c;
        }
        assert!(start.elapsed() < Duration::from_secs(30), "keeper not up");
        std::thread::sleep(Duration::from_millis(20));
    };
    let scene = create_scene(&mut c);
    rename_scene(&mut c, scene, 20);
    let (log, mirror) = journal_copies(&s);
    let (l, m) = (
        std::fs::read(&log).expect("log"),
        std::fs::read(&mirror).expect("mirror"),
    );
    assert!(m.len() > 8, "the mirror on disk grows: {} bytes", m.len());
    assert_eq!(l, m, "the mirror on disk holds what the log holds");
    assert!(robosim_instance_space::pid_alive(winner));
}

/// Issue 34 (messages and leftovers): `kill -9` of the keeper left 34–48 files in /dev/shm that
/// `down` on the dead session did not remove ("nothing running"). Now `down` runs iceoryx2's
/// dead-node cleanup and removes what is left of the session: none of its files remain.
#[test]
fn down_after_kill9_of_the_keeper_removes_the_sessions_shared_memory() {
    let mut t = TestSession::new("dl");
    let keeper = t.start_keeper();
    let s = t.session();
    {
        let mut c = Client::connect(&s, "writer").expect("connect");
        create_scene(&mut c);
        let r = Reader::attach(&s, "reader").expect("attach");
        assert!(r.snapshot().is_some());
    }
    t.kill9_and_reap(keeper);
    let left = s.shm_files().len();
    assert!(left > 0, "a killed keeper leaves shared memory behind");
    let out = t.robosim(&["down", "--session", &t.name]);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{text}");
    let files = s.shm_files();
    assert!(
        files.is_empty(),
        "{left} files before `down`, {} after: {files:?}\n{text}",
        files.len()
    );
    assert!(
        text.contains(&format!("removed {left} shared-memory file(s)")),
        "{text}"
    );
}

/// Issue 34 item 1: both journal files deleted after `kill -9` (the scene note kept) made the
/// next `up` start silently at version 1 with the scene loaded again. The journal control
/// file names the journal and its first version: the keeper refuses, `up` says why, naming
/// the files, and changes nothing; `up --fresh` moves what is left aside and starts over.
#[test]
fn vanished_journal_files_are_refused_by_up_naming_them() {
    let mut t = TestSession::new("jv");
    let keeper = t.start_keeper();
    let s = t.session();
    let mut c = Client::connect(&s, "writer").expect("connect");
    create_scene(&mut c);
    drop(c);
    t.kill9_and_reap(keeper);
    let (log, mirror) = journal_copies(&s);
    std::fs::remove_file(&log).expect("remove log");
    std::fs::remove_file(&mirror).expect("remove mirror");
    let _down = t.down_when_dropped();
    let out = t.robosim(&["up", "demo", "--session", &t.name]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !out.status.success(),
        "`up` must not start from nothing:\n{err}"
    );
    let name = log
        .file_name()
        .expect("name")
        .to_string_lossy()
        .into_owned();
    for want in [name.as_str(), "is missing", "journal.control", "--fresh"] {
        assert!(err.contains(want), "{want:?} in:\n{err}");
    }
    assert!(!log.exists() && !mirror.exists());
    let out = t.robosim(&["up", "demo", "--session", &t.name, "--fresh"]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    assert!(err.contains("the saved model was moved to"), "{err}");
}
