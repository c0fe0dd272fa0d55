//! Writes the robot-versus-scene workload of issue 37 item 2 as data, so that robosim's
//! criterion bench (`core/collision/benches/station_check.rs`) and coal
//! (`tools/peers/station_check_coal.py`) check the same shapes at the same poses:
//!
//! the standard library's `space_station` scene (default parameters); the servicer (rail + five
//! revolute joints, 6 DOF) is the robot, every other solid part — the fixed structure and the
//! other robots' parts at their scene q — is an object of the scene. Two configurations of the
//! servicer, found by a seeded search over its joint limits: `contact` (in contact with the
//! structure, exact mode) and `clear` (no contact, with the most link-box × object-box overlaps
//! the search met, so the narrow phase has work).
//!
//! Shapes are written in the query protocol's shape form (box, cylinder, cone, sphere; other
//! library primitives as `mesh` from their polyhedra, as `studies::common::collision_solid`
//! builds them), poses as row-major 4×4 matrices.
//!
//! `cargo run --release -p robosim-report --example station_check_export -- testdata/collision/station_check.json`

use nalgebra::Matrix4;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_collision::json::solid_from_json;
use robosim_collision::robot::{
    CheckResult, CollisionSettings, LinkSolids, Scene, check_links, isometry_from_matrix,
};
use robosim_kinematics::fk;
use robosim_library::{Evaluated, Params, PlacedSolid, Primitive};
use serde_json::{Value, json};
use std::sync::Arc;

fn shape_json(p: &PlacedSolid) -> Value {
    match &p.primitive {
        Primitive::Box { size } => json!({"shape": "box", "size": size}),
        Primitive::Cylinder {
            radius,
            height,
            facets,
        } => json!({"shape": "cylinder", "radius": radius, "height": height, "facets": facets}),
        Primitive::Cone {
            radius,
            height,
            facets,
        } => json!({"shape": "cone", "radius": radius, "height": height, "facets": facets}),
        Primitive::Sphere { radius, facets } => {
            json!({"shape": "sphere", "radius": radius, "facets": facets})
        }
        _ => {
            let poly = &p.polyhedron;
            let polygons: Vec<Vec<u32>> = (0..poly.polygons.len())
                .map(|i| poly.polygon_indices(i).to_vec())
                .collect();
            let vertices: Vec<[f64; 3]> = poly.vertices.iter().map(|v| [v.x, v.y, v.z]).collect();
            json!({"shape": "mesh", "vertices": vertices, "polygons": polygons})
        }
    }
}

fn matrix_json(m: &Matrix4<f64>) -> Value {
    json!(
        (0..4)
            .map(|r| (0..4).map(|c| m[(r, c)]).collect::<Vec<f64>>())
            .collect::<Vec<_>>()
    )
}

fn with_pose(mut shape: Value, key: &str, value: Value) -> Value {
    if let Some(o) = shape.as_object_mut() {
        o.insert(key.into(), value);
    }
    shape
}

fn main() -> Result<(), String> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "testdata/collision/station_check.json".into());
    let lib = robosim_library::standard_library().ok_or("the standard library failed to load")?;
    let scene = match lib.evaluate("space_station", &Params::new()) {
        Ok(Evaluated::Scene(s)) => s,
        Ok(_) => return Err("space_station is not a scene".into()),
        Err(e) => return Err(format!("space_station: {e}")),
    };
    let servicer = scene
        .robots
        .iter()
        .find(|r| r.name == "servicer")
        .ok_or("no robot named servicer")?;
    // The objects: every fixed part, and every other robot's parts at its scene q.
    let mut objects = Vec::new();
    for it in &scene.solids {
        for s in &it.solid.parts {
            let pose = it.placement * s.transform;
            objects.push(with_pose(
                with_pose(
                    shape_json(s),
                    "name",
                    json!(format!("{}/{}", it.name, s.name)),
                ),
                "pose",
                matrix_json(&pose),
            ));
        }
    }
    for r in scene.robots.iter().filter(|r| r.name != "servicer") {
        let frames = fk::link_frames(&r.model.robot, &r.q);
        for (link, solids) in r.model.frames.iter().enumerate() {
            for s in solids {
                let pose = frames[link] * s.transform;
                objects.push(with_pose(
                    with_pose(
                        shape_json(s),
                        "name",
                        json!(format!("{}/{}", r.name, s.name)),
                    ),
                    "pose",
                    matrix_json(&pose),
                ));
            }
        }
    }
    let mut sc = Scene::new();
    for (i, o) in objects.iter().enumerate() {
        let solid = solid_from_json(o, &format!("objects[{i}]"), &["name", "pose"])
            .map_err(|e| e.to_string())?;
        let pose = robosim_collision::json::pose_from_json(&o["pose"], "pose")
            .map_err(|e| e.to_string())?;
        sc.add(o["name"].as_str().unwrap_or("?"), Arc::new(solid), pose);
    }
    // The servicer's links: parts in each link frame.
    let robot = &servicer.model.robot;
    let mut link_json = Vec::new();
    let mut parts = Vec::new();
    for solids in &servicer.model.frames {
        let mut lj = Vec::new();
        let mut lp = Vec::new();
        for s in solids {
            let shape = shape_json(s);
            let solid = solid_from_json(&shape, "link part", &[]).map_err(|e| e.to_string())?;
            lp.push((isometry_from_matrix(&s.transform), solid));
            lj.push(with_pose(shape, "pose", matrix_json(&s.transform)));
        }
        parts.push(lp);
        link_json.push(Value::Array(lj));
    }
    let links = LinkSolids::from_parts(parts).map_err(|e| e.to_string())?;
    let settings = CollisionSettings {
        self_collision: false,
        ..CollisionSettings::default()
    };
    // Seeded search: the contact with the most box overlaps, and the clear q likewise.
    let mut rng = ChaCha8Rng::seed_from_u64(37);
    let (mut best_contact, mut best_clear): (Option<(usize, Vec<f64>)>, Option<(usize, Vec<f64>)>) =
        (None, None);
    for _ in 0..4000 {
        let q: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| rng.random_range(j.qlim[0]..=j.qlim[1]))
            .collect();
        let lp = robosim_collision::robot::link_poses(robot, &links, &q);
        let overlaps = overlap_count(&links, &lp, &sc);
        let slot = match check_links(&links, &lp, &sc, &settings) {
            CheckResult::Clear => &mut best_clear,
            CheckResult::Contact(_) => &mut best_contact,
            CheckResult::Unknown { .. } => continue,
        };
        if slot.as_ref().is_none_or(|(n, _)| overlaps > *n) {
            *slot = Some((overlaps, q));
        }
    }
    let (nc, qc) = best_contact.ok_or("no contact configuration found")?;
    let (nf, qf) = best_clear.ok_or("no clear configuration found")?;
    let frames =
        |q: &[f64]| -> Vec<Value> { fk::link_frames(robot, q).iter().map(matrix_json).collect() };
    let doc = json!({
        "about": "issue 37 item 2 workload: the servicer of the standard library's space_station (default parameters) against every other part of the scene. Written by report/examples/station_check_export.rs.",
        "robot": servicer.name,
        "dof": robot.dof(),
        "links": link_json,
        "objects": objects,
        "configurations": {
            "contact": {"q": qc, "link_frames": frames(&qc), "box_overlaps": nc},
            "clear": {"q": qf, "link_frames": frames(&qf), "box_overlaps": nf},
        },
    });
    let text = serde_json::to_string(&doc).map_err(|e| e.to_string())?;
    std::fs::write(&out, text).map_err(|e| format!("{out}: {e}"))?;
    println!(
        "{out}: {} objects, {} links; contact q with {nc} link×object box overlaps, clear q with {nf}",
        objects.len(),
        links.links.len()
    );
    Ok(())
}

/// Link-box × object-box overlaps at link poses `lp` (the narrow-phase work of a check).
fn overlap_count(links: &LinkSolids, lp: &[Option<nalgebra::Isometry3<f64>>], sc: &Scene) -> usize {
    let mut n = 0;
    for (l, p) in links.links.iter().zip(lp) {
        let (Some(l), Some(p)) = (l, p) else { continue };
        let b = robosim_collision::bbox::world_box(&l.solid.bbox, p);
        n += sc
            .objects()
            .iter()
            .filter(|o| o.in_use && o.world_box().overlaps(&b))
            .count();
    }
    n
}
