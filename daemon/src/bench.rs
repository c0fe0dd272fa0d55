//! `robosim bench reaction`: what a change costs the simulator daemon, keeper to state, and
//! what a 30-step MOVEJI costs it — for any `robosim` binary, so one run measures the binary
//! built from this tree ("after") and, with `--before PATH`, a binary built from an older
//! commit ("before") on the same machine, scenes and requests. Written to
//! `docs/bench/reaction.{md,csv}`.
//!
//! Per binary and scene (three scenes of growing size: the PUMA 560 alone, the surgical
//! positioner cell of seed §2.7, the Space Station of chapter 4 with its five manipulators):
//! * **reaction**: a keeper and a daemon (`--mode fast`, publishing every step) are started; a
//!   writer (this process) commits a one-joint change of the first robot and waits for the
//!   first state record the daemon publishes for that version, and checks that it carries the
//!   new joint value. Median and p90 over the repetitions; the writer's acknowledgement time
//!   alone is the baseline measured beside it.
//! * **MOVEJI 30 steps**: the daemon runs in lockstep (idle: it sleeps between polls); a
//!   `robosim query --session` process, its own collision check off (C_SWITCH: the move is the
//!   same for both binaries and is not stopped by a contact), moves the first robot in 30
//!   journaled steps; then the
//!   writer steps the daemon once and waits for its record of the last version. Reported: the
//!   query's answer time, the daemon's CPU time over the whole move (from /proc, 10 ms ticks)
//!   and its idle CPU over the same wall time (the baseline).

use robosim_instance_space::state::{CommandSender, StateSubscriber};
use robosim_instance_space::{Client, Reader, Session};
use robosim_scene::{CompiledRobot, CompiledScene, joint_tx};
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, String>;

fn e<E: std::fmt::Display>(what: &str) -> impl Fn(E) -> String + '_ {
    move |err| format!("{what}: {err}")
}

/// The scenes measured, smallest first.
pub const SCENES: &[&str] = &["puma560", "surgical_positioner_cell", "space_station"];

struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.0.id().to_string()])
            .status();
        let _ = self.0.wait();
    }
}

fn spawn(bin: &Path, args: &[&str]) -> Result<Proc> {
    Command::new(bin)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map(Proc)
        .map_err(e("spawn"))
}

fn wait_until<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> Result<T> {
    let start = Instant::now();
    loop {
        if let Some(v) = f() {
            return Ok(v);
        }
        if start.elapsed() > Duration::from_secs(60) {
            return Err(format!("timed out waiting for {what}"));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// User + system CPU time of `pid`, s (10 ms resolution: /proc's clock ticks).
fn cpu_s(pid: u32) -> Result<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).map_err(e("proc stat"))?;
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // utime and stime are fields 14 and 15 (1-based) of the whole line: 11 and 12 here.
    Ok((ticks(11) + ticks(12)) / 100.0)
}

/// A value of joint 1 at fraction `f` of its range (around `q0` when the range is unbounded).
fn inside(robot: &robosim_kinematics::Robot, q0: f64, f: f64) -> f64 {
    let [lo, hi] = robot.joints[0].qlim;
    if lo.is_finite() && hi.is_finite() {
        lo + (hi - lo) * f
    } else {
        q0 + (f - 0.5)
    }
}

fn median_p90(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    (at(0.5), at(0.9))
}

/// One row of the report.
struct Row {
    binary: String,
    scene: String,
    objects: usize,
    vertices: usize,
    robots: usize,
    ack_ms: (f64, f64),
    reaction_ms: (f64, f64),
    moveji_ms: f64,
    moveji_cpu_s: f64,
    idle_cpu_s: f64,
}

fn measure(bin: &Path, label: &str, scene: &str, reps: usize) -> Result<Row> {
    // session names are at most 24 characters: pid, binary label and scene, shortened
    let short = |t: &str, n: usize| t.chars().take(n).collect::<String>();
    let name = format!(
        "rx{}-{}-{}",
        std::process::id(),
        short(label, 3),
        short(scene, 5)
    );
    let session = Session::open(Some(&name)).map_err(e("session"))?;
    let _ = std::fs::remove_dir_all(session.data_dir());
    let session = Session::open(Some(&name)).map_err(e("session"))?;
    let result = (|| {
        let _keeper = spawn(
            bin,
            &["space", "--session", &name, "--scene", scene, "--no-sync"],
        )?;
        let mut client = wait_until("keeper", || Client::connect(&session, "bench").ok())?;
        let mut reader = Reader::attach(&session, "bench").map_err(e("reader"))?;
        let (robot, (objects, vertices, robots)) = first_robot(&mut reader, scene)?;

        // Reaction: fast mode, every step published.
        let (ack, reaction) = reaction_times(
            bin,
            &name,
            &session,
            &mut client,
            &robot,
            reps,
            label,
            scene,
        )?;

        // MOVEJI: lockstep daemon, CPU from /proc.
        let (moveji_ms, moveji_cpu_s, idle_cpu_s) =
            moveji(bin, &name, &session, &mut reader, &robot, label, scene)?;
        Ok(Row {
            binary: label.to_owned(),
            scene: scene.to_owned(),
            objects,
            vertices,
            robots,
            ack_ms: median_p90(ack),
            reaction_ms: median_p90(reaction),
            moveji_ms,
            moveji_cpu_s,
            idle_cpu_s,
        })
    })();
    let _ = std::fs::remove_dir_all(session.dir());
    result
}

/// Waits for the keeper's model: its first robot, and the scene's (objects, vertices,
/// robots).
fn first_robot(reader: &mut Reader, scene: &str) -> Result<(CompiledRobot, (usize, usize, usize))> {
    let snap = wait_until("model", || {
        reader.refresh().ok()?;
        reader.snapshot().filter(|s| !s.is_empty())
    })?;
    let scene_model = CompiledScene::of(&snap);
    let robot = scene_model
        .robots()
        .first()
        .ok_or_else(|| format!("{scene} has no robot"))?
        .clone();
    let (objects, vertices, robots) = (snap.len(), snap.vertex_count(), scene_model.robots().len());
    drop(snap);
    Ok((robot, (objects, vertices, robots)))
}

/// The reaction measurement: a daemon in fast mode, publishing every step; `reps` one-joint
/// changes of `robot` committed by `client`, each timed to its acknowledgement and to the
/// daemon's first state record of its version (checked to carry the new value). Returns the
/// (acknowledgement, reaction) times, ms.
#[allow(clippy::too_many_arguments)]
fn reaction_times(
    bin: &Path,
    name: &str,
    session: &Session,
    client: &mut Client,
    robot: &CompiledRobot,
    reps: usize,
    label: &str,
    scene: &str,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let mut ack = Vec::new();
    let mut reaction = Vec::new();
    {
        let _daemon = spawn(
            bin,
            &[
                "simulator",
                "--session",
                name,
                "--mode",
                "fast",
                "--publish-hz",
                "1e9",
            ],
        )?;
        let mut state = wait_until("state service", || {
            StateSubscriber::open(session, "simulator", "bench").ok()
        })?;
        wait_until("first state", || {
            state
                .wait(Duration::from_millis(50))
                .ok()
                .filter(|r| !r.is_empty())
        })?;
        for k in 0..reps {
            let mut q = robot.q.clone();
            // Alternate between two values inside the limits: every change is real.
            q[0] = inside(
                &robot.robot,
                robot.q[0],
                if k % 2 == 0 { 0.45 } else { 0.55 },
            );
            let tx = joint_tx(&robot.robot, &robot.links, &q);
            state.drain().map_err(e("drain"))?;
            let t0 = Instant::now();
            let v = client.transact(&tx).map_err(e("transact"))?.version;
            let t_ack = t0.elapsed();
            let link = robot.links[0];
            let seen = wait_until("state of the new version", || {
                let recs = state.wait(Duration::from_millis(20)).ok()?;
                recs.into_iter().find(|r| r.header.structure_version >= v)
            })?;
            let t_seen = t0.elapsed();
            let qj = seen.joints.iter().find(|j| j.id == link).map(|j| j.q);
            if qj.is_none_or(|x| (x - q[0]).abs() > 1e-9) {
                return Err(format!(
                    "{label} {scene}: state for version {v} has joint 1 at {qj:?}, committed {}",
                    q[0]
                ));
            }
            ack.push(t_ack.as_secs_f64() * 1e3);
            reaction.push(t_seen.as_secs_f64() * 1e3);
        }
    }
    Ok((ack, reaction))
}

/// The MOVEJI measurement: a daemon in lockstep; a `robosim query` process (warmed up, its
/// collision check off) moves `robot` in 30 steps, then the daemon is stepped to the last
/// version. Returns the query's answer time (ms), the daemon's CPU time over the move and
/// its idle CPU time over the same wall time (s).
fn moveji(
    bin: &Path,
    name: &str,
    session: &Session,
    reader: &mut Reader,
    robot: &CompiledRobot,
    label: &str,
    scene: &str,
) -> Result<(f64, f64, f64)> {
    let daemon = spawn(bin, &["simulator", "--session", name, "--mode", "lockstep"])?;
    let pid = daemon.0.id();
    let mut state = wait_until("state service", || {
        StateSubscriber::open(session, "simulator", "bench").ok()
    })?;
    let mut ctl = wait_until("command service", || {
        CommandSender::open(session, "simulator", "bench").ok()
    })?;
    let step_and_wait = |ctl: &mut CommandSender, state: &mut StateSubscriber, v: u64| {
        ctl.send(br#"{"cmd": "step", "n": 1}"#, Duration::from_secs(30))
            .map_err(e("step"))?;
        wait_until("lockstep state", || {
            let recs = state.wait(Duration::from_millis(20)).ok()?;
            recs.into_iter().find(|r| r.header.structure_version >= v)
        })
    };
    reader.refresh().map_err(e("refresh"))?;
    let v0 = reader.snapshot().map_or(0, |s| s.version());
    step_and_wait(&mut ctl, &mut state, v0)?;
    let (mut query, mut qin, mut qout, mut line) = query_process(bin, name, robot)?;
    let mut target = robot.q.clone();
    target[0] = inside(&robot.robot, robot.q[0], 0.52);
    let req = serde_json::json!({"op": "moveji", "robot": robot.name(), "q": target, "steps": 30});
    let cpu0 = cpu_s(pid)?;
    let t0 = Instant::now();
    writeln!(qin, "{req}").map_err(e("write"))?;
    line.clear();
    qout.read_line(&mut line).map_err(e("read"))?;
    let moveji_ms = t0.elapsed().as_secs_f64() * 1e3;
    let answer: serde_json::Value = serde_json::from_str(&line).map_err(e("answer"))?;
    let v_end = answer["version"]
        .as_u64()
        .ok_or(format!("moveji answered {line}"))?;
    if answer["steps_done"].as_u64() != Some(30) {
        return Err(format!(
            "{label} {scene}: moveji did not take 30 steps: {line}"
        ));
    }
    step_and_wait(&mut ctl, &mut state, v_end)?;
    let wall = t0.elapsed();
    let moveji_cpu_s = cpu_s(pid)? - cpu0;
    // The idle baseline: the same wall time with nothing to do.
    let idle0 = cpu_s(pid)?;
    std::thread::sleep(wall.max(Duration::from_millis(200)));
    let idle_cpu_s = (cpu_s(pid)? - idle0) * wall.as_secs_f64()
        / wall.max(Duration::from_millis(200)).as_secs_f64();
    drop(qin);
    let _ = query.wait();
    drop(daemon);
    Ok((moveji_ms, moveji_cpu_s, idle_cpu_s))
}

/// Starts a `robosim query` process on session `name` and warms it up (attach, first
/// snapshot: a `get_robot` of `robot`), then turns its collision check off: the process, its
/// stdin, its stdout and the line buffer its answers were read into.
fn query_process(
    bin: &Path,
    name: &str,
    robot: &CompiledRobot,
) -> Result<(Child, ChildStdin, BufReader<ChildStdout>, String)> {
    let mut query = Command::new(bin)
        .args(["query", "--session", name])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(e("query"))?;
    let mut qin = query.stdin.take().ok_or("query stdin")?;
    let mut qout = BufReader::new(query.stdout.take().ok_or("query stdout")?);
    // Warm the query process (attach, first snapshot) before timing.
    writeln!(qin, r#"{{"op": "get_robot", "robot": "{}"}}"#, robot.name()).map_err(e("write"))?;
    let mut line = String::new();
    qout.read_line(&mut line).map_err(e("read"))?;
    // The query process's per-step collision check is off (C_SWITCH): the bench measures
    // what the 30 transactions cost the daemon, and the station's alpha joints rest inside
    // their truss bay (a contact at q = 0 that would stop any MOVEJI at step 0).
    writeln!(qin, r#"{{"op": "c_switch", "on": false}}"#).map_err(e("write"))?;
    line.clear();
    qout.read_line(&mut line).map_err(e("read"))?;
    Ok((query, qin, qout, line))
}

/// Runs the bench for `after` (and `before`, if given) and writes reaction.md/.csv to `out`.
pub fn run(out: &Path, quick: bool, after: &Path, before: Option<&Path>) -> Result<Vec<PathBuf>> {
    let reps = if quick { 10 } else { 100 };
    let mut bins: Vec<(&str, &Path)> = Vec::new();
    if let Some(b) = before {
        bins.push(("before", b));
    }
    bins.push(("after", after));
    let mut rows = Vec::new();
    for scene in SCENES {
        for (label, bin) in &bins {
            eprintln!("reaction: {label} {scene}");
            rows.push(measure(bin, label, scene, reps)?);
        }
    }
    std::fs::create_dir_all(out).map_err(e("create out"))?;
    let mut csv = String::from(
        "binary,scene,objects,vertices,robots,ack_ms_p50,reaction_ms_p50,reaction_ms_p90,moveji30_ms,moveji30_daemon_cpu_s,idle_cpu_s\n",
    );
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Keeper → simulator reaction and a 30-step MOVEJI\n\nRegenerate: `cargo run --release -- bench reaction{}` \
         (one run, {reps} one-joint changes per scene; `--before` names a `robosim` binary built from an \
         older commit, measured in the same run).\n",
        if before.is_some() {
            " --before PATH"
        } else {
            ""
        }
    );
    let _ = writeln!(
        md,
        "| binary | scene | objects | vertices | robots | ack p50 ms | reaction p50 ms | reaction p90 ms | MOVEJI 30 ms | daemon CPU during MOVEJI s | idle CPU same time s |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        // the CSV keeps one more digit than the table
        let cells = |p: usize| {
            [
                r.binary.to_string(),
                r.scene.to_string(),
                r.objects.to_string(),
                r.vertices.to_string(),
                r.robots.to_string(),
                format!("{:.*}", p + 1, r.ack_ms.0),
                format!("{:.*}", p + 1, r.reaction_ms.0),
                format!("{:.*}", p + 1, r.reaction_ms.1),
                format!("{:.*}", p - 1, r.moveji_ms),
                format!("{:.*}", p, r.moveji_cpu_s),
                format!("{:.*}", p, r.idle_cpu_s),
            ]
        };
        let _ = writeln!(csv, "{}", cells(3).join(","));
        let _ = writeln!(md, "| {} |", cells(2).join(" | "));
    }
    if before.is_some() {
        let _ = writeln!(md, "\nRatios before / after (same run):\n");
        for scene in SCENES {
            let find = |l: &str| rows.iter().find(|r| r.binary == l && r.scene == *scene);
            if let (Some(b), Some(a)) = (find("before"), find("after")) {
                // /proc counts CPU in 10 ms ticks: below one tick the ratio is a lower bound
                let tick = 0.01;
                let cpu = if a.moveji_cpu_s < tick {
                    format!(
                        "≥ {:.0}× (after: below one 10 ms tick)",
                        b.moveji_cpu_s / tick
                    )
                } else {
                    format!("{:.1}×", b.moveji_cpu_s / a.moveji_cpu_s)
                };
                let _ = writeln!(
                    md,
                    "* {scene}: reaction p50 {:.1}×, daemon CPU during MOVEJI {cpu} (minus idle: {:.2} s vs {:.2} s)",
                    b.reaction_ms.0 / a.reaction_ms.0,
                    (b.moveji_cpu_s - b.idle_cpu_s).max(0.0),
                    (a.moveji_cpu_s - a.idle_cpu_s).max(0.0)
                );
            }
        }
    }
    let csv_path = out.join("reaction.csv");
    let md_path = out.join("reaction.md");
    std::fs::write(&csv_path, csv).map_err(e("write csv"))?;
    std::fs::write(&md_path, md).map_err(e("write md"))?;
    Ok(vec![md_path, csv_path])
}
