//! Sessions: one namespace for all of a simulation's shared memory, services, journal and
//! process registry. Two sessions on one machine never see each other.
//!
//! * Files: `$ROBOSIM_HOME/<session>/` (default `$HOME/.local/state/robosim/<session>/`), mode
//!   0700; the journal and checkpoints under `data/` and the process registry under `run/`,
//!   every file 0600.
//! * iceoryx2: an explicit [`iceoryx2::config::Config`] per session — file prefix
//!   `rs_<session>_` and root path `<session dir>/iox2/` — so nothing depends on the working
//!   directory's `config/iceoryx2.toml`, and another session's names cannot collide.

use iceoryx2::prelude::*;
use serde::{Deserialize, Serialize};
use std::fs;
use std::io::Write as _;
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path as FsPath, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("session name {0:?} is invalid: use 1–24 characters from A–Z a–z 0–9 _ -")]
    BadName(String),
    #[error("cannot create {path}: {source}")]
    Dir {
        path: PathBuf,
        source: std::io::Error,
    },
    /// iceoryx2 refused a name or path this session builds (`what`), or to create a node.
    #[error("iceoryx2 configuration for session {session}: {what}: {source}")]
    Config {
        session: String,
        what: String,
        #[source]
        source: crate::error::Cause,
    },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Another keeper holds the session's keeper lock ([`Session::lock_keeper`]).
    #[error(
        "session {session} already has a keeper ({}; it holds the lock {}): one keeper per \
         session. Stop it first (`robosim down --session {session}`)",
        match pid { Some(p) => format!("pid {p}"), None => "its pid is not known yet".to_owned() },
        lock.display()
    )]
    KeeperRunning {
        session: String,
        pid: Option<u32>,
        lock: PathBuf,
    },
    /// A reader or joiner named a session that was never started (nothing is created).
    #[error("no session {name} under {}; {}", home.display(), running_list(running))]
    NoSession {
        name: String,
        home: PathBuf,
        running: Vec<String>,
    },
}

/// The `open_or_create` error of an iceoryx2 service builder (one type per messaging pattern):
/// whether it failed because the service hangs in creation, told by its variant.
pub trait OpenOrCreateError {
    /// True for `HangsInCreation`, whether met while opening or while creating.
    fn hangs_in_creation(&self) -> bool;
}

impl OpenOrCreateError
    for iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError
{
    fn hangs_in_creation(&self) -> bool {
        use iceoryx2::service::builder::publish_subscribe::{
            PublishSubscribeCreateError as Create, PublishSubscribeOpenError as Open,
            PublishSubscribeOpenOrCreateError as E,
        };
        matches!(
            self,
            E::PublishSubscribeOpenError(Open::HangsInCreation)
                | E::PublishSubscribeCreateError(Create::HangsInCreation)
        )
    }
}

impl OpenOrCreateError for iceoryx2::service::builder::event::EventOpenOrCreateError {
    fn hangs_in_creation(&self) -> bool {
        use iceoryx2::service::builder::event::{
            EventOpenError as Open, EventOpenOrCreateError as E,
        };
        // iceoryx2 0.10's EventCreateError has no HangsInCreation: a creator that finds the
        // service half-made reports it while opening.
        matches!(self, E::EventOpenError(Open::HangsInCreation))
    }
}

impl OpenOrCreateError
    for iceoryx2::service::builder::request_response::RequestResponseOpenOrCreateError
{
    fn hangs_in_creation(&self) -> bool {
        use iceoryx2::service::builder::request_response::{
            RequestResponseCreateError as Create, RequestResponseOpenError as Open,
            RequestResponseOpenOrCreateError as E,
        };
        matches!(
            self,
            E::RequestResponseOpenError(Open::HangsInCreation)
                | E::RequestResponseCreateError(Create::HangsInCreation)
        )
    }
}

fn running_list(running: &[String]) -> String {
    if running.is_empty() {
        "no session is running (start one with `robosim up SCENE --session NAME`)".into()
    } else {
        format!("running sessions: {}", running.join(", "))
    }
}

/// A session: its name and its directory.
#[derive(Debug, Clone)]
pub struct Session {
    name: String,
    dir: PathBuf,
}

/// The default session name: one per user.
pub fn default_session_name() -> String {
    format!("u{}", uid())
}

pub(crate) fn uid() -> u32 {
    use std::os::unix::fs::MetadataExt;
    // /proc/self belongs to the process's real uid; without /proc, fall back to the home dir.
    fs::metadata("/proc/self")
        .or_else(|_| fs::metadata("."))
        .map_or(0, |m| m.uid())
}

/// `$ROBOSIM_HOME`, else `$HOME/.local/state/robosim`, else `/tmp/robosim-<uid>`.
pub fn home() -> PathBuf {
    if let Some(h) = std::env::var_os("ROBOSIM_HOME") {
        return PathBuf::from(h);
    }
    match std::env::var_os("HOME") {
        Some(h) => PathBuf::from(h).join(".local/state/robosim"),
        None => PathBuf::from(format!("/tmp/robosim-{}", uid())),
    }
}

fn private_dir(path: &FsPath) -> Result<(), SessionError> {
    fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(path)
        .map_err(|source| SessionError::Dir {
            path: path.to_owned(),
            source,
        })?;
    // An existing directory keeps its mode: tighten it.
    fs::set_permissions(path, fs::Permissions::from_mode(0o700)).map_err(|source| {
        SessionError::Dir {
            path: path.to_owned(),
            source,
        }
    })
}

/// Writes `bytes` to `path` atomically (temp file, fsync, rename) with mode 0600.
pub fn write_private(path: &FsPath, bytes: &[u8]) -> Result<(), SessionError> {
    let tmp = path.with_extension("tmp");
    let io = |source| SessionError::Io {
        path: path.to_owned(),
        source,
    };
    let mut f = fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(&tmp)
        .map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    fs::rename(&tmp, path).map_err(io)
}

fn checked_name(name: Option<&str>) -> Result<String, SessionError> {
    let name = name.map(str::to_owned).unwrap_or_else(default_session_name);
    if name.is_empty()
        || name.len() > 24
        || !name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
    {
        return Err(SessionError::BadName(name));
    }
    Ok(name)
}

/// The sessions under `root` that have at least one live registered process, sorted. Reads
/// only: stale registry entries are left for the session's own processes to clean.
pub fn running_sessions(root: &FsPath) -> Vec<String> {
    let Ok(entries) = fs::read_dir(root) else {
        return Vec::new();
    };
    let mut out: Vec<String> = entries
        .flatten()
        .filter(|e| {
            fs::read_dir(e.path().join("run")).is_ok_and(|run| {
                run.flatten().any(|r| {
                    fs::read(r.path())
                        .ok()
                        .and_then(|b| serde_json::from_slice::<ProcInfo>(&b).ok())
                        .is_some_and(|p| pid_alive(p.pid))
                })
            })
        })
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    out.sort();
    out
}

impl Session {
    /// Opens (creating its directories) the session `name`, or the default one, under
    /// [`home`].
    pub fn open(name: Option<&str>) -> Result<Self, SessionError> {
        Self::open_in(&home(), name)
    }

    /// Opens the session `name` (or the default one) under [`home`] only if it exists: for
    /// the processes that read or join a session (`ps`, `query --session`, `display`, …). A
    /// missing session is [`SessionError::NoSession`], naming the sessions that run, and
    /// nothing is created.
    pub fn existing(name: Option<&str>) -> Result<Self, SessionError> {
        Self::existing_in(&home(), name)
    }

    /// [`Session::existing`] under the directory `root` instead of [`home`].
    pub fn existing_in(root: &FsPath, name: Option<&str>) -> Result<Self, SessionError> {
        let name = checked_name(name)?;
        let dir = root.join(&name);
        if !dir.join("data").is_dir() {
            return Err(SessionError::NoSession {
                name,
                home: root.to_owned(),
                running: running_sessions(root),
            });
        }
        Self::open_in(root, Some(&name))
    }

    /// Opens the session `name` under the directory `root` instead of [`home`].
    pub fn open_in(root: &FsPath, name: Option<&str>) -> Result<Self, SessionError> {
        let name = checked_name(name)?;
        private_dir(root)?;
        let dir = root.join(&name);
        for d in [
            dir.clone(),
            dir.join("data"),
            dir.join("run"),
            dir.join("iox2"),
        ] {
            private_dir(&d)?;
        }
        Ok(Session { name, dir })
    }
    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn dir(&self) -> &FsPath {
        &self.dir
    }
    /// Journal and checkpoints.
    pub fn data_dir(&self) -> PathBuf {
        self.dir.join("data")
    }
    /// Process registry.
    pub fn run_dir(&self) -> PathBuf {
        self.dir.join("run")
    }
    /// The shared-memory file prefix of this session (in /dev/shm).
    pub fn shm_prefix(&self) -> String {
        shm_prefix_of(&self.name)
    }

    /// A [`SessionError::Config`] of this session for `what`, keeping iceoryx2's error.
    fn config_err<E: std::error::Error + Send + Sync + 'static>(
        &self,
        what: impl Into<String>,
    ) -> impl FnOnce(E) -> SessionError {
        let (session, what) = (self.name.clone(), what.into());
        move |e| SessionError::Config {
            session,
            what,
            source: Box::new(e),
        }
    }

    /// The iceoryx2 configuration of this session.
    pub fn iox_config(&self) -> Result<iceoryx2::config::Config, SessionError> {
        let mut cfg = iceoryx2::config::Config::default();
        cfg.global.prefix =
            FileName::new(self.shm_prefix().as_bytes()).map_err(self.config_err("prefix"))?;
        let root = format!("{}/", self.dir.join("iox2").display());
        let root =
            Path::new(root.as_bytes()).map_err(self.config_err(format!("root path {root:?}")))?;
        cfg.global.set_root_path(&root);
        Ok(cfg)
    }

    /// Removes this session's iceoryx2 static service configs that a process left half-made
    /// more than `min_age` ago; the paths removed.
    ///
    /// iceoryx2 0.10 makes a service's static config file first, with mode 0600, and makes it
    /// read-only once the service is complete. A process killed in between (a keeper killed
    /// while it makes a pose-chunk service) leaves the 0600 file for good: everyone who opens
    /// or creates that service afterwards gets `HangsInCreation`, and its dead-node cleanup
    /// does not remove it (iceoryx2 issue #1584). A file still 0600 after iceoryx2's own
    /// creation timeout belongs to no creation in progress.
    pub fn remove_stalled_services(&self, min_age: std::time::Duration) -> Vec<PathBuf> {
        let dir = self.dir.join("iox2").join("services");
        let prefix = self.shm_prefix();
        let mut removed = Vec::new();
        for e in fs::read_dir(&dir).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let Ok(meta) = e.metadata() else { continue };
            let stalled = name.starts_with(&prefix)
                && name.ends_with(".service")
                && meta.is_file()
                && meta.permissions().mode() & 0o777 == 0o600
                && meta
                    .modified()
                    .ok()
                    .and_then(|m| m.elapsed().ok())
                    .is_some_and(|age| age >= min_age);
            if stalled && fs::remove_file(e.path()).is_ok() {
                removed.push(e.path());
            }
        }
        removed
    }

    /// Runs `open_or_create` (an iceoryx2 service builder's); when it fails because the service
    /// hangs in creation, removes the session's stalled service configs
    /// ([`Session::remove_stalled_services`]) and runs it once more.
    pub fn open_or_create_service<T, E: OpenOrCreateError>(
        &self,
        mut open_or_create: impl FnMut() -> Result<T, E>,
    ) -> Result<T, E> {
        match open_or_create() {
            Err(e) if e.hangs_in_creation() => {
                let timeout = self
                    .iox_config()
                    .map(|c| c.global.creation_timeout)
                    .unwrap_or(std::time::Duration::from_millis(500));
                for path in self.remove_stalled_services(timeout) {
                    eprintln!(
                        "robosim: removed {}: a service left half-made by a process that died while making it",
                        path.display()
                    );
                }
                open_or_create()
            }
            r => r,
        }
    }

    /// Creates an iceoryx2 node named `role` in this session. With `handle_signals`, SIGINT and
    /// SIGTERM are caught and reported by `node.wait()` instead of killing the process.
    pub fn node(
        &self,
        role: &str,
        handle_signals: bool,
    ) -> Result<Node<ipc::Service>, SessionError> {
        let cfg = self.iox_config()?;
        let name = NodeName::new(role).map_err(self.config_err(format!("node name {role:?}")))?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&cfg)
            .signal_handling_mode(if handle_signals {
                SignalHandlingMode::HandleTerminationRequests
            } else {
                SignalHandlingMode::Disabled
            })
            .create::<ipc::Service>()
            .map_err(self.config_err(format!("node {role:?}")))?;
        self.tighten_shm_modes();
        Ok(node)
    }

    /// iceoryx2 creates its global management segment world-writable (0666); everything of a
    /// session must be private to its user, so tighten every file of this session's prefix
    /// in /dev/shm to 0600 (they are all ours: the prefix names the session).
    fn tighten_shm_modes(&self) {
        let prefix = self.shm_prefix();
        let Ok(entries) = fs::read_dir("/dev/shm") else {
            return;
        };
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(&prefix)
                && let Ok(m) = e.metadata()
                && m.permissions().mode() & 0o077 != 0
            {
                let _ = fs::set_permissions(
                    e.path(),
                    fs::Permissions::from_mode(m.permissions().mode() & 0o700),
                );
            }
        }
    }

    /// The files of this session in /dev/shm with their modes (for audits and tests).
    pub fn shm_files(&self) -> Vec<(PathBuf, u32)> {
        let prefix = self.shm_prefix();
        let Ok(entries) = fs::read_dir("/dev/shm") else {
            return Vec::new();
        };
        entries
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
            .filter_map(|e| {
                e.metadata()
                    .ok()
                    .map(|m| (e.path(), m.permissions().mode() & 0o777))
            })
            .collect()
    }

    /// Removes what this session's processes that died (`kill -9`) left in shared memory, as
    /// iceoryx2 means it to be done: its dead-node cleanup for every dead node of the session
    /// (the node's ports, connections and data segments, and the services it was the last user
    /// of); then, when no node of the session is alive and no registered process is, every
    /// file of the session's prefix left in /dev/shm (iceoryx2's management segments, which
    /// outlive the last node). A node still alive (a reader or client that did not register)
    /// keeps what it uses.
    pub fn remove_leftovers(&self) -> Leftovers {
        let before = self.shm_files().len();
        let mut out = Leftovers::default();
        if let Ok(cfg) = self.iox_config() {
            let _ = Node::<ipc::Service>::list(&cfg, |state| {
                match state {
                    NodeState::Dead(view) => {
                        if view
                            .blocking_remove_stale_resources(std::time::Duration::from_secs(1))
                            .is_ok()
                        {
                            out.dead_nodes += 1;
                        }
                    }
                    NodeState::Alive(_) | NodeState::Inaccessible(_) => out.alive_nodes += 1,
                    NodeState::Undefined(_) => {}
                }
                CallbackProgression::Continue
            });
        }
        if out.alive_nodes == 0 && self.processes().is_empty() {
            for (path, _) in self.shm_files() {
                let _ = fs::remove_file(path);
            }
        }
        out.files = before.saturating_sub(self.shm_files().len());
        out
    }

    /// A service name inside this session.
    pub fn service(&self, suffix: &str) -> Result<ServiceName, SessionError> {
        let s = format!("robosim/{}/{}", self.name, suffix);
        ServiceName::new(&s).map_err(self.config_err(format!("service name {s:?}")))
    }

    /// Registers this process in the session's registry until the returned guard drops.
    pub fn register(&self, role: &str, attached: &[&str]) -> Result<Registration, SessionError> {
        let info = ProcInfo {
            role: role.to_owned(),
            pid: std::process::id(),
            attached: attached.iter().map(|s| s.to_string()).collect(),
            started_unix_ms: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_millis() as u64),
        };
        let path = self.run_dir().join(format!("{role}-{}.json", info.pid));
        let json = serde_json::to_vec_pretty(&info).unwrap_or_default();
        write_private(&path, &json)?;
        Ok(Registration { path })
    }

    /// Takes the session's keeper lock: an OS lock (`flock`, exclusive, not waited for) on
    /// `<session>/keeper.lock`, held until the returned guard drops (or the process dies: the
    /// kernel releases it, so a keeper killed with -9 leaves no stale lock). The holder's pid
    /// is written into the file. A keeper takes it before it touches the journal, so two
    /// keepers started at the same instant cannot both recover and write it: the second gets
    /// [`SessionError::KeeperRunning`] naming the first's pid.
    pub fn lock_keeper(&self) -> Result<KeeperLock, SessionError> {
        use std::os::unix::fs::FileExt;
        let path = self.dir.join(KEEPER_LOCK);
        let io = |source| SessionError::Io {
            path: path.clone(),
            source,
        };
        let file = fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .mode(0o600)
            .open(&path)
            .map_err(io)?;
        // The holder writes its pid right after it locks. Until a live holder's pid is there
        // (a pid left by an earlier holder, dead, is not the answer; a holder killed a moment
        // ago releases the lock as it exits), try again for a moment.
        let start = std::time::Instant::now();
        loop {
            match file.try_lock() {
                Ok(()) => break,
                Err(fs::TryLockError::WouldBlock) => {
                    let pid = fs::read_to_string(&path)
                        .ok()
                        .and_then(|t| t.trim().parse::<u32>().ok())
                        .filter(|&p| pid_alive(p));
                    if pid.is_some() || start.elapsed() > std::time::Duration::from_secs(2) {
                        return Err(SessionError::KeeperRunning {
                            session: self.name.clone(),
                            pid,
                            lock: path,
                        });
                    }
                    std::thread::sleep(std::time::Duration::from_millis(10));
                }
                Err(fs::TryLockError::Error(e)) => return Err(io(e)),
            }
        }
        let pid = format!("{}\n", std::process::id());
        file.set_len(0)
            .and_then(|_| file.write_all_at(pid.as_bytes(), 0))
            .map_err(io)?;
        Ok(KeeperLock { file })
    }

    /// Processes registered in this session that are still alive (stale entries of dead
    /// processes are removed).
    pub fn processes(&self) -> Vec<ProcInfo> {
        let mut out = Vec::new();
        let Ok(entries) = fs::read_dir(self.run_dir()) else {
            return out;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.extension().is_none_or(|x| x != "json") {
                continue;
            }
            let Ok(bytes) = fs::read(&p) else { continue };
            let Ok(info) = serde_json::from_slice::<ProcInfo>(&bytes) else {
                continue;
            };
            if pid_alive(info.pid) {
                out.push(info);
            } else {
                let _ = fs::remove_file(&p);
            }
        }
        out.sort_by_key(|a| (role_rank(&a.role), a.pid));
        out
    }
}

fn role_rank(role: &str) -> u32 {
    if role == "space" { 0 } else { 1 }
}

/// True if a process with this pid exists and is not a zombie.
pub fn pid_alive(pid: u32) -> bool {
    match fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state is the field after the parenthesised command name.
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| !rest.trim_start().starts_with('Z')),
        Err(_) => false,
    }
}

/// How a child process ended, in words for a message: "exited with status 3", "killed by
/// signal 9".
pub fn exit_words(s: std::process::ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (s.code(), s.signal()) {
        (Some(c), _) => format!("exited with status {c}"),
        (None, Some(sig)) => format!("killed by signal {sig}"),
        _ => format!("ended ({s})"),
    }
}

/// One registered process of a session.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ProcInfo {
    pub role: String,
    pub pid: u32,
    /// What it is attached to (services, files).
    pub attached: Vec<String>,
    pub started_unix_ms: u64,
}

/// The prefix of session `name`'s files in /dev/shm (see [`Session::shm_prefix`]).
fn shm_prefix_of(name: &str) -> String {
    format!("rs_{name}_")
}

/// Removes every file of session `name` in /dev/shm (the prefix `rs_NAME_`), whoever still
/// maps them, and returns how many it removed. For throw-away sessions (tests, benches) once
/// their processes are stopped: iceoryx2 leaves the global management segment behind when the
/// last node goes. A user's session goes through [`Session::remove_leftovers`], which keeps
/// what live nodes use.
pub fn remove_shm_files(name: &str) -> usize {
    let prefix = shm_prefix_of(name);
    let Ok(entries) = fs::read_dir("/dev/shm") else {
        return 0;
    };
    entries
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .filter(|e| fs::remove_file(e.path()).is_ok())
        .count()
}

/// What [`Session::remove_leftovers`] found and removed.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Leftovers {
    /// Dead iceoryx2 nodes whose resources were removed.
    pub dead_nodes: u64,
    /// Nodes still alive (their resources were kept).
    pub alive_nodes: u64,
    /// Files of the session removed from /dev/shm.
    pub files: usize,
}

/// The session's keeper lock file (in the session directory).
pub const KEEPER_LOCK: &str = "keeper.lock";

/// The session's keeper lock ([`Session::lock_keeper`]); released when dropped.
#[derive(Debug)]
pub struct KeeperLock {
    file: fs::File,
}

impl Drop for KeeperLock {
    fn drop(&mut self) {
        // The pid goes while the lock is still held; closing the file releases the lock.
        let _ = self.file.set_len(0);
    }
}

/// Removes the registry entry when dropped.
#[derive(Debug)]
pub struct Registration {
    path: PathBuf,
}

impl Drop for Registration {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

/// iceoryx2's timed wait on `listener`, with an interrupted wait taken as a wake-up with no
/// events. A blocking wait fails with EINTR when the process is stopped and continued (Ctrl-Z
/// and `fg`, a debugger or strace attaching) or when a handled SIGINT/SIGTERM arrives; neither
/// is an error of the wait. Processes that handle termination signals see them through their
/// node's `wait` (the flag stays set until that looks), processes that do not are ended by the
/// signal itself, so nothing is lost by carrying on.
pub(crate) fn timed_wait_events<F: FnMut(EventActivation)>(
    listener: &iceoryx2::port::listener::Listener<ipc::Service>,
    callback: F,
    timeout: std::time::Duration,
) -> Result<u64, iceoryx2::port::listener::ListenerWaitError> {
    // A zero timeout polls: iceoryx2's timed wait takes zero as "no timeout" and blocks.
    if timeout.is_zero() {
        let mut n = 0;
        let mut callback = callback;
        return listener
            .try_wait(|e| {
                n += 1;
                callback(e)
            })
            .map(|_| n);
    }
    match listener.timed_wait(callback, timeout) {
        Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => Ok(0),
        r => r,
    }
}

#[cfg(test)]
mod tests {
    use super::OpenOrCreateError;
    use iceoryx2::service::builder::{event, publish_subscribe as ps, request_response as rr};

    /// The stalled-service cleanup is chosen by iceoryx2's variant (an upgrade that renames it
    /// fails to compile here), whether the service was being opened or created.
    #[test]
    fn hangs_in_creation_is_told_by_variant_for_every_messaging_pattern() {
        use ps::PublishSubscribeOpenOrCreateError as P;
        assert!(
            P::PublishSubscribeOpenError(ps::PublishSubscribeOpenError::HangsInCreation)
                .hangs_in_creation()
        );
        assert!(
            P::PublishSubscribeCreateError(ps::PublishSubscribeCreateError::HangsInCreation)
                .hangs_in_creation()
        );
        assert!(
            !P::PublishSubscribeOpenError(ps::PublishSubscribeOpenError::DoesNotExist)
                .hangs_in_creation()
        );
        assert!(!P::SystemInFlux.hangs_in_creation());
        use event::EventOpenOrCreateError as E;
        assert!(E::EventOpenError(event::EventOpenError::HangsInCreation).hangs_in_creation());
        assert!(!E::EventCreateError(event::EventCreateError::AlreadyExists).hangs_in_creation());
        use rr::RequestResponseOpenOrCreateError as R;
        assert!(
            R::RequestResponseOpenError(rr::RequestResponseOpenError::HangsInCreation)
                .hangs_in_creation()
        );
        assert!(
            R::RequestResponseCreateError(rr::RequestResponseCreateError::HangsInCreation)
                .hangs_in_creation()
        );
        assert!(
            !R::RequestResponseOpenError(rr::RequestResponseOpenError::DoesNotExist)
                .hangs_in_creation()
        );
    }
}
