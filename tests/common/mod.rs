//! Shared by the cross-process tests: a session home and the processes started in it,
//! killed and their shared memory removed when dropped.

#![allow(dead_code)]

use std::process::{Child, Command};
use std::time::{Duration, Instant};

pub const ROBOSIM: &str = env!("CARGO_BIN_EXE_robosim");

pub struct Procs {
    pub children: Vec<Child>,
    pub home: tempfile::TempDir,
    pub name: String,
}

impl Procs {
    /// A fresh home and a session name unique to this test process and `tag`.
    pub fn new(tag: &str) -> Self {
        iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
        Procs {
            children: Vec::new(),
            home: tempfile::tempdir().expect("temp dir"),
            name: format!("{tag}{}", std::process::id()),
        }
    }
    /// `robosim ARGS --session NAME` in the background; returns its pid. Its stdout and stderr go to
    /// `HOME/logs/PID.log`, printed when the test fails (see `Drop`).
    pub fn spawn(&mut self, args: &[&str]) -> u32 {
        let dir = self.home.path().join("logs");
        std::fs::create_dir_all(&dir).expect("log dir");
        let tmp = dir.join(format!("starting-{}.log", self.children.len()));
        let pid = self.spawn_logged(args, &tmp);
        let _ = std::fs::rename(&tmp, dir.join(format!("{pid}-{}.log", args[0])));
        pid
    }
    /// [`Procs::spawn`] with the process's stdout and stderr written to `log`.
    pub fn spawn_logged(&mut self, args: &[&str], log: &std::path::Path) -> u32 {
        self.spawn_wrapped(&[], args, log)
    }
    /// [`Procs::spawn_logged`] run by a wrapper command, `WRAPPER… robosim ARGS` (e.g.
    /// `ip netns exec NS` to start it on another network host); empty: directly.
    pub fn spawn_wrapped(&mut self, wrapper: &[&str], args: &[&str], log: &std::path::Path) -> u32 {
        let f = std::fs::File::create(log).expect("log file");
        let mut c = match wrapper.split_first() {
            Some((cmd, rest)) => {
                let mut c = Command::new(cmd);
                c.args(rest).arg(ROBOSIM);
                c
            }
            None => Command::new(ROBOSIM),
        };
        let c = c
            .args(args)
            .args(["--session", &self.name])
            .env("ROBOSIM_HOME", self.home.path())
            .stdout(f.try_clone().expect("log file"))
            .stderr(f)
            .spawn()
            .expect("spawn robosim");
        let pid = c.id();
        self.children.push(c);
        pid
    }
    /// SIGTERM to a process this started, then waits for it to exit.
    pub fn stop(&mut self, pid: u32) -> std::process::ExitStatus {
        let i = self
            .children
            .iter()
            .position(|c| c.id() == pid)
            .expect("a process this test started");
        let mut c = self.children.remove(i);
        let _ = Command::new("kill")
            .args(["-TERM", &pid.to_string()])
            .status();
        c.wait().expect("wait")
    }
    pub fn session(&self) -> robosim_instance_space::Session {
        robosim_instance_space::Session::open_in(self.home.path(), Some(&self.name))
            .expect("session")
    }
    /// Starts the keeper with `extra` arguments and waits until a client can connect.
    pub fn start_keeper(&mut self, extra: &[&str]) -> u32 {
        let mut args = vec!["space"];
        args.extend_from_slice(extra);
        let pid = self.spawn(&args);
        let s = self.session();
        wait_for("keeper", || {
            robosim_instance_space::Client::connect(&s, "probe").ok()
        });
        // The keeper serves before it has committed its scene; it notes the scene once the
        // scene is in. Tests start from a model that is
        // there, not from a race with its loading.
        if extra.contains(&"--scene") {
            let note = s.data_dir().join(robosim_launcher::SCENE_NOTE);
            wait_for("the keeper's scene", || note.exists().then_some(()));
        }
        pid
    }
}

impl Drop for Procs {
    fn drop(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
        // A failing test shows what its processes said: the logs go with the temp home.
        // With ROBOSIM_TEST_LOG_DIR set, whole logs are kept there (DIR/SESSION/).
        if std::thread::panicking() {
            if let Some(keep) = std::env::var_os("ROBOSIM_TEST_LOG_DIR") {
                let to = std::path::Path::new(&keep).join(&self.name);
                let _ = std::fs::create_dir_all(&to);
                for e in std::fs::read_dir(self.home.path().join("logs"))
                    .into_iter()
                    .flatten()
                    .flatten()
                {
                    let _ = std::fs::copy(e.path(), to.join(e.file_name()));
                }
            }
            let logs = std::fs::read_dir(self.home.path().join("logs"));
            for e in logs.into_iter().flatten().flatten() {
                let text = std::fs::read_to_string(e.path()).unwrap_or_default();
                let tail: Vec<&str> = text.lines().rev().take(60).collect();
                eprintln!(
                    "--- {} (last {} lines) ---",
                    e.file_name().to_string_lossy(),
                    tail.len()
                );
                for l in tail.iter().rev() {
                    eprintln!("{l}");
                }
            }
        }
        robosim_instance_space::remove_shm_files(&self.name);
    }
}

/// Polls `f` every 20 ms until it gives a value; fails the test after 60 s.
pub fn wait_for<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Two network namespaces joined by a veth pair, removed when dropped.
pub struct Hosts {
    pub a: String,
    pub b: String,
    veth: String,
}

impl Hosts {
    /// An error (with the reason) when this machine cannot make them: not root, or no
    /// iproute2. `tag` (two characters) tells apart the hosts of different test files; host a
    /// is 10.77.0.1, host b 10.77.0.2.
    pub fn make(tag: &str) -> Result<Hosts, String> {
        let id = std::process::id();
        let hosts = Hosts {
            a: format!("rs{tag}a{id}"),
            b: format!("rs{tag}b{id}"),
            veth: format!("rs{tag}v{id}"),
        };
        let (va, vb) = (format!("{}a", hosts.veth), format!("{}b", hosts.veth));
        let steps: Vec<Vec<String>> = vec![
            vec!["netns", "add", &hosts.a],
            vec!["netns", "add", &hosts.b],
            vec!["link", "add", &va, "type", "veth", "peer", "name", &vb],
            vec!["link", "set", &va, "netns", &hosts.a],
            vec!["link", "set", &vb, "netns", &hosts.b],
            vec!["-n", &hosts.a, "addr", "add", "10.77.0.1/24", "dev", &va],
            vec!["-n", &hosts.b, "addr", "add", "10.77.0.2/24", "dev", &vb],
            vec!["-n", &hosts.a, "link", "set", &va, "up"],
            vec!["-n", &hosts.b, "link", "set", &vb, "up"],
            vec!["-n", &hosts.a, "link", "set", "lo", "up"],
            vec!["-n", &hosts.b, "link", "set", "lo", "up"],
        ]
        .into_iter()
        .map(|v| v.into_iter().map(str::to_owned).collect())
        .collect();
        for step in steps {
            let out = Command::new("ip")
                .args(&step)
                .output()
                .map_err(|e| format!("ip: {e}"))?;
            if !out.status.success() {
                return Err(format!(
                    "ip {}: {}",
                    step.join(" "),
                    String::from_utf8_lossy(&out.stderr).trim()
                ));
            }
        }
        Ok(hosts)
    }

    /// Takes host a's end of the link down or up.
    pub fn link(&self, up: bool) {
        let va = format!("{}a", self.veth);
        let ok = Command::new("ip")
            .args([
                "-n",
                &self.a,
                "link",
                "set",
                &va,
                if up { "up" } else { "down" },
            ])
            .status()
            .expect("ip")
            .success();
        assert!(
            ok,
            "could not set the link {}",
            if up { "up" } else { "down" }
        );
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        for ns in [&self.a, &self.b] {
            let _ = Command::new("ip").args(["netns", "del", ns]).status();
        }
    }
}

/// `robosim ARGS --session NAME` in the session's home, to completion: (success, stdout + stderr).
pub fn robosim(k: &Procs, args: &[&str]) -> (bool, String) {
    let out = Command::new(ROBOSIM)
        .args(args)
        .args(["--session", &k.name])
        .env("ROBOSIM_HOME", k.home.path())
        .env("IOX2_LOG_LEVEL", "Error")
        .output()
        .expect("run robosim");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr),
    )
}

/// Runs `robosim down` for the session when dropped, so a failed assertion does not leave the
/// processes `up` started (they are not the test's children) running.
pub struct Down<'a>(pub &'a Procs);

impl Drop for Down<'_> {
    fn drop(&mut self) {
        robosim(self.0, &["down"]);
    }
}
