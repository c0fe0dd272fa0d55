//! Durability: an append-only journal of committed transactions plus periodic compacted
//! checkpoints, so that `kill -9` of the keeper at any moment loses nothing it acknowledged.
//!
//! * `journal-<first version>.log`: magic, then records `[len u32][crc32 u32][version u64][tx]`,
//!   the CRC covering version and payload. [`Journal::sync`] (fdatasync) runs before the keeper
//!   acknowledges; one sync covers every transaction of a group (group commit).
//! * `checkpoint-<version>.bin`: magic, crc32, the whole model (bincode). Written to a temp file,
//!   synced, renamed, directory synced; then a new journal starts and older files are removed.
//! * [`recover`]: newest valid checkpoint, then every journal record after it, in order. A torn
//!   or corrupt tail (short record, bad CRC, version out of sequence) is reported and cut off;
//!   nothing before it is lost.
//!
//! Every file is created 0600 inside the session's 0700 data directory.

use crate::store::{Appearance, Id, Kind, Kinematics, MassProps, Object, Pose, Store};
use crate::transaction::{GeometryInput, Transaction};
use serde::{Deserialize, Serialize};
use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
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
    #[error("{path}: checkpoint is corrupt: {reason}")]
    Checkpoint { path: PathBuf, reason: String },
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

/// Removes the mirror `m` if there is one.
fn remove_stale_mirror(m: &Path) -> Result<(), JournalError> {
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
            remove_stale_mirror(&m)?;
            None
        };
        sync_dir(dir)?;
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

    /// Reopens an existing journal for appending (after recovery cut it to its valid length).
    /// The mirror is rewritten from the journal (recovery has just checked and repaired it), or
    /// removed with one copy: a mirror must never hold records a cut took out of the journal.
    fn reopen(dir: &Path, path: PathBuf, records: u64, copies: u8) -> Result<Self, JournalError> {
        let mut f = OpenOptions::new()
            .append(true)
            .open(&path)
            .map_err(io_err(&path))?;
        f.seek(SeekFrom::End(0)).map_err(io_err(&path))?;
        let m = mirror_path(&path);
        let mirror = if copies >= 2 {
            let bytes = read_journal_bytes(&path)?;
            let tmp = m.with_extension("mirror-tmp");
            drop(create_with(&tmp, &bytes)?);
            fs::rename(&tmp, &m).map_err(io_err(&m))?;
            let mf = OpenOptions::new()
                .append(true)
                .open(&m)
                .map_err(io_err(&m))?;
            Some((m, BufWriter::with_capacity(1 << 20, mf)))
        } else {
            remove_stale_mirror(&m)?;
            None
        };
        sync_dir(dir)?;
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
        StoreDecodeError::Corrupt(reason) => JournalError::Checkpoint {
            path: path.to_owned(),
            reason,
        },
    })
}

/// Why [`decode_store`] refused its bytes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StoreDecodeError {
    #[error("not a robosim model encoding (bad magic)")]
    Magic,
    #[error("model encoding is corrupt: {0}")]
    Corrupt(String),
}

/// Reads [`encode_store`]'s bytes back into a model: checksum, bounded decode, every geometry
/// re-validated, as recovery does.
pub fn decode_store(bytes: &[u8]) -> Result<Store, StoreDecodeError> {
    let bad = |reason: &str| StoreDecodeError::Corrupt(reason.to_owned());
    if bytes.len() < 12 || &bytes[..8] != CHECKPOINT_MAGIC {
        return Err(StoreDecodeError::Magic);
    }
    let crc = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if crc32fast::hash(&bytes[12..]) != crc {
        return Err(bad("checksum mismatch"));
    }
    let (data, used) = decode_checkpoint(&bytes[12..]).map_err(|e| bad(&e.to_string()))?;
    let rest = &bytes[12 + used..];
    let selection: Option<crate::Selection> = if rest.is_empty() {
        None
    } else {
        match bincode::serde::decode_from_slice(rest, bincode::config::standard()) {
            Ok((s, n)) if n == rest.len() => s,
            Ok(_) => return Err(bad("trailing bytes after the selection")),
            Err(e) => return Err(bad(&format!("selection: {e}"))),
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
                    .map_err(|e| bad(&format!("object {}: {e}", o.id)))?;
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

/// The file in a session's `run/` directory where the keeper leaves [`RecoveryReport::lost_message`]
/// when its recovery lost something (removed when a later recovery loses nothing).
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
    let lost_dir = dir.join("lost");
    fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(&lost_dir)
        .map_err(io_err(&lost_dir))?;
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
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

/// [`recover`], then keep `copies` (1 or 2) copies of the journal from here on. Recovery reads
/// a mirror wherever one exists, whatever `copies` says.
pub fn recover_copies(
    dir: &Path,
    copies: u8,
) -> Result<(Store, Journal, RecoveryReport), JournalError> {
    let mut report = RecoveryReport::default();
    let mut names: Vec<String> = fs::read_dir(dir)
        .map_err(io_err(dir))?
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut model = Store::new();
    for ck in names
        .iter()
        .rev()
        .filter(|n| n.starts_with("checkpoint-") && n.ends_with(".bin"))
    {
        match read_checkpoint(&dir.join(ck)) {
            Ok(m) => {
                model = m;
                report.checkpoint_version = model.version;
                break;
            }
            Err(e) => report.problems.push(format!("skipped checkpoint: {e}")),
        }
    }
    let journals: Vec<&String> = names
        .iter()
        .filter(|n| n.starts_with("journal-") && n.ends_with(".log"))
        .collect();
    let mut last: Option<(PathBuf, u64)> = None;
    let mut stop = false;
    for name in journals {
        let path = dir.join(name);
        if stop {
            report.problems.push(format!(
                "{}: after a corrupt record; set aside as {}.corrupt",
                path.display(),
                name
            ));
            let aside = dir.join(format!("{name}.corrupt"));
            let _ = fs::rename(&path, &aside);
            // Its mirror goes with it: a later journal of the same name must never read it.
            let m = mirror_path(&path);
            let _ = fs::rename(&m, m.with_extension("mirror.corrupt"));
            if let Ok(bytes) = read_journal_bytes(&aside) {
                let (records, damaged) = scan_records(&bytes, JOURNAL_MAGIC.len().min(bytes.len()));
                report.lost.push(LostTail {
                    cause: format!("{name}: follows the cut"),
                    first_version: model.version + 1,
                    last_version: records.iter().map(|r| r.version).max(),
                    readable_records: records.len() as u64,
                    damaged_bytes: damaged,
                    copy: aside,
                });
            }
            continue;
        }
        let (records, good_len, problem) = replay(&path, &mut model, &mut report)?;
        if let Some(p) = problem {
            report.problems.push(p.clone());
            // Keep what is cut. A torn last record with nothing readable after it was never
            // acknowledged (the sync that acknowledges it did not finish): not a loss.
            let bytes = read_journal_bytes(&path)?;
            let cut = keep_cut(dir, &path, &bytes, good_len as usize, model.version + 1, p)?;
            if cut.readable_records > 0 || !cut.cause.contains("torn record") {
                report.lost.push(cut);
            } else {
                let _ = fs::remove_file(&cut.copy);
            }
            let f = OpenOptions::new()
                .write(true)
                .open(&path)
                .map_err(io_err(&path))?;
            f.set_len(good_len).map_err(io_err(&path))?;
            f.sync_all().map_err(io_err(&path))?;
            stop = true;
        }
        last = Some((path, records));
    }
    let journal = match last {
        Some((path, records))
            if path.file_name().is_some_and(|n| {
                *n.to_string_lossy() >= *journal_name(report.checkpoint_version + 1)
            }) =>
        {
            Journal::reopen(dir, path, records, copies)?
        }
        _ => Journal::create_copies(dir, model.version + 1, copies)?,
    };
    Ok((model, journal, report))
}

/// The record at `pos` of a journal's bytes: (payload length, version), or what is wrong.
fn check_record(bytes: &[u8], pos: usize) -> Result<(usize, u64), &'static str> {
    if bytes.len() - pos < RECORD_HEADER {
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

/// Writes `data` at byte `pos` of the file `path` and syncs it.
fn write_at(path: &Path, pos: usize, data: &[u8]) -> Result<(), JournalError> {
    use std::os::unix::fs::FileExt;
    let f = OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(io_err(path))?;
    f.write_all_at(data, pos as u64)
        .and_then(|_| f.sync_data())
        .map_err(io_err(path))
}

/// Replays one journal file into `model`; returns (records replayed, valid length, problem).
fn replay(
    path: &Path,
    model: &mut Store,
    report: &mut RecoveryReport,
) -> Result<(u64, u64, Option<String>), JournalError> {
    let mut bytes = Vec::new();
    File::open(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(io_err(path))?;
    if bytes.len() < 8 || &bytes[..8] != JOURNAL_MAGIC {
        if bytes.len() < 8 && JOURNAL_MAGIC.starts_with(&bytes) {
            // Torn while being created: it holds nothing. Rewrite its header.
            let mut f = OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(io_err(path))?;
            f.write_all(JOURNAL_MAGIC)
                .and_then(|_| f.sync_all())
                .map_err(io_err(path))?;
            report.problems.push(format!(
                "{}: torn header ({} bytes); rewritten empty",
                path.display(),
                bytes.len()
            ));
            return Ok((0, 8, None));
        }
        return Err(JournalError::Magic {
            path: path.to_owned(),
            what: "journal",
        });
    }
    // The mirror, when the journal keeps two copies: the same bytes at the same offsets.
    let mirror = fs::read(mirror_path(path)).ok();
    let mut pos = 8usize;
    let mut records = 0u64;
    let tail = |bytes: &[u8], pos: usize, what: &str| {
        Some(format!(
            "{}: {what} at byte {pos}; dropped the tail ({} bytes)",
            path.display(),
            bytes.len() - pos
        ))
    };
    while pos < bytes.len() {
        let (len, version) = match check_record(&bytes, pos) {
            Ok(r) => r,
            Err(what) => match mirror
                .as_deref()
                .and_then(|m| record_at(m, pos, None).map(|r| (m, r)))
            {
                Some((m, r)) => {
                    // Repair the journal from its mirror, on disk and here.
                    let good = &m[pos..pos + RECORD_HEADER + r.len];
                    write_at(path, pos, good)?;
                    if bytes.len() < pos + good.len() {
                        bytes.resize(pos + good.len(), 0);
                    }
                    bytes[pos..pos + good.len()].copy_from_slice(good);
                    report.problems.push(format!(
                        "{}: {what} at byte {pos}; the record of version {} was repaired from the mirror",
                        path.display(),
                        r.version
                    ));
                    (r.len, r.version)
                }
                None => return Ok((records, pos as u64, tail(&bytes, pos, what))),
            },
        };
        let at = |what: &str| tail(&bytes, pos, what);
        let payload = &bytes[pos + RECORD_HEADER..pos + RECORD_HEADER + len];
        if version <= model.version {
            // Already in the checkpoint.
            pos += RECORD_HEADER + len;
            continue;
        }
        if version != model.version + 1 {
            return Ok((
                records,
                pos as u64,
                at(&format!(
                    "version {version} out of sequence (expected {})",
                    model.version + 1
                )),
            ));
        }
        let applied = Transaction::decode(payload).and_then(|tx| model.apply(&tx));
        if let Err(e) = applied {
            return Ok((
                records,
                pos as u64,
                at(&format!(
                    "record for version {version} no longer applies ({e})"
                )),
            ));
        }
        records += 1;
        report.replayed += 1;
        pos += RECORD_HEADER + len;
    }
    Ok((records, pos as u64, None))
}
