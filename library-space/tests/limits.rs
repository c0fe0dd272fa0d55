//! Issue #20 ("Hard cases"), items 1 and 2: input that used to abort the process or read
//! without end. Each test is named after the defect it guards against.
//!
//! * A flat chain of `+` terms built a left-deep tree, and the evaluator, every walk and the
//!   tree's `Drop` recursed once per operand: 10,000 terms overflowed the stack (the nesting
//!   limit counts parentheses, not operands). Chains are now flat `Vec`s; the tests run on a
//!   256 KiB thread to prove that nothing recurses per operand.
//! * `include "/dev/zero"` read 10 GB in 8 s. Every source file is now a regular file of at
//!   most `MAX_SOURCE_BYTES`.

use robosim_library::{
    EVAL_STEP_BUDGET, Error, ErrorKind, Evaluated, Library, MAX_SOURCE_BYTES, Params,
};
use std::time::Instant;

/// `let x = 1 + 1 + … + 1` with `n` terms of `op`.
fn chain(n: usize, op: &str) -> String {
    let mut s = String::with_capacity(n * (op.len() + 1) + 8);
    s.push_str("let x = 1");
    for _ in 1..n {
        s.push_str(op);
        s.push('1');
    }
    s.push('\n');
    s
}

fn constant(lib: &Library, name: &str) -> f64 {
    match lib.evaluate(name, &Params::new()) {
        Ok(Evaluated::Constant { value, .. }) => value,
        other => panic!("`{name}` is not a constant: {other:?}"),
    }
}

/// Runs `f` on a thread with a 256 KiB stack: far too small for one frame per operand of a
/// 10,000-term chain, enough for the parser's and evaluator's bounded nesting.
fn on_small_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(f)
        .expect("spawn")
        .join()
        .expect("the small-stack thread panicked");
}

fn ten_thousand_terms_load_and_evaluate() {
    for (op, want) in [("+", 10_000.0), ("-", -9_998.0), ("*", 1.0), ("/", 1.0)] {
        let lib = Library::from_source("flat.rsl", &chain(10_000, op))
            .unwrap_or_else(|e| panic!("10,000 `{op}` terms: {}", e.message));
        assert_eq!(constant(&lib, "x"), want, "op {op}");
        // the library (and its tree) is dropped here: Drop must not recurse per operand either
    }
    // mixed precedence, units, and a chain inside a call inside a chain
    let mut src = String::from("let y = sqrt(0 m");
    for _ in 0..5_000 {
        src.push_str(" + 2 mm * 0.5");
    }
    src.push_str(" - 1 mm) + 0 m\n");
    let e = Library::from_source("flat.rsl", &src).expect_err("sqrt of a length");
    assert!(
        e.message.contains("square root of a length"),
        "{}",
        e.message
    );
    let src = src.replace("sqrt(", "abs(");
    let lib = Library::from_source("flat.rsl", &src)
        .unwrap_or_else(|e| panic!("5,000 mixed terms: {}", e.message));
    assert!((constant(&lib, "y") - 4.999).abs() < 1e-9);
}

#[test]
fn issue_20_flat_chain_of_10000_terms_does_not_overflow_the_stack() {
    ten_thousand_terms_load_and_evaluate();
}

#[test]
fn issue_20_flat_chain_of_10000_terms_on_a_256k_stack() {
    on_small_stack(ten_thousand_terms_load_and_evaluate);
}

fn million_terms_are_refused_with_a_location() {
    for op in ["+", "*"] {
        let e = Library::from_source("flat.rsl", &chain(1_000_000, op)).expect_err("too large");
        assert_eq!(e.kind, ErrorKind::Syntax);
        assert!(
            e.message
                .starts_with("expression too large: more than 100000 "),
            "{}",
            e.message
        );
        // the operator after the 100,000th, on line 1: "let x = 1" + 100,000 × "+1" + 1
        assert_eq!(e.position(), format!("flat.rsl:1:{}", 9 + 2 * 100_000 + 1));
    }
}

#[test]
fn issue_20_flat_chain_of_a_million_terms_is_refused_not_a_crash() {
    million_terms_are_refused_with_a_location();
    on_small_stack(million_terms_are_refused_with_a_location);
}

#[test]
fn issue_20_long_chains_as_parameter_expressions() {
    on_small_stack(|| {
        let lib = Library::from_source(
            "host.rsl",
            "solid slab(x = 1 m) { part box(x, 1 m, 1 m) }\n",
        )
        .expect("host");
        let terms = |n: usize| vec!["1 mm"; n].join("+");
        match lib.evaluate("slab", &Params::new().expr("x", &terms(10_000))) {
            Ok(Evaluated::Solid(s)) => {
                let robosim_library::Primitive::Box { size } = s.parts[0].primitive else {
                    panic!("not a box: {:?}", s.parts[0].primitive);
                };
                assert!((size[0] - 10.0).abs() < 1e-9, "{size:?}");
            }
            Ok(other) => panic!("not a solid: {other:?}"),
            Err(e) => panic!("{}", e.to_string().lines().next().unwrap_or("")),
        }
        match lib.evaluate("slab", &Params::new().expr("x", &terms(1_000_000))) {
            Err(Error::Source(e)) => {
                assert!(
                    e.message.starts_with("expression too large"),
                    "{}",
                    e.message
                );
                assert_eq!(e.location.file, "<parameter x>");
            }
            Err(e) => panic!("{}", e.to_string().lines().next().unwrap_or("")),
            Ok(_) => panic!("a million terms accepted"),
        }
    });
}

#[test]
fn issue_20_right_nested_power_chain_is_bounded_by_the_nesting_limit() {
    // `^` is right-associative, so a chain of them nests; it used to recurse without a bound
    let src = format!("let x = 1{}\n", "^1".repeat(10_000));
    let e = Library::from_source("pow.rsl", &src).expect_err("too deep");
    assert!(e.message.contains("nested more than 200 deep"), "{e}");
    let lib = Library::from_source("pow.rsl", &format!("let x = 1{}\n", "^1".repeat(150)))
        .expect("150 powers");
    assert_eq!(constant(&lib, "x"), 1.0);
}

#[test]
fn issue_20_declarations_used_exponentially_many_times_are_refused_quickly() {
    // a_k uses a_{k-1} twice: a_60 would take 2^60 steps
    let mut src = String::from("let a0 = 1\n");
    for k in 1..=60 {
        src.push_str(&format!("let a{k} = a{} + a{}\n", k - 1, k - 1));
    }
    let t = Instant::now();
    let e = Library::from_source("exp.rsl", &src).expect_err("too much work");
    assert_eq!(e.kind, ErrorKind::OutOfRange);
    assert!(
        e.message.starts_with(&format!(
            "evaluation too large: more than {EVAL_STEP_BUDGET}"
        )),
        "{e}"
    );
    assert!(e.position().starts_with("exp.rsl:"), "{e}");
    // bounded (not a test of speed: hours before the budget, seconds after)
    assert!(t.elapsed().as_secs() < 120, "{:?}", t.elapsed());
    // 20 doublings (10^6 steps) are fine
    let cut: String = src.lines().take(21).map(|l| format!("{l}\n")).collect();
    let lib = Library::from_source("exp.rsl", &cut).expect("2^20 steps");
    assert_eq!(constant(&lib, "a20"), f64::from(1 << 20));
}

#[test]
fn the_standard_library_is_far_below_the_evaluation_budget() {
    // the budget must never refuse a real library: the whole standard library, at defaults
    let lib = robosim_library::standard_library().expect("standard library");
    for d in lib.declarations() {
        if d.kind != robosim_library::DeclKind::Scene {
            lib.evaluate(&d.name, &Params::new())
                .unwrap_or_else(|e| panic!("{}: {e}", d.name));
        }
    }
}

// ------------------------------------------------------------------ item 2: what is read

fn include_error(target: &str) -> robosim_library::LibError {
    let src = format!("include \"{target}\"\nlet x = 1\n");
    let t = Instant::now();
    let e = Library::from_source("inc.rsl", &src).expect_err("refused");
    assert!(t.elapsed().as_secs() < 30, "took {:?}", t.elapsed());
    assert_eq!(e.kind, ErrorKind::Include, "{e}");
    assert_eq!(e.position(), "inc.rsl:1:9", "{e}");
    assert!(
        e.message
            .starts_with(&format!("cannot read included file `{target}`: ")),
        "{e}"
    );
    e
}

#[test]
fn issue_20_include_dev_zero_is_refused_not_read() {
    let e = include_error("/dev/zero");
    assert!(
        e.message
            .contains("it is a character device, not a regular file"),
        "{e}"
    );
}

#[test]
fn issue_20_include_of_a_fifo_is_refused_without_blocking() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("pipe.rsl");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo");
    assert!(made.success());
    // opening a FIFO for reading blocks until a writer comes: the check comes before the open
    let e = include_error(fifo.to_str().expect("utf-8 path"));
    assert!(
        e.message
            .contains("it is a FIFO (named pipe), not a regular file"),
        "{e}"
    );
}

#[test]
fn issue_20_include_of_a_directory_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let e = include_error(dir.path().to_str().expect("utf-8 path"));
    assert!(
        e.message.contains("it is a directory, not a regular file"),
        "{e}"
    );
}

#[test]
fn issue_20_include_larger_than_the_cap_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let big = dir.path().join("big.rsl");
    // sparse: a file of zero bytes one past the cap costs no disk
    let f = std::fs::File::create(&big).expect("create");
    f.set_len(MAX_SOURCE_BYTES + 1).expect("set_len");
    drop(f);
    let e = include_error(big.to_str().expect("utf-8 path"));
    assert!(
        e.message
            .contains("it is larger than 16 MiB, the limit for a library source file"),
        "{e}"
    );
    // exactly at the cap is read (and then refused as text: NUL is not a token)
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(&big)
        .expect("open");
    f.set_len(MAX_SOURCE_BYTES).expect("set_len");
    drop(f);
    let e = Library::from_source("inc.rsl", &format!("include \"{}\"\n", big.display()))
        .expect_err("NUL bytes");
    assert_eq!(e.kind, ErrorKind::Syntax, "{e}");
}

#[test]
fn issue_20_top_level_file_dev_zero_and_fifo_are_refused() {
    match Library::load("/dev/zero") {
        Err(Error::Io { path, message }) => {
            assert_eq!(path, "/dev/zero");
            assert!(message.contains("character device"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    let dir = tempfile::tempdir().expect("tempdir");
    match Library::load(dir.path()) {
        Err(Error::Io { message, .. }) => assert!(message.contains("a directory"), "{message}"),
        other => panic!("{other:?}"),
    }
    let ok = dir.path().join("ok.rsl");
    std::fs::write(&ok, "let x = 2 + 2\n").expect("write");
    assert_eq!(
        constant(&Library::load(&ok).expect("a regular file loads"), "x"),
        4.0
    );
    // a file that includes a device is refused with the including line
    let inc = dir.path().join("inc.rsl");
    std::fs::write(&inc, "\n  include \"/dev/urandom\"\n").expect("write");
    match Library::load(&inc) {
        Err(Error::Source(e)) => {
            assert_eq!(e.kind, ErrorKind::Include);
            assert_eq!((e.location.line, e.location.column), (2, 11), "{e}");
            assert!(e.message.contains("character device"), "{e}");
        }
        other => panic!("{other:?}"),
    }
}
