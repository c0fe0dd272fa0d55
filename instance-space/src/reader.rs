//! Readers: map the keeper's published model and follow its changes.
//!
//! A [`Snapshot`] holds the iceoryx2 samples of one consistent version — the pose chunks the
//! poses head names, the object chunks of the structure version it is indexed against, and the
//! geometry those objects reference — and views them in place: reading the model copies nothing, whatever its size. Holding a
//! snapshot keeps its version alive while the keeper publishes newer ones (up to
//! `MAX_HELD_SNAPSHOTS` older snapshots per reader at a time). An object chunk whose records
//! alone changed is the whole chunk it held (the same memory) with those records, copied out of
//! the objects head that carried them as patches ([`crate::layout::PatchEntry`]), put in place.
//!
//! [`Reader::wait_change`] blocks (with a timeout) on the keeper's change event and returns the
//! change records — version, aspects, ids — in order; [`Reader::changes_since`] answers "what
//! changed since version N" from the records this reader has seen.

use crate::keeper::events;
use crate::layout::{
    ChangeRec, ChunkEntry, GeometryBundleHeader, GeometryHeader, LayoutError, OBJECT_CHUNK,
    ObjectChunkHeader, ObjectRec, ObjectsHeader, POSE_CHUNK, PatchEntry, PatchRec, PolygonRec,
    PoseChunkHeader, PoseRec, PosesHeader, Segment, flags, geometry_sections as gs,
};
use crate::object::{Id, Kind};
use crate::services;
use crate::session::{Session, SessionError};
use iceoryx2::prelude::*;
use std::collections::{HashMap, VecDeque};
use std::rc::Rc;
use std::time::{Duration, Instant};

mod groups;
use groups::Groups;

type Sample = iceoryx2::sample::Sample<ipc::Service, [u64], ()>;
type Sub = iceoryx2::port::subscriber::Subscriber<ipc::Service, [u64], ()>;

/// How many change records a reader remembers for [`Reader::changes_since`].
const CHANGE_LOG: usize = 1 << 16;

#[derive(Debug, thiserror::Error)]
pub enum ReaderError {
    #[error(transparent)]
    Session(#[from] SessionError),
    /// A keeper's service could not be opened: none runs, or (`cause`) iceoryx2 refused it.
    #[error("no keeper is running in session {session} (opening its {service} service: {cause})")]
    NoKeeper {
        session: String,
        service: String,
        #[source]
        cause: crate::error::Cause,
    },
    #[error("the keeper published nothing within {0:?}")]
    Timeout(Duration),
    #[error("a published segment is malformed: {0}")]
    Layout(#[from] LayoutError),
    #[error(
        "changes before version {oldest} are no longer known to this reader (asked for changes since {since}); take a new snapshot"
    )]
    ChangesLost { since: u64, oldest: u64 },
    #[error("this reader holds too many snapshots; drop old ones before taking a new one")]
    TooManySnapshotsHeld,
    /// The session's keeper serves at most `limit` readers at once and that many are attached
    /// (each `robosim query`, display, simulator, rules process is one).
    #[error(
        "session {session} already has its limit of {limit} readers attached; stop one, or start the session's keeper with more ({}=N robosim up …)",
        crate::MAX_CLIENTS_ENV
    )]
    TooManyReaders { session: String, limit: usize },
    /// iceoryx2 refused `what`; its error is the source (matched by variant where it matters).
    #[error("iceoryx2 {what}: {source}")]
    Ipc {
        what: String,
        #[source]
        source: crate::error::Cause,
    },
}

/// The error of an iceoryx2 call doing `what`. `what` is formatted only when the call fails:
/// the follow path (every change: the changes, the poses head, the pose base, each changed
/// chunk) names what it receives without a `String` per call (issue 37 item 5: those
/// allocations and formats were a fifth of a follower's instructions per change).
fn ipc<E: std::error::Error + Send + Sync + 'static>(
    what: impl std::fmt::Display,
) -> impl FnOnce(E) -> ReaderError {
    move |e| ReaderError::Ipc {
        what: what.to_string(),
        source: Box::new(e),
    }
}

/// A subscriber's receive error: holding too many samples (snapshots) by its variant, any
/// other as [`ReaderError::Ipc`] (`what` formatted only then, see [`ipc`]).
fn receive_err(
    what: impl std::fmt::Display,
) -> impl FnOnce(iceoryx2::port::ReceiveError) -> ReaderError {
    move |e| match e {
        iceoryx2::port::ReceiveError::ExceedsMaxBorrows => ReaderError::TooManySnapshotsHeld,
        e => ipc(what)(e),
    }
}

/// `"{0}{1}"`, formatted when displayed: an error context built on the hot path without
/// allocating ([`ipc`]).
struct Joined<A, B>(A, B);

impl<A: std::fmt::Display, B: std::fmt::Display> std::fmt::Display for Joined<A, B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}", self.0, self.1)
    }
}

/// One committed transaction as announced by the keeper.
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    pub version: u64,
    /// [`crate::aspect`] bits.
    pub aspects: u64,
    pub ids: Vec<Id>,
    /// CLOCK_MONOTONIC ns when the keeper published it.
    pub published_ns: u64,
}

/// One consistent version of the model, viewed in place in shared memory.
pub struct Snapshot {
    version: u64,
    epoch: u64,
    /// The objects' header (structure version, count, selection) and every object chunk's
    /// generation, as the objects head named them; shared by the snapshots of one structure
    /// version.
    head: Rc<ObjectsHead>,
    /// The object chunks of that structure version, in object order ([`OBJECT_CHUNK`] objects
    /// each, the last maybe fewer): where each one's records, names and geometry index are. A
    /// chunk unchanged between structure versions is the same memory in the snapshots of both;
    /// the list itself is shared by the snapshots of one structure version (a pose change
    /// copies no per-chunk handle), and by groups between structure versions (a one-chunk
    /// change copies one group of handles, [`groups`]).
    objects: Groups<ObjSrc>,
    /// The object chunks (indices, ascending) viewed in place in the sample of the objects
    /// head that carried them rather than copied out of it; every other chunk is a copy or a
    /// range of an objects base. Shared like `head`.
    head_views: Rc<Vec<usize>>,
    /// [`Snapshot::objects`] as one slice, assembled on first use when there are several
    /// chunks; shared by the snapshots of one structure version (so a pose change does not
    /// assemble it again).
    objects_flat: Rc<std::cell::OnceCell<Vec<ObjectRec>>>,
    /// Where each pose chunk of this version is, in object order (one chunk holding every pose
    /// for a process-local snapshot): its own chunk sample, or its range of a pose base. A
    /// chunk unchanged between versions is the same sample, shared by the snapshots of both;
    /// the list is shared by groups like `objects`.
    poses: Groups<PoseSrc>,
    /// Each pose chunk's generation as the poses head this snapshot was assembled from named
    /// it (every chunk of `poses` is at it); empty for a snapshot not assembled from a poses
    /// head (process-local, advanced). The next follow finds the pose chunks that changed by
    /// comparing these words with the new head's, a pass over two plain arrays, instead of
    /// walking the chunk handles group by group (at 10⁵ objects that walk grew with the model
    /// in every follow, a one-body geometry change's included: issue 37 item 6).
    pose_gens: Rc<Vec<u64>>,
    /// Records per chunk (≥ 1).
    chunk_len: usize,
    /// [`Snapshot::poses`] as one slice, assembled on first use when there are several chunks.
    flat: std::cell::OnceCell<Vec<PoseRec>>,
    /// By object chunk, then index in it; `None` for objects without geometry. A chunk's table
    /// is shared by the snapshots that share the chunk (a pose change touches none); a chunk
    /// with no geometry at all has an empty table. The list is shared like `objects`.
    geometry: Groups<Table>,
}

/// An objects head as a reader keeps it: the header and the chunks' generations (copied).
struct ObjectsHead {
    header: ObjectsHeader,
    gens: Vec<u64>,
}

/// One segment a snapshot uses — an object's geometry, an object chunk: all of `words` (a copy
/// this process owns), or words `start..start + len` of section `section` of a bundle (a
/// geometry or objects base, viewed in place). Bounds were checked when the snapshot was
/// assembled.
#[derive(Clone)]
struct SegSrc {
    words: Rc<Words>,
    /// (section, start, len) in a bundle; `None`: the whole of `words`.
    range: Option<(usize, usize, usize)>,
    generation: u64,
}

/// An object's geometry segment.
type GeomSrc = SegSrc;

/// An object chunk of a snapshot: its segment as published whole (`seg`, at generation
/// `seg.generation`), and the records an objects head patched since ([`PatchEntry`]) — the
/// chunk at `generation` is `seg` with `patches` put in place. Its length, names and geometry
/// index are `seg`'s (a patch changes none of them, and every patched record has the id, name,
/// origin and geometry flag of the record it replaces: checked when the snapshot was
/// assembled, [`ObjSrc::check_patches`]).
#[derive(Clone)]
struct ObjSrc {
    seg: SegSrc,
    patches: Option<Rc<Patches>>,
    generation: u64,
}

/// The records patched in an object chunk: their indices (ascending) and the records, copied
/// out of the objects head that carried them (at most [`crate::layout::OBJECT_PATCH_MAX`]).
struct Patches {
    at: Vec<usize>,
    recs: Vec<ObjectRec>,
}

impl Patches {
    /// The patched record at index `j`, if `j` is patched.
    fn get(&self, j: usize) -> Option<&ObjectRec> {
        let p = self.at.binary_search(&j).ok()?;
        self.recs.get(p)
    }
}
/// An object chunk's geometry table: by index in the chunk, `None` for objects without; shared
/// by groups ([`Groups`]), so that the table of a chunk whose one object's geometry changed is
/// the old one with one group copied, not 256 handles copied.
type Table = Groups<Option<GeomSrc>>;

/// A changed chunk's geometry table while it is assembled.
enum NewTable {
    /// No object of the chunk has geometry: the shared empty table.
    Empty,
    /// Built slot by slot.
    Fresh(Vec<Option<GeomSrc>>),
    /// The chunk's old table (its objects with geometry at the same places), slots replaced.
    From(Table),
}

impl NewTable {
    fn set(&mut self, j: usize, g: GeomSrc) {
        match self {
            NewTable::Empty => {}
            NewTable::Fresh(v) => {
                if let Some(slot) = v.get_mut(j) {
                    *slot = Some(g);
                }
            }
            NewTable::From(t) => {
                t.set(j, Some(g));
            }
        }
    }
}

impl SegSrc {
    fn owned(words: Vec<u64>, generation: u64) -> SegSrc {
        SegSrc {
            words: Rc::new(Words::Owned(words)),
            range: None,
            generation,
        }
    }
    /// The segment's words, or why they are not where `range` says.
    fn seg_words(&self) -> Result<&[u64], ReaderError> {
        let all = self.words.words();
        match self.range {
            None => Ok(all),
            Some((section, start, len)) => {
                let data = Segment::parse(all)?.section::<u64>(section)?;
                Ok(start
                    .checked_add(len)
                    .and_then(|end| data.get(start..end))
                    .ok_or(LayoutError::Section(section))?)
            }
        }
    }
    fn segment(&self) -> Option<Segment<'_>> {
        Segment::parse(self.seg_words().ok()?).ok()
    }
}

impl ObjSrc {
    /// The chunk as published whole (no patches).
    fn whole(seg: SegSrc) -> ObjSrc {
        ObjSrc {
            generation: seg.generation,
            seg,
            patches: None,
        }
    }
    fn owned(words: Vec<u64>, generation: u64) -> ObjSrc {
        ObjSrc::whole(SegSrc::owned(words, generation))
    }
    /// The whole segment (checked when the snapshot was assembled, [`ObjSrc::check`]).
    fn chunk(&self) -> Segment<'_> {
        // (a closure: `unreachable_segment` as a fn item would pin the lifetime to 'static)
        #[allow(clippy::redundant_closure)]
        self.seg.segment().unwrap_or_else(|| unreachable_segment())
    }
    /// The whole segment's records: the chunk's but for the patched ones, which have the same
    /// ids (so a search by id may use these).
    fn base_records(&self) -> &[ObjectRec] {
        self.chunk().section(1).unwrap_or(&[])
    }
    /// The chunk's record `j`, patched or not. Panics if `j` is out of range, like indexing.
    fn rec(&self, j: usize) -> &ObjectRec {
        match self.patches.as_ref().and_then(|p| p.get(j)) {
            Some(r) => r,
            None => &self.base_records()[j],
        }
    }
    /// The chunk's record `j`, if it has one.
    fn get(&self, j: usize) -> Option<&ObjectRec> {
        let base = self.base_records().get(j)?;
        Some(self.patches.as_ref().and_then(|p| p.get(j)).unwrap_or(base))
    }
    /// The chunk's records, patched, after those of `out`.
    fn extend_records(&self, out: &mut Vec<ObjectRec>) {
        let start = out.len();
        out.extend_from_slice(self.base_records());
        if let Some(p) = &self.patches {
            for (&j, r) in p.at.iter().zip(&p.recs) {
                if let Some(slot) = out.get_mut(start + j) {
                    *slot = *r;
                }
            }
        }
    }
    /// An object chunk's names.
    fn names(&self) -> &[u8] {
        self.chunk().section(2).unwrap_or(&[])
    }
    /// An object chunk's geometry index: the indices in it of the objects with geometry.
    fn geometry_index(&self) -> &[u64] {
        self.chunk().section(3).unwrap_or(&[])
    }
    /// Whether `other` has the same whole segment (the same memory: it was checked once).
    fn same_whole(&self, other: &ObjSrc) -> bool {
        Rc::ptr_eq(&self.seg.words, &other.seg.words) && self.seg.range == other.seg.range
    }
    /// Checks the patches against the whole segment's records (checked already): each patched
    /// record replaces one of them and keeps its id, name, origin and geometry flag — so that
    /// the names, the geometry index and a search by id read the whole segment.
    fn check_patches(&self) -> Result<(), ReaderError> {
        let Some(p) = &self.patches else {
            return Ok(());
        };
        let base = self.base_records();
        for (&j, r) in p.at.iter().zip(&p.recs) {
            let b = base.get(j).ok_or(LayoutError::Section(5))?;
            if r.id != b.id
                || (r.name_off, r.name_len) != (b.name_off, b.name_len)
                || (r.origin_off, r.origin_len) != (b.origin_off, b.origin_len)
                || (r.flags ^ b.flags) & flags::HAS_GEOMETRY != 0
            {
                return Err(LayoutError::Section(5).into());
            }
        }
        Ok(())
    }
    /// Checks this is object chunk `k` of `count` objects with its sections in bounds, its
    /// geometry index sound and its patches fitting it; returns its objects with geometry:
    /// (index in the chunk, id, geometry generation), patched.
    fn check(&self, k: usize, count: usize) -> Result<Vec<(usize, Id, u64)>, ReaderError> {
        let seg = Segment::parse(self.seg.seg_words()?)?;
        let h: ObjectChunkHeader = *seg.record(0)?;
        let recs = seg.section::<ObjectRec>(1)?;
        // Names are read with bounds checks ([`Snapshot::name`]); the records are not all
        // touched here (at 10⁵ objects that faulted in 32 MB of shared memory per attach).
        seg.section::<u8>(2)?;
        if h.first as usize != k * OBJECT_CHUNK || h.count as usize != count || recs.len() != count
        {
            return Err(LayoutError::Section(1).into());
        }
        self.check_patches()?;
        let mut out: Vec<(usize, Id, u64)> = Vec::new();
        for &j in seg.section::<u64>(3)? {
            let r = recs.get(j as usize).ok_or(LayoutError::Section(3))?;
            if r.flags & flags::HAS_GEOMETRY == 0 || out.last().is_some_and(|l| l.0 >= j as usize) {
                return Err(LayoutError::Section(3).into());
            }
            let r = self.rec(j as usize);
            out.push((j as usize, r.id, r.geom_gen));
        }
        Ok(out)
    }
}

/// One pose chunk of a snapshot: records `first..first + count` of section `section` of
/// `words` (a chunk segment: section 1 from 0; a pose base: section 2 from the chunk's first
/// object). Bounds were checked when the snapshot was assembled.
#[derive(Clone)]
struct PoseSrc {
    words: Rc<Words>,
    section: usize,
    first: usize,
    count: usize,
    /// The chunk's generation (the version it was published at).
    generation: u64,
}

impl PoseSrc {
    /// A whole chunk segment (section 1).
    fn chunk(words: Rc<Words>, count: usize, generation: u64) -> PoseSrc {
        PoseSrc {
            words,
            section: 1,
            first: 0,
            count,
            generation,
        }
    }
    fn records(&self) -> &[PoseRec] {
        Snapshot::seg(&self.words)
            .section::<PoseRec>(self.section)
            .ok()
            .and_then(|s| s.get(self.first..self.first + self.count))
            .unwrap_or(&[])
    }
}

/// A segment's words: a sample in shared memory, or (for [`Snapshot::from_store`]) a copy
/// owned by this process.
enum Words {
    Shared(Sample),
    Owned(Vec<u64>),
}

impl Words {
    fn words(&self) -> &[u64] {
        match self {
            Words::Shared(s) => s.payload(),
            Words::Owned(v) => v,
        }
    }
}

/// Geometry of one object, in place.
#[derive(Clone, Copy)]
pub struct GeometryView<'a> {
    pub header: &'a GeometryHeader,
    pub vertices: &'a [[f64; 3]],
    pub indices: &'a [u32],
    /// One per entry of `indices`: [nx, ny, nz, d] of that polygon side's penalty plane.
    pub penalty: &'a [[f64; 4]],
    pub polygons: &'a [PolygonRec],
    pub edges: &'a [[u32; 2]],
}

/// One object with its pose and name.
#[derive(Clone, Copy)]
pub struct ObjectView<'a> {
    pub rec: &'a ObjectRec,
    pub pose: &'a PoseRec,
    pub name: &'a str,
}

impl ObjectView<'_> {
    pub fn kind(&self) -> Option<Kind> {
        Kind::from_u32(self.rec.kind)
    }
}

impl Snapshot {
    fn seg(s: &Words) -> Segment<'_> {
        // Segments were validated when the snapshot was assembled.
        Segment::parse(s.words()).unwrap_or_else(|_| unreachable_segment())
    }

    /// A process-local snapshot of a plain [`Store`](crate::Store), with the same records and
    /// views as a published one (epoch 0), its poses in chunks of [`POSE_CHUNK`] as a keeper
    /// publishes them. For tools that evaluate a model without a session — `robosim render` —
    /// so they read it through the one API the session readers use.
    pub fn from_store(model: &crate::Store) -> Snapshot {
        let segs = crate::encode::model_segments(model, 0);
        let poses = Groups::from_vec(
            segs.poses
                .chunks(POSE_CHUNK)
                .enumerate()
                .map(|(k, recs)| Self::owned_chunk(0, model.version, k * POSE_CHUNK, recs))
                .collect(),
        );
        let generation = segs.objects_header.version;
        let geometry: Vec<Option<GeomSrc>> = segs
            .geometry
            .into_iter()
            .zip(model.objects())
            .map(|(g, o)| g.map(|w| GeomSrc::owned(w, o.geom_gen)))
            .collect();
        Snapshot {
            version: model.version,
            epoch: 0,
            head: Rc::new(ObjectsHead {
                header: segs.objects_header,
                gens: vec![generation; segs.object_chunks.len()],
            }),
            objects: Groups::from_vec(
                segs.object_chunks
                    .into_iter()
                    .map(|w| ObjSrc::owned(w, generation))
                    .collect(),
            ),
            head_views: Rc::default(),
            objects_flat: Rc::default(),
            poses,
            pose_gens: Rc::default(),
            chunk_len: POSE_CHUNK,
            flat: std::cell::OnceCell::new(),
            geometry: Groups::from_vec(
                geometry
                    .chunks(OBJECT_CHUNK)
                    .map(|c| Groups::from_vec(c.to_vec()))
                    .collect(),
            ),
        }
    }

    /// A pose chunk segment of `recs` (objects `first..`) owned by this process.
    fn owned_chunk(epoch: u64, generation: u64, first: usize, recs: &[PoseRec]) -> PoseSrc {
        let header = [crate::encode::pose_chunk_header(
            epoch,
            generation,
            first,
            recs.len(),
        )];
        let words = crate::encode::pose_chunk_writer(&header, recs).to_vec();
        PoseSrc::chunk(Rc::new(Words::Owned(words)), recs.len(), generation)
    }

    /// A process-local copy of this snapshot in which the objects of `overrides` have the
    /// given local poses and joint values — what the simulator publishes as its high-rate state
    /// (link poses relative to the robot) — sharing the object chunks, the geometry and every
    /// pose chunk no override falls in with this one. Ids the snapshot does not hold are
    /// ignored. O(overrides + touched chunks × chunk length + chunks).
    pub fn with_poses(&self, overrides: &[PoseRec]) -> Snapshot {
        self.advanced(self.version, overrides)
    }

    /// This snapshot moved on to `version` by pose-only changes: [`Snapshot::with_poses`] at
    /// another version — what a reader following pose-only commits assembles, for tools that
    /// replay such changes without a session (and `robosim bench display`).
    pub fn advanced(&self, version: u64, overrides: &[PoseRec]) -> Snapshot {
        let chunk_len = self.chunk_len.max(1);
        let mut touched: std::collections::BTreeMap<usize, Vec<PoseRec>> = Default::default();
        for o in overrides {
            let Some(i) = self.index_of(o.id) else {
                continue;
            };
            let k = i / chunk_len;
            let recs = touched.entry(k).or_insert_with(|| self.chunk(k).to_vec());
            if let Some(r) = recs.get_mut(i % chunk_len) {
                r.pose = o.pose;
                r.joint = o.joint;
            }
        }
        let mut poses = self.poses.clone();
        for (k, recs) in touched {
            poses.set(
                k,
                Self::owned_chunk(self.epoch, version, k * chunk_len, &recs),
            );
        }
        Snapshot {
            version,
            epoch: self.epoch,
            head: self.head.clone(),
            objects: self.objects.clone(),
            head_views: self.head_views.clone(),
            objects_flat: self.objects_flat.clone(),
            poses,
            pose_gens: Rc::default(),
            chunk_len,
            flat: std::cell::OnceCell::new(),
            geometry: self.geometry.clone(),
        }
    }
    /// The newest version this snapshot includes.
    pub fn version(&self) -> u64 {
        self.version
    }
    /// The keeper's start time; changes when the keeper restarts.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }
    pub fn len(&self) -> usize {
        self.head.header.count as usize
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub(crate) fn objects_header(&self) -> ObjectsHeader {
        self.head.header
    }
    /// The session's selection at this version (the display's last pick), if any.
    pub fn selection(&self) -> Option<crate::Selection> {
        self.objects_header().selection()
    }
    /// Every object, sorted by id. In place when the model fits one object chunk as it was
    /// published whole; otherwise (several chunks, or records patched since) the chunks are
    /// copied into one array on the first call (O(objects), once per structure version: the
    /// snapshots of pose changes share it) — [`Snapshot::rec`], [`Snapshot::object`] and
    /// [`Snapshot::index_of`] read in place.
    pub fn objects(&self) -> &[ObjectRec] {
        match self.objects.first() {
            None => &[],
            Some(c) if self.objects.len() == 1 && c.patches.is_none() => c.base_records(),
            Some(_) => self.objects_flat.get_or_init(|| {
                let mut v = Vec::with_capacity(self.len());
                for c in self.objects.iter() {
                    c.extend_records(&mut v);
                }
                v
            }),
        }
    }
    /// The record of object `i`, in place (a patched record where its objects head put it).
    /// Panics if `i` is out of range, like indexing.
    pub fn rec(&self, i: usize) -> &ObjectRec {
        self.objects[i / OBJECT_CHUNK].rec(i % OBJECT_CHUNK)
    }
    /// Every object's local pose, same order as [`Snapshot::objects`]. In place when the
    /// model fits one pose chunk or every chunk is still as in one pose base; otherwise the
    /// chunks are copied into one array on the first call (O(objects), once per snapshot) —
    /// [`Snapshot::pose`] reads one record in place.
    pub fn poses(&self) -> &[PoseRec] {
        match self.poses.first() {
            None => &[],
            Some(c) if self.poses.len() == 1 => c.records(),
            Some(c)
                if c.first == 0 && self.poses.iter().all(|o| Rc::ptr_eq(&o.words, &c.words)) =>
            {
                // Every chunk from the same base, in order: its whole section.
                let all: &[PoseRec] = Self::seg(&c.words).section(c.section).unwrap_or(&[]);
                all.get(..self.len()).unwrap_or(&[])
            }
            Some(_) => self.flat.get_or_init(|| {
                let mut v = Vec::with_capacity(self.len());
                for c in self.poses.iter() {
                    v.extend_from_slice(c.records());
                }
                v
            }),
        }
    }
    /// The local pose of object `i`, in place. Panics if `i` is out of range, like indexing.
    pub fn pose(&self, i: usize) -> &PoseRec {
        &self.chunk(i / self.chunk_len)[i % self.chunk_len]
    }
    fn chunk(&self, k: usize) -> &[PoseRec] {
        self.poses.get(k).map_or(&[], PoseSrc::records)
    }
    /// Bytes `off..off + len` of the names of object `i`'s chunk, as text.
    fn text(&self, i: usize, off: u32, len: u32) -> &str {
        let names = self.objects[i / OBJECT_CHUNK].names();
        names
            .get(off as usize..off as usize + len as usize)
            .and_then(|b| std::str::from_utf8(b).ok())
            .unwrap_or("")
    }
    pub fn name(&self, i: usize) -> &str {
        let r = self.rec(i);
        self.text(i, r.name_off, r.name_len)
    }
    /// The origin record of an instance (see [`crate::Op::SetOrigin`]); empty otherwise.
    pub fn origin(&self, i: usize) -> &str {
        let r = self.rec(i);
        self.text(i, r.origin_off, r.origin_len)
    }
    /// The index of object `id`: a binary search over the chunks' first ids, then in one chunk.
    pub fn index_of(&self, id: Id) -> Option<usize> {
        let k = self
            .objects
            .partition_point(|c| c.base_records().first().is_some_and(|r| r.id <= id))
            .checked_sub(1)?;
        // (a patched record has the id of the record it replaces)
        let j = self.objects[k]
            .base_records()
            .binary_search_by_key(&id, |r| r.id)
            .ok()?;
        Some(k * OBJECT_CHUNK + j)
    }
    pub fn object(&self, i: usize) -> ObjectView<'_> {
        ObjectView {
            rec: self.rec(i),
            pose: self.pose(i),
            name: self.name(i),
        }
    }
    /// The first object called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        (0..self.len()).find(|&i| self.name(i) == name)
    }
    /// The first object at `path`: names `/`-separated, the last the object's, those before it
    /// its parent's, grandparent's… (`spare_oru`, `port_solar/gimbal/oru0`); the path need not
    /// reach the root.
    pub fn find_path(&self, path: &str) -> Option<usize> {
        let names: Vec<&str> = path.split('/').collect();
        let (last, above) = names.split_last()?;
        (0..self.len()).find(|&i| {
            if self.name(i) != *last {
                return false;
            }
            let mut at = i;
            for want in above.iter().rev() {
                match self.index_of(self.rec(at).parent) {
                    Some(p) if self.name(p) == *want => at = p,
                    _ => return false,
                }
            }
            true
        })
    }
    fn geom_src(&self, i: usize) -> Option<&GeomSrc> {
        self.geometry
            .get(i / OBJECT_CHUNK)?
            .get(i % OBJECT_CHUNK)?
            .as_ref()
    }
    pub fn geometry(&self, i: usize) -> Option<GeometryView<'_>> {
        let seg = self.geom_src(i)?.segment()?;
        Some(GeometryView {
            header: seg.record(gs::HEADER).ok()?,
            vertices: seg.section(gs::VERTICES).ok()?,
            indices: seg.section(gs::INDICES).ok()?,
            penalty: seg.section(gs::PENALTY).ok()?,
            polygons: seg.section(gs::POLYGONS).ok()?,
            edges: seg.section(gs::EDGES).ok()?,
        })
    }
    /// Total vertices over all objects (a cheap whole-model read, used by benchmarks).
    pub fn vertex_count(&self) -> usize {
        (0..self.len())
            .filter_map(|i| self.geometry(i))
            .map(|g| g.vertices.len())
            .sum()
    }
    /// Pose of object `i` in the world: the product of local poses up the parent chain,
    /// 3×4 row-major.
    pub fn world_pose(&self, i: usize) -> [f64; 12] {
        let mut m = self.pose(i).pose;
        let mut parent = self.rec(i).parent;
        let mut guard = self.len();
        while parent != 0 && guard > 0 {
            let Some(p) = self.index_of(parent) else {
                break;
            };
            m = compose(&self.pose(p).pose, &m);
            parent = self.rec(p).parent;
            guard -= 1;
        }
        m
    }
}

/// `a · b` for 3×4 row-major rigid transforms.
pub fn compose(a: &[f64; 12], b: &[f64; 12]) -> [f64; 12] {
    let mut out = [0.0; 12];
    for r in 0..3 {
        for c in 0..4 {
            let mut s = if c == 3 { a[r * 4 + 3] } else { 0.0 };
            for k in 0..3 {
                s += a[r * 4 + k] * b[k * 4 + c];
            }
            out[r * 4 + c] = s;
        }
    }
    out
}

/// The newest sample `sub` holds (the older ones are released), if any.
fn newest(sub: &Sub, what: &str) -> Result<Option<Sample>, ReaderError> {
    let mut newest = None;
    while let Some(s) = sub
        .receive()
        .map_err(receive_err(Joined("receive ", what)))?
    {
        newest = Some(s);
    }
    Ok(newest)
}

fn unreachable_segment() -> Segment<'static> {
    static EMPTY: [u64; 2] = [crate::layout::MAGIC, 0];
    // EMPTY is a valid segment with no sections.
    Segment::parse(&EMPTY).unwrap_or_else(|_| unreachable_segment())
}

struct ChunkSub {
    sub: Sub,
    latest: Option<Rc<Words>>,
    epoch: u64,
    generation: u64,
    /// The (first object, count) `latest` was checked against: a chunk that did not change
    /// since is not parsed and checked again (a pose-only follow then costs one generation
    /// compare per unchanged chunk).
    checked: Option<(usize, usize)>,
}

/// A received pose base (see [`crate::layout`]), checked: its head and chunk generations.
struct Base {
    words: Rc<Words>,
    head: PosesHeader,
    gens: Vec<u64>,
}

impl Base {
    fn parse(s: Sample) -> Result<Base, ReaderError> {
        let words = Rc::new(Words::Shared(s));
        let (head, gens) = {
            let seg = Segment::parse(words.words())?;
            let head: PosesHeader = *seg.record(0)?;
            let gens = seg.section::<u64>(1)?.to_vec();
            let recs = seg.section::<PoseRec>(2)?.len();
            let chunk_len = head.chunk_len as usize;
            if chunk_len == 0
                || recs != head.count as usize
                || gens.len() != recs.div_ceil(chunk_len)
            {
                return Err(LayoutError::Section(2).into());
            }
            (head, gens)
        };
        Ok(Base { words, head, gens })
    }

    /// Chunk `k` (`count` records of `chunk_len` per chunk) as of generation `generation` of
    /// `epoch`, if this base holds it: same epoch and chunking, same generation.
    fn chunk(
        &self,
        k: usize,
        chunk_len: usize,
        count: usize,
        epoch: u64,
        generation: u64,
    ) -> Option<PoseSrc> {
        let first = k * chunk_len;
        (self.head.epoch == epoch
            && self.head.chunk_len as usize == chunk_len
            && self.gens.get(k) == Some(&generation)
            && first + count <= self.head.count as usize)
            .then(|| PoseSrc {
                words: self.words.clone(),
                section: 2,
                first,
                count,
                generation,
            })
    }
}

/// A reader asks for a pose base, rather than opening chunk services one by one, when it has no
/// snapshot yet (attaching) or more than this many chunks it follows no service of changed at
/// once (a keeper restart, a simulator that moved everything): opening one iceoryx2 service
/// costs milliseconds, a base one round trip.
const BASE_OVER: usize = 8;

/// A reader attaching takes the pose base it finds in the service's history (published for an
/// earlier joiner) and opens the services of the chunks changed since, rather than asking the
/// keeper for a fresh base, when a fresh base would hold more than this many records per chunk
/// to open. Measured here (release, 2 cores): opening a chunk service and receiving its history
/// 1.1–2.9 ms; the keeper's fresh base 1.0–1.2 ms at 10⁴ records and 3.7–12.5 ms at 10⁵ (its
/// samples' pages touched for the first time). So a late joiner of a model of 10⁵ bodies where
/// one chunk moved since the last base opens one service, and no keeper copies 11 MB for it;
/// one of 10³ bodies asks for a base.
const RECORDS_PER_OPEN: usize = 16_384;

/// One object's geometry as an update brought it (copied out of the update's sample).
struct GeomUpdate {
    epoch: u64,
    /// The update's version.
    version: u64,
    geometry: GeomSrc,
}

/// In a bundle (`entries` the section of its [`ChunkEntry`]s, ascending by key, the next section
/// their words): where `key` at `generation` is — (words section, first word, length) — if the
/// bundle holds it.
fn bundle_find(
    words: &[u64],
    entries: usize,
    key: u64,
    generation: u64,
) -> Result<Option<(usize, usize, usize)>, ReaderError> {
    let seg = Segment::parse(words)?;
    let list = seg.section::<ChunkEntry>(entries)?;
    let Ok(k) = list.binary_search_by_key(&key, |e| e.id) else {
        return Ok(None);
    };
    let e = list[k];
    if e.generation != generation {
        return Ok(None);
    }
    let (start, len) = (e.start as usize, e.len as usize);
    let data = seg.section::<u64>(entries + 1)?.len();
    if start.checked_add(len).is_none_or(|end| end > data) {
        return Err(LayoutError::Section(entries).into());
    }
    Ok(Some((entries + 1, start, len)))
}

/// Whether a base of keeper `epoch` at structure version `version` serves head `h`: of its
/// structure version or newer, or of a newer keeper (then a newer head follows).
fn serves_structure(h: &PosesHeader, epoch: u64, version: u64) -> bool {
    epoch > h.epoch || (epoch == h.epoch && version >= h.structure_version)
}

/// A received geometry bundle (a base), its header checked.
struct GeomBase {
    words: Rc<Words>,
    head: GeometryBundleHeader,
}

impl GeomBase {
    fn parse(s: Sample) -> Result<GeomBase, ReaderError> {
        let words = Rc::new(Words::Shared(s));
        let head = *Segment::parse(words.words())?.record::<GeometryBundleHeader>(0)?;
        Ok(GeomBase { words, head })
    }
}

/// Looks objects' geometry up in a geometry base in ascending id order, each search galloping
/// from where the last one ended: a late joiner of 10⁵ boxes made 10⁵ independent binary
/// searches over a 3 MB entry list, a cache miss per step.
struct BaseCursor<'a> {
    base: &'a GeomBase,
    list: &'a [ChunkEntry],
    /// Words in the base's data section.
    data: usize,
    at: usize,
}

impl GeomBase {
    fn cursor(&self) -> Result<BaseCursor<'_>, ReaderError> {
        let seg = Segment::parse(self.words.words())?;
        Ok(BaseCursor {
            base: self,
            list: seg.section::<ChunkEntry>(1)?,
            data: seg.section::<u64>(2)?.len(),
            at: 0,
        })
    }
}

impl BaseCursor<'_> {
    /// The geometry of object `id` at `generation` of `epoch`, if the base holds it; fastest
    /// when called with ascending ids.
    fn find(
        &mut self,
        epoch: u64,
        id: Id,
        generation: u64,
    ) -> Result<Option<GeomSrc>, ReaderError> {
        if self.base.head.epoch != epoch {
            return Ok(None);
        }
        let list = self.list;
        // From the last position if the entries before it are all below `id`, else from 0.
        let from = if self.at > 0 && list.get(self.at - 1).is_some_and(|e| e.id < id) {
            self.at
        } else {
            0
        };
        // Gallop to a bound `hi` with list[hi].id >= id (or the end); everything before `lo`
        // is below `id`.
        let (mut lo, mut hi, mut step) = (from, from, 1);
        while hi < list.len() && list[hi].id < id {
            lo = hi + 1;
            hi = from + step;
            step *= 2;
        }
        let hi = hi.min(list.len());
        let k = lo + list[lo..hi].partition_point(|e| e.id < id);
        self.at = k;
        let Some(e) = list
            .get(k)
            .filter(|e| e.id == id && e.generation == generation)
        else {
            return Ok(None);
        };
        let (start, len) = (e.start as usize, e.len as usize);
        if start.checked_add(len).is_none_or(|end| end > self.data) {
            return Err(LayoutError::Section(1).into());
        }
        Ok(Some(GeomSrc {
            words: self.base.words.clone(),
            range: Some((2, start, len)),
            generation,
        }))
    }
}

/// A received objects base, its header checked.
struct ObjBase {
    words: Rc<Words>,
    head: ObjectsHeader,
}

impl ObjBase {
    fn parse(s: Sample) -> Result<ObjBase, ReaderError> {
        let words = Rc::new(Words::Shared(s));
        let head = *Segment::parse(words.words())?.record::<ObjectsHeader>(0)?;
        Ok(ObjBase { words, head })
    }

    /// Object chunk `k` at `generation` of `epoch`, if this base holds it.
    fn find(&self, epoch: u64, k: usize, generation: u64) -> Result<Option<ObjSrc>, ReaderError> {
        if self.head.epoch != epoch {
            return Ok(None);
        }
        Ok(
            bundle_find(self.words.words(), 2, k as u64, generation)?.map(|range| {
                ObjSrc::whole(SegSrc {
                    words: self.words.clone(),
                    range: Some(range),
                    generation,
                })
            }),
        )
    }
}

/// An object chunk as an objects head brought it.
struct ObjUpdate {
    epoch: u64,
    /// The head's structure version.
    version: u64,
    chunk: Brought,
    /// The chunk's whole segment is viewed in a head's sample (the newest head received),
    /// not copied.
    in_head: bool,
}

/// What an objects head brought of one chunk.
enum Brought {
    /// The chunk: whole, or patches put on a whole segment of its lineage that an earlier
    /// pending update brought.
    Chunk(ObjSrc),
    /// Patches to put on the chunk's whole segment at a generation from `since` to
    /// `generation` ([`PatchEntry`]), which the snapshot being followed should hold.
    Patches {
        since: u64,
        generation: u64,
        patches: Rc<Patches>,
    },
}

impl Brought {
    fn generation(&self) -> u64 {
        match self {
            Brought::Chunk(c) => c.generation,
            Brought::Patches { generation, .. } => *generation,
        }
    }
    /// The chunk at its generation, `patches` put on `held` (the chunk as a snapshot holds
    /// it) when its whole segment is of the patches' lineage.
    fn resolve(&self, held: Option<&ObjSrc>) -> Option<ObjSrc> {
        match self {
            Brought::Chunk(c) => Some(c.clone()),
            Brought::Patches {
                since,
                generation,
                patches,
            } => {
                let seg = &held?.seg;
                (*since <= seg.generation && seg.generation <= *generation).then(|| ObjSrc {
                    seg: seg.clone(),
                    patches: Some(patches.clone()),
                    generation: *generation,
                })
            }
        }
    }
}

/// What a long-running follower (the simulator daemon, the display, the bridge) does with
/// its reader's errors: it does not exit on them. A malformed segment already makes the
/// reader attach again ([`Reader::refresh`]); any other error (the keeper killed between the
/// parts of a version, an iceoryx2 refusal) leaves the snapshot at the last good version and
/// the next pass tries again. Each trouble is said once on stderr — when it begins, when it
/// changes, when the reader attached again, and when following resumes — not once per pass.
#[derive(Debug, Default)]
pub struct FollowTrouble {
    said: Option<String>,
    reattached: u64,
}

impl FollowTrouble {
    /// [`Reader::refresh`] for a follower named `who`: whether the snapshot advanced; `false`
    /// on an error (said once).
    pub fn refresh(&mut self, who: &str, reader: &mut Reader) -> bool {
        let r = reader.refresh();
        let advanced = matches!(r, Ok(true));
        self.note(who, reader, r.map(|_| ()));
        advanced
    }

    /// Notes the outcome `r` of a reader call made by follower `who`; `true` when it went
    /// well.
    pub fn note(&mut self, who: &str, reader: &Reader, r: Result<(), ReaderError>) -> bool {
        let version = reader.snapshot().map_or(0, |s| s.version());
        if reader.reattachments() != self.reattached {
            self.reattached = reader.reattachments();
            eprintln!(
                "{who}: met a malformed published segment ({}); attached again, following from version {version}",
                reader.last_reattach_cause().unwrap_or("?")
            );
        }
        match r {
            Ok(()) => {
                if self.said.take().is_some() {
                    eprintln!("{who}: following the model again at version {version}");
                }
                true
            }
            Err(e) => {
                let message = e.to_string();
                if self.said.as_deref() != Some(message.as_str()) {
                    eprintln!(
                        "{who}: cannot follow the model ({message}); keeping version {version} and trying again"
                    );
                    self.said = Some(message);
                }
                false
            }
        }
    }

    /// Whether the last reader call noted went wrong.
    pub fn in_trouble(&self) -> bool {
        self.said.is_some()
    }
}

/// The Library Space as published ([`Reader::library`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LibraryPublication {
    /// The library's source files (name, text), in load order.
    pub files: Vec<(String, String)>,
    /// The checked library's encoding (`robosim_library::Library::encode_checked`), if the
    /// keeper published one.
    pub checked: Option<Vec<u8>>,
}

/// A process's read attachment to a session's Instance Space.
pub struct Reader {
    session: Session,
    node: Node<ipc::Service>,
    objects: Sub,
    poses: Sub,
    changes: Sub,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    hello: iceoryx2::port::notifier::Notifier<ipc::Service>,
    /// Geometry updates, and the geometry they brought that no snapshot took yet.
    geometry_sub: Sub,
    geometry: HashMap<Id, GeomUpdate>,
    geometry_base_sub: Sub,
    /// The newest geometry base received, and how many times this reader asked for one.
    geometry_base: Option<GeomBase>,
    geometry_bases_asked: u64,
    /// Subscriptions to the pose chunks, by chunk index: opened when this reader first needs
    /// a chunk that its pose base does not hold.
    chunks: Vec<Option<ChunkSub>>,
    base_sub: Sub,
    /// The newest pose base received.
    base: Option<Base>,
    /// The newest objects head received, and the object chunks heads brought that no snapshot
    /// took yet (by chunk index).
    latest_head: Option<Rc<ObjectsHead>>,
    obj_updates: HashMap<usize, ObjUpdate>,
    /// The objects head samples chunks are viewed in (by snapshots or pending updates): at
    /// most `MAX_HELD_SNAPSHOTS` alive ([`Reader::receive_objects_heads`]).
    head_samples: Vec<std::rc::Weak<Words>>,
    objects_base_sub: Sub,
    /// The newest objects base received, and how many times this reader asked for one.
    objects_base: Option<ObjBase>,
    objects_bases_asked: u64,
    /// How many object chunks this reader's snapshots took as record patches.
    patched_chunks: u64,
    /// How many times this reader asked for a pose base.
    pose_bases_asked: u64,
    current: Option<Rc<Snapshot>>,
    log: VecDeque<Change>,
    /// Highest change version seen (0 = none yet).
    seen: u64,
    /// Lowest version from which the log is gap-free.
    log_floor: u64,
    /// Changes drained but not yet returned by [`Reader::wait_change`].
    pending: Vec<Change>,
    timeout: Duration,
    /// The role this reader attached as: [`Reader::reattach`] attaches again as it.
    role: String,
    /// How many times this reader attached again after meeting a malformed segment, and the
    /// last segment error that made it.
    reattached: u64,
    last_reattach: Option<String>,
    _services: Vec<Box<dyn std::any::Any>>,
}

impl Reader {
    /// Attaches to the keeper of `session` and waits (up to 10 s) for its current model.
    pub fn attach(session: &Session, role: &str) -> Result<Reader, ReaderError> {
        let node = session.node(role, false)?;
        let no_keeper = |service: &str, e: crate::error::Cause| ReaderError::NoKeeper {
            session: session.name().to_owned(),
            service: service.to_owned(),
            cause: e,
        };
        let open = |suffix: &str| -> Result<_, ReaderError> {
            node.service_builder(&session.service(suffix)?)
                .publish_subscribe::<[u64]>()
                .open()
                .map_err(|e| no_keeper(suffix, Box::new(e)))
        };
        let objects_svc = open(services::OBJECTS)?;
        let objects_base_svc = open(services::OBJECTS_BASE)?;
        let objects_base_sub = objects_base_svc
            .subscriber_builder()
            .create()
            .map_err(|e| match e {
                iceoryx2::port::subscriber::SubscriberCreateError::ExceedsMaxSupportedSubscribers => {
                    ReaderError::TooManyReaders {
                        session: session.name().to_owned(),
                        limit: objects_base_svc.static_config().max_subscribers(),
                    }
                }
                e => ipc("subscribe objects base")(e),
            })?;
        let poses_svc = open(services::POSES)?;
        let changes_svc = open(services::CHANGES)?;
        let base_svc = open(services::POSE_BASE)?;
        let geometry_svc = open(services::GEOMETRY)?;
        let geometry_base_svc = open(services::GEOMETRY_BASE)?;
        let geometry_sub = geometry_svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe geometry"))?;
        let geometry_base_sub = geometry_base_svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe geometry base"))?;
        let base_sub = base_svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe pose base"))?;
        let objects = objects_svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe objects"))?;
        let poses = poses_svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe poses"))?;
        let changes = changes_svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe changes"))?;
        let change_event = node
            .service_builder(&session.service(services::CHANGE_EVENT)?)
            .event()
            .open()
            .map_err(|e| no_keeper(services::CHANGE_EVENT, Box::new(e)))?;
        let listener = change_event
            .listener_builder()
            .create()
            .map_err(ipc("listen to changes"))?;
        let req_event = node
            .service_builder(&session.service(services::REQUEST_EVENT)?)
            .event()
            .open()
            .map_err(|e| no_keeper(services::REQUEST_EVENT, Box::new(e)))?;
        let hello = req_event
            .notifier_builder()
            .create()
            .map_err(ipc("create hello notifier"))?;
        let mut r = Reader {
            session: session.clone(),
            node,
            objects,
            poses,
            changes,
            listener,
            hello,
            geometry_sub,
            geometry: HashMap::new(),
            geometry_base_sub,
            geometry_base: None,
            geometry_bases_asked: 0,
            chunks: Vec::new(),
            base_sub,
            base: None,
            latest_head: None,
            obj_updates: HashMap::new(),
            head_samples: Vec::new(),
            objects_base_sub,
            objects_base: None,
            objects_bases_asked: 0,
            patched_chunks: 0,
            pose_bases_asked: 0,
            current: None,
            log: VecDeque::new(),
            seen: 0,
            log_floor: 0,
            pending: Vec::new(),
            timeout: Duration::from_secs(10),
            role: role.to_owned(),
            reattached: 0,
            last_reattach: None,
            _services: vec![
                Box::new(objects_svc),
                Box::new(objects_base_svc),
                Box::new(poses_svc),
                Box::new(changes_svc),
                Box::new(base_svc),
                Box::new(geometry_svc),
                Box::new(geometry_base_svc),
                Box::new(change_event),
                Box::new(req_event),
            ],
        };
        let _ = r
            .hello
            .notify_with_custom_event_id(EventId::new(events::HELLO));
        let start = Instant::now();
        while r.current.is_none() {
            // (not `refresh`: a malformed segment met while attaching is the answer, not a
            // reason to attach again)
            r.refresh_once()?;
            if r.current.is_some() {
                break;
            }
            if start.elapsed() > r.timeout {
                return Err(ReaderError::Timeout(r.timeout));
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        let v = r.current.as_ref().map_or(0, |s| s.version);
        r.seen = v;
        r.log_floor = v + 1;
        // History of the change stream: what the snapshot already includes is dropped; what
        // came after it is kept for the first wait_change.
        r.pending = r.drain_changes()?;
        Ok(r)
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    /// How many pose chunk services this reader subscribes to: those it had to follow since
    /// its pose base. A late joiner starts with none when it asked for a fresh base, or with
    /// those changed since the base it found published when that was cheaper
    /// ([`RECORDS_PER_OPEN`]).
    pub fn pose_chunks_followed(&self) -> usize {
        self.chunks.iter().filter(|c| c.is_some()).count()
    }

    /// How many times this reader asked the keeper for a pose base: at most once to attach
    /// (none when a base published for an earlier joiner serves), then only when more than a
    /// few chunks it follows no service of changed at once.
    pub fn pose_bases_asked(&self) -> u64 {
        self.pose_bases_asked
    }

    /// How many times this reader asked the keeper for the geometry base: once to attach (to a
    /// model with geometry), then only after a keeper restart or a geometry change it had no
    /// update for (too large for one, or missed while this reader did not follow).
    pub fn geometry_bases_asked(&self) -> u64 {
        self.geometry_bases_asked
    }

    /// How many times this reader asked the keeper for the objects base: once to attach, then
    /// only after a keeper restart or a structural change whose chunks it did not get from an
    /// objects head (too many at once, or heads missed while it did not follow).
    pub fn objects_bases_asked(&self) -> u64 {
        self.objects_bases_asked
    }

    /// How many object chunks this reader's snapshots took as the whole segment of a chunk
    /// they held (or a head brought) with an objects head's record patches put on it
    /// ([`crate::layout::PatchEntry`]), rather than as a whole chunk.
    pub fn patched_chunks_followed(&self) -> u64 {
        self.patched_chunks
    }

    /// The size in words of the geometry base this reader holds (0 without one).
    pub fn geometry_base_words(&self) -> usize {
        self.geometry_base
            .as_ref()
            .map_or(0, |b| b.words.words().len())
    }

    /// The newest consistent snapshot this reader has assembled (call [`Reader::refresh`] or
    /// [`Reader::wait_change`] to advance it). Cheap: a reference-counted handle.
    pub fn snapshot(&self) -> Option<Rc<Snapshot>> {
        self.current.clone()
    }

    /// How many times this reader met a malformed published segment and attached again
    /// ([`Reader::refresh`]); 0 for a reader that followed every publication as published.
    pub fn reattachments(&self) -> u64 {
        self.reattached
    }

    /// The segment error that made this reader attach again last, if it ever did.
    pub fn last_reattach_cause(&self) -> Option<&str> {
        self.last_reattach.as_deref()
    }

    /// Assembles the newest published version if there is one; returns whether it advanced.
    ///
    /// A reader that meets a malformed segment (one whose sections disagree with the head that
    /// names it) does not stop following: it lets go of everything it assembled from (its
    /// subscriptions, the chunks and bases it holds), attaches again — fresh subscriptions, the
    /// keeper asked for fresh bases — and assembles the newest version from those
    /// ([`Reader::reattachments`] counts it). Its change log goes on uninterrupted. Only when
    /// the fresh attachment meets a malformed segment too is the error returned (the keeper's
    /// publication itself is wrong); the snapshot then stays the last good one and the next
    /// call tries again.
    pub fn refresh(&mut self) -> Result<bool, ReaderError> {
        match self.refresh_once() {
            Err(ReaderError::Layout(cause)) => {
                self.reattach(&cause)?;
                Ok(true)
            }
            other => other,
        }
    }

    /// Attaches again as this reader's role (after a malformed segment, `cause`): the snapshot
    /// and everything it was assembled from come from the fresh attachment; the change stream
    /// (its subscription, log and pending records) is this reader's own and goes on.
    fn reattach(&mut self, cause: &LayoutError) -> Result<(), ReaderError> {
        // Records not drained yet stay with the change stream kept.
        let drained = self.drain_changes()?;
        self.pending.extend(drained);
        let fresh = Reader::attach(&self.session, &self.role)?;
        let old = std::mem::replace(self, fresh);
        self.changes = old.changes;
        self.listener = old.listener;
        self.log = old.log;
        self.seen = old.seen;
        self.log_floor = old.log_floor;
        self.pending = old.pending;
        self.timeout = old.timeout;
        self.pose_bases_asked += old.pose_bases_asked;
        self.objects_bases_asked += old.objects_bases_asked;
        self.patched_chunks += old.patched_chunks;
        self.geometry_bases_asked += old.geometry_bases_asked;
        self.reattached = old.reattached + 1;
        self.last_reattach = Some(cause.to_string());
        // The old change stream's service handles stay with it.
        self._services.extend(old._services);
        Ok(())
    }

    fn refresh_once(&mut self) -> Result<bool, ReaderError> {
        // The poses head: the keeper publishes it last in every commit, after the objects
        // segment, the geometry and the pose chunks it names.
        let Some(mut head) = newest(&self.poses, "poses")? else {
            return Ok(false);
        };
        let deadline = Instant::now() + self.timeout;
        loop {
            if let Some(snapshot) = self.assemble(&head, deadline)? {
                self.current = Some(Rc::new(snapshot));
                return Ok(true);
            }
            // Something newer than this head was published: a newer head follows (the keeper
            // publishes the head last, microseconds later). Let go of this one and take the
            // newest. A keeper killed between the two never sends it: after a grace second the
            // snapshot stays where it was (`false`), as when nothing new was published.
            drop(head);
            let grace = Instant::now() + self.timeout.min(Duration::from_secs(1));
            head = loop {
                if let Some(s) = newest(&self.poses, "poses")? {
                    break s;
                }
                if Instant::now() > grace {
                    return Ok(false);
                }
                std::thread::sleep(Duration::from_micros(50));
            };
        }
    }

    /// The snapshot of the version `head` names, or `None` if a part newer than it was found.
    fn assemble(
        &mut self,
        head: &Sample,
        deadline: Instant,
    ) -> Result<Option<Snapshot>, ReaderError> {
        let h: PosesHeader = *Segment::parse(head.payload())?.record::<PosesHeader>(0)?;
        // The objects head of the structure version the poses head is indexed against; it was
        // published before the poses head.
        loop {
            self.receive_objects_heads()?;
            if let Some(o) = &self.latest_head {
                let oh = o.header;
                if oh.epoch == h.epoch && oh.version == h.structure_version {
                    break;
                }
                if oh.epoch > h.epoch || (oh.epoch == h.epoch && oh.version > h.structure_version) {
                    // Structure moved on after this head (or a new keeper started).
                    return Ok(None);
                }
            }
            if Instant::now() > deadline {
                return Err(ReaderError::Timeout(self.timeout));
            }
            std::thread::sleep(Duration::from_micros(50));
        }
        let objects_head = self
            .latest_head
            .clone()
            .ok_or(ReaderError::Timeout(self.timeout))?;
        let n = objects_head.header.count as usize;
        // Same structure as the current snapshot (a pose-only change): same objects, geometry.
        if let Some(cur) = &self.current
            && Rc::ptr_eq(&cur.head, &objects_head)
        {
            let (objects, head_views, geometry, objects_flat) = (
                cur.objects.clone(),
                cur.head_views.clone(),
                cur.geometry.clone(),
                cur.objects_flat.clone(),
            );
            let Some((poses, pose_gens)) = self.collect_pose_chunks(head, &h, n, deadline)? else {
                return Ok(None);
            };
            return Ok(Some(Snapshot {
                version: h.version,
                epoch: h.epoch,
                head: objects_head,
                objects,
                head_views,
                objects_flat,
                poses,
                pose_gens,
                chunk_len: (h.chunk_len as usize).max(1),
                flat: std::cell::OnceCell::new(),
                geometry,
            }));
        }
        let Some((objects, head_views, geometry)) =
            self.collect_objects(&h, &objects_head, deadline)?
        else {
            return Ok(None);
        };
        let Some((poses, pose_gens)) = self.collect_pose_chunks(head, &h, n, deadline)? else {
            // A chunk newer than this head: a newer head follows.
            return Ok(None);
        };
        Ok(Some(Snapshot {
            version: h.version,
            epoch: h.epoch,
            head: objects_head,
            objects,
            head_views: Rc::new(head_views),
            objects_flat: Rc::default(),
            poses,
            pose_gens,
            chunk_len: (h.chunk_len as usize).max(1),
            flat: std::cell::OnceCell::new(),
            geometry,
        }))
    }

    /// The object chunks `oh` names, each at its generation — as the current snapshot holds
    /// it (with its geometry table), from an objects head, or from the objects base, asked for
    /// when some are in none of them — and the geometry tables of those not held. The lists
    /// start as the current snapshot's (shared by groups, [`Groups`]) and only the chunks whose
    /// generation differs, or that are new, are looked for and replaced: a one-body change at
    /// 10⁵ objects is one chunk's work, not 391 chunks' bookkeeping. A chunk the head of this
    /// structure version carried is viewed in that head's sample, not copied; one the current
    /// snapshot viewed in an older head's sample and that is kept stays viewed there, unless
    /// too many head samples are held. Also returns the chunks viewed
    /// ([`Snapshot::head_views`]). `None` when the base is newer than the head (a newer
    /// head follows).
    #[allow(clippy::type_complexity)]
    fn collect_objects(
        &mut self,
        h: &PosesHeader,
        oh: &ObjectsHead,
        deadline: Instant,
    ) -> Result<Option<(Groups<ObjSrc>, Vec<usize>, Groups<Table>)>, ReaderError> {
        let n = oh.header.count as usize;
        let chunks = n.div_ceil(OBJECT_CHUNK);
        if oh.gens.len() != chunks {
            return Err(LayoutError::Section(1).into());
        }
        let count_of = |k: usize| OBJECT_CHUNK.min(n - k * OBJECT_CHUNK);
        self.receive_objects_base()?;
        let cur = self.current.clone().filter(|c| c.epoch == h.epoch);
        // Same epoch and generation: the same chunk (the keeper gives a chunk a new
        // generation whenever its words change, its length included), so it is kept with its
        // geometry table and not touched again — at 10⁵ objects that was a cache miss per
        // chunk. The chunks to look for: those whose generation differs, and the new ones.
        let (mut objects, mut geometry) = match &cur {
            Some(c) if c.objects.len() == c.geometry.len() => {
                (c.objects.clone(), c.geometry.clone())
            }
            _ => Default::default(),
        };
        // The held chunks are at the generations their head named (every chunk of a snapshot
        // is taken at its head's generation): comparing those words with the new head's is a
        // pass over two plain arrays, not over the chunk handles (at 10⁵ objects the handles'
        // walk was the largest cost that grew with the model).
        let mut todo: Vec<usize> = match &cur {
            Some(c) if c.head.gens.len() == objects.len() => c
                .head
                .gens
                .iter()
                .zip(&oh.gens)
                .enumerate()
                .filter(|(_, (a, b))| a != b)
                .map(|(k, _)| k)
                .collect(),
            _ => objects
                .iter()
                .zip(&oh.gens)
                .enumerate()
                .filter(|(_, (o, g))| o.generation != **g)
                .map(|(k, _)| k)
                .collect(),
        };
        todo.extend(objects.len().min(chunks)..chunks);
        objects.truncate(chunks);
        geometry.truncate(chunks);
        // (chunk, where it is), in `todo`'s order, and which of them are viewed in the head
        let mut found: Vec<Option<ObjSrc>> = Vec::with_capacity(todo.len());
        let mut head_views = Vec::new();
        let mut missing = Vec::new();
        for (t, &k) in todo.iter().enumerate() {
            let generation = oh.gens[k];
            // (patches the head brought are put on the chunk as the current snapshot holds
            // it, when that is of their lineage)
            let brought = match self.obj_updates.get(&k) {
                Some(u) if u.epoch == h.epoch && u.chunk.generation() == generation => u
                    .chunk
                    .resolve(cur.as_ref().and_then(|c| c.objects.get(k)))
                    .map(|c| (c, u.in_head)),
                _ => None,
            };
            let got = match brought {
                Some((c, in_head)) => {
                    if in_head {
                        head_views.push(k);
                    }
                    if c.patches.is_some() {
                        self.patched_chunks += 1;
                    }
                    Some(c)
                }
                None => match &self.objects_base {
                    Some(b) => b.find(h.epoch, k, generation)?,
                    None => None,
                },
            };
            if got.is_none() {
                missing.push(t);
            }
            found.push(got);
        }
        if !missing.is_empty() {
            let base = self.wait_objects_base(h, deadline)?;
            if base.head.epoch != h.epoch {
                return Ok(None);
            }
            for &t in &missing {
                let k = todo[t];
                match base.find(h.epoch, k, oh.gens[k])? {
                    Some(c) => found[t] = Some(c),
                    // The base is newer than this head (a newer head follows)…
                    None if base.head.version > h.structure_version => return Ok(None),
                    // …or does not hold what its own head names.
                    None => return Err(LayoutError::Section(2).into()),
                }
            }
        }
        // The chunks found with their geometry tables.
        let mut tables: Vec<(ObjSrc, NewTable)> = Vec::with_capacity(todo.len());
        // The objects with geometry of those chunks not held: (chunk, index in it, id,
        // generation), and where each goes: (index in `tables`, index in the chunk).
        let mut want: Vec<(usize, usize, Id, u64)> = Vec::new();
        let mut want_at: Vec<(usize, usize)> = Vec::new();
        for (t, (&k, f)) in todo.iter().zip(found).enumerate() {
            let src = f.ok_or(LayoutError::Section(1))?;
            // The chunk as the current snapshot holds it (an older generation): an object at
            // the same place with the same geometry generation keeps its geometry, found by
            // position rather than looked up by id (a one-body change made 256 searches over
            // every chunk at 10⁵ objects).
            let old = cur.as_ref().and_then(|c| {
                let o = c.objects.get(k)?;
                Some((o, o.geometry_index(), c.geometry.get(k)?))
            });
            // The same whole segment as the held chunk, patched otherwise (an objects head's
            // record patches): the segment was checked when the held chunk was, so only the
            // records either chunk patches can differ — O(patched records), where checking
            // the chunk and matching its objects with geometry is O(chunk) (issue 37 item 6).
            if let Some((o, places, t_old)) = old
                && src.same_whole(o)
                && o.base_records().len() == count_of(k)
                && (places.is_empty() || t_old.len() == count_of(k))
            {
                src.check_patches()?;
                if places.is_empty() {
                    tables.push((src, NewTable::Empty));
                    continue;
                }
                let mut slots: Vec<usize> = [&o.patches, &src.patches]
                    .into_iter()
                    .flatten()
                    .flat_map(|p| p.at.iter().copied())
                    .collect();
                slots.sort_unstable();
                slots.dedup();
                for j in slots {
                    let r = src.rec(j);
                    if r.flags & flags::HAS_GEOMETRY == 0 {
                        // (without geometry in the whole segment too: its slot is empty)
                        continue;
                    }
                    let kept = t_old
                        .get(j)
                        .and_then(Option::as_ref)
                        .is_some_and(|s| s.generation == r.geom_gen && o.rec(j).id == r.id);
                    if !kept {
                        want.push((k, j, r.id, r.geom_gen));
                        want_at.push((t, j));
                    }
                }
                tables.push((src, NewTable::From(t_old.clone())));
                continue;
            }
            let with = src.check(k, count_of(k))?;
            if with.is_empty() {
                tables.push((src, NewTable::Empty));
                continue;
            }
            // When the objects with geometry are at the same places as in the old chunk (a
            // geometry replaced, a colour, a rename), the old table is the start and only the
            // slots whose object or geometry changed are replaced.
            let mut table = match old {
                Some((_, places, t))
                    if t.len() == count_of(k) && places == src.geometry_index() =>
                {
                    NewTable::From(t.clone())
                }
                _ => NewTable::Fresh(vec![None; count_of(k)]),
            };
            for (j, id, g) in with {
                let kept = old.and_then(|(o, _, t)| {
                    o.get(j).filter(|r| r.id == id && r.geom_gen == g)?;
                    t.get(j)?.as_ref().filter(|s| s.generation == g)
                });
                match kept {
                    Some(s) => {
                        if let NewTable::Fresh(_) = table {
                            table.set(j, s.clone());
                        }
                    }
                    None => {
                        want.push((k, j, id, g));
                        want_at.push((t, j));
                    }
                }
            }
            tables.push((src, table));
        }
        if !want.is_empty() {
            let Some(got) = self.collect_geometry(h, &want, deadline)? else {
                return Ok(None);
            };
            for (&(t, j), g) in want_at.iter().zip(got) {
                if let Some((_, table)) = tables.get_mut(t) {
                    table.set(j, g);
                }
            }
        }
        // A chunk without geometry shares one empty table (at 10⁵ solids a table of 256 empty
        // slots per chunk was 5 MB of fresh memory written per attach).
        let empty: Table = Groups::default();
        for (&k, (src, table)) in todo.iter().zip(tables) {
            let table = match table {
                NewTable::Empty => empty.clone(),
                NewTable::Fresh(v) => Groups::from_vec(v),
                NewTable::From(t) => t,
            };
            // `todo` is ascending and holds every chunk from the current length on.
            if !(objects.set_or_push(k, src) && geometry.set_or_push(k, table)) {
                return Err(LayoutError::Section(1).into());
            }
        }
        // The chunks the current snapshot views in older heads' samples and that this one
        // keeps: still viewed there (the same memory, so an unchanged chunk is shared between
        // the snapshots; how many head samples are held is bounded where heads are received,
        // [`Reader::receive_objects_heads`]).
        let mut views = Vec::new();
        if let Some(c) = &cur {
            for &k in c.head_views.iter() {
                let (Some(old), Some(now)) = (c.objects.get(k), objects.get(k)) else {
                    continue;
                };
                if !Rc::ptr_eq(&old.seg.words, &now.seg.words) {
                    continue;
                }
                views.push(k);
            }
        }
        // (a chunk patched on the whole segment of a held one may be in both)
        views.extend(head_views);
        views.sort_unstable();
        views.dedup();
        let head_views = views;
        // What heads up to this structure version brought is in this snapshot (which holds it
        // from now on) or superseded; newer ones wait for the next head.
        self.obj_updates
            .retain(|_, u| u.epoch == h.epoch && u.version > h.structure_version);
        Ok(Some((objects, head_views, geometry)))
    }

    /// The geometry of the objects `want` ((chunk, index in it, id, generation), objects with
    /// geometry at structure version `h.structure_version`), in that order: as the current
    /// snapshot holds it, from a geometry update, or from the geometry base — asked for when
    /// something is in none of them. `None` when the base is newer than the head (a newer head
    /// follows).
    fn collect_geometry(
        &mut self,
        h: &PosesHeader,
        want: &[(usize, usize, Id, u64)],
        deadline: Instant,
    ) -> Result<Option<Vec<GeomSrc>>, ReaderError> {
        self.receive_geometry_updates()?;
        self.receive_geometry_base()?;
        let cur = self.current.clone().filter(|c| c.epoch == h.epoch);
        let held = |id: Id, generation: u64| {
            let c = cur.as_ref()?;
            c.geom_src(c.index_of(id)?)
                .filter(|g| g.generation == generation)
                .cloned()
        };
        let mut geometry: Vec<Option<GeomSrc>> = Vec::with_capacity(want.len());
        let mut missing = Vec::new();
        // `want` is in object order, which is ascending id order.
        let mut in_base = self
            .geometry_base
            .as_ref()
            .map(GeomBase::cursor)
            .transpose()?;
        for (w, &(_, _, id, generation)) in want.iter().enumerate() {
            let update = match self.geometry.get(&id) {
                Some(u) if u.epoch == h.epoch && u.geometry.generation == generation => {
                    Some(u.geometry.clone())
                }
                _ => None,
            };
            let found = match update.or_else(|| held(id, generation)) {
                Some(g) => Some(g),
                None => match in_base.as_mut() {
                    Some(b) => b.find(h.epoch, id, generation)?,
                    None => None,
                },
            };
            if found.is_none() {
                missing.push(w);
            }
            geometry.push(found);
        }
        if !missing.is_empty() {
            let base = self.wait_geometry_base(h, deadline)?;
            if base.head.epoch != h.epoch {
                return Ok(None);
            }
            let mut base_at = base.cursor()?;
            for &w in &missing {
                let (_, _, id, generation) = want[w];
                match base_at.find(h.epoch, id, generation)? {
                    Some(g) => geometry[w] = Some(g),
                    // The base is newer than this head (a newer head follows)…
                    None if base.head.version > h.structure_version => return Ok(None),
                    // …or does not hold what the objects of its own version name.
                    None => return Err(LayoutError::Section(1).into()),
                }
            }
        }
        // What updates up to this structure version brought is in this snapshot (which holds
        // it from now on) or superseded; newer ones wait for the next head.
        self.geometry
            .retain(|_, u| u.epoch == h.epoch && u.version > h.structure_version);
        Ok(Some(
            geometry
                .into_iter()
                .map(|g| g.ok_or(LayoutError::Section(1)))
                .collect::<Result<_, _>>()?,
        ))
    }

    /// Takes every objects head published since the last call: the newest becomes
    /// `latest_head`. The chunks the newest carries are viewed in its sample (kept while a
    /// snapshot or a pending update uses them: a follower of a one-body change copies no chunk
    /// out — at 10⁵ objects the chunk's 84 kB were most of what following cost); before a
    /// newer head is taken, the chunks no snapshot took yet from the one before are copied out
    /// of it ([`Reader::copy_out_head_updates`]), so a reader holds at most one head sample
    /// besides those of the snapshots it has made. A head is copied out at once, as before,
    /// when snapshots already hold `MAX_HELD_SNAPSHOTS` head samples: the views never make a
    /// receive exceed the subscription's borrowed samples (`MAX_HELD_SNAPSHOTS + 1`). (At
    /// worst — four chunks changed once and held since — every head is copied, as before.)
    fn receive_objects_heads(&mut self) -> Result<(), ReaderError> {
        while self
            .objects
            .has_samples()
            .map_err(ipc("look for objects heads"))?
        {
            self.copy_out_head_updates()?;
            let Some(s) = self
                .objects
                .receive()
                .map_err(receive_err("receive objects"))?
            else {
                break;
            };
            self.head_samples.retain(|w| w.strong_count() > 0);
            let view = self.head_samples.len() < crate::keeper::MAX_HELD_SNAPSHOTS;
            let words = Rc::new(Words::Shared(s));
            let seg = Segment::parse(words.words())?;
            let header: ObjectsHeader = *seg.record(0)?;
            let gens = seg.section::<u64>(1)?.to_vec();
            let data = seg.section::<u64>(3)?;
            for e in seg.section::<ChunkEntry>(2)? {
                let (start, len) = (e.start as usize, e.len as usize);
                let chunk_words = data
                    .get(start..)
                    .and_then(|d| d.get(..len))
                    .ok_or(LayoutError::Section(2))?;
                let chunk = if view {
                    ObjSrc::whole(SegSrc {
                        words: words.clone(),
                        range: Some((3, start, len)),
                        generation: e.generation,
                    })
                } else {
                    ObjSrc::owned(chunk_words.to_vec(), e.generation)
                };
                self.obj_updates.insert(
                    e.id as usize,
                    ObjUpdate {
                        epoch: header.epoch,
                        version: header.version,
                        chunk: Brought::Chunk(chunk),
                        in_head: view,
                    },
                );
            }
            // The chunks carried as record patches (none in a head of a keeper that carries
            // every chunk whole): the records are copied out (a few hundred bytes each). Put on
            // the whole segment a pending update brought when that is of their lineage (a head
            // missed by no snapshot), else kept to be put on the held chunk when assembling.
            let (entries, recs) = match (seg.section::<PatchEntry>(4), seg.section::<PatchRec>(5)) {
                (Err(LayoutError::Missing(_)), _) => (&[][..], &[][..]),
                (entries, recs) => (entries?, recs?),
            };
            for e in entries {
                let list = (e.start as usize)
                    .checked_add(e.len as usize)
                    .and_then(|end| recs.get(e.start as usize..end))
                    .filter(|l| !l.is_empty() && l.len() <= OBJECT_CHUNK)
                    .ok_or(LayoutError::Section(4))?;
                let at: Vec<usize> = list.iter().map(|p| p.index as usize).collect();
                if at.windows(2).any(|w| w[0] >= w[1]) || at.iter().any(|&j| j >= OBJECT_CHUNK) {
                    return Err(LayoutError::Section(5).into());
                }
                let patches = Rc::new(Patches {
                    at,
                    recs: list.iter().map(|p| p.rec).collect(),
                });
                let k = e.chunk as usize;
                let brought = Brought::Patches {
                    since: e.since,
                    generation: e.generation,
                    patches,
                };
                let on_pending = self
                    .obj_updates
                    .get(&k)
                    .filter(|u| u.epoch == header.epoch)
                    .and_then(|u| match &u.chunk {
                        Brought::Chunk(c) => Some((brought.resolve(Some(c))?, u.in_head)),
                        Brought::Patches { .. } => None,
                    });
                let (chunk, in_head) = match on_pending {
                    Some((c, in_head)) => (Brought::Chunk(c), in_head),
                    None => (brought, false),
                };
                self.obj_updates.insert(
                    k,
                    ObjUpdate {
                        epoch: header.epoch,
                        version: header.version,
                        chunk,
                        in_head,
                    },
                );
            }
            if view && Rc::strong_count(&words) > 1 {
                self.head_samples.push(Rc::downgrade(&words));
            }
            self.latest_head = Some(Rc::new(ObjectsHead { header, gens }));
        }
        Ok(())
    }

    /// Copies the chunks pending updates view in a head's sample out of it (see
    /// [`Reader::receive_objects_heads`]); the sample is released unless a snapshot uses it.
    fn copy_out_head_updates(&mut self) -> Result<(), ReaderError> {
        for u in self.obj_updates.values_mut().filter(|u| u.in_head) {
            if let Brought::Chunk(c) = &mut u.chunk {
                c.seg = SegSrc::owned(c.seg.seg_words()?.to_vec(), c.seg.generation);
            }
            u.in_head = false;
        }
        Ok(())
    }

    /// Takes the newest objects base published, if one came since the last call.
    fn receive_objects_base(&mut self) -> Result<(), ReaderError> {
        if let Some(s) = newest(&self.objects_base_sub, "objects base")? {
            self.objects_base = Some(ObjBase::parse(s)?);
        }
        Ok(())
    }

    /// Asks the keeper for an objects base and waits for one of head `h`'s structure version
    /// or newer (or of a newer keeper).
    fn wait_objects_base(
        &mut self,
        h: &PosesHeader,
        deadline: Instant,
    ) -> Result<&ObjBase, ReaderError> {
        let fresh = |b: &ObjBase| serves_structure(h, b.head.epoch, b.head.version);
        if !self.objects_base.as_ref().is_some_and(fresh) {
            self.objects_bases_asked += 1;
            self.ask_until(events::OBJECTS_BASE, deadline, |r| {
                r.receive_objects_base()?;
                Ok(r.objects_base.as_ref().is_some_and(fresh))
            })?;
        }
        self.objects_base
            .as_ref()
            .ok_or(ReaderError::Timeout(self.timeout))
    }

    /// Copies the geometry of every update received since the last call (the update samples
    /// are released at once).
    fn receive_geometry_updates(&mut self) -> Result<(), ReaderError> {
        while let Some(s) = self
            .geometry_sub
            .receive()
            .map_err(receive_err("receive geometry update"))?
        {
            let seg = Segment::parse(s.payload())?;
            let head: GeometryBundleHeader = *seg.record(0)?;
            let data = seg.section::<u64>(2)?;
            for e in seg.section::<ChunkEntry>(1)? {
                let words = data
                    .get(e.start as usize..)
                    .and_then(|d| d.get(..e.len as usize))
                    .ok_or(LayoutError::Section(1))?;
                self.geometry.insert(
                    e.id,
                    GeomUpdate {
                        epoch: head.epoch,
                        version: head.version,
                        geometry: GeomSrc::owned(words.to_vec(), e.generation),
                    },
                );
            }
        }
        Ok(())
    }

    /// Takes the newest geometry base published, if one came since the last call.
    fn receive_geometry_base(&mut self) -> Result<(), ReaderError> {
        if let Some(s) = newest(&self.geometry_base_sub, "geometry base")? {
            self.geometry_base = Some(GeomBase::parse(s)?);
        }
        Ok(())
    }

    /// Asks the keeper for a geometry base and waits for one of head `h`'s structure version
    /// or newer (or of a newer keeper).
    fn wait_geometry_base(
        &mut self,
        h: &PosesHeader,
        deadline: Instant,
    ) -> Result<&GeomBase, ReaderError> {
        let fresh = |b: &GeomBase| serves_structure(h, b.head.epoch, b.head.version);
        if !self.geometry_base.as_ref().is_some_and(fresh) {
            self.geometry_bases_asked += 1;
            self.ask_until(events::GEOMETRY_BASE, deadline, |r| {
                r.receive_geometry_base()?;
                Ok(r.geometry_base.as_ref().is_some_and(fresh))
            })?;
        }
        self.geometry_base
            .as_ref()
            .ok_or(ReaderError::Timeout(self.timeout))
    }

    /// The pose chunks the head names, each at the generation the head gives: chunks this
    /// reader already holds at that generation are reused, the others taken from its pose base
    /// or received (only those changed since this reader's last snapshot). The list starts as
    /// the current snapshot's (shared by groups, [`Groups`]) and only the chunks whose
    /// generation or length differs, or that are new, are looked for: a follow costs one
    /// generation compare per unchanged chunk. A reader without a snapshot, or missing many
    /// chunks at once, asks the keeper for a base first. `None` when a chunk or the base is
    /// newer than the head.
    fn collect_pose_chunks(
        &mut self,
        head: &Sample,
        h: &PosesHeader,
        objects: usize,
        deadline: Instant,
    ) -> Result<Option<(Groups<PoseSrc>, Rc<Vec<u64>>)>, ReaderError> {
        let gens: Vec<u64> = Segment::parse(head.payload())?.section::<u64>(1)?.to_vec();
        let n = h.count as usize;
        let chunk_len = h.chunk_len as usize;
        if chunk_len == 0 || n != objects || gens.len() != n.div_ceil(chunk_len) {
            return Err(LayoutError::Section(1).into());
        }
        let count_of = |k: usize| chunk_len.min(n - k * chunk_len);
        // The chunks as the current snapshot holds them (the same memory as before); those at
        // another generation or length, and the new ones, are to be found (every one without
        // a current snapshot of this keeper and chunking).
        let cur = self
            .current
            .as_ref()
            .filter(|c| c.epoch == h.epoch && c.chunk_len == chunk_len);
        let mut out = cur.map(|c| c.poses.clone()).unwrap_or_default();
        // With as many objects as the current snapshot (so every chunk's length is as it was)
        // and its head's generations at hand, the chunks to find are those whose generation
        // word differs; otherwise the held chunks are walked.
        let mut todo: Vec<usize> = match cur {
            Some(c)
                if c.pose_gens.len() == out.len() && out.len() == gens.len() && c.len() == n =>
            {
                c.pose_gens
                    .iter()
                    .zip(&gens)
                    .enumerate()
                    .filter(|(_, (a, b))| a != b)
                    .map(|(k, _)| k)
                    .collect()
            }
            _ => out
                .iter()
                .zip(&gens)
                .enumerate()
                .filter(|(k, (p, g))| p.generation != **g || p.count != count_of(*k))
                .map(|(k, _)| k)
                .collect(),
        };
        todo.extend(out.len().min(gens.len())..gens.len());
        out.truncate(gens.len());
        // After a keeper restart (a new epoch) no chunk is held and none is on its service
        // before it changes (`Keeper::publish_all`): the base has them all, and the services
        // followed under the old keeper are let go.
        let new_keeper = self.current.as_ref().is_some_and(|c| c.epoch != h.epoch);
        if new_keeper {
            self.chunks.clear();
        }
        self.chunks.truncate(gens.len());
        self.chunks.resize_with(gens.len(), || None);
        self.receive_base()?;
        let from_base = |base: &Option<Base>, k: usize| {
            base.as_ref()
                .and_then(|b| b.chunk(k, chunk_len, count_of(k), h.epoch, gens[k]))
        };
        // Each chunk to find that no service is followed for, once (by its place in `todo`):
        // from the base, or `None` (missing).
        let mut unfollowed: Vec<Option<PoseSrc>> = todo
            .iter()
            .map(|&k| {
                self.chunks[k]
                    .is_none()
                    .then(|| from_base(&self.base, k))
                    .flatten()
            })
            .collect();
        let missing = |chunks: &[Option<ChunkSub>], unfollowed: &[Option<PoseSrc>], t: usize| {
            chunks[todo[t]].is_none() && unfollowed[t].is_none()
        };
        let n_missing = (0..todo.len())
            .filter(|&t| missing(&self.chunks, &unfollowed, t))
            .count();
        let attaching = self.current.is_none();
        if n_missing > 0
            && (n_missing > BASE_OVER
                || new_keeper
                || (attaching && n_missing * RECORDS_PER_OPEN > n))
        {
            if !self.wait_base(h, deadline)? {
                return Ok(None);
            }
            for t in 0..todo.len() {
                if missing(&self.chunks, &unfollowed, t) {
                    unfollowed[t] = from_base(&self.base, todo[t]);
                }
            }
        }
        let mut opened = false;
        for t in 0..todo.len() {
            if missing(&self.chunks, &unfollowed, t) {
                self.chunks[todo[t]] = Some(self.open_chunk(todo[t])?);
                opened = true;
            }
        }
        let mut said_hello = false;
        if opened {
            // New subscribers: ask the keeper to deliver their history now.
            let _ = self
                .hello
                .notify_with_custom_event_id(EventId::new(events::HELLO));
            said_hello = true;
        }
        for (t, &k) in todo.iter().enumerate() {
            let generation = gens[k];
            let count = count_of(k);
            let src = match self.chunks[k].as_mut() {
                // Not followed: in the base (found above).
                None => unfollowed[t].take().ok_or(LayoutError::Section(1))?,
                Some(c) => {
                    while !(c.epoch == h.epoch && c.generation == generation) {
                        match c
                            .sub
                            .receive()
                            .map_err(receive_err(Joined("receive pose chunk ", k)))?
                        {
                            Some(s) => {
                                let ch: PoseChunkHeader =
                                    *Segment::parse(s.payload())?.record::<PoseChunkHeader>(0)?;
                                c.epoch = ch.epoch;
                                c.generation = ch.generation;
                                c.latest = Some(Rc::new(Words::Shared(s)));
                                c.checked = None;
                                if ch.epoch > h.epoch
                                    || (ch.epoch == h.epoch && ch.generation > generation)
                                {
                                    return Ok(None);
                                }
                            }
                            None if Instant::now() > deadline => {
                                return Err(ReaderError::Timeout(self.timeout));
                            }
                            None => {
                                if !said_hello {
                                    let _ = self
                                        .hello
                                        .notify_with_custom_event_id(EventId::new(events::HELLO));
                                    said_hello = true;
                                }
                                std::thread::sleep(Duration::from_micros(50));
                            }
                        }
                    }
                    let latest = c.latest.clone().ok_or(ReaderError::Timeout(self.timeout))?;
                    let first = k * chunk_len;
                    if c.checked != Some((first, count)) {
                        let seg = Segment::parse(latest.words())?;
                        let ch: PoseChunkHeader = *seg.record(0)?;
                        if ch.first as usize != first
                            || ch.count as usize != count
                            || seg.section::<PoseRec>(1)?.len() != count
                        {
                            return Err(LayoutError::Section(1).into());
                        }
                        c.checked = Some((first, count));
                    }
                    PoseSrc::chunk(latest, count, generation)
                }
            };
            // `todo` is ascending and holds every chunk from the current length on.
            if !out.set_or_push(k, src) {
                return Err(LayoutError::Section(1).into());
            }
        }
        Ok(Some((out, Rc::new(gens))))
    }

    /// Opens the service of pose chunk `k` and subscribes (the caller says hello once for all
    /// it opened, so that the keeper delivers their history).
    fn open_chunk(&mut self, k: usize) -> Result<ChunkSub, ReaderError> {
        let svc = self
            .node
            .service_builder(&self.session.service(&services::pose_chunk(k))?)
            .publish_subscribe::<[u64]>()
            .open()
            .map_err(ipc(format!("open pose chunk {k}")))?;
        let sub = svc
            .subscriber_builder()
            .create()
            .map_err(ipc(format!("subscribe pose chunk {k}")))?;
        self._services.push(Box::new(svc));
        Ok(ChunkSub {
            sub,
            latest: None,
            epoch: 0,
            generation: 0,
            checked: None,
        })
    }

    /// Sends the keeper `event` (on the request event) and polls `got` until it says the
    /// answer arrived, or the deadline passes.
    fn ask_until(
        &mut self,
        event: usize,
        deadline: Instant,
        mut got: impl FnMut(&mut Reader) -> Result<bool, ReaderError>,
    ) -> Result<(), ReaderError> {
        let _ = self.hello.notify_with_custom_event_id(EventId::new(event));
        while !got(self)? {
            if Instant::now() > deadline {
                return Err(ReaderError::Timeout(self.timeout));
            }
            std::thread::sleep(Duration::from_micros(50));
        }
        Ok(())
    }

    /// Takes the newest pose base published, if one came since the last call.
    fn receive_base(&mut self) -> Result<(), ReaderError> {
        if let Some(s) = newest(&self.base_sub, "pose base")? {
            self.base = Some(Base::parse(s)?);
        }
        Ok(())
    }

    /// Asks the keeper for a pose base and waits for one at least as new as head `h`. `false`
    /// when the base is newer than the head (a newer head follows).
    fn wait_base(&mut self, h: &PosesHeader, deadline: Instant) -> Result<bool, ReaderError> {
        let fresh = |b: &Base| {
            b.head.epoch > h.epoch || (b.head.epoch == h.epoch && b.head.version >= h.version)
        };
        if !self.base.as_ref().is_some_and(fresh) {
            self.pose_bases_asked += 1;
            self.ask_until(events::BASE, deadline, |r| {
                r.receive_base()?;
                Ok(r.base.as_ref().is_some_and(fresh))
            })?;
        }
        Ok(self
            .base
            .as_ref()
            .is_some_and(|b| b.head.epoch == h.epoch && b.head.version == h.version))
    }

    fn drain_changes(&mut self) -> Result<Vec<Change>, ReaderError> {
        let mut out = Vec::new();
        while let Some(s) = self
            .changes
            .receive()
            .map_err(receive_err("receive changes"))?
        {
            let seg = Segment::parse(s.payload())?;
            let recs: &[ChangeRec] = seg.section(0)?;
            let ids: &[u64] = seg.section(1)?;
            for r in recs {
                if r.version <= self.seen {
                    continue;
                }
                if r.version != self.seen + 1 {
                    // Missed records (overflow, or a keeper restart that replayed unpublished
                    // commits): the log is only complete from here on.
                    self.log.clear();
                    self.log_floor = r.version;
                }
                let range = r.ids_start as usize..(r.ids_start + r.ids_len) as usize;
                let c = Change {
                    version: r.version,
                    aspects: r.aspects,
                    ids: ids.get(range).unwrap_or(&[]).to_vec(),
                    published_ns: r.published_ns,
                };
                self.seen = r.version;
                self.log.push_back(c.clone());
                if self.log.len() > CHANGE_LOG {
                    self.log.pop_front();
                    self.log_floor += 1;
                }
                out.push(c);
            }
        }
        Ok(out)
    }

    /// Waits up to `timeout` for the next change(s) and returns them in version order (empty on
    /// timeout). The snapshot is advanced to the newest version.
    pub fn wait_change(&mut self, timeout: Duration) -> Result<Vec<Change>, ReaderError> {
        // Consume pending wake-ups *before* draining: the keeper publishes a record before it
        // notifies, so every event consumed here belongs to a record the drain below sees.
        // (Consuming after draining would swallow the wake-up of a record published in
        // between, and the next wait would sleep through it.)
        let _ = self.listener.try_wait(|_| {});
        let mut out = std::mem::take(&mut self.pending);
        out.extend(self.drain_changes()?);
        if out.is_empty() {
            crate::session::timed_wait_events(&self.listener, |_| {}, timeout)
                .map_err(ipc("wait for changes"))?;
            out = self.drain_changes()?;
        }
        if !out.is_empty() {
            self.refresh()?;
        }
        Ok(out)
    }

    /// The session's Library Space: its source files as the keeper published them (see
    /// `Keeper::publish_library`). Waits up to the reader's timeout for the first delivery.
    pub fn library_files(&mut self) -> Result<Vec<(String, String)>, ReaderError> {
        Ok(self.library()?.files)
    }

    /// The session's Library Space as the keeper published it: the source files and, when the
    /// keeper published one (`Keeper::publish_library_checked`), the checked library's
    /// encoding. Waits up to the reader's timeout for the first delivery.
    pub fn library(&mut self) -> Result<LibraryPublication, ReaderError> {
        let svc = self
            .node
            .service_builder(&self.session.service(services::LIBRARY)?)
            .publish_subscribe::<[u64]>()
            .open()
            .map_err(ipc(
                "open the Library Space (the keeper publishes it at start)",
            ))?;
        let sub = svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe library"))?;
        let _ = self
            .hello
            .notify_with_custom_event_id(EventId::new(events::HELLO));
        let deadline = Instant::now() + self.timeout;
        loop {
            if let Some(s) = sub.receive().map_err(receive_err("receive library"))? {
                return Ok(LibraryPublication {
                    files: crate::layout::decode_files(s.payload())?,
                    checked: crate::layout::decode_library_checked(s.payload())?,
                });
            }
            if Instant::now() > deadline {
                return Err(ReaderError::Timeout(self.timeout));
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }

    /// Waits for the change event without draining anything (for latency measurement:
    /// returns the instant of wake-up in CLOCK_MONOTONIC ns, or None on timeout).
    pub fn wait_event(&mut self, timeout: Duration) -> Result<Option<u64>, ReaderError> {
        let n = crate::session::timed_wait_events(&self.listener, |_| {}, timeout)
            .map_err(ipc("wait for changes"))?;
        Ok((n > 0).then(crate::monotonic_ns))
    }

    /// Every change after `version` that this reader knows, in order; an error if some of them
    /// happened before this reader's log begins.
    pub fn changes_since(&mut self, version: u64) -> Result<Vec<Change>, ReaderError> {
        self.drain_changes()?;
        if version + 1 < self.log_floor {
            return Err(ReaderError::ChangesLost {
                since: version,
                oldest: self.log_floor,
            });
        }
        Ok(self
            .log
            .iter()
            .filter(|c| c.version > version)
            .cloned()
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::SegmentWriter;

    /// The error contexts formatted only on failure still say what failed, with the cause kept
    /// as the source, and a subscriber holding too many samples is still told by its variant.
    #[test]
    fn error_contexts_formatted_on_failure_name_what_and_keep_the_cause() {
        let cause = std::io::Error::other("shared memory gone");
        match ipc(Joined("receive pose chunk ", 7))(cause) {
            ReaderError::Ipc { what, source } => {
                assert_eq!(what, "receive pose chunk 7");
                assert_eq!(source.to_string(), "shared memory gone");
            }
            other => panic!("{other:?}"),
        }
        let e = ipc::<std::io::Error>("subscribe changes")(std::io::Error::other("x"));
        assert_eq!(e.to_string(), "iceoryx2 subscribe changes: x");
        assert!(matches!(
            receive_err(Joined("receive ", "poses"))(
                iceoryx2::port::ReceiveError::ExceedsMaxBorrows
            ),
            ReaderError::TooManySnapshotsHeld
        ));
    }

    /// A geometry base of the objects `ids` (ascending), object `id`'s geometry the one word
    /// `id * 10` at generation `id + 1`.
    fn base(ids: &[u64]) -> GeomBase {
        let head = [GeometryBundleHeader {
            epoch: 3,
            version: 1,
            count: ids.len() as u64,
        }];
        let entries: Vec<ChunkEntry> = ids
            .iter()
            .enumerate()
            .map(|(k, &id)| ChunkEntry {
                id,
                generation: id + 1,
                start: k as u64,
                len: 1,
            })
            .collect();
        let data: Vec<u64> = ids.iter().map(|id| id * 10).collect();
        let mut w = SegmentWriter::new();
        w.push(&head).push(&entries).push(&data);
        let mut words = vec![0; w.words()];
        w.write(&mut words);
        GeomBase {
            words: Rc::new(Words::Owned(words)),
            head: head[0],
        }
    }

    fn word(g: Option<GeomSrc>) -> Option<u64> {
        g.map(|g| g.seg_words().expect("in bounds")[0])
    }

    #[test]
    fn the_base_cursor_finds_what_a_binary_search_finds_in_any_order() {
        // Gaps of every size, so the gallop overshoots and lands on boundaries.
        let ids: Vec<u64> = (0..2_000u64).map(|k| k * 3 + (k * k) % 7).collect();
        let mut ids = ids;
        ids.dedup();
        let b = base(&ids);
        let mut c = b.cursor().expect("cursor");
        // Ascending, with absent ids between.
        for id in 0..ids.last().copied().unwrap_or(0) + 5 {
            let want = ids.binary_search(&id).ok().map(|_| id * 10);
            assert_eq!(word(c.find(3, id, id + 1).expect("find")), want, "id {id}");
        }
        // Descending and jumping: the cursor starts over where it must.
        for &id in ids
            .iter()
            .rev()
            .step_by(37)
            .chain([ids[5], ids[1_000], ids[2]].iter())
        {
            assert_eq!(word(c.find(3, id, id + 1).expect("find")), Some(id * 10));
        }
        // Another generation or another keeper: not there.
        assert_eq!(word(c.find(3, ids[7], ids[7] + 2).expect("find")), None);
        assert_eq!(word(c.find(4, ids[7], ids[7] + 1).expect("find")), None);
    }

    #[test]
    fn an_entry_past_the_data_is_an_error_not_a_panic() {
        let mut b = base(&[1, 2, 3]);
        if let Words::Owned(w) = Rc::get_mut(&mut b.words).expect("unique") {
            // The third entry's start: section 1's first word is in the section table, and an
            // entry is four words (id, generation, start, len).
            let off = w[2 + 2] as usize;
            w[off + 2 * 4 + 2] = 99;
        }
        let mut c = b.cursor().expect("cursor");
        assert_eq!(word(c.find(3, 1, 2).expect("find")), Some(10));
        assert!(c.find(3, 3, 4).is_err());
    }
}
