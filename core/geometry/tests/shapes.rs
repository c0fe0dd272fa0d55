//! Golden tests for the shape generators and their mass properties against closed forms
//! (vertex/face counts, volume within the declared chord-error bound, outward normals, convex
//! planar faces, Euler characteristic), plus proptest properties.

use nalgebra::{Matrix3, Point2, Point3, Vector3};
use proptest::prelude::*;
use robosim_geometry::polygon2d::{PolygonError, convex_decomposition, is_convex, signed_area};
use robosim_geometry::shapes::{
    self, DEFAULT_CHORD_TOL, ShapeError, chord_error, default_facets, volume_error_bound,
};
use robosim_geometry::{MassError, Polyhedron};
use std::f64::consts::PI;

/// Closed, Euler characteristic 2, every face's plane has the solid's centroid on its inner
/// side (outward normals; all our test solids are star-shaped about the centroid), and the
/// bounding box is centred on the origin.
fn assert_valid_closed(p: &Polyhedron) {
    assert!(p.is_closed(), "not closed");
    assert_eq!(p.euler_characteristic(), 2);
    let mp = p
        .mass_properties(1.0)
        .expect("closed solid has mass properties");
    for (i, poly) in p.polygons.iter().enumerate() {
        assert!(
            poly.plane.signed_distance(&mp.center_of_mass) < 0.0,
            "face {i} points inward"
        );
        // convex planar: Polyhedron::from_polygons validated it; re-check planarity explicitly
        for &k in p.polygon_indices(i) {
            assert!(poly.plane.signed_distance(&p.vertices[k as usize]).abs() < 1e-9);
        }
    }
    assert!(
        p.bbox.center.coords.norm() < 1e-12,
        "bbox centre {:?}",
        p.bbox.center
    );
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

#[test]
fn box_golden() {
    let p = shapes::cuboid(1.0, 2.0, 3.0).expect("box");
    assert_eq!(
        (p.vertices.len(), p.polygons.len(), p.edges.len()),
        (8, 6, 12)
    );
    assert_valid_closed(&p);
    let m = p.mass_properties(2.0).expect("mass");
    assert!(close(m.volume, 6.0, 1e-14));
    assert!(close(m.mass, 12.0, 1e-14));
    assert!(m.center_of_mass.coords.norm() < 1e-14);
    let exact =
        Matrix3::from_diagonal(&Vector3::new(4.0 + 9.0, 1.0 + 9.0, 1.0 + 4.0)) * (12.0 / 12.0);
    assert!((m.inertia - exact).abs().max() < 1e-12, "{}", m.inertia);
    assert_eq!(p.bbox.half, Vector3::new(0.5, 1.0, 1.5));
}

#[test]
fn cylinder_golden_counts_bound_and_exact_prism_inertia() {
    let (r, h) = (0.3, 0.8);
    let n = default_facets(r, DEFAULT_CHORD_TOL);
    assert_eq!(n % 4, 0);
    assert!(chord_error(r, n) <= DEFAULT_CHORD_TOL);
    assert!(chord_error(r, n - 4) > DEFAULT_CHORD_TOL || n - 4 < shapes::MIN_FACETS);
    let p = shapes::cylinder(r, h, None).expect("cylinder");
    assert_eq!(
        (p.vertices.len(), p.polygons.len(), p.edges.len()),
        (2 * n, n + 2, 3 * n)
    );
    assert_valid_closed(&p);
    assert_eq!(p.bbox.half, Vector3::new(r, r, h / 2.0));
    let m = p.mass_properties(1.0).expect("mass");
    let exact = PI * r * r * h;
    assert!(m.volume <= exact && m.volume >= exact * (1.0 - volume_error_bound(false, n)));
    // The faceted cylinder is exactly a regular n-gon prism: closed forms for that.
    let nf = n as f64;
    let area = 0.5 * nf * r * r * (2.0 * PI / nf).sin();
    assert!(close(m.volume, area * h, 1e-12));
    let k = (1.0 + 2.0 * (PI / nf).cos().powi(2)) / 6.0 * r * r; // polar moment per area
    let izz = m.volume * k;
    let ixx = m.volume * (k / 2.0 + h * h / 12.0);
    assert!(
        close(m.inertia[(2, 2)], izz, 1e-10),
        "{} vs {}",
        m.inertia[(2, 2)],
        izz
    );
    assert!(close(m.inertia[(0, 0)], ixx, 1e-10));
    assert!(close(m.inertia[(1, 1)], ixx, 1e-10));
    assert!(m.inertia[(0, 1)].abs() < 1e-12 && m.inertia[(0, 2)].abs() < 1e-12);
    // And the continuous closed forms within the chord-error bound
    let cont_zz = 0.5 * exact * r * r;
    assert!((m.inertia[(2, 2)] - cont_zz).abs() <= cont_zz * 2.0 * volume_error_bound(false, n));
}

#[test]
fn cone_golden_base_down_apex_up() {
    let (r, h) = (0.5, 1.2);
    let n = 40;
    let p = shapes::cone(r, h, Some(n)).expect("cone");
    assert_eq!(
        (p.vertices.len(), p.polygons.len(), p.edges.len()),
        (n + 1, n + 1, 2 * n)
    );
    assert_valid_closed(&p);
    let apex = p.vertices.iter().fold(f64::MIN, |m, v| m.max(v.z));
    assert!(close(apex, h / 2.0, 1e-14));
    // the base disc is one polygon at z = −h/2 facing −z
    assert!(
        p.polygons
            .iter()
            .any(|q| q.len == n as u32 && (q.plane.normal + Vector3::z()).norm() < 1e-12)
    );
    let m = p.mass_properties(1.0).expect("mass");
    let exact = PI * r * r * h / 3.0;
    assert!(m.volume <= exact && m.volume >= exact * (1.0 - volume_error_bound(false, n)));
    // centre of mass a quarter of the height above the base
    assert!(close(m.center_of_mass.z, -h / 2.0 + h / 4.0, 1e-12));
    let ezz = 0.3 * exact * r * r;
    assert!((m.inertia[(2, 2)] - ezz).abs() <= ezz * 2.0 * volume_error_bound(false, n));
    let exx = exact * (3.0 * r * r / 20.0 + 3.0 * h * h / 80.0);
    assert!((m.inertia[(0, 0)] - exx).abs() <= exx * 2.0 * volume_error_bound(false, n));
}

#[test]
fn truncated_cone_golden() {
    let (rb, rt, h) = (0.4, 0.2, 0.5);
    let p = shapes::truncated_cone(rb, rt, h, None).expect("frustum");
    let n = default_facets(rb, DEFAULT_CHORD_TOL);
    assert_eq!(
        (p.vertices.len(), p.polygons.len(), p.edges.len()),
        (2 * n, n + 2, 3 * n)
    );
    assert_valid_closed(&p);
    let m = p.mass_properties(1.0).expect("mass");
    let exact = PI * h / 3.0 * (rb * rb + rb * rt + rt * rt);
    assert!(m.volume <= exact && m.volume >= exact * (1.0 - volume_error_bound(false, n)));
    // centroid height above the base: h (R² + 2Rr + 3r²) / (4 (R² + Rr + r²))
    let zc = h * (rb * rb + 2.0 * rb * rt + 3.0 * rt * rt) / (4.0 * (rb * rb + rb * rt + rt * rt));
    assert!(close(m.center_of_mass.z, -h / 2.0 + zc, 1e-10));
    // The faceted frustum is exactly a regular n-gon frustum: scale the radii by the polygon's
    // area factor and the prism formula agrees.
    let nf = n as f64;
    let f = nf * (2.0 * PI / nf).sin() / (2.0 * PI);
    assert!(close(m.volume, exact * f, 1e-12));
    // upside-down cone via a zero bottom radius
    let q = shapes::truncated_cone(0.0, 0.3, 0.4, Some(12)).expect("inverted cone");
    assert_valid_closed(&q);
    assert!(q.mass_properties(1.0).expect("mass").center_of_mass.z > 0.0);
}

#[test]
fn sphere_golden_and_face_distance_bound() {
    let r = 0.25;
    let n = 16;
    let p = shapes::sphere(r, Some(n)).expect("sphere");
    assert_eq!(p.vertices.len(), n * (n / 2 - 1) + 2);
    assert_eq!(p.polygons.len(), n * n / 2);
    assert_valid_closed(&p);
    for v in &p.vertices {
        assert!(close(v.coords.norm(), r, 1e-14));
    }
    let c = (PI / n as f64).cos();
    let min_dist = p
        .polygons
        .iter()
        .map(|q| -q.plane.d)
        .fold(f64::MAX, f64::min);
    assert!(
        min_dist >= r * c * c - 1e-15,
        "face at {min_dist} < r cos²(π/n) = {}",
        r * c * c
    );
    let m = p.mass_properties(1.0).expect("mass");
    let exact = 4.0 / 3.0 * PI * r.powi(3);
    assert!(m.volume <= exact && m.volume >= exact * (1.0 - volume_error_bound(true, n)));
    let i_exact = 0.4 * exact * r * r;
    for k in 0..3 {
        assert!(
            (m.inertia[(k, k)] - i_exact).abs()
                <= i_exact * 5.0 / 3.0 * volume_error_bound(true, n)
        );
    }
    assert!(m.center_of_mass.coords.norm() < 1e-12);
    // default facet count, odd count
    assert_valid_closed(&shapes::sphere(2.0, None).expect("big sphere"));
    assert_valid_closed(&shapes::sphere(1.0, Some(9)).expect("odd sphere"));
}

#[test]
fn extruded_concave_polygon_golden() {
    // R2's table 1 "custom object" (seed §2.3): a pentagon extruded by 10 (cm).
    let pent: Vec<Point2<f64>> = [
        (-10.0, -10.0),
        (-10.0, 10.0),
        (15.0, 10.0),
        (25.0, 0.0),
        (15.0, -10.0),
    ]
    .iter()
    .map(|&(x, y)| Point2::new(x, y))
    .collect();
    let p = shapes::extrude(&pent, 10.0).expect("clockwise convex pentagon");
    assert_eq!((p.vertices.len(), p.polygons.len()), (10, 7));
    assert_valid_closed(&p);
    let m = p.mass_properties(1.0).expect("mass");
    assert!(close(m.volume, signed_area(&pent).abs() * 10.0, 1e-13));
    // A U shape: concave, split into convex pieces for both caps.
    let u: Vec<Point2<f64>> = [
        (0.0, 0.0),
        (3.0, 0.0),
        (3.0, 2.0),
        (2.0, 2.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 2.0),
    ]
    .iter()
    .map(|&(x, y)| Point2::new(x, y))
    .collect();
    let p = shapes::extrude(&u, 0.5).expect("U");
    assert_eq!(p.vertices.len(), 16);
    assert!(p.is_closed());
    assert_eq!(p.euler_characteristic(), 2);
    let m = p.mass_properties(1.0).expect("mass");
    assert!(close(m.volume, 5.0 * 0.5, 1e-13));
    // pieces: 3×1 centred at y = 0.5, two 1×1 at y = 1.5; the bounding box centre is y = 1
    let yc = (3.0 * 0.5 + 2.0 * 1.5) / 5.0 - 1.0;
    assert!(
        close(m.center_of_mass.y, yc, 1e-12),
        "{} vs {}",
        m.center_of_mass.y,
        yc
    );
    assert!(m.center_of_mass.x.abs() < 1e-12);
}

#[test]
fn revolved_profiles_golden() {
    // A washer (annulus revolved): rectangle ρ ∈ [1, 2], z ∈ [0, 1], full turn → torus of genus 1
    let rect: Vec<Point2<f64>> = [(1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0)]
        .iter()
        .map(|&(x, y)| Point2::new(x, y))
        .collect();
    let p = shapes::revolve(&rect, 2.0 * PI, Some(32)).expect("washer");
    assert!(p.is_closed());
    assert_eq!(p.euler_characteristic(), 0, "a washer has genus 1");
    let m = p.mass_properties(1.0).expect("mass");
    let exact = PI * (4.0 - 1.0) * 1.0;
    assert!(m.volume <= exact && m.volume >= exact * (1.0 - volume_error_bound(false, 32)));
    // half a turn of an L profile touching the axis: end caps split into convex pieces
    let l: Vec<Point2<f64>> = [
        (0.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 2.0),
    ]
    .iter()
    .map(|&(x, y)| Point2::new(x, y))
    .collect();
    let p = shapes::revolve(&l, PI, Some(24)).expect("half L");
    assert_valid_closed(&p);
    let m = p.mass_properties(1.0).expect("mass");
    let exact = 0.5 * (PI * 4.0 * 1.0 + PI * 1.0 * 1.0);
    assert!(m.volume <= exact && m.volume >= exact * (1.0 - volume_error_bound(false, 48)));
    // clockwise input is accepted (the seed demanded clockwise for revolve, counter-clockwise for extrude)
    let cw: Vec<Point2<f64>> = l.iter().rev().copied().collect();
    assert!(close(
        shapes::revolve(&cw, PI, Some(24))
            .expect("cw")
            .mass_properties(1.0)
            .expect("mass")
            .volume,
        m.volume,
        1e-12
    ));
}

#[test]
fn mass_properties_of_a_moved_solid_follow_the_motion() {
    let p = shapes::cuboid(0.2, 0.4, 1.0).expect("box");
    let iso = nalgebra::Isometry3::new(Vector3::new(5.0, -3.0, 2.0), Vector3::new(0.3, 0.5, -0.2));
    let moved = p.transformed(&iso).mass_properties(7.0).expect("mass");
    let carried = p.mass_properties(7.0).expect("mass").transformed(&iso);
    assert!((moved.center_of_mass - carried.center_of_mass).norm() < 1e-12);
    assert!((moved.inertia - carried.inertia).abs().max() < 1e-10);
}

#[test]
fn bad_parameters_are_refused_with_the_field_named() {
    assert_eq!(
        shapes::cuboid(1.0, -2.0, 1.0).expect_err("negative side"),
        ShapeError::NonPositive {
            shape: "box",
            field: "y",
            value: -2.0
        }
    );
    assert!(matches!(
        shapes::cylinder(f64::NAN, 1.0, None),
        Err(ShapeError::Negative {
            field: "bottom radius",
            ..
        })
    ));
    assert!(matches!(
        shapes::cone(1.0, 1.0, Some(2)),
        Err(ShapeError::FacetsOutOfRange { facets: 2, .. })
    ));
    assert!(matches!(
        shapes::sphere(1.0, Some(4096)),
        Err(ShapeError::FacetsOutOfRange { max: 1024, .. })
    ));
    assert!(matches!(
        shapes::truncated_cone(0.0, 0.0, 1.0, None),
        Err(ShapeError::NonPositive {
            field: "radius",
            ..
        })
    ));
    let bowtie: Vec<Point2<f64>> = [(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]
        .iter()
        .map(|&(x, y)| Point2::new(x, y))
        .collect();
    assert!(matches!(
        shapes::extrude(&bowtie, 1.0),
        Err(ShapeError::Profile {
            source: PolygonError::SelfIntersecting { .. },
            ..
        })
    ));
    let crossing: Vec<Point2<f64>> = [(-1.0, 0.0), (1.0, 0.0), (1.0, 1.0)]
        .iter()
        .map(|&(x, y)| Point2::new(x, y))
        .collect();
    assert!(matches!(
        shapes::revolve(&crossing, PI, None),
        Err(ShapeError::ProfileCrossesAxis { index: 0, .. })
    ));
    let pinch: Vec<Point2<f64>> = [(0.0, 0.0), (1.0, 0.5), (0.0, 1.0), (1.0, 1.5), (0.5, 0.75)]
        .iter()
        .map(|&(x, y)| Point2::new(x, y))
        .collect();
    assert!(shapes::revolve(&pinch, PI, None).is_err());
    assert!(matches!(
        shapes::revolve(&crossing[1..], 7.0, None),
        Err(ShapeError::AngleOutOfRange { .. })
    ));
}

#[test]
fn open_surfaces_have_no_mass_properties() {
    let v = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
    ];
    let tri = Polyhedron::from_polygons(v, &[vec![0, 1, 2]]).expect("one triangle");
    assert_eq!(
        tri.mass_properties(1.0).expect_err("open surface"),
        MassError::NotClosed
    );
    assert!(matches!(
        shapes::cuboid(1.0, 1.0, 1.0)
            .expect("box")
            .mass_properties(-1.0),
        Err(MassError::BadDensity { .. })
    ));
}

/// A random star-shaped (hence simple) polygon: sorted angles, random radii; usually concave.
fn star_polygon() -> impl Strategy<Value = Vec<Point2<f64>>> {
    (5usize..16).prop_flat_map(|n| {
        (
            prop::collection::vec(0.05f64..1.0, n),
            prop::collection::vec(0.2f64..1.0, n),
        )
            .prop_map(move |(gaps, radii)| {
                let total: f64 = gaps.iter().sum();
                let mut acc = 0.0;
                gaps.iter()
                    .zip(&radii)
                    .map(|(g, r)| {
                        acc += g / total * 2.0 * PI;
                        Point2::new(r * acc.cos(), r * acc.sin())
                    })
                    .collect()
            })
    })
}

// A fixed seed: the same cases on every run, so CI never meets a new random case (a random
// run failed CI once on a pose numeric IK cannot reach, core/kinematics/tests/properties.rs).
// Look for more by changing the seed or the case count.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 200,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x6E_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn concave_polygons_split_into_convex_pieces_of_equal_total_area(poly in star_polygon()) {
        match convex_decomposition(&poly) {
            Ok(pieces) => {
                let mut total = 0.0;
                for pc in &pieces {
                    let pts: Vec<Point2<f64>> = pc.iter().map(|&i| poly[i]).collect();
                    prop_assert!(is_convex(&pts));
                    let a = signed_area(&pts);
                    prop_assert!(a > 0.0);
                    total += a;
                }
                prop_assert!((total - signed_area(&poly).abs()).abs() < 1e-9);
                prop_assert!(pieces.len() <= poly.len() - 2);
            }
            // nearly collinear random triples are refused, never mis-split
            Err(PolygonError::Collinear { .. }) => {}
            Err(e) => prop_assert!(false, "unexpected {e}"),
        }
    }

    #[test]
    fn random_extrusions_are_valid_closed_solids(poly in star_polygon(), h in 0.01f64..3.0) {
        if let Ok(p) = shapes::extrude(&poly, h) {
            assert_valid_closed_any(&p)?;
            let m = p.mass_properties(1.0).expect("closed");
            prop_assert!((m.volume - signed_area(&poly).abs() * h).abs() < 1e-9 * m.volume.max(1.0));
        }
    }

    #[test]
    fn random_primitives_are_valid_closed_solids(
        a in 0.001f64..20.0, b in 0.001f64..20.0, c in 0.001f64..20.0, n in prop::option::of(3usize..64)
    ) {
        for p in [
            shapes::cuboid(a, b, c),
            shapes::cylinder(a, b, n),
            shapes::cone(a, b, n),
            shapes::truncated_cone(a, c, b, n),
            shapes::sphere(a, n.map(|k| k.max(4))),
        ] {
            let p = p.expect("parameters in range");
            assert_valid_closed_any(&p)?;
        }
    }

    #[test]
    fn random_revolutions_are_valid_closed_solids(poly in star_polygon(), turn in 0.1f64..1.0) {
        // shift the star into ρ > 0
        let prof: Vec<Point2<f64>> = poly.iter().map(|p| Point2::new(p.x + 1.5, p.y)).collect();
        if let Ok(p) = shapes::revolve(&prof, turn * 2.0 * PI, Some(12)) {
            prop_assert!(p.is_closed());
            let expect = if turn >= 1.0 { 0 } else { 2 };
            prop_assert_eq!(p.euler_characteristic(), expect);
            prop_assert!(p.mass_properties(1.0).is_ok());
        }
    }
}

fn assert_valid_closed_any(p: &Polyhedron) -> Result<(), TestCaseError> {
    prop_assert!(p.is_closed());
    prop_assert_eq!(p.euler_characteristic(), 2);
    let m = p
        .mass_properties(1.0)
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    prop_assert!(m.volume > 0.0);
    prop_assert!(p.bbox.center.coords.norm() <= 1e-9 * p.bbox.half.norm());
    Ok(())
}
