//! The certified depth of overlapping convex pairs (issue 37 item 4: what was left per `collide`
//! request): `exact::collide` with the default options (certified, depth and witness points) on
//! pairs in contact — a cylinder (r 0.2, h 0.5) at the origin against a cone (r 0.15, h 0.4),
//! a box (0.3 × 0.2 × 0.25) or a cylinder, the second placed by the seeded poses of the
//! `collide_rate` example of robosim-hl-interface (same generator), the pairs not in contact
//! dropped. Clear pairs are timed as well (their path is not changed by the depth work).
//!
//! `cargo bench -p robosim-collision --bench contact_depth`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use robosim_collision::Solid;
use robosim_collision::exact::{self, ExactOptions};
use std::hint::black_box;

/// The poses of `collide_rate` (hl-interface/examples/collide_rate.rs): a small LCG.
fn poses(n: usize) -> Vec<Isometry3<f64>> {
    let mut state: u64 = 37;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let (x, y, z) = (0.2 + 0.5 * next(), 0.3 * next() - 0.15, 0.3 * next() - 0.15);
            let a = 6.0 * next();
            Isometry3::from_parts(
                Translation3::new(x, y, z),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a),
            )
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let a = Solid::cylinder(0.2, 0.5, None).expect("cylinder");
    let others = [
        ("cylinder-cone", Solid::cone(0.15, 0.4, None).expect("cone")),
        (
            "cylinder-box",
            Solid::cuboid(Vector3::new(0.3, 0.2, 0.25)).expect("box"),
        ),
        (
            "cylinder-cylinder",
            Solid::cylinder(0.15, 0.4, None).expect("cylinder"),
        ),
    ];
    let pa = Isometry3::identity();
    let all = poses(400);
    let mut g = c.benchmark_group("contact_depth");
    for (class, b) in &others {
        for (label, contact) in [("contact", true), ("clear", false)] {
            let mine: Vec<Isometry3<f64>> = all
                .iter()
                .filter(|pb| exact::intersects(&a, &pa, b, pb) == Ok(contact))
                .copied()
                .collect();
            g.throughput(Throughput::Elements(mine.len() as u64));
            g.bench_function(format!("{class}/{label}"), |bch| {
                bch.iter(|| {
                    for pb in &mine {
                        black_box(exact::collide(&a, &pa, b, pb, ExactOptions::default()));
                    }
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
