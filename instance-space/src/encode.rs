//! The flat records of the Instance Space built from the plain [`Store`]: one encoder, used by
//! the keeper to publish and by [`crate::Snapshot::from_store`] for a process-local snapshot.

use crate::layout::{
    ChunkEntry, GeometryBundleHeader, GeometryEntry, GeometryHeader, OBJECT_CHUNK,
    ObjectChunkHeader, ObjectRec, ObjectsHeader, PatchEntry, PatchRec, PolygonRec, PoseChunkHeader,
    PoseRec, Segment, SegmentWriter, flags, section_mut,
};
use crate::record::{self, KinematicsFields};
use crate::store::{Id, Object, Store};
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

/// The segments of a whole model, as owned words.
pub(crate) struct ModelSegments {
    /// The objects' header and every object chunk, in object order.
    pub objects_header: ObjectsHeader,
    pub object_chunks: Vec<Vec<u64>>,
    /// Every object's pose record, in object order.
    pub poses: Vec<PoseRec>,
    /// In object order; `None` for objects without geometry.
    pub geometry: Vec<Option<Vec<u64>>>,
}

/// Every segment of `model` as the keeper would publish it at its current version (every
/// object chunk of generation `model.structure_version()`).
pub(crate) fn model_segments(model: &Store, epoch: u64) -> ModelSegments {
    let objects: Vec<&Object> = model.objects().collect();
    let generation = model.structure_version();
    let object_chunks = objects
        .chunks(OBJECT_CHUNK)
        .enumerate()
        .map(|(k, c)| object_chunk(c.iter().copied(), k * OBJECT_CHUNK, generation))
        .collect();
    let poses = objects.iter().map(|o| pose_rec(o)).collect();
    let geometry = objects
        .iter()
        .map(|o| {
            o.geometry.as_ref().map(|poly| {
                GeometryParts::new(poly, o.id, o.geom_gen)
                    .writer(poly)
                    .to_vec()
            })
        })
        .collect();
    ModelSegments {
        objects_header: ObjectsHeader::new(generation, epoch, objects.len(), model.selection()),
        object_chunks,
        poses,
        geometry,
    }
}

/// The segment of the object chunk holding `objects` (object order), the first of them object
/// `first`, at `generation` (see [`ObjectChunkHeader`]).
pub(crate) fn object_chunk<'a>(
    objects: impl IntoIterator<Item = &'a Object>,
    first: usize,
    generation: u64,
) -> Vec<u64> {
    let mut recs = Vec::with_capacity(OBJECT_CHUNK);
    let mut names = Vec::new();
    for o in objects {
        recs.push(object_rec(o, &mut names));
    }
    let header = [ObjectChunkHeader {
        generation,
        first: first as u64,
        count: recs.len() as u64,
    }];
    let with_geometry = geometry_index(&recs);
    let mut w = SegmentWriter::new();
    w.push(&header)
        .push(&recs)
        .push(&names)
        .push(&with_geometry);
    w.to_vec()
}

/// Rewrites record `j` of the object chunk `words` for `o` where it is, when nothing but the
/// record changes: the same object, its name and origin as the chunk's names section holds
/// them, and its place in the geometry index the same (geometry before and after, or neither).
/// `Some(changed)` (whether a byte of the record changed); `None` when the chunk must be
/// encoded again ([`object_chunk`]). O(1), where encoding the chunk is O([`OBJECT_CHUNK`]).
/// `names` is scratch space.
pub(crate) fn patch_object_rec(
    words: &mut [u64],
    j: usize,
    o: &Object,
    names: &mut Vec<u8>,
) -> Option<bool> {
    let seg = Segment::parse(words).ok()?;
    let old = *seg.section::<ObjectRec>(1).ok()?.get(j)?;
    let text = seg.section::<u8>(2).ok()?;
    let at = |off: u32, len: u32| text.get(off as usize..off as usize + len as usize);
    if old.id != o.id
        || at(old.name_off, old.name_len)? != o.name.as_bytes()
        || at(old.origin_off, old.origin_len)? != o.origin.as_bytes()
    {
        return None;
    }
    names.clear();
    let mut rec = object_rec(o, names);
    if (rec.flags ^ old.flags) & flags::HAS_GEOMETRY != 0 {
        return None;
    }
    rec.name_off = old.name_off;
    rec.origin_off = old.origin_off;
    // Bytes, not values: -0.0 for 0.0 is a change a reader must see.
    if bytemuck::bytes_of(&rec) == bytemuck::bytes_of(&old) {
        return Some(false);
    }
    *section_mut::<ObjectRec>(words, 1).ok()?.get_mut(j)? = rec;
    Some(true)
}

/// The object chunk `old` with `objects` (object order) appended after its records: its
/// records, names and geometry index copied as they are and the new ones' added, at
/// `generation` — what [`object_chunk`] of all of them gives, without encoding the old
/// records again. `None` when `old` is not a sound object chunk or the result would pass
/// [`OBJECT_CHUNK`] records.
pub(crate) fn extend_object_chunk<'a>(
    old: &[u64],
    objects: impl IntoIterator<Item = &'a Object>,
    generation: u64,
) -> Option<Vec<u64>> {
    let seg = Segment::parse(old).ok()?;
    let head: ObjectChunkHeader = *seg.record(0).ok()?;
    let mut recs = seg.section::<ObjectRec>(1).ok()?.to_vec();
    let mut names = seg.section::<u8>(2).ok()?.to_vec();
    let mut with_geometry = seg.section::<u64>(3).ok()?.to_vec();
    for o in objects {
        if o.geometry.is_some() {
            with_geometry.push(recs.len() as u64);
        }
        recs.push(object_rec(o, &mut names));
    }
    if recs.len() > OBJECT_CHUNK {
        return None;
    }
    let header = [ObjectChunkHeader {
        generation,
        first: head.first,
        count: recs.len() as u64,
    }];
    let mut w = SegmentWriter::new();
    w.push(&header)
        .push(&recs)
        .push(&names)
        .push(&with_geometry);
    Some(w.to_vec())
}

/// Sets the generation in an object chunk's header (written by [`object_chunk`]).
pub(crate) fn set_chunk_generation(words: &mut [u64], generation: u64) {
    // Section 0's offset is word 2 (see `SegmentWriter`); the generation is its first word.
    if let Some(&off) = words.get(2)
        && let Some(w) = words.get_mut(off as usize)
    {
        *w = generation;
    }
}

/// The bundle index of the object chunks `carried` — (chunk index, its segment), ascending —
/// laid end to end, with their generations from `gens`.
pub(crate) fn chunk_entries(gens: &[u64], carried: &[(usize, &[u64])]) -> Vec<ChunkEntry> {
    let mut start = 0;
    carried
        .iter()
        .map(|&(k, words)| {
            let e = ChunkEntry {
                id: k as u64,
                generation: gens.get(k).copied().unwrap_or(0),
                start: start as u64,
                len: words.len() as u64,
            };
            start += words.len();
            e
        })
        .collect()
}

/// An objects publication (see [`crate::layout`]): `header`, the generation of every chunk,
/// the chunks `carried` whole as a bundle indexed by `entries` ([`chunk_entries`]), and the
/// chunks carried as record patches (`patches`, each naming its records in `patched`); the
/// segments are written in place.
pub(crate) fn objects_writer<'a>(
    header: &'a [ObjectsHeader; 1],
    gens: &'a [u64],
    entries: &'a [ChunkEntry],
    carried: &[(usize, &'a [u64])],
    patches: &'a [PatchEntry],
    patched: &'a [PatchRec],
) -> SegmentWriter<'a> {
    let mut w = SegmentWriter::new();
    w.push(header)
        .push(gens)
        .push(entries)
        .push_parts(carried.iter().map(|&(_, words)| words))
        .push(patches)
        .push(patched);
    w
}

/// Records `indices` (ascending) of the object chunk `words` as patches, appended to `out`
/// with the entry naming them: chunk `k` at `generation`, carried whole last at `since`.
/// `None` (nothing appended) when `words` is not a sound object chunk or lacks a record.
pub(crate) fn chunk_patches(
    words: &[u64],
    k: usize,
    generation: u64,
    since: u64,
    indices: &[u32],
    out: &mut Vec<PatchRec>,
) -> Option<PatchEntry> {
    let recs = Segment::parse(words).ok()?.section::<ObjectRec>(1).ok()?;
    let start = out.len();
    for &j in indices {
        match recs.get(j as usize) {
            Some(&rec) => out.push(PatchRec {
                index: u64::from(j),
                rec,
            }),
            None => {
                out.truncate(start);
                return None;
            }
        }
    }
    Some(PatchEntry {
        chunk: k as u64,
        generation,
        since,
        start: start as u64,
        len: indices.len() as u64,
    })
}

/// An object chunk's last section: the index in the chunk of every record with geometry,
/// ascending.
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
        surface: record::surface(&o.appearance),
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
    // Which aspect field goes where: the one description in `crate::record`.
    KinematicsFields::of(o.kinematics.as_ref()).write(&mut rec);
    record::write_dynamics(o.dynamics.as_ref(), &mut rec);
    rec
}

#[cfg(test)]
mod tests {
    use crate::layout::OBJECT_CHUNK;
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

    fn tetra(scale: f64) -> GeometryInput {
        GeometryInput {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [scale, 0.0, 0.0],
                [0.0, scale, 0.0],
                [0.0, 0.0, scale],
            ],
            polygons: vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]],
        }
    }

    /// A model of `n` solids under a scene, every other one with geometry; their ids.
    fn model(n: usize) -> (Store, Vec<u64>) {
        let mut model = Store::new();
        let mut tx = Transaction::new();
        let scene = tx.create(Kind::Scene, "scene", None);
        for k in 0..n {
            let s = tx.create(Kind::Solid, &format!("s{k}"), Some(scene));
            if k % 2 == 0 {
                tx.set_geometry(s, Some(tetra(1.0)));
            }
        }
        let a = model.apply(&tx).expect("valid transaction");
        (model, a.created)
    }

    fn chunk_of(model: &Store, generation: u64) -> Vec<u64> {
        super::object_chunk(model.objects(), 0, generation)
    }

    /// A record patched where it is gives the chunk that encoding the model again gives; a
    /// change to the names or to the geometry index is refused (the chunk is encoded again).
    #[test]
    fn a_patched_record_is_the_record_encoded_again() {
        let (mut model, ids) = model(6);
        let mut words = chunk_of(&model, 1);
        // Geometry replaced (the record's generation changes), a colour set.
        let mut tx = Transaction::new();
        tx.set_geometry(ids[3], Some(tetra(2.0)));
        tx.set_appearance(
            ids[3],
            crate::Appearance {
                color: [0.5, 0.25, 1.0, 1.0],
                ..Default::default()
            },
        );
        model.apply(&tx).expect("valid transaction");
        let o = model.get(ids[3]).expect("object");
        let mut names = Vec::new();
        assert_eq!(
            super::patch_object_rec(&mut words, 3, o, &mut names),
            Some(true)
        );
        assert_eq!(words, chunk_of(&model, 1));
        // The same again changes nothing.
        assert_eq!(
            super::patch_object_rec(&mut words, 3, o, &mut names),
            Some(false)
        );
        // The wrong place, a new name, geometry gone: not patched, nothing written.
        let before = words.clone();
        assert_eq!(super::patch_object_rec(&mut words, 2, o, &mut names), None);
        let mut tx = Transaction::new();
        tx.set_name(ids[3], "renamed");
        model.apply(&tx).expect("valid transaction");
        let o = model.get(ids[3]).expect("object");
        assert_eq!(super::patch_object_rec(&mut words, 3, o, &mut names), None);
        let mut tx = Transaction::new();
        tx.set_geometry(ids[5], None);
        model.apply(&tx).expect("valid transaction");
        let o = model.get(ids[5]).expect("object");
        assert_eq!(super::patch_object_rec(&mut words, 5, o, &mut names), None);
        assert_eq!(words, before);
    }

    /// The patches of a chunk are its records at the indices given, after what `out` held; an
    /// index past the chunk appends nothing.
    #[test]
    fn chunk_patches_are_the_chunks_records() {
        let (model, _) = model(6);
        let words = chunk_of(&model, 4);
        let recs: Vec<crate::layout::ObjectRec> = model
            .objects()
            .map(|o| super::object_rec(o, &mut Vec::new()))
            .collect();
        let mut out = Vec::new();
        let e = super::chunk_patches(&words, 0, 9, 4, &[1, 4], &mut out).expect("sound chunk");
        assert_eq!(
            (e.chunk, e.generation, e.since, e.start, e.len),
            (0, 9, 4, 0, 2)
        );
        assert_eq!(out.iter().map(|p| p.index).collect::<Vec<_>>(), [1, 4]);
        // (names are at their own offsets in the chunk: compare what does not depend on them)
        assert_eq!(out[0].rec.id, recs[1].id);
        assert_eq!(out[1].rec.id, recs[4].id);
        assert_eq!(out[1].rec.geom_gen, recs[4].geom_gen);
        let e = super::chunk_patches(&words, 0, 9, 4, &[2], &mut out).expect("sound chunk");
        assert_eq!((e.start, e.len), (2, 1));
        assert!(super::chunk_patches(&words, 0, 9, 4, &[3, 7], &mut out).is_none());
        assert_eq!(out.len(), 3, "nothing appended for a refused list");
    }

    /// Objects appended to a chunk give the chunk that encoding all of them gives.
    #[test]
    fn an_extended_chunk_is_the_chunk_encoded_again() {
        let (model, _) = model(9);
        let objects: Vec<&crate::Object> = model.objects().collect();
        let old = super::object_chunk(objects[..4].iter().copied(), 0, 3);
        let extended = super::extend_object_chunk(&old, objects[4..].iter().copied(), 7)
            .expect("a sound chunk");
        assert_eq!(extended, super::object_chunk(objects.iter().copied(), 0, 7));
        // Past a chunk's capacity: refused.
        let full = super::object_chunk(std::iter::repeat_n(objects[1], OBJECT_CHUNK), 0, 1);
        assert!(super::extend_object_chunk(&full, [objects[2]], 2).is_none());
    }
}
