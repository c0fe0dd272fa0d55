//! The integration-test layout (CI time, issue 35 item 6): a crate whose tests/ would make more
//! than one test binary gathers them into one — `autotests = false` in its Cargo.toml and one
//! `[[test]]` whose root file (tests/main.rs) declares each file of tests/ as a module — so the
//! crate's tests link once, not once per file. With `autotests = false`, a file of tests/
//! without its `mod` line is never compiled nor run, silently: these tests name it.

use std::path::{Path, PathBuf};

/// The workspace members of the root Cargo.toml (`members = [ ... ]`), as directories.
fn members(root: &Path) -> Vec<PathBuf> {
    let text = std::fs::read_to_string(root.join("Cargo.toml")).expect("read Cargo.toml");
    let start = text
        .find("members = [")
        .expect("the root Cargo.toml lists its members");
    let list = &text[start + "members = [".len()..];
    let list = &list[..list.find(']').expect("members list ends")];
    list.split(',')
        .map(|m| m.trim().trim_matches('"'))
        .filter(|m| !m.is_empty())
        .map(|m| root.join(m))
        .collect()
}

/// The `path`s of the `[[test]]` sections of a manifest.
fn test_roots(manifest: &str) -> Vec<String> {
    let mut roots = Vec::new();
    let mut in_test = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            in_test = line == "[[test]]";
        } else if in_test && let Some(rest) = line.strip_prefix("path") {
            let value = rest.trim_start().trim_start_matches('=').trim();
            roots.push(value.trim_matches('"').to_owned());
        }
    }
    roots
}

/// Whether `source` declares `mod NAME;` (any visibility, any `#[path]` above it).
fn declares(source: &str, name: &str) -> bool {
    let wanted = format!("mod {name};");
    source.lines().map(str::trim).any(|l| {
        l == wanted
            || l.strip_prefix("pub ").is_some_and(|r| r == wanted)
            || l.strip_prefix("pub(crate) ").is_some_and(|r| r == wanted)
    })
}

/// What a crate's tests/ holds: files `NAME.rs` (a binary each under autotests), directories
/// with a `main.rs` (a binary each) and directories with a `mod.rs` (helpers, no binary).
struct TestsDir {
    files: Vec<String>,
    binary_dirs: Vec<String>,
    helper_dirs: Vec<String>,
}

fn tests_dir(dir: &Path) -> Option<TestsDir> {
    let entries = std::fs::read_dir(dir.join("tests")).ok()?;
    let mut t = TestsDir {
        files: Vec::new(),
        binary_dirs: Vec::new(),
        helper_dirs: Vec::new(),
    };
    for entry in entries {
        let path = entry.expect("read tests/").path();
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .expect("UTF-8 file name")
            .to_owned();
        if path.is_dir() {
            if path.join("main.rs").is_file() {
                t.binary_dirs.push(name);
            } else if path.join("mod.rs").is_file() {
                t.helper_dirs.push(name);
            }
        } else if let Some(stem) = name.strip_suffix(".rs") {
            t.files.push(stem.to_owned());
        }
    }
    Some(t)
}

#[test]
fn every_crate_with_several_test_files_builds_one_test_binary() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut wrong = Vec::new();
    for dir in members(root) {
        let Some(t) = tests_dir(&dir) else { continue };
        let manifest =
            std::fs::read_to_string(dir.join("Cargo.toml")).expect("read a member's Cargo.toml");
        let autotests_off = manifest.lines().any(|l| l.trim() == "autotests = false");
        let binaries = t.files.len() + t.binary_dirs.len();
        if binaries > 1 && !autotests_off {
            wrong.push(format!(
                "{}: tests/ makes {binaries} test binaries; gather them in one (autotests = false, \
                 one [[test]] with tests/main.rs declaring each file as a module)",
                dir.display()
            ));
        }
        if autotests_off && test_roots(&manifest).len() != 1 {
            wrong.push(format!(
                "{}: autotests = false wants exactly one [[test]] (found {})",
                dir.display(),
                test_roots(&manifest).len()
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn every_file_of_tests_is_a_module_of_the_test_binary() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut missing = Vec::new();
    let mut checked = 0;
    for dir in members(root) {
        let Some(t) = tests_dir(&dir) else { continue };
        let manifest =
            std::fs::read_to_string(dir.join("Cargo.toml")).expect("read a member's Cargo.toml");
        if !manifest.lines().any(|l| l.trim() == "autotests = false") {
            continue;
        }
        let roots = test_roots(&manifest);
        let sources: Vec<String> = roots
            .iter()
            .map(|r| std::fs::read_to_string(dir.join(r)).expect("read a [[test]] root"))
            .collect();
        let is_root = |rel: &str| roots.iter().any(|r| r == rel);
        let modules = t
            .files
            .iter()
            .filter(|f| !is_root(&format!("tests/{f}.rs")))
            .chain(
                t.binary_dirs
                    .iter()
                    .filter(|d| !is_root(&format!("tests/{d}/main.rs"))),
            )
            .chain(t.helper_dirs.iter());
        for name in modules {
            checked += 1;
            if !sources.iter().any(|s| declares(s, name)) {
                missing.push(format!(
                    "{}: tests/{name} is in no test binary: add `mod {name};` to {}",
                    dir.display(),
                    roots.join(" or ")
                ));
            }
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
    // The workspace's crates hold well over a hundred test files: finding none means this test
    // looked in the wrong place.
    assert!(checked > 50, "only {checked} test files found");
}

/// The value of `key = true|false` in the manifest's `[lib]` section, if set there.
fn lib_flag(manifest: &str, key: &str) -> Option<bool> {
    let mut in_lib = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            in_lib = line == "[lib]";
        } else if in_lib && let Some(rest) = line.strip_prefix(key) {
            let value = rest.trim_start();
            if let Some(v) = value.strip_prefix('=') {
                return Some(v.trim() == "true");
            }
        }
    }
    None
}

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries {
        let path = entry.expect("read a source dir").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Lines (1-based) of `source` where a doc comment opens a code block rustdoc would compile and
/// run: a fence with no language, or `rust` (with or without attributes other than `ignore`/
/// `text`-like languages). A fence that closes a block is skipped.
fn doctest_fences(source: &str) -> Vec<usize> {
    let mut found = Vec::new();
    let mut open = false;
    for (i, line) in source.lines().enumerate() {
        let l = line.trim_start();
        let Some(doc) = l
            .strip_prefix("///")
            .or_else(|| l.strip_prefix("//!"))
            .map(str::trim_start)
        else {
            continue;
        };
        let Some(info) = doc.strip_prefix("```") else {
            continue;
        };
        if open {
            open = false;
            continue;
        }
        open = true;
        let info = info.trim();
        let words: Vec<&str> = info.split(',').map(str::trim).collect();
        let rust = info.is_empty()
            || words.iter().all(|w| {
                matches!(
                    *w,
                    "rust"
                        | "should_panic"
                        | "no_run"
                        | "compile_fail"
                        | "edition2021"
                        | "edition2024"
                )
            });
        if rust && !words.contains(&"ignore") {
            found.push(i + 1);
        }
    }
    found
}

/// CI time (issue 35 item 6): a library whose docs hold no example opts out of rustdoc's test
/// pass (`doctest = false`), and one without unit tests out of its test-mode build
/// (`test = false`) — each pass costs a compile of the crate for nothing. These flags would hide a
/// doc example or a unit test added later, so they are allowed only where there is none.
#[test]
fn libraries_that_skip_doctests_or_unit_tests_have_none() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut wrong = Vec::new();
    let mut skipping = 0;
    for dir in members(root) {
        let manifest =
            std::fs::read_to_string(dir.join("Cargo.toml")).expect("read a member's Cargo.toml");
        let no_doctests = lib_flag(&manifest, "doctest") == Some(false);
        let no_unit_tests = lib_flag(&manifest, "test") == Some(false);
        if !no_doctests && !no_unit_tests {
            continue;
        }
        skipping += 1;
        let mut files = Vec::new();
        rust_files(&dir.join("src"), &mut files);
        for file in files {
            let source = std::fs::read_to_string(&file).expect("read a source file");
            if no_doctests {
                for line in doctest_fences(&source) {
                    wrong.push(format!(
                        "{}:{line}: a doc example, but the crate's [lib] says doctest = false \
                         (it would never run): remove that line from {}/Cargo.toml",
                        file.display(),
                        dir.display()
                    ));
                }
            }
            if no_unit_tests && source.lines().any(|l| l.trim() == "#[test]") {
                wrong.push(format!(
                    "{}: a unit test, but the crate's [lib] says test = false (it would never \
                     run): remove that line from {}/Cargo.toml",
                    file.display(),
                    dir.display()
                ));
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    assert!(
        skipping > 10,
        "only {skipping} libraries skip a pass: the manifests moved?"
    );
}

#[test]
fn the_doctest_scan_finds_a_runnable_example_and_skips_text() {
    let src = "//! ```\n//! let x = 1;\n//! ```\n/// ```text\n/// not rust\n/// ```\n\
               /// ```rust,ignore\n/// skipped\n/// ```\n/// ```no_run\n/// x();\n/// ```\n";
    assert_eq!(doctest_fences(src), vec![1, 10]);
    assert_eq!(
        lib_flag(
            "[package]\nname = \"a\"\n[lib]\ndoctest = false\n",
            "doctest"
        ),
        Some(false)
    );
    assert_eq!(lib_flag("[lib]\ntest = false\n", "doctest"), None);
}
