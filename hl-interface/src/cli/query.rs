//! `robosim query`: the JSON-lines transport on the command line.
//!
//! Reads requests from `--input FILE` (default: standard input; `-` also means standard input)
//! and writes one answer line per request line to standard output, flushed after each, so a
//! planner can drive it interactively through pipes. Entry points: [`QueryArgs`], [`run`].

use crate::{ServeStats, serve};
use std::io::{self, BufReader};
use std::path::PathBuf;

/// Arguments of `robosim query`.
#[derive(Debug, Clone)]
pub struct QueryArgs {
    /// Read requests from this file instead of standard input ("-" is standard input).
    pub input: Option<PathBuf>,
    /// At the end, print the counts (lines, ok, errors) to standard error.
    pub stats: bool,
}

/// Serves requests until the input ends. A client closing standard output (broken pipe) ends
/// the session normally. Errors: the input file cannot be opened, or an I/O error on either
/// stream; bad requests are answered on the stream, never returned here.
pub fn run(args: &QueryArgs) -> Result<(), super::CommandError> {
    let stdout = io::stdout();
    let result = match args.input.as_deref() {
        Some(path) if path.as_os_str() != "-" => {
            let file = std::fs::File::open(path).map_err(|source| super::CommandError::Open {
                path: path.to_path_buf(),
                source,
            })?;
            serve(BufReader::new(file), stdout.lock())
        }
        _ => serve(io::stdin().lock(), stdout.lock()),
    };
    let stats = match result {
        Ok(stats) => stats,
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => return Ok(()),
        Err(e) => return Err(super::CommandError::Io(e)),
    };
    if args.stats {
        let ServeStats { lines, ok, errors } = stats;
        eprintln!("query: {lines} lines, {ok} ok, {errors} errors");
    }
    Ok(())
}
