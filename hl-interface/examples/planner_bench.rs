//! Latency of the Rust planner client (`robosim_hl_interface::planner::Planner`), the rows that
//! python/examples/bench.py puts beside the Python ones (docs/bench/python.md):
//!
//! ```sh norun
//! cargo run --release -p robosim-hl-interface --example planner_bench -- --session lab --n 2000
//! ```
//!
//! * `set_joints` → acknowledged: one transaction of the positioner's joints and link poses;
//! * commit published → `wait_change` returned: a writer process (this example with
//!   `--writer K`) commits K times, 2 ms apart; the waiter takes CLOCK_MONOTONIC when
//!   `wait_change` returns (the snapshot refreshed, the names looked up) against the keeper's
//!   publish stamp, counting only wake-ups that saw exactly one commit.
//!
//! * with `--churn K`, instead: a client leaving the session, K times — a process attaches a
//!   planner, commits once and exits; then the time of this planner's next `set_joints`
//!   (the keeper notices the departure on its next receive) and the keeper's CPU time per
//!   attach + departure (from /proc, 10 ms ticks, summed over the K cycles), and the child's
//!   attach time;
//! * with `--ack-only`, only the first row.
//!
//! Prints one JSON object per row: `{"row", "p50_us", "p99_us", "n"}` (churn rows add
//! `max_us`, and the CPU row `mean_us`).

use robosim_hl_interface::planner::Planner;
use std::time::{Duration, Instant};

const ROBOT: &str = "positioner";

fn pct(mut xs: Vec<f64>, p: f64) -> f64 {
    xs.sort_by(f64::total_cmp);
    if xs.is_empty() {
        return f64::NAN;
    }
    let k = ((xs.len() - 1) as f64 * p / 100.0).round() as usize;
    xs[k]
}

fn row(name: &str, ns: Vec<f64>) {
    let n = ns.len();
    println!(
        "{}",
        serde_json::json!({"row": name, "p50_us": pct(ns.clone(), 50.0) / 1e3,
                           "p99_us": pct(ns, 99.0) / 1e3, "n": n})
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let session = arg("--session").unwrap_or_else(|| "lab".into());
    let n: usize = arg("--n").map_or(Ok(2000), |s| s.parse())?;
    let mut p = Planner::attach(&session)?;
    let q0 = p.joints(ROBOT)?;
    let q_at = |k: usize| {
        let mut q = q0.clone();
        q[5] += 1e-4 * (k % 2) as f64;
        q
    };
    if args.iter().any(|a| a == "--attach-once") {
        let t = Instant::now();
        let mut c = Planner::attach(&session)?;
        let attach = t.elapsed().as_nanos();
        let q = c.joints(ROBOT)?;
        c.set_joints(ROBOT, &q)?;
        println!("{attach}");
        return Ok(());
    }
    if let Some(k) = arg("--churn") {
        return churn(&mut p, &session, k.parse()?, &q_at);
    }
    if let Some(k) = arg("--writer") {
        for i in 0..k.parse::<usize>()? {
            p.set_joints(ROBOT, &q_at(i))?;
            std::thread::sleep(Duration::from_millis(2));
        }
        return Ok(());
    }
    let mut ack = Vec::with_capacity(n);
    for k in 0..n {
        let q = q_at(k);
        let t = Instant::now();
        p.set_joints(ROBOT, &q)?;
        ack.push(t.elapsed().as_nanos() as f64);
    }
    row("Rust planner `set_joints` → acknowledged", ack);
    if args.iter().any(|a| a == "--ack-only") {
        return Ok(());
    }
    let exe = std::env::current_exe()?;
    let mut writer = std::process::Command::new(exe)
        .args(["--session", &session, "--writer", &(n / 4).to_string()])
        .spawn()?;
    while p.wait_change(Duration::ZERO)?.is_some() {}
    let mut wake = Vec::new();
    loop {
        let c = p.wait_change(Duration::from_secs(1))?;
        let now = robosim_instance_space::monotonic_ns();
        if let Some(c) = c
            && c.changes.len() == 1
        {
            wake.push(now.saturating_sub(c.changes[0].published_ns) as f64);
        }
        if writer.try_wait()?.is_some() {
            break;
        }
    }
    row(
        "commit published → Rust planner `wait_change` returned",
        wake,
    );
    Ok(())
}

/// The keeper's CPU time (user + system) in clock ticks.
fn keeper_ticks(pid: u32) -> Result<u64, Box<dyn std::error::Error>> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))?;
    // Fields after the command name (which may hold spaces) start at ") ".
    let rest = stat.rsplit_once(") ").map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let field = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    // utime and stime are fields 14 and 15 of stat, 12 and 13 after the name.
    Ok(field(11) + field(12))
}

fn churn(
    p: &mut Planner,
    session: &str,
    k: usize,
    q_at: &dyn Fn(usize) -> Vec<f64>,
) -> Result<(), Box<dyn std::error::Error>> {
    let keeper = robosim_instance_space::Session::open(Some(session))?
        .processes()
        .into_iter()
        .find(|p| p.role == "space")
        .ok_or("no keeper in the session")?
        .pid;
    let hz = 100.0; // USER_HZ on Linux
    let exe = std::env::current_exe()?;
    let (mut next, mut attach) = (Vec::new(), Vec::new());
    let cpu0 = keeper_ticks(keeper)?;
    for i in 0..k {
        let out = std::process::Command::new(&exe)
            .args(["--session", session, "--attach-once"])
            .output()?;
        if !out.status.success() {
            return Err(format!(
                "attach-once child failed: {}",
                String::from_utf8_lossy(&out.stderr)
            )
            .into());
        }
        if let Ok(ns) = String::from_utf8_lossy(&out.stdout).trim().parse::<f64>() {
            attach.push(ns);
        }
        let t = Instant::now();
        p.set_joints(ROBOT, &q_at(i))?;
        next.push(t.elapsed().as_nanos() as f64);
    }
    let cpu = (keeper_ticks(keeper)? - cpu0) as f64 / hz;
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max) / 1e3;
    for (name, v) in [
        ("first `set_joints` after a client left", next),
        ("a client's `Planner::attach`", attach),
    ] {
        println!(
            "{}",
            serde_json::json!({"row": name, "p50_us": pct(v.clone(), 50.0) / 1e3,
                               "p99_us": pct(v.clone(), 99.0) / 1e3, "max_us": max(&v), "n": v.len()})
        );
    }
    println!(
        "{}",
        serde_json::json!({"row": "keeper CPU per client attach + departure",
                           "mean_us": cpu * 1e6 / k as f64, "n": k})
    );
    Ok(())
}
