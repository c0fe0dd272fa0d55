//! The flat shared-memory layout: `#[repr(C)]` records addressed by index, packed into
//! segments of `u64` words so that every section is 8-byte aligned and can be viewed in place
//! (zero-copy) with `bytemuck` — no `unsafe` anywhere in this crate.
//!
//! A segment is `[magic, n_sections, (offset_words, len_bytes) × n, data…]`. The segments:
//! * object chunk, [`OBJECT_CHUNK`] objects in object order: [`ObjectChunkHeader`],
//!   [`ObjectRec`] × up to [`OBJECT_CHUNK`], their names (UTF-8 arena, offsets local to the
//!   chunk), and the index in the chunk (`u64`) of every object that has geometry, ascending —
//!   so that a reader finds the geometry it needs without touching every record's page — never
//!   published alone but in an objects publication:
//! * objects publication ([`ObjectsHeader`], the generation of every object chunk, then a
//!   bundle of object chunks: a [`ChunkEntry`] per chunk carried and their segments end to end,
//!   then the chunks carried as record patches: a [`PatchEntry`] per chunk and the
//!   [`PatchRec`]s), on two services: the objects head, published by every structural commit
//!   with the chunks that commit changed (O(objects / [`OBJECT_CHUNK`] + changed records): a
//!   chunk whose records alone changed since it was last carried whole goes as those records,
//!   up to [`OBJECT_PATCH_MAX`] of them, any other changed chunk whole; the chunks omitted when
//!   they pass [`GEOMETRY_UPDATE_MAX_WORDS`]), and the objects base, every chunk whole at one
//!   structure version, published only when a reader asks for it (attaching, after a keeper
//!   restart, or having missed a head) — a reader assembles the objects of a structure version
//!   from the chunks with exactly the generations its head names;
//! * poses head: [`PosesHeader`] and the generation of every pose chunk — published by every
//!   commit, O(objects / [`POSE_CHUNK`]) words;
//! * pose chunks, one service per [`POSE_CHUNK`] objects: [`PoseChunkHeader`], [`PoseRec`] ×
//!   up to [`POSE_CHUNK`], in the same order as the objects — published only when a pose in
//!   that range (or the structure) changed, O(changed chunks);
//! * pose base: the poses head's [`PosesHeader`] and chunk generations, then every
//!   [`PoseRec`] — the whole poses of one version in one sample, O(objects), published only
//!   when a reader asks for it (attaching, or after a keeper restart), so that a late joiner
//!   subscribes to one service instead of one per chunk;
//! * geometry of one object: [`GeometryHeader`], vertices, indices, penalty planes, polygons,
//!   edges, box — never published alone but inside a geometry bundle:
//! * geometry bundles ([`GeometryBundleHeader`], a [`GeometryEntry`] per object, their geometry
//!   segments end to end), on two services: the geometry update, the objects whose geometry
//!   one group of commits changed (O(changed), up to [`GEOMETRY_UPDATE_MAX_WORDS`]; a larger
//!   change goes by the base only), and the geometry base, every object's geometry at one
//!   structure version, published only when a reader asks for it (attaching, after a keeper
//!   restart, or having missed an update) — so a session holds two geometry services whatever
//!   the number of objects;
//! * changes: [`ChangeRec`] × n and their ids.

use bytemuck::{Pod, Zeroable};

pub const MAGIC: u64 = 0x5253_494d_0001_0000; // "RSIM" v1

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LayoutError {
    #[error("segment too short ({0} words)")]
    Short(usize),
    #[error("bad magic {0:#x}")]
    Magic(u64),
    #[error("section {0} is out of bounds or misaligned for its record type")]
    Section(usize),
    #[error("section {0} is missing")]
    Missing(usize),
}

/// Builds a segment: push sections, then write into a `u64` buffer of [`SegmentWriter::words`].
#[derive(Default)]
pub struct SegmentWriter<'a> {
    /// Each section: its parts, end to end.
    sections: Vec<Vec<&'a [u8]>>,
}

impl<'a> SegmentWriter<'a> {
    pub fn new() -> Self {
        SegmentWriter {
            sections: Vec::new(),
        }
    }
    pub fn push<T: Pod>(&mut self, data: &'a [T]) -> &mut Self {
        self.sections.push(vec![bytemuck::cast_slice(data)]);
        self
    }
    /// One section of the word slices `parts` end to end (a bundle's segments, written
    /// without first copying them into one buffer).
    pub fn push_parts(&mut self, parts: impl IntoIterator<Item = &'a [u64]>) -> &mut Self {
        self.sections
            .push(parts.into_iter().map(bytemuck::cast_slice).collect());
        self
    }
    fn section_len(parts: &[&[u8]]) -> usize {
        parts.iter().map(|p| p.len()).sum()
    }
    /// Total size in words.
    pub fn words(&self) -> usize {
        2 + 2 * self.sections.len()
            + self
                .sections
                .iter()
                .map(|s| Self::section_len(s).div_ceil(8))
                .sum::<usize>()
    }
    /// Writes the segment into `out`, which must be exactly [`Self::words`] long.
    pub fn write(&self, out: &mut [u64]) {
        debug_assert_eq!(out.len(), self.words());
        out[0] = MAGIC;
        out[1] = self.sections.len() as u64;
        let mut offset = 2 + 2 * self.sections.len();
        for (i, parts) in self.sections.iter().enumerate() {
            let len = Self::section_len(parts);
            out[2 + 2 * i] = offset as u64;
            out[3 + 2 * i] = len as u64;
            let w = len.div_ceil(8);
            let dst: &mut [u8] = bytemuck::cast_slice_mut(&mut out[offset..offset + w]);
            let mut at = 0;
            for p in parts {
                dst[at..at + p.len()].copy_from_slice(p);
                at += p.len();
            }
            dst[len..].fill(0);
            offset += w;
        }
    }
    pub fn to_vec(&self) -> Vec<u64> {
        let mut v = vec![0u64; self.words()];
        self.write(&mut v);
        v
    }
}

/// A read view over a segment (borrowed from shared memory or a Vec).
#[derive(Clone, Copy)]
pub struct Segment<'a> {
    words: &'a [u64],
    n: usize,
}

impl<'a> Segment<'a> {
    pub fn parse(words: &'a [u64]) -> Result<Self, LayoutError> {
        if words.len() < 2 {
            return Err(LayoutError::Short(words.len()));
        }
        if words[0] != MAGIC {
            return Err(LayoutError::Magic(words[0]));
        }
        let n = words[1] as usize;
        if words.len() < 2 + 2 * n {
            return Err(LayoutError::Short(words.len()));
        }
        Ok(Segment { words, n })
    }
    /// Section `i` viewed as `[T]` in place.
    pub fn section<T: Pod>(&self, i: usize) -> Result<&'a [T], LayoutError> {
        if i >= self.n {
            return Err(LayoutError::Missing(i));
        }
        let off = self.words[2 + 2 * i] as usize;
        let len = self.words[3 + 2 * i] as usize;
        let w = len.div_ceil(8);
        let words = self
            .words
            .get(off..off.checked_add(w).ok_or(LayoutError::Section(i))?)
            .ok_or(LayoutError::Section(i))?;
        let bytes: &[u8] = bytemuck::cast_slice(words);
        bytemuck::try_cast_slice(&bytes[..len]).map_err(|_| LayoutError::Section(i))
    }
    /// The single record of section `i`.
    pub fn record<T: Pod>(&self, i: usize) -> Result<&'a T, LayoutError> {
        self.section::<T>(i)?.first().ok_or(LayoutError::Section(i))
    }
}

/// Section `i` of the segment `words` viewed as `[T]` in place, to write (a record patched
/// where it is); the same bounds as [`Segment::section`].
pub fn section_mut<T: Pod>(words: &mut [u64], i: usize) -> Result<&mut [T], LayoutError> {
    let n = Segment::parse(words)?.n;
    if i >= n {
        return Err(LayoutError::Missing(i));
    }
    let off = words[2 + 2 * i] as usize;
    let len = words[3 + 2 * i] as usize;
    let w = len.div_ceil(8);
    let words = off
        .checked_add(w)
        .and_then(|end| words.get_mut(off..end))
        .ok_or(LayoutError::Section(i))?;
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(words);
    bytemuck::try_cast_slice_mut(&mut bytes[..len]).map_err(|_| LayoutError::Section(i))
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct ObjectsHeader {
    /// The model version this structure was published at.
    pub version: u64,
    /// The keeper's start time (ns since the epoch): changes when a keeper restarts.
    pub epoch: u64,
    pub count: u64,
    /// The session's selection ([`crate::Selection`]): the object's id, 0 for none.
    pub selected: u64,
    /// The selected polygon, [`NO_POLYGON`] for the object as a whole.
    pub selected_polygon: u64,
}

/// `ObjectsHeader::selected_polygon` when no polygon is selected.
pub const NO_POLYGON: u64 = u64::MAX;

impl ObjectsHeader {
    /// The header of a model's objects publication.
    pub(crate) fn new(
        version: u64,
        epoch: u64,
        count: usize,
        selection: Option<crate::Selection>,
    ) -> Self {
        ObjectsHeader {
            version,
            epoch,
            count: count as u64,
            selected: selection.map_or(0, |s| s.object),
            selected_polygon: selection
                .and_then(|s| s.polygon)
                .map_or(NO_POLYGON, u64::from),
        }
    }
    /// The selection this header carries.
    pub fn selection(&self) -> Option<crate::Selection> {
        (self.selected != 0).then(|| crate::Selection {
            object: self.selected,
            polygon: u32::try_from(self.selected_polygon).ok(),
        })
    }
}

/// Objects per object chunk: the pose partition, so that object `i` is in chunk
/// `i / OBJECT_CHUNK` of both. A structural change to one object republishes its chunk (≈ 84 KB
/// of records and names) and one word per chunk.
pub const OBJECT_CHUNK: usize = POSE_CHUNK;

/// An object chunk: section 0 this header, section 1 the [`ObjectRec`]s of objects
/// `first..first + count` (object order), section 2 their names, section 3 (`u64`) the index in
/// the chunk of each object with geometry, ascending.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct ObjectChunkHeader {
    /// The structure version at which this chunk was last published.
    pub generation: u64,
    /// Index of the first object in this chunk.
    pub first: u64,
    pub count: u64,
}

/// Where one chunk's segment is in a bundle's words: the key (an object chunk's index, or in a
/// geometry bundle the object's id), its generation, and its word range.
pub type ChunkEntry = GeometryEntry;

/// An object chunk an objects head carries as record patches (section 4 of an objects
/// publication): the chunk at `generation` is the chunk as it was carried whole at any
/// generation from `since` to `generation` (in an objects head, or in the objects base) with
/// the records `start..start + len` of section 5 put in place — every record that changed since
/// it was last carried whole at `since` (nothing else of the chunk changed: its length, names
/// and geometry index are those of `since`). A one-record change at 10⁵ objects is then
/// published as one record, not as its chunk of [`OBJECT_CHUNK`] records (84 kB).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PatchEntry {
    /// The object chunk's index.
    pub chunk: u64,
    /// Its generation with the patches put in place.
    pub generation: u64,
    /// The generation at which it was last carried whole (its lineage).
    pub since: u64,
    /// First record and count in section 5.
    pub start: u64,
    pub len: u64,
}

/// One patched record: its index in its chunk, and the record (its id, name, origin and
/// geometry flag those of the record it replaces).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PatchRec {
    pub index: u64,
    pub rec: ObjectRec,
}

/// The most records an objects head carries as patches of one chunk: past this many records
/// changed since the chunk was last carried whole, the chunk is carried whole again (and a new
/// lineage starts). 16 × 336 B, against 84 kB for a chunk of [`OBJECT_CHUNK`] records.
pub const OBJECT_PATCH_MAX: usize = 16;

/// `ObjectRec::flags` bits.
pub mod flags {
    pub const HAS_KINEMATICS: u32 = 1;
    pub const HAS_DYNAMICS: u32 = 2;
    pub const HAS_GEOMETRY: u32 = 4;
    /// `kin_tag`: the kinematics record is a joint (else a robot).
    pub const KIN_JOINT: u32 = 1;
    pub const KIN_ROBOT: u32 = 2;
    /// `kin_tag`: the kinematics record is a general joint (placement and axis).
    pub const KIN_AXIS: u32 = 3;
    /// `kin_tag`: a general joint that follows another (`Kinematics::Mimic`): as
    /// [`KIN_AXIS`], with `joint_kind` holding the joint kind in its low 8 bits and the
    /// leader's index + 1 above them (0: no leader), `dh[3]` the multiplier and `dh[4]` the
    /// mimic offset. No field of the record changes: the layout is the same.
    pub const KIN_MIMIC: u32 = 4;
}

/// One object, every aspect but its geometry (which has its own segment) and its pose
/// (which is in the poses segment at the same index).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct ObjectRec {
    pub id: u64,
    pub parent: u64,
    /// [`crate::Kind`] as u32.
    pub kind: u32,
    /// [`flags`].
    pub flags: u32,
    /// Byte range of the name in the names section.
    pub name_off: u32,
    pub name_len: u32,
    pub geom_gen: u64,
    /// RGBA, 0..1.
    pub color: [f32; 4],
    /// diffuse, specular, shininess, unused.
    pub surface: [f32; 4],
    /// `flags::KIN_JOINT`, `flags::KIN_ROBOT` or `flags::KIN_AXIS` (0 = none).
    pub kin_tag: u32,
    /// Joint and general joint: [`crate::JointKind`]; robot: unused.
    pub joint_kind: u32,
    /// Joint and robot: [`crate::DhConvention`]; general joint: the parent link frame
    /// (`Kinematics::Axis::parent`).
    pub convention: u32,
    /// Joint and general joint: index in q; robot: IK family.
    pub index_or_family: u32,
    /// Joint: a, d, alpha, theta, offset, qlo, qhi (m, rad). General joint: axis x, y, z,
    /// unused, offset, qlo, qhi.
    pub dh: [f64; 7],
    /// Robot: tool transform; general joint: placement. 3×4 row-major.
    pub tool: [f64; 12],
    pub mass: f64,
    pub com: [f64; 3],
    /// xx, yy, zz, xy, xz, yz about the centre of mass.
    pub inertia: [f64; 6],
    /// Byte range of the origin record (instances only) in the names section.
    pub origin_off: u32,
    pub origin_len: u32,
}

/// The poses head: section 0 this header, section 1 one `u64` per pose chunk — the model
/// version at which that chunk was last published (its generation). A reader assembles the
/// poses of this version from the chunk samples with exactly these generations.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PosesHeader {
    /// The model version of this publication (the newest committed version).
    pub version: u64,
    /// The structure version (objects head) these poses are indexed against.
    pub structure_version: u64,
    pub epoch: u64,
    pub count: u64,
    /// Records per chunk (every chunk but the last is full).
    pub chunk_len: u64,
}

/// Objects per pose chunk: a one-body pose transaction republishes one chunk of this many
/// records (28 KiB) and a head of one word per chunk, so at 10⁵ objects the keeper copies
/// ≈ 31 KiB per commit instead of 11 MiB.
pub const POSE_CHUNK: usize = 256;

/// A pose chunk: section 0 this header, section 1 the [`PoseRec`]s of objects
/// `first..first + count` (object order).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PoseChunkHeader {
    pub epoch: u64,
    /// The model version at which this chunk was published.
    pub generation: u64,
    /// Index of the first object in this chunk.
    pub first: u64,
    pub count: u64,
}

/// Local pose of the object at the same index in object order.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PoseRec {
    pub id: u64,
    /// 3×4 row-major [R | t] relative to the parent.
    pub pose: [f64; 12],
    /// Link joint value (rad or m).
    pub joint: f64,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct GeometryHeader {
    pub id: u64,
    pub generation: u64,
    /// bbox centre and half-diagonal.
    pub bbox: [f64; 6],
}

/// The header of a geometry bundle: section 0 this header, section 1 one [`GeometryEntry`] per
/// object (ascending id), section 2 (words) the objects' geometry segments end to end.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct GeometryBundleHeader {
    pub epoch: u64,
    /// The base: the structure version it was taken at (it holds every object's geometry as of
    /// then). An update: the version of the last commit whose geometry it carries.
    pub version: u64,
    pub count: u64,
}

/// Where one object's geometry segment is in a bundle's section 2.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct GeometryEntry {
    pub id: u64,
    /// The object's geometry generation ([`ObjectRec::geom_gen`]).
    pub generation: u64,
    /// First word and length in words.
    pub start: u64,
    pub len: u64,
}

/// The largest geometry update, in words (1 MiB): a group of commits that changes more
/// geometry than this (a scene loaded at once) publishes no update; readers take the base.
pub const GEOMETRY_UPDATE_MAX_WORDS: usize = 1 << 17;

/// A polygon record: `indices[start..start+len]`, its plane `n·p + d = 0` as [nx, ny, nz, d].
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PolygonRec {
    pub start: u32,
    pub len: u32,
    pub plane: [f64; 4],
}

/// One committed transaction as announced.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct ChangeRec {
    pub version: u64,
    /// [`crate::aspect`] bits.
    pub aspects: u64,
    /// Range of this record's ids in the ids section.
    pub ids_start: u64,
    pub ids_len: u64,
    /// CLOCK_MONOTONIC ns when the keeper published it (for latency measurement).
    pub published_ns: u64,
}

/// Encodes text files as a segment: section 0 holds `[name_off, name_len, text_off,
/// text_len]` per file, section 1 the bytes.
pub fn encode_files(files: &[(String, String)]) -> Vec<u64> {
    encode_library(files, None)
}

/// The Library Space's publication: [`encode_files`] and, as section 2, the checked library's
/// encoding (opaque here; `robosim_library::Library::encode_checked`). A reader that knows
/// only sections 0 and 1 reads the files as before.
pub fn encode_library(files: &[(String, String)], checked: Option<&[u8]>) -> Vec<u64> {
    let mut index: Vec<[u64; 4]> = Vec::with_capacity(files.len());
    let mut bytes = Vec::new();
    for (name, text) in files {
        index.push([
            bytes.len() as u64,
            name.len() as u64,
            (bytes.len() + name.len()) as u64,
            text.len() as u64,
        ]);
        bytes.extend_from_slice(name.as_bytes());
        bytes.extend_from_slice(text.as_bytes());
    }
    let mut w = SegmentWriter::new();
    w.push(&index).push(&bytes);
    if let Some(c) = checked {
        w.push(c);
    }
    w.to_vec()
}

/// The checked library's encoding in a publication of [`encode_library`], if it has one.
pub fn decode_library_checked(words: &[u64]) -> Result<Option<Vec<u8>>, LayoutError> {
    let seg = Segment::parse(words)?;
    match seg.section::<u8>(2) {
        Ok(b) => Ok(Some(b.to_vec())),
        Err(LayoutError::Missing(_)) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Decodes [`encode_files`] (and the files of [`encode_library`]).
pub fn decode_files(words: &[u64]) -> Result<Vec<(String, String)>, LayoutError> {
    let seg = Segment::parse(words)?;
    let index: &[[u64; 4]] = seg.section(0)?;
    let bytes: &[u8] = seg.section(1)?;
    let text = |off: u64, len: u64| -> Result<String, LayoutError> {
        let r = bytes
            .get(off as usize..(off + len) as usize)
            .ok_or(LayoutError::Section(1))?;
        String::from_utf8(r.to_vec()).map_err(|_| LayoutError::Section(1))
    };
    index
        .iter()
        .map(|i| Ok((text(i[0], i[1])?, text(i[2], i[3])?)))
        .collect()
}

/// Geometry segment sections.
pub mod geometry_sections {
    pub const HEADER: usize = 0;
    pub const VERTICES: usize = 1;
    pub const INDICES: usize = 2;
    pub const PENALTY: usize = 3;
    pub const POLYGONS: usize = 4;
    pub const EDGES: usize = 5;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_round_trip_with_alignment() {
        let a: [u32; 3] = [1, 2, 3];
        let b: [[f64; 3]; 2] = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]];
        let c: [u8; 5] = *b"hello";
        let mut w = SegmentWriter::new();
        w.push(&a).push(&b).push(&c);
        let v = w.to_vec();
        let s = Segment::parse(&v).expect("parse");
        assert_eq!(s.section::<u32>(0).expect("a"), &a);
        assert_eq!(s.section::<[f64; 3]>(1).expect("b"), &b);
        assert_eq!(s.section::<u8>(2).expect("c"), b"hello");
        assert!(s.section::<u8>(3).is_err());
        assert!(Segment::parse(&[1, 2]).is_err());
    }

    #[test]
    fn record_sizes_have_no_padding() {
        assert_eq!(std::mem::size_of::<ObjectRec>(), 328);
        assert_eq!(std::mem::size_of::<PoseRec>(), 112);
        assert_eq!(std::mem::size_of::<PolygonRec>(), 40);
        assert_eq!(std::mem::size_of::<PatchRec>(), 336);
    }
}
