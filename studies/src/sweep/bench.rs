//! `robosim bench sweep`: one sweep (the §2.7 surgical positioner, encoder bits × upper arm
//! × forearm length, 108 jobs) run in this process without workers (the baseline of the
//! study's own cost), on one local worker process and on two, then on one and two workers of a
//! `robosim sweep-host` reached over Zenoh (TCP on localhost), in the same run; wall time, jobs
//! per second and the speed-up over one local worker, written as sweep.md and sweep.csv. The
//! result tables are compared: the bench fails if any differs from the in-process one.

use super::cli::{ConnectRemote, Plan, csv, plan, study_named, sweep_local, sweep_on};
use super::coordinator::Options;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "?".into())
}

/// A `robosim sweep-host` on a free localhost port, killed and reaped when dropped; its stderr
/// is kept for the error of a failed connection.
struct Host {
    child: std::process::Child,
    endpoint: String,
    log: std::sync::Arc<std::sync::Mutex<String>>,
}

impl Host {
    fn start(exe: &Path, workers: usize) -> Result<Host, String> {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| format!("a free port: {e}"))?
            .port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let mut child = std::process::Command::new(exe)
            .args(["sweep-host", "--listen", &endpoint, "--workers"])
            .arg(workers.to_string())
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .map_err(|e| format!("{} sweep-host: {e}", exe.display()))?;
        let log = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        if let Some(err) = child.stderr.take() {
            let l = log.clone();
            std::thread::spawn(move || {
                use std::io::BufRead;
                for line in std::io::BufReader::new(err).lines().map_while(Result::ok) {
                    let mut g = l.lock().unwrap_or_else(|p| p.into_inner());
                    g.push_str(&line);
                    g.push('\n');
                }
            });
        }
        Ok(Host {
            child,
            endpoint,
            log,
        })
    }
    fn log(&self) -> String {
        self.log.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

impl Drop for Host {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One configuration's row of the tables: its name, workers, wall time (s), the load average
/// before it.
type Row = (String, usize, f64, String);

/// Runs the bench; `exe` is the robosim binary for the workers and the sweep host, `connect`
/// reaches a host's workers (`robosim sweep --remote`). Returns the files written.
pub fn run(
    out: &Path,
    quick: bool,
    exe: &Path,
    connect: ConnectRemote<'_>,
) -> Result<Vec<PathBuf>, String> {
    let def = study_named("surgical").map_err(|e| e.to_string())?;
    let params: Vec<String> = if quick {
        vec!["bits=12,16".into(), "upper_arm=0.2:0.24:2".into()]
    } else {
        vec![
            "bits=10,12,14,16".into(),
            "upper_arm=0.18:0.26:9".into(),
            "forearm=0.18,0.2,0.22".into(),
        ]
    };
    let p = plan(def, &params).map_err(|e| e.to_string())?;
    let jobs = &p.jobs;
    let mut rows: Vec<Row> = Vec::new();

    // baseline: the same jobs, one after another, in this process
    let load0 = load();
    let t0 = Instant::now();
    let outcomes: Vec<_> = jobs
        .iter()
        .map(|j| (def.run)(&j.params).map_err(|e| robosim_instance_space::error_chain(&e)))
        .collect();
    let serial_s = t0.elapsed().as_secs_f64();
    let reference = csv(def, &p.axes, jobs, &outcomes);
    rows.push(("in this process, no workers".into(), 0, serial_s, load0));

    let opts = Options::default();
    let mut walls = Vec::new();
    local_sweeps(&p, exe, &opts, &reference, &mut rows, &mut walls)?;
    host_sweeps(&p, exe, connect, &opts, &reference, &mut rows, &mut walls)?;
    write_tables(out, quick, &params, jobs.len(), serial_s, &rows, &walls)
}

/// The sweep on 1 and on 2 local worker processes, each checked against the in-process
/// `reference`: a row and a wall time each.
fn local_sweeps(
    p: &Plan,
    exe: &Path,
    opts: &Options,
    reference: &str,
    rows: &mut Vec<Row>,
    walls: &mut Vec<f64>,
) -> Result<(), String> {
    for workers in [1usize, 2] {
        let l = load();
        let ran = sweep_local(p, exe, workers, opts, None, &mut |line| eprintln!("{line}"))
            .map_err(|e| e.to_string())?;
        if ran.csv != reference {
            return Err(format!(
                "the sweep on {workers} worker(s) gave other results than the in-process run"
            ));
        }
        if ran.failed > 0 {
            return Err(format!("{} jobs failed on {workers} worker(s)", ran.failed));
        }
        walls.push(ran.wall_s);
        rows.push((
            format!(
                "{workers} worker process{}",
                if workers == 1 { "" } else { "es" }
            ),
            workers,
            ran.wall_s,
            l,
        ));
    }
    Ok(())
}

/// The same sweep on 1 and 2 workers of a sweep host, over Zenoh on localhost TCP, each
/// checked against the in-process `reference`: a row and a wall time each.
fn host_sweeps(
    p: &Plan,
    exe: &Path,
    connect: ConnectRemote<'_>,
    opts: &Options,
    reference: &str,
    rows: &mut Vec<Row>,
    walls: &mut Vec<f64>,
) -> Result<(), String> {
    let host = Host::start(exe, 2)?;
    for workers in [1usize, 2] {
        let mut launchers = connect(
            &host.endpoint,
            "robosim",
            std::time::Duration::from_secs(15),
        )
        .map_err(|e| format!("{e}\nthe host said:\n{}", host.log()))?;
        launchers.truncate(workers);
        let l = load();
        let ran = sweep_on(p, launchers, opts, None, &mut |line| eprintln!("{line}"))
            .map_err(|e| format!("{e}\nthe host said:\n{}", host.log()))?;
        if ran.csv != reference {
            return Err(format!(
                "the sweep on {workers} remote worker(s) gave other results than the in-process run"
            ));
        }
        if ran.failed > 0 || ran.stats.deaths > 0 {
            return Err(format!(
                "{} jobs failed and {} workers died on {workers} remote worker(s)",
                ran.failed, ran.stats.deaths
            ));
        }
        walls.push(ran.wall_s);
        rows.push((
            format!(
                "{workers} worker{} on a sweep host (Zenoh, localhost TCP)",
                if workers == 1 { "" } else { "s" }
            ),
            workers,
            ran.wall_s,
            l,
        ));
    }
    drop(host);
    Ok(())
}

/// sweep.md and sweep.csv in `out`: the configurations' rows with jobs per second and the
/// speed-up over 1 local worker (`walls`: 1 and 2 local workers, 1 and 2 on the host).
fn write_tables(
    out: &Path,
    quick: bool,
    params: &[String],
    n_jobs: usize,
    serial_s: f64,
    rows: &[Row],
    walls: &[f64],
) -> Result<Vec<PathBuf>, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let one = walls[0];
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut c = String::from(
        "configuration,workers,jobs,wall_s,jobs_per_s,speedup_over_1_local_worker,load_avg_1min_before\n",
    );
    let mut md = format!(
        "# Sweep: one parameter study on 1 and 2 worker processes, local and on a sweep host (`robosim bench sweep{}`)\n\n\
         The sweep: `robosim sweep surgical {}` — {} jobs, each the seed's §2.7 reach and \
         encoder-accuracy study (861 tool poses over the head: analytic IK, collision against \
         the head, the encoder bound) for one configuration. The same jobs are run in this \
         process one after another (no workers: the study's own cost), then by the coordinator \
         on 1 and on 2 `robosim sweep-worker` processes, then on 1 and 2 workers of one \
         `robosim sweep-host` process reached over Zenoh (TCP on localhost: the protocol and \
         its latency without a network's), in the same run; the five CSVs are identical \
         (checked). This machine: {cores} cores; build: {profile}. Wall time from \
         CLOCK_MONOTONIC, process start-up included. Speed-up = wall time on 1 local worker / \
         wall time.\n\n\
         | configuration | workers | jobs | wall (s) | jobs/s | speed-up over 1 local worker | load avg before |\n\
         |---|---:|---:|---:|---:|---:|---:|\n",
        if quick { " --quick" } else { "" },
        params
            .iter()
            .map(|p| format!("--param {p}"))
            .collect::<Vec<_>>()
            .join(" "),
        n_jobs,
        profile = if cfg!(debug_assertions) {
            "dev profile (opt-level 1, dependencies 2, debug assertions on)"
        } else {
            "release profile"
        },
    );
    for (name, workers, wall, l) in rows {
        let jps = n_jobs as f64 / wall;
        let speed = one / wall;
        c += &format!(
            "{name},{workers},{},{wall:.3},{jps:.2},{speed:.2},{l}\n",
            n_jobs
        );
        md += &format!(
            "| {name} | {workers} | {} | {wall:.2} | {jps:.2} | {speed:.2} | {l} |\n",
            n_jobs
        );
    }
    md += &format!(
        "\nSpeed-up of 2 workers over 1: **{:.2}×** local, **{:.2}×** on the sweep host; 1 \
         worker over the in-process run: {:.2}× (the cost of a process, its start and the \
         protocol); 1 worker on the host over 1 local worker: {:.2}× (the cost of the Zenoh \
         pipe and the host).\n",
        one / walls[1],
        walls[2] / walls[3],
        serial_s / one,
        one / walls[2],
    );
    let md_path = out.join("sweep.md");
    let csv_path = out.join("sweep.csv");
    std::fs::write(&md_path, md).map_err(|e| format!("{}: {e}", md_path.display()))?;
    std::fs::write(&csv_path, c).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    Ok(vec![md_path, csv_path])
}
