//! robosim's side of the exact-distance rows of `tools/peers/run.py` (issue 37 items 3, 7): the
//! 40 separated pairs per class of `testdata/collision/tolerance_pairs.csv` through
//! `exact::collide` (distance and witness points, as the `collide` op asks), at the tolerance
//! named, timed as coal's side is timed (`tools/peers/collision_tolerance_coal.py`): the median
//! over passes of one pass over the class's pairs — a pass (~40 µs) is shorter than a scheduler
//! slice, so the median is the unloaded speed on a shared machine, as it is for coal's passes.
//!
//! `cargo run --release -p robosim-collision --example peer_distance -- [--passes 60]
//! CLASS:TOLERANCE ...` (TOLERANCE `certified` or metres, e.g. `cylinder-cone:1e-6`); prints one
//! JSON object per case: `{"class", "tolerance", "ns_per_pair", "passes"}`.

#[path = "../benches/common/pairs.rs"]
mod pairs;

use robosim_collision::exact::{self, ExactOptions, Tolerance};
use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;

fn tolerance(text: &str) -> Result<Tolerance, String> {
    if text == "certified" {
        return Ok(Tolerance::Certified);
    }
    let t: f64 = text
        .parse()
        .map_err(|e| format!("tolerance {text:?}: {e}"))?;
    Tolerance::gjk(t).map_err(|_| format!("tolerance {text}: not a length > 0"))
}

fn run() -> Result<(), String> {
    let mut passes = 60usize;
    let mut cases = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--passes" {
            let n = args.next().ok_or("--passes needs a number")?;
            passes = n.parse().map_err(|e| format!("--passes {n}: {e}"))?;
        } else {
            let (class, tol) = a
                .split_once(':')
                .ok_or(format!("{a:?}: expected CLASS:TOLERANCE"))?;
            cases.push((class.to_owned(), tol.to_owned(), tolerance(tol)?));
        }
    }
    let all = pairs::load()?;
    for (class, label, tolerance) in cases {
        let mine: Vec<&pairs::Pair> = all.iter().filter(|p| p.class == class).collect();
        if mine.is_empty() {
            return Err(format!("no pairs of class {class:?}"));
        }
        let opts = ExactOptions {
            tolerance,
            ..ExactOptions::default()
        };
        let mut per: Vec<f64> = (0..passes.max(1) + 3)
            .map(|_| {
                let t0 = Instant::now();
                for p in &mine {
                    black_box(exact::collide(&p.a, &p.pa, &p.b, &p.pb, opts));
                }
                t0.elapsed().as_nanos() as f64 / mine.len() as f64
            })
            .skip(3) // warm-up passes
            .collect();
        per.sort_by(f64::total_cmp);
        let median = per[per.len() / 2];
        println!(
            "{{\"class\": \"{class}\", \"tolerance\": \"{label}\", \"ns_per_pair\": {median:.1}, \"passes\": {}}}",
            per.len()
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("peer_distance: {e}");
            ExitCode::FAILURE
        }
    }
}
