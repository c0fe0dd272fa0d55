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
use std::os::unix::fs::OpenOptionsExt;
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

impl Journal {
    /// Starts a new journal file whose first record will be `first_version`.
    pub fn create(dir: &Path, first_version: u64) -> Result<Self, JournalError> {
        let path = dir.join(journal_name(first_version));
        let mut f = create_private(&path)?;
        f.write_all(JOURNAL_MAGIC).map_err(io_err(&path))?;
        f.sync_all().map_err(io_err(&path))?;
        sync_dir(dir)?;
        Ok(Journal {
            dir: dir.to_owned(),
            path,
            out: BufWriter::with_capacity(1 << 20, f),
            since_checkpoint: 0,
            dirty: false,
        })
    }

    /// Reopens an existing journal for appending (after recovery cut it to its valid length).
    fn reopen(dir: &Path, path: PathBuf, records: u64) -> Result<Self, JournalError> {
        let mut f = OpenOptions::new()
            .append(true)
            .open(&path)
            .map_err(io_err(&path))?;
        f.seek(SeekFrom::End(0)).map_err(io_err(&path))?;
        Ok(Journal {
            dir: dir.to_owned(),
            path,
            out: BufWriter::with_capacity(1 << 20, f),
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
        self.out.get_ref().sync_data().map_err(io_err(&self.path))?;
        self.dirty = false;
        Ok(())
    }

    /// Writes a checkpoint of `model`, starts a new journal after it and removes the files the
    /// checkpoint made redundant. Call after [`Journal::sync`].
    pub fn checkpoint(&mut self, model: &Store) -> Result<(), JournalError> {
        self.sync()?;
        write_checkpoint(&self.dir, model)?;
        let next = Journal::create(&self.dir, model.version + 1)?;
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
            let stale = (name.starts_with("journal-") && name.ends_with(".log") && name < keep_j)
                || (name.starts_with("checkpoint-") && name.ends_with(".bin") && name < keep_ck);
            if stale {
                let _ = fs::remove_file(e.path());
            }
        }
        sync_dir(&self.dir)
    }
}

/// One object in checkpoint form.
#[derive(Serialize, Deserialize)]
struct ObjectData {
    id: Id,
    kind: Kind,
    parent: Id,
    name: String,
    pose: Pose,
    joint: f64,
    appearance: Appearance,
    kinematics: Option<Kinematics>,
    dynamics: Option<MassProps>,
    geometry: Option<GeometryInput>,
    geom_gen: u64,
    origin: String,
}

#[derive(Serialize, Deserialize)]
struct CheckpointData {
    version: u64,
    next_id: Id,
    objects: Vec<ObjectData>,
}

fn write_checkpoint(dir: &Path, model: &Store) -> Result<(), JournalError> {
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
    let body =
        bincode::serde::encode_to_vec(&data, bincode::config::standard()).unwrap_or_default();
    let path = dir.join(checkpoint_name(model.version));
    let tmp = path.with_extension("tmp");
    let mut f = create_private(&tmp)?;
    f.write_all(CHECKPOINT_MAGIC).map_err(io_err(&tmp))?;
    f.write_all(&crc32fast::hash(&body).to_le_bytes())
        .map_err(io_err(&tmp))?;
    f.write_all(&body).map_err(io_err(&tmp))?;
    f.sync_all().map_err(io_err(&tmp))?;
    fs::rename(&tmp, &path).map_err(io_err(&path))?;
    sync_dir(dir)
}

fn read_checkpoint(path: &Path) -> Result<Store, JournalError> {
    let bytes = fs::read(path).map_err(io_err(path))?;
    let bad = |reason: &str| JournalError::Checkpoint {
        path: path.to_owned(),
        reason: reason.to_owned(),
    };
    if bytes.len() < 12 || &bytes[..8] != CHECKPOINT_MAGIC {
        return Err(JournalError::Magic {
            path: path.to_owned(),
            what: "checkpoint",
        });
    }
    let crc = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if crc32fast::hash(&bytes[12..]) != crc {
        return Err(bad("checksum mismatch"));
    }
    let data = decode_checkpoint(&bytes[12..]).map_err(|e| bad(&e.to_string()))?;
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
    Ok(Store::from_parts(data.version, data.next_id, objects))
}

/// Decodes a checkpoint body with a memory limit in proportion to its size, as
/// `Transaction::decode` does: a length prefix claiming more than the body could describe
/// (a 1 KiB checkpoint whose name claims 2^62 bytes, found by the `journal` fuzz target) is
/// refused before anything is allocated; without the limit bincode allocated first, and an
/// impossible size aborted the keeper during recovery.
fn decode_checkpoint(body: &[u8]) -> Result<CheckpointData, bincode::error::DecodeError> {
    use bincode::config::standard;
    // decoded size is at most ~32× the encoded size (an empty Vec: 1 byte on disk, 24 in memory)
    let limit = body.len().saturating_mul(32).saturating_add(4096);
    macro_rules! within {
        ($($n:literal),*) => {
            $( if limit <= (1usize << $n) {
                return bincode::serde::decode_from_slice(body, standard().with_limit::<{ 1usize << $n }>())
                    .map(|(d, _)| d);
            } )*
        };
    }
    within!(16, 20, 24, 28, 30, 32, 34);
    bincode::serde::decode_from_slice(body, standard().with_limit::<{ 1usize << 36 }>())
        .map(|(d, _)| d)
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
}

/// Rebuilds the model from `dir` and opens the journal for appending.
pub fn recover(dir: &Path) -> Result<(Store, Journal, RecoveryReport), JournalError> {
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
            let _ = fs::rename(&path, dir.join(format!("{name}.corrupt")));
            continue;
        }
        let (records, good_len, problem) = replay(&path, &mut model, &mut report)?;
        if let Some(p) = problem {
            report.problems.push(p);
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
            Journal::reopen(dir, path, records)?
        }
        _ => Journal::create(dir, model.version + 1)?,
    };
    Ok((model, journal, report))
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
    let mut pos = 8usize;
    let mut records = 0u64;
    while pos < bytes.len() {
        let at = |what: &str| {
            Some(format!(
                "{}: {what} at byte {pos}; dropped the tail ({} bytes)",
                path.display(),
                bytes.len() - pos
            ))
        };
        if bytes.len() - pos < RECORD_HEADER {
            return Ok((records, pos as u64, at("torn record header")));
        }
        let len = u32::from_le_bytes([bytes[pos], bytes[pos + 1], bytes[pos + 2], bytes[pos + 3]])
            as usize;
        let crc = u32::from_le_bytes([
            bytes[pos + 4],
            bytes[pos + 5],
            bytes[pos + 6],
            bytes[pos + 7],
        ]);
        let mut v = [0u8; 8];
        v.copy_from_slice(&bytes[pos + 8..pos + 16]);
        let version = u64::from_le_bytes(v);
        if bytes.len() - pos - RECORD_HEADER < len {
            return Ok((records, pos as u64, at("torn record")));
        }
        let payload = &bytes[pos + RECORD_HEADER..pos + RECORD_HEADER + len];
        let mut h = crc32fast::Hasher::new();
        h.update(&v);
        h.update(payload);
        if h.finalize() != crc {
            return Ok((records, pos as u64, at("checksum mismatch")));
        }
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
