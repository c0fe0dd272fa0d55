//! The workspace's shape, checked: the crates and their dependency arrows as DESIGN.md draws
//! them. The picture in docs/architecture.md (a Mermaid graph) and docs/images/crates.svg are
//! generated from the Cargo.toml files by this test — `ROBOSIM_UPDATE_DOCS=1 cargo test --test
//! architecture` rewrites them; without it the test fails when they are stale — and the rules
//! below fail the build when an arrow points the wrong way.

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
