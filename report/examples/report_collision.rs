//! Writes the collision report until the lead wires `robosim report collision`:
//! `cargo run --release -p robosim-report --example report_collision -- docs/reports [--quick]`
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "docs/reports".into());
    let quick = args.iter().any(|a| a == "--quick");
    match robosim_report::collision::report_collision(std::path::Path::new(&dir), quick) {
        Ok(paths) => {
            for p in paths {
                println!("{}", p.display());
            }
        }
        Err(e) => {
            eprintln!("report collision: {e}");
            std::process::exit(1);
        }
    }
}
