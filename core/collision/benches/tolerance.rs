//! The exact distance of separated convex pairs at a chosen tolerance (issue 37 item 3): the
//! 40 pairs per class of `testdata/collision/tolerance_pairs.csv` and of the convex meshes'
//! `tolerance_hull_pairs.csv` (coal's side:
//! `tools/peers/collision_tolerance_coal.py`; side by side in `tools/peers/run.py`), timed per
//! class and tolerance — certified (bracket ≤ 1e-11 m) and GJK 1e-6 / 1e-9 m — through
//! `exact::collide` with distance and witness points, as the `collide` op asks.
//!
//! `cargo bench -p robosim-collision --bench tolerance`

#[path = "common/pairs.rs"]
mod pairs;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use robosim_collision::exact::{self, ExactOptions, Tolerance};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let all = pairs::load().expect("tolerance_pairs.csv");
    let mut g = c.benchmark_group("tolerance");
    for class in [
        "cylinder-cone",
        "cylinder-box",
        "cone-box",
        "box-box",
        "hull-hull",
    ] {
        let mine: Vec<&pairs::Pair> = all.iter().filter(|p| p.class == class).collect();
        g.throughput(Throughput::Elements(mine.len() as u64));
        for (label, tolerance) in [
            ("certified", Tolerance::Certified),
            ("1e-6", Tolerance::Gjk(1e-6)),
            ("1e-9", Tolerance::Gjk(1e-9)),
        ] {
            let opts = ExactOptions {
                tolerance,
                ..ExactOptions::default()
            };
            g.bench_function(format!("{class}/{label}"), |b| {
                b.iter(|| {
                    for p in &mine {
                        black_box(exact::collide(&p.a, &p.pa, &p.b, &p.pb, opts));
                    }
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
