//! `robosim sim`, driven through [`run`].

use robosim_hl_interface::cli::CommandError;
use robosim_hl_interface::cli::sim::{SimArgs, run};

#[test]
fn sim_command_builds_prints_and_runs() {
    let none = |_: &str| None;
    let args = SimArgs {
        robot: "puma560".into(),
        effects: Some(r#"{"kinematics": true, "dynamics": {"integrator": "rk4"}}"#.into()),
        q0: Some(vec![0.0, 0.4, -0.6, 0.0, 0.5, 0.0]),
        steps: 100,
    };
    run(&args, &none).expect("runs");
    let bad = SimArgs {
        robot: "nonesuch".into(),
        ..args.clone()
    };
    assert!(
        run(&bad, &none)
            .expect_err("unknown robot")
            .to_string()
            .contains("nonesuch")
    );
    let bad = SimArgs {
        effects: Some(r#"{"dynamics": {"integrator": "leapfrog"}}"#.into()),
        ..args.clone()
    };
    let err = run(&bad, &none).expect_err("bad integrator");
    assert!(matches!(err, CommandError::Effects(_)), "{err:?}");
    assert!(err.to_string().contains("dynamics.integrator"), "{err}");
    let bad = SimArgs {
        q0: Some(vec![0.0; 5]),
        ..args
    };
    let err = run(&bad, &none).expect_err("a start q of the wrong length");
    assert!(
        matches!(
            err,
            CommandError::Pipeline(robosim_simulator::BuildError::Robot { field: "q0", .. })
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("`q0`: q has 5 values"), "{err}");
}
