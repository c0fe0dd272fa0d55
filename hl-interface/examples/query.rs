//! `robosim query` without the rest of the binary (no `--session`): serves JSON-lines requests
//! from standard input (or `--input FILE`) to standard output:
//! `cargo run -p robosim-hl-interface --example query < hl-interface/examples/requests.jsonl`.
//! (docs/query.md's examples come from the real binary: the `make_query_doc` example.)
//!
//! Its two options are read by hand: clap is the binary's alone (src/cli/).

use robosim_hl_interface::cli::{QueryArgs, run};

/// `[--input FILE] [--stats]`, or a message naming the argument it cannot use.
fn args() -> Result<QueryArgs, String> {
    let mut args = QueryArgs {
        input: None,
        stats: false,
    };
    let mut it = std::env::args_os().skip(1);
    while let Some(a) = it.next() {
        match a.to_str() {
            Some("--stats") => args.stats = true,
            Some("--input") => {
                let file = it.next().ok_or("--input needs a FILE")?;
                args.input = Some(file.into());
            }
            _ => {
                return Err(format!(
                    "unexpected argument {a:?}; usage: query [--input FILE] [--stats]"
                ));
            }
        }
    }
    Ok(args)
}

fn main() -> std::process::ExitCode {
    // the command's error with its causes, one line each
    match args().and_then(|a| run(&a).map_err(|e| robosim_instance_space::error_chain(&e))) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            std::process::ExitCode::FAILURE
        }
    }
}
