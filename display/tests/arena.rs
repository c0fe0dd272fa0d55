//! The shared mesh buffers (display/src/arena.rs) under churn: bodies added, removed and
//! re-added with meshes of different sizes, geometry replaced by a larger mesh, buffers grown,
//! split into several pages and compacted. After each step the renderer that lived through
//! the churn must draw what a fresh renderer of the same model draws, and no two bodies may
//! share a vertex range. A wrong offset, a range freed twice or a compaction that loses track
//! of a body shows up as a body drawn with another's mesh, with garbage, or not at all.

use nalgebra::Point3;
use robosim_display::{Camera, Renderer, RgbaImage, Tolerance, compare};
use robosim_instance_space::{
    Appearance, GeometryInput, IDENTITY, Id, Kind, Snapshot, Store, Transaction,
};

const W: u32 = 240;
const H: u32 = 180;
const SIDE: usize = 12;

fn at(x: f64, y: f64) -> [f64; 12] {
    let mut p = IDENTITY;
    p[3] = x;
    p[7] = y;
    p
}

/// Shape `k`: boxes and spheres of several sizes and facet counts (6 to several hundred
/// triangles), so ranges of many lengths come and go.
fn shape(k: usize) -> GeometryInput {
    let p = match k % 4 {
        0 => robosim_geometry::shapes::cuboid(0.5, 0.3 + 0.05 * (k % 5) as f64, 0.4),
        1 => robosim_geometry::shapes::sphere(0.3, Some(6 + 2 * (k % 7))),
        2 => robosim_geometry::shapes::cuboid(0.2, 0.6, 0.2),
        _ => robosim_geometry::shapes::sphere(0.25, Some(16 + 4 * (k % 3))),
    }
    .expect("valid shape");
    GeometryInput::from_polyhedron(&p)
}

/// A colour per grid cell: a body drawn with another's transform or mesh lands in the wrong
/// place or with the wrong outline.
fn colour(cell: usize) -> [f32; 4] {
    let h = cell as f32 * 0.618_034;
    let f = |o: f32| 0.15 + 0.8 * (((h + o).fract() * 6.0 - 3.0).abs() - 1.0).clamp(0.0, 1.0);
    [f(0.0), f(1.0 / 3.0), f(2.0 / 3.0), 1.0]
}

/// The grid cell `cell` holds a body of shape `k`.
fn create(model: &mut Store, cell: usize, k: usize) -> Id {
    let mut tx = Transaction::new();
    let id = tx.create(Kind::Solid, &format!("b{cell}_{k}"), None);
    tx.set_geometry(id, Some(shape(k)));
    tx.set_pose(id, at((cell % SIDE) as f64, (cell / SIDE) as f64));
    tx.set_appearance(
        id,
        Appearance {
            color: colour(cell),
            ..Appearance::default()
        },
    );
    model.apply(&tx).expect("valid").created[0]
}

fn camera() -> Camera {
    let c = (SIDE as f64 - 1.0) / 2.0;
    Camera::looking(Point3::new(c - 4.0, c - 9.0, 10.0), Point3::new(c, c, 0.0))
}

fn fresh_image(model: &Store) -> RgbaImage {
    let mut r = Renderer::headless().expect("a Vulkan adapter (mesa-vulkan-drivers on CI)");
    r.sync(&Snapshot::from_store(model));
    r.camera = camera();
    r.style.edges = true;
    r.render_image(W, H).expect("frame")
}

/// No two bodies' triangle ranges overlap, on any page.
fn ranges_disjoint(r: &Renderer, step: &str) {
    let ranges = r.mesh_ranges();
    for w in ranges.windows(2) {
        let (a, b) = (w[0], w[1]);
        assert!(
            a.1 != b.1 || a.2 + a.3 <= b.2,
            "{step}: bodies {} and {} overlap on page {}: {}+{} and {}+{}",
            a.0,
            b.0,
            a.1,
            a.2,
            a.3,
            b.2,
            b.3
        );
    }
}

fn same_as_fresh(r: &mut Renderer, model: &Store, step: &str) {
    ranges_disjoint(r, step);
    r.camera = camera();
    r.style.edges = true;
    let img = r.render_image(W, H).expect("frame");
    let fresh = fresh_image(model);
    // Same model, same camera, same device: the same pixels, up to the order of draws where
    // two bodies' edges meet.
    let tol = Tolerance {
        channel: 24,
        fraction: 0.0005,
    };
    let d = compare(&img, &fresh, &tol).expect("same size");
    assert!(
        d.within(&tol),
        "{step}: the churned renderer draws something else than a fresh one: {d:?}"
    );
}

fn churn(r: &mut Renderer) {
    let mut model = Store::new();
    let mut cells: Vec<Option<Id>> = (0..SIDE * SIDE)
        .map(|cell| Some(create(&mut model, cell, cell)))
        .collect();
    r.sync(&Snapshot::from_store(&model));
    same_as_fresh(r, &model, "all created");
    // Remove every third body, then fill the holes with bodies of other shapes (other
    // sizes: some fit the freed ranges, some do not).
    let mut tx = Transaction::new();
    for id in cells.iter_mut().step_by(3).filter_map(Option::take) {
        tx.delete(id, false);
    }
    model.apply(&tx).expect("valid");
    r.sync(&Snapshot::from_store(&model));
    same_as_fresh(r, &model, "every third removed");
    for (cell, c) in cells.iter_mut().enumerate() {
        if c.is_none() {
            *c = Some(create(&mut model, cell, cell + 1));
        }
    }
    r.sync(&Snapshot::from_store(&model));
    same_as_fresh(r, &model, "re-added with other shapes");
    // Replace geometry: boxes (12 triangles) become fine spheres (hundreds), which cannot go
    // back into their old ranges.
    let bigger = robosim_geometry::shapes::sphere(0.35, Some(24)).expect("valid");
    let mut tx = Transaction::new();
    for id in cells.iter().step_by(5).flatten() {
        tx.set_geometry(*id, Some(GeometryInput::from_polyhedron(&bigger)));
    }
    model.apply(&tx).expect("valid");
    r.sync(&Snapshot::from_store(&model));
    same_as_fresh(r, &model, "geometry replaced by larger meshes");
    // Remove most bodies (many holes: the buffers compact), move one, add a few back.
    let mut tx = Transaction::new();
    for (_, c) in cells.iter_mut().enumerate().filter(|(i, _)| i % 7 != 0) {
        if let Some(id) = c.take() {
            tx.delete(id, false);
        }
    }
    model.apply(&tx).expect("valid");
    r.sync(&Snapshot::from_store(&model));
    same_as_fresh(r, &model, "most removed");
    let first = cells.iter().flatten().next().copied().expect("one left");
    let mut tx = Transaction::new();
    tx.set_pose(first, at(-1.0, -1.0));
    model.apply(&tx).expect("valid");
    for (cell, c) in cells.iter_mut().enumerate().filter(|(i, _)| i % 4 == 1) {
        if c.is_none() {
            *c = Some(create(&mut model, cell, cell + 2));
        }
    }
    r.sync(&Snapshot::from_store(&model));
    same_as_fresh(r, &model, "moved and some re-added");
}

#[test]
fn bodies_added_removed_and_reshaped_draw_as_a_fresh_renderer_draws() {
    if robosim_display::skipped_without_vulkan(
        "bodies_added_removed_and_reshaped_draw_as_a_fresh_renderer_draws",
    ) {
        return;
    }
    let mut r = Renderer::headless().expect("adapter");
    churn(&mut r);
    let total = r.total_upload();
    assert!(total.regrowths > 0, "the shared buffers grew: {total:?}");
    assert!(
        total.compactions > 0,
        "removing most bodies compacts: {total:?}"
    );
    let (tri_buffers, _, draws) = r.mesh_buffers();
    assert_eq!(tri_buffers, 1, "one triangle buffer holds this scene");
    assert!(draws >= 1);
}

/// The same churn with every shared buffer capped at 64 KiB (2,340 triangle vertices, more
/// than the largest mesh here, which a buffer must hold whole): meshes are
/// spread over many pages, and a page that cannot grow gets a neighbour.
#[test]
fn meshes_spread_over_many_small_buffers_draw_the_same() {
    if robosim_display::skipped_without_vulkan(
        "meshes_spread_over_many_small_buffers_draw_the_same",
    ) {
        return;
    }
    let mut r = Renderer::headless().expect("adapter");
    r.set_mesh_buffer_limit(64 << 10);
    churn(&mut r);
    let (tri_buffers, edge_buffers, _) = r.mesh_buffers();
    assert!(
        tri_buffers > 3 && edge_buffers > 1,
        "{tri_buffers} triangle and {edge_buffers} edge buffers"
    );
}

/// A pose update touches one 64-byte transform whatever the number of bodies, and the
/// number of shared buffers and draws does not follow the number of bodies.
#[test]
fn the_number_of_buffers_and_draws_does_not_follow_the_bodies() {
    if robosim_display::skipped_without_vulkan(
        "the_number_of_buffers_and_draws_does_not_follow_the_bodies",
    ) {
        return;
    }
    let mut model = Store::new();
    let mut ids = Vec::new();
    for cell in 0..SIDE * SIDE {
        ids.push(create(&mut model, cell, 0));
    }
    let mut r = Renderer::headless().expect("adapter");
    r.sync(&Snapshot::from_store(&model));
    let (t, e, draws) = r.mesh_buffers();
    assert_eq!(
        (t, e, draws),
        (1, 1, 1),
        "all bodies in one run of one buffer"
    );
    let mut tx = Transaction::new();
    tx.set_pose(ids[7], at(0.5, -2.0));
    model.apply(&tx).expect("valid");
    let up = r.sync(&Snapshot::from_store(&model));
    assert_eq!(
        (up.transforms, up.transform_bytes, up.meshes),
        (1, 64, 0),
        "{up:?}"
    );
    same_as_fresh(&mut r, &model, "one moved");
}
