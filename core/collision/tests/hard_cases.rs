//! The named hard cases of issue 5.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use robosim_collision::robot::{
    Body, CheckResult, CollisionSettings, LinkSolid, LinkSolids, Scene, move_checked,
};
use robosim_collision::{Mode, PairResult, PolygonOptions, ShapeError, Solid, collide, polygon};
use robosim_geometry::GeometryError;
use robosim_kinematics::{Joint, Robot};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
use std::sync::Arc;

fn cube(s: f64) -> Solid {
    Solid::cuboid(Vector3::new(s, s, s)).expect("cube")
}

const MODES: [Mode; 3] = [Mode::BBox, Mode::Polygon, Mode::Exact];

#[test]
fn faces_exactly_touching_is_contact_at_distance_zero() {
    let a = cube(1.0);
    let (pa, pb) = (
        Isometry3::identity(),
        Isometry3::translation(1.0, 0.25, -0.3),
    );
    for m in MODES {
        assert_eq!(
            collide(&a, &pa, &a, &pb, m).intersects(),
            Some(true),
            "{m:?}"
        );
    }
    assert_eq!(
        collide(&a, &pa, &a, &pb, Mode::Exact).signed_distance(),
        Some(0.0)
    );
}

#[test]
fn separated_by_1e9_is_clear_with_that_distance() {
    let a = cube(1.0);
    let x = 1.0 + 1e-9;
    let (pa, pb) = (Isometry3::identity(), Isometry3::translation(x, 0.25, -0.3));
    for m in MODES {
        assert_eq!(
            collide(&a, &pa, &a, &pb, m).intersects(),
            Some(false),
            "{m:?}"
        );
    }
    let d = collide(&a, &pa, &a, &pb, Mode::Exact)
        .signed_distance()
        .expect("distance");
    assert!((d - (x - 1.0)).abs() < 1e-15, "{d:e}");
    // Spheres too: 1e-9 apart along a skew direction.
    let s = Solid::sphere(0.5, None).expect("sphere");
    let dir = Vector3::new(1.0, 2.0, -0.5).normalize();
    let pb = Isometry3::from_parts(
        Translation3::from(dir * (1.0 + 1e-9)),
        UnitQuaternion::identity(),
    );
    let r = collide(&s, &pa, &s, &pb, Mode::Exact);
    assert_eq!(r.intersects(), Some(false));
    assert!((r.signed_distance().expect("d") - 1e-9).abs() < 1e-15);
}

#[test]
fn full_containment_is_caught_except_by_the_seeds_own_algorithm() {
    let (big, small) = (cube(1.0), cube(0.1));
    let pa = Isometry3::identity();
    let pb = Isometry3::new(Vector3::new(0.1, -0.2, 0.15), Vector3::new(0.3, 0.2, 0.1));
    assert_eq!(
        collide(&big, &pa, &small, &pb, Mode::Exact).intersects(),
        Some(true)
    );
    assert_eq!(
        collide(&small, &pb, &big, &pa, Mode::Exact).intersects(),
        Some(true)
    );
    assert_eq!(
        collide(&big, &pa, &small, &pb, Mode::Polygon).intersects(),
        Some(true)
    );
    // The seed admits this miss (§2.6): without the containment test, POCODA says clear.
    let seed = polygon::collide(
        &big,
        &pa,
        &small,
        &pb,
        PolygonOptions { containment: false },
    );
    assert_eq!(seed.intersects(), Some(false));
    // Inside a non-convex closed mesh (an L-shaped prism): parry sees only its surface, the
    // pseudo-normal containment test catches it.
    let l = l_prism();
    let inside = Isometry3::translation(0.5, 0.5, 0.5);
    assert!(!l.pieces[0].convex && l.pieces[0].closed);
    for m in [Mode::Exact, Mode::Polygon] {
        assert_eq!(
            collide(&l, &pa, &small, &inside, m).intersects(),
            Some(true),
            "{m:?}"
        );
        assert_eq!(
            collide(&small, &inside, &l, &pa, m).intersects(),
            Some(true),
            "{m:?}"
        );
    }
    // In the notch of the L: outside.
    let notch = Isometry3::translation(1.5, 1.5, 0.5);
    for m in [Mode::Exact, Mode::Polygon] {
        assert_eq!(
            collide(&l, &pa, &small, &notch, m).intersects(),
            Some(false),
            "{m:?}"
        );
    }
}

/// An L-shaped prism 2 × 2 × 1 with the square [1,2]×[1,2] cut out, as convex polygons.
fn l_prism() -> Solid {
    let outline = [
        (0.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 2.0),
    ];
    let mut v: Vec<Point3<f64>> = outline
        .iter()
        .map(|&(x, y)| Point3::new(x, y, 0.0))
        .collect();
    v.extend(outline.iter().map(|&(x, y)| Point3::new(x, y, 1.0)));
    let mut faces: Vec<Vec<u32>> = vec![
        // bottom (seen from below: clockwise in xy), split into two convex parts
        vec![0, 3, 2, 1],
        vec![0, 5, 4, 3],
        // top
        vec![6, 7, 8, 9],
        vec![6, 9, 10, 11],
    ];
    for i in 0..6u32 {
        let j = (i + 1) % 6;
        faces.push(vec![i, j, 6 + j, 6 + i]);
    }
    Solid::mesh(v, &faces).expect("L prism")
}

#[test]
fn one_millimetre_plates_crossing() {
    let plate = Solid::cuboid(Vector3::new(1.0, 1.0, 0.001)).expect("plate");
    let pa = Isometry3::identity();
    // The second plate stands upright through the first, offset so no vertex is inside.
    let pb = Isometry3::new(
        Vector3::new(0.2, 0.1, 0.0),
        Vector3::new(FRAC_PI_2, 0.0, 0.0),
    );
    for m in MODES {
        assert_eq!(
            collide(&plate, &pa, &plate, &pb, m).intersects(),
            Some(true),
            "{m:?}"
        );
    }
    // Separating them takes a translation of 0.4005 m (along y, out of the other plate's width).
    let depth = -collide(&plate, &pa, &plate, &pb, Mode::Exact)
        .signed_distance()
        .expect("depth");
    assert!((depth - 0.4005).abs() < 1e-9, "{depth}");
    // Moved sideways until the upright plate's face is 1 mm past the flat plate's edge.
    let apart = Isometry3::new(
        Vector3::new(0.2, 0.5 + 0.0005 + 0.001, 0.0),
        Vector3::new(FRAC_PI_2, 0.0, 0.0),
    );
    let r = collide(&plate, &pa, &plate, &apart, Mode::Exact);
    assert!(
        (r.signed_distance().expect("d") - 0.001).abs() < 1e-12,
        "{r:?}"
    );
    assert_eq!(
        collide(&plate, &pa, &plate, &apart, Mode::Polygon).intersects(),
        Some(false)
    );
}

#[test]
fn hundred_metre_truss_against_a_one_centimetre_part() {
    // 100 bays of 1 m: two chords and a diagonal per bay, 5 cm square members — 300 parts.
    let mut parts = Vec::new();
    for k in 0..100 {
        let x = k as f64 + 0.5;
        for y in [0.0, 1.0] {
            parts.push((
                Isometry3::translation(x, y, 0.0),
                Solid::cuboid(Vector3::new(1.0, 0.05, 0.05)).expect("chord"),
            ));
        }
        let diag = Isometry3::from_parts(
            Translation3::new(x, 0.5, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_4),
        );
        parts.push((
            diag,
            Solid::cuboid(Vector3::new(2f64.sqrt(), 0.05, 0.05)).expect("diagonal"),
        ));
    }
    let truss = Solid::compound(parts).expect("truss");
    assert_eq!(truss.pieces.len(), 300);
    let part = cube(0.01);
    let pt = Isometry3::identity();
    // Sitting on the top face of the lower chord at x = 73.3, 1 mm deep.
    let hit = Isometry3::translation(73.3, 0.0, 0.025 + 0.005 - 0.001);
    let miss = Isometry3::translation(73.3, 0.0, 0.025 + 0.005 + 0.001);
    for m in MODES {
        assert_eq!(
            collide(&truss, &pt, &part, &hit, m).intersects(),
            Some(true),
            "{m:?}"
        );
    }
    let r = collide(&truss, &pt, &part, &hit, Mode::Exact);
    assert!(
        (r.signed_distance().expect("depth") + 0.001).abs() < 1e-9,
        "{r:?}"
    );
    let r = collide(&truss, &pt, &part, &miss, Mode::Exact);
    assert!(
        (r.signed_distance().expect("distance") - 0.001).abs() < 1e-9,
        "{r:?}"
    );
    assert_eq!(
        collide(&truss, &pt, &part, &miss, Mode::Polygon).intersects(),
        Some(false)
    );
    // Inside the truss's box but between its members: only the bbox mode says contact.
    let between = Isometry3::translation(50.0, 0.5, 0.0);
    assert_eq!(
        collide(&truss, &pt, &part, &between, Mode::BBox).intersects(),
        Some(true)
    );
    assert_eq!(
        collide(&truss, &pt, &part, &between, Mode::Polygon).intersects(),
        Some(false)
    );
    assert_eq!(
        collide(&truss, &pt, &part, &between, Mode::Exact).intersects(),
        Some(false)
    );
}

#[test]
fn rotated_45_degrees_about_two_axes() {
    let a = cube(1.0);
    let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_4)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_4);
    // Extent of the rotated cube along +x, from its vertices (closed form).
    let reach = a.pieces[0]
        .poly
        .vertices
        .iter()
        .map(|v| (rot * v).x)
        .fold(f64::MIN, f64::max);
    let wall = Solid::cuboid(Vector3::new(1.0, 4.0, 4.0)).expect("wall");
    let pa = Isometry3::from_parts(Translation3::identity(), rot);
    for (gap, expect) in [(1e-3, false), (-1e-3, true)] {
        let pw = Isometry3::translation(reach + 0.5 + gap, 0.0, 0.0);
        for m in [Mode::Polygon, Mode::Exact] {
            assert_eq!(
                collide(&a, &pa, &wall, &pw, m).intersects(),
                Some(expect),
                "{m:?} gap {gap}"
            );
        }
        let sd = collide(&a, &pa, &wall, &pw, Mode::Exact)
            .signed_distance()
            .expect("sd");
        assert!((sd - gap).abs() < 1e-9, "{sd} vs {gap}");
    }
}

fn one_link_arm() -> (Robot, LinkSolids) {
    let robot = Robot {
        joints: vec![Joint {
            a: 1.0,
            ..Joint::default()
        }],
        ..Robot::default()
    };
    let bar = Solid::cuboid(Vector3::new(1.0, 0.04, 0.04)).expect("bar");
    // Link 1's frame is at the tip; the bar runs back along −x.
    let links = LinkSolids {
        links: vec![
            None,
            Some(LinkSolid {
                solid: Arc::new(bar),
                offset: Isometry3::translation(-0.5, 0.0, 0.0),
            }),
        ],
        allowed: vec![],
    };
    (robot, links)
}

#[test]
fn fast_link_passing_through_a_thin_object_between_two_steps() {
    let (robot, links) = one_link_arm();
    let mut scene = Scene::new();
    // A 1 mm plate across the arc at q = 0 (the link along +x).
    let plate = Solid::cuboid(Vector3::new(0.2, 0.001, 0.2)).expect("plate");
    scene.add(
        "plate",
        Arc::new(plate),
        Isometry3::translation(0.6, 0.0, 0.0),
    );
    let (from, to) = ([-FRAC_PI_2], [FRAC_PI_2]);
    let discrete = CollisionSettings::default();
    let m = move_checked(&robot, &links, &from, &to, 1, &scene, &discrete).expect("move");
    assert!(
        m.completed,
        "discrete checks only see both ends: the seed's admitted miss"
    );
    let continuous = CollisionSettings {
        continuous: true,
        ..CollisionSettings::default()
    };
    let m = move_checked(&robot, &links, &from, &to, 1, &scene, &continuous).expect("move");
    assert!(!m.completed);
    assert_eq!(m.q, from.to_vec());
    let s = m.time_of_impact.expect("time of impact");
    // First contact when the bar's leading face (y = −0.02 side) meets the plate (y = −0.0005):
    // somewhat before the half-way point of the swing.
    assert!(s > 0.45 && s < 0.5, "{s}");
    match m.stopped_by {
        Some(CheckResult::Contact(c)) => {
            assert_eq!(c[0].a, Body::Link(1));
            assert_eq!(
                c[0].b,
                Body::Object {
                    index: 0,
                    name: "plate".into()
                }
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn degenerate_polygon_refused_at_load() {
    let v = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(2.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
    ];
    let r = Solid::mesh(v, &[vec![0, 1, 3], vec![0, 1, 2]]);
    assert_eq!(r.err().map(|e| e.polygon()), Some(Some(1)));
    let r = Solid::mesh(vec![Point3::origin(); 3], &[vec![0, 1, 2]]);
    assert!(matches!(
        r,
        Err(ShapeError::Geometry(GeometryError::Degenerate {
            polygon: 0,
            ..
        }))
    ));
}

#[test]
fn open_mesh_containment_is_unknown_not_clear() {
    // A cube with its top missing, and a small cube floating inside the open box.
    let c = cube(1.0);
    let p = &c.pieces[0].poly;
    let faces: Vec<Vec<u32>> = (0..p.polygons.len())
        .filter(|&i| i != 1)
        .map(|i| p.polygon_indices(i).to_vec())
        .collect();
    let open = Solid::mesh(p.vertices.clone(), &faces).expect("open box");
    assert!(!open.pieces[0].closed);
    let small = cube(0.1);
    let (po, ps) = (Isometry3::identity(), Isometry3::translation(0.1, 0.0, 0.0));
    for m in [Mode::Exact, Mode::Polygon] {
        let r = collide(&open, &po, &small, &ps, m);
        assert!(matches!(r, PairResult::Unknown { .. }), "{m:?}: {r:?}");
    }
}
