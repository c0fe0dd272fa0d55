//! Bad transactions: each gets its own typed error naming the op, the object and the field,
//! and the model (version included) is unchanged.

use robosim_instance_space::*;

fn cube(s: f64) -> GeometryInput {
    let v = (0..8)
        .map(|i| {
            [
                s * ((i & 1) as f64 - 0.5),
                s * (((i >> 1) & 1) as f64 - 0.5),
                s * (((i >> 2) & 1) as f64 - 0.5),
            ]
        })
        .collect();
    GeometryInput {
        vertices: v,
        polygons: vec![
            vec![0, 2, 3, 1],
            vec![4, 5, 7, 6],
            vec![0, 1, 5, 4],
            vec![2, 6, 7, 3],
            vec![0, 4, 6, 2],
            vec![1, 3, 7, 5],
        ],
    }
}

/// A scene with a robot with one link carrying a solid; returns (model, scene, robot, link, solid).
fn base_model() -> (Store, Id, Id, Id, Id) {
    let mut m = Store::new();
    let mut tx = Transaction::new();
    let scene = tx.create(Kind::Scene, "cell", None);
    let robot = tx.create(Kind::Robot, "arm", Some(scene));
    let link = tx.create(Kind::Link, "link1", Some(robot));
    let solid = tx.create(Kind::Solid, "body", Some(link));
    tx.set_geometry(solid, Some(cube(0.1)));
    let a = m.apply(&tx).expect("valid scene");
    assert_eq!(a.version, 1);
    (m, a.created[0], a.created[1], a.created[2], a.created[3])
}

fn refused(m: &mut Store, tx: &Transaction) -> TxError {
    let before_version = m.version;
    let before: Vec<Object> = m.objects().cloned().collect();
    let err = m.apply(tx).expect_err("must be refused");
    assert_eq!(
        m.version, before_version,
        "a refused transaction bumps no version"
    );
    let after: Vec<Object> = m.objects().cloned().collect();
    assert_eq!(before, after, "a refused transaction changes nothing");
    err
}

#[test]
fn nan_pose_is_refused_naming_object_and_field() {
    let (mut m, _, _, link, _) = base_model();
    let mut tx = Transaction::new();
    tx.set_joint(link, 0.5); // a valid op first: must not survive the refusal
    let mut pose = IDENTITY;
    pose[7] = f64::NAN;
    tx.set_pose(link, pose);
    let e = refused(&mut m, &tx);
    assert!(
        matches!(&e, TxError::NonFinite { op: 1, id, field, .. } if *id == link && field == "pose[7]"),
        "{e:?}"
    );
    assert!(e.to_string().contains("pose[7] is not finite"), "{e}");
}

#[test]
fn unknown_id_is_refused() {
    let (mut m, ..) = base_model();
    let mut tx = Transaction::new();
    tx.set_pose(999, IDENTITY);
    assert_eq!(
        refused(&mut m, &tx),
        TxError::UnknownObject { op: 0, id: 999 }
    );
    let mut tx = Transaction::new();
    tx.push(Op::SetName {
        id: ObjRef::New(3),
        name: "x".into(),
    });
    assert_eq!(
        refused(&mut m, &tx),
        TxError::UnknownNewRef {
            op: 0,
            reference: 3
        }
    );
}

#[test]
fn non_planar_polygon_is_refused() {
    let (mut m, _, _, _, solid) = base_model();
    let mut g = cube(1.0);
    g.vertices[7][2] += 0.01;
    let mut tx = Transaction::new();
    tx.set_geometry(solid, Some(g));
    let e = refused(&mut m, &tx);
    assert!(
        matches!(&e, TxError::InvalidGeometry { op: 0, id, reason } if *id == solid && reason.contains("not planar")),
        "{e:?}"
    );
}

#[test]
fn concave_polygon_is_refused() {
    let (mut m, _, _, _, solid) = base_model();
    let g = GeometryInput {
        vertices: vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [1.0, 0.5, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
        ],
        polygons: vec![vec![0, 1, 2, 3, 4]],
    };
    let mut tx = Transaction::new();
    tx.set_geometry(solid, Some(g));
    let e = refused(&mut m, &tx);
    assert!(
        matches!(&e, TxError::InvalidGeometry { reason, .. } if reason.contains("not convex at its vertex 2")),
        "{e:?}"
    );
}

#[test]
fn index_out_of_range_is_refused() {
    let (mut m, _, _, _, solid) = base_model();
    let mut g = cube(1.0);
    g.polygons[2][1] = 42;
    let mut tx = Transaction::new();
    tx.set_geometry(solid, Some(g));
    let e = refused(&mut m, &tx);
    assert!(
        matches!(&e, TxError::InvalidGeometry { reason, .. } if reason.contains("polygon 2 refers to vertex 42")),
        "{e:?}"
    );
}

#[test]
fn cycle_in_hierarchy_is_refused() {
    let (mut m, scene, ..) = base_model();
    let mut tx = Transaction::new();
    let s1 = tx.create(Kind::Solid, "a", Some(ObjRef::Id(scene)));
    let s2 = tx.create(Kind::Solid, "b", Some(s1));
    tx.attach(s1, s2);
    let e = refused(&mut m, &tx);
    assert!(matches!(e, TxError::Cycle { op: 2, .. }), "{e:?}");
    assert_eq!(
        m.next_id(),
        5,
        "ids handed out by a refused transaction are not consumed"
    );
}

#[test]
fn wrong_parent_kind_and_orphan_link_are_refused() {
    let (mut m, scene, ..) = base_model();
    let mut tx = Transaction::new();
    tx.create(Kind::Link, "loose", Some(ObjRef::Id(scene)));
    assert!(matches!(
        refused(&mut m, &tx),
        TxError::WrongParentKind { .. }
    ));
    let mut tx = Transaction::new();
    tx.create(Kind::Link, "orphan", None);
    assert!(matches!(refused(&mut m, &tx), TxError::NeedsParent { .. }));
}

#[test]
fn request_to_allocate_a_trillion_elements_is_refused_before_allocating() {
    // A hand-made wire message: SetGeometry whose vertex count claims 10^12 entries.
    let (mut m, _, _, _, solid) = base_model();
    let mut tx = Transaction::new();
    tx.set_geometry(
        solid,
        Some(GeometryInput {
            vertices: vec![[0.0; 3]],
            polygons: vec![],
        }),
    );
    let mut bytes = tx.encode();
    // Find the encoded vertex count (1) followed by 24 zero bytes and patch in 10^12
    // (bincode varint: 0xFD + u64 little endian).
    let pos = bytes
        .windows(25)
        .position(|w| w[0] == 1 && w[1..].iter().all(|b| *b == 0))
        .expect("vertex count");
    let mut patched = bytes[..pos].to_vec();
    patched.push(0xFD);
    patched.extend_from_slice(&1_000_000_000_000u64.to_le_bytes());
    patched.extend_from_slice(&bytes[pos + 1..]);
    bytes = patched;
    let e = Transaction::decode(&bytes).expect_err("refused");
    assert!(matches!(e, TxError::TooLarge { .. }), "{e:?}");
    assert_eq!(m.version, 1);
    let _ = &mut m;
}

#[test]
fn oversized_geometry_is_refused_by_count() {
    let (mut m, _, _, _, solid) = base_model();
    let g = GeometryInput {
        vertices: vec![[0.0; 3]; (MAX_ELEMENTS + 1) as usize],
        polygons: vec![],
    };
    let mut tx = Transaction::new();
    tx.set_geometry(solid, Some(g));
    assert!(matches!(refused(&mut m, &tx), TxError::TooLarge { field, .. } if field == "vertices"));
}

#[test]
fn delete_with_children_needs_recursive_and_then_removes_the_subtree() {
    let (mut m, _, robot, link, solid) = base_model();
    let mut tx = Transaction::new();
    tx.delete(robot, false);
    assert!(matches!(refused(&mut m, &tx), TxError::HasChildren { .. }));
    let mut tx = Transaction::new();
    tx.delete(robot, true);
    let a = m.apply(&tx).expect("recursive delete");
    assert_eq!(
        a.changes.iter().map(|c| c.0).collect::<Vec<_>>(),
        vec![robot, link, solid]
    );
    assert_eq!(m.len(), 1);
}

#[test]
fn a_pose_change_touches_only_the_pose_aspect_of_one_object() {
    let (mut m, _, _, link, _) = base_model();
    let mut tx = Transaction::new();
    tx.set_joint(link, 0.3);
    let a = m.apply(&tx).expect("ok");
    assert_eq!(a.changes, vec![(link, aspect::POSE)]);
    assert_eq!(a.version, 2);
}

/// The session's selection (the display's pick): an object and one of its polygons, checked
/// against the model, announced with the SELECTION aspect on the objects it left and reached,
/// published in the snapshot, and dropped with its object.
#[test]
fn selection_is_checked_announced_published_and_dropped_with_its_object() {
    use robosim_instance_space::{Selection, Snapshot, TxError, aspect};
    let mut m = Store::new();
    let mut tx = Transaction::new();
    let s = tx.create(Kind::Scene, "s", None);
    let a = tx.create(Kind::Solid, "a", Some(s));
    tx.set_geometry(a, Some(cube(1.0)));
    tx.create(Kind::Solid, "b", Some(s));
    let ids = m.apply(&tx).expect("scene").created;
    let (a, b) = (ids[1], ids[2]);

    let mut tx = Transaction::new();
    tx.select(Some(a.into()), Some(6));
    let e = m.apply(&tx).expect_err("a cube has 6 polygons");
    assert!(
        matches!(&e, TxError::InvalidValue { id, field, .. } if *id == a && field == "selection polygon"),
        "{e}"
    );
    let mut tx = Transaction::new();
    tx.select(Some(b.into()), Some(0));
    assert!(m.apply(&tx).is_err(), "b has no geometry, so no polygon 0");
    let mut tx = Transaction::new();
    tx.select(None, Some(0));
    assert!(m.apply(&tx).is_err(), "a polygon without an object");
    assert_eq!(m.selection(), None, "refused selections changed nothing");

    let mut tx = Transaction::new();
    tx.select(Some(a.into()), Some(5));
    let applied = m.apply(&tx).expect("select a/5");
    assert_eq!(applied.changes, vec![(a, aspect::SELECTION)]);
    let want = Selection {
        object: a,
        polygon: Some(5),
    };
    assert_eq!(m.selection(), Some(want));
    assert_eq!(Snapshot::from_store(&m).selection(), Some(want));

    let mut tx = Transaction::new();
    tx.select(Some(b.into()), None);
    let applied = m.apply(&tx).expect("select b");
    assert_eq!(
        applied.changes,
        vec![(a, aspect::SELECTION), (b, aspect::SELECTION)],
        "both the object left and the one reached"
    );
    let mut tx = Transaction::new();
    tx.delete(b, false);
    m.apply(&tx).expect("delete b");
    assert_eq!(m.selection(), None, "a deleted object is not selected");
    assert_eq!(Snapshot::from_store(&m).selection(), None);
}
