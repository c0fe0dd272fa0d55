//! The workspace's shape, checked: the crates and their dependency arrows as DESIGN.md draws
//! them. The picture in docs/architecture.md (a Mermaid graph) and docs/images/crates.svg are
//! generated from the Cargo.toml files by this test — `ROBOSIM_UPDATE_DOCS=1 cargo test --test
//! architecture` rewrites them; without it the test fails when they are stale — and the rules
//! below fail the build when an arrow points the wrong way.
//!
//! The floors (issue 35, "Folders say the layers"): every workspace crate sits on one floor of
//! [`FLOORS`], and may depend — dependencies, dev-dependencies and build-dependencies alike, as
//! `cargo metadata` lists them — only on crates of its own floor or below; a crate missing from
//! the table fails. A folder says its floor (`core/*` is the core floor; a crate nested in
//! another crate's folder sits on that crate's floor). clap is the binary's alone, and every
//! crate whose sources hold no `unsafe` says `#![forbid(unsafe_code)]`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The numeric cores: plain functions over plain data (DESIGN.md, "Layout").
const CORES: &[&str] = &[
    "robosim-geometry",
    "robosim-kinematics",
    "robosim-dynamics",
    "robosim-collision",
];
/// What a core may depend on.
const CORE_ALLOWED: &[&str] = &[
    "nalgebra",
    "parry3d-f64",
    "serde",
    "thiserror",
    "rand",
    "rand_chacha",
    // The inline robot JSON form lives in the kinematics core (robosim_kinematics::json).
    "serde_json",
    "robosim-geometry",
    "robosim-kinematics",
    "robosim-dynamics",
    "robosim-collision",
];
/// Transport, command-line and report crates: no core, no space, no pipeline reaches them.
const OUTER: &[&str] = &[
    "clap",
    "plotters",
    "robosim-report",
    "robosim-hl-interface",
    "robosim-display",
    "robosim-studies",
    "iceoryx2",
    "wgpu",
    "winit",
];
/// External crates worth drawing (the heavy or architectural ones).
const DRAWN_EXTERNAL: &[&str] = &["iceoryx2", "parry3d-f64", "wgpu", "clap", "plotters"];

/// `(package name, folder, its [dependencies] names)` of every workspace member.
fn members() -> Vec<(String, String, BTreeSet<String>)> {
    let root = std::fs::read_to_string(Path::new(ROOT).join("Cargo.toml")).expect("Cargo.toml");
    let list = root
        .split("members = [")
        .nth(1)
        .and_then(|s| s.split(']').next())
        .expect("workspace members");
    let mut out = Vec::new();
    for m in list.split(',') {
        let dir = m.trim().trim_matches('"');
        if dir.is_empty() {
            continue;
        }
        let text = std::fs::read_to_string(Path::new(ROOT).join(dir).join("Cargo.toml"))
            .expect("member Cargo.toml");
        let mut name = String::new();
        let mut deps = BTreeSet::new();
        let mut section = String::new();
        for line in text.lines() {
            let line = line.trim();
            if line.starts_with('[') {
                section = line.to_owned();
                continue;
            }
            if line.starts_with('#') || line.is_empty() {
                continue;
            }
            if section == "[package]" && line.starts_with("name") {
                name = line
                    .split('=')
                    .nth(1)
                    .map(|v| v.trim().trim_matches('"').to_owned())
                    .unwrap_or_default();
            }
            if section == "[dependencies]" {
                let dep = line
                    .split(['=', '.', ' '])
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_owned();
                if !dep.is_empty() {
                    deps.insert(dep);
                }
            }
        }
        let folder = if dir == "." {
            "src".to_owned()
        } else {
            dir.to_owned()
        };
        out.push((name, folder, deps));
    }
    out
}

fn short(name: &str) -> String {
    name.trim_start_matches("robosim-").to_owned()
}

/// Layers for drawing: a crate sits one layer above the highest crate it depends on.
fn layers(ms: &[(String, String, BTreeSet<String>)]) -> BTreeMap<String, usize> {
    let names: BTreeSet<&str> = ms.iter().map(|m| m.0.as_str()).collect();
    let mut layer: BTreeMap<String, usize> = BTreeMap::new();
    for _ in 0..ms.len() + 1 {
        for (n, _, deps) in ms {
            let l = deps
                .iter()
                .filter(|d| names.contains(d.as_str()))
                .map(|d| layer.get(d).copied().unwrap_or(0) + 1)
                .max()
                .unwrap_or(0);
            layer.insert(n.clone(), l);
        }
    }
    layer
}

fn mermaid(ms: &[(String, String, BTreeSet<String>)]) -> String {
    let names: BTreeSet<&str> = ms.iter().map(|m| m.0.as_str()).collect();
    let mut s = String::from("```mermaid\ngraph BT\n");
    for (n, folder, _) in ms {
        s += &format!(
            "  {}[\"{}<br/><small>{}/</small>\"]\n",
            short(n).replace('-', "_"),
            short(n),
            folder
        );
    }
    for e in DRAWN_EXTERNAL {
        s += &format!("  x_{}((\"{}\"))\n", e.replace('-', "_"), e);
    }
    for (n, _, deps) in ms {
        for d in deps {
            if names.contains(d.as_str()) {
                s += &format!(
                    "  {} --> {}\n",
                    short(n).replace('-', "_"),
                    short(d).replace('-', "_")
                );
            } else if DRAWN_EXTERNAL.contains(&d.as_str()) {
                s += &format!(
                    "  {} -.-> x_{}\n",
                    short(n).replace('-', "_"),
                    d.replace('-', "_")
                );
            }
        }
    }
    s + "```\n"
}

fn svg(ms: &[(String, String, BTreeSet<String>)]) -> String {
    let layer = layers(ms);
    let top = layer.values().copied().max().unwrap_or(0);
    let mut rows: BTreeMap<usize, Vec<&str>> = BTreeMap::new();
    for (n, _, _) in ms {
        rows.entry(layer[n]).or_default().push(n);
    }
    let (bw, bh, gx, gy) = (150.0, 34.0, 24.0, 70.0);
    let width = rows.values().map(|r| r.len()).max().unwrap_or(1) as f64 * (bw + gx) + gx;
    let height = (top + 1) as f64 * (bh + gy) + gy;
    let mut pos: BTreeMap<&str, (f64, f64)> = BTreeMap::new();
    for (l, row) in &rows {
        let y = gy / 2.0 + (top - l) as f64 * (bh + gy);
        let x0 = (width - row.len() as f64 * (bw + gx) + gx) / 2.0;
        for (k, n) in row.iter().enumerate() {
            pos.insert(n, (x0 + k as f64 * (bw + gx), y));
        }
    }
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width:.0}\" height=\"{height:.0}\" font-family=\"sans-serif\" font-size=\"13\">\n\
         <defs><marker id=\"a\" viewBox=\"0 0 10 10\" refX=\"10\" refY=\"5\" markerWidth=\"7\" markerHeight=\"7\" orient=\"auto\"><path d=\"M0,0 L10,5 L0,10 z\" fill=\"#555\"/></marker></defs>\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    for (n, _, deps) in ms {
        for d in deps {
            if let (Some(&(x1, y1)), Some(&(x2, y2))) = (pos.get(n.as_str()), pos.get(d.as_str())) {
                s += &format!(
                    "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"#888\" marker-end=\"url(#a)\"/>\n",
                    x1 + bw / 2.0,
                    y1 + bh,
                    x2 + bw / 2.0,
                    y2
                );
            }
        }
    }
    for (n, folder, _) in ms {
        let (x, y) = pos[n.as_str()];
        let fill = if CORES.contains(&n.as_str()) {
            "#dbe9f6"
        } else {
            "#f3f3f3"
        };
        s += &format!(
            "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{bw}\" height=\"{bh}\" rx=\"5\" fill=\"{fill}\" stroke=\"#333\"/>\n\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\n\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\" font-size=\"10\" fill=\"#555\">{}/</text>\n",
            x + bw / 2.0,
            y + 15.0,
            short(n),
            x + bw / 2.0,
            y + 28.0,
            folder
        );
    }
    s + "</svg>\n"
}

const BEGIN: &str = "<!-- crates: generated by tests/architecture.rs -->\n";
const END: &str = "<!-- end crates -->";

#[test]
fn cores_depend_only_on_numeric_crates() {
    let ms = members();
    for (n, _, deps) in &ms {
        if CORES.contains(&n.as_str()) {
            let bad: Vec<&String> = deps
                .iter()
                .filter(|d| !CORE_ALLOWED.contains(&d.as_str()))
                .collect();
            assert!(bad.is_empty(), "core {n} depends on {bad:?}");
        }
    }
}

#[test]
fn no_arrow_points_from_an_inner_crate_to_transport_cli_or_report() {
    let inner = [
        "robosim-geometry",
        "robosim-kinematics",
        "robosim-dynamics",
        "robosim-collision",
        "robosim-simulator",
        "robosim-instance-space",
        "robosim-library",
        "robosim-scene",
        "robosim-automation",
    ];
    for (n, _, deps) in members() {
        if inner.contains(&n.as_str()) {
            let bad: Vec<&String> = deps
                .iter()
                .filter(|d| {
                    OUTER.contains(&d.as_str())
                        && !(n == "robosim-instance-space" && d.as_str() == "iceoryx2")
                })
                .collect();
            assert!(bad.is_empty(), "{n} depends on {bad:?}");
        }
    }
}

#[test]
fn the_pictures_of_the_crates_are_current() {
    let ms = members();
    let doc_path = Path::new(ROOT).join("docs/architecture.md");
    let svg_path = Path::new(ROOT).join("docs/images/crates.svg");
    let mut doc = std::fs::read_to_string(&doc_path).expect("docs/architecture.md");
    let (head, rest) = doc.split_once(BEGIN).expect("begin marker");
    let (_, tail) = rest.split_once(END).expect("end marker");
    let want_doc = format!("{head}{BEGIN}{}{END}{tail}", mermaid(&ms));
    let want_svg = svg(&ms);
    if std::env::var_os("ROBOSIM_UPDATE_DOCS").is_some() {
        std::fs::write(&doc_path, &want_doc).expect("write doc");
        std::fs::write(&svg_path, &want_svg).expect("write svg");
        doc = std::fs::read_to_string(&doc_path).expect("docs/architecture.md");
    }
    assert_eq!(
        doc, want_doc,
        "docs/architecture.md's crate graph is stale: ROBOSIM_UPDATE_DOCS=1 cargo test -p robosim --test robosim architecture::"
    );
    assert_eq!(
        std::fs::read_to_string(&svg_path).unwrap_or_default(),
        want_svg,
        "docs/images/crates.svg is stale"
    );
}

/// The floors, bottom first: a crate may depend only on crates of its floor or below.
///
/// * core — what every process computes with: plain functions over plain data, no transport;
/// * engine — the effect pipeline and the automation kernels over the cores;
/// * spaces — the Instance Space (shared memory) and the Library Space (the language);
/// * seam — Library → Instance and Instance → cores (scene), and the recording format (record);
/// * tools — the accuracy-against-time reports (report): below the processes because the
///   display draws its status line with report's bundled font and its bench writes reports;
/// * processes — each a process role or a front end (and the launcher that starts them);
/// * studies — the case studies, which start sessions and drive the processes;
/// * binary — the `robosim` binary: the command line (clap) and the dispatch.
const FLOORS: &[(&str, &[&str])] = &[
    (
        "core",
        &[
            "robosim-input",
            "robosim-geometry",
            "robosim-kinematics",
            "robosim-dynamics",
            "robosim-collision",
            "robosim-urdf",
            "robosim-model",
        ],
    ),
    ("engine", &["robosim-simulator", "robosim-automation"]),
    ("spaces", &["robosim-instance-space", "robosim-library"]),
    ("seam", &["robosim-scene", "robosim-record"]),
    ("tools", &["robosim-report"]),
    (
        "processes",
        &[
            "robosim-simulator-daemon",
            "robosim-display",
            "robosim-hl-interface",
            "robosim-rules",
            "robosim-file-io",
            "robosim-editor",
            "robosim-bridge",
            "robosim-python",
            "robosim-launcher",
        ],
    ),
    ("studies", &["robosim-studies"]),
    ("binary", &["robosim"]),
];

/// Folders that say a floor: every crate under them sits on it.
const FOLDER_FLOORS: &[(&str, &str)] = &[("core/", "core")];

/// Arrows pointing up that are being removed, each with who removes it: the test fails on any
/// upward arrow not listed here. Empty since issue 35 (the cores' dev-dependencies on hl-interface
/// and file-io and simulator -> library-space are gone); the mechanism stays for the next move.
const KNOWN_UPWARD: &[(&str, &str, &str)] = &[];

/// Crates nested in the folder of a crate of another floor, known. Empty since the simulator
/// daemon moved from simulator/daemon/ (the engine's folder) to daemon/ beside the other processes.
const KNOWN_NESTED: &[(&str, &str)] = &[];

/// Crates that may depend on clap and clap_complete: the binary, whose src/cli/ is the command
/// line of every crate.
const CLAP_USERS: &[&str] = &["robosim"];

/// One workspace package as `cargo metadata` lists it.
struct Package {
    name: String,
    /// Its folder relative to the workspace root ("" for the root package).
    folder: String,
    /// Every dependency: (name, kind: "normal", "dev" or "build").
    deps: Vec<(String, String)>,
    /// The root source files of its lib, cdylib and bin targets.
    roots: Vec<std::path::PathBuf>,
}

/// The workspace's packages from `cargo metadata --no-deps` (dev-dependencies included).
fn packages() -> Vec<Package> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned());
    let out = std::process::Command::new(cargo)
        .args([
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ])
        .current_dir(ROOT)
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata JSON");
    let root = Path::new(ROOT);
    let str_of = |v: &serde_json::Value| v.as_str().unwrap_or_default().to_owned();
    meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| {
            let manifest = std::path::PathBuf::from(str_of(&p["manifest_path"]));
            let dir = manifest.parent().expect("manifest's folder");
            let folder = dir
                .strip_prefix(root)
                .unwrap_or(dir)
                .to_string_lossy()
                .into_owned();
            let deps = p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .map(|d| {
                    let kind = d["kind"].as_str().unwrap_or("normal").to_owned();
                    (str_of(&d["name"]), kind)
                })
                .collect();
            let roots = p["targets"]
                .as_array()
                .expect("targets")
                .iter()
                .filter(|t| {
                    t["kind"].as_array().is_some_and(|k| {
                        k.iter()
                            .any(|k| matches!(k.as_str(), Some("lib" | "cdylib" | "rlib" | "bin")))
                    })
                })
                .map(|t| std::path::PathBuf::from(str_of(&t["src_path"])))
                .collect();
            Package {
                name: str_of(&p["name"]),
                folder,
                deps,
                roots,
            }
        })
        .collect()
}

/// The floor index of every crate of [`FLOORS`].
fn floor_of() -> BTreeMap<&'static str, usize> {
    let mut m = BTreeMap::new();
    for (i, (_, crates)) in FLOORS.iter().enumerate() {
        for c in *crates {
            assert!(m.insert(*c, i).is_none(), "{c} is on two floors");
        }
    }
    m
}

/// Every dependency arrow between workspace crates that points to a higher floor, as
/// "from (floor) -> to (floor) [kind]", the known ones left out.
fn upward_arrows(pkgs: &[Package], floors: &BTreeMap<&str, usize>) -> Vec<String> {
    let names: BTreeSet<&str> = pkgs.iter().map(|p| p.name.as_str()).collect();
    let mut bad = Vec::new();
    for p in pkgs {
        let Some(&from) = floors.get(p.name.as_str()) else {
            continue;
        };
        for (d, kind) in &p.deps {
            if !names.contains(d.as_str()) {
                continue;
            }
            let Some(&to) = floors.get(d.as_str()) else {
                continue;
            };
            let known = KNOWN_UPWARD
                .iter()
                .any(|(a, b, _)| *a == p.name && *b == d.as_str());
            if to > from && !known {
                bad.push(format!(
                    "{} ({}) -> {d} ({}) [{kind}]",
                    p.name, FLOORS[from].0, FLOORS[to].0
                ));
            }
        }
    }
    bad
}

#[test]
fn every_crate_depends_only_on_its_floor_or_below_dev_dependencies_included() {
    let pkgs = packages();
    let floors = floor_of();
    let missing: Vec<&str> = pkgs
        .iter()
        .map(|p| p.name.as_str())
        .filter(|n| !floors.contains_key(n))
        .collect();
    assert!(
        missing.is_empty(),
        "crates on no floor (add them to FLOORS in tests/architecture.rs): {missing:?}"
    );
    let bad = upward_arrows(&pkgs, &floors);
    assert!(
        bad.is_empty(),
        "dependencies pointing to a higher floor:\n  {}",
        bad.join("\n  ")
    );
}

#[test]
fn the_floor_check_catches_an_upward_arrow() {
    // The same check over a made-up crate on the core floor that dev-depends on the binary.
    let mut floors = floor_of();
    floors.insert("robosim-made-up-core", 0);
    let pkgs = vec![
        Package {
            name: "robosim-made-up-core".into(),
            folder: "core/made-up".into(),
            deps: vec![("robosim".into(), "dev".into())],
            roots: Vec::new(),
        },
        Package {
            name: "robosim".into(),
            folder: String::new(),
            deps: Vec::new(),
            roots: Vec::new(),
        },
    ];
    assert_eq!(
        upward_arrows(&pkgs, &floors),
        ["robosim-made-up-core (core) -> robosim (binary) [dev]"]
    );
}

#[test]
fn every_folder_says_its_floor() {
    let pkgs = packages();
    let floors = floor_of();
    let mut bad = Vec::new();
    for p in &pkgs {
        let Some(&floor) = floors.get(p.name.as_str()) else {
            continue;
        };
        let folder = format!("{}/", p.folder);
        for (prefix, said) in FOLDER_FLOORS {
            if folder.starts_with(prefix) && FLOORS[floor].0 != *said {
                bad.push(format!(
                    "{} in {folder} sits on floor {}, the folder says {said}",
                    p.name, FLOORS[floor].0
                ));
            }
        }
        // A crate nested in another crate's folder sits on that crate's floor.
        for q in &pkgs {
            let outer = format!("{}/", q.folder);
            let nested = q.name != p.name && !q.folder.is_empty() && folder.starts_with(&outer);
            let known = KNOWN_NESTED.iter().any(|(n, _)| *n == p.name);
            if nested && !known && floors.get(q.name.as_str()) != Some(&floor) {
                bad.push(format!(
                    "{} in {folder} sits on floor {}, inside {} of floor {}",
                    p.name,
                    FLOORS[floor].0,
                    q.name,
                    floors.get(q.name.as_str()).map_or("none", |&f| FLOORS[f].0)
                ));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "folders that misstate the floor:\n  {}",
        bad.join("\n  ")
    );
}

#[test]
fn clap_is_the_binarys_alone() {
    let bad: Vec<String> = packages()
        .iter()
        .filter(|p| !CLAP_USERS.contains(&p.name.as_str()))
        .flat_map(|p| {
            p.deps
                .iter()
                .filter(|(d, _)| d == "clap" || d == "clap_complete")
                .map(move |(d, kind)| format!("{} -> {d} [{kind}]", p.name))
        })
        .collect();
    assert!(
        bad.is_empty(),
        "clap outside the binary (its command line lives in src/cli/): {bad:?}"
    );
}

/// True when `text` holds the keyword `unsafe` outside `//` comments.
fn has_unsafe(text: &str) -> bool {
    let ident = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
    text.lines().any(|line| {
        let code = line.split("//").next().unwrap_or_default();
        code.match_indices("unsafe").any(|(i, _)| {
            !ident(code[..i].chars().next_back()) && !ident(code[i + 6..].chars().next())
        })
    })
}

/// The `.rs` files under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let path = e.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn the_unsafe_check_sees_the_keyword_not_words_that_contain_it() {
    assert!(has_unsafe("    unsafe { libc::kill(pid, 9) };"));
    assert!(has_unsafe("pub unsafe fn f() {}"));
    assert!(!has_unsafe("#![forbid(unsafe_code)]"));
    assert!(!has_unsafe("// SAFETY: no unsafe here"));
    assert!(!has_unsafe("let not_unsafe = 1;"));
}

#[test]
fn every_crate_without_unsafe_forbids_it() {
    let mut missing = Vec::new();
    for p in packages() {
        let mut files = Vec::new();
        for r in &p.roots {
            rust_files(r.parent().expect("a target's folder"), &mut files);
        }
        files.sort();
        files.dedup();
        let unsafe_in: Vec<&std::path::PathBuf> = files
            .iter()
            .filter(|f| has_unsafe(&std::fs::read_to_string(f).unwrap_or_default()))
            .collect();
        if !unsafe_in.is_empty() {
            continue;
        }
        for r in &p.roots {
            let text = std::fs::read_to_string(r).unwrap_or_default();
            if !text.lines().any(|l| l.trim() == "#![forbid(unsafe_code)]") {
                missing.push(format!("{} ({})", p.name, r.display()));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "crates without unsafe that do not say #![forbid(unsafe_code)]: {missing:?}"
    );
}

// ---- Files of one crate that import each other (issue 35 item 5, "the circles gone") ----
//
// The Rust form of tools/modcycles.py: file A uses an item defined in file B and B one defined
// in A (`use crate::…`, `use super::…`, `use self::…`, a child module's name, or such a path
// written in the code). Imports are followed through re-exports to the file that defines the
// item; a `pub use` (any `pub(…) use`) alone is a module's facade, not an import; everything
// from a file's first `#[cfg(test)]` on is left out, and so are `src/bin/`, `tests/`, `benches/`,
// `examples/` and `fuzz/`. A pair means a shared type lives in the wrong file: move it to the
// file that owns it, or to a small module both import.

/// A module: its path from the crate root (`[]` for lib.rs/main.rs, `["a", "b"]` for
/// src/a/b.rs or src/a/b/mod.rs).
type ModKey = Vec<String>;

/// One import of a file: whether it is a `pub use`, its path's segments, and the name it
/// brings in (the alias, or the last segment).
struct Import {
    public: bool,
    segs: Vec<String>,
    alias: String,
}

struct CrateModules {
    files: BTreeMap<ModKey, std::path::PathBuf>,
    defs: BTreeMap<ModKey, BTreeSet<String>>,
    uses: BTreeMap<ModKey, Vec<Import>>,
}

/// The crates under `root`: folders with a Cargo.toml and a `src/` (target, .git, tests,
/// benches, examples and fuzz folders not searched).
fn crate_folders(root: &Path, out: &mut Vec<std::path::PathBuf>) {
    const SKIP: &[&str] = &[
        "target",
        ".git",
        "node_modules",
        "fuzz",
        "tests",
        "benches",
        "examples",
    ];
    if root.join("Cargo.toml").is_file() && root.join("src").is_dir() {
        out.push(root.to_path_buf());
    }
    let Ok(entries) = std::fs::read_dir(root) else {
        return;
    };
    let mut dirs: Vec<_> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| !SKIP.contains(&n))
        })
        .collect();
    dirs.sort();
    for d in dirs {
        crate_folders(&d, out);
    }
}

/// The text with comments removed, string and char literals emptied, and everything from the
/// first `#[cfg(test)]` on cut.
fn strip_code(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if c[i] == '\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
        } else if c[i] == 'r'
            && (next == Some('"') || next == Some('#'))
            && {
                // not the end of an identifier (`br"…"` is a raw byte string)
                let before = |k: usize| i >= k && is_ident_char(c[i - k]);
                !before(1) || (c[i - 1] == 'b' && !before(2))
            }
            && {
                // a raw string r"…" or r#"…"#
                let mut k = i + 1;
                while c.get(k) == Some(&'#') {
                    k += 1;
                }
                c.get(k) == Some(&'"')
            }
        {
            let mut k = i + 1;
            let mut hashes = 0;
            while c[k] == '#' {
                hashes += 1;
                k += 1;
            }
            k += 1;
            loop {
                if k >= c.len() {
                    break;
                }
                if c[k] == '"' && (0..hashes).all(|h| c.get(k + 1 + h) == Some(&'#')) {
                    k += 1 + hashes;
                    break;
                }
                k += 1;
            }
            out.push_str("\"\"");
            i = k;
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' {
            // a char literal ('x', '\n', '\u{1F600}'), not a lifetime ('a)
            let close = if next == Some('\\') {
                (i + 2..c.len().min(i + 12)).find(|&k| c[k] == '\'')
            } else if c.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match close {
                Some(k) => {
                    out.push_str("' '");
                    i = k + 1;
                }
                None => {
                    out.push('\'');
                    i += 1;
                }
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    match out.find("#[cfg(test)]") {
        Some(k) => out[..k].to_string(),
        None => out,
    }
}

fn is_ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// After an optional `pub` or `pub(…)` and whitespace at the start of `s`: the rest, and
/// whether there was one.
fn after_pub(s: &str) -> (&str, bool) {
    let Some(rest) = s.strip_prefix("pub") else {
        return (s, false);
    };
    let rest = match rest.strip_prefix('(') {
        Some(r) => match r.find(')') {
            Some(k) => &r[k + 1..],
            None => return (s, false),
        },
        None => rest,
    };
    if rest.starts_with(char::is_whitespace) {
        (rest.trim_start(), true)
    } else {
        (s, false)
    }
}

/// The leading identifier of `s`.
fn ident(s: &str) -> &str {
    let end = s.find(|c: char| !is_ident_char(c)).unwrap_or(s.len());
    &s[..end]
}

/// The names a file defines at the start of a line: `fn`, `struct`, `enum`, `trait`, `type`,
/// `const`, `static`, `union`, `mod` (after `pub`, `pub(…)`, `unsafe`, `const`, `async`) and
/// `macro_rules!`.
fn definitions(code: &str) -> BTreeSet<String> {
    const KINDS: &[&str] = &[
        "fn", "struct", "enum", "trait", "type", "const", "static", "union", "mod",
    ];
    const QUALIFIERS: &[&str] = &["unsafe", "const", "async"];
    let mut out = BTreeSet::new();
    for line in code.lines() {
        let (mut s, _) = after_pub(line.trim_start());
        if let Some(r) = s.strip_prefix("macro_rules!") {
            let name = ident(r.trim_start());
            if r.starts_with(char::is_whitespace) && !name.is_empty() {
                out.insert(name.to_string());
            }
            continue;
        }
        // the line's first words, each but the last followed by white space
        let mut words = Vec::new();
        while words.len() < 8 {
            let w = ident(s);
            if w.is_empty() {
                break;
            }
            words.push(w);
            let rest = &s[w.len()..];
            if !rest.starts_with(char::is_whitespace) {
                break;
            }
            s = rest.trim_start();
        }
        // as many qualifiers as leave a kind and a name (`const fn f`, `const N`)
        let q = words.iter().take_while(|w| QUALIFIERS.contains(w)).count();
        for k in (0..=q).rev() {
            let (Some(kind), Some(name)) = (words.get(k), words.get(k + 1)) else {
                continue;
            };
            if KINDS.contains(kind) && !name.starts_with(|c: char| c.is_ascii_digit()) {
                out.insert(name.to_string());
                break;
            }
        }
    }
    out
}

/// A `use` tree expanded into its paths: `a::{b, c::{d, self}}` is `a::b`, `a::c::d`, `a::c`.
fn expand_use(u: &str) -> Vec<String> {
    let Some(i) = u.find('{') else {
        return vec![u.to_string()];
    };
    let Some(j) = u.rfind('}') else {
        return vec![u.to_string()];
    };
    let head = &u[..i];
    let mut parts = Vec::new();
    let mut depth = 0;
    let mut cur = String::new();
    for ch in u[i + 1..j].chars() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            _ => {}
        }
        if ch == ',' && depth == 0 {
            parts.push(std::mem::take(&mut cur));
        } else {
            cur.push(ch);
        }
    }
    parts.push(cur);
    let mut out = Vec::new();
    for p in parts {
        let p = p.trim();
        if p.is_empty() {
            continue;
        }
        if p == "self" {
            out.push(head.trim_end_matches(':').to_string());
            continue;
        }
        out.extend(expand_use(&format!("{head}{p}")));
    }
    out
}

/// The `use` declarations of a file (at a line's start), as (is `pub`, the tree), and the code
/// without them.
fn use_declarations(code: &str) -> (Vec<(bool, String)>, String) {
    let mut uses = Vec::new();
    let mut rest = String::with_capacity(code.len());
    let mut at = 0;
    let mut line_start = 0;
    while line_start < code.len() {
        let line_end = code[line_start..]
            .find('\n')
            .map_or(code.len(), |k| line_start + k + 1);
        if line_start < at {
            line_start = line_end;
            continue;
        }
        let line = &code[line_start..line_end];
        let trimmed = line.trim_start();
        let (after, public) = after_pub(trimmed);
        let is_use = after
            .strip_prefix("use")
            .is_some_and(|r| r.starts_with(char::is_whitespace));
        if is_use {
            let start = line_start + (line.len() - after.len()) + 3;
            if let Some(k) = code[start..].find(';') {
                rest.push_str(&code[at..line_start]);
                let tree: String = code[start..start + k]
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" ");
                uses.push((public, tree));
                at = start + k + 1;
            }
        }
        line_start = line_end;
    }
    rest.push_str(&code[at.min(code.len())..]);
    (uses, rest)
}

/// Paths written in the code that start at `crate`, `super` or `self` (`crate::a::B::new`).
fn code_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for (i, _) in code.char_indices() {
        let prev = code[..i].chars().next_back();
        if prev.is_some_and(|p| is_ident_char(p) || p == ':') {
            continue;
        }
        let first = ident(&code[i..]);
        if !matches!(first, "crate" | "super" | "self") {
            continue;
        }
        let mut segs = vec![first.to_string()];
        let mut k = i + first.len();
        while code[k..].starts_with("::") {
            let seg = ident(&code[k + 2..]);
            if seg.is_empty() || seg.starts_with(|c: char| c.is_ascii_digit()) {
                break;
            }
            segs.push(seg.to_string());
            k += 2 + seg.len();
        }
        if segs.len() > 1 {
            out.push(segs);
        }
    }
    out
}

impl CrateModules {
    fn read(src: &Path) -> CrateModules {
        let mut paths = Vec::new();
        rust_files(src, &mut paths);
        paths.sort();
        let mut files = BTreeMap::new();
        for p in paths {
            let rel = p.strip_prefix(src).expect("under src").with_extension("");
            let mut key: ModKey = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if key.first().is_some_and(|k| k == "bin") {
                continue;
            }
            if key == ["lib"] || key == ["main"] {
                key.clear();
            } else if key.last().is_some_and(|k| k == "mod") {
                key.pop();
            }
            files.entry(key).or_insert(p);
        }
        let mut defs = BTreeMap::new();
        let mut uses = BTreeMap::new();
        for (key, path) in &files {
            let code = strip_code(&std::fs::read_to_string(path).unwrap_or_default());
            defs.insert(key.clone(), definitions(&code));
            let (decls, body) = use_declarations(&code);
            let mut imports = Vec::new();
            for (public, tree) in decls {
                for p in expand_use(&tree) {
                    let (path, alias) = match p.split_once(" as ") {
                        Some((a, b)) => (a.trim().to_string(), Some(b.trim().to_string())),
                        None => (p.trim().to_string(), None),
                    };
                    let segs: Vec<String> = path
                        .split("::")
                        .map(str::trim)
                        .filter(|s| !s.is_empty())
                        .map(String::from)
                        .collect();
                    if let Some(last) = segs.last().cloned() {
                        imports.push(Import {
                            public,
                            segs,
                            alias: alias.unwrap_or(last),
                        });
                    }
                }
            }
            for segs in code_paths(&body) {
                let alias = segs.last().cloned().unwrap_or_default();
                imports.push(Import {
                    public: false,
                    segs,
                    alias,
                });
            }
            uses.insert(key.clone(), imports);
        }
        CrateModules { files, defs, uses }
    }

    fn has(&self, key: &[String]) -> bool {
        self.files.contains_key(key)
    }

    /// The module a path starts from, seen from `here`, and the rest of the path (`None`: an
    /// outside crate).
    fn start(&self, here: &[String], segs: &[String]) -> Option<(ModKey, Vec<String>)> {
        match segs.first().map(String::as_str) {
            Some("crate") => Some((Vec::new(), segs[1..].to_vec())),
            Some("super") => {
                let mut base = here.to_vec();
                let mut k = 0;
                while segs.get(k).is_some_and(|s| s == "super") {
                    base.pop();
                    k += 1;
                }
                Some((base, segs[k..].to_vec()))
            }
            Some("self") => Some((here.to_vec(), segs[1..].to_vec())),
            Some(first) => {
                let mut child = here.to_vec();
                child.push(first.to_string());
                self.has(&child).then(|| (here.to_vec(), segs.to_vec()))
            }
            None => None,
        }
    }

    /// The file (module) that defines what `segs` names, seen from `here`.
    fn target(
        &self,
        here: &[String],
        segs: &[String],
        seen: &mut Vec<(ModKey, String)>,
    ) -> Option<ModKey> {
        let (mut base, mut rest) = self.start(here, segs)?;
        while let Some(first) = rest.first() {
            let mut child = base.clone();
            child.push(first.clone());
            if !self.has(&child) {
                break;
            }
            base = child;
            rest.remove(0);
        }
        if rest.is_empty() || rest == ["*"] {
            return Some(base);
        }
        let name = rest[0].clone();
        if self.defs.get(&base).is_some_and(|d| d.contains(&name)) {
            return Some(base);
        }
        if seen.contains(&(base.clone(), name.clone())) {
            return Some(base);
        }
        for imp in self.uses.get(&base).into_iter().flatten() {
            let glob = imp.segs.last().is_some_and(|s| s == "*");
            if imp.alias != name && !glob {
                continue;
            }
            let path: Vec<String> = if imp.alias == name {
                imp.segs.clone()
            } else {
                let mut p = imp.segs[..imp.segs.len() - 1].to_vec();
                p.push(name.clone());
                p
            };
            seen.push((base.clone(), name.clone()));
            let t = self.target(&base, &path, seen);
            seen.pop();
            if let Some(t) = t {
                if imp.alias == name || self.defs.get(&t).is_some_and(|d| d.contains(&name)) {
                    return Some(t);
                }
            }
        }
        Some(base)
    }

    /// Pairs of this crate's files that import each other (paths relative to `root`).
    fn pairs(&self, root: &Path) -> Vec<String> {
        let mut edges: BTreeSet<(ModKey, ModKey)> = BTreeSet::new();
        for (key, imports) in &self.uses {
            for imp in imports.iter().filter(|i| !i.public) {
                if let Some(t) = self.target(key, &imp.segs, &mut Vec::new()) {
                    if &t != key {
                        edges.insert((key.clone(), t));
                    }
                }
            }
        }
        let rel = |k: &ModKey| {
            let p = &self.files[k];
            p.strip_prefix(root).unwrap_or(p).display().to_string()
        };
        edges
            .iter()
            .filter(|(a, b)| a < b && edges.contains(&(b.clone(), a.clone())))
            .map(|(a, b)| format!("{} <-> {}", rel(a), rel(b)))
            .collect()
    }
}

/// Every pair of files of one crate under `root` that import each other.
fn module_cycles(root: &Path) -> Vec<String> {
    let mut crates = Vec::new();
    crate_folders(root, &mut crates);
    crates
        .iter()
        .flat_map(|c| CrateModules::read(&c.join("src")).pairs(root))
        .collect()
}

#[test]
fn no_two_files_of_a_crate_import_each_other() {
    let pairs = module_cycles(Path::new(ROOT));
    assert!(
        pairs.is_empty(),
        "files of one crate that import each other (a shared type in the wrong file: move it \
         to the file that owns it, or to a small module both import; tools/modcycles.py lists \
         the same): {pairs:#?}"
    );
}

#[test]
fn the_cycle_check_catches_a_pair() {
    let dir = tempfile::tempdir().expect("temp dir");
    let src = dir.path().join("made-up/src");
    std::fs::create_dir_all(src.join("outer")).expect("folders");
    std::fs::write(dir.path().join("made-up/Cargo.toml"), "").expect("Cargo.toml");
    let files = [
        (
            "lib.rs",
            "mod a;\nmod b;\nmod c;\nmod outer;\npub use a::A;\n",
        ),
        // a uses b's item by a `use` with a group, b uses a's through the crate's re-export
        ("a.rs", "use crate::{c::C, b::B};\npub struct A(B, C);\n"),
        ("b.rs", "pub struct B;\nfn f(_: crate::A) {}\n"),
        // c only re-exports (a facade) and writes "crate::a" in a string and a comment
        (
            "c.rs",
            "pub use crate::a::A as Alias;\npub struct C;\n// crate::a::A\nconst S: &str = \"crate::a::A\";\n",
        ),
        // a parent and its child, the child reaching up by `super`
        (
            "outer/mod.rs",
            "mod inner;\nuse inner::I;\npub struct O(I);\n",
        ),
        (
            "outer/inner.rs",
            "pub struct I;\nfn g(_: super::O) {}\n#[cfg(test)]\nmod tests { use crate::a::A; }\n",
        ),
    ];
    for (name, text) in files {
        std::fs::write(src.join(name), text).expect("file");
    }
    assert_eq!(
        module_cycles(dir.path()),
        [
            "made-up/src/a.rs <-> made-up/src/b.rs",
            "made-up/src/outer/mod.rs <-> made-up/src/outer/inner.rs",
        ]
    );
}
