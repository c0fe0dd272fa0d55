use rand::{Rng, SeedableRng};
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::{builtin_robot, fk};
fn main() {
    let robot = builtin_robot("puma560").unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let mut times = vec![];
    for _ in 0..300 {
        let q: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * rng.random::<f64>())
            .collect();
        let t = fk::forward(&robot, &q);
        let o = IkOptions {
            all: true,
            ..IkOptions::default()
        };
        let s = std::time::Instant::now();
        let r = ik::solve(&robot, &t, Method::Hybrid, &o).unwrap();
        times.push((
            s.elapsed().as_secs_f64() * 1e6,
            r.solutions.iter().map(|s| s.iterations).max().unwrap(),
        ));
    }
    times.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    println!(
        "median {:?} p90 {:?} max {:?}",
        times[150], times[270], times[299]
    );
}
