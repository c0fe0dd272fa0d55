//! Writes the Library Space benchmark report: `cargo run -p robosim-report --example
//! report_library -- OUT_DIR [--quick]` (the lead wires the same function as
//! `robosim report library`).
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = std::path::PathBuf::from(args.get(1).map_or("docs/reports", String::as_str));
    let quick = args.iter().any(|a| a == "--quick");
    match robosim_report::library::report_library(&out, quick) {
        Ok(files) => files.iter().for_each(|f| println!("{}", f.display())),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
