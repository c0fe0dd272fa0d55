//! Keepers on throw-away sessions, for benches and tests.
//!
//! [`ScratchKeeper`] is a keeper process started from the `robosim` binary (`robosim space
//! --session NAME …`), waited for until a client can connect, and on drop stopped with SIGTERM
//! (the keeper's clean shutdown) and its session directory and shared-memory files removed.
//! Benches start their keepers as separate processes on purpose: the costs they report are
//! those a user's processes see across the shared-memory boundary.
//!
//! [`ThreadKeeper`] is a keeper stepping in a thread of the calling process, on a session of
//! its own under a fresh home in the temp directory; on drop it is stopped and the home and
//! the session's shared-memory files are removed. For tests that need a live keeper but no
//! binary.

use crate::{Client, Keeper, KeeperError, KeeperOptions, Session, remove_shm_files};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A keeper process on a fresh session of its own; see the module documentation.
pub struct ScratchKeeper {
    child: Child,
    session: Session,
}

impl ScratchKeeper {
    /// Removes whatever an earlier run left under session `name`, starts `exe space --session
    /// NAME ARGS…` (its stderr inherited, so a keeper's complaint is seen) and waits up to
    /// `timeout` for it to accept a client. On any failure the process is stopped and the
    /// session directory removed before the error (text naming the session) is returned.
    pub fn start(exe: &Path, name: &str, args: &[&str], timeout: Duration) -> Result<Self, String> {
        ScratchKeeper::start_as(exe, name, &["space"], args, timeout)
    }

    /// [`ScratchKeeper::start`] of another command that runs the session's keeper (`robosim
    /// bridge --connect …`, whose replica is the keeper): `exe COMMAND… --session NAME ARGS…`.
    pub fn start_as(
        exe: &Path,
        name: &str,
        command: &[&str],
        args: &[&str],
        timeout: Duration,
    ) -> Result<Self, String> {
        let what = |e: &dyn std::fmt::Display| format!("scratch session {name}: {e}");
        let session = Session::open(Some(name)).map_err(|e| what(&e))?;
        let _ = std::fs::remove_dir_all(session.data_dir());
        // Reopened: recreates data/ with its permissions.
        let session = Session::open(Some(name)).map_err(|e| what(&e))?;
        let child = Command::new(exe)
            .args(command)
            .args(["--session", name])
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| what(&format!("cannot start {}: {e}", exe.display())))?;
        let mut keeper = ScratchKeeper { child, session };
        let start = Instant::now();
        while Client::connect(&keeper.session, "scratch-probe").is_err() {
            if let Ok(Some(status)) = keeper.child.try_wait() {
                return Err(what(&format!(
                    "the keeper exited during start-up ({status})"
                )));
            }
            if start.elapsed() > timeout {
                return Err(what(&format!(
                    "the keeper did not start within {timeout:?}"
                )));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        Ok(keeper)
    }

    /// The session the keeper serves.
    pub fn session(&self) -> &Session {
        &self.session
    }
}

impl Drop for ScratchKeeper {
    fn drop(&mut self) {
        // SIGTERM, not SIGKILL: the keeper removes its shared-memory services on the way out.
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(self.session.dir());
        // iceoryx2 leaves the session's global management segment in /dev/shm when the last
        // node goes; a throw-away session's files go with it (mappings still open stay valid).
        remove_shm_files(self.session.name());
    }
}

/// A keeper stepping in a thread of this process; see the module documentation.
pub struct ThreadKeeper {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<(), KeeperError>>>,
    home: PathBuf,
    session: Session,
}

impl ThreadKeeper {
    /// Opens session `name` under a fresh home (`TMPDIR/rsPID-N`, N counting this process's
    /// thread keepers; whatever an earlier run left there removed first, as are the session's
    /// /dev/shm files),
    /// starts a keeper with `opts` in a new thread and waits up to `timeout` for it to serve.
    /// The keeper steps every 5 ms until the `ThreadKeeper` is dropped. On failure (the
    /// session cannot be opened, the keeper does not start, or not in time) the error names
    /// the session; what was created is removed.
    pub fn start(name: &str, opts: KeeperOptions, timeout: Duration) -> Result<Self, String> {
        let what = |e: &dyn std::fmt::Display| format!("thread keeper of session {name}: {e}");
        // Short on purpose: iceoryx2's unix-socket paths under the home have a length limit
        // (a longer home made the keeper's listener fail with ResourceCreationFailed).
        static HOMES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let home = std::env::temp_dir().join(format!(
            "rs{}-{}",
            std::process::id(),
            HOMES.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&home);
        remove_shm_files(name);
        let session = match Session::open_in(&home, Some(name)) {
            Ok(s) => s,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&home);
                return Err(what(&e));
            }
        };
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let thread = {
            let (session, stop) = (session.clone(), stop.clone());
            std::thread::spawn(move || {
                let mut keeper = match Keeper::start(&session, opts) {
                    Ok((k, _)) => k,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return Ok(());
                    }
                };
                let _ = ready_tx.send(Ok(()));
                while !stop.load(Ordering::Relaxed) {
                    keeper.step(Duration::from_millis(5))?;
                }
                Ok(())
            })
        };
        // Built before waiting, so that an early return stops the thread and cleans up.
        let keeper = ThreadKeeper {
            stop,
            thread: Some(thread),
            home,
            session,
        };
        match ready_rx.recv_timeout(timeout) {
            Ok(Ok(())) => Ok(keeper),
            Ok(Err(e)) => Err(what(&format!(
                "the keeper did not start: {}",
                crate::error::error_chain(&e)
            ))),
            Err(_) => Err(what(&format!(
                "the keeper did not start within {timeout:?}"
            ))),
        }
    }

    /// The session the keeper serves.
    pub fn session(&self) -> &Session {
        &self.session
    }
}

impl Drop for ThreadKeeper {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            // A keeper step that failed ended the thread early; its error has nobody to go to.
            let _ = t.join();
        }
        let _ = std::fs::remove_dir_all(&self.home);
        remove_shm_files(self.session.name());
    }
}
