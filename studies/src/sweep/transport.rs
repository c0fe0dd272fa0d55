//! How the coordinator reaches its workers: a [`Launcher`] starts workers, each a
//! [`WorkerLink`] that takes job lines; what workers answer arrives as [`Event`]s on one
//! channel for all of them. [`LocalLauncher`] starts `robosim sweep-worker` processes on this
//! machine (pipes); a remote launcher (workers on other machines, e.g. over Zenoh) implements
//! the same two traits, and the coordinator does not change.

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::Sender;

/// What the coordinator hears. `slot` is the coordinator's worker number, `generation` which
/// start of that slot's worker (a restarted worker's old events are told apart and ignored).
#[derive(Debug)]
pub enum Event {
    /// One line the worker wrote (a result line of the protocol).
    Line {
        slot: usize,
        generation: u64,
        line: String,
    },
    /// The worker is gone: its output ended (exit, crash, kill, a dropped connection).
    Closed { slot: usize, generation: u64 },
}

/// Where a worker delivers its events: its slot and generation are filled in.
#[derive(Clone)]
pub struct EventSink {
    tx: Sender<Event>,
    slot: usize,
    generation: u64,
}

impl EventSink {
    pub fn new(tx: Sender<Event>, slot: usize, generation: u64) -> EventSink {
        EventSink {
            tx,
            slot,
            generation,
        }
    }
    /// Delivers a line; false when the coordinator no longer listens.
    pub fn line(&self, line: String) -> bool {
        self.tx
            .send(Event::Line {
                slot: self.slot,
                generation: self.generation,
                line,
            })
            .is_ok()
    }
    /// Says the worker is gone (once, after its last line).
    pub fn closed(&self) {
        let _ = self.tx.send(Event::Closed {
            slot: self.slot,
            generation: self.generation,
        });
    }
}

/// A source of workers.
pub trait Launcher: Send {
    /// What it starts, for the log: "local process", "tcp/10.0.0.2:7447".
    fn describe(&self) -> String;
    /// Why it cannot start a worker now but may later — its host is gone (a lapsed link, a
    /// host restarting) and may come back — or `None`: it can try. The coordinator does not
    /// launch a waiting launcher's worker (so it is not given up for failing to start) and
    /// starts it again once this says `None`.
    fn waiting(&self) -> Option<String> {
        None
    }
    /// Starts one worker whose result lines, then its end, go to `sink`.
    fn launch(&mut self, sink: EventSink) -> Result<Box<dyn WorkerLink>, String>;
}

/// One running worker.
pub trait WorkerLink: Send {
    /// Which worker, for the log: "pid 1234".
    fn describe(&self) -> String;
    /// Hands it one job line; an error means it is gone.
    fn send(&mut self, line: &str) -> Result<(), String>;
    /// Whether it is still there (a process that has not exited; a remote peer still seen).
    fn is_alive(&mut self) -> bool;
    /// Ends it now and says how it ended ("killed by signal 9", "exited with status 0").
    fn kill(&mut self) -> String;
    /// No more jobs: lets it end by itself (its input closed), waiting up to `grace`, then
    /// kills it.
    fn finish(&mut self, grace: std::time::Duration);
}

/// Starts `EXE sweep-worker` processes: jobs on their stdin, results on their stdout, their
/// stderr passed through to ours.
pub struct LocalLauncher {
    pub exe: PathBuf,
}

impl Launcher for LocalLauncher {
    fn describe(&self) -> String {
        "local process".into()
    }
    fn launch(&mut self, sink: EventSink) -> Result<Box<dyn WorkerLink>, String> {
        let mut child = Command::new(&self.exe)
            .arg("sweep-worker")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("{} sweep-worker: {e}", self.exe.display()))?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            let _ = child.kill();
            let _ = child.wait();
            return Err("the worker's pipes were not opened".into());
        };
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                match line {
                    Ok(l) => {
                        if !sink.line(l) {
                            return;
                        }
                    }
                    Err(_) => break,
                }
            }
            sink.closed();
        });
        Ok(Box::new(LocalWorker {
            child,
            stdin: Some(stdin),
        }))
    }
}

struct LocalWorker {
    child: Child,
    stdin: Option<ChildStdin>,
}

impl WorkerLink for LocalWorker {
    fn describe(&self) -> String {
        format!("pid {}", self.child.id())
    }
    fn send(&mut self, line: &str) -> Result<(), String> {
        let stdin = self.stdin.as_mut().ok_or("its input is closed")?;
        stdin
            .write_all(line.as_bytes())
            .and_then(|_| stdin.write_all(b"\n"))
            .and_then(|_| stdin.flush())
            .map_err(|e| e.to_string())
    }
    fn is_alive(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
    fn kill(&mut self) -> String {
        self.stdin = None;
        if let Ok(Some(s)) = self.child.try_wait() {
            return robosim_instance_space::exit_words(s);
        }
        let _ = self.child.kill();
        match self.child.wait() {
            Ok(s) => robosim_instance_space::exit_words(s),
            Err(e) => format!("not waited for: {e}"),
        }
    }
    fn finish(&mut self, grace: std::time::Duration) {
        self.stdin = None;
        let until = std::time::Instant::now() + grace;
        while std::time::Instant::now() < until {
            if !matches!(self.child.try_wait(), Ok(None)) {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        self.kill();
    }
}

impl Drop for LocalWorker {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            self.kill();
        }
    }
}
