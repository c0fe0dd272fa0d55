//! Export and import without a session: glTF read back with the `gltf` crate, STL in world
//! coordinates, STL/OBJ import, the trajectory CSV.

use robosim_file_io::import::{import_tx, mesh_geometry, parse_at, read_mesh};
use robosim_file_io::stl::{read_stl, to_stl};
use robosim_file_io::{SavedModel, scene_model};
use robosim_instance_space::{Kind, Store};
use std::path::Path;

fn fan_triangles(m: &SavedModel, i: usize) -> usize {
    m.objects[i]
        .geometry
        .as_ref()
        .map_or(0, |g| g.polygons.iter().map(|p| p.len() - 2).sum())
}

#[test]
fn space_station_gltf_has_a_node_per_object_and_the_instance_space_triangles() {
    let m = scene_model("space_station", &[]).expect("station");
    let (glb, stats) = robosim_file_io::gltf::to_glb(&m).expect("valid model");
    let g = gltf::Gltf::from_slice(&glb).expect("the gltf crate reads our .glb");
    let blob = g.blob.as_deref().expect("a BIN chunk");
    let order = m.plan().expect("valid");
    assert_eq!(g.nodes().count(), m.objects.len(), "one node per object");
    let bodies: Vec<usize> = (0..m.objects.len())
        .filter(|&i| m.objects[i].geometry.is_some())
        .collect();
    assert_eq!(g.meshes().count(), bodies.len(), "one mesh per body");
    assert!(bodies.len() > 20);
    // Every node with a mesh: its name, triangle count and colour are the object's.
    let mut seen = 0;
    let mut total = 0;
    for node in g.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        // Nodes are written in creation order (parents first), names need not be unique.
        let i = order[node.index()];
        assert_eq!(node.name(), Some(m.objects[i].name.as_str()));
        let prim = mesh.primitives().next().expect("one primitive");
        let reader = prim.reader(|_| Some(blob));
        let tris = reader.read_indices().expect("indices").into_u32().count() / 3;
        assert_eq!(tris, fan_triangles(&m, i), "{}", m.objects[i].name);
        total += tris;
        let colour = prim.material().pbr_metallic_roughness().base_color_factor();
        assert_eq!(colour, m.objects[i].appearance.color);
        assert!(reader.read_positions().expect("positions").count() >= 3);
        seen += 1;
    }
    assert_eq!(seen, bodies.len());
    assert_eq!(total, stats.triangles);
    let expected: usize = (0..m.objects.len()).map(|i| fan_triangles(&m, i)).sum();
    assert_eq!(
        total, expected,
        "triangles = the Instance Space's polygons fanned"
    );
    // The hierarchy: the scene is the only root, and every other node is someone's child.
    let roots: Vec<_> = g.scenes().next().expect("a scene").nodes().collect();
    assert_eq!(roots.len(), 1);
    let children: usize = g.nodes().map(|n| n.children().count()).sum();
    assert_eq!(children + roots.len(), m.objects.len());
}

#[test]
fn stl_export_is_in_world_coordinates_and_reads_back() {
    // The built-in demo: the table-top (0.6 × 0.6 × 0.1 box) sits under the table item at
    // x = 0.8, z = −0.05.
    let m = scene_model("demo", &[]).expect("demo");
    let table = m.objects.iter().find(|o| o.name == "table").expect("table");
    let (bytes, n) = to_stl(&m, Some(&[table.id]), "table").expect("valid");
    assert_eq!(n, 12, "a box: 6 quads, 12 triangles");
    assert_eq!(bytes.len(), 84 + 50 * 12);
    assert!(!bytes.starts_with(b"solid"));
    let tris = read_stl(&bytes, Path::new("t.stl")).expect("reads back");
    let range = |c: usize| {
        let v = tris.iter().flatten().map(|p| p[c]);
        (
            v.clone().fold(f64::MAX, f64::min),
            v.fold(f64::MIN, f64::max),
        )
    };
    let (x, z) = (range(0), range(2));
    assert!(
        (x.0 - 0.5).abs() < 1e-6 && (x.1 - 1.1).abs() < 1e-6,
        "{x:?}"
    );
    assert!((z.0 + 0.1).abs() < 1e-6 && z.1.abs() < 1e-6, "{z:?}");
    let (_, all) = to_stl(&m, None, "demo").expect("valid");
    assert_eq!(all, 36, "table and two link bodies");
}

const CUBE_OBJ: &str = "# unit cube, quads\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

#[test]
fn obj_and_ascii_stl_meshes_become_one_valid_item_transaction() {
    let dir = tempfile::tempdir().expect("tmp");
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, CUBE_OBJ).expect("write");
    let tris = read_mesh(&obj, 0.5).expect("obj reads");
    assert_eq!(tris.len(), 12);
    let g = mesh_geometry(&tris, false, &obj).expect("geometry");
    assert_eq!(g.geometry.vertices.len(), 8, "identical vertices welded");
    assert_eq!(g.dropped, 0);
    // ASCII STL of the same cube, with one degenerate facet added.
    let mut stl = String::from("solid cube\n");
    let facet = |t: &[[f64; 3]; 3]| {
        let mut s = String::from(" facet normal 0 0 0\n  outer loop\n");
        for v in t {
            s += &format!("   vertex {} {} {}\n", v[0], v[1], v[2]);
        }
        s + "  endloop\n endfacet\n"
    };
    for t in &tris {
        stl += &facet(t);
    }
    stl += &facet(&[[0.0; 3], [0.0; 3], [0.5, 0.0, 0.0]]);
    stl += "endsolid cube\n";
    let p = dir.path().join("cube.stl");
    std::fs::write(&p, &stl).expect("write");
    let st = read_mesh(&p, 1.0).expect("ascii stl reads");
    let g2 = mesh_geometry(&st, false, &p).expect("geometry");
    assert_eq!(g2.dropped, 1, "the zero-area facet is dropped");
    assert_eq!(g2.geometry, g.geometry);
    // Into a store: one transaction, an item at the given place with the solid under it.
    let mut store = Store::new();
    let mut tx = robosim_instance_space::Transaction::new();
    tx.create(Kind::Scene, "cell", None);
    store.apply(&tx).expect("scene");
    let place = robosim_file_io::import::Placement {
        name: "fixture".into(),
        pose: parse_at("1,2,3,0,0,90").expect("at"),
        parent: Some(1),
        appearance: Default::default(),
    };
    let a = store
        .apply(&import_tx(&g.geometry, &place))
        .expect("valid import");
    assert_eq!(a.created.len(), 2);
    let item = store.get(a.created[0]).expect("item");
    assert_eq!(item.kind, Kind::Item);
    assert!(
        (item.pose[3] - 1.0).abs() < 1e-12 && (item.pose[1] + 1.0).abs() < 1e-12,
        "yaw 90°: x axis → y"
    );
    // The hull of an L-shaped (non-convex) mesh is convex: every vertex behind every face.
    let l = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 1\nv 2 0 1\nv 2 1 1\nv 1 1 1\nv 1 2 1\nv 0 2 1\nf 1 6 5 4 3 2\nf 7 8 9 10 11 12\nf 1 2 8 7\nf 2 3 9 8\nf 3 4 10 9\nf 4 5 11 10\nf 5 6 12 11\nf 6 1 7 12\n";
    let lp = dir.path().join("l.obj");
    std::fs::write(&lp, l).expect("write");
    let lt = read_mesh(&lp, 1.0).expect("l reads");
    let hull = mesh_geometry(&lt, true, &lp).expect("hull");
    let verts: Vec<nalgebra::Point3<f64>> = hull
        .geometry
        .vertices
        .iter()
        .map(|v| nalgebra::Point3::new(v[0], v[1], v[2]))
        .collect();
    let poly = robosim_geometry::Polyhedron::from_polygons(verts.clone(), &hull.geometry.polygons)
        .expect("valid");
    assert!(
        poly.polygons
            .iter()
            .all(|p| verts.iter().all(|v| p.plane.signed_distance(v) <= 1e-9))
    );
    assert!(
        !verts
            .iter()
            .any(|v| (v.x - 1.0).abs() < 1e-12 && (v.y - 1.0).abs() < 1e-12),
        "the inner corner is gone"
    );
}

#[test]
fn bad_meshes_name_the_line() {
    let dir = tempfile::tempdir().expect("tmp");
    let cases = [
        ("a.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", ":3:"),
        ("b.obj", "v 0 0 zero\n", ":1:"),
        (
            "c.stl",
            "solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n  endloop\n endfacet\nendsolid\n",
            ":2:",
        ),
        ("d.stl", "this is not an STL file at all", ":1:"),
        ("e.ply", "ply\n", "reads .stl and .obj"),
    ];
    for (name, text, want) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, text).expect("write");
        let e = read_mesh(&p, 1.0)
            .err()
            .unwrap_or_else(|| panic!("{name} accepted"));
        assert!(e.to_string().contains(want), "{name}: {e}");
    }
    let p = dir.path().join("f.obj");
    std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").expect("write");
    let t = read_mesh(&p, 1.0).expect("reads");
    assert!(
        mesh_geometry(&t, false, &p).is_err(),
        "only a zero-area triangle"
    );
}

#[test]
fn trajectory_csv_has_units_and_reads_both_log_headers() {
    let cols = vec!["shoulder_rad".to_string(), "slide_m".to_string()];
    let p = Path::new("log.csv");
    let old = "t,q1,q2,qd1,qd2\n0.01,0.1,0.2,1,2\n0.02,0.3,0.4,1,2\n";
    let new = "t_s,q1_rad,q2_m,qd1_rad_s,qd2_m_s\n0.01,0.1,0.2,1,2\n0.02,0.3,0.4,1,2\n";
    let want = "t_s,shoulder_rad,slide_m\n0.01,0.1,0.2\n0.02,0.3,0.4\n";
    assert_eq!(
        robosim_file_io::trajectory::convert(old, &cols, None, p).expect("old"),
        want
    );
    assert_eq!(
        robosim_file_io::trajectory::convert(new, &cols, None, p).expect("new"),
        want
    );
    let no_t = "q1,q2\n0.1,0.2\n0.3,0.4\n";
    assert!(robosim_file_io::trajectory::convert(no_t, &cols, None, p).is_err());
    assert_eq!(
        robosim_file_io::trajectory::convert(no_t, &cols, Some(0.01), p).expect("dt"),
        want
    );
    let e = robosim_file_io::trajectory::convert("t,q1,q2\n0.1,x,0\n", &cols, None, p)
        .expect_err("bad cell");
    assert!(e.to_string().contains("log.csv:2"), "{e}");
}
