//! The file interface against a running session: read its model at one version (a reader
//! snapshot), write a file ([`save`]); load a file as one transaction through the keeper
//! ([`load`]); describe the model ([`info`]); and prepare a keeper that starts from a file
//! ([`preload`], `robosim space --load`).

use crate::digest::{ModelDigest, digest};
use crate::error::FileError;
use crate::format::{self, Encoding};
use crate::model::{LoadMode, SavedModel, blame};
use robosim_instance_space::{Client, Id, Kind, Reader, Session, Store};
use std::collections::BTreeMap;
use std::path::Path;

/// The session's model at its current version, with its Library Space additions.
pub fn read_session(session: &Session) -> Result<SavedModel, FileError> {
    let mut reader = Reader::attach(session, "file-io")?;
    let snap = reader.snapshot().ok_or_else(|| {
        FileError::Usage(format!(
            "session {}: the keeper published no model",
            session.name()
        ))
    })?;
    let library = reader.library_files()?;
    Ok(SavedModel::from_snapshot(&snap, &library))
}

/// What [`save`] wrote.
#[derive(Debug, Clone)]
pub struct Saved {
    pub version: u64,
    pub objects: usize,
    pub bytes: u64,
    pub digest: ModelDigest,
}

/// `robosim save FILE`: the whole model of `session` at one version into `path`.
pub fn save(session: &Session, path: &Path, encoding: Encoding) -> Result<Saved, FileError> {
    let model = read_session(session)?;
    let bytes = format::write(&model, path, encoding)?;
    Ok(Saved {
        version: model.version,
        objects: model.objects.len(),
        bytes,
        digest: digest(&model).unwrap_or(ModelDigest([0; 32])),
    })
}

/// What [`load`] did.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The version the load committed (one transaction: one version).
    pub version: u64,
    pub created: usize,
    /// Objects of the session the load deleted (replace).
    pub deleted: usize,
    /// Library Space files of the model that the running session does not have.
    pub missing_library: Vec<String>,
}

/// The roots (objects without a parent) of a store: what a replace deletes.
pub fn roots_of(store: &Store) -> Vec<Id> {
    store
        .objects()
        .filter(|o| o.parent == 0)
        .map(|o| o.id)
        .collect()
}

/// `robosim load FILE`: reads and checks the file first (a bad file never reaches the
/// session), then sends one transaction — replace: delete every object, create the file's;
/// merge: create the file's beside them — so every other process sees one change.
pub fn load(session: &Session, path: &Path, mode: LoadMode) -> Result<Loaded, FileError> {
    let model = format::read(path)?;
    let mut reader = Reader::attach(session, "file-io")?;
    let snap = reader.snapshot().ok_or_else(|| {
        FileError::Usage(format!(
            "session {}: the keeper published no model",
            session.name()
        ))
    })?;
    let roots: Vec<Id> = match mode {
        LoadMode::Replace => snap
            .objects()
            .iter()
            .filter(|o| o.parent == 0)
            .map(|o| o.id)
            .collect(),
        LoadMode::Merge => Vec::new(),
    };
    let deleted = if roots.is_empty() { 0 } else { snap.len() };
    let have = reader.library_files()?;
    let missing_library = model
        .library
        .iter()
        .filter(|f| !have.iter().any(|(n, t)| *n == f.name && *t == f.text))
        .map(|f| f.name.clone())
        .collect();
    drop(snap);
    let plan = model
        .to_transaction(&roots)
        .map_err(|problem| FileError::Model {
            path: path.to_owned(),
            problem,
        })?;
    if plan.tx.is_empty() {
        return Err(FileError::Usage(format!(
            "{}: the file holds no objects and the session none to replace: nothing to load",
            path.display()
        )));
    }
    let mut client = Client::connect(session, "file-io")?;
    let applied = match client.transact(&plan.tx) {
        Ok(a) => a,
        Err(robosim_instance_space::ClientError::Refused(e)) => {
            return Err(blame(path, &model, &plan, session.name(), e));
        }
        Err(e) => return Err(e.into()),
    };
    Ok(Loaded {
        version: applied.version,
        created: applied.created.len(),
        deleted,
        missing_library,
    })
}

/// What `robosim info` prints.
#[derive(Debug, Clone)]
pub struct Info {
    pub version: u64,
    /// Objects per kind.
    pub counts: BTreeMap<Kind, usize>,
    pub vertices: usize,
    pub digest: ModelDigest,
}

impl Info {
    pub fn of(model: &SavedModel) -> Info {
        Info {
            version: model.version,
            counts: model.counts(),
            vertices: model.vertex_count(),
            digest: digest(model).unwrap_or(ModelDigest([0; 32])),
        }
    }
}

impl std::fmt::Display for Info {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "version {}", self.version)?;
        let total: usize = self.counts.values().sum();
        let by_kind: Vec<String> = self
            .counts
            .iter()
            .map(|(k, n)| format!("{} {n}", k.name()))
            .collect();
        writeln!(f, "objects {total} ({})", by_kind.join(", "))?;
        writeln!(f, "vertices {}", self.vertices)?;
        writeln!(f, "digest {}", self.digest)
    }
}

/// `robosim info`: the session's version, object counts and digest.
pub fn info(session: &Session) -> Result<Info, FileError> {
    Ok(Info::of(&read_session(session)?))
}
