//! Mass properties of extruded and revolved solids against trimesh (an established mesh
//! library), data in testdata/library/mass_reference.json (see the README there).

use nalgebra::Point2;
use robosim_geometry::shapes;
use serde_json::Value;

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

#[test]
fn extrusions_and_revolutions_match_trimesh() {
    let data: Value = serde_json::from_str(include_str!(
        "../../../testdata/library/mass_reference.json"
    ))
    .expect("json");
    let cases = data["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), 6);
    for c in cases {
        let name = c["name"].as_str().expect("name");
        let pts: Vec<Point2<f64>> = c["points"]
            .as_array()
            .expect("points")
            .iter()
            .map(|p| Point2::new(f(&p[0]), f(&p[1])))
            .collect();
        let solid = match c["kind"].as_str() {
            Some("revolve") => shapes::revolve(
                &pts,
                std::f64::consts::TAU,
                Some(c["facets"].as_u64().expect("facets") as usize),
            ),
            _ => shapes::extrude(&pts, f(&c["height"])),
        }
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let m = solid.mass_properties(1.0).expect("closed");
        let v = f(&c["volume"]);
        assert!(
            (m.volume - v).abs() < 1e-12 * v,
            "{name}: volume {} vs {v}",
            m.volume
        );
        for k in 0..3 {
            let com = f(&c["com_rel_bbox"][k]);
            assert!(
                (m.center_of_mass[k] - com).abs() < 1e-11 * v.cbrt().max(1.0),
                "{name}: com[{k}] {} vs {com}",
                m.center_of_mass[k]
            );
            for l in 0..3 {
                let i = f(&c["inertia"][k][l]);
                let scale = f(&c["inertia"][0][0])
                    .abs()
                    .max(f(&c["inertia"][2][2]).abs());
                assert!(
                    (m.inertia[(k, l)] - i).abs() < 1e-10 * scale,
                    "{name}: I[{k}{l}] {} vs {i}",
                    m.inertia[(k, l)]
                );
            }
        }
    }
}
