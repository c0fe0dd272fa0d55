//! `robosim bench bridge`: what carrying a space over Zenoh costs (issue 18 §1), at 10², 10³,
//! 10⁴ and 10⁵ bodies, on localhost TCP, in one run:
//!
//! * a one-body pose transaction written on the primary's machine (the baseline) and the same
//!   written on the replica (forwarded to the primary's keeper, journaled there, sent back and
//!   applied on the replica before the writer is answered);
//! * the replica's lag: the primary's writer answered → a reader on the replica has that
//!   version;
//! * a late joiner: a replica bridge started → its session's keeper accepts writers at the
//!   primary's version (snapshot, decode, reset of its data directory, first publication).
//!
//! Keepers run without the journal's fsync (a constant that would hide what depends on the
//! model). Bodies are solids without geometry, as in `bench scale`.

use crate::ipc::{Result, bin, keeper, stats};
use crate::scale::pose_tx;
use robosim_instance_space::{Client, Reader, ScratchKeeper};
use std::fmt::Write as _;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub const SIZES: [usize; 4] = [100, 1_000, 10_000, 100_000];

struct Row {
    n: usize,
    local: (f64, f64, f64),
    forwarded: (f64, f64, f64),
    lag: (f64, f64, f64),
    join_ms: f64,
}

/// A child process stopped with SIGTERM when dropped.
struct Stopped(Child);
impl Drop for Stopped {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.0.id().to_string()])
            .status();
        let _ = self.0.wait();
    }
}

/// Runs the bench and writes `bridge.md` and `bridge.csv` into `out`.
pub fn run(out: &Path, quick: bool) -> Result<()> {
    let reps = if quick { 200 } else { 2_000 };
    let pid = std::process::id();
    let mut rows = Vec::new();
    for n in SIZES {
        let primary = keeper(&format!("brp{pid}n{n}"), false)?;
        let mut pw = Client::connect(primary.session(), "bench-writer")?;
        let body = crate::scale::build(&mut pw, n)?;
        let port = std::net::TcpListener::bind("127.0.0.1:0")?
            .local_addr()?
            .port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let _bridge = Stopped(
            Command::new(bin()?)
                .args(["bridge", "--listen", &endpoint, "--session"])
                .arg(primary.session().name())
                .stdout(Stdio::null())
                .stderr(Stdio::inherit())
                .spawn()?,
        );
        let t = Instant::now();
        let replica = ScratchKeeper::start_as(
            &bin()?,
            &format!("brr{pid}n{n}"),
            &["bridge", "--connect", &endpoint],
            &[],
            Duration::from_secs(300),
        )?;
        let join_ms = t.elapsed().as_secs_f64() * 1e3;
        let mut rw = Client::connect(replica.session(), "bench-writer")?;
        let mut follower = Reader::attach(replica.session(), "bench-follower")?;
        let mut local = Vec::with_capacity(reps);
        let mut forwarded = Vec::with_capacity(reps);
        let mut lag = Vec::with_capacity(reps);
        for k in 0..reps + 50 {
            let warm = k < 50;
            // The baseline, and the replica's lag behind it.
            let t = Instant::now();
            let v = pw.transact(&pose_tx(body, k as f64 * 1e-3))?.version;
            let tl = t.elapsed();
            let t = Instant::now();
            loop {
                follower.wait_change(Duration::from_secs(5))?;
                if follower.snapshot().is_some_and(|s| s.version() >= v) {
                    break;
                }
                if t.elapsed() > Duration::from_secs(30) {
                    return Err(
                        format!("the replica did not reach version {v} at {n} bodies").into(),
                    );
                }
            }
            let tlag = t.elapsed();
            // Written on the replica.
            let t = Instant::now();
            let c = rw.transact(&pose_tx(body, -(k as f64) * 1e-3))?;
            let tf = t.elapsed();
            if follower.refresh().is_ok()
                && follower.snapshot().is_some_and(|s| s.version() < c.version)
            {
                return Err(
                    format!("the replica answered before it had version {}", c.version).into(),
                );
            }
            if !warm {
                local.push(tl.as_nanos() as f64 / 1e3);
                lag.push(tlag.as_nanos() as f64 / 1e3);
                forwarded.push(tf.as_nanos() as f64 / 1e3);
            }
        }
        rows.push(Row {
            n,
            local: stats(local),
            forwarded: stats(forwarded),
            lag: stats(lag),
            join_ms,
        });
        drop(replica);
    }
    write(out, quick, &rows)
}

fn write(out: &Path, quick: bool, rows: &[Row]) -> Result<()> {
    let mut md = String::from("# The space over Zenoh (`robosim bench bridge");
    md.push_str(if quick { " --quick`)\n\n" } else { "`)\n\n" });
    md.push_str(
        "One run on this machine, localhost TCP; the primary's keeper, its bridge, the replica \
         bridge (the replica's keeper) and this process on a shared 2-core machine. Keepers \
         without fsync. A one-body pose transaction on a model of N solids:\n\n\
         * **local**: written on the primary (the baseline);\n\
         * **forwarded**: written on the replica, committed by the primary's keeper and applied \
         on the replica before the writer is answered;\n\
         * **lag**: the primary's writer answered → a reader on the replica has the version;\n\
         * **join**: a replica bridge started → its keeper accepts writers at the primary's \
         version (snapshot over TCP, decode, data directory reset, first publication).\n\n\
         | bodies | local mean / p50 / p99 (µs) | forwarded mean / p50 / p99 (µs) | forwarded ÷ local (p50) | lag mean / p50 / p99 (µs) | join (ms) | join ×10² |\n\
         |---|---|---|---|---|---|---|\n",
    );
    let mut csv = String::from(
        "bodies,local_mean_us,local_p50_us,local_p99_us,forwarded_mean_us,forwarded_p50_us,forwarded_p99_us,lag_mean_us,lag_p50_us,lag_p99_us,join_ms\n",
    );
    let base = rows.first().map_or(1.0, |r| r.join_ms);
    for r in rows {
        let t = |v: (f64, f64, f64)| format!("{:.0} / {:.0} / {:.0}", v.0, v.1, v.2);
        writeln!(
            md,
            "| {} | {} | {} | {:.1} | {} | {:.0} | {:.1} |",
            r.n,
            t(r.local),
            t(r.forwarded),
            r.forwarded.1 / r.local.1.max(1e-9),
            t(r.lag),
            r.join_ms,
            r.join_ms / base
        )
        .ok();
        writeln!(
            csv,
            "{},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1},{:.1}",
            r.n,
            r.local.0,
            r.local.1,
            r.local.2,
            r.forwarded.0,
            r.forwarded.1,
            r.forwarded.2,
            r.lag.0,
            r.lag.1,
            r.lag.2,
            r.join_ms
        )
        .ok();
    }
    md.push_str("\nRegenerate: `cargo run --release -- bench bridge --out docs/bench`.\n");
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("bridge.md"), &md)?;
    std::fs::write(out.join("bridge.csv"), &csv)?;
    print!("{md}");
    Ok(())
}
