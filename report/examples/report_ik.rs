//! Writes the IK report: `cargo run --release -p robosim-report --example report_ik -- OUT_DIR [--quick]`
//! (the same as `robosim report ik` once the binary wires it).

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "docs/reports".into());
    match robosim_report::ik::report_ik(std::path::Path::new(&out), quick) {
        Ok(paths) => {
            for p in paths {
                println!("{}", p.display());
            }
        }
        Err(e) => {
            eprintln!("report ik: {e}");
            std::process::exit(1);
        }
    }
}
