//! `collide` requests per second through the whole query-protocol path (`handle_line`: parse
//! the line, build or look up the shapes, answer, frame), issue 37 item 4:
//!
//! * `repeated shapes` — one cylinder and one cone, new poses every request (a planner's
//!   stream): the shapes come from the op cache after the first request;
//! * `new shapes` — the cone's radius differs by 1e-12 m in every request, so every request
//!   builds both solids (faceted and exact forms) and inserts them into the cache, evicting the
//!   oldest: what every request cost before the cache, plus the cache's own work;
//! * `repeated shapes, tolerance 1e-6 m` — as the first, with `"tolerance": 1e-6` (coal's
//!   default GJK tolerance) instead of the certified distance.
//!
//! Interleaved rounds; prints the median and spread of each. With `--write FILE`, also writes
//! the repeated-shape request lines (one per line) for tools/peers/collide_rate_coal.py, which
//! runs the same lines through a Python + coal loop.
//!
//! `--only certified|new|loose` times one of the three (for a profile: `perf record` of one
//! stream).
//!
//! `cargo run --release -p robosim-hl-interface --example collide_rate -- [--n 20000] [--rounds 7] [--write FILE] [--only NAME]`

use std::time::Instant;

fn pose(x: f64, y: f64, z: f64, a: f64) -> String {
    let (s, c) = a.sin_cos();
    format!(
        "[[{c}, {ms}, 0, {x}], [{s}, {c}, 0, {y}], [0, 0, 1, {z}], [0, 0, 0, 1]]",
        ms = -s
    )
}

fn lines(n: usize, new_shapes: bool, tolerance: &str) -> Vec<String> {
    // A small LCG: the same poses in every run.
    let mut state: u64 = 37;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|i| {
            let cone_r = if new_shapes {
                0.15 + i as f64 * 1e-12
            } else {
                0.15
            };
            let pb = pose(
                0.2 + 0.5 * next(),
                0.3 * next() - 0.15,
                0.3 * next() - 0.15,
                6.0 * next(),
            );
            format!(
                r#"{{"id": {i}, "op": "collide", "a": {{"shape": "cylinder", "radius": 0.2, "height": 0.5}}, "pose_a": {pa}, "b": {{"shape": "cone", "radius": {cone_r}, "height": 0.4}}, "pose_b": {pb}{tolerance}}}"#,
                pa = pose(0.0, 0.0, 0.0, 0.0)
            )
        })
        .collect()
}

fn per_request_us(ls: &[String]) -> f64 {
    let t = Instant::now();
    for l in ls {
        std::hint::black_box(robosim_hl_interface::handle_line(l));
    }
    t.elapsed().as_secs_f64() / ls.len() as f64 * 1e6
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let n: usize = arg("--n").and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let rounds: usize = arg("--rounds").and_then(|s| s.parse().ok()).unwrap_or(7);
    let same = lines(n, false, "");
    let fresh = lines(n, true, "");
    // coal's default GJK tolerance, for the loop in tools/peers/collide_rate_coal.py
    let loose = lines(n, false, r#", "tolerance": 1e-6"#);
    if let Some(path) = arg("--write") {
        if let Err(e) = std::fs::write(&path, same.join("\n") + "\n") {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
    }
    // The answers must not depend on the cache: the same line answered twice is the same.
    let first = robosim_hl_interface::handle_line(&same[1]);
    let _ = per_request_us(&same[..100]);
    assert_eq!(first, robosim_hl_interface::handle_line(&same[1]));
    let only = arg("--only");
    let runs = |name: &str| only.as_deref().is_none_or(|o| o == name);
    let (mut hit, mut miss, mut hit_loose) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        if runs("certified") {
            hit.push(per_request_us(&same));
        }
        if runs("new") {
            miss.push(per_request_us(&fresh));
        }
        if runs("loose") {
            hit_loose.push(per_request_us(&loose));
        }
    }
    let show = |name: &str, x: &[f64]| {
        if x.is_empty() {
            return f64::NAN;
        }
        let m = median(x.to_vec());
        let (lo, hi) = x
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
        println!(
            "{name}: {m:.2} us per request ({:.0} requests/s), spread {lo:.2}..{hi:.2} us over {rounds} rounds of {n}",
            1e6 / m
        );
        m
    };
    let h = show("repeated shapes (cached)", &hit);
    let f = show("new shapes (built every request)", &miss);
    show("repeated shapes, tolerance 1e-6 m", &hit_loose);
    println!("ratio repeated/new: {:.3}", h / f);
}
