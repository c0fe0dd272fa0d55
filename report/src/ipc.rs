//! `robosim bench ipc` (dispatched by the binary, which passes itself as the keeper and reader
//! processes to start): the Instance Space's costs, measured in one run on this machine and
//! written to `docs/bench/ipc.md` (and a CSV beside it). Every figure is reported with the
//! baseline it should be compared with, measured in the same run; the machine is shared, so
//! absolute numbers drift between runs while the ratios are what the claims rest on.
//!
//! (a) reader access to the current snapshot, 1,000- vs 1,000,000-vertex models with the same
//!     number of objects; (b) a one-body pose transaction in both; (c) change-notification
//!     latency keeper → blocked reader (another process), p50/p99 over 10,000 changes; (d)
//!     journaled transactions per second with group commit, and the cost of one fsync here.

use crate::percentile;
use robosim_instance_space::{
    Client, GeometryInput, IDENTITY, Kind, Reader, ScratchKeeper, Session, Transaction,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Anything that stopped the bench, as text for the command line.
pub type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

macro_rules! bail {
    ($($t:tt)*) => { return Err(format!($($t)*).into()) };
}

/// A UV sphere of quads (planar isosceles trapezoids) and two triangle fans: a closed convex
/// solid with about `n` vertices.
pub fn sphere_geometry(n: usize, radius: f64) -> GeometryInput {
    let rings = ((n as f64 / 2.0).sqrt().floor() as usize).max(3);
    let segs = (n.saturating_sub(2) / rings).max(3);
    let mut vertices = vec![[0.0, 0.0, -radius]];
    for r in 1..=rings {
        let phi = std::f64::consts::PI * r as f64 / (rings + 1) as f64;
        for s in 0..segs {
            let th = std::f64::consts::TAU * s as f64 / segs as f64;
            vertices.push([
                radius * phi.sin() * th.cos(),
                radius * phi.sin() * th.sin(),
                -radius * phi.cos(),
            ]);
        }
    }
    vertices.push([0.0, 0.0, radius]);
    let top = (vertices.len() - 1) as u32;
    let at = |r: usize, s: usize| (1 + (r - 1) * segs + s % segs) as u32;
    let mut polygons = Vec::new();
    for s in 0..segs {
        polygons.push(vec![0, at(1, s + 1), at(1, s)]);
        polygons.push(vec![top, at(rings, s), at(rings, s + 1)]);
    }
    for r in 1..rings {
        for s in 0..segs {
            polygons.push(vec![at(r, s), at(r, s + 1), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    GeometryInput { vertices, polygons }
}

/// A keeper process of this binary on a fresh session `name` (journal synced when `durable`).
pub(crate) fn keeper(name: &str, durable: bool) -> Result<ScratchKeeper> {
    let args: &[&str] = if durable { &[] } else { &["--no-sync"] };
    Ok(ScratchKeeper::start(
        &bin()?,
        name,
        args,
        Duration::from_secs(60),
    )?)
}

/// Builds a scene of `objects` solids with `verts_each` vertices each; returns the id of one.
fn build(client: &mut Client, objects: usize, verts_each: usize) -> Result<u64> {
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "bench", None);
    let scene = client.transact(&tx)?.created[0];
    let mut first = 0;
    for k in 0..objects {
        let mut tx = Transaction::new();
        let s = tx.create(Kind::Solid, &format!("body{k}"), Some(scene.into()));
        tx.set_geometry(s, Some(sphere_geometry(verts_each, 0.1)));
        let c = client.transact(&tx)?;
        if k == 0 {
            first = c.created[0];
        }
    }
    Ok(first)
}

/// Mean, p50 and p99.
pub(crate) fn stats(mut v: Vec<f64>) -> (f64, f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, percentile(&mut v, 50.0), percentile(&mut v, 99.0))
}

/// Runs the bench and writes `ipc.md` and `ipc.csv` into `out`.
pub fn run(out: &Path, quick: bool) -> Result<()> {
    let reps = if quick { 2_000 } else { 100_000 };
    let tx_reps = if quick { 500 } else { 5_000 };
    let lat_count = if quick { 1_000 } else { 10_000 };
    let pid = std::process::id();
    let mut doc = Doc {
        md: String::new(),
        csv: String::from("measure,model,value,unit\n"),
    };
    write_header(&mut doc, quick);
    access_and_pose_tx(&mut doc, pid, reps, tx_reps)?;
    notify_latency(&mut doc, pid, lat_count)?;
    journaled_throughput(&mut doc, pid, quick)?;
    write_doc(out, &doc)
}

/// The bench's two outputs, filled section by section: the Markdown page and the CSV of its
/// figures.
struct Doc {
    md: String,
    csv: String,
}

/// The page's title and the note on how to read it.
fn write_header(doc: &mut Doc, quick: bool) {
    let Doc { md, .. } = doc;
    writeln!(
        md,
        "# Instance Space benchmark (`robosim bench ipc{}`)\n",
        if quick { " --quick" } else { "" }
    )
    .ok();
    writeln!(md, "Measured on this machine (2 cores, shared), one run; compare figures within this table, not across runs.\n").ok();
}

/// (a) snapshot access and (b) a one-body pose transaction, without and with fsync, in a
/// 1,000- and a 1,000,000-vertex model of the same 10 objects.
fn access_and_pose_tx(doc: &mut Doc, pid: u32, reps: usize, tx_reps: usize) -> Result<()> {
    let Doc { md, csv } = doc;
    // (a) and (b): two models with the same 10 objects, 1,000 and 1,000,000 vertices in all.
    writeln!(
        md,
        "## (a) snapshot access and (b) one-body pose transaction\n"
    )
    .ok();
    writeln!(md, "Both models have 10 solid bodies plus the scene; only the vertex count differs. (a) is `reader.snapshot()` plus a read of every object's geometry header (the whole model is reachable; nothing is copied). (b) is one `SetPose` transaction, end to end through the keeper process (client → keeper → apply → publish → ack), without and with the journal's fsync.\n").ok();
    writeln!(md, "| model | vertices | (a) snapshot access mean / p99 (ns) | (b) pose tx, no fsync, mean / p99 (µs) | (b) pose tx with fsync, mean / p99 (µs) |\n|---|---|---|---|---|").ok();
    let mut a_means = Vec::new();
    let mut b_means = Vec::new();
    for (label, verts_each) in [("1k", 100usize), ("1M", 100_000usize)] {
        let mut row = Vec::new();
        for durable in [false, true] {
            let kp = keeper(&format!("bench{pid}{label}{}", durable as u8), durable)?;
            let mut client = Client::connect(kp.session(), "bench-writer")?;
            let body = build(&mut client, 10, verts_each)?;
            let reader = Reader::attach(kp.session(), "bench-reader")?;
            let total_verts = reader.snapshot().map_or(0, |s| s.vertex_count());
            if !durable {
                let samples = snapshot_access_ns(&reader, reps);
                let (mean, _, p99) = stats(samples);
                a_means.push(mean);
                row.push(format!("{mean:.0} / {p99:.0}"));
                csv.push_str(&format!("snapshot_access_mean,{label},{mean:.1},ns\n"));
                row.insert(0, total_verts.to_string());
            }
            let samples = pose_tx_us(&mut client, body, tx_reps)?;
            let (mean, _, p99) = stats(samples);
            if !durable {
                b_means.push(mean);
            }
            row.push(format!("{mean:.1} / {p99:.1}"));
            csv.push_str(&format!(
                "pose_tx_mean_{},{label},{mean:.2},us\n",
                if durable { "fsync" } else { "nosync" }
            ));
        }
        writeln!(md, "| {label} | {} |", row.join(" | ")).ok();
    }
    if a_means.len() == 2 && b_means.len() == 2 {
        writeln!(md, "\nRatios 1M / 1k (goal: 1 within noise): snapshot access {:.2}, pose transaction {:.2}.\n", a_means[1] / a_means[0], b_means[1] / b_means[0]).ok();
    }
    Ok(())
}

/// (a)'s samples: `reps` snapshot accesses, each reading every object's geometry header (ns).
fn snapshot_access_ns(reader: &Reader, reps: usize) -> Vec<f64> {
    let mut samples = Vec::with_capacity(reps);
    let mut sink = 0usize;
    for _ in 0..reps {
        let t = Instant::now();
        let s = reader.snapshot();
        if let Some(s) = s {
            sink += (0..s.len())
                .filter_map(|i| s.geometry(i))
                .map(|g| g.header.generation as usize)
                .sum::<usize>();
        }
        samples.push(t.elapsed().as_nanos() as f64);
    }
    std::hint::black_box(sink);
    samples
}

/// (b)'s samples: 200 warm-up transactions, then `tx_reps` one-body pose transactions, each
/// timed end to end (µs).
fn pose_tx_us(client: &mut Client, body: u64, tx_reps: usize) -> Result<Vec<f64>> {
    // Warm-up: first-touch of shared-memory pages and caches is not what (b) measures.
    for k in 0..200 {
        let mut tx = Transaction::new();
        let mut pose = IDENTITY;
        pose[11] = k as f64 * 1e-3;
        tx.set_pose(body, pose);
        client.transact(&tx)?;
    }
    let mut samples = Vec::with_capacity(tx_reps);
    for k in 0..tx_reps {
        let mut pose = IDENTITY;
        pose[3] = k as f64 * 1e-3;
        let mut tx = Transaction::new();
        tx.set_pose(body, pose);
        let t = Instant::now();
        client.transact(&tx)?;
        samples.push(t.elapsed().as_nanos() as f64 / 1e3);
    }
    Ok(samples)
}

/// (c) change-notification latency keeper → blocked reader in another process.
fn notify_latency(doc: &mut Doc, pid: u32, lat_count: usize) -> Result<()> {
    let Doc { md, csv } = doc;
    // (c) notification latency keeper → blocked reader in another process.
    writeln!(md, "## (c) change-notification latency\n").ok();
    {
        let kp = keeper(&format!("bench{pid}lat"), false)?;
        let mut client = Client::connect(kp.session(), "bench-writer")?;
        let body = build(&mut client, 1, 8)?;
        let lat_path = std::env::temp_dir().join(format!("robosim-lat-{pid}.txt"));
        let mut reader = Command::new(bin()?)
            .args([
                "bench",
                "ipc-reader",
                "--session",
                kp.session().name(),
                "--count",
                &lat_count.to_string(),
                "--out",
            ])
            .arg(&lat_path)
            .stdout(Stdio::piped())
            .spawn()?;
        // Wait for the reader to say it is attached and blocked.
        let mut line = String::new();
        use std::io::BufRead;
        if let Some(o) = reader.stdout.as_mut() {
            std::io::BufReader::new(o).read_line(&mut line)?;
        }
        for k in 0..lat_count {
            let mut tx = Transaction::new();
            let mut pose = IDENTITY;
            pose[3] = k as f64;
            tx.set_pose(body, pose);
            client.transact(&tx)?;
            // Give the reader time to block again, so every sample is a wake-up from sleep.
            std::thread::sleep(Duration::from_micros(300));
        }
        let status = reader.wait()?;
        if !status.success() {
            bail!("latency reader failed: {status}");
        }
        let text = std::fs::read_to_string(&lat_path)?;
        let _ = std::fs::remove_file(&lat_path);
        let v: Vec<f64> = text.lines().filter_map(|l| l.parse::<f64>().ok()).collect();
        let n = v.len();
        let (mean, p50, p99) = stats(v);
        writeln!(md, "Keeper publishes a change record (stamped with CLOCK_MONOTONIC) and notifies; a reader process blocked in `wait_event` wakes and stamps again. {n} changes: **p50 {p50:.1} µs, p99 {p99:.1} µs**, mean {mean:.1} µs (goal p50 ≤ 15 µs; iceoryx2's event wake-up alone was measured at ≈ 12 µs on this machine).\n").ok();
        csv.push_str(&format!(
            "notify_latency_p50,,{p50:.2},us\nnotify_latency_p99,,{p99:.2},us\n"
        ));
    }
    Ok(())
}

/// (d) journaled transactions per second with group commit, and the cost of one fsync.
fn journaled_throughput(doc: &mut Doc, pid: u32, quick: bool) -> Result<()> {
    let Doc { md, csv } = doc;
    // (d) journaled throughput with group commit, and one fsync.
    writeln!(md, "## (d) journaled transactions per second\n").ok();
    {
        let kp = keeper(&format!("bench{pid}tps"), true)?;
        let mut client = Client::connect(kp.session(), "bench-writer")?;
        let body = build(&mut client, 1, 8)?;
        let n = if quick { 5_000 } else { 50_000 };
        let window = Client::MAX_IN_FLIGHT;
        let mut in_flight = std::collections::VecDeque::new();
        let t = Instant::now();
        for k in 0..n {
            if in_flight.len() >= window {
                let p = in_flight.pop_front().ok_or("queue")?;
                client.wait(p)??;
            }
            let mut tx = Transaction::new();
            let mut pose = IDENTITY;
            pose[7] = k as f64 * 1e-6;
            tx.set_pose(body, pose);
            in_flight.push_back(client.submit(&tx)?);
        }
        while let Some(p) = in_flight.pop_front() {
            client.wait(p)??;
        }
        let secs = t.elapsed().as_secs_f64();
        let tps = n as f64 / secs;
        // One fsync here: append 100 bytes and fdatasync, 200 times, in the session's data dir.
        let f_path = kp.session().data_dir().join("fsync-probe");
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&f_path)?;
        let mut fs = Vec::new();
        for _ in 0..200 {
            use std::io::Write;
            f.write_all(&[7u8; 100])?;
            let t = Instant::now();
            f.sync_data()?;
            fs.push(t.elapsed().as_nanos() as f64 / 1e3);
        }
        let _ = std::fs::remove_file(&f_path);
        let (fmean, fp50, fp99) = stats(fs);
        writeln!(md, "{n} one-body pose transactions, pipelined {window} deep from one client, each journaled and acknowledged only after the group's fdatasync: **{tps:.0} transactions/s** (goal ≥ 20,000/s). One fdatasync of a 100-byte append here: mean {fmean:.0} µs, p50 {fp50:.0} µs, p99 {fp99:.0} µs — so without group commit the ceiling would be about {:.0}/s.\n", 1e6 / fmean.max(1e-9)).ok();
        csv.push_str(&format!(
            "journaled_tps,,{tps:.0},1/s\nfsync_mean,,{fmean:.1},us\n"
        ));
    }
    Ok(())
}

/// Writes `ipc.md` and `ipc.csv` into `out` and prints the page.
fn write_doc(out: &Path, doc: &Doc) -> Result<()> {
    let Doc { md, csv } = doc;
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("ipc.md"), md)?;
    std::fs::write(out.join("ipc.csv"), csv)?;
    print!("{md}");
    println!("written: {}", out.join("ipc.md").display());
    Ok(())
}

/// The latency reader: attach, then for each change block in `wait_event` and record
/// (wake-up time − publish time).
/// The reader process of the latency measurement (`robosim bench ipc-reader`).
pub fn latency_reader(session: &str, count: usize, out: &Path) -> Result<()> {
    let s = Session::open(Some(session))?;
    let mut reader = Reader::attach(&s, "latency-reader")?;
    println!("ready");
    use std::io::Write;
    std::io::stdout().flush()?;
    let mut lat = Vec::with_capacity(count);
    let mut last = std::time::Instant::now();
    while lat.len() < count {
        // `None` is a timeout or a wake-up without an event (a signal interrupted the wait):
        // only ten seconds without a change end the measurement.
        let Some(woke) = reader.wait_event(Duration::from_secs(1))? else {
            if last.elapsed() > Duration::from_secs(10) {
                bail!(
                    "no change within {:.1} s after {} samples",
                    last.elapsed().as_secs_f64(),
                    lat.len()
                )
            }
            continue;
        };
        last = std::time::Instant::now();
        for ch in reader.wait_change(Duration::ZERO)? {
            lat.push(woke.saturating_sub(ch.published_ns) as f64 / 1e3);
        }
    }
    let text: String = lat.iter().map(|v| format!("{v:.3}\n")).collect();
    std::fs::write(out, text)?;
    Ok(())
}

/// The listener process of the bare iceoryx2 baseline (`robosim bench ipc-reader --bare TAG`):
/// blocks for `count` events of bare event `tag` in `session`
/// ([`robosim_instance_space::bare_event`]) and writes the wake-up times (CLOCK_MONOTONIC ns),
/// one a line, to `out`.
pub fn bare_listener(session: &str, tag: &str, count: usize, out: &Path) -> Result<()> {
    let s = Session::open(Some(session))?;
    let woke = robosim_instance_space::bare_event::listen(
        &s,
        tag,
        count,
        Duration::from_secs(10),
        || {
            use std::io::Write;
            println!("ready");
            let _ = std::io::stdout().flush();
        },
    )?;
    let text: String = woke.iter().map(|t| format!("{t}\n")).collect();
    std::fs::write(out, text)?;
    Ok(())
}

/// The `robosim` binary that runs the keeper and reader processes: this process's own.
pub(crate) fn bin() -> std::io::Result<PathBuf> {
    std::env::current_exe()
}
