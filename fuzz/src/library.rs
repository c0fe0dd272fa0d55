//! Target `library`: the Library Space language (`library-space/src/{lexer,parser,eval}`):
//! a file is lexed, parsed, checked (every declaration evaluated at its defaults), listed, its
//! parameters read and every declaration evaluated with a polygon budget; then the same bytes
//! as a parameter expression (`lib eval --param`, the protocol's `lib_evaluate` params).
//!
//! Whatever the bytes: a library or a located error, never a panic, a stack overflow or
//! unbounded time. Includes other than the embedded standard library (`"std"`, `"std/…"`) are
//! not followed: reading files is not what this target tests (see the library's own tests of
//! `include` limits), and a fuzzer must not read `/dev/stdin`.

use robosim_library::{EvalOptions, Library, Params};
use std::sync::OnceLock;

/// The polygon budget of one evaluation here (the library's default is 5,000,000).
const MAX_POLYGONS: usize = 100_000;

/// A small library whose declarations take the fuzzed bytes as a parameter expression.
const PARAM_HOST: &str =
    "solid slab(x = 1 m, c = rgb(1, 0, 0)) { part box(x, 1 m, 1 m) colour c }\n";

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if includes_outside_std(text) {
        return;
    }
    let opts = EvalOptions {
        facets: None,
        max_polygons: Some(MAX_POLYGONS),
    };
    match Library::from_source("fuzz.rsl", text) {
        Ok(lib) => {
            for d in lib.declarations() {
                let _ = lib.params(&d.name);
                let _ = lib.evaluate_with(&d.name, &Params::new(), &opts);
            }
        }
        Err(e) => {
            assert!(
                e.position().starts_with("fuzz.rsl:") || e.position().starts_with("std/"),
                "error not located in the input: {e}"
            );
            let _ = e.to_string();
        }
    }
    static HOST: OnceLock<Option<Library>> = OnceLock::new();
    if let Some(host) = HOST.get_or_init(|| Library::from_source("host.rsl", PARAM_HOST).ok()) {
        let _ = host.evaluate_with("slab", &Params::new().expr("x", text), &opts);
        let _ = host.evaluate_with("slab", &Params::new().expr("c", text), &opts);
    }
}

/// Whether `text` may include a file from disk: any `include` not directly followed by a
/// string starting `"std` (those resolve in the embedded standard library, or name a relative
/// file `std…` that does not exist in the fuzzer's directory).
fn includes_outside_std(text: &str) -> bool {
    text.match_indices("include").any(|(i, w)| {
        let rest = text[i + w.len()..].trim_start_matches(|c: char| c.is_ascii_whitespace());
        !rest.starts_with("\"std")
    })
}
