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
