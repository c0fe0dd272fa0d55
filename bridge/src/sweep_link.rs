//! Line pipes to worker processes on other machines, over Zenoh (issue 18 §2, `robosim sweep
//! --remote`; docs/studies.md "Sweeps on other machines").
//!
//! This module knows lines and processes, nothing of studies: a **host**
//! (`robosim sweep-host --listen ENDPOINT --workers N`) starts, per request, one local process
//! from the command it is given and pipes lines between Zenoh and the process's stdin/stdout; a
//! **[`Remote`]** (the coordinator's side, one per host endpoint) asks for such processes and
//! gets a [`Pipe`] for each: lines in, lines out, one end.
//!
//! Keys, under the prefix `--key` (default `robosim`):
//! * `<key>/sweep/host` — the host's liveliness token: while the coordinator sees it the host is
//!   there. It goes when the host ends, or when its link lapses (kill -9 closes the TCP
//!   connection at once; a cut cable after the link lease, 3 s) — every pipe of that host then
//!   ends ("its host is gone"), so the coordinator redoes their jobs elsewhere.
//! * `<key>/sweep/info` (query) → `workers=N`, how many processes the host runs at most.
//! * `<key>/sweep/open` (query, payload the pipe id) → `ok`, or an error (full, cannot start).
//! * `<key>/sweep/coord/<cid>` — the coordinator's liveliness token: when it goes, the host
//!   kills that coordinator's processes.
//! * `<key>/sweep/pipe/<cid>/<n>/in` — `L<line>` a line for the process's stdin, `C` close its
//!   stdin (the worker ends when its input ends), `K` kill it.
//! * `<key>/sweep/pipe/<cid>/<n>/out` — `L<line>` a line the process wrote, then `E<how it
//!   ended>` once. Both directions are one key each, so Zenoh keeps their order.
//!
//! Every put is reliable and blocks on congestion: a line is never dropped while the link is
//! up, and when it is not, the pipe ends.

use crate::{BridgeError, Result, key, zerr};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh::sample::SampleKind;

/// `robosim sweep-host`: runs sweep workers for coordinators on other machines.
#[derive(Debug, Clone)]
pub struct HostArgs {
    /// The Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7448 (only there; no multicast
    /// scouting, no gossip).
    pub listen: String,
    /// Worker processes run at most at once, for all coordinators together [default: one per
    /// core].
    pub workers: Option<usize>,
    /// Key prefix on the Zenoh network (the coordinator's `--remote-key` must match).
    pub key: String,
}

fn check_key(k: &str) -> Result<()> {
    if k.is_empty() || k.contains(['*', '$', '#', '?']) || k.starts_with('/') || k.ends_with('/') {
        return Err(BridgeError::Usage(format!(
            "--key {k:?}: a Zenoh key prefix without wildcards, `?` or a leading or trailing /"
        )));
    }
    Ok(())
}

fn put(z: &zenoh::Session, k: &str, payload: Vec<u8>) -> std::result::Result<(), String> {
    z.put(k, payload)
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .wait()
        .map_err(|e| e.to_string())
}

fn tagged(tag: u8, text: &str) -> Vec<u8> {
    let mut v = Vec::with_capacity(text.len() + 1);
    v.push(tag);
    v.extend_from_slice(text.as_bytes());
    v
}

// ---------------------------------------------------------------------------------------------
// the host

enum HostEvent {
    Info(zenoh::query::Query),
    Open(zenoh::query::Query),
    /// A message for pipe `id` (`<cid>/<n>`).
    In {
        id: String,
        payload: Vec<u8>,
    },
    /// A coordinator's token went: kill its processes.
    CoordinatorGone(String),
    /// Pipe `id`'s process closed its stdout.
    OutputEnded(String),
}

struct Running {
    child: Child,
    stdin: Option<ChildStdin>,
}

/// Runs a host until the process is ended: on each open request, `spawn()` is started with
/// piped stdin/stdout (stderr inherited) and piped to the requesting coordinator. `ready` is
/// called once the host listens.
pub fn host(
    args: &HostArgs,
    spawn: &dyn Fn() -> Command,
    ready: &mut dyn FnMut(&str),
) -> Result<()> {
    check_key(&args.key)?;
    let workers = args.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    });
    if workers == 0 {
        return Err(BridgeError::Usage(
            "--workers 0: a host runs at least one worker".into(),
        ));
    }
    let z = zenoh::open(crate::zenoh_config(Some(&args.listen), None)?)
        .wait()
        .map_err(zerr(format!("listen on {}", args.listen)))?;
    let (tx, rx) = mpsc::channel::<HostEvent>();
    let listening = listen(&z, &args.key, &tx)?;
    ready(&format!(
        "sweep-host: listening on {} as {:?}, {workers} workers at most",
        args.listen, args.key
    ));

    let mut host = Host {
        z: &z,
        workers,
        spawn,
        pipe_prefix: &listening.pipe_prefix,
        tx,
        running: HashMap::new(),
    };
    while let Ok(ev) = rx.recv() {
        match ev {
            HostEvent::Info(q) => {
                let _ = q
                    .reply(q.key_expr().clone(), format!("workers={workers}"))
                    .wait();
            }
            HostEvent::Open(q) => host.open(q),
            HostEvent::In { id, payload } => host.input(&id, &payload),
            HostEvent::CoordinatorGone(cid) => host.coordinator_gone(&cid),
            HostEvent::OutputEnded(id) => {
                if let Some(r) = host.running.remove(&id) {
                    host.end(&id, r);
                }
            }
        }
    }
    Ok(())
}

/// What a host declares on the Zenoh network; kept while it runs.
struct Listening {
    /// `<key>/sweep/pipe/`: the pipes' keys start with it.
    pipe_prefix: String,
    _info: zenoh::query::Queryable<()>,
    _open: zenoh::query::Queryable<()>,
    _inputs: zenoh::pubsub::Subscriber<()>,
    _coords: zenoh::pubsub::Subscriber<()>,
    _token: zenoh::liveliness::LivelinessToken,
}

/// Declares the host's queryables (info, open), its subscribers (the pipes' inputs, the
/// coordinators' tokens), each sending its events to `tx`, and its own liveliness token.
fn listen(z: &zenoh::Session, key_prefix: &str, tx: &mpsc::Sender<HostEvent>) -> Result<Listening> {
    let k = |what: &str| key(key_prefix, &format!("sweep/{what}"));
    let t = tx.clone();
    let _info = z
        .declare_queryable(k("info"))
        .callback(move |q| {
            let _ = t.send(HostEvent::Info(q));
        })
        .wait()
        .map_err(zerr("declare the info queryable"))?;
    let t = tx.clone();
    let _open = z
        .declare_queryable(k("open"))
        .callback(move |q| {
            let _ = t.send(HostEvent::Open(q));
        })
        .wait()
        .map_err(zerr("declare the open queryable"))?;
    let t = tx.clone();
    let pipe_prefix = k("pipe/");
    let prefix = pipe_prefix.clone();
    let _inputs = z
        .declare_subscriber(k("pipe/*/*/in"))
        .callback(move |s| {
            let ke = s.key_expr().as_str();
            if let Some(id) = ke.strip_prefix(&prefix).and_then(|r| r.strip_suffix("/in")) {
                let _ = t.send(HostEvent::In {
                    id: id.to_owned(),
                    payload: s.payload().to_bytes().into_owned(),
                });
            }
        })
        .wait()
        .map_err(zerr("declare the input subscriber"))?;
    let t = tx.clone();
    let coord_prefix = k("coord/");
    let _coords = z
        .liveliness()
        .declare_subscriber(k("coord/*"))
        .callback(move |s| {
            if s.kind() == SampleKind::Delete
                && let Some(cid) = s.key_expr().as_str().strip_prefix(&coord_prefix)
            {
                let _ = t.send(HostEvent::CoordinatorGone(cid.to_owned()));
            }
        })
        .wait()
        .map_err(zerr("declare the coordinator watch"))?;
    let _token = z
        .liveliness()
        .declare_token(k("host"))
        .wait()
        .map_err(zerr("declare the host's token"))?;
    Ok(Listening {
        pipe_prefix,
        _info,
        _open,
        _inputs,
        _coords,
        _token,
    })
}

/// A listening host's state: its processes, by pipe id.
struct Host<'a> {
    z: &'a zenoh::Session,
    workers: usize,
    spawn: &'a dyn Fn() -> Command,
    pipe_prefix: &'a str,
    tx: mpsc::Sender<HostEvent>,
    running: HashMap<String, Running>,
}

impl Host<'_> {
    /// The key pipe `id`'s output goes to.
    fn out_key(&self, id: &str) -> String {
        let pipe_prefix = self.pipe_prefix;
        format!("{pipe_prefix}{id}/out")
    }

    /// A process's end: reaped, its end message sent after its last line.
    fn end(&self, id: &str, mut r: Running) {
        r.stdin = None;
        let how = match r.child.wait() {
            Ok(s) => robosim_instance_space::exit_words(s),
            Err(e) => format!("not waited for: {e}"),
        };
        let _ = put(self.z, &self.out_key(id), tagged(b'E', &how));
        eprintln!("sweep-host: pipe {id}: the worker {how}");
    }

    /// An open request: starts a process for the pipe, or refuses it (malformed, open
    /// already, the host full, the process not started); the answer is the query's reply.
    fn open(&mut self, q: zenoh::query::Query) {
        // "<coordinator>/<n> <floor>": the coordinator's pipes below <floor> ended on
        // its side when it lost this host; those still running here are killed first
        let text = q
            .payload()
            .map(|p| String::from_utf8_lossy(&p.to_bytes()).into_owned())
            .unwrap_or_default();
        let (id, floor) = match text.split_once(' ') {
            Some((id, f)) => (id.to_owned(), f.parse::<u64>().ok()),
            None => (text.clone(), Some(0)),
        };
        let valid = floor.is_some()
            && id.split('/').count() == 2
            && id.split('/').all(|p| {
                !p.is_empty()
                    && p.chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
            });
        if let (true, Some(floor), Some((cid, _))) = (valid, floor, id.split_once('/')) {
            self.kill_stale(cid, floor);
        }
        let workers = self.workers;
        let answer = if !valid {
            Err(format!(
                "pipe request {text:?}: expected COORDINATOR/N FLOOR"
            ))
        } else if self.running.contains_key(&id) {
            Err(format!("pipe {id} is open already"))
        } else if self.running.len() >= workers {
            Err(format!(
                "the host is full: {workers} of {workers} workers run"
            ))
        } else {
            start(
                self.z,
                &id,
                (self.spawn)(),
                &self.out_key(&id),
                self.tx.clone(),
            )
            .map(|r| {
                self.running.insert(id.clone(), r);
            })
        };
        let _ = match answer {
            Ok(()) => {
                eprintln!("sweep-host: pipe {id} opened");
                q.reply(q.key_expr().clone(), "ok").wait()
            }
            Err(e) => {
                eprintln!("sweep-host: pipe {id} refused: {e}");
                q.reply_err(e).wait()
            }
        };
    }

    /// Kills and ends coordinator `cid`'s pipes numbered below `floor`: they ended on its
    /// side when it lost this host.
    fn kill_stale(&mut self, cid: &str, floor: u64) {
        let stale: Vec<String> = self
            .running
            .keys()
            .filter(|r| {
                r.split_once('/')
                    .is_some_and(|(c, n)| c == cid && n.parse::<u64>().is_ok_and(|n| n < floor))
            })
            .cloned()
            .collect();
        for old in stale {
            if let Some(mut r) = self.running.remove(&old) {
                eprintln!(
                    "sweep-host: pipe {old}: its coordinator lost this host since, \
                     killing it"
                );
                let _ = r.child.kill();
                self.end(&old, r);
            }
        }
    }

    /// A message for pipe `id`: a line for its process's stdin (`L`), close its stdin (`C`),
    /// kill it (`K`). Ignored when the pipe is not running.
    fn input(&mut self, id: &str, payload: &[u8]) {
        let Some(r) = self.running.get_mut(id) else {
            return;
        };
        match payload.split_first() {
            Some((b'L', line)) => {
                let ok = r.stdin.as_mut().is_some_and(|s| {
                    s.write_all(line)
                        .and_then(|_| s.write_all(b"\n"))
                        .and_then(|_| s.flush())
                        .is_ok()
                });
                if !ok {
                    // its end is reported when its output ends
                    r.stdin = None;
                }
            }
            Some((b'C', _)) => r.stdin = None,
            Some((b'K', _)) => {
                let _ = r.child.kill();
            }
            _ => {}
        }
    }

    /// Coordinator `cid`'s token went: its processes are killed (their ends are reported when
    /// their output ends).
    fn coordinator_gone(&mut self, cid: &str) {
        for (id, r) in self.running.iter_mut() {
            if id.split('/').next() == Some(cid) {
                eprintln!("sweep-host: pipe {id}: its coordinator is gone, killing it");
                r.stdin = None;
                let _ = r.child.kill();
            }
        }
    }
}

/// Starts one process for pipe `id`: a thread carries its stdout lines to `out_key`.
fn start(
    z: &zenoh::Session,
    id: &str,
    mut cmd: Command,
    out_key: &str,
    events: mpsc::Sender<HostEvent>,
) -> std::result::Result<Running, String> {
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start the worker: {e}"))?;
    let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
        let _ = child.kill();
        let _ = child.wait();
        return Err("the worker's pipes were not opened".into());
    };
    let z = z.clone();
    let (id, out_key) = (id.to_owned(), out_key.to_owned());
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if put(&z, &out_key, tagged(b'L', &line)).is_err() {
                break;
            }
        }
        let _ = events.send(HostEvent::OutputEnded(id));
    });
    Ok(Running {
        child,
        stdin: Some(stdin),
    })
}

// ---------------------------------------------------------------------------------------------
// the coordinator's side

type LineFn = Box<dyn Fn(String) + Send + Sync>;
type EndFn = Box<dyn Fn(String) + Send + Sync>;

/// One pipe's shared state: its callbacks and whether (and how) it ended.
struct PipeState {
    on_line: LineFn,
    on_end: EndFn,
    ended: Mutex<Option<String>>,
}

impl PipeState {
    /// Ends the pipe once: the first reason wins, later ones are ignored.
    fn end(&self, how: String) {
        let mut e = self.ended.lock().unwrap_or_else(|p| p.into_inner());
        if e.is_none() {
            *e = Some(how.clone());
            drop(e);
            (self.on_end)(how);
        }
    }
    fn ended(&self) -> Option<String> {
        self.ended.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

/// A coordinator's link to one host: asks it for processes.
pub struct Remote {
    z: zenoh::Session,
    endpoint: String,
    key: String,
    cid: String,
    workers: usize,
    next: AtomicU64,
    /// The first pipe number after the host was last lost: the pipes below it ended here when
    /// their host went, and the host is told to kill them should it still run them (it does
    /// when it did not see this coordinator go, e.g. after a link cut shorter on its side).
    floor: Arc<AtomicU64>,
    host_here: Arc<AtomicBool>,
    pipes: Arc<Mutex<HashMap<u64, Arc<PipeState>>>>,
    _token: zenoh::liveliness::LivelinessToken,
    _host_watch: zenoh::pubsub::Subscriber<()>,
}

impl Remote {
    /// Connects to the host listening at `endpoint` and asks how many workers it runs, for up
    /// to `wait` (the host may still be starting).
    pub fn connect(endpoint: &str, key_prefix: &str, wait: Duration) -> Result<Remote> {
        check_key(key_prefix)?;
        let z = zenoh::open(crate::zenoh_config(None, Some(endpoint))?)
            .wait()
            .map_err(zerr(format!("connect to {endpoint}")))?;
        let k = |what: &str| key(key_prefix, &format!("sweep/{what}"));
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let cid = format!("c{}-{nanos}", std::process::id());
        let host_here = Arc::new(AtomicBool::new(false));
        let pipes: Arc<Mutex<HashMap<u64, Arc<PipeState>>>> = Arc::default();
        let floor = Arc::new(AtomicU64::new(0));
        let (here, watched, lost_at) = (host_here.clone(), pipes.clone(), floor.clone());
        let host_watch = z
            .liveliness()
            .declare_subscriber(k("host"))
            .history(true)
            .callback(move |s| match s.kind() {
                SampleKind::Put => here.store(true, Ordering::SeqCst),
                SampleKind::Delete => {
                    here.store(false, Ordering::SeqCst);
                    let mut pipes = watched.lock().unwrap_or_else(|p| p.into_inner());
                    if let Some(&last) = pipes.keys().max() {
                        lost_at.fetch_max(last + 1, Ordering::SeqCst);
                    }
                    let all: Vec<Arc<PipeState>> = pipes.drain().map(|(_, p)| p).collect();
                    drop(pipes);
                    for p in all {
                        p.end("its host is gone (the link to it closed or lapsed)".into());
                    }
                }
            })
            .wait()
            .map_err(zerr("watch the host's token"))?;
        let token = z
            .liveliness()
            .declare_token(k(&format!("coord/{cid}")))
            .wait()
            .map_err(zerr("declare the coordinator's token"))?;
        let until = Instant::now() + wait;
        let mut last = "no answer".to_owned();
        let workers = loop {
            let replies = z
                .get(k("info"))
                .timeout(Duration::from_millis(1000))
                .wait()
                .map_err(zerr("ask the host"))?;
            match replies.recv().map(|r| r.into_result()) {
                Ok(Ok(sample)) => {
                    let text = String::from_utf8_lossy(&sample.payload().to_bytes()).into_owned();
                    match text
                        .strip_prefix("workers=")
                        .and_then(|n| n.parse::<usize>().ok())
                    {
                        Some(n) => break n,
                        None => last = format!("it answered {text:?}"),
                    }
                }
                Ok(Err(e)) => {
                    last = format!(
                        "it refused: {}",
                        String::from_utf8_lossy(&e.payload().to_bytes())
                    )
                }
                Err(_) => {}
            }
            if Instant::now() >= until {
                return Err(BridgeError::Usage(format!(
                    "no sweep host answered within {:.0} s ({last}); is `robosim sweep-host \
                     --listen {endpoint} --key {key_prefix}` running there?",
                    wait.as_secs_f64()
                )));
            }
            std::thread::sleep(Duration::from_millis(100));
        };
        // the host answered: its token is (or is about to be) seen; count it there until its
        // Delete says otherwise
        host_here.store(true, Ordering::SeqCst);
        Ok(Remote {
            z,
            endpoint: endpoint.to_owned(),
            key: key_prefix.to_owned(),
            cid,
            workers,
            next: AtomicU64::new(0),
            floor,
            host_here,
            pipes,
            _token: token,
            _host_watch: host_watch,
        })
    }

    /// How many worker processes the host runs at most.
    pub fn workers(&self) -> usize {
        self.workers
    }

    pub fn endpoint(&self) -> &str {
        &self.endpoint
    }

    /// Whether the host's token is seen.
    pub fn host_here(&self) -> bool {
        self.host_here.load(Ordering::SeqCst)
    }

    /// Asks the host for one process: its output lines go to `on_line`, then its end (once,
    /// after its last line; or when the host goes) to `on_end`.
    pub fn open(
        &self,
        on_line: impl Fn(String) + Send + Sync + 'static,
        on_end: impl Fn(String) + Send + Sync + 'static,
    ) -> std::result::Result<Pipe, String> {
        if !self.host_here() {
            return Err(format!("the host at {} is gone", self.endpoint));
        }
        let n = self.next.fetch_add(1, Ordering::SeqCst);
        let id = format!("{}/{n}", self.cid);
        let k = |what: &str| key(&self.key, &format!("sweep/pipe/{id}/{what}"));
        let state = Arc::new(PipeState {
            on_line: Box::new(on_line),
            on_end: Box::new(on_end),
            ended: Mutex::new(None),
        });
        let s = state.clone();
        let out = self
            .z
            .declare_subscriber(k("out"))
            .callback(move |sample| {
                let bytes = sample.payload().to_bytes();
                match bytes.split_first() {
                    Some((b'L', line)) if s.ended().is_none() => {
                        (s.on_line)(String::from_utf8_lossy(line).into_owned())
                    }
                    Some((b'E', how)) => s.end(String::from_utf8_lossy(how).into_owned()),
                    _ => {}
                }
            })
            .wait()
            .map_err(|e| format!("subscribe to the pipe's output: {e}"))?;
        self.pipes
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert(n, state.clone());
        let opened = (|| {
            let replies = self
                .z
                .get(key(&self.key, "sweep/open"))
                .payload(format!("{id} {}", self.floor.load(Ordering::SeqCst)))
                .timeout(Duration::from_secs(10))
                .wait()
                .map_err(|e| e.to_string())?;
            match replies.recv() {
                Ok(r) => match r.into_result() {
                    Ok(_) => Ok(()),
                    Err(e) => Err(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned()),
                },
                Err(_) => Err(format!("the host at {} did not answer", self.endpoint)),
            }
        })();
        if let Err(e) = opened {
            self.pipes
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .remove(&n);
            return Err(e);
        }
        // the host went between the check above and now: its Delete may have missed the pipe
        if !self.host_here() {
            state.end("its host is gone (the link to it closed or lapsed)".into());
        }
        Ok(Pipe {
            z: self.z.clone(),
            in_key: k("in"),
            id,
            n,
            state,
            pipes: self.pipes.clone(),
            _out: out,
        })
    }
}

/// One process on a host.
pub struct Pipe {
    z: zenoh::Session,
    in_key: String,
    id: String,
    n: u64,
    state: Arc<PipeState>,
    pipes: Arc<Mutex<HashMap<u64, Arc<PipeState>>>>,
    _out: zenoh::pubsub::Subscriber<()>,
}

impl Pipe {
    /// The pipe's id on its host (`<coordinator>/<n>`).
    pub fn id(&self) -> &str {
        &self.id
    }
    /// Sends one line to the process's stdin.
    pub fn send(&self, line: &str) -> std::result::Result<(), String> {
        if let Some(how) = self.state.ended() {
            return Err(format!("it ended: {how}"));
        }
        put(&self.z, &self.in_key, tagged(b'L', line))
    }
    /// How it ended, if it has.
    pub fn ended(&self) -> Option<String> {
        self.state.ended()
    }
    /// Closes its stdin (a worker then ends by itself).
    pub fn close_input(&self) {
        let _ = put(&self.z, &self.in_key, vec![b'C']);
    }
    /// Asks its host to kill it now.
    pub fn kill(&self) {
        if self.state.ended().is_none() {
            let _ = put(&self.z, &self.in_key, vec![b'K']);
        }
    }
    /// Waits up to `d` for its end; how it ended, if it did.
    pub fn wait_end(&self, d: Duration) -> Option<String> {
        let until = Instant::now() + d;
        loop {
            if let Some(how) = self.state.ended() {
                return Some(how);
            }
            if Instant::now() >= until {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Pipe {
    fn drop(&mut self) {
        if self.state.ended().is_none() {
            self.kill();
        }
        self.pipes
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .remove(&self.n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A host that did not see its coordinator lose it (the link came back before its own
    /// lease ran out) still runs the pipes the coordinator gave up: a full host would refuse
    /// the coordinator's new pipe. The floor sent with the open request has it kill them first.
    #[test]
    fn pipes_from_before_a_lost_host_are_killed_when_the_coordinator_opens_anew() {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .expect("a free port")
            .port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let args = HostArgs {
            listen: endpoint.clone(),
            workers: Some(1),
            key: format!("t{}", std::process::id()),
        };
        let key = args.key.clone();
        // The host runs on a thread until the test process ends; its workers are `cat`, which
        // ends when its stdin closes.
        std::thread::spawn(move || {
            let spawn = || Command::new("cat");
            let _ = host(&args, &spawn, &mut |_| {});
        });
        let remote = Remote::connect(&endpoint, &key, Duration::from_secs(15)).expect("connect");
        assert_eq!(remote.workers(), 1);
        let (tx, rx) = mpsc::channel::<String>();
        let echo = {
            let tx = tx.clone();
            move |line: String| {
                let _ = tx.send(line);
            }
        };
        let first = remote.open(echo.clone(), |_| {}).expect("first pipe");
        first.send("one").expect("send");
        assert_eq!(
            rx.recv_timeout(Duration::from_secs(10)).as_deref(),
            Ok("one")
        );
        // As the host's Delete does on the coordinator's side: the first pipe is over here.
        first.state.end("its host is gone (test)".into());
        remote.floor.store(1, Ordering::SeqCst);
        let ended = Arc::new(Mutex::new(None::<String>));
        let e = ended.clone();
        let second = remote
            .open(echo, move |how| {
                *e.lock().unwrap_or_else(|p| p.into_inner()) = Some(how);
            })
            .expect("the host frees its one worker for the new pipe");
        second.send("two").expect("send");
        assert_eq!(
            rx.recv_timeout(Duration::from_secs(10)).as_deref(),
            Ok("two")
        );
        assert_eq!(*ended.lock().unwrap_or_else(|p| p.into_inner()), None);
        // Without the floor, a third pipe is refused: the host is full.
        let third = remote.open(|_| {}, |_| {});
        assert!(
            third
                .as_ref()
                .is_err_and(|e| e.contains("the host is full: 1 of 1 workers run")),
            "{:?}",
            third.err()
        );
    }
}
