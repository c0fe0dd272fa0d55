//! The flat records of the Instance Space built from the plain [`Store`]: one encoder, used by
//! the keeper to publish and by [`crate::Snapshot::from_store`] for a process-local snapshot.

use crate::layout::{
    GeometryBundleHeader, GeometryEntry, GeometryHeader, ObjectRec, ObjectsHeader, PolygonRec,
    PoseChunkHeader, PoseRec, SegmentWriter, flags,
};
use crate::store::{Id, Kinematics, Object, Store};
use robosim_geometry::Polyhedron;

pub(crate) fn pose_rec(o: &Object) -> PoseRec {
    PoseRec {
        id: o.id,
        pose: o.pose,
        joint: o.joint,
    }
}

/// The derived per-object arrays of a geometry segment (the polyhedron's own `indices` and
/// `edges` are written in place).
pub(crate) struct GeometryParts {
    header: [GeometryHeader; 1],
    vertices: Vec<[f64; 3]>,
    penalty: Vec<[f64; 4]>,
    polygons: Vec<PolygonRec>,
}

impl GeometryParts {
    pub(crate) fn new(poly: &Polyhedron, id: Id, generation: u64) -> Self {
        GeometryParts {
            header: [GeometryHeader {
                id,
                generation,
                bbox: [
                    poly.bbox.center.x,
                    poly.bbox.center.y,
                    poly.bbox.center.z,
                    poly.bbox.half.x,
                    poly.bbox.half.y,
                    poly.bbox.half.z,
                ],
            }],
            vertices: poly.vertices.iter().map(|v| [v.x, v.y, v.z]).collect(),
            penalty: poly
                .penalty
                .iter()
                .map(|p| [p.normal.x, p.normal.y, p.normal.z, p.d])
                .collect(),
            polygons: poly
                .polygons
                .iter()
                .map(|p| PolygonRec {
                    start: p.start,
                    len: p.len,
                    plane: [
                        p.plane.normal.x,
                        p.plane.normal.y,
                        p.plane.normal.z,
                        p.plane.d,
                    ],
                })
                .collect(),
        }
    }

    /// The segment, sections in [`crate::layout::geometry_sections`] order.
    pub(crate) fn writer<'a>(&'a self, poly: &'a Polyhedron) -> SegmentWriter<'a> {
        let mut w = SegmentWriter::new();
        w.push(&self.header)
            .push(&self.vertices)
            .push(&poly.indices)
            .push(&self.penalty)
            .push(&self.polygons)
            .push(&poly.edges);
        w
    }
}

/// A geometry bundle of the objects given (those without geometry are skipped): see
/// [`GeometryBundleHeader`]. The objects must come in ascending id.
pub(crate) struct GeometryBundle {
    header: [GeometryBundleHeader; 1],
    entries: Vec<GeometryEntry>,
    data: Vec<u64>,
}

impl GeometryBundle {
    /// `None` as soon as the geometry passes `max_words` (the rest is not encoded).
    pub(crate) fn new<'a>(
        epoch: u64,
        version: u64,
        objects: impl IntoIterator<Item = &'a Object>,
        max_words: usize,
    ) -> Option<Self> {
        let mut entries = Vec::new();
        let mut data: Vec<u64> = Vec::new();
        for o in objects {
            let Some(poly) = &o.geometry else {
                continue;
            };
            let parts = GeometryParts::new(poly, o.id, o.geom_gen);
            let w = parts.writer(poly);
            let start = data.len();
            if start + w.words() > max_words {
                return None;
            }
            data.resize(start + w.words(), 0);
            w.write(&mut data[start..]);
            entries.push(GeometryEntry {
                id: o.id,
                generation: o.geom_gen,
                start: start as u64,
                len: w.words() as u64,
            });
        }
        Some(GeometryBundle {
            header: [GeometryBundleHeader {
                epoch,
                version,
                count: entries.len() as u64,
            }],
            entries,
            data,
        })
    }
    pub(crate) fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
    pub(crate) fn writer(&self) -> SegmentWriter<'_> {
        let mut w = SegmentWriter::new();
        w.push(&self.header).push(&self.entries).push(&self.data);
        w
    }
}

/// The three kinds of segment of a whole model, as owned words.
pub(crate) struct ModelSegments {
    pub objects: Vec<u64>,
    /// Every object's pose record, in object order.
    pub poses: Vec<PoseRec>,
    /// In object order; `None` for objects without geometry.
    pub geometry: Vec<Option<Vec<u64>>>,
}

/// Every segment of `model` as the keeper would publish it at its current version.
pub(crate) fn model_segments(model: &Store, epoch: u64) -> ModelSegments {
    let mut recs = Vec::with_capacity(model.len());
    let mut names = Vec::new();
    let mut poses = Vec::with_capacity(model.len());
    let mut geometry = Vec::with_capacity(model.len());
    for o in model.objects() {
        recs.push(object_rec(o, &mut names));
        poses.push(pose_rec(o));
        geometry.push(o.geometry.as_ref().map(|poly| {
            GeometryParts::new(poly, o.id, o.geom_gen)
                .writer(poly)
                .to_vec()
        }));
    }
    let objects_header = [ObjectsHeader::new(
        model.structure_version(),
        epoch,
        recs.len(),
        model.selection(),
    )];
    let mut w = SegmentWriter::new();
    let with_geometry = geometry_index(&recs);
    w.push(&objects_header)
        .push(&recs)
        .push(&names)
        .push(&with_geometry);
    let objects = w.to_vec();
    ModelSegments {
        objects,
        poses,
        geometry,
    }
}

/// The objects segment's last section: the index of every record with geometry, ascending.
pub(crate) fn geometry_index(recs: &[ObjectRec]) -> Vec<u64> {
    recs.iter()
        .enumerate()
        .filter(|(_, r)| r.flags & crate::layout::flags::HAS_GEOMETRY != 0)
        .map(|(i, _)| i as u64)
        .collect()
}

pub(crate) fn pose_chunk_header(
    epoch: u64,
    generation: u64,
    first: usize,
    count: usize,
) -> PoseChunkHeader {
    PoseChunkHeader {
        epoch,
        generation,
        first: first as u64,
        count: count as u64,
    }
}

/// A pose chunk segment: its header and its records.
pub(crate) fn pose_chunk_writer<'a>(
    header: &'a [PoseChunkHeader; 1],
    recs: &'a [PoseRec],
) -> SegmentWriter<'a> {
    let mut w = SegmentWriter::new();
    w.push(header).push(recs);
    w
}

pub(crate) fn object_rec(o: &Object, names: &mut Vec<u8>) -> ObjectRec {
    let name_off = names.len() as u32;
    names.extend_from_slice(o.name.as_bytes());
    let mut rec = ObjectRec {
        id: o.id,
        parent: o.parent,
        kind: o.kind as u32,
        name_off,
        name_len: o.name.len() as u32,
        geom_gen: o.geom_gen,
        color: o.appearance.color,
        surface: [
            o.appearance.diffuse,
            o.appearance.specular,
            o.appearance.shininess,
            0.0,
        ],
        ..bytemuck::Zeroable::zeroed()
    };
    if !o.origin.is_empty() {
        rec.origin_off = names.len() as u32;
        rec.origin_len = o.origin.len() as u32;
        names.extend_from_slice(o.origin.as_bytes());
    }
    if o.geometry.is_some() {
        rec.flags |= flags::HAS_GEOMETRY;
    }
    match o.kinematics {
        Some(Kinematics::Joint {
            index,
            joint,
            convention,
            a,
            d,
            alpha,
            theta,
            offset,
            qlim,
        }) => {
            rec.flags |= flags::HAS_KINEMATICS;
            rec.kin_tag = flags::KIN_JOINT;
            rec.joint_kind = joint as u32;
            rec.convention = convention as u32;
            rec.index_or_family = index;
            rec.dh = [a, d, alpha, theta, offset, qlim[0], qlim[1]];
        }
        Some(Kinematics::Axis {
            index,
            parent,
            joint,
            placement,
            axis,
            offset,
            qlim,
        }) => {
            rec.flags |= flags::HAS_KINEMATICS;
            rec.kin_tag = flags::KIN_AXIS;
            rec.joint_kind = joint as u32;
            rec.convention = parent;
            rec.index_or_family = index;
            rec.dh = [axis[0], axis[1], axis[2], 0.0, offset, qlim[0], qlim[1]];
            rec.tool = placement;
        }
        Some(Kinematics::Robot {
            convention,
            ik_family,
            tool,
        }) => {
            rec.flags |= flags::HAS_KINEMATICS;
            rec.kin_tag = flags::KIN_ROBOT;
            rec.convention = convention as u32;
            rec.index_or_family = ik_family;
            rec.tool = tool;
        }
        None => {}
    }
    if let Some(m) = o.dynamics {
        rec.flags |= flags::HAS_DYNAMICS;
        rec.mass = m.mass;
        rec.com = m.com;
        rec.inertia = m.inertia;
    }
    rec
}

#[cfg(test)]
mod tests {
    use crate::{GeometryInput, Kind, Snapshot, Store, Transaction};

    /// A local snapshot reads back what the model holds: names, parents, world poses through
    /// the parent chain, geometry by object index.
    #[test]
    fn snapshot_from_model_matches_the_model() {
        let mut model = Store::new();
        let mut tx = Transaction::new();
        let item = tx.create(Kind::Item, "item", None);
        tx.set_pose(
            item,
            [1.0, 0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        );
        let solid = tx.create(Kind::Solid, "tri", Some(item));
        tx.set_pose(
            solid,
            [0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 3.0, 0.0, 0.0, 1.0, 0.0],
        );
        tx.set_geometry(
            solid,
            Some(GeometryInput {
                vertices: vec![
                    [0.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                ],
                polygons: vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]],
            }),
        );
        model.apply(&tx).expect("valid transaction");
        let snap = Snapshot::from_store(&model);
        assert_eq!(snap.version(), model.version);
        assert_eq!(snap.len(), 2);
        let i = snap.find("tri").expect("tri present");
        assert_eq!(snap.name(i), "tri");
        let w = snap.world_pose(i);
        // item translates by x=2, the solid by y=3 after a 90° turn about z.
        assert_eq!([w[3], w[7], w[11]], [2.0, 3.0, 0.0]);
        let g = snap.geometry(i).expect("geometry");
        assert_eq!(g.vertices.len(), 4);
        assert_eq!(g.polygons.len(), 4);
        assert!(snap.geometry(snap.find("item").expect("item")).is_none());
    }
}
