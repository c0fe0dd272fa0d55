//! Issue #19 items 5, 9 and 14, with a real keeper, a real lock-step simulator daemon and the
//! real `robosim` binary: the simulator's state read with `simctl get` and the query
//! protocol's `sim_state`; the CSV log's time column and units; a `simctl` refusal said once,
//! on stderr; the run recorded to MCAP, read back with the `mcap` crate — closed with its
//! summary by `robosim down`, still streamable after `kill -9`.

use crate::common;

use common::{Procs, ROBOSIM, wait_for};
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const DT: f64 = 0.01;

/// Kinematic motion at 1 rad/s, joint limits, collision (bbox, no self-collision: the scene
/// has no obstacles, so every check is clear), and a CSV log of q and qd.
const EFFECTS: &str = r#"{"dt": 0.01, "max_speed": 1.0, "kinematics": true, "joint_limits": true,
    "collision": {"mode": "bbox", "self": false}, "logging": {"signals": ["q", "qd"]}}"#;

/// A keeper with the PUMA 560 scene and a lock-step daemon recording to `run.mcap`.
fn session_with_daemon(tag: &str) -> (Procs, u32, PathBuf) {
    let mut p = Procs::new(tag);
    let effects = p.home.path().join("effects.json");
    std::fs::write(&effects, EFFECTS).expect("effects");
    let mcap = p.home.path().join("run.mcap");
    p.start_keeper(&["--scene", "puma560"]);
    let eff = effects.to_str().expect("utf-8").to_owned();
    let rec = mcap.to_str().expect("utf-8").to_owned();
    let daemon = p.spawn(&[
        "simulator",
        "--mode",
        "lockstep",
        "--effects",
        &eff,
        "--record",
        &rec,
    ]);
    let session = p.session();
    wait_for("simulator registered", || {
        session
            .processes()
            .iter()
            .any(|x| x.role == "simulator" && x.pid == daemon)
            .then_some(())
    });
    (p, daemon, mcap)
}

fn simctl(p: &Procs, cmds: &[&str]) -> Output {
    Command::new(ROBOSIM)
        .arg("simctl")
        .args(["--session", &p.name])
        .args(cmds)
        .env("ROBOSIM_HOME", p.home.path())
        .output()
        .expect("simctl")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// `simctl get`, parsed; asserts it succeeded with one JSON line on stdout and nothing on
/// stderr.
fn get(p: &Procs) -> Value {
    let out = simctl(p, &["get"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stderr.is_empty(), "stderr: {}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    serde_json::from_str(&stdout).expect("get answers JSON")
}

/// Steps `n` lock-step steps and waits until `get` says they were taken.
fn step(p: &Procs, n: u64) -> Value {
    let out = simctl(p, &[&json!({"cmd": "step", "n": n}).to_string()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(text(&out.stdout), "ok\n");
    wait_for("the steps taken", || {
        let s = get(p);
        (s["state"] == "paused").then_some(s)
    })
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// The joint-state messages of `topic` streamed from `bytes`, stopping at the first record
/// that cannot be read (a file cut by `kill -9`): (log_time, publish_time, JSON).
fn stream(bytes: &[u8], topic: &str) -> Vec<(u64, u64, Value)> {
    mcap::MessageStream::new(bytes)
        .expect("MCAP magic")
        .map_while(Result::ok)
        .filter(|m| m.channel.topic == topic)
        .map(|m| {
            (
                m.log_time,
                m.publish_time,
                serde_json::from_slice(&m.data).expect("JSON message"),
            )
        })
        .collect()
}

/// `log_time == publish_time == k · dt` for k = 0, 1, …, in ns.
fn assert_times_k_dt(msgs: &[(u64, u64, Value)]) {
    for (k, (log, publish, _)) in msgs.iter().enumerate() {
        let want = (k as f64 * DT * 1e9).round() as u64;
        assert_eq!((*log, *publish), (want, want), "message {k}");
    }
}

/// Equal but for the last bit: the CSV is parsed by `str::parse` (correctly rounded), the JSON
/// by serde_json, whose default float parser may be one ulp off (both writers print the
/// shortest representation that round-trips).
fn assert_close(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= 1e-12 * x.abs().max(1.0),
            "{what}: {a:?} vs {b:?}"
        );
    }
}

fn csv(path: &Path) -> (String, Vec<Vec<f64>>) {
    let t = std::fs::read_to_string(path).expect("CSV log");
    let mut lines = t.lines();
    let header = lines.next().expect("header").to_owned();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().expect("number")).collect())
        .collect();
    (header, rows)
}

/// Item 5 and item 14: N lock-step steps; `get` (and `sim_state` over the query protocol)
/// reports t = N·dt and the q of the CSV log's last row; the log has `t_s` first and units in
/// its header; `robosim down` closes the recording with its summary: N + 1 messages per
/// state channel (the start state and one per step) at k·dt, schemas present.
#[test]
fn get_reports_the_lockstep_state_the_csv_log_has_and_down_closes_the_mcap_recording() {
    const N: u64 = 50;
    let (mut p, daemon, mcap_path) = session_with_daemon("rec");
    let target = r#"{"cmd": "target", "robot": "puma560", "q": [1.0, -0.5, 0, 0, 0, 0]}"#;
    let out = simctl(&p, &[target]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let s = step(&p, N);

    assert!(
        (s["t_s"].as_f64().expect("t_s") - N as f64 * DT).abs() < 1e-12,
        "{s}"
    );
    assert_eq!(s["steps"], N);
    assert_eq!(s["run_steps"], N);
    assert_eq!(s["dt_s"], DT);
    assert_eq!(s["mode"], "lockstep");
    assert_eq!(s["running"], false);
    assert_eq!(s["queued_steps"], 0);
    let r = &s["robots"][0];
    assert_eq!(r["name"], "puma560");
    assert_eq!(r["joint_types"], json!(vec!["revolute"; 6]));
    assert_eq!(r["joints"].as_array().map(Vec::len), Some(6));
    assert_eq!(floats(&r["target"]), [1.0, -0.5, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(r["contact"], false, "collision checked, nothing to hit");
    let q = floats(&r["q"]);
    assert!(
        (q[0] - 0.5).abs() < 1e-9 && (q[1] + 0.5).abs() < 1e-9,
        "1 rad/s for 0.5 s: {q:?}"
    );

    // The CSV log: time first, units in the header, its last row is what `get` says.
    let log = PathBuf::from(r["log"].as_str().expect("log path"));
    assert_eq!(log, p.session().run_dir().join("simulator-puma560.csv"));
    let (header, rows) = csv(&log);
    let want: Vec<String> = std::iter::once("t_s".to_owned())
        .chain((1..=6).map(|j| format!("q{j}_rad")))
        .chain((1..=6).map(|j| format!("qd{j}_rad_s")))
        .collect();
    assert_eq!(header, want.join(","));
    assert_eq!(rows.len() as u64, N, "one row per step");
    let last = rows.last().expect("rows");
    assert!((last[0] - N as f64 * DT).abs() < 1e-12, "t_s {}", last[0]);
    assert_close(&last[1..7], &q, "the log's last q is get's q");
    assert_close(&last[7..13], &floats(&r["qd"]), "and its qd");

    // The same state over the query protocol.
    let mut child = Command::new(ROBOSIM)
        .args(["query", "--session", &p.name])
        .env("ROBOSIM_HOME", p.home.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("query");
    writeln!(
        child.stdin.take().expect("stdin"),
        r#"{{"id": 7, "op": "sim_state"}}"#
    )
    .expect("write");
    let out = child.wait_with_output().expect("query output");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut answer: Value = serde_json::from_slice(&out.stdout).expect("one JSON answer");
    assert_eq!(answer["ok"], true, "{answer}");
    let m = answer.as_object_mut().expect("object");
    assert_eq!(m.remove("id"), Some(json!(7)));
    m.remove("ok");
    assert_eq!(answer, s, "sim_state answers what simctl get does");

    // `robosim down` stops the daemon with SIGTERM; it closes the recording.
    let down = Command::new(ROBOSIM)
        .args(["down", "--session", &p.name])
        .env("ROBOSIM_HOME", p.home.path())
        .output()
        .expect("down");
    assert!(down.status.success(), "{}", text(&down.stderr));
    let said = text(&down.stdout);
    assert!(
        said.contains(&format!("stopped simulator (pid {daemon})\n")),
        "stopped cleanly, not by SIGKILL: {said}"
    );
    let i = p
        .children
        .iter()
        .position(|c| c.id() == daemon)
        .expect("daemon child");
    let status = p.children.remove(i).wait().expect("wait");
    assert!(status.success(), "daemon exit: {status}");

    let bytes = std::fs::read(&mcap_path).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("readable summary")
        .expect("summary section present: the file was closed");
    let mut schemas: Vec<(String, String)> = summary
        .schemas
        .values()
        .map(|s| (s.name.clone(), s.encoding.clone()))
        .collect();
    schemas.sort();
    assert_eq!(
        schemas,
        [
            "foxglove.FrameTransforms",
            "foxglove.Log",
            "robosim.Contacts",
            "sensor_msgs/msg/JointState"
        ]
        .map(|n| (n.to_owned(), "jsonschema".to_owned()))
    );
    for s in summary.schemas.values() {
        let v: Value = serde_json::from_slice(&s.data).expect("schema is JSON");
        assert_eq!(v["title"], s.name.as_str());
    }
    let stats = summary.stats.as_ref().expect("statistics");
    let count = |topic: &str| {
        let (id, c) = summary
            .channels
            .iter()
            .find(|(_, c)| c.topic == topic)
            .unwrap_or_else(|| panic!("channel {topic}"));
        assert_eq!(c.message_encoding, "json");
        assert!(c.schema.is_some(), "{topic} has a schema");
        stats.channel_message_counts.get(id).copied().unwrap_or(0)
    };
    for topic in ["/puma560/joint_states", "/tf", "/contacts"] {
        assert_eq!(
            count(topic),
            N + 1,
            "{topic}: the start state and one per step"
        );
    }
    assert_eq!(
        count("/simulator/log"),
        2,
        "the target and the step command"
    );
    assert_eq!(stats.message_end_time, (N as f64 * DT * 1e9).round() as u64);

    let joints = stream(&bytes, "/puma560/joint_states");
    assert_eq!(joints.len() as u64, N + 1);
    assert_times_k_dt(&joints);
    let last = &joints.last().expect("messages").2;
    assert_eq!(
        floats(&last["position"]),
        q,
        "the last joint state is get's q"
    );
    assert_eq!(last["name"], r["joints"]);
    assert_eq!(
        floats(&joints[0].2["position"]),
        [0.0; 6],
        "the start state"
    );
    let tf = stream(&bytes, "/tf");
    assert_times_k_dt(&tf);
    let transforms = tf[0].2["transforms"].as_array().expect("transforms");
    assert_eq!(
        transforms.len(),
        7,
        "world → puma560, puma560 → its 6 links"
    );
    assert_eq!(transforms[0]["parent_frame_id"], "world");
    assert_eq!(transforms[1]["parent_frame_id"], "puma560");

    plots_say_what_the_run_did(&p, &mcap_path, &log);
}

/// Issue 39 item 10: `robosim plot` of the recording and of the CSV log draws what the run
/// did — 6 joints, q₁ from 0 to 0.5 rad and q₂ to −0.5 rad over 0.5 s, no contact, the two
/// commands marked — read back from plot.json (the figure's content), and the PNGs decode.
fn plots_say_what_the_run_did(p: &Procs, mcap: &Path, log: &Path) {
    let plot = |run: &Path, out: &Path| {
        let o = Command::new(ROBOSIM)
            .arg("plot")
            .arg(run)
            .arg("--out")
            .arg(out)
            .output()
            .expect("plot");
        assert!(o.status.success(), "{}", text(&o.stderr));
        let said = text(&o.stdout);
        let json: Value =
            serde_json::from_slice(&std::fs::read(out.join("plot.json")).expect("plot.json"))
                .expect("JSON");
        (said, json)
    };
    let range = |v: &Value| -> (f64, f64) {
        let r = floats(v);
        (r[0], r[1])
    };
    let near = |(a, b): (f64, f64), (c, d): (f64, f64), what: &str| {
        assert!(
            (a - c).abs() < 1e-9 && (b - d).abs() < 1e-9,
            "{what}: {a}..{b}, expected {c}..{d}"
        );
    };
    let out = p.home.path().join("plots-mcap");
    let (said, j) = plot(mcap, &out);
    assert!(said.contains("puma560.png (2 panels, 12 series)"), "{said}");
    let figures = j["figures"].as_array().expect("figures");
    let names: Vec<&str> = figures.iter().filter_map(|f| f["file"].as_str()).collect();
    assert_eq!(names, ["puma560.png", "contacts.png"]);
    let panels = figures[0]["panels"].as_array().expect("panels");
    let titles: Vec<&str> = panels.iter().filter_map(|x| x["title"].as_str()).collect();
    assert_eq!(
        titles,
        ["joint positions", "joint velocities"],
        "a kinematic run records no efforts (not zeros): no effort or work panel"
    );
    assert_eq!(panels[0]["series"].as_array().map(Vec::len), Some(6));
    near(range(&panels[0]["x_range"]), (0.0, 0.5), "time");
    near(range(&panels[0]["y_range"]), (-0.5, 0.5), "q");
    near(
        range(&panels[1]["y_range"]),
        (-1.0, 1.0),
        "q̇ at the 1 rad/s limit",
    );
    let contacts = &figures[1]["panels"][0];
    near(range(&contacts["y_range"]), (0.0, 0.0), "never a contact");
    assert_eq!(
        j["events"].as_array().map(Vec::len),
        Some(2),
        "target and step"
    );
    assert_eq!(j["truncated"], false);
    for f in ["puma560.png", "contacts.png"] {
        let png = std::fs::read(out.join(f)).expect("png");
        assert_eq!(&png[1..4], b"PNG", "{f}");
    }

    let out = p.home.path().join("plots-csv");
    let (_, j) = plot(log, &out);
    let panels = j["figures"][0]["panels"].as_array().expect("panels");
    assert_eq!(j["figures"][0]["file"], "puma560.png");
    assert_eq!(panels.len(), 2, "q and qd columns");
    near(
        range(&panels[0]["x_range"]),
        (DT, 0.5),
        "the log's rows: t = dt … 0.5 s",
    );
    near(range(&panels[0]["y_range"]), (-0.5, 0.5), "q in the log");
}

/// Item 9: a refusal is one message, once, on stderr, exit status 1; `ok` answers go to
/// stdout; the commands after a refused one are not sent.
#[test]
fn a_simctl_refusal_is_said_once_on_stderr_and_stops_the_commands_after_it() {
    let (p, _daemon, _) = session_with_daemon("refuse");
    let out = simctl(
        &p,
        &[
            "pause",
            r#"{"cmd": "step", "n": 0}"#,
            r#"{"cmd": "resume"}"#,
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(text(&out.stdout), "ok\n", "only the accepted pause");
    let err = text(&out.stderr);
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert_eq!(
        err.matches("must be an integer from 1 to").count(),
        1,
        "{err}"
    );
    assert!(
        err.contains(r#"refused {"cmd": "step", "n": 0}"#),
        "names the command: {err}"
    );
    assert_eq!(get(&p)["running"], false, "resume was not sent");

    // A command that is not one is refused before anything is sent.
    let out = simctl(&p, &["resume", "stpe"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let err = text(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(r#""stpe""#), "{err}");
    assert_eq!(get(&p)["running"], false, "resume was not sent");
}

/// Item 14 after `kill -9`: no summary, but streaming reads every message up to the last
/// flushed chunk — all of them, since an idle lock-step daemon has flushed everything.
#[test]
fn a_recording_cut_by_kill_9_streams_every_message_written_before_it() {
    const N: u64 = 20;
    let (p, daemon, mcap_path) = session_with_daemon("reck");
    let s = step(&p, N);
    let q = floats(&s["robots"][0]["q"]);
    let _ = Command::new("kill")
        .args(["-KILL", &daemon.to_string()])
        .status();
    wait_for("daemon gone", || {
        (!robosim_instance_space::pid_alive(daemon)).then_some(())
    });
    let bytes = std::fs::read(&mcap_path).expect("recording");
    assert!(
        !matches!(mcap::Summary::read(&bytes), Ok(Some(_))),
        "no summary after kill -9"
    );
    let joints = stream(&bytes, "/puma560/joint_states");
    assert_eq!(joints.len() as u64, N + 1, "nothing flushed was lost");
    assert_times_k_dt(&joints);
    assert_eq!(floats(&joints.last().expect("messages").2["position"]), q);
    assert_eq!(stream(&bytes, "/tf").len() as u64, N + 1);
}

/// Item 14, the display's side: `render --play … --record FILE.mcap` records every sample of
/// the trajectory as joint states (in SI units) and link poses at the file's dt, readable with
/// the `mcap` crate; the summary is written (the file is closed).
#[test]
fn a_render_playback_is_recorded_to_mcap_at_the_trajectorys_dt() {
    if robosim_display::skipped_without_vulkan(
        "a_render_playback_is_recorded_to_mcap_at_the_trajectorys_dt",
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("dir");
    let traj = dir.path().join("puma.traj");
    // Degrees for revolute joints; dt 0.05 s; 4 samples.
    std::fs::write(
        &traj,
        "# dt: 0.05\n0 0 0 0 0 0\n10 20 -30 0 45 0\n20 40 -60 0 45 0\n30 45 -90 10 45 0\n",
    )
    .expect("trajectory");
    let mcap_path = dir.path().join("play.mcap");
    let out = Command::new(ROBOSIM)
        .args(["render", "puma560", "--play"])
        .arg(format!("puma560={}", traj.display()))
        .arg("--record")
        .arg(&mcap_path)
        .output()
        .expect("render");
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let bytes = std::fs::read(&mcap_path).expect("recording");
    assert!(
        matches!(mcap::Summary::read(&bytes), Ok(Some(_))),
        "summary present"
    );
    let states = stream(&bytes, "/puma560/joint_states");
    assert_eq!(states.len(), 4, "one message per sample");
    for (k, (log, publish, _)) in states.iter().enumerate() {
        let want = (k as f64 * 0.05 * 1e9).round() as u64;
        assert_eq!((*log, *publish), (want, want), "sample {k}");
    }
    let last = floats(&states[3].2["position"]);
    let want: Vec<f64> = [30.0, 45.0, -90.0, 10.0, 45.0, 0.0]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect();
    assert_close(&last, &want, "last sample in rad");
    assert_eq!(stream(&bytes, "/tf").len(), 4, "link poses per sample");
}

/// A tmpfs of `size` mounted on a fresh directory, unmounted when dropped; `None` (with the
/// reason printed) when this process may not mount one (not root, or no CAP_SYS_ADMIN).
struct TinyFs {
    dir: tempfile::TempDir,
}

impl TinyFs {
    fn mount(size: &str) -> Option<TinyFs> {
        let uid = Command::new("id").arg("-u").output().ok()?;
        if text(&uid.stdout).trim() != "0" {
            eprintln!("skipped: mounting a tiny tmpfs needs root");
            return None;
        }
        let dir = tempfile::tempdir().expect("mount point");
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir.path())
            .output()
            .ok()?;
        if !out.status.success() {
            eprintln!("skipped: mount -t tmpfs failed: {}", text(&out.stderr));
            return None;
        }
        Some(TinyFs { dir })
    }
}

impl Drop for TinyFs {
    fn drop(&mut self) {
        let _ = Command::new("umount")
            .arg("-l")
            .arg(self.dir.path())
            .status();
    }
}

/// Issue 34 item 7: the disk filling up under `simulator --record FILE` made the whole
/// simulator exit. The recording stops with a message naming the file and the error; the
/// daemon keeps stepping and answering, and `get` reports the recording stopped and why.
#[test]
fn a_full_disk_stops_the_recording_and_the_simulator_keeps_simulating() {
    let Some(fs) = TinyFs::mount("96k") else {
        return;
    };
    let mut p = Procs::new("recfull");
    let effects = p.home.path().join("effects.json");
    std::fs::write(&effects, EFFECTS).expect("effects");
    let mcap = fs.dir.path().join("run.mcap");
    p.start_keeper(&["--scene", "puma560"]);
    let daemon = p.spawn(&[
        "simulator",
        "--mode",
        "lockstep",
        "--effects",
        effects.to_str().expect("utf-8"),
        "--record",
        mcap.to_str().expect("utf-8"),
    ]);
    let session = p.session();
    wait_for("simulator registered", || {
        session
            .processes()
            .iter()
            .any(|x| x.role == "simulator" && x.pid == daemon)
            .then_some(())
    });
    // Step until the file system is full (96 KiB: a few hundred samples at most).
    let mut s = get(&p);
    for _ in 0..200 {
        if s["recording"]["state"] == "stopped" {
            break;
        }
        let before = s["run_steps"].as_u64().expect("run_steps");
        s = step(&p, 20);
        assert_eq!(s["run_steps"].as_u64(), Some(before + 20), "{s}");
    }
    let rec = &s["recording"];
    assert_eq!(rec["state"], "stopped", "the disk filled up: {s}");
    let why = rec["stopped"].as_str().expect("why it stopped");
    assert!(
        why.contains(&mcap.display().to_string()) && why.contains("No space left on device"),
        "names the file and the error: {why}"
    );
    let written = rec["messages"].as_u64().expect("messages");
    assert!(written > 0, "{s}");
    // Still simulating and answering after it.
    let before = s["run_steps"].as_u64().expect("run_steps");
    let s = step(&p, 5);
    assert_eq!(
        s["run_steps"].as_u64(),
        Some(before + 5),
        "still stepping: {s}"
    );
    assert_eq!(s["recording"]["messages"].as_u64(), Some(written));
    let log = std::fs::read_to_string(
        p.home
            .path()
            .join("logs")
            .join(format!("{daemon}-simulator.log")),
    )
    .unwrap_or_default();
    assert_eq!(
        log.matches("the recording stopped; the simulation goes on")
            .count(),
        1,
        "said once: {log}"
    );
    assert!(p.stop(daemon).success(), "a clean stop after it: {log}");
    drop(p);
    drop(fs);
}
