//! Durability: an append-only journal of committed transactions plus periodic compacted
//! checkpoints, so that `kill -9` of the keeper at any moment loses nothing it acknowledged.
//!
//! * `journal-<first version>.log`: magic, then records `[len u32][crc32 u32][version u64][tx]`,
//!   the CRC covering version and payload. [`Journal::sync`] (fdatasync) runs before the keeper
//!   acknowledges; one sync covers every transaction of a group (group commit).
//! * `checkpoint-<version>.bin`: magic, crc32, the whole model (bincode). Written to a temp file,
//!   synced, renamed, directory synced; then a new journal starts and older files are removed.
//! * `journal.control` ([`CONTROL_FILE`]): names the current journal file and its first
//!   version; written at a journal's start, at every checkpoint and after every recovery. A
//!   recovery that finds less than it names (the journal gone, the checkpoint before it gone)
//!   refuses and changes nothing.
//! * [`recover`]: newest valid checkpoint, then every journal record after it, in order, each
//!   taken from whichever copy (log or mirror) holds it intact: the longest valid prefix over
//!   both copies. Every disagreement between the copies is reported, and both are rewritten to
//!   what was recovered. A torn or corrupt tail (short record, bad CRC, version out of
//!   sequence, in both copies) is reported and cut off, kept under `lost/` when it holds
//!   anything readable; nothing before it is lost.
//!
//! Every file is created 0600 inside the session's 0700 data directory.

use crate::object::{Appearance, Id, Kind, Kinematics, MassProps, Object, Pose};
use crate::store::Store;
use crate::transaction::{GeometryInput, Transaction};
use serde::{Deserialize, Serialize};
use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Read, Write};
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const JOURNAL_MAGIC: &[u8; 8] = b"RSJRNL01";
const CHECKPOINT_MAGIC: &[u8; 8] = b"RSCKPT01";
const RECORD_HEADER: usize = 16;

#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a robosim {what} (bad magic)")]
    Magic { path: PathBuf, what: &'static str },
    #[error("{path}: checkpoint is corrupt: {source}")]
    Checkpoint {
        path: PathBuf,
        #[source]
        source: Corruption,
    },
    #[error(
        "{path}: the journal control file is unreadable: {reason}; nothing was changed. Restore \
         it, or move it aside to recover from what the data directory holds (and be told what \
         that lacks)"
    )]
    Control { path: PathBuf, reason: String },
    #[error(
        "neither {log} nor its mirror {mirror} starts with a robosim journal header (bad \
         magic): refusing to read them; nothing was changed"
    )]
    Headers { log: PathBuf, mirror: PathBuf },
    /// The control file names a journal that is gone (both copies).
    #[error(
        "the session's journal {journal} is missing, and so is its mirror {mirror}, but \
         {control} names it as the journal of every transaction from version {first_version} \
         on: the transactions acknowledged since version {} would be lost (the data directory \
         holds the model up to version {found}). Refusing to start; nothing was changed. \
         Restore the journal files, or, to accept the loss, move {control} aside (the keeper \
         then starts from version {found}), or start over with `robosim up SCENE --fresh` (the \
         data directory is moved aside, not deleted)",
        first_version - 1
    )]
    Missing {
        control: PathBuf,
        journal: PathBuf,
        mirror: PathBuf,
        first_version: u64,
        found: u64,
    },
    /// The control file says a checkpoint holds version `needed`, and none does.
    #[error(
        "{control} says version {needed} is checkpointed in {checkpoint}, but the data \
         directory holds the model only up to version {found} ({}): refusing to start; nothing \
         was changed. Restore the checkpoint, or, to accept the loss, move {control} aside, or \
         start over with `robosim up SCENE --fresh` (the data directory is moved aside, not \
         deleted)",
        match used { Some(c) => format!("from {c}"), None => "no readable checkpoint".to_owned() }
    )]
    Behind {
        control: PathBuf,
        checkpoint: PathBuf,
        needed: u64,
        found: u64,
        used: Option<String>,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> JournalError + '_ {
    move |source| JournalError::Io {
        path: path.to_owned(),
        source,
    }
}

/// The open journal the keeper appends to.
pub struct Journal {
    dir: PathBuf,
    path: PathBuf,
    out: BufWriter<File>,
    /// The second copy (`journal-<v>.mirror`, same bytes) when the journal keeps two.
    mirror: Option<(PathBuf, BufWriter<File>)>,
    /// Records appended since the last checkpoint.
    pub since_checkpoint: u64,
    dirty: bool,
}

fn journal_name(first_version: u64) -> String {
    format!("journal-{first_version:020}.log")
}
fn checkpoint_name(version: u64) -> String {
    format!("checkpoint-{version:020}.bin")
}
/// The mirror of a journal file: same directory, same stem, `.mirror`.
fn mirror_path(journal: &Path) -> PathBuf {
    journal.with_extension("mirror")
}

fn create_private(path: &Path) -> Result<File, JournalError> {
    OpenOptions::new()
        .create(true)
        .truncate(true)
        .write(true)
        .mode(0o600)
        .open(path)
        .map_err(io_err(path))
}

fn sync_dir(dir: &Path) -> Result<(), JournalError> {
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(io_err(dir))
}

/// Removes the file `m` if there is one.
fn remove_if_present(m: &Path) -> Result<(), JournalError> {
    match fs::remove_file(m) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(JournalError::Io {
            path: m.to_owned(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Creates `path` holding exactly `bytes`, synced.
fn create_with(path: &Path, bytes: &[u8]) -> Result<File, JournalError> {
    let mut f = create_private(path)?;
    f.write_all(bytes).map_err(io_err(path))?;
    f.sync_all().map_err(io_err(path))?;
    Ok(f)
}

impl Journal {
    /// Starts a new journal file whose first record will be `first_version` (one copy).
    pub fn create(dir: &Path, first_version: u64) -> Result<Self, JournalError> {
        Journal::create_copies(dir, first_version, 1)
    }

    /// [`Journal::create`] keeping `copies` (1 or 2) identical files: with 2, every record is
    /// also written to `journal-<v>.mirror`, and recovery reads a damaged record from there.
    pub fn create_copies(dir: &Path, first_version: u64, copies: u8) -> Result<Self, JournalError> {
        let path = dir.join(journal_name(first_version));
        let f = create_with(&path, JOURNAL_MAGIC)?;
        let m = mirror_path(&path);
        let mirror = if copies >= 2 {
            let mf = create_with(&m, JOURNAL_MAGIC)?;
            Some((m, BufWriter::with_capacity(1 << 20, mf)))
        } else {
            // A mirror left by an older journal of this name must not be read for this one.
            remove_if_present(&m)?;
            None
        };
        sync_dir(dir)?;
        write_control(dir, first_version, copies.clamp(1, 2))?;
        Ok(Journal {
            dir: dir.to_owned(),
            path,
            out: BufWriter::with_capacity(1 << 20, f),
            mirror,
            since_checkpoint: 0,
            dirty: false,
        })
    }

    /// How many copies this journal keeps.
    pub fn copies(&self) -> u8 {
        1 + self.mirror.is_some() as u8
    }

    /// Reopens an existing journal for appending, after recovery made its copies hold exactly
    /// what was recovered (and removed the mirror when one copy is kept).
    fn reopen(
        dir: &Path,
        path: PathBuf,
        first_version: u64,
        records: u64,
        copies: u8,
    ) -> Result<Self, JournalError> {
        let open = |p: &Path| OpenOptions::new().append(true).open(p).map_err(io_err(p));
        let f = open(&path)?;
        let mirror = if copies >= 2 {
            let m = mirror_path(&path);
            let mf = open(&m)?;
            Some((m, BufWriter::with_capacity(1 << 20, mf)))
        } else {
            None
        };
        write_control(dir, first_version, copies.clamp(1, 2))?;
        Ok(Journal {
            dir: dir.to_owned(),
            path,
            out: BufWriter::with_capacity(1 << 20, f),
            mirror,
            since_checkpoint: records,
            dirty: false,
        })
    }

    /// Buffers one committed transaction. Not durable until [`Journal::sync`].
    pub fn append(&mut self, version: u64, tx: &[u8]) -> Result<(), JournalError> {
        let mut crc = crc32fast::Hasher::new();
        crc.update(&version.to_le_bytes());
        crc.update(tx);
        let mut head = [0u8; RECORD_HEADER];
        head[0..4].copy_from_slice(&(tx.len() as u32).to_le_bytes());
        head[4..8].copy_from_slice(&crc.finalize().to_le_bytes());
        head[8..16].copy_from_slice(&version.to_le_bytes());
        self.out.write_all(&head).map_err(io_err(&self.path))?;
        self.out.write_all(tx).map_err(io_err(&self.path))?;
        if let Some((m, out)) = &mut self.mirror {
            out.write_all(&head).map_err(io_err(m))?;
            out.write_all(tx).map_err(io_err(m))?;
        }
        self.since_checkpoint += 1;
        self.dirty = true;
        Ok(())
    }

    /// Makes every appended record durable (write + fdatasync). Cheap when nothing is pending.
    pub fn sync(&mut self) -> Result<(), JournalError> {
        if !self.dirty {
            return Ok(());
        }
        self.out.flush().map_err(io_err(&self.path))?;
        match &mut self.mirror {
            None => self.out.get_ref().sync_data().map_err(io_err(&self.path))?,
            Some((m, out)) => {
                out.flush().map_err(io_err(m))?;
                // The two syncs go to the device together: the group waits for the slower,
                // not for their sum.
                let (a, b) = (self.out.get_ref(), out.get_ref());
                let (ra, rb) = std::thread::scope(|sc| {
                    let h = sc.spawn(|| b.sync_data());
                    (a.sync_data(), h.join())
                });
                ra.map_err(io_err(&self.path))?;
                match rb {
                    Ok(r) => r.map_err(io_err(m))?,
                    Err(_) => {
                        return Err(JournalError::Io {
                            path: m.clone(),
                            source: std::io::Error::other("the mirror's sync thread panicked"),
                        });
                    }
                }
            }
        }
        self.dirty = false;
        Ok(())
    }

    /// Writes a checkpoint of `model`, starts a new journal after it and removes the files the
    /// checkpoint made redundant. Call after [`Journal::sync`].
    pub fn checkpoint(&mut self, model: &Store) -> Result<(), JournalError> {
        self.sync()?;
        write_checkpoint(&self.dir, model)?;
        let next = Journal::create_copies(&self.dir, model.version + 1, self.copies())?;
        let old = std::mem::replace(self, next);
        drop(old);
        // Remove journals and checkpoints older than this checkpoint.
        let keep_ck = checkpoint_name(model.version);
        let keep_j = journal_name(model.version + 1);
        for e in fs::read_dir(&self.dir)
            .map_err(io_err(&self.dir))?
            .flatten()
        {
            let name = e.file_name().to_string_lossy().into_owned();
            let stale = (name.starts_with("journal-")
                && (name.ends_with(".log") || name.ends_with(".mirror"))
                && name < keep_j)
                || (name.starts_with("checkpoint-") && name.ends_with(".bin") && name < keep_ck);
            if stale {
                let _ = fs::remove_file(e.path());
            }
        }
        sync_dir(&self.dir)
    }
}

/// One object in checkpoint form: every aspect of an Instance Space object as plain data, the
/// geometry as the vertices and polygons a writer sends (the derived forms are recomputed on
/// load). The keeper's checkpoints and the file interface's model files (`file-io/`) both hold
/// objects in this form, so there is one serialised model, not two.
///
/// Units and frames as in [`Object`]: metres, radians, kilograms; `pose` local to `parent`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectData {
    pub id: Id,
    pub kind: Kind,
    /// 0: a root.
    pub parent: Id,
    pub name: String,
    pub pose: Pose,
    pub joint: f64,
    pub appearance: Appearance,
    pub kinematics: Option<Kinematics>,
    pub dynamics: Option<MassProps>,
    pub geometry: Option<GeometryInput>,
    pub geom_gen: u64,
    pub origin: String,
}

#[derive(Serialize, Deserialize)]
struct CheckpointData {
    version: u64,
    next_id: Id,
    objects: Vec<ObjectData>,
}

/// The whole model as checkpoint bytes: magic, crc32 of the body, the body (bincode). The same
/// bytes are a checkpoint file's and what a network bridge sends a late joiner
/// ([`decode_store`] reads both).
pub fn encode_store(model: &Store) -> Vec<u8> {
    let data = CheckpointData {
        version: model.version,
        next_id: model.next_id(),
        objects: model
            .objects()
            .map(|o| ObjectData {
                id: o.id,
                kind: o.kind,
                parent: o.parent,
                name: o.name.clone(),
                pose: o.pose,
                joint: o.joint,
                appearance: o.appearance,
                kinematics: o.kinematics,
                dynamics: o.dynamics,
                geometry: o.geometry.as_deref().map(GeometryInput::from_polyhedron),
                geom_gen: o.geom_gen,
                origin: o.origin.clone(),
            })
            .collect(),
    };
    let mut body =
        bincode::serde::encode_to_vec(&data, bincode::config::standard()).unwrap_or_default();
    // The session's selection follows the objects (a checkpoint written before selections
    // existed simply ends after them: see `decode_store`).
    body.extend(
        bincode::serde::encode_to_vec(model.selection(), bincode::config::standard())
            .unwrap_or_default(),
    );
    let mut out = Vec::with_capacity(12 + body.len());
    out.extend_from_slice(CHECKPOINT_MAGIC);
    out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

fn write_checkpoint(dir: &Path, model: &Store) -> Result<(), JournalError> {
    let path = dir.join(checkpoint_name(model.version));
    let tmp = path.with_extension("tmp");
    let mut f = create_private(&tmp)?;
    f.write_all(&encode_store(model)).map_err(io_err(&tmp))?;
    f.sync_all().map_err(io_err(&tmp))?;
    fs::rename(&tmp, &path).map_err(io_err(&path))?;
    sync_dir(dir)
}

fn read_checkpoint(path: &Path) -> Result<Store, JournalError> {
    let bytes = fs::read(path).map_err(io_err(path))?;
    decode_store(&bytes).map_err(|e| match e {
        StoreDecodeError::Magic => JournalError::Magic {
            path: path.to_owned(),
            what: "checkpoint",
        },
        StoreDecodeError::Corrupt(source) => JournalError::Checkpoint {
            path: path.to_owned(),
            source,
        },
    })
}

/// Why [`decode_store`] refused its bytes.
#[derive(Debug, thiserror::Error)]
pub enum StoreDecodeError {
    #[error("not a robosim model encoding (bad magic)")]
    Magic,
    #[error("model encoding is corrupt: {0}")]
    Corrupt(#[source] Corruption),
}

/// What is wrong inside a model encoding whose magic is right (a checkpoint file's, or a
/// snapshot's): the decoder's own error kept as the source.
#[derive(Debug, thiserror::Error)]
pub enum Corruption {
    #[error("checksum mismatch")]
    Checksum,
    /// The objects do not decode.
    #[error("{0}")]
    Decode(#[source] bincode::error::DecodeError),
    #[error("trailing bytes after the selection")]
    TrailingBytes,
    /// The selection after the objects does not decode.
    #[error("selection: {0}")]
    Selection(#[source] bincode::error::DecodeError),
    /// An object's stored geometry is not a valid polyhedron.
    #[error("object {id}: {source}")]
    Geometry {
        id: Id,
        #[source]
        source: robosim_geometry::GeometryError,
    },
}

/// Reads [`encode_store`]'s bytes back into a model: checksum, bounded decode, every geometry
/// re-validated, as recovery does.
pub fn decode_store(bytes: &[u8]) -> Result<Store, StoreDecodeError> {
    let bad = StoreDecodeError::Corrupt;
    if bytes.len() < 12 || &bytes[..8] != CHECKPOINT_MAGIC {
        return Err(StoreDecodeError::Magic);
    }
    let crc = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if crc32fast::hash(&bytes[12..]) != crc {
        return Err(bad(Corruption::Checksum));
    }
    let (data, used) = decode_checkpoint(&bytes[12..]).map_err(|e| bad(Corruption::Decode(e)))?;
    let rest = &bytes[12 + used..];
    let selection: Option<crate::Selection> = if rest.is_empty() {
        None
    } else {
        match bincode::serde::decode_from_slice(rest, bincode::config::standard()) {
            Ok((s, n)) if n == rest.len() => s,
            Ok(_) => return Err(bad(Corruption::TrailingBytes)),
            Err(e) => return Err(bad(Corruption::Selection(e))),
        }
    };
    let mut objects = Vec::with_capacity(data.objects.len());
    for o in data.objects {
        let geometry = match o.geometry {
            None => None,
            Some(g) => {
                let verts = g
                    .vertices
                    .iter()
                    .map(|v| nalgebra::Point3::new(v[0], v[1], v[2]))
                    .collect();
                let p = robosim_geometry::Polyhedron::from_polygons(verts, &g.polygons)
                    .map_err(|source| bad(Corruption::Geometry { id: o.id, source }))?;
                Some(Arc::new(p))
            }
        };
        objects.push(Object {
            id: o.id,
            kind: o.kind,
            parent: o.parent,
            name: o.name,
            pose: o.pose,
            joint: o.joint,
            appearance: o.appearance,
            kinematics: o.kinematics,
            dynamics: o.dynamics,
            geometry,
            geom_gen: o.geom_gen,
            origin: o.origin,
        });
    }
    Ok(Store::from_parts(
        data.version,
        data.next_id,
        objects,
        selection,
    ))
}

/// Replaces everything in the data directory `dir` by `model`: every journal and checkpoint
/// there is removed, a checkpoint of `model` written and a new journal opened after it. For a
/// mirror that takes its model from elsewhere (a bridge's snapshot), not for recovery.
pub fn reset(dir: &Path, model: &Store, copies: u8) -> Result<Journal, JournalError> {
    // The control file first: it must never name a journal this removes.
    remove_if_present(&dir.join(CONTROL_FILE))?;
    for e in fs::read_dir(dir).map_err(io_err(dir))?.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if (name.starts_with("journal-") && (name.ends_with(".log") || name.ends_with(".mirror")))
            || (name.starts_with("checkpoint-") && name.ends_with(".bin"))
        {
            fs::remove_file(e.path()).map_err(io_err(&e.path()))?;
        }
    }
    write_checkpoint(dir, model)?;
    Journal::create_copies(dir, model.version + 1, copies)
}

/// The file in a session's `run/` directory where the keeper leaves [`RecoveryReport::notice`]
/// when its recovery lost or repaired something (removed when a later recovery finds nothing).
pub const LOST_NOTE: &str = "recovery-lost.txt";

/// Decodes a checkpoint body with a memory limit in proportion to its size, as
/// `Transaction::decode` does: a length prefix claiming more than the body could describe
/// (a 1 KiB checkpoint whose name claims 2^62 bytes, found by the `journal` fuzz target) is
/// refused before anything is allocated; without the limit bincode allocated first, and an
/// impossible size aborted the keeper during recovery.
/// Returns the data and the bytes it took.
fn decode_checkpoint(body: &[u8]) -> Result<(CheckpointData, usize), bincode::error::DecodeError> {
    use bincode::config::standard;
    // decoded size is at most ~32× the encoded size (an empty Vec: 1 byte on disk, 24 in memory)
    let limit = body.len().saturating_mul(32).saturating_add(4096);
    macro_rules! within {
        ($($n:literal),*) => {
            $( if limit <= (1usize << $n) {
                return bincode::serde::decode_from_slice(body, standard().with_limit::<{ 1usize << $n }>());
            } )*
        };
    }
    within!(16, 20, 24, 28, 30, 32, 34);
    bincode::serde::decode_from_slice(body, standard().with_limit::<{ 1usize << 36 }>())
}

/// What recovery found.
#[derive(Debug, Default, Clone)]
pub struct RecoveryReport {
    /// The checkpoint version started from (0: none).
    pub checkpoint_version: u64,
    /// Journal records replayed after it.
    pub replayed: u64,
    /// Problems found and what was done about them (torn tails cut off, bad checkpoints skipped).
    pub problems: Vec<String>,
    /// Journal bytes that could not be replayed, each kept as a file (see [`LostTail`]). A
    /// torn last record — a crash in the middle of a write, never acknowledged — is not listed
    /// when nothing readable follows it; anything else is.
    pub lost: Vec<LostTail>,
}

impl RecoveryReport {
    /// Readable (checksummed, once acknowledged) records that recovery could not replay.
    pub fn lost_records(&self) -> u64 {
        self.lost.iter().map(|l| l.readable_records).sum()
    }

    /// What a launcher says aloud after the keeper started: [`RecoveryReport::lost_message`],
    /// then every problem recovery found and what it did (a copy repaired from the other, a
    /// torn tail cut); empty when recovery found nothing to say.
    pub fn notice(&self) -> String {
        let mut m = self.lost_message();
        if !self.problems.is_empty() {
            m += "recovery of the journal found:\n";
            for p in &self.problems {
                m += &format!("  {p}\n");
            }
        }
        m
    }

    /// The loud paragraph a command line prints when something was lost (empty otherwise).
    pub fn lost_message(&self) -> String {
        if self.lost.is_empty() {
            return String::new();
        }
        let mut m = format!(
            "RECOVERY LOST DATA: the model was recovered only up to version {}.\n",
            self.lost[0].first_version - 1
        );
        for l in &self.lost {
            let range = match l.last_version {
                Some(v) => format!("versions {}..={v}", l.first_version),
                None => format!("from version {}", l.first_version),
            };
            m += &format!(
                "  {}: {range} not replayed: {} readable record(s) (acknowledged transactions) and {} damaged byte(s).\n  The cut is kept in {}\n  Inspect it with: robosim journal inspect {}\n",
                l.cause,
                l.readable_records,
                l.damaged_bytes,
                l.copy.display(),
                l.copy.display()
            );
        }
        m
    }
}

/// A part of the journal recovery had to cut: its cause, what it held and where it was kept.
#[derive(Debug, Clone, PartialEq)]
pub struct LostTail {
    /// What was found where (file, byte offset, reason).
    pub cause: String,
    /// The first version the recovered model lacks (its version + 1).
    pub first_version: u64,
    /// The highest version in a readable record of the cut (`None`: nothing readable).
    pub last_version: Option<u64>,
    /// Records of the cut whose checksum holds: transactions that were acknowledged once.
    pub readable_records: u64,
    /// Bytes of the cut that belong to no readable record (the damage itself).
    pub damaged_bytes: u64,
    /// The file the cut was kept in: a journal of its own, readable by [`inspect`].
    pub copy: PathBuf,
}

/// One record found by [`scan_records`]: byte offset, version, payload length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordAt {
    pub offset: usize,
    pub version: u64,
    pub len: usize,
}

/// The readable records of `bytes[from..]`, resynchronising after damage: at an offset whose
/// header does not check out, the scan moves one byte on (a record is accepted only if its
/// length fits and its CRC matches, and the CRC is computed only for a version above the last
/// one found, so garbage costs little). Returns the records and the bytes that belong to none.
pub fn scan_records(bytes: &[u8], from: usize) -> (Vec<RecordAt>, u64) {
    let mut out: Vec<RecordAt> = Vec::new();
    let (mut pos, mut damaged) = (from, 0u64);
    while pos < bytes.len() {
        if let Some(r) = record_at(bytes, pos, out.last().map(|r| r.version)) {
            pos += RECORD_HEADER + r.len;
            out.push(r);
        } else {
            pos += 1;
            damaged += 1;
        }
    }
    (out, damaged)
}

/// The record whose header starts at `pos`, if it checks out (and its version is above
/// `after`, when given).
fn record_at(bytes: &[u8], pos: usize, after: Option<u64>) -> Option<RecordAt> {
    let head = bytes.get(pos..pos + RECORD_HEADER)?;
    let len = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    let version = u64::from_le_bytes(head[8..16].try_into().ok()?);
    if version == 0 || after.is_some_and(|a| version <= a) {
        return None;
    }
    let payload = bytes.get(pos + RECORD_HEADER..(pos + RECORD_HEADER).checked_add(len)?)?;
    let mut h = crc32fast::Hasher::new();
    h.update(&head[8..16]);
    h.update(payload);
    (h.finalize() == crc).then_some(RecordAt {
        offset: pos,
        version,
        len,
    })
}

/// `<data>/lost/`, made (private to the user) if it is not there.
fn make_lost_dir(dir: &Path) -> Result<PathBuf, JournalError> {
    let lost_dir = dir.join("lost");
    fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(&lost_dir)
        .map_err(io_err(&lost_dir))?;
    Ok(lost_dir)
}

/// Keeps `bytes[from..]` of the journal `path` as a journal file of its own under
/// `<data>/lost/` and describes what it holds.
fn keep_cut(
    dir: &Path,
    path: &Path,
    bytes: &[u8],
    from: usize,
    first_version: u64,
    cause: String,
) -> Result<LostTail, JournalError> {
    let lost_dir = make_lost_dir(dir)?;
    let stamp = unique_stamp();
    let base = path
        .file_name()
        .map_or_else(|| "journal".into(), |n| n.to_string_lossy().into_owned());
    let copy = lost_dir.join(format!("{base}.cut-at-{from}.{stamp}"));
    let mut f = create_private(&copy)?;
    f.write_all(JOURNAL_MAGIC)
        .and_then(|_| f.write_all(&bytes[from..]))
        .and_then(|_| f.sync_all())
        .map_err(io_err(&copy))?;
    sync_dir(&lost_dir)?;
    let (records, damaged) = scan_records(bytes, from);
    Ok(LostTail {
        cause,
        first_version,
        last_version: records.iter().map(|r| r.version).max(),
        readable_records: records.len() as u64,
        damaged_bytes: damaged,
        copy,
    })
}

/// One line per record of the journal file `path` (a session journal or a kept cut): offset,
/// version, size, checksum and the transaction's operations; damaged stretches are named with
/// their length. For `robosim journal inspect`.
pub fn inspect(path: &Path, out: &mut dyn Write) -> Result<(), JournalError> {
    let bytes = read_journal_bytes(path)?;
    if bytes.len() < 8 || &bytes[..8] != JOURNAL_MAGIC {
        return Err(JournalError::Magic {
            path: path.to_owned(),
            what: "journal",
        });
    }
    let w = |e| JournalError::Io {
        path: PathBuf::from("<output>"),
        source: e,
    };
    let (records, damaged) = scan_records(&bytes, 8);
    writeln!(
        out,
        "{}: {} bytes, {} readable record(s), {} damaged byte(s)",
        path.display(),
        bytes.len(),
        records.len(),
        damaged
    )
    .map_err(w)?;
    let mut pos = 8usize;
    for r in &records {
        if r.offset > pos {
            writeln!(out, "  @{pos}: {} damaged byte(s)", r.offset - pos).map_err(w)?;
        }
        let payload = &bytes[r.offset + RECORD_HEADER..r.offset + RECORD_HEADER + r.len];
        let what = match Transaction::decode(payload) {
            Ok(tx) => summarize(&tx),
            Err(e) => format!("undecodable transaction ({e})"),
        };
        writeln!(
            out,
            "  @{}: version {} ({} bytes): {what}",
            r.offset, r.version, r.len
        )
        .map_err(w)?;
        pos = r.offset + RECORD_HEADER + r.len;
    }
    if bytes.len() > pos {
        writeln!(out, "  @{pos}: {} damaged byte(s)", bytes.len() - pos).map_err(w)?;
    }
    Ok(())
}

/// "3 ops: create solid \"arm\", set_joint #12 = 0.5, …" (at most 4 named).
fn summarize(tx: &Transaction) -> String {
    use crate::transaction::Op;
    let names: Vec<String> = tx
        .ops()
        .iter()
        .take(4)
        .map(|op| match op {
            Op::Create { kind, name, .. } => format!("create {kind:?} {name:?}"),
            Op::Delete { id, .. } => format!("delete {id:?}"),
            Op::SetJoint { id, value } => format!("set_joint {id:?} = {value}"),
            Op::SetName { id, name } => format!("set_name {id:?} = {name:?}"),
            other => {
                let d = format!("{other:?}");
                d.split([' ', '{', '(']).next().unwrap_or("op").to_owned()
            }
        })
        .collect();
    let more = tx.len().saturating_sub(names.len());
    let tail = if more > 0 {
        format!(", … {more} more")
    } else {
        String::new()
    };
    format!("{} op(s): {}{tail}", tx.len(), names.join(", "))
}

/// Reads a journal file, refusing anything that is not a regular file.
fn read_journal_bytes(path: &Path) -> Result<Vec<u8>, JournalError> {
    let meta = fs::metadata(path).map_err(io_err(path))?;
    if !meta.is_file() {
        return Err(JournalError::Io {
            path: path.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"),
        });
    }
    let mut bytes = Vec::new();
    File::open(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(io_err(path))?;
    Ok(bytes)
}

/// Rebuilds the model from `dir` and opens the journal for appending (one copy).
pub fn recover(dir: &Path) -> Result<(Store, Journal, RecoveryReport), JournalError> {
    recover_copies(dir, 1)
}

/// The session's journal control file, in the data directory beside the journal: which
/// journal file is current, the version it starts at (the checkpoint before it holds every
/// version below) and how many copies it keeps. Written (temp file, fsync, rename, directory
/// fsync) whenever a journal file is started or reopened — at a session's first start, at
/// every checkpoint (the keeper's clean stop writes one), after every recovery.
///
/// Recovery reads it before anything else and refuses to start (changing nothing) when the
/// data directory holds less than it names: the current journal gone (both copies), or no
/// checkpoint/journal reaching the version the journal starts after. This is PostgreSQL's
/// `pg_control`: a vanished journal is an error naming the files and versions, not a new,
/// empty session at version 1. A data directory without it (written by an older robosim) is
/// recovered as found, and gets one.
pub const CONTROL_FILE: &str = "journal.control";
const CONTROL_HEAD: &str = "robosim journal control 1";

/// What [`CONTROL_FILE`] says.
#[derive(Debug, Clone, PartialEq)]
pub struct Control {
    /// The current journal's file name (`journal-<first version>.log`).
    pub journal: String,
    /// The version of the journal's first record: every version below it is in a checkpoint
    /// (or there is none: 1).
    pub first_version: u64,
    /// The copies the journal was written with (1, or 2 with a `.mirror`).
    pub copies: u8,
}

fn write_control(dir: &Path, first_version: u64, copies: u8) -> Result<(), JournalError> {
    let text = format!(
        "{CONTROL_HEAD}\njournal {}\nfirst_version {first_version}\ncopies {copies}\n",
        journal_name(first_version)
    );
    let path = dir.join(CONTROL_FILE);
    let tmp = dir.join(format!("{CONTROL_FILE}.tmp"));
    drop(create_with(&tmp, text.as_bytes())?);
    fs::rename(&tmp, &path).map_err(io_err(&path))?;
    sync_dir(dir)
}

/// Reads the data directory's [`CONTROL_FILE`]; `None` when there is none.
pub fn read_control(dir: &Path) -> Result<Option<Control>, JournalError> {
    let path = dir.join(CONTROL_FILE);
    let bad = |reason: String| JournalError::Control {
        path: path.clone(),
        reason,
    };
    let meta = match fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io_err(&path)(e)),
        Ok(m) => m,
    };
    if !meta.is_file() || meta.len() > 4096 {
        return Err(bad(format!(
            "not a regular file of at most 4096 bytes ({} bytes)",
            meta.len()
        )));
    }
    let text = fs::read_to_string(&path).map_err(io_err(&path))?;
    let mut lines = text.lines();
    if lines.next() != Some(CONTROL_HEAD) {
        return Err(bad(format!("its first line is not {CONTROL_HEAD:?}")));
    }
    let (mut journal, mut first, mut copies) = (None, None, None);
    for l in lines {
        match l.split_once(' ') {
            Some(("journal", v)) => journal = Some(v.to_owned()),
            Some(("first_version", v)) => first = v.parse::<u64>().ok(),
            Some(("copies", v)) => copies = v.parse::<u8>().ok().filter(|c| (1..=2).contains(c)),
            _ => return Err(bad(format!("unexpected line {l:?}"))),
        }
    }
    match (journal, first, copies) {
        (Some(journal), Some(first_version), Some(copies))
            if first_version >= 1 && journal == journal_name(first_version) =>
        {
            Ok(Some(Control {
                journal,
                first_version,
                copies,
            }))
        }
        _ => Err(bad(
            "it must name the journal, its first version (>= 1, as in the name) and its copies (1 or 2)"
                .into(),
        )),
    }
}

/// A journal file's first version, from its name (`journal-<20 digits>.log` / `.mirror`).
fn journal_first_version(name: &str) -> Option<u64> {
    let stem = name
        .strip_suffix(".log")
        .or_else(|| name.strip_suffix(".mirror"))?
        .strip_prefix("journal-")?;
    (stem.len() == 20 && stem.bytes().all(|b| b.is_ascii_digit()))
        .then(|| stem.parse().ok())
        .flatten()
}

/// Reads a journal copy: `None` when there is none.
fn read_copy(path: &Path) -> Result<Option<Vec<u8>>, JournalError> {
    match fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_err(path)(e)),
        Ok(_) => read_journal_bytes(path).map(Some),
    }
}

const COPY_NAMES: [&str; 2] = ["log", "mirror"];

/// A journal file's two copies as read, and what recovery makes of them (worked out before
/// anything on disk changes: see [`recover_copies`]).
struct PairPlan {
    first: u64,
    paths: [PathBuf; 2],
    orig: [Option<Vec<u8>>; 2],
    /// The journal as recovered: the header and every record taken, each from a copy where it
    /// checks out. Both copies are made this (a copy's extra bytes kept first, see `cut`).
    good: Vec<u8>,
    /// Records replayed into the model.
    records: u64,
    /// Per copy: the records it lacked or held damaged, (byte offset, version, what was wrong).
    repairs: [Vec<(usize, u64, String)>; 2],
    /// Per copy: why it is kept whole under `lost/` before it is rewritten (it held a readable
    /// record other than the one taken).
    keep_whole: [Option<String>; 2],
    /// Where replay stopped before the end of a copy.
    cut: Option<Cut>,
    /// Follows a cut in an earlier journal: set aside whole.
    aside: bool,
    header_problem: Option<String>,
}

impl PairPlan {
    /// The plan for journal `first` before its copies are compared: nothing replayed,
    /// repaired, cut or set aside yet.
    fn new(first: u64, paths: [PathBuf; 2], orig: [Option<Vec<u8>>; 2], good: Vec<u8>) -> Self {
        PairPlan {
            first,
            paths,
            orig,
            good,
            records: 0,
            repairs: [Vec::new(), Vec::new()],
            keep_whole: [None, None],
            cut: None,
            aside: false,
            header_problem: None,
        }
    }
}

struct Cut {
    pos: usize,
    cause: String,
    /// The first version the recovered model lacks.
    first_version: u64,
    /// Only a record torn by a crash while it was written, in every copy, with nothing
    /// readable after it: never acknowledged (the sync that acknowledges it did not finish).
    torn: bool,
}

/// The record at `pos` of `bytes` whose length field is damaged but whose checksum holds for
/// some length: (length, version). The length is the one field the checksum does not cover; a
/// record is taken with a repaired length only if it ends at the end of the copy or where a
/// record of the next version starts, and its transaction decodes.
fn length_repaired(bytes: &[u8], pos: usize, version: u64) -> Option<usize> {
    let head = bytes.get(pos..pos + RECORD_HEADER)?;
    if u64::from_le_bytes(head[8..16].try_into().ok()?) != version {
        return None;
    }
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    let body = &bytes[pos + RECORD_HEADER..];
    let next = (version + 1).to_le_bytes();
    // Where the record can end: the end of the copy, or a header naming the next version
    // (a cheap comparison first; the checksums only there).
    (0..=body.len())
        .filter(|&len| {
            let end = pos + RECORD_HEADER + len;
            end == bytes.len() || bytes.get(end + 8..end + 16) == Some(&next[..])
        })
        .find(|&len| {
            let end = pos + RECORD_HEADER + len;
            let mut h = crc32fast::Hasher::new();
            h.update(&head[8..16]);
            h.update(&body[..len]);
            h.finalize() == crc
                && (end == bytes.len()
                    || matches!(check_record(bytes, end), Ok((_, v)) if v == version + 1))
                && Transaction::decode(&body[..len]).is_ok()
        })
}

/// Is `bytes[pos..]` nothing but a record torn while being written (or nothing at all)?
fn only_torn(bytes: &[u8], pos: usize) -> bool {
    bytes.len() <= pos
        || (matches!(
            check_record(bytes, pos),
            Err("torn record header" | "torn record")
        ) && scan_records(bytes, pos).0.is_empty())
}

/// Works out one journal file: reads both copies, takes record by record the longest valid
/// prefix over them (a record is taken from whichever copy holds it intact and in sequence)
/// and replays it into `model`. Changes nothing on disk.
fn plan_pair(
    dir: &Path,
    first: u64,
    model: &mut Store,
    mirror_expected: bool,
) -> Result<PairPlan, JournalError> {
    let log = dir.join(journal_name(first));
    let mirror = mirror_path(&log);
    let orig = [read_copy(&log)?, read_copy(&mirror)?];
    let paths = [log, mirror];
    let mut plan = PairPlan::new(first, paths, orig, JOURNAL_MAGIC.to_vec());
    let header_ok =
        |b: &Option<Vec<u8>>| b.as_deref().is_some_and(|b| b.starts_with(JOURNAL_MAGIC));
    if !plan.orig.iter().any(header_ok) {
        let torn_only = plan
            .orig
            .iter()
            .flatten()
            .all(|b| b.len() < JOURNAL_MAGIC.len() && JOURNAL_MAGIC.starts_with(b));
        if !torn_only {
            return Err(JournalError::Headers {
                log: plan.paths[0].clone(),
                mirror: plan.paths[1].clone(),
            });
        }
        // Torn while being created: it holds nothing.
        plan.header_problem = Some(format!(
            "{}: torn header ({} bytes); rewritten empty",
            plan.paths[0].display(),
            plan.orig[0].as_ref().map_or(0, Vec::len)
        ));
        return Ok(plan);
    }
    for i in 0..2 {
        let missing_ok = i == 1 && !mirror_expected;
        match &plan.orig[i] {
            None if missing_ok => {}
            None => plan.repairs[i].push((0, 0, "missing".into())),
            Some(b) if !b.starts_with(JOURNAL_MAGIC) => {
                plan.repairs[i].push((0, 0, "damaged header".into()))
            }
            Some(_) => {}
        }
    }
    let mut pos = JOURNAL_MAGIC.len();
    while plan.orig.iter().flatten().any(|b| b.len() > pos) {
        let expected = model.version + 1;
        let mut why: [String; 2] = [String::new(), String::new()];
        let mut cand: [Option<(usize, u64, bool)>; 2] = [None, None];
        for i in 0..2 {
            // The mirror's bytes the same as the log's record: the same record (one checksum).
            if i == 1
                && let (Some((len, ..)), Some(a), Some(b)) = (cand[0], &plan.orig[0], &plan.orig[1])
                && b.get(pos..pos + RECORD_HEADER + len) == a.get(pos..pos + RECORD_HEADER + len)
            {
                cand[1] = cand[0];
                continue;
            }
            match &plan.orig[i] {
                None => why[i] = "missing".into(),
                Some(b) if b.len() <= pos => why[i] = format!("ends at byte {}", b.len()),
                Some(b) => match check_record(b, pos) {
                    Ok((len, v)) if v == expected || v <= model.version => {
                        cand[i] = Some((len, v, false))
                    }
                    Ok((_, v)) => {
                        why[i] = format!("version {v} out of sequence (expected {expected})")
                    }
                    Err(w) => why[i] = w.into(),
                },
            }
        }
        if cand.iter().all(Option::is_none) {
            for i in 0..2 {
                if let Some(b) = &plan.orig[i]
                    && let Some(len) = length_repaired(b, pos, expected)
                {
                    cand[i] = Some((len, expected, true));
                }
            }
        }
        // The record as it must be: its bytes from copy `i`, the length field rewritten.
        let record = |i: usize, (len, _, _): (usize, u64, bool)| -> Vec<u8> {
            let mut r = plan.orig[i].as_deref().unwrap_or_default()[pos..pos + RECORD_HEADER + len]
                .to_vec();
            r[0..4].copy_from_slice(&(len as u32).to_le_bytes());
            r
        };
        let Some(i) = (0..2).find(|&i| cand[i].is_some()) else {
            let torn = plan.orig.iter().flatten().all(|b| only_torn(b, pos));
            let parts: Vec<String> = (0..2)
                .filter(|&i| plan.orig[i].is_some() || mirror_expected)
                .map(|i| {
                    let at = if why[i].starts_with("ends at") || why[i] == "missing" {
                        String::new()
                    } else {
                        format!(" at byte {pos}")
                    };
                    format!("{}: {}{at}", plan.paths[i].display(), why[i])
                })
                .collect();
            plan.cut = Some(Cut {
                pos,
                cause: parts.join("; "),
                first_version: expected,
                torn,
            });
            break;
        };
        let Some(c) = cand[i] else { break };
        let rec = record(i, c);
        let j = 1 - i;
        let rec_j = cand[j].map(|cj| record(j, cj));
        let v = c.1;
        if c.2 {
            plan.repairs[i].push((pos, v, "damaged length field".into()));
        }
        match cand[j] {
            Some(cj) if rec_j.as_deref() == Some(&rec[..]) => {
                if cj.2 {
                    plan.repairs[j].push((pos, v, "damaged length field".into()));
                }
            }
            Some((_, vj, _)) => {
                plan.keep_whole[j] = Some(format!(
                    "its record at byte {pos} (version {vj}) differs from the {}'s (version {v}), which was taken",
                    COPY_NAMES[i]
                ));
                plan.repairs[j].push((pos, v, "a different record".into()));
            }
            None if plan.orig[j].is_none() && j == 1 && !mirror_expected => {}
            None => plan.repairs[j].push((pos, v, std::mem::take(&mut why[j]))),
        }
        if v > model.version {
            let payload = &rec[RECORD_HEADER..];
            if let Err(e) = Transaction::decode(payload).and_then(|tx| model.apply(&tx)) {
                plan.cut = Some(Cut {
                    pos,
                    cause: format!(
                        "{}: record for version {v} no longer applies ({e}) at byte {pos}",
                        plan.paths[0].display()
                    ),
                    first_version: v,
                    torn: false,
                });
                break;
            }
            plan.records += 1;
        }
        plan.good.extend_from_slice(&rec);
        pos += rec.len();
    }
    Ok(plan)
}

/// "versions 58..=201 (144 records)" / "version 20".
fn versions_words(repairs: &[(usize, u64, String)]) -> String {
    let vs: Vec<u64> = repairs.iter().map(|r| r.1).filter(|&v| v > 0).collect();
    match (vs.first(), vs.last()) {
        (Some(a), Some(b)) if vs.len() == 1 || a == b => format!("the record of version {a}"),
        (Some(a), Some(b)) => format!("{} records (versions {a}..={b})", vs.len()),
        _ => "its header".into(),
    }
}

/// Does what `plan` worked out, on disk: keeps whatever a copy holds that the recovered journal
/// lacks (under `lost/`), then rewrites each copy to the recovered journal (temp file, fsync,
/// rename: at every moment one copy holds every record taken).
fn carry_out(
    dir: &Path,
    plan: &PairPlan,
    copies: u8,
    report: &mut RecoveryReport,
) -> Result<(), JournalError> {
    if let Some(p) = &plan.header_problem {
        report.problems.push(p.clone());
    }
    for i in 0..2 {
        if let (Some(reason), Some(bytes)) = (&plan.keep_whole[i], &plan.orig[i]) {
            let kept = keep_whole(dir, &plan.paths[i], bytes)?;
            report.problems.push(format!(
                "{}: the copies disagree: {reason}; this copy is kept whole as {}",
                plan.paths[i].display(),
                kept.display()
            ));
        }
        let r = &plan.repairs[i];
        if let Some((pos, _, what)) = r.first() {
            let other = COPY_NAMES[1 - i];
            report.problems.push(if what == "missing" {
                format!(
                    "{}: missing; rewritten from the {other}",
                    plan.paths[i].display()
                )
            } else {
                format!(
                    "{}: {what} at byte {pos}; {} {} repaired from the {other}",
                    plan.paths[i].display(),
                    versions_words(r),
                    if r.iter().filter(|x| x.1 > 0).count() > 1 {
                        "were"
                    } else {
                        "was"
                    }
                )
            });
        }
    }
    if let Some(cut) = &plan.cut {
        let tail_bytes: u64 = plan
            .orig
            .iter()
            .flatten()
            .map(|b| b.len().saturating_sub(cut.pos) as u64)
            .max()
            .unwrap_or(0);
        report.problems.push(format!(
            "{}; dropped the tail ({tail_bytes} bytes)",
            cut.cause
        ));
        if !cut.torn {
            // Keep the tail of the copy holding the most readable records (then the longer).
            let rank = |i: usize| {
                plan.orig[i].as_deref().map_or((0, 0), |b| {
                    let n = if b.len() > cut.pos {
                        scan_records(b, cut.pos).0.len()
                    } else {
                        0
                    };
                    (n, b.len())
                })
            };
            let best = if rank(1) > rank(0) { 1 } else { 0 };
            if let Some(b) = &plan.orig[best] {
                let tail = keep_cut(
                    dir,
                    &plan.paths[best],
                    b,
                    cut.pos.min(b.len()),
                    cut.first_version,
                    cut.cause.clone(),
                )?;
                report.lost.push(tail);
            }
            let other = 1 - best;
            if let (Some(a), Some(b)) = (&plan.orig[best], &plan.orig[other])
                && b.len() > cut.pos
                && a.get(cut.pos..) != b.get(cut.pos..)
                && !scan_records(b, cut.pos).0.is_empty()
            {
                let also = keep_cut(
                    dir,
                    &plan.paths[other],
                    b,
                    cut.pos,
                    cut.first_version,
                    cut.cause.clone(),
                )?;
                report.problems.push(format!(
                    "{}: its own tail, different from the {}'s, is kept too in {}",
                    plan.paths[other].display(),
                    COPY_NAMES[best],
                    also.copy.display()
                ));
            }
        }
    }
    for i in 0..2 {
        let path = &plan.paths[i];
        if i == 1 && copies < 2 {
            // One copy from here on: the mirror holds nothing the log now lacks (its extra
            // records were kept above).
            remove_if_present(path)?;
            continue;
        }
        if plan.orig[i].as_deref() == Some(&plan.good[..]) {
            continue;
        }
        let tmp = path.with_extension(format!("{}-tmp", COPY_NAMES[i]));
        drop(create_with(&tmp, &plan.good)?);
        fs::rename(&tmp, path).map_err(io_err(path))?;
        sync_dir(dir)?;
    }
    Ok(())
}

/// Keeps the whole file `path` (its bytes as read) under `<data>/lost/`; the copy's path.
fn keep_whole(dir: &Path, path: &Path, bytes: &[u8]) -> Result<PathBuf, JournalError> {
    let lost_dir = make_lost_dir(dir)?;
    let base = path
        .file_name()
        .map_or_else(|| "journal".into(), |n| n.to_string_lossy().into_owned());
    let copy = lost_dir.join(format!("{base}.whole.{}", unique_stamp()));
    drop(create_with(&copy, bytes)?);
    sync_dir(&lost_dir)?;
    Ok(copy)
}

/// Seconds since the epoch and nanoseconds: names of kept files never collide.
fn unique_stamp() -> String {
    let d = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    format!("{}.{:09}", d.as_secs(), d.subsec_nanos())
}

/// [`recover`], then keep `copies` (1 or 2) copies of the journal from here on. Recovery reads
/// a mirror wherever one exists, whatever `copies` says.
///
/// For each journal file, record by record, a record is taken from whichever copy holds it
/// intact and in sequence: the longest valid prefix over both copies, whichever is shorter or
/// damaged. Every disagreement between the copies is a problem in the report; a copy is then
/// rewritten to what was recovered, and only after whatever it held beyond that (a tail past a
/// record damaged in both copies, a readable record other than the one taken) was kept under
/// `lost/` and reported. Nothing on disk changes until the whole recovery is worked out, and
/// nothing changes at all when the data directory holds less than its [`CONTROL_FILE`] names
/// (the recovery is refused).
pub fn recover_copies(
    dir: &Path,
    copies: u8,
) -> Result<(Store, Journal, RecoveryReport), JournalError> {
    let mut report = RecoveryReport::default();
    let control = read_control(dir)?;
    let mut names: Vec<String> = fs::read_dir(dir)
        .map_err(io_err(dir))?
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut model = Store::new();
    let mut checkpoint_name_used = None;
    for ck in names
        .iter()
        .rev()
        .filter(|n| n.starts_with("checkpoint-") && n.ends_with(".bin"))
    {
        match read_checkpoint(&dir.join(ck)) {
            Ok(m) => {
                model = m;
                report.checkpoint_version = model.version;
                checkpoint_name_used = Some(ck.clone());
                break;
            }
            Err(e) => report.problems.push(format!("skipped checkpoint: {e}")),
        }
    }
    let mut firsts: Vec<u64> = names
        .iter()
        .filter_map(|n| journal_first_version(n))
        .collect();
    firsts.dedup();
    let mirror_expected = control.as_ref().is_some_and(|c| c.copies >= 2);
    // Work everything out first.
    let mut plans: Vec<PairPlan> = Vec::new();
    let mut stopped = false;
    for &first in &firsts {
        if stopped {
            let log = dir.join(journal_name(first));
            let paths = [log.clone(), mirror_path(&log)];
            plans.push(PairPlan {
                aside: true,
                ..PairPlan::new(first, paths, [None, None], Vec::new())
            });
            continue;
        }
        let plan = plan_pair(dir, first, &mut model, mirror_expected)?;
        stopped = plan.cut.is_some();
        plans.push(plan);
    }
    if let Some(c) = &control {
        let log = dir.join(&c.journal);
        if !firsts.contains(&c.first_version) {
            return Err(JournalError::Missing {
                control: dir.join(CONTROL_FILE),
                journal: log.clone(),
                mirror: mirror_path(&log),
                first_version: c.first_version,
                found: model.version,
            });
        }
        if model.version + 1 < c.first_version {
            return Err(JournalError::Behind {
                control: dir.join(CONTROL_FILE),
                checkpoint: dir.join(checkpoint_name(c.first_version - 1)),
                needed: c.first_version - 1,
                found: model.version,
                used: checkpoint_name_used,
            });
        }
    }
    // Then do it.
    let mut last: Option<(PathBuf, u64, u64)> = None;
    for plan in &plans {
        if plan.aside {
            set_aside(dir, plan, model.version + 1, &mut report)?;
            continue;
        }
        carry_out(dir, plan, copies, &mut report)?;
        report.replayed += plan.records;
        last = Some((plan.paths[0].clone(), plan.first, plan.records));
    }
    let journal = match last {
        Some((path, first, records)) if first > report.checkpoint_version => {
            Journal::reopen(dir, path, first, records, copies)?
        }
        _ => {
            if model.version > report.checkpoint_version {
                // The journal that starts after the model must follow a checkpoint of it.
                write_checkpoint(dir, &model)?;
                report.checkpoint_version = model.version;
            }
            Journal::create_copies(dir, model.version + 1, copies)?
        }
    };
    Ok((model, journal, report))
}

/// Sets a journal that follows a cut aside (`.corrupt`, both copies) and reports what it holds.
fn set_aside(
    dir: &Path,
    plan: &PairPlan,
    first_version: u64,
    report: &mut RecoveryReport,
) -> Result<(), JournalError> {
    let name = journal_name(plan.first);
    let mut best: Option<LostTail> = None;
    for path in &plan.paths {
        if fs::symlink_metadata(path).is_err() {
            continue;
        }
        let file = path
            .file_name()
            .map_or_else(|| name.clone(), |n| n.to_string_lossy().into_owned());
        let aside = dir.join(format!("{file}.corrupt"));
        fs::rename(path, &aside).map_err(io_err(path))?;
        report.problems.push(format!(
            "{}: after a corrupt record; set aside as {file}.corrupt",
            path.display()
        ));
        if let Ok(bytes) = read_journal_bytes(&aside) {
            let (records, damaged) = scan_records(&bytes, JOURNAL_MAGIC.len().min(bytes.len()));
            let tail = LostTail {
                cause: format!("{file}: follows the cut"),
                first_version,
                last_version: records.iter().map(|r| r.version).max(),
                readable_records: records.len() as u64,
                damaged_bytes: damaged,
                copy: aside,
            };
            if best
                .as_ref()
                .is_none_or(|b| b.readable_records < tail.readable_records)
            {
                best = Some(tail);
            }
        }
    }
    sync_dir(dir)?;
    report.lost.extend(best);
    Ok(())
}

/// The record at `pos` of a journal's bytes: (payload length, version), or what is wrong.
fn check_record(bytes: &[u8], pos: usize) -> Result<(usize, u64), &'static str> {
    if bytes.len().saturating_sub(pos) < RECORD_HEADER {
        return Err("torn record header");
    }
    let len =
        u32::from_le_bytes([bytes[pos], bytes[pos + 1], bytes[pos + 2], bytes[pos + 3]]) as usize;
    let crc = u32::from_le_bytes([
        bytes[pos + 4],
        bytes[pos + 5],
        bytes[pos + 6],
        bytes[pos + 7],
    ]);
    let v = &bytes[pos + 8..pos + 16];
    if bytes.len() - pos - RECORD_HEADER < len {
        return Err("torn record");
    }
    let mut h = crc32fast::Hasher::new();
    h.update(v);
    h.update(&bytes[pos + RECORD_HEADER..pos + RECORD_HEADER + len]);
    if h.finalize() != crc {
        return Err("checksum mismatch");
    }
    let mut vb = [0u8; 8];
    vb.copy_from_slice(v);
    Ok((len, u64::from_le_bytes(vb)))
}
