//! `robosim query` without the rest of the binary: serves JSON-lines requests from standard
//! input (or `--input FILE`) to standard output. Used to produce docs/query.md's examples:
//! `cargo run -p robosim-hl-interface --example query < requests.jsonl`.

use clap::Parser;
use robosim_hl_interface::cli::{QueryArgs, run};

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    args: QueryArgs,
}

fn main() -> std::process::ExitCode {
    match run(&Cli::parse().args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            std::process::ExitCode::FAILURE
        }
    }
}
