//! A keeper process on a throw-away session, for benches: started from the `robosim` binary
//! (`robosim space --session NAME …`), waited for until a client can connect, and on drop
//! stopped with SIGTERM (the keeper's clean shutdown) and its session directory and shared-memory
//! files removed.
//!
//! Benches start their keepers as separate processes on purpose: the costs they report are
//! those a user's processes see across the shared-memory boundary.

use crate::{Client, Session};
use std::path::Path;
use std::process::{Child, Command, Stdio};
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
        for (path, _) in self.session.shm_files() {
            let _ = std::fs::remove_file(path);
        }
    }
}
