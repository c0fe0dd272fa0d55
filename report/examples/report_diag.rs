//! Regenerates the diagnosis reports: `cargo run --release -p robosim-report --example
//! report_diag -- OUT_DIR [--quick]` (the lead wires the same function as `robosim report diag`).
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "docs/reports".into());
    let quick = args.iter().any(|a| a == "--quick");
    match robosim_report::automation::report_diag(std::path::Path::new(&dir), quick) {
        Ok(files) => files.iter().for_each(|f| println!("{}", f.display())),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
