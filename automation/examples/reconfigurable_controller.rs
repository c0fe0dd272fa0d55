//! The reconfigurable controller of the seed's pictures 6–7: a one-link arm under a P
//! controller; the Checker rewires the running dataflow graph to PID when the tracking error is
//! unacceptable. Run: `cargo run -p robosim-automation --example reconfigurable_controller`.
use robosim_automation::reconfig::{ReconfigOptions, run_reconfig_demo};

fn main() {
    let fixed = run_reconfig_demo(&ReconfigOptions {
        allow_switch: false,
        ..Default::default()
    });
    let adaptive = run_reconfig_demo(&ReconfigOptions::default());
    match (fixed, adaptive) {
        (Ok(p), Ok(r)) => {
            println!(
                "P controller all along:   RMS error over the last 0.5 s = {:.4} rad",
                p.rms_error_after
            );
            match r.switched_at {
                Some(t) => println!(
                    "Checker switched P -> PID at t = {t:.3} s (RMS error then {:.4} rad)",
                    r.rms_error_before
                ),
                None => println!("Checker never switched"),
            }
            println!(
                "reconfigured controller:  RMS error over the last 0.5 s = {:.4} rad",
                r.rms_error_after
            );
            println!(
                "{} integration steps, {} actor firings traced",
                r.steps, r.firings
            );
            println!("\nGraph after the run (DOT):\n{}", r.dot_after);
        }
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
