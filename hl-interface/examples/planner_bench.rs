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
//! Prints one JSON object per row: `{"row", "p50_us", "p99_us", "n"}`.

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
