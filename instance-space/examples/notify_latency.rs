//! A driver for profiling change notification beside iceoryx2's own event (issue 37 item 5):
//! a keeper in a thread of this process (no journal sync, the session's spin window from
//! `ROBOSIM_SPIN_US` as a session keeper takes it), a writer in this process, and in every round
//! a reader process (this program again) blocked in `Reader::wait_event` while the writer commits
//! `batch` one-body pose transactions 300 µs apart, then a bare-event listener process while a
//! bare iceoryx2 notifier here notifies `batch` times 300 µs apart — what `robosim bench scale`
//! measures, in one small release binary that `valgrind --tool=callgrind` and `perf` can run.
//! Prints each round's p50s (µs) and the pooled p50s with their ratio.
//!
//! `cargo run --release -p robosim-instance-space --example notify_latency -- 5 200`

use robosim_instance_space::bare_event::{self, BareNotifier};
use robosim_instance_space::{
    Client, IDENTITY, KeeperOptions, Kind, Reader, Session, ThreadKeeper, Transaction,
    spin_from_env,
};
use std::io::{BufRead, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// CLOCK_MONOTONIC (ns), the clock of the keeper's publish stamp.
fn monotonic_ns() -> u64 {
    robosim_instance_space::monotonic_ns()
}

fn p50(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn pose_tx(body: u64, x: f64) -> Transaction {
    let mut tx = Transaction::new();
    let mut pose = IDENTITY;
    pose[3] = x;
    tx.set_pose(body, pose);
    tx
}

/// The reader process: attach, say "ready", then `count` changes; prints one latency (µs) a
/// line (wake-up stamp − the keeper's publish stamp), as `robosim bench ipc-reader` does.
fn reader(root: &str, name: &str, count: usize) -> Result<()> {
    let s = Session::open_in(Path::new(root), Some(name))?;
    let mut reader = Reader::attach(&s, "latency-reader")?;
    let attached = reader.snapshot().map_or(0, |s| s.version());
    println!("ready");
    std::io::stdout().flush()?;
    let mut lat = Vec::with_capacity(count);
    while lat.len() < count {
        let Some(woke) = reader.wait_event(Duration::from_secs(10))? else {
            continue;
        };
        let changes = reader.wait_change(Duration::ZERO)?;
        // The snapshot at the change's version is assembled: the reader sees it now.
        let seen = monotonic_ns();
        if reader.snapshot().map(|s| s.version()) < changes.last().map(|c| c.version) {
            return Err(format!(
                "the reader's snapshot is at {:?}, the last change at {:?}",
                reader.snapshot().map(|s| s.version()),
                changes.last().map(|c| c.version)
            )
            .into());
        }
        // Changes from before the attach (the change service's history) are not timed.
        for ch in changes.into_iter().filter(|c| c.version > attached) {
            lat.push((
                woke.saturating_sub(ch.published_ns) as f64 / 1e3,
                seen.saturating_sub(ch.published_ns) as f64 / 1e3,
            ));
        }
    }
    for (w, s) in lat {
        println!("{w:.3} {s:.3}");
    }
    Ok(())
}

/// The bare listener process: prints one wake-up stamp (ns) a line.
fn bare(root: &str, name: &str, tag: &str, count: usize) -> Result<()> {
    let s = Session::open_in(Path::new(root), Some(name))?;
    let woke = bare_event::listen(&s, tag, count, Duration::from_secs(10), || {
        println!("ready");
        let _ = std::io::stdout().flush();
    })?;
    for t in woke {
        println!("{t}");
    }
    Ok(())
}

/// Starts this program as `args`, waits for its "ready" line; returns the child.
fn spawn_ready(args: &[&str]) -> Result<std::process::Child> {
    let mut child = Command::new(std::env::current_exe()?)
        .args(args)
        .stdout(Stdio::piped())
        .spawn()?;
    let mut line = String::new();
    if let Some(o) = child.stdout.as_mut() {
        std::io::BufReader::new(o).read_line(&mut line)?;
    }
    if line.trim() != "ready" {
        let _ = child.kill();
        let _ = child.wait();
        return Err(format!("{args:?} did not get ready").into());
    }
    Ok(child)
}

fn lines(child: std::process::Child) -> Result<Vec<String>> {
    let out = child.wait_with_output()?;
    if !out.status.success() {
        return Err(format!("a child failed: {}", out.status).into());
    }
    Ok(String::from_utf8(out.stdout)?
        .lines()
        .map(str::to_owned)
        .collect())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("reader") => return reader(&args[2], &args[3], args[4].parse()?),
        Some("bare") => return bare(&args[2], &args[3], &args[4], args[5].parse()?),
        _ => {}
    }
    let rounds: usize = args.get(1).map_or(Ok(5), |a| a.parse())?;
    let batch: usize = args.get(2).map_or(Ok(200), |a| a.parse())?;
    let opts = KeeperOptions {
        durable: false,
        spin: spin_from_env()?,
        ..KeeperOptions::default()
    };
    let name = format!("nl{}", std::process::id());
    let kp = ThreadKeeper::start(&name, opts, Duration::from_secs(60))?;
    let session = kp.session();
    let root = session
        .dir()
        .parent()
        .ok_or("the session has no parent directory")?
        .to_str()
        .ok_or("a non-UTF-8 home")?
        .to_owned();
    let mut client = Client::connect(session, "nl-writer")?;
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "nl", None);
    let scene = client.transact(&tx)?.created[0];
    let mut tx = Transaction::new();
    tx.create(Kind::Solid, "body", Some(scene.into()));
    let body = client.transact(&tx)?.created[0];
    // A follower in this process, as in `bench scale` (notified too, not following).
    let follower = Reader::attach(session, "nl-follower")?;
    let mut k = 0usize;
    let (mut all_notify, mut all_seen, mut all_event) = (Vec::new(), Vec::new(), Vec::new());
    // Per change: wake-up → the reader sees the version (drain and assemble), µs.
    let mut all_follow = Vec::new();
    for round in 0..rounds {
        let child = spawn_ready(&["reader", &root, &name, &batch.to_string()])?;
        for _ in 0..batch {
            k += 1;
            client.transact(&pose_tx(body, k as f64 * 1e-3))?;
            std::thread::sleep(Duration::from_micros(300));
        }
        let pairs: Vec<(f64, f64)> = lines(child)?
            .iter()
            .filter_map(|l| {
                let (w, s) = l.split_once(' ')?;
                Some((w.parse().ok()?, s.parse().ok()?))
            })
            .collect();
        let notify: Vec<f64> = pairs.iter().map(|p| p.0).collect();
        let seen: Vec<f64> = pairs.iter().map(|p| p.1).collect();
        all_follow.extend(pairs.iter().map(|p| p.1 - p.0));
        let tag = format!("{}-{round}", std::process::id());
        let mut notifier = BareNotifier::create(session, &tag)?;
        let child = spawn_ready(&["bare", &root, &name, &tag, &batch.to_string()])?;
        let mut sent = Vec::with_capacity(batch);
        for _ in 0..batch {
            sent.push(notifier.notify()?);
            std::thread::sleep(Duration::from_micros(300));
        }
        let event: Vec<f64> = lines(child)?
            .iter()
            .filter_map(|l| l.parse::<u64>().ok())
            .zip(&sent)
            .map(|(w, s)| w.saturating_sub(*s) as f64 / 1e3)
            .collect();
        println!(
            "round {round}: notify p50 {:.1} µs (sees the version {:.1} µs), bare event p50 {:.1} µs",
            p50(notify.clone()),
            p50(seen.clone()),
            p50(event.clone())
        );
        all_seen.extend(seen);
        all_notify.extend(notify);
        all_event.extend(event);
    }
    let (n, s, e, f) = (
        p50(all_notify),
        p50(all_seen),
        p50(all_event),
        p50(all_follow),
    );
    println!(
        "pooled: notify p50 {n:.1} µs (sees the version {s:.1} µs; wake → sees {f:.2} µs), bare event p50 {e:.1} µs, notify / event {:.2}",
        n / e
    );
    drop(follower);
    Ok(())
}
