//! `robosim query` without the rest of the binary (no `--session`): serves JSON-lines requests
//! from standard input (or `--input FILE`) to standard output:
//! `cargo run -p robosim-hl-interface --example query < hl-interface/examples/requests.jsonl`.
//! (docs/query.md's examples come from the real binary: the `make_query_doc` example.)

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
