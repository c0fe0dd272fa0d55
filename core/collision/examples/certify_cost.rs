//! What certification costs: ns per pair for parry's own answers (the exact mode before issue
//! #20 item 8: `intersection_test`, then `closest_points` when apart) against the certified exact
//! mode (`exact::intersects`, `exact::collide`), on the same random near-contact pairs, in one
//! run. `cargo run --release -p robosim-collision --example certify_cost`
//!
//! Timings only; nothing is asserted (a shared machine).

use nalgebra::{Isometry3, Vector3};
use parry3d_f64::query;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_collision::{ExactOptions, Solid, exact};
use std::hint::black_box;
use std::time::Instant;

fn solid(kind: &str, rng: &mut ChaCha8Rng) -> Solid {
    let mut s = || rng.random_range(0.2..1.2);
    match kind {
        "box" => Solid::cuboid(Vector3::new(s(), s(), s())),
        "sphere" => Solid::sphere(s() / 2.0, None),
        "cylinder" => Solid::cylinder(s() / 2.0, s(), None),
        _ => Solid::cone(s() / 2.0, s(), None),
    }
    .expect("solid")
}

/// Best of `reps` runs of `f` over every pair, ns per pair.
fn ns_per_pair(reps: usize, n: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_nanos() as f64 / n as f64
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    println!(
        "| pair | parry boolean | certified boolean | parry distance (bool + closest points) | certified collide (distance/depth) |"
    );
    println!("|---|---|---|---|---|");
    for (ka, kb) in [
        ("box", "box"),
        ("cylinder", "box"),
        ("cone", "box"),
        ("cylinder", "cone"),
        ("sphere", "cylinder"),
    ] {
        let pairs: Vec<_> = (0..500)
            .map(|_| {
                let (a, b) = (solid(ka, &mut rng), solid(kb, &mut rng));
                let pa = Isometry3::new(
                    Vector3::zeros(),
                    Vector3::new(rng.random(), rng.random(), rng.random()),
                );
                let dir = Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize();
                let pb = Isometry3::new(
                    dir * rng.random_range(0.3..1.3),
                    Vector3::new(rng.random(), rng.random(), rng.random()),
                );
                (a, pa, b, pb)
            })
            .collect();
        let n = pairs.len();
        let parry_bool = ns_per_pair(9, n, || {
            for (a, pa, b, pb) in &pairs {
                let (ga, gb) = (pa * a.exact_offset, pb * b.exact_offset);
                black_box(
                    query::intersection_test(&ga, a.exact.as_ref(), &gb, b.exact.as_ref()).ok(),
                );
            }
        });
        let ours_bool = ns_per_pair(9, n, || {
            for (a, pa, b, pb) in &pairs {
                black_box(exact::intersects(a, pa, b, pb).ok());
            }
        });
        let parry_dist = ns_per_pair(9, n, || {
            for (a, pa, b, pb) in &pairs {
                let (ga, gb) = (pa * a.exact_offset, pb * b.exact_offset);
                let (sa, sb) = (a.exact.as_ref(), b.exact.as_ref());
                if query::intersection_test(&ga, sa, &gb, sb).unwrap_or(true) {
                    black_box(query::contact(&ga, sa, &gb, sb, 0.0).ok());
                } else {
                    black_box(query::closest_points(&ga, sa, &gb, sb, f64::MAX).ok());
                }
            }
        });
        let ours_dist = ns_per_pair(9, n, || {
            for (a, pa, b, pb) in &pairs {
                black_box(exact::collide(a, pa, b, pb, ExactOptions::default()));
            }
        });
        println!(
            "| {ka}–{kb} | {parry_bool:.0} | {ours_bool:.0} | {parry_dist:.0} | {ours_dist:.0} |"
        );
    }
}
