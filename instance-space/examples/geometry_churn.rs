//! A driver for profiling what a one-body geometry change costs in a model of `n` boxes:
//! a keeper in a thread of this process (no journal sync), a model of `n` boxes built once,
//! then `reps` `SetGeometry` transactions on the middle box and `reps` boxes created, each
//! followed by a reader in this process. Prints the means and medians (µs) of the keeper's
//! transaction and of the reader following it (the median is what to compare on a loaded
//! machine: a keeper thread descheduled for milliseconds moves the mean, not the median). `robosim bench scale` measures the same against keeper
//! processes; this exists so that `perf record` sees only the part that matters.
//!
//! `cargo run --release -p robosim-instance-space --example geometry_churn -- 100000 2000`

use robosim_instance_space::{
    Client, GeometryInput, KeeperOptions, Kind, Reader, ThreadKeeper, Transaction,
};
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn cube(s: f64) -> Result<GeometryInput> {
    let p = robosim_geometry::shapes::cuboid(s, s, s).map_err(|e| e.to_string())?;
    Ok(GeometryInput::from_polyhedron(&p))
}

/// Commits `tx`, then follows with `reader` until it has the commit's version: (tx µs, follow
/// µs) and what was created.
fn commit(client: &mut Client, reader: &mut Reader, tx: &Transaction) -> Result<(f64, f64, u64)> {
    let t = Instant::now();
    let c = client.transact(tx)?;
    let tx_us = t.elapsed().as_secs_f64() * 1e6;
    let t = Instant::now();
    while reader.snapshot().is_none_or(|s| s.version() < c.version) {
        reader.wait_change(Duration::from_secs(5))?;
    }
    Ok((
        tx_us,
        t.elapsed().as_secs_f64() * 1e6,
        c.created.first().copied().unwrap_or(0),
    ))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(Ok(100_000), |a| a.parse())?;
    let reps: usize = args.get(2).map_or(Ok(1_000), |a| a.parse())?;
    // "geometry", "create" or both (anything else).
    let only = args.get(3).map_or("", String::as_str);
    let opts = KeeperOptions {
        durable: false,
        ..KeeperOptions::default()
    };
    let kp = ThreadKeeper::start(
        &format!("gc{}", std::process::id()),
        opts,
        Duration::from_secs(60),
    )?;
    let mut client = Client::connect(kp.session(), "churn-writer")?;
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "churn", None);
    let scene = client.transact(&tx)?.created[0];
    let boxed = cube(0.1)?;
    let mut middle = 0;
    let mut k = 0;
    let t = Instant::now();
    while k < n {
        let mut tx = Transaction::new();
        let end = (k + 1_000).min(n);
        for j in k..end {
            let b = tx.create(Kind::Solid, &format!("body{j}"), Some(scene.into()));
            tx.set_geometry(b, Some(boxed.clone()));
        }
        let c = client.transact(&tx)?;
        if (k..end).contains(&(n / 2)) {
            middle = c.created[n / 2 - k];
        }
        k = end;
    }
    eprintln!("built {n} boxes in {:.1} s", t.elapsed().as_secs_f64());
    let mut reader = Reader::attach(kp.session(), "churn-reader")?;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let p50 = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(0.0)
    };
    let (mut tx_us, mut follow_us) = (Vec::new(), Vec::new());
    for k in 0..if only == "create" { 0 } else { reps + 20 } {
        let mut tx = Transaction::new();
        tx.set_geometry(middle, Some(cube(0.1 + (k % 7 + 1) as f64 * 0.01)?));
        let (a, b, _) = commit(&mut client, &mut reader, &tx)?;
        if k >= 20 {
            tx_us.push(a);
            follow_us.push(b);
        }
    }
    println!(
        "{n} boxes: geometry tx {:.1} µs, follow {:.1} µs (p50 {:.1} µs, {:.1} µs)",
        mean(&tx_us),
        mean(&follow_us),
        p50(&tx_us),
        p50(&follow_us)
    );
    let (mut tx_us, mut follow_us) = (Vec::new(), Vec::new());
    for k in 0..if only == "geometry" { 0 } else { reps + 20 } {
        let mut tx = Transaction::new();
        let b = tx.create(Kind::Solid, &format!("added{k}"), Some(scene.into()));
        tx.set_geometry(b, Some(cube(0.05)?));
        let (a, b, created) = commit(&mut client, &mut reader, &tx)?;
        if reader
            .snapshot()
            .and_then(|s| s.index_of(created))
            .is_none()
        {
            return Err("the reader lacks the created box".into());
        }
        if k >= 20 {
            tx_us.push(a);
            follow_us.push(b);
        }
    }
    println!(
        "{n} boxes: create tx {:.1} µs, follow {:.1} µs (p50 {:.1} µs, {:.1} µs)",
        mean(&tx_us),
        mean(&follow_us),
        p50(&tx_us),
        p50(&follow_us)
    );
    Ok(())
}
