//! RNEA and ABA per call on the general joint model against the DH path, in one run (issue 14,
//! docs/dynamics.md "URDF robots"): the built-in PUMA 560 (DH rows), the same PUMA rewritten as
//! general joints in memory (`chain::to_general`), the same PUMA exported to URDF (`to_urdf`)
//! and imported back (`import_urdf_str`), the UR5 chain from testdata/urdf/ur5_robot.urdf (to
//! `tool0`) and the Panda tree (testdata/urdf/panda.urdf, 9 joints, `import_urdf_tree`).
//!
//! Method (as `robosim report dynamics`): batches of 1000 calls, every (robot, algorithm) pair
//! timed once per round and the rounds repeated, so machine noise hits all alike; the median
//! and the 10th percentile of the per-call times; ratios against the DH PUMA of the same run.
//!
//! `cargo run --release -p robosim-file-io --example bench_urdf_dynamics [-- ROUNDS]`

use robosim_dynamics::{Data, Model, aba, rnea};
use robosim_file_io::urdf_import::{import_urdf, import_urdf_str, import_urdf_tree};
use robosim_kinematics::{Robot, builtin_robot, chain::to_general};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let k = ((p / 100.0) * (v.len() - 1) as f64).round() as usize;
    v[k]
}

fn main() -> Result<(), String> {
    let rounds: usize = std::env::args()
        .nth(1)
        .map(|a| {
            a.parse()
                .map_err(|_| format!("{a:?}: not a number of rounds"))
        })
        .transpose()?
        .unwrap_or(201);
    let testdata = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf");
    let puma = builtin_robot("puma560").ok_or("no builtin puma560")?;
    let text = robosim_file_io::urdf::to_urdf(&puma)?;
    let puma_urdf = import_urdf_str(&text, Path::new("puma560.urdf"), Some("puma560_tool"))
        .map_err(|e| e.to_string())?
        .robot;
    let ur5 = import_urdf(&testdata.join("ur5_robot.urdf"), Some("tool0"))
        .map_err(|e| e.to_string())?
        .robot;
    let panda = import_urdf_tree(&testdata.join("panda.urdf"))
        .map_err(|e| e.to_string())?
        .robot;
    let robots: Vec<(&str, Robot)> = vec![
        ("PUMA 560, DH rows (builtin)", puma.clone()),
        ("PUMA 560, to_general (in memory)", to_general(&puma)),
        ("PUMA 560, to_urdf → import_urdf", puma_urdf),
        ("UR5 chain (URDF, 6 joints)", ur5),
        ("Panda tree (URDF, 9 joints)", panda),
    ];
    struct Case {
        model: Model,
        data: Data,
        q: Vec<f64>,
        qd: Vec<f64>,
        x: Vec<f64>,
        times: [Vec<f64>; 2],
    }
    let mut cases: Vec<Case> = robots
        .iter()
        .map(|(_, r)| {
            let model = Model::new(r).map_err(|e| e.to_string())?;
            let n = model.dof();
            Ok(Case {
                data: Data::new(&model),
                q: (0..n).map(|j| 0.3 + 0.1 * j as f64).collect(),
                qd: (0..n).map(|j| 0.5 - 0.2 * j as f64).collect(),
                x: (0..n).map(|j| 1.0 - 0.3 * j as f64).collect(),
                times: [Vec::new(), Vec::new()],
                model,
            })
        })
        .collect::<Result<_, String>>()?;
    let per = 1000;
    for _ in 0..rounds {
        for c in &mut cases {
            let start = Instant::now();
            for _ in 0..per {
                black_box(
                    rnea(&c.model, &mut c.data, black_box(&c.q), &c.qd, &c.x)
                        .map(|t| t[0])
                        .ok(),
                );
            }
            c.times[0].push(start.elapsed().as_secs_f64() / per as f64);
            let start = Instant::now();
            for _ in 0..per {
                black_box(
                    aba(&c.model, &mut c.data, black_box(&c.q), &c.qd, &c.x)
                        .map(|t| t[0])
                        .ok(),
                );
            }
            c.times[1].push(start.elapsed().as_secs_f64() / per as f64);
        }
    }
    let stats: Vec<[(f64, f64); 2]> = cases
        .iter_mut()
        .map(|c| {
            let mut f = |k: usize| {
                (
                    percentile(&mut c.times[k], 50.0) * 1e9,
                    percentile(&mut c.times[k], 10.0) * 1e9,
                )
            };
            [f(0), f(1)]
        })
        .collect();
    println!(
        "{rounds} rounds × {per} calls per (robot, algorithm), interleaved; median (10th percentile) ns per call; ratio = median / DH PUMA's median"
    );
    println!("| robot | DOF | RNEA ns | ABA ns | RNEA ratio | ABA ratio |");
    println!("|---|---|---|---|---|---|");
    for ((name, r), s) in robots.iter().zip(&stats) {
        println!(
            "| {name} | {} | {:.0} ({:.0}) | {:.0} ({:.0}) | {:.2} | {:.2} |",
            r.dof(),
            s[0].0,
            s[0].1,
            s[1].0,
            s[1].1,
            s[0].0 / stats[0][0].0,
            s[1].0 / stats[0][1].0
        );
    }
    Ok(())
}
