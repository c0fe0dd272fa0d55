use rand::{Rng, SeedableRng};
use robosim_kinematics::ik::{IkOptions, IkSolver, dls::Dls};
use robosim_kinematics::pose::Tolerances;
use robosim_kinematics::{builtin_robot, fk};
fn main() {
    let robot = builtin_robot("panda").unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let _: Vec<f64> = (0..10000 * 6).map(|_| rng.random::<f64>()).collect(); // skip puma poses
    let dls = Dls::default();
    let (mut f50, mut f500, mut f50_nolim) = (0, 0, 0);
    for k in 0..3000 {
        let q: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * rng.random::<f64>())
            .collect();
        let t = fk::forward(&robot, &q);
        let o = IkOptions {
            tolerances: Tolerances::uniform(1e-6, 1e-6),
            seed: k as u64,
            ..IkOptions::default()
        };
        if dls.solve(&robot, &t, &o).is_err() {
            f50 += 1;
            let near: Vec<String> = robot
                .joints
                .iter()
                .zip(&q)
                .map(|(j, x)| format!("{:.2}", ((x - j.qlim[0]).min(j.qlim[1] - x))))
                .collect();
            let o2 = IkOptions {
                restarts: 500,
                ..o.clone()
            };
            let ok500 = dls.solve(&robot, &t, &o2).is_ok();
            if !ok500 {
                f500 += 1;
            }
            let o3 = IkOptions {
                respect_limits: false,
                ..o.clone()
            };
            let oknl = dls.solve(&robot, &t, &o3).is_ok();
            if !oknl {
                f50_nolim += 1;
            }
            println!("fail k={k} margin-to-limits {near:?} ok500={ok500} ok_nolimits={oknl}");
        }
    }
    println!("fails50 {f50} fails500 {f500} fails_nolim {f50_nolim} of 3000");
}
