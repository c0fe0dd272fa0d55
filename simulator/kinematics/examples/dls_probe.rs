use rand::{Rng, SeedableRng};
use robosim_kinematics::ik::{IkOptions, IkSolver, dls::Dls};
use robosim_kinematics::pose::Tolerances;
use robosim_kinematics::{builtin_robot, fk};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let name = a[1].clone();
    let dls = Dls {
        mu0: a[2].parse().unwrap(),
        mu_down: a[3].parse().unwrap(),
        mu_up: a[4].parse().unwrap(),
        max_stalls: a[5].parse().unwrap(),
        max_step: a[7].parse().unwrap(),
    };
    let iters: usize = a[6].parse().unwrap();
    let robot = builtin_robot(&name).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let n = 500;
    let mut its = vec![];
    let mut fails = 0;
    let t0 = std::time::Instant::now();
    for k in 0..n {
        let q: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * rng.random::<f64>())
            .collect();
        let t = fk::forward(&robot, &q);
        let o = IkOptions {
            tolerances: Tolerances::uniform(1e-6, 1e-6),
            seed: k as u64,
            max_iterations: iters,
            ..IkOptions::default()
        };
        match dls.solve(&robot, &t, &o) {
            Ok(r) => its.push(r.solutions[0].iterations),
            Err(_) => fails += 1,
        }
    }
    its.sort();
    println!(
        "{name} {:?} it{iters}: mean {:.1} us, fails {fails}, iters median {} p90 {} max {}",
        &a[2..8],
        t0.elapsed().as_secs_f64() / n as f64 * 1e6,
        its[its.len() / 2],
        its[its.len() * 9 / 10],
        its[its.len() - 1]
    );
}
