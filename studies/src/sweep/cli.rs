//! `robosim sweep STUDY --param … --workers N --out FILE.csv` and the hidden
//! `robosim sweep-worker` (src/main.rs only forwards here).

use super::SweepError;
use super::coordinator::{self, Options, Stats};
use super::protocol::Outcome;
use super::spec::{self, Axis, Job};
use super::study::{self, StudyDef};
use super::transport::{Launcher, LocalLauncher};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Debug, Clone)]
pub struct SweepArgs {
    /// The study: surgical (seed §2.7 reach and encoder accuracy), welding, or station
    /// (docs/studies.md lists each one's parameters and result columns).
    pub study: String,
    /// A swept parameter, NAME=A:B:N (N values evenly from A to B, both included) or
    /// NAME=V1,V2,… (numbers in the parameter's unit, or words for a choice). Repeat for more
    /// parameters: every combination is run, the first parameter varying slowest.
    pub params: Vec<String>,
    /// Worker processes on this machine [default: one per core]. 0 with --remote: only
    /// remote workers.
    pub workers: Option<usize>,
    /// Workers on another machine: the Zenoh endpoint where `robosim sweep-host` listens
    /// there, e.g. tcp/10.0.0.2:7448; as many workers as that host runs. Repeat for more hosts.
    pub remote: Vec<String>,
    /// Key prefix of the sweep hosts on the Zenoh network (their --key).
    pub remote_key: String,
    /// How long to wait for a --remote host, seconds: at the start for each to answer, and
    /// later, when every worker left is on a host whose link lapsed, for one to come back.
    pub remote_wait: f64,
    /// The CSV to write: the parameters' columns, then the study's result columns, then
    /// `error` (empty for a job that ran), one row per point in job order.
    pub out: PathBuf,
    /// How many times a job is tried when its worker dies running it.
    pub attempts: u32,
    /// Kill a worker whose job runs longer than this many seconds (counted as a death: the
    /// job is redone) [default: no limit].
    pub job_timeout: Option<f64>,
}

/// The study named `name`, or an error listing those there are.
pub fn study_named(name: &str) -> Result<&'static StudyDef, SweepError> {
    study::find(name).ok_or_else(|| SweepError::UnknownStudy {
        name: name.to_owned(),
        known: study::STUDIES
            .iter()
            .map(|s| s.name)
            .collect::<Vec<_>>()
            .join(", "),
    })
}

/// A sweep to run: the study, its axes and its jobs (every point checked by the study).
pub struct Plan {
    pub def: &'static StudyDef,
    pub axes: Vec<Axis>,
    pub jobs: Vec<Job>,
}

/// Parses the `--param`s of `def` into axes and jobs, and has the study check every point.
pub fn plan(def: &'static StudyDef, params: &[String]) -> Result<Plan, SweepError> {
    let axes = params
        .iter()
        .map(|a| spec::parse_axis(def, a))
        .collect::<Result<Vec<_>, _>>()?;
    let jobs = spec::jobs(&axes)?;
    for j in &jobs {
        (def.check)(&j.params).map_err(|e| SweepError::Point {
            index: j.index,
            point: point_words(j),
            source: e,
        })?;
    }
    Ok(Plan { def, axes, jobs })
}

fn point_words(j: &Job) -> String {
    if j.params.is_empty() {
        return "the study's defaults".into();
    }
    j.params
        .iter()
        .map(|(n, v)| format!("{n}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// One CSV field, quoted when it has a comma, quote or line break (RFC 4180).
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// The sweep's CSV text: header, then one row per job in job order.
pub fn csv(def: &StudyDef, axes: &[Axis], jobs: &[Job], outcomes: &[Outcome]) -> String {
    let mut header: Vec<String> = axes.iter().map(|a| field(&a.name)).collect();
    header.extend(def.results.iter().map(|r| r.to_string()));
    header.push("error".into());
    let mut out = header.join(",") + "\n";
    for (j, o) in jobs.iter().zip(outcomes) {
        let mut row: Vec<String> = j
            .params
            .iter()
            .map(|(_, v)| field(&v.to_string()))
            .collect();
        match o {
            Ok(values) => {
                row.extend(values.iter().map(|v| v.to_string()));
                row.push(String::new());
            }
            Err(e) => {
                row.extend(def.results.iter().map(|_| String::new()));
                row.push(field(e));
            }
        }
        out += &row.join(",");
        out.push('\n');
    }
    out
}

/// What one sweep did.
pub struct Ran {
    pub jobs: usize,
    pub failed: usize,
    pub wall_s: f64,
    pub stats: Stats,
    pub csv: String,
}

/// `workers` launchers of local `exe sweep-worker` processes.
pub fn local_launchers(exe: &Path, workers: usize) -> Vec<Box<dyn Launcher>> {
    (0..workers)
        .map(|_| {
            Box::new(LocalLauncher {
                exe: exe.to_owned(),
            }) as Box<dyn Launcher>
        })
        .collect()
}

/// Runs `plan` on `workers` local `exe sweep-worker` processes,
/// writes the CSV to `out` (when given) and logs worker events to `log`.
pub fn sweep_local(
    plan: &Plan,
    exe: &Path,
    workers: usize,
    opts: &Options,
    out: Option<&Path>,
    log: &mut dyn FnMut(String),
) -> Result<Ran, SweepError> {
    sweep_on(plan, local_launchers(exe, workers), opts, out, log)
}

/// Runs `plan` on the workers `launchers` start (one each), writes the CSV to `out` (when
/// given) and logs worker events to `log`.
pub fn sweep_on(
    plan: &Plan,
    launchers: Vec<Box<dyn Launcher>>,
    opts: &Options,
    out: Option<&Path>,
    log: &mut dyn FnMut(String),
) -> Result<Ran, SweepError> {
    let Plan { def, axes, jobs } = plan;
    let pb = robosim_report::progress::bar(jobs.len() as u64, &format!("sweep {}", def.name));
    let t0 = std::time::Instant::now();
    let (outcomes, stats) = coordinator::run(
        def.name,
        jobs,
        launchers,
        opts,
        &mut |line| pb.suspend(|| log(line)),
        &mut |remaining| pb.set_position((jobs.len() - remaining) as u64),
    )?;
    let wall_s = t0.elapsed().as_secs_f64();
    pb.finish_and_clear();
    let text = csv(def, axes, jobs, &outcomes);
    if let Some(path) = out {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|err| SweepError::Io {
                path: dir.to_owned(),
                err,
            })?;
        }
        std::fs::write(path, &text).map_err(|err| SweepError::Io {
            path: path.to_owned(),
            err,
        })?;
    }
    Ok(Ran {
        jobs: jobs.len(),
        failed: outcomes.iter().filter(|o| o.is_err()).count(),
        wall_s,
        stats,
        csv: text,
    })
}

/// Connects to a `--remote` host: (endpoint, key prefix, how long to wait for it) → one
/// launcher per worker there.
pub type ConnectRemote<'a> =
    &'a mut dyn FnMut(&str, &str, Duration) -> Result<Vec<Box<dyn Launcher>>, SweepError>;

/// `robosim sweep …`: `exe` is the robosim binary the local workers run, `remote` connects to
/// the `--remote` hosts (after the parameters are checked); the summary goes to `out`, worker
/// events to stderr.
pub fn run(
    args: &SweepArgs,
    exe: &Path,
    remote: ConnectRemote<'_>,
    out: &mut dyn Write,
) -> Result<(), SweepError> {
    let def = study_named(&args.study)?;
    let workers = args.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    });
    if workers == 0 && args.remote.is_empty() {
        return Err(SweepError::NoWorkers);
    }
    let job_timeout = match args.job_timeout {
        None => None,
        Some(s) if s.is_finite() && s > 0.0 => Some(Duration::from_secs_f64(s)),
        Some(s) => {
            return Err(SweepError::Param {
                arg: format!("--job-timeout {s}"),
                why: "expected a positive number of seconds".into(),
            });
        }
    };
    if !(args.remote_wait.is_finite() && args.remote_wait > 0.0) {
        return Err(SweepError::Param {
            arg: format!("--remote-wait {}", args.remote_wait),
            why: "expected a positive number of seconds".into(),
        });
    }
    if args.attempts == 0 {
        return Err(SweepError::Param {
            arg: "--attempts 0".into(),
            why: "a job must be tried at least once".into(),
        });
    }
    let p = plan(def, &args.params)?;
    let opts = Options {
        max_attempts: args.attempts,
        job_timeout,
        host_wait: Duration::from_secs_f64(args.remote_wait),
    };
    let mut launchers = local_launchers(exe, workers.min(p.jobs.len().max(1)));
    for endpoint in &args.remote {
        let there = remote(
            endpoint,
            &args.remote_key,
            Duration::from_secs_f64(args.remote_wait),
        )?;
        eprintln!(
            "sweep: {endpoint}: a sweep host with {} worker{}",
            there.len(),
            if there.len() == 1 { "" } else { "s" }
        );
        launchers.extend(there);
    }
    let workers = launchers.len();
    let ran = sweep_on(&p, launchers, &opts, Some(&args.out), &mut |line| {
        eprintln!("{line}")
    })?;
    let shape = if p.axes.is_empty() {
        "the study's defaults".to_owned()
    } else {
        p.axes
            .iter()
            .map(|a| format!("{} {}", a.name, a.values.len()))
            .collect::<Vec<_>>()
            .join(" × ")
    };
    let w = |e: std::io::Error| SweepError::Io {
        path: "stdout".into(),
        err: e,
    };
    writeln!(
        out,
        "sweep {}: {} jobs ({shape}) on {} workers in {:.1} s: {} ran, {} failed; {} worker deaths, {} jobs redone",
        def.name,
        ran.jobs,
        workers,
        ran.wall_s,
        ran.jobs - ran.failed,
        ran.failed,
        ran.stats.deaths,
        ran.stats.redone
    )
    .map_err(w)?;
    writeln!(out, "wrote {}", args.out.display()).map_err(w)?;
    Ok(())
}

/// `robosim sweep-worker`: serves jobs from stdin until it ends.
pub fn worker() -> Result<(), SweepError> {
    super::worker::serve(std::io::stdin().lock(), std::io::stdout().lock()).map_err(|err| {
        SweepError::Io {
            path: "the worker's stdin/stdout".into(),
            err,
        }
    })
}
