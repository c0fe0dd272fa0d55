//! Regenerates the published dynamics report until `robosim report dynamics` is wired:
//! `cargo run --release -p robosim-report --example report_dynamics -- docs/reports [--quick]`
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map_or("docs/reports", String::as_str);
    let quick = args.iter().any(|a| a == "--quick");
    match robosim_report::dynamics::report_dynamics(std::path::Path::new(dir), quick) {
        Ok(paths) => paths.iter().for_each(|p| println!("{}", p.display())),
        Err(e) => {
            eprintln!("report dynamics: {e}");
            std::process::exit(1);
        }
    }
}
