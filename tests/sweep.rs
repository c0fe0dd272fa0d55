//! Issue 18 §2, with real processes: `robosim sweep` splits a parameter study over
//! `robosim sweep-worker` processes and gathers one CSV; a worker killed with SIGKILL mid-job
//! (by the test hook, or from outside by its pid) has its job redone and the CSV is the
//! one-worker CSV byte for byte; a job that kills every worker it runs on fails alone, in its
//! row; bad input is refused by name. Workers on a `robosim sweep-host` over Zenoh (TCP on
//! localhost): the same CSV; a host killed mid-sweep has its jobs redone locally; a host whose
//! link lapsed is waited for and used again. No session, no shared memory: each test has its
//! own temp dir.

use crate::common;

use common::ROBOSIM;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// The sweep of these tests: the seed's §2.7 surgical study at 2 encoder resolutions × 2
/// upper arm lengths (4 jobs).
const PARAMS: &[&str] = &["--param", "bits=8,12", "--param", "upper_arm=0.2:0.24:2"];

fn sweep(dir: &Path, csv: &str, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(ROBOSIM);
    c.arg("sweep")
        .arg("surgical")
        .args(PARAMS)
        .args(["--out", dir.join(csv).to_str().expect("utf-8 path")])
        .args(extra)
        .env("ROBOSIM_HOME", dir)
        .env_remove("ROBOSIM_SWEEP_DIE_ON")
        .env_remove("ROBOSIM_SWEEP_DIE_ONCE");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("robosim runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "robosim sweep failed:\n{}\n{}",
        text(&o.stdout),
        text(&o.stderr)
    );
    text(&o.stderr)
}

/// The CSV of the sweep on one worker (the reference every other run is compared with).
fn reference(dir: &Path) -> String {
    ok(&sweep(dir, "one.csv", &["--workers", "1"], &[]));
    std::fs::read_to_string(dir.join("one.csv")).expect("one.csv")
}

/// The CSV's rows and fields (RFC 4180: a field in quotes may hold commas and doubled quotes;
/// no field of these sweeps holds a line break).
fn rows(csv: &str) -> Vec<Vec<String>> {
    csv.lines()
        .map(|l| {
            let (mut fields, mut field, mut quoted) = (Vec::new(), String::new(), false);
            let mut chars = l.chars().peekable();
            while let Some(c) = chars.next() {
                match (c, quoted) {
                    ('"', true) if chars.peek() == Some(&'"') => {
                        field.push('"');
                        chars.next();
                    }
                    ('"', _) => quoted = !quoted,
                    (',', false) => fields.push(std::mem::take(&mut field)),
                    _ => field.push(c),
                }
            }
            assert!(!quoted, "unclosed quote in {l:?}");
            fields.push(field);
            fields
        })
        .collect()
}

fn col(table: &[Vec<String>], name: &str) -> usize {
    table[0]
        .iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name} in {:?}", table[0]))
}

/// The same grid computed in this process, one job after another, no worker: the CSV every
/// sweep must give.
fn in_process() -> String {
    use robosim_studies::sweep::cli;
    let def = cli::study_named("surgical").expect("surgical");
    let params: Vec<String> = PARAMS
        .iter()
        .skip(1)
        .step_by(2)
        .map(|p| p.to_string())
        .collect();
    let plan = cli::plan(def, &params).expect("plan");
    let outcomes: Vec<_> = plan
        .jobs
        .iter()
        .map(|j| (def.run)(&j.params).map_err(|e| robosim_instance_space::error_chain(&e)))
        .collect();
    cli::csv(def, &plan.axes, &plan.jobs, &outcomes)
}

#[test]
fn two_workers_give_the_one_worker_csv_in_job_order() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    assert_eq!(
        one,
        in_process(),
        "one worker differs from the in-process run"
    );
    let log = ok(&sweep(dir.path(), "two.csv", &["--workers", "2"], &[]));
    let two = std::fs::read_to_string(dir.path().join("two.csv")).expect("two.csv");
    assert_eq!(one, two, "the CSV depends on the number of workers");
    assert_eq!(
        log.matches("started: local process pid").count(),
        2,
        "{log}"
    );
    assert!(!log.contains("died"), "{log}");

    let t = rows(&one);
    assert_eq!(t.len(), 5, "header + 4 jobs:\n{one}");
    assert_eq!(t[0][..2], ["bits", "upper_arm"]);
    assert_eq!(t[0].last().map(String::as_str), Some("error"));
    // job order: the first parameter varies slowest; the range ends exactly at its ends
    let points: Vec<(&str, &str)> = t[1..]
        .iter()
        .map(|r| (r[0].as_str(), r[1].as_str()))
        .collect();
    assert_eq!(
        points,
        [("8", "0.2"), ("8", "0.24"), ("12", "0.2"), ("12", "0.24")]
    );
    let (reached, worst, points_c, err) = (
        col(&t, "reached"),
        col(&t, "worst_position_bound_mm"),
        col(&t, "points"),
        col(&t, "error"),
    );
    let f = |r: usize, c: usize| -> f64 { t[r][c].parse().expect("a number") };
    for (r, row) in t.iter().enumerate().take(5).skip(1) {
        assert_eq!(row[err], "", "job {} failed: {row:?}", r - 1);
        assert_eq!(f(r, points_c), 861.0);
        assert!(f(r, reached) > 0.0, "nothing reached: {row:?}");
    }
    // the bits change the bound, not the reach: the same solutions at 8 and 12 bits, so the
    // worst bound scales by 2^(12-8) = 16 (joint resolution 2π/2^bits, seed §2.7)
    for (a, b) in [(1, 3), (2, 4)] {
        assert_eq!(f(a, reached), f(b, reached));
        let ratio = f(a, worst) / f(b, worst);
        assert!((ratio - 16.0).abs() < 1e-9, "8 vs 12 bits: {ratio}");
    }
    // the arm length does change what is reached or how accurately
    assert!(
        f(1, reached) != f(2, reached) || f(1, worst) != f(2, worst),
        "upper_arm changed nothing: {:?} {:?}",
        t[1],
        t[2]
    );
}

#[test]
fn a_worker_killed_mid_job_has_its_job_redone() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let marker = dir.path().join("died-once");
    // the worker that receives job 2 first kills itself (SIGKILL) before answering
    let o = sweep(
        dir.path(),
        "killed.csv",
        &["--workers", "2"],
        &[
            ("ROBOSIM_SWEEP_DIE_ON", "2"),
            ("ROBOSIM_SWEEP_DIE_ONCE", marker.to_str().expect("utf-8")),
        ],
    );
    let log = ok(&o);
    assert!(
        text(&o.stdout).contains("4 ran, 0 failed; 1 worker deaths, 1 jobs redone"),
        "{}",
        text(&o.stdout)
    );
    assert!(marker.exists(), "no worker received job 2:\n{log}");
    let csv = std::fs::read_to_string(dir.path().join("killed.csv")).expect("killed.csv");
    assert_eq!(csv, one, "the CSV after a death differs:\n{log}");
    assert!(
        log.contains(
            "died: its output ended (killed by signal 9); job 2 is redone (attempt 2 of 3)"
        ),
        "{log}"
    );
}

#[test]
fn a_job_that_kills_every_worker_fails_alone() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let o = sweep(
        dir.path(),
        "bad.csv",
        &["--workers", "2", "--attempts", "2"],
        &[("ROBOSIM_SWEEP_DIE_ON", "1")],
    );
    let log = ok(&o);
    assert!(
        text(&o.stdout).contains("3 ran, 1 failed; 2 worker deaths, 1 jobs redone"),
        "{}",
        text(&o.stdout)
    );
    assert!(log.contains("job 1 failed: tried 2 times"), "{log}");
    let csv = std::fs::read_to_string(dir.path().join("bad.csv")).expect("bad.csv");
    let (want, got) = (rows(&one), rows(&csv));
    assert_eq!(got.len(), want.len());
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        if i == 2 {
            // job 1: its point, no results, the error
            assert_eq!(g[..2], w[..2]);
            assert!(g[2..g.len() - 1].iter().all(String::is_empty), "{g:?}");
            assert!(
                g.last()
                    .is_some_and(|e| e.starts_with("the worker died 2 times running this job")),
                "{g:?}"
            );
        } else {
            assert_eq!(g, w, "row {i}");
        }
    }
}

#[test]
fn a_worker_killed_from_outside_by_pid_has_its_job_redone() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let mut child = Command::new(ROBOSIM)
        .arg("sweep")
        .arg("surgical")
        .args(PARAMS)
        .args(["--workers", "2", "--out"])
        .arg(dir.path().join("outside.csv"))
        .env("ROBOSIM_HOME", dir.path())
        .env_remove("ROBOSIM_SWEEP_DIE_ON")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("robosim sweep starts");
    let stderr = child.stderr.take().expect("stderr");
    let mut log = String::new();
    let mut victim = None;
    for line in BufReader::new(stderr).lines() {
        let line = line.expect("stderr line");
        log += &line;
        log.push('\n');
        if victim.is_none()
            && let Some(pid) = line
                .strip_prefix("sweep: worker 1 started: local process pid ")
                .and_then(|p| p.trim().parse::<u32>().ok())
        {
            // stopped first, so it cannot finish its job (or anything) before it is killed:
            // the coordinator must see it die whatever the timing
            for sig in ["-STOP", "-KILL"] {
                let s = Command::new("kill")
                    .args([sig, &pid.to_string()])
                    .status()
                    .expect("kill runs");
                assert!(s.success(), "kill {sig} {pid}");
            }
            victim = Some(pid);
        }
    }
    let status = child.wait().expect("wait");
    assert!(status.success(), "{log}");
    let pid = victim.expect("worker 1's start line");
    assert!(
        log.contains(&format!("(pid {pid}) died")),
        "the death of {pid} is not logged:\n{log}"
    );
    let csv = std::fs::read_to_string(dir.path().join("outside.csv")).expect("outside.csv");
    assert_eq!(csv, one, "{log}");
}

#[test]
fn a_job_the_study_refuses_at_run_time_is_a_row_with_its_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("w.csv");
    // a branch 5 m above the flange does not meet the pipe: no saddle seam
    let o = Command::new(ROBOSIM)
        .args(["sweep", "welding", "--workers", "2"])
        .args(["--param", "seam=saddle", "--param", "branch_height=0.18,5"])
        .args(["--param", "step=2", "--param", "speed=20"])
        .arg("--out")
        .arg(&out)
        .output()
        .expect("robosim runs");
    ok(&o);
    let csv = std::fs::read_to_string(&out).expect("w.csv");
    let t = rows(&csv);
    assert_eq!(t.len(), 3, "{csv}");
    let err = col(&t, "error");
    let covered = col(&t, "covered_pct");
    assert_eq!(t[1][err], "", "{csv}");
    assert!(
        t[1][covered].parse::<f64>().expect("covered") > 0.0,
        "{csv}"
    );
    assert!(!t[2][err].is_empty(), "{csv}");
    assert_eq!(t[2][covered], "", "{csv}");
}

#[test]
fn bad_input_is_refused_by_name_without_a_panic() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("never.csv");
    let cases: &[(&[&str], &str)] = &[
        (
            &["sweep", "surgery", "--param", "bits=8"],
            "unknown study \"surgery\"",
        ),
        (
            &["sweep", "surgical", "--param", "elbow=1,2"],
            "--param \"elbow=1,2\": study surgical has no parameter \"elbow\"",
        ),
        (
            &["sweep", "surgical", "--param", "upper_arm=0.2:0.3"],
            "--param \"upper_arm=0.2:0.3\": range \"0.2:0.3\": expected A:B:N",
        ),
        (
            &["sweep", "surgical", "--param", "upper_arm=0.2:0.3:0"],
            "the count must be at least 1",
        ),
        (
            &["sweep", "surgical", "--param", "upper_arm=0.2,nan"],
            "--param \"upper_arm=0.2,nan\": \"nan\" is not a finite number",
        ),
        (
            &["sweep", "surgical", "--param", "upper_arm"],
            "--param \"upper_arm\": expected NAME=A:B:N",
        ),
        (
            &["sweep", "surgical", "--param", "bits=8:16:4"],
            "--param \"bits=8:16:4\": bits = 10.66666666666666",
        ),
        (
            &["sweep", "welding", "--param", "mode=0:1:2"],
            "mode is a choice (bbox, polygon, exact)",
        ),
        (
            &["sweep", "welding", "--param", "mode=exact,fast"],
            "mode \"fast\": expected one of bbox, polygon, exact",
        ),
        (
            &["sweep", "welding", "--param", "speed=4,400"],
            "point 1 (speed=400): travel speed 400 mm/s",
        ),
        (
            &[
                "sweep", "surgical", "--param", "bits=8", "--param", "bits=12",
            ],
            "--param \"bits\": given twice",
        ),
        (&["sweep", "surgical", "--workers", "0"], "no workers"),
    ];
    for (args, want) in cases {
        let o = Command::new(ROBOSIM)
            .args(*args)
            .arg("--out")
            .arg(&out)
            .env_remove("ROBOSIM_SWEEP_DIE_ON")
            .output()
            .expect("robosim runs");
        let err = text(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(
            err.contains(want),
            "{args:?}: {err:?} does not say {want:?}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} wrote a CSV");
    }
}

// ---- workers on another machine: `robosim sweep-host` over Zenoh, TCP on localhost ----

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// A `robosim sweep-host` process, killed (SIGKILL) and reaped when dropped.
struct Host {
    child: std::process::Child,
    endpoint: String,
    log: std::sync::Arc<std::sync::Mutex<String>>,
}

impl Host {
    /// Starts a host with `workers` workers on a free port and waits for its ready line.
    fn start(workers: usize) -> Host {
        Host::start_in(&[], &format!("tcp/127.0.0.1:{}", free_port()), workers)
    }
    /// Starts a host listening on `endpoint` under `wrapper` (`ip netns exec NS`: on another
    /// network host) and waits for its ready line.
    fn start_in(wrapper: &[&str], endpoint: &str, workers: usize) -> Host {
        let endpoint = endpoint.to_owned();
        let mut child = wrapped(wrapper)
            .args(["sweep-host", "--listen", &endpoint, "--workers"])
            .arg(workers.to_string())
            .env_remove("ROBOSIM_SWEEP_DIE_ON")
            .env_remove("ROBOSIM_SWEEP_DIE_ONCE")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("robosim sweep-host starts");
        let mut lines = BufReader::new(child.stderr.take().expect("stderr")).lines();
        let log = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        let mut first = String::new();
        for line in lines.by_ref() {
            let line = line.expect("host stderr");
            first += &line;
            first.push('\n');
            if line.starts_with("sweep-host: listening on") {
                break;
            }
        }
        assert!(
            first.contains(&format!("listening on {endpoint}")),
            "the host did not start:\n{first}"
        );
        *log.lock().expect("log") = first;
        let l = log.clone();
        // keep reading so the host never blocks on a full pipe
        std::thread::spawn(move || {
            for line in lines.map_while(Result::ok) {
                let mut g = l.lock().expect("log");
                *g += &line;
                g.push('\n');
            }
        });
        Host {
            child,
            endpoint,
            log,
        }
    }
    fn log(&self) -> String {
        self.log.lock().expect("log").clone()
    }
}

impl Drop for Host {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn remote_workers_on_a_sweep_host_give_the_one_worker_csv() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let host = Host::start(2);
    let o = sweep(
        dir.path(),
        "remote.csv",
        &["--workers", "0", "--remote", &host.endpoint],
        &[],
    );
    let log = ok(&o);
    let csv = std::fs::read_to_string(dir.path().join("remote.csv")).expect("remote.csv");
    assert_eq!(csv, one, "{log}\nhost:\n{}", host.log());
    assert!(
        log.contains(&format!(
            "sweep: {}: a sweep host with 2 workers",
            host.endpoint
        )),
        "{log}"
    );
    assert_eq!(
        log.matches(&format!("started: remote {} pipe ", host.endpoint))
            .count(),
        2,
        "{log}"
    );
    assert!(!log.contains("died"), "{log}");
    assert!(
        text(&o.stdout).contains("4 ran, 0 failed; 0 worker deaths"),
        "{}",
        text(&o.stdout)
    );
}

/// `robosim`, run by `wrapper` (`ip netns exec NS`) unless it is empty.
fn wrapped(wrapper: &[&str]) -> Command {
    match wrapper.split_first() {
        Some((cmd, args)) => {
            let mut c = Command::new(cmd);
            c.args(args).arg(ROBOSIM);
            c
        }
        None => Command::new(ROBOSIM),
    }
}

/// Runs `robosim sweep surgical` with `extra` (under `wrapper`, see [`wrapped`]), writing
/// `csv` in `dir`, and hands `on_line` each line of its stderr as it comes (to act on the
/// sweep mid-way). Returns whether it succeeded, its stderr and its stdout.
fn sweep_watched(
    dir: &Path,
    csv: &str,
    extra: &[&str],
    wrapper: &[&str],
    on_line: &mut dyn FnMut(&str),
) -> (bool, String, String) {
    let mut child = wrapped(wrapper)
        .arg("sweep")
        .arg("surgical")
        .args(PARAMS)
        .args(extra)
        .arg("--out")
        .arg(dir.join(csv))
        .env("ROBOSIM_HOME", dir)
        .env_remove("ROBOSIM_SWEEP_DIE_ON")
        .env_remove("ROBOSIM_SWEEP_DIE_ONCE")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("robosim sweep starts");
    let stderr = child.stderr.take().expect("stderr");
    let mut log = String::new();
    for line in BufReader::new(stderr).lines() {
        let line = line.expect("stderr line");
        log += &line;
        log.push('\n');
        on_line(&line);
    }
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut child.stdout.take().expect("stdout"), &mut stdout)
        .expect("stdout");
    let status = child.wait().expect("wait");
    (status.success(), log, stdout)
}

/// Sends `sig` ("-STOP", "-KILL"…) to `pid`.
fn signal(sig: &str, pid: u32) {
    let s = Command::new("kill")
        .args([sig, &pid.to_string()])
        .status()
        .expect("kill runs");
    assert!(s.success(), "kill {sig} {pid}");
}

#[test]
fn a_sweep_host_killed_mid_sweep_has_its_jobs_redone_locally() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let mut host = Host::start(1);
    let pid = host.child.id();
    let mut killed = false;
    let (ok, log, stdout) = sweep_watched(
        dir.path(),
        "host-killed.csv",
        &["--workers", "1", "--remote", &host.endpoint.clone()],
        &[],
        &mut |line| {
            if !killed && line.starts_with("sweep: worker 1 started: remote ") {
                // stopped first, so its worker cannot answer anything before the kill, then
                // SIGKILL: whatever the timing, the host is gone mid-sweep
                signal("-STOP", pid);
                signal("-KILL", pid);
                killed = true;
            }
        },
    );
    let _ = host.child.wait();
    assert!(ok, "{log}\n{stdout}");
    assert!(killed, "the remote worker never started:\n{log}");
    assert!(
        log.contains("died: its output ended (its host is gone"),
        "the host's death is not seen:\n{log}"
    );
    assert!(stdout.contains("4 ran, 0 failed"), "{stdout}\n{log}");
    let csv = std::fs::read_to_string(dir.path().join("host-killed.csv")).expect("host-killed.csv");
    assert_eq!(csv, one, "{log}");
}

/// The link to the only host lapses mid-sweep (the host is stopped with SIGSTOP past the 3 s
/// link lease, so the coordinator sees its token go) and comes back (SIGCONT: Zenoh
/// reconnects): the sweep waits for the host instead of giving its workers up, then runs the
/// rest there; the CSV is the one-worker CSV.
#[test]
fn a_sweep_host_whose_link_lapsed_is_used_again_when_it_is_back() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let host = Host::start(1);
    let pid = host.child.id();
    let (mut stopped, mut continued) = (false, false);
    let (ok, log, stdout) = sweep_watched(
        dir.path(),
        "host-back.csv",
        &[
            "--workers",
            "0",
            "--remote",
            &host.endpoint.clone(),
            "--remote-wait",
            "120",
        ],
        &[],
        &mut |line| {
            if !stopped && line.starts_with("sweep: worker 0 started: remote ") {
                signal("-STOP", pid);
                stopped = true;
            }
            if stopped
                && !continued
                && line.starts_with("sweep: worker 0 (remote ")
                && line.contains(") waits: its host at ")
            {
                signal("-CONT", pid);
                continued = true;
            }
        },
    );
    if !continued {
        signal("-CONT", pid);
    }
    assert!(ok, "{log}\n{stdout}\nhost:\n{}", host.log());
    assert!(continued, "the sweep never waited for its host:\n{log}");
    assert!(
        log.contains("died: its output ended (its host is gone (the link to it closed or lapsed))"),
        "{log}"
    );
    assert!(log.contains("sweep: worker 0 (remote "), "{log}");
    assert!(log.contains(") can start again"), "{log}");
    assert!(
        log.matches("sweep: worker 0 started: remote ").count() >= 2,
        "the host was not used again:\n{log}"
    );
    assert!(!log.contains("given up"), "{log}");
    assert!(stdout.contains("4 ran, 0 failed"), "{stdout}\n{log}");
    let csv = std::fs::read_to_string(dir.path().join("host-back.csv")).expect("host-back.csv");
    assert_eq!(csv, one, "{log}\nhost:\n{}", host.log());
}

#[test]
fn a_remote_endpoint_with_no_host_is_refused_by_name() {
    let dir = tempfile::tempdir().expect("temp dir");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let o = sweep(
        dir.path(),
        "none.csv",
        &[
            "--workers",
            "0",
            "--remote",
            &endpoint,
            "--remote-wait",
            "2",
        ],
        &[],
    );
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(
        err.contains(&format!(
            "--remote {endpoint}: no sweep host answered within 2 s"
        )),
        "{err}"
    );
    assert!(!dir.path().join("none.csv").exists());
}

/// The host and the coordinator on two network hosts (namespaces joined by a veth pair; root
/// and iproute2, as in CI): the link is cut mid-sweep (`ip link set … down`) until the
/// coordinator has seen the host go, then restored; the sweep waits, reconnects, runs the rest
/// on the same host and gives the one-worker CSV.
#[test]
fn a_cut_link_to_a_sweep_host_on_another_network_host_is_waited_out() {
    let hosts = match common::Hosts::make("sw") {
        Ok(h) => h,
        Err(why) => {
            assert!(
                std::env::var_os("CI").is_none(),
                "the two-host sweep test could not make its hosts: {why}"
            );
            eprintln!("skipped: cannot make network namespaces here ({why})");
            return;
        }
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let one = reference(dir.path());
    let host = Host::start_in(&["ip", "netns", "exec", &hosts.a], "tcp/10.77.0.1:7448", 1);
    let (mut cut, mut restored) = (false, false);
    let (ok, log, stdout) = sweep_watched(
        dir.path(),
        "cut.csv",
        &[
            "--workers",
            "0",
            "--remote",
            "tcp/10.77.0.1:7448",
            "--remote-wait",
            "120",
        ],
        &["ip", "netns", "exec", &hosts.b],
        &mut |line| {
            if !cut && line.starts_with("sweep: worker 0 started: remote ") {
                hosts.link(false);
                cut = true;
            }
            if cut && !restored && line.contains(") waits: its host at tcp/10.77.0.1:7448 is gone")
            {
                hosts.link(true);
                restored = true;
            }
        },
    );
    if !restored {
        hosts.link(true);
    }
    assert!(ok, "{log}\n{stdout}\nhost:\n{}", host.log());
    assert!(restored, "the sweep never waited for its host:\n{log}");
    assert!(log.contains(") can start again"), "{log}");
    assert!(
        log.matches("sweep: worker 0 started: remote ").count() >= 2,
        "the host was not used again:\n{log}"
    );
    assert!(stdout.contains("4 ran, 0 failed"), "{stdout}\n{log}");
    let csv = std::fs::read_to_string(dir.path().join("cut.csv")).expect("cut.csv");
    assert_eq!(csv, one, "{log}\nhost:\n{}", host.log());
}
