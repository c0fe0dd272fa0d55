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
