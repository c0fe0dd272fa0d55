//! `robosim sweep --remote ENDPOINT`: the sweep's [`Launcher`]/[`WorkerLink`] over the
//! bridge's Zenoh line pipes ([`robosim_bridge::sweep_link`]), which know nothing of the
//! studies (docs/studies.md, "Sweeps on other machines"). The studies sit above the processes'
//! floor, so they may use the bridge; Zenoh itself stays in the bridge.

use crate::sweep::SweepError;
use crate::sweep::transport::{EventSink, Launcher, WorkerLink};
use robosim_bridge::sweep_link::{Pipe, Remote};
use std::sync::Arc;
use std::time::Duration;

/// Connects to the sweep host at `endpoint` (waiting up to `wait` for it to answer): one
/// launcher per worker it runs.
pub fn connect(
    endpoint: &str,
    key: &str,
    wait: Duration,
) -> Result<Vec<Box<dyn Launcher>>, SweepError> {
    let remote = Remote::connect(endpoint, key, wait).map_err(|e| SweepError::Remote {
        endpoint: endpoint.to_owned(),
        why: e.to_string(),
    })?;
    let remote = Arc::new(remote);
    Ok((0..remote.workers())
        .map(|_| {
            Box::new(RemoteLauncher {
                remote: remote.clone(),
            }) as Box<dyn Launcher>
        })
        .collect())
}

/// Starts workers on one host.
struct RemoteLauncher {
    remote: Arc<Remote>,
}

impl Launcher for RemoteLauncher {
    fn describe(&self) -> String {
        format!("remote {}", self.remote.endpoint())
    }
    fn waiting(&self) -> Option<String> {
        (!self.remote.host_here()).then(|| {
            format!(
                "its host at {} is gone (the link closed or lapsed); waiting for it to come back",
                self.remote.endpoint()
            )
        })
    }
    fn launch(&mut self, sink: EventSink) -> Result<Box<dyn WorkerLink>, String> {
        let lines = sink.clone();
        let pipe = self.remote.open(
            move |line| {
                lines.line(line);
            },
            move |_how| sink.closed(),
        )?;
        Ok(Box::new(RemoteWorker { pipe }))
    }
}

/// A worker on a host: its pipe ends when the process ends or the host goes.
struct RemoteWorker {
    pipe: Pipe,
}

impl WorkerLink for RemoteWorker {
    fn describe(&self) -> String {
        format!("pipe {}", self.pipe.id())
    }
    fn send(&mut self, line: &str) -> Result<(), String> {
        self.pipe.send(line)
    }
    fn is_alive(&mut self) -> bool {
        self.pipe.ended().is_none()
    }
    fn kill(&mut self) -> String {
        if let Some(how) = self.pipe.ended() {
            return how;
        }
        self.pipe.kill();
        self.pipe
            .wait_end(Duration::from_secs(1))
            .unwrap_or_else(|| "asked its host to kill it; no answer within 1 s".into())
    }
    fn finish(&mut self, grace: Duration) {
        self.pipe.close_input();
        if self.pipe.wait_end(grace).is_none() {
            self.pipe.kill();
        }
    }
}
