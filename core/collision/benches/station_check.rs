//! Robot versus scene, issue 37 item 2: the space station's servicer (6 DOF) against the 300-odd
//! other parts of `space_station`, exact mode, at a configuration in contact and one clear
//! (`testdata/collision/station_check.json`, written by
//! `report/examples/station_check_export.rs`; coal checks the same data in
//! `tools/peers/station_check_coal.py`). Timed from link poses (no forward kinematics), no
//! self-collision, stopping at the first contact — the seed's CHECK as the simulator's
//! collision stage runs it.
//!
//! * `boolean` — the certified boolean only (`depth: None`: the simulator's stage, MOVEJ's
//!   stop test);
//! * `depth` — plus the penetration depth and witness points of the contact reported.
//!
//! `cargo bench -p robosim-collision --bench station_check`

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Isometry3;
use robosim_collision::json::{pose_from_json, solid_from_json};
use robosim_collision::robot::{CheckResult, CollisionSettings, LinkSolids, Scene, check_links};
use serde_json::Value;
use std::hint::black_box;
use std::sync::Arc;

struct Workload {
    links: LinkSolids,
    scene: Scene,
    contact: Vec<Option<Isometry3<f64>>>,
    clear: Vec<Option<Isometry3<f64>>>,
}

fn load() -> Workload {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../testdata/collision/station_check.json"
    );
    let text = std::fs::read_to_string(path).expect("station_check.json is checked in");
    let doc: Value = serde_json::from_str(&text).expect("JSON");
    let mut scene = Scene::new();
    for (i, o) in doc["objects"]
        .as_array()
        .expect("objects")
        .iter()
        .enumerate()
    {
        let solid = solid_from_json(o, &format!("objects[{i}]"), &["name", "pose"]).expect("solid");
        let pose = pose_from_json(&o["pose"], "pose").expect("pose");
        scene.add(o["name"].as_str().unwrap_or("?"), Arc::new(solid), pose);
    }
    let mut parts = Vec::new();
    for l in doc["links"].as_array().expect("links") {
        let mut p = Vec::new();
        for s in l.as_array().expect("parts") {
            let solid = solid_from_json(s, "part", &["pose"]).expect("part");
            p.push((pose_from_json(&s["pose"], "pose").expect("pose"), solid));
        }
        parts.push(p);
    }
    let links = LinkSolids::from_parts(parts).expect("link solids");
    let poses = |name: &str| -> Vec<Option<Isometry3<f64>>> {
        let frames = doc["configurations"][name]["link_frames"]
            .as_array()
            .expect("frames");
        links
            .links
            .iter()
            .zip(frames)
            .map(|(l, f)| {
                l.as_ref()
                    .map(|l| pose_from_json(f, "frame").expect("frame") * l.offset)
            })
            .collect()
    };
    let (contact, clear) = (poses("contact"), poses("clear"));
    Workload {
        links,
        scene,
        contact,
        clear,
    }
}

fn station(c: &mut Criterion) {
    let w = load();
    let mut boolean = CollisionSettings {
        self_collision: false,
        ..CollisionSettings::default()
    };
    let mut depth = boolean;
    boolean.depth = None; // depth
    depth.depth = Some(Default::default()); // depth
    let mut g = c.benchmark_group("station_check");
    for (name, lp, expect_clear) in [("contact", &w.contact, false), ("clear", &w.clear, true)] {
        for (variant, s) in [("boolean", &boolean), ("depth", &depth)] {
            let r = check_links(&w.links, lp, &w.scene, s);
            assert_eq!(
                matches!(r, CheckResult::Clear),
                expect_clear,
                "{name}/{variant}: {r:?}"
            );
            g.bench_function(format!("{name}/{variant}"), |b| {
                b.iter(|| black_box(check_links(&w.links, black_box(lp), &w.scene, s)))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, station);
criterion_main!(benches);
