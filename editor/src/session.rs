//! The editor against the Instance Space: each accepted edit becomes **one** keeper transaction
//! (so every other process — the display first — sees it through the change notifications),
//! undo and redo are transactions too, and a refused edit sends nothing.
//!
//! Undo across editor processes: an editor given the session's history file
//! ([`Editor::keep_history`], `<session>/data/editor-<robot>.history.json`, beside the journal)
//! writes its undo and redo steps there after every accepted edit, undo and redo, with the
//! design they lead to; a later `robosim edit` of the same design takes them up, so it undoes
//! the edits of the editors before it. The file is the session's (it sits in the data directory
//! with the journal: `up --fresh` moves it aside with the model). It is taken up only when the
//! design it ends at is the design the space holds: a design changed since by anything else is
//! not undone from a stale history (the editor says so instead). The journal itself cannot
//! serve: a checkpoint (every clean stop writes one) drops the records before it.
//!
//! Where the design lives in the Instance Space: a scene object named after the robot, one item
//! per link (`ROBOT.LINK`), one solid per editor object under its parent object (or the link),
//! pose = `ref · amat`, geometry = the shape's polygons (joint markers have none). Each
//! object's origin record holds its editor record (shape, ref, amat, attachment) as JSON, so
//! the design can be read back from the space ([`design_from_snapshot`]) by a restarted editor.

use crate::structure::{Cause, Design, EdObject, EditError};
use robosim_instance_space::{
    GeometryInput, Id, Kind, ObjRef, Pose, Snapshot, Store, Transaction, TxError,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Where transactions go.
pub trait Space {
    /// Commits one transaction; the ids of its creates, in order, and the version. A refusal
    /// is the space's own error ([`TxError`] of a store, `ClientError` of a client), kept.
    fn commit(&mut self, tx: &Transaction) -> Result<(Vec<Id>, u64), Cause>;
}

impl Space for Store {
    fn commit(&mut self, tx: &Transaction) -> Result<(Vec<Id>, u64), Cause> {
        self.apply(tx)
            .map(|a| (a.created, a.version))
            .map_err(|e: TxError| Cause::new(e))
    }
}

impl Space for robosim_instance_space::Client {
    fn commit(&mut self, tx: &Transaction) -> Result<(Vec<Id>, u64), Cause> {
        self.transact(tx)
            .map(|a| (a.created, a.version))
            .map_err(Cause::new)
    }
}

/// The history in `path`; `None` when there is no file.
fn read_history(path: &std::path::Path) -> Result<Option<History>, EditError> {
    let fail = |e| EditError::HistoryRead {
        path: path.display().to_string(),
        source: e,
    };
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(fail(Cause::new(e))),
        Ok(_) => {}
    }
    let text = robosim_input::read_to_string(
        path,
        "the session's edit history",
        robosim_input::Limit::MODEL,
    )
    .map_err(|e| fail(Cause::new(e)))?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| EditError::HistoryFormat {
            path: path.display().to_string(),
            source: Cause::new(e),
        })
}

/// The record on each object (its origin field).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct ObjectRecord {
    editor: u32,
    link: String,
    object: EdObject,
}

/// The record on the design's scene object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct DesignRecord {
    editor: u32,
    robot: String,
    links: Vec<String>,
    current: usize,
    /// Per link (as `links`), its objects' names in the design's order. The store orders
    /// objects by id, and an object an undo brings back gets a new id, so without this a
    /// restarted editor would list (and generate code for) the objects in another order.
    /// Absent in designs written before it: their objects are read in id order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    order: Vec<Vec<String>>,
}

impl DesignRecord {
    fn of(d: &Design) -> DesignRecord {
        DesignRecord {
            editor: 1,
            robot: d.robot.clone(),
            links: d.links.iter().map(|l| l.name.clone()).collect(),
            current: d.current,
            order: d
                .links
                .iter()
                .map(|l| l.objects.iter().map(|o| o.name.clone()).collect())
                .collect(),
        }
    }
}

/// One undoable step: a whole design (what the design was before, or after), or a move of an
/// object of the session's model that is not part of the design (its local pose before and
/// after).
#[derive(Debug, Clone, Serialize, Deserialize)]
enum Step {
    Design(Design),
    Pose { id: Id, before: Pose, after: Pose },
}

/// The session's edit history of one design, as written to its file: the steps, and the design
/// they lead to (the design the space held after the last of them).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct History {
    robot: String,
    now: Design,
    undo: Vec<Step>,
    redo: Vec<Step>,
}

/// The file of the session's edit history of design `robot` in the session's data directory
/// `data_dir` (a robot name outside `[A-Za-z0-9_+-]` is spelled with `_` there).
pub fn history_path(data_dir: &std::path::Path, robot: &str) -> std::path::PathBuf {
    let safe: String = robot
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '+') {
                c
            } else {
                '_'
            }
        })
        .collect();
    data_dir.join(format!("editor-{safe}.history.json"))
}

/// What [`Editor::keep_history`] found in the session's history file.
#[derive(Debug, Clone, PartialEq)]
pub enum HistoryFound {
    /// No file (the design's first editor, or its edits were never kept).
    None,
    /// Taken up: this many steps to undo and to redo.
    Taken { undo: usize, redo: usize },
    /// The file ends at another design than the space holds (changed since by something
    /// else): not taken up; it is replaced at this editor's first edit.
    Stale,
}

/// An editor session: the design, its history, and what of it the space holds.
pub struct Editor<S: Space> {
    pub space: S,
    design: Design,
    undo: Vec<Step>,
    redo: Vec<Step>,
    /// ids in the space: the scene, each link item, each (link, object).
    scene: Option<Id>,
    links: BTreeMap<String, Id>,
    objects: BTreeMap<(String, String), Id>,
    /// What the space holds (the design last committed).
    committed: Option<Design>,
    /// Version of the last commit.
    pub version: u64,
    /// Objects of the model outside the design this editor moved: the version of its last
    /// write of each one's pose (an undo or redo expects the pose unchanged since: a move by
    /// another writer in between makes it a conflict, not an overwrite).
    moved: BTreeMap<Id, u64>,
    /// The session's history file, when kept ([`Editor::keep_history`]).
    history: Option<std::path::PathBuf>,
}

/// The result of an accepted edit.
#[derive(Debug, Clone, PartialEq)]
pub struct Done {
    pub version: u64,
    pub ops: usize,
}

impl<S: Space> Editor<S> {
    /// A new design `robot`, written to the space at once.
    pub fn new(space: S, robot: &str) -> Result<Editor<S>, EditError> {
        let mut e = Editor {
            space,
            design: Design::new(robot),
            undo: Vec::new(),
            redo: Vec::new(),
            scene: None,
            links: BTreeMap::new(),
            objects: BTreeMap::new(),
            committed: None,
            version: 0,
            moved: BTreeMap::new(),
            history: None,
        };
        e.sync()?;
        Ok(e)
    }

    /// Resumes design `robot` found in `snap` (written by an earlier editor).
    pub fn resume(space: S, snap: &Snapshot, robot: &str) -> Result<Editor<S>, EditError> {
        let (design, scene, links, objects) = read_snapshot(snap, robot)?;
        Ok(Editor {
            space,
            committed: Some(design.clone()),
            design,
            undo: Vec::new(),
            redo: Vec::new(),
            scene: Some(scene),
            links,
            objects,
            version: snap.version(),
            moved: BTreeMap::new(),
            history: None,
        })
    }

    /// Keeps this design's undo and redo steps in the session's history file `path` (see the
    /// module docs), taking up the steps an earlier editor left there when they end at the
    /// design the space holds.
    pub fn keep_history(&mut self, path: std::path::PathBuf) -> Result<HistoryFound, EditError> {
        let found = match read_history(&path)? {
            None => HistoryFound::None,
            Some(h) if h.robot == self.design.robot && h.now == self.design => {
                let found = HistoryFound::Taken {
                    undo: h.undo.len(),
                    redo: h.redo.len(),
                };
                self.undo = h.undo;
                self.redo = h.redo;
                found
            }
            Some(_) => HistoryFound::Stale,
        };
        self.history = Some(path);
        Ok(found)
    }

    /// Before an undo or redo: the steps another editor of the session wrote since this one
    /// last did (the file ends at the design this editor holds, so its steps are the newest).
    fn take_up_history(&mut self) -> Result<(), EditError> {
        let Some(path) = &self.history else {
            return Ok(());
        };
        if let Some(h) = read_history(path)?
            && h.robot == self.design.robot
            && h.now == self.design
        {
            self.undo = h.undo;
            self.redo = h.redo;
        }
        Ok(())
    }

    /// After an accepted edit, undo or redo: the history file says what this editor's stacks
    /// say. The edit is committed either way; a failure here is reported as such.
    fn write_history(&self, done: Done) -> Result<Done, EditError> {
        let Some(path) = &self.history else {
            return Ok(done);
        };
        let h = History {
            robot: self.design.robot.clone(),
            now: self.design.clone(),
            undo: self.undo.clone(),
            redo: self.redo.clone(),
        };
        let fail = |source| EditError::HistoryWrite {
            path: path.display().to_string(),
            version: done.version,
            source,
        };
        let text = serde_json::to_vec(&h).map_err(|e| fail(Cause::new(e)))?;
        robosim_input::write_file_atomic(path, &text).map_err(|e| fail(Cause::new(e)))?;
        Ok(done)
    }

    pub fn design(&self) -> &Design {
        &self.design
    }

    /// The space id of object `name` of the current link.
    pub fn id_of(&self, name: &str) -> Option<Id> {
        self.objects
            .get(&(self.design.link().name.clone(), name.to_owned()))
            .copied()
    }

    /// The object (current link) whose space id is `id`.
    pub fn name_of(&self, id: Id) -> Option<String> {
        let link = &self.design.link().name;
        self.objects
            .iter()
            .find(|((l, _), v)| l == link && **v == id)
            .map(|((_, o), _)| o.clone())
    }

    /// Applies an edit: the new design is committed as one transaction, or nothing changes.
    pub fn apply(
        &mut self,
        edit: impl FnOnce(&Design) -> Result<Design, EditError>,
    ) -> Result<Done, EditError> {
        let new = edit(&self.design)?;
        let old = std::mem::replace(&mut self.design, new);
        match self.sync() {
            Ok(done) => {
                self.undo.push(Step::Design(old));
                self.redo.clear();
                self.write_history(done)
            }
            Err(e) => {
                self.design = old;
                Err(e)
            }
        }
    }

    /// Moves object `id` of the session's model — one that is not part of the design, e.g. a
    /// module of a library scene — from local pose `before` (what the space holds) to `after`:
    /// one transaction (a single pose op), undoable like any edit. `read`: the version
    /// `before` was read at; when another writer moved the object since, the keeper refuses
    /// the move as a conflict and nothing changes (the move is not made from a stale pose).
    pub fn move_model_object(
        &mut self,
        id: Id,
        before: Pose,
        after: Pose,
        read: u64,
    ) -> Result<Done, EditError> {
        let done = self.commit_pose(id, after, read)?;
        self.undo.push(Step::Pose { id, before, after });
        self.redo.clear();
        self.write_history(done)
    }

    fn commit_pose(&mut self, id: Id, pose: Pose, read: u64) -> Result<Done, EditError> {
        let mut tx = Transaction::new();
        tx.set_pose(id, pose).expect_unchanged_since(read);
        let (_, version) = self
            .space
            .commit(&tx)
            .map_err(|source| EditError::Refused { source })?;
        self.version = version;
        self.moved.insert(id, version);
        Ok(Done { version, ops: 1 })
    }

    /// Goes one step through the history: `from` is popped, the step applied in the direction
    /// `back`, and pushed on `to` (on failure, back on `from`).
    fn step(&mut self, back: bool) -> Result<Done, EditError> {
        self.take_up_history()?;
        let (from, what) = if back {
            (&mut self.undo, "undo")
        } else {
            (&mut self.redo, "redo")
        };
        let Some(step) = from.pop() else {
            return Err(EditError::Invalid(format!("nothing to {what}")));
        };
        let result = match &step {
            Step::Design(d) => {
                let cur = std::mem::replace(&mut self.design, d.clone());
                match self.sync() {
                    Ok(done) => Ok((done, Step::Design(cur))),
                    Err(e) => {
                        self.design = cur;
                        Err(e)
                    }
                }
            }
            Step::Pose { id, before, after } => {
                let since = self.moved.get(id).copied().unwrap_or(self.version);
                self.commit_pose(*id, if back { *before } else { *after }, since)
                    .map(|done| (done, step.clone()))
            }
        };
        match result {
            Ok((done, inverse)) => {
                if back {
                    self.redo.push(inverse);
                } else {
                    self.undo.push(inverse);
                }
                self.write_history(done)
            }
            Err(e) => {
                if back {
                    self.undo.push(step);
                } else {
                    self.redo.push(step);
                }
                Err(e)
            }
        }
    }

    /// Undoes the last edit (one transaction back to the previous design, or pose).
    pub fn undo(&mut self) -> Result<Done, EditError> {
        self.step(true)
    }

    /// Redoes the last undone edit.
    pub fn redo(&mut self) -> Result<Done, EditError> {
        self.step(false)
    }

    /// Replaces the whole design (load, restart, code → editor) as one undoable edit.
    pub fn replace(&mut self, d: Design) -> Result<Done, EditError> {
        self.apply(|_| Ok(d))
    }

    /// Commits the difference between what the space holds and the design.
    ///
    /// Every object the difference writes must be as this editor last committed (or read) it:
    /// a concurrent write to one of them since `self.version` makes the keeper refuse the
    /// edit as a conflict ([`robosim_instance_space::TxError::Conflict`]) instead of the
    /// editor's stale copy overwriting it.
    fn sync(&mut self) -> Result<Done, EditError> {
        let (mut tx, creates) = self.diff()?;
        if !tx.is_empty() {
            tx.expect_unchanged_since(self.version);
        }
        if tx.is_empty() {
            self.committed = Some(self.design.clone());
            return Ok(Done {
                version: self.version,
                ops: 0,
            });
        }
        let (ids, version) = self
            .space
            .commit(&tx)
            .map_err(|source| EditError::Refused { source })?;
        for (k, key) in creates.into_iter().enumerate() {
            let Some(&id) = ids.get(k) else { break };
            match key {
                Created::Scene => self.scene = Some(id),
                Created::Link(l) => {
                    self.links.insert(l, id);
                }
                Created::Object(l, o) => {
                    self.objects.insert((l, o), id);
                }
            }
        }
        // forget what was deleted
        let d = &self.design;
        self.links
            .retain(|l, _| d.links.iter().any(|x| &x.name == l));
        self.objects.retain(|(l, o), _| {
            d.links
                .iter()
                .any(|x| &x.name == l && x.objects.iter().any(|y| &y.name == o))
        });
        self.committed = Some(self.design.clone());
        self.version = version;
        Ok(Done {
            version,
            ops: tx.ops().iter().filter(|o| !o.is_precondition()).count(),
        })
    }

    fn diff(&self) -> Result<(Transaction, Vec<Created>), EditError> {
        let mut tx = Transaction::new();
        let mut creates = Vec::new();
        let d = &self.design;
        let empty = Design {
            robot: d.robot.clone(),
            links: Vec::new(),
            current: 0,
        };
        let old = self.committed.as_ref().unwrap_or(&empty);
        let scene: ObjRef = match self.scene {
            Some(id) => ObjRef::Id(id),
            None => {
                creates.push(Created::Scene);
                tx.create(Kind::Scene, &d.robot, None)
            }
        };
        let header = DesignRecord::of(d);
        let old_header = DesignRecord::of(old);
        if self.scene.is_none() || header != old_header {
            tx.set_origin(scene, &json(&header));
        }
        let mut deletes: Vec<(usize, Id)> = Vec::new();
        for l in &d.links {
            let lref: ObjRef = match self.links.get(&l.name) {
                Some(&id) => ObjRef::Id(id),
                None => {
                    creates.push(Created::Link(l.name.clone()));
                    let r = tx.create(Kind::Item, &format!("{}.{}", d.robot, l.name), Some(scene));
                    tx.set_origin(r, "{\"editor\":1}");
                    r
                }
            };
            let old_l = old.links.iter().find(|x| x.name == l.name);
            let mut refs: BTreeMap<String, ObjRef> = BTreeMap::new();
            for o in &l.objects {
                if let Some(&id) = self.objects.get(&(l.name.clone(), o.name.clone())) {
                    refs.insert(o.name.clone(), ObjRef::Id(id));
                }
            }
            // creates, parents first
            let mut pending: Vec<&EdObject> = l
                .objects
                .iter()
                .filter(|o| !refs.contains_key(&o.name))
                .collect();
            while !pending.is_empty() {
                let before = pending.len();
                let mut rest = Vec::new();
                for o in pending {
                    let parent = match &o.parent {
                        None => Some(lref),
                        Some(p) => refs.get(p).copied(),
                    };
                    match parent {
                        Some(p) => {
                            creates.push(Created::Object(l.name.clone(), o.name.clone()));
                            let r = tx.create(Kind::Solid, &o.name, Some(p));
                            refs.insert(o.name.clone(), r);
                            write_object(&mut tx, r, &l.name, o, None)?;
                        }
                        None => rest.push(o),
                    }
                }
                if rest.len() == before {
                    return Err(EditError::Invalid(
                        "the attachments name objects that do not exist".into(),
                    ));
                }
                pending = rest;
            }
            // changed objects
            for o in &l.objects {
                let Some(&id) = self.objects.get(&(l.name.clone(), o.name.clone())) else {
                    continue;
                };
                let prev = old_l.and_then(|x| x.objects.iter().find(|y| y.name == o.name));
                if prev.map(|p| &p.parent) != Some(&o.parent) {
                    let parent = match &o.parent {
                        None => lref,
                        Some(p) => *refs.get(p).ok_or_else(|| {
                            EditError::Invalid(format!("{}: parent {p} does not exist", o.name))
                        })?,
                    };
                    tx.attach(id, parent);
                }
                write_object(&mut tx, ObjRef::Id(id), &l.name, o, prev)?;
            }
            // deleted objects (their surviving children were re-hung above); an object deleted
            // with its parent goes first (deepest first: each delete finds no children left)
            if let Some(ol) = old_l {
                let depth = |o: &EdObject| {
                    let mut d = 0usize;
                    let mut cur = o.parent.as_deref();
                    while let Some(p) = cur {
                        d += 1;
                        cur = ol
                            .objects
                            .iter()
                            .find(|x| x.name == p)
                            .and_then(|x| x.parent.as_deref());
                        if d > ol.objects.len() {
                            break;
                        }
                    }
                    d
                };
                for o in &ol.objects {
                    if !l.objects.iter().any(|x| x.name == o.name)
                        && let Some(&id) = self.objects.get(&(l.name.clone(), o.name.clone()))
                    {
                        deletes.push((depth(o), id));
                    }
                }
            }
        }
        for l in &old.links {
            if !d.links.iter().any(|x| x.name == l.name)
                && let Some(&id) = self.links.get(&l.name)
            {
                {
                    tx.delete(id, true);
                }
            }
        }
        deletes.sort_by_key(|d| std::cmp::Reverse(d.0));
        for (_, id) in deletes {
            tx.delete(id, false);
        }
        Ok((tx, creates))
    }
}

enum Created {
    Scene,
    Link(String),
    Object(String, String),
}

fn json<T: Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_default()
}

fn pose(m: &nalgebra::Matrix4<f64>) -> [f64; 12] {
    robosim_scene::pose::from_matrix(m)
}

fn write_object(
    tx: &mut Transaction,
    r: ObjRef,
    link: &str,
    o: &EdObject,
    prev: Option<&EdObject>,
) -> Result<(), EditError> {
    if prev.is_some_and(|p| p == o) {
        return Ok(());
    }
    let local = o.ref_ * o.amat;
    if prev.is_none_or(|p| p.ref_ * p.amat != local) {
        tx.set_pose(r, pose(&local));
    }
    if prev.is_none_or(|p| p.shape != o.shape) {
        let g = o
            .shape
            .polyhedron()
            .map_err(|source| EditError::Solid {
                object: o.name.clone(),
                source,
            })?
            .map(|p| GeometryInput::from_polyhedron(&p));
        if prev.is_some() || g.is_some() {
            tx.set_geometry(r, g);
        }
    }
    tx.set_origin(
        r,
        &json(&ObjectRecord {
            editor: 1,
            link: link.to_owned(),
            object: o.clone(),
        }),
    );
    Ok(())
}

type Ids = (
    Design,
    Id,
    BTreeMap<String, Id>,
    BTreeMap<(String, String), Id>,
);

/// The design `robot` an editor left in the space, with the ids of its objects.
fn read_snapshot(snap: &Snapshot, robot: &str) -> Result<Ids, EditError> {
    let Some(si) = (0..snap.len()).find(|&i| {
        snap.name(i) == robot
            && snap.object(i).kind() == Some(Kind::Scene)
            && snap.origin(i).contains("\"editor\"")
    }) else {
        return Err(EditError::Invalid(format!(
            "the session holds no editor design {robot:?}"
        )));
    };
    let header: DesignRecord =
        serde_json::from_str(snap.origin(si)).map_err(|e| EditError::Record {
            at: robot.to_owned(),
            source: Cause::new(e),
        })?;
    let scene = snap.rec(si).id;
    let mut design = Design {
        robot: header.robot.clone(),
        links: Vec::new(),
        current: header.current,
    };
    let mut links = BTreeMap::new();
    let mut objects = BTreeMap::new();
    for (li_order, lname) in header.links.iter().enumerate() {
        let item = format!("{robot}.{lname}");
        let Some(li) = snap.children(scene).find(|&k| snap.name(k) == item) else {
            return Err(EditError::Invalid(format!(
                "{robot}: link {item} is missing"
            )));
        };
        let lid = snap.rec(li).id;
        links.insert(lname.clone(), lid);
        let mut objs = Vec::new();
        let mut stack: Vec<Id> = vec![lid];
        while let Some(p) = stack.pop() {
            for k in snap.children(p) {
                let rec: ObjectRecord =
                    serde_json::from_str(snap.origin(k)).map_err(|e| EditError::Record {
                        at: snap.path(k).to_string(),
                        source: Cause::new(e),
                    })?;
                let id = snap.rec(k).id;
                objects.insert((lname.clone(), rec.object.name.clone()), id);
                objs.push((id, rec.object));
                stack.push(id);
            }
        }
        objs.sort_by_key(|(id, _)| *id);
        if let Some(order) = header.order.get(li_order) {
            // The design's order; a name the record does not list keeps its id order, last.
            let rank = |o: &EdObject| {
                order
                    .iter()
                    .position(|n| *n == o.name)
                    .unwrap_or(usize::MAX)
            };
            objs.sort_by_key(|(_, o)| rank(o));
        }
        design.links.push(crate::structure::LinkDesign {
            name: lname.clone(),
            objects: objs.into_iter().map(|x| x.1).collect(),
        });
    }
    Ok((design, scene, links, objects))
}

/// The design `robot` as the space holds it.
pub fn design_from_snapshot(snap: &Snapshot, robot: &str) -> Result<Design, EditError> {
    read_snapshot(snap, robot).map(|x| x.0)
}
