//! The keeper's store: the working model as plain Rust data, and the one function that changes it:
//! [`Store::apply`], which validates a whole [`Transaction`] and then applies it, or refuses it
//! and changes nothing.
//!
//! The keeper owns a `Store`; readers never see this type — they see the flat `#[repr(C)]`
//! records of [`crate::layout`] that the keeper publishes from it.
//!
//! Part-whole structure (seed §3.2 item 2): scene → robots / items → links → solids → parts.
//! Poses are local (relative to the parent) rigid transforms, 3×4 row-major `[R | t]`, metres.

pub(crate) use crate::object::{
    Appearance, DhConvention, FloatingBase, Id, JointKind, Kind, Kinematics, MassProps, Object,
    Pose, Selection, aspect,
};
use crate::object::{IDENTITY, MAX_ELEMENTS, MAX_NAME_BYTES, MAX_ORIGIN_BYTES};
pub(crate) use crate::transaction::TxError;
use crate::transaction::{GeometryInput, ObjRef, Op, Transaction};

mod validate;
use robosim_geometry::Polyhedron;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::Arc;
pub use validate::{INERTIA_TOL, mass_props, principal_moments};

/// What a committed transaction did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Applied {
    pub version: u64,
    /// Ids assigned to the transaction's creates, in order.
    pub created: Vec<Id>,
    /// Every touched object with the aspects touched, sorted by id.
    pub changes: Vec<(Id, u64)>,
}

impl Applied {
    /// The union of the aspects touched.
    pub fn aspects(&self) -> u64 {
        self.changes.iter().fold(0, |a, c| a | c.1)
    }
}

/// The keeper's store: the whole working model of the Instance Space as plain data (the
/// keeper's copy behind the published records). `version` counts committed transactions.
/// Named `Store`, not `Model`, so that "Model" means one thing in the project: the
/// immutable description a simulation core runs over (Pinocchio's and MuJoCo's sense).
#[derive(Debug, Clone)]
pub struct Store {
    pub version: u64,
    /// The version of the last transaction that touched anything but poses and joint values
    /// (what a published objects head carries: see `Snapshot::structure_version`).
    structure_version: u64,
    next_id: Id,
    objects: BTreeMap<Id, Object>,
    children: HashMap<Id, BTreeSet<Id>>,
    selection: Option<Selection>,
    /// Per object, the version of the last transaction that changed each aspect (index: the
    /// aspect's bit number, [`aspect::COUNT`] of them), for [`Op::Expect`]. An object without
    /// an entry has not changed since `stamps_base`.
    stamps: HashMap<Id, [u64; aspect::COUNT]>,
    /// The version every aspect of an object without a stamp is taken to have changed at: 0
    /// for a store built by transactions, the checkpoint's version for one rebuilt from a
    /// checkpoint (what changed before it is not known, so a precondition read before it
    /// conflicts — a retry reads again — rather than pass unchecked).
    stamps_base: u64,
}

impl Default for Store {
    /// An empty store; ids start at 1 (0 is "no parent").
    fn default() -> Self {
        Store::new()
    }
}

impl Store {
    /// An empty store; ids start at 1 (0 is "no parent").
    pub fn new() -> Self {
        Store {
            version: 0,
            structure_version: 0,
            next_id: 1,
            objects: BTreeMap::new(),
            children: HashMap::new(),
            selection: None,
            stamps: HashMap::new(),
            stamps_base: 0,
        }
    }
    /// Rebuilds a model from a checkpoint's parts.
    pub(crate) fn from_parts(
        version: u64,
        next_id: Id,
        objects: Vec<Object>,
        selection: Option<Selection>,
    ) -> Self {
        let mut m = Store {
            version,
            structure_version: version,
            next_id,
            objects: BTreeMap::new(),
            children: HashMap::new(),
            selection: None,
            stamps: HashMap::new(),
            stamps_base: version,
        };
        for o in objects {
            m.children.entry(o.parent).or_default().insert(o.id);
            m.objects.insert(o.id, o);
        }
        m.selection = selection.and_then(|s| m.still_valid(s));
        m
    }
    /// The session's selection (see [`Selection`]).
    pub fn selection(&self) -> Option<Selection> {
        self.selection
    }
    /// `s` as far as the model still holds it: `None` when its object is gone; without its
    /// polygon when the object's geometry no longer has that polygon.
    fn still_valid(&self, s: Selection) -> Option<Selection> {
        let o = self.objects.get(&s.object)?;
        let polys = o.geometry.as_ref().map_or(0, |g| g.polygons.len());
        Some(Selection {
            object: s.object,
            polygon: s.polygon.filter(|&k| (k as usize) < polys),
        })
    }
    pub fn get(&self, id: Id) -> Option<&Object> {
        self.objects.get(&id)
    }
    pub fn objects(&self) -> impl Iterator<Item = &Object> {
        self.objects.values()
    }
    pub fn len(&self) -> usize {
        self.objects.len()
    }
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }
    pub fn next_id(&self) -> Id {
        self.next_id
    }
    pub fn children_of(&self, id: Id) -> impl Iterator<Item = Id> + '_ {
        self.children
            .get(&id)
            .into_iter()
            .flat_map(|s| s.iter().copied())
    }

    /// Validates `tx` as a whole against the model and applies it: on success the version
    /// grows by one and the result says what changed; on error nothing changed at all.
    /// Cost: proportional to the objects the transaction touches (plus its geometry), not to
    /// the model.
    ///
    /// [`Op::Expect`] preconditions are checked against the committed model (where in the
    /// transaction they stand does not matter); a transaction of preconditions only changes
    /// nothing and is refused as [`TxError::Empty`].
    pub fn apply(&mut self, tx: &Transaction) -> Result<Applied, TxError> {
        if tx.ops().iter().all(Op::is_precondition) {
            return Err(TxError::Empty);
        }
        let mut stage = Stage {
            model: self,
            overlay: HashMap::new(),
            created: Vec::new(),
            next_id: self.next_id,
            touched: BTreeMap::new(),
            reparented: Vec::new(),
            selection: None,
        };
        for (i, op) in tx.ops().iter().enumerate() {
            stage.op(i, op)?;
        }
        stage.check_structure()?;
        stage.check_chains(tx.ops())?;
        let Stage {
            overlay,
            created,
            next_id,
            mut touched,
            selection,
            ..
        } = stage;
        // Commit: nothing below can fail.
        // The children index changes only where a parent did (a pose or a rename leaves it
        // alone), and an emptied set goes at once: no pass over every parent per commit.
        for (id, obj) in overlay {
            let old_parent = self.objects.get(&id).map(|o| o.parent);
            let new_parent = obj.as_ref().map(|o| o.parent);
            if old_parent != new_parent {
                if let Some(p) = old_parent
                    && let Some(set) = self.children.get_mut(&p)
                {
                    set.remove(&id);
                    if set.is_empty() {
                        self.children.remove(&p);
                    }
                }
                if let Some(p) = new_parent {
                    self.children.entry(p).or_default().insert(id);
                }
            }
            match obj {
                Some(o) => {
                    self.objects.insert(id, o);
                }
                None => {
                    self.objects.remove(&id);
                    self.children.remove(&id);
                }
            }
        }
        self.next_id = next_id;
        let version = self.version + 1;
        for (&id, &mask) in &touched {
            if !self.objects.contains_key(&id) {
                self.stamps.remove(&id);
                continue;
            }
            if mask & aspect::ALL == 0 {
                continue;
            }
            let base = self.stamps_base;
            let stamp = self.stamps.entry(id).or_insert([base; aspect::COUNT]);
            for (bit, s) in stamp.iter_mut().enumerate() {
                if mask & (1 << bit) != 0 {
                    *s = version;
                }
            }
        }
        // The selection: as the transaction set it, then as the committed model still holds
        // it (a deleted object, a polygon its new geometry lacks). Both the object it left and
        // the one it reached are announced with the SELECTION aspect.
        let before = self.selection;
        let after = selection
            .unwrap_or(before)
            .and_then(|s| self.still_valid(s));
        if after != before {
            for s in [before, after].into_iter().flatten() {
                *touched.entry(s.object).or_default() |= aspect::SELECTION;
            }
            self.selection = after;
        }
        self.version += 1;
        let applied = Applied {
            version: self.version,
            created,
            changes: touched.into_iter().collect(),
        };
        if applied.aspects() & !aspect::POSE != 0 {
            self.structure_version = self.version;
        }
        Ok(applied)
    }

    /// The version of the last transaction that changed anything but poses and joint values.
    pub fn structure_version(&self) -> u64 {
        self.structure_version
    }

    /// The version of the last transaction that changed any of `aspects` of object `id` (for a
    /// store rebuilt from a checkpoint, at least the checkpoint's version); `None` for an
    /// object that does not exist.
    pub fn changed_at(&self, id: Id, aspects: u64) -> Option<u64> {
        self.objects.get(&id)?;
        let base = self.stamps_base;
        Some(match self.stamps.get(&id) {
            None => base,
            Some(stamp) => stamp
                .iter()
                .enumerate()
                .filter(|(bit, _)| aspects & (1 << bit) != 0)
                .map(|(_, v)| *v)
                .max()
                .unwrap_or(base),
        })
    }
}

/// A transaction being validated: the model plus an overlay of the objects it changed.
struct Stage<'m> {
    model: &'m Store,
    /// `None` = deleted by this transaction.
    overlay: HashMap<Id, Option<Object>>,
    created: Vec<Id>,
    next_id: Id,
    touched: BTreeMap<Id, u64>,
    reparented: Vec<(usize, Id)>,
    /// Set by a `Select` op: the selection to commit (`Some(None)`: cleared).
    selection: Option<Option<Selection>>,
}

impl Stage<'_> {
    fn resolve(&self, op: usize, r: ObjRef) -> Result<Id, TxError> {
        let id = match r {
            ObjRef::Id(id) => id,
            ObjRef::New(k) => *self
                .created
                .get(k as usize)
                .ok_or(TxError::UnknownNewRef { op, reference: k })?,
        };
        if self.exists(id) {
            Ok(id)
        } else {
            Err(TxError::UnknownObject { op, id })
        }
    }
    fn exists(&self, id: Id) -> bool {
        match self.overlay.get(&id) {
            Some(o) => o.is_some(),
            None => self.model.objects.contains_key(&id),
        }
    }
    fn lookup(&self, id: Id) -> Option<&Object> {
        match self.overlay.get(&id) {
            Some(o) => o.as_ref(),
            None => self.model.objects.get(&id),
        }
    }
    /// The staged copy of `id`, cloned from the model on first write (geometry is shared).
    fn edit(&mut self, op: usize, r: ObjRef, aspects: u64) -> Result<&mut Object, TxError> {
        let id = self.resolve(op, r)?;
        if !self.overlay.contains_key(&id) {
            let copy = self.model.objects.get(&id).cloned();
            self.overlay.insert(id, copy);
        }
        *self.touched.entry(id).or_default() |= aspects;
        // resolve() checked existence, and we just inserted the model's copy if absent.
        self.overlay
            .get_mut(&id)
            .and_then(|o| o.as_mut())
            .ok_or(TxError::UnknownObject { op, id })
    }
    fn op(&mut self, i: usize, op: &Op) -> Result<(), TxError> {
        use crate::store::aspect::*;
        match op {
            Op::Create { kind, name, parent } => self.create(i, *kind, name, *parent)?,
            Op::Delete { id, recursive } => self.delete(i, *id, *recursive)?,
            Op::SetParent { id, parent } => {
                let parent = match parent {
                    Some(p) => self.resolve(i, *p)?,
                    None => 0,
                };
                let obj = self.edit(i, *id, STRUCTURE)?;
                obj.parent = parent;
                let id = obj.id;
                self.reparented.push((i, id));
            }
            Op::SetName { id, name } => {
                check_name(i, 0, name)?;
                self.edit(i, *id, STRUCTURE)?.name = name.clone();
            }
            Op::SetOrigin { id, origin } => {
                if origin.len() > MAX_ORIGIN_BYTES {
                    return Err(TxError::TooLarge {
                        op: i,
                        id: 0,
                        field: "origin".into(),
                        requested: origin.len() as u64,
                        limit: MAX_ORIGIN_BYTES as u64,
                    });
                }
                self.edit(i, *id, STRUCTURE)?.origin = origin.clone();
            }
            Op::SetPose { id, pose } => {
                let rid = self.resolve(i, *id)?;
                check_pose(i, rid, "pose", pose)?;
                self.edit(i, *id, POSE)?.pose = *pose;
            }
            Op::SetJoint { id, value } => {
                let rid = self.resolve(i, *id)?;
                finite(i, rid, "joint", *value)?;
                let obj = self.edit(i, *id, POSE)?;
                if obj.kind != Kind::Link {
                    return Err(TxError::InvalidValue {
                        op: i,
                        id: rid,
                        field: "joint".into(),
                        reason: format!("a {} has no joint", obj.kind.name()),
                    });
                }
                obj.joint = *value;
            }
            Op::SetAppearance { id, appearance } => self.set_appearance(i, *id, appearance)?,
            Op::SetKinematics { id, kinematics } => self.set_kinematics(i, *id, kinematics)?,
            Op::SetDynamics { id, dynamics } => {
                let rid = self.resolve(i, *id)?;
                if let Some(m) = dynamics {
                    finite(i, rid, "mass", m.mass)?;
                    finite_each(i, rid, "com", &m.com)?;
                    finite_each(i, rid, "inertia", &m.inertia)?;
                    validate::mass_props(m).map_err(|(field, reason)| TxError::InvalidValue {
                        op: i,
                        id: rid,
                        field: field.into(),
                        reason,
                    })?;
                }
                self.edit(i, *id, DYNAMICS)?.dynamics = *dynamics;
            }
            Op::SetGeometry { id, geometry } => self.set_geometry(i, *id, geometry)?,
            Op::Expect {
                id,
                aspects,
                version,
            } => self.expect(i, *id, *aspects, *version)?,
            Op::Select { id, polygon } => self.select(i, *id, *polygon)?,
        }
        Ok(())
    }

    /// [`Op::Create`]: a new object under `parent` (0: the root) with the next id, an identity
    /// pose and no data.
    fn create(
        &mut self,
        i: usize,
        kind: Kind,
        name: &str,
        parent: Option<ObjRef>,
    ) -> Result<(), TxError> {
        use crate::store::aspect::*;
        check_name(i, 0, name)?;
        let parent = match parent {
            Some(p) => self.resolve(i, p)?,
            None => 0,
        };
        let id = self.next_id;
        self.next_id += 1;
        let obj = Object {
            id,
            kind,
            parent,
            name: name.to_owned(),
            pose: IDENTITY,
            joint: 0.0,
            appearance: Appearance::default(),
            kinematics: None,
            dynamics: None,
            geometry: None,
            geom_gen: 0,
            origin: String::new(),
        };
        self.overlay.insert(id, Some(obj));
        self.created.push(id);
        self.touched.insert(id, ALL);
        self.reparented.push((i, id));
        Ok(())
    }

    /// [`Op::Delete`]: the object, and with `recursive` its whole subtree; an object with
    /// children is refused without it.
    fn delete(&mut self, i: usize, id: ObjRef, recursive: bool) -> Result<(), TxError> {
        use crate::store::aspect::*;
        let id = self.resolve(i, id)?;
        let mut doomed = vec![id];
        let mut k = 0;
        while k < doomed.len() {
            let d = doomed[k];
            let kids: Vec<Id> = self.child_ids(d);
            if !kids.is_empty() && !recursive {
                return Err(TxError::HasChildren {
                    op: i,
                    id: d,
                    children: kids.len(),
                });
            }
            doomed.extend(kids);
            k += 1;
        }
        for d in doomed {
            self.overlay.insert(d, None);
            self.touched.insert(d, ALL);
        }
        Ok(())
    }

    /// [`Op::SetAppearance`]: colour components in [0, 1], diffuse, specular and shininess
    /// finite and ≥ 0.
    fn set_appearance(
        &mut self,
        i: usize,
        id: ObjRef,
        appearance: &Appearance,
    ) -> Result<(), TxError> {
        use crate::store::aspect::*;
        let rid = self.resolve(i, id)?;
        for (k, c) in appearance.color.iter().enumerate() {
            if !(0.0..=1.0).contains(c) {
                return Err(TxError::InvalidValue {
                    op: i,
                    id: rid,
                    field: format!("color[{k}]"),
                    reason: format!("{c} is outside [0, 1]"),
                });
            }
        }
        for (f, v) in [
            ("diffuse", appearance.diffuse),
            ("specular", appearance.specular),
            ("shininess", appearance.shininess),
        ] {
            if !v.is_finite() || v < 0.0 {
                return Err(TxError::InvalidValue {
                    op: i,
                    id: rid,
                    field: f.into(),
                    reason: format!("{v} must be finite and ≥ 0"),
                });
            }
        }
        self.edit(i, id, APPEARANCE)?.appearance = *appearance;
        Ok(())
    }

    /// [`Op::SetKinematics`]: checked values, joint data only on a link and robot data only
    /// on a robot.
    fn set_kinematics(
        &mut self,
        i: usize,
        id: ObjRef,
        kinematics: &Option<Kinematics>,
    ) -> Result<(), TxError> {
        use crate::store::aspect::*;
        let rid = self.resolve(i, id)?;
        if let Some(k) = kinematics {
            check_kinematics(i, rid, k)?;
        }
        let kind = self.lookup(rid).map(|o| o.kind);
        match (kinematics, kind) {
            (
                Some(Kinematics::Joint { .. } | Kinematics::Axis { .. } | Kinematics::Mimic { .. }),
                Some(k),
            ) if k != Kind::Link => {
                return Err(TxError::InvalidValue {
                    op: i,
                    id: rid,
                    field: "kinematics".into(),
                    reason: format!("joint data belongs on a link, not a {}", k.name()),
                });
            }
            (Some(Kinematics::Robot { .. } | Kinematics::FloatingRobot { .. }), Some(k))
                if k != Kind::Robot =>
            {
                return Err(TxError::InvalidValue {
                    op: i,
                    id: rid,
                    field: "kinematics".into(),
                    reason: format!("robot data belongs on a robot, not a {}", k.name()),
                });
            }
            _ => {}
        }
        self.edit(i, id, KINEMATICS)?.kinematics = *kinematics;
        Ok(())
    }

    /// [`Op::SetGeometry`]: bounded sizes, finite vertices, a valid polyhedron (its derived
    /// forms computed here); the object's geometry generation moves on.
    fn set_geometry(
        &mut self,
        i: usize,
        id: ObjRef,
        geometry: &Option<GeometryInput>,
    ) -> Result<(), TxError> {
        use crate::store::aspect::*;
        let rid = self.resolve(i, id)?;
        let poly = match geometry {
            None => None,
            Some(g) => {
                for (field, n) in [
                    ("vertices", g.vertices.len()),
                    ("polygons", g.polygons.len()),
                ] {
                    if n as u64 > MAX_ELEMENTS {
                        return Err(TxError::TooLarge {
                            op: i,
                            id: rid,
                            field: field.into(),
                            requested: n as u64,
                            limit: MAX_ELEMENTS,
                        });
                    }
                }
                for (k, v) in g.vertices.iter().enumerate() {
                    // The field named only for a value that is not finite: a format
                    // per coordinate was most of a small geometry's validation.
                    if v.iter().any(|x| !x.is_finite()) {
                        finite_each(i, rid, &format!("vertices[{k}]"), v)?;
                    }
                }
                let verts = g
                    .vertices
                    .iter()
                    .map(|v| nalgebra::Point3::new(v[0], v[1], v[2]))
                    .collect();
                let p = Polyhedron::from_polygons(verts, &g.polygons).map_err(|e| {
                    TxError::InvalidGeometry {
                        op: i,
                        id: rid,
                        reason: e.to_string(),
                    }
                })?;
                Some(Arc::new(p))
            }
        };
        let obj = self.edit(i, id, GEOMETRY)?;
        obj.geometry = poly;
        obj.geom_gen += 1;
        Ok(())
    }

    /// [`Op::Select`]: the selection set to an object (and one of its polygons), or cleared.
    fn select(
        &mut self,
        i: usize,
        id: Option<ObjRef>,
        polygon: Option<u32>,
    ) -> Result<(), TxError> {
        let Some(id) = id else {
            if polygon.is_some() {
                return Err(TxError::InvalidValue {
                    op: i,
                    id: 0,
                    field: "selection".into(),
                    reason: "a polygon without an object".into(),
                });
            }
            self.selection = Some(None);
            return Ok(());
        };
        let rid = self.resolve(i, id)?;
        if let Some(k) = polygon {
            let n = self
                .lookup(rid)
                .and_then(|o| o.geometry.as_ref())
                .map_or(0, |g| g.polygons.len());
            if k as usize >= n {
                return Err(TxError::InvalidValue {
                    op: i,
                    id: rid,
                    field: "selection polygon".into(),
                    reason: format!("polygon {k} does not exist (the object has {n})"),
                });
            }
        }
        self.selection = Some(Some(Selection {
            object: rid,
            polygon,
        }));
        Ok(())
    }

    /// [`Op::Expect`]: checked against the committed model, whatever this transaction
    /// changed before it.
    fn expect(&self, i: usize, id: Id, aspects: u64, version: u64) -> Result<(), TxError> {
        let invalid = |reason: String| TxError::InvalidValue {
            op: i,
            id,
            field: "expect".into(),
            reason,
        };
        if aspects == 0 || aspects & !aspect::ALL != 0 {
            return Err(invalid(format!(
                "aspects {aspects:#x} must be a non-empty set of object aspects (bits of {:#x})",
                aspect::ALL
            )));
        }
        if version > self.model.version {
            return Err(invalid(format!(
                "version {version} was never committed (the model is at version {})",
                self.model.version
            )));
        }
        let Some(changed) = self.model.changed_at(id, aspects) else {
            return Err(TxError::UnknownObject { op: i, id });
        };
        if changed > version {
            let mask = self.model.stamps.get(&id).map_or(aspects, |stamp| {
                (0..aspect::COUNT)
                    .filter(|&bit| aspects & (1 << bit) != 0 && stamp[bit] > version)
                    .fold(0, |m, bit| m | (1 << bit))
            });
            return Err(TxError::Conflict {
                op: i,
                id,
                aspects: aspect::names(mask).join(", "),
                read: version,
                changed,
            });
        }
        Ok(())
    }

    fn child_ids(&self, id: Id) -> Vec<Id> {
        let mut out: Vec<Id> = self
            .model
            .children
            .get(&id)
            .map(|s| {
                s.iter()
                    .copied()
                    .filter(|c| self.lookup(*c).is_some_and(|o| o.parent == id))
                    .collect()
            })
            .unwrap_or_default();
        for (cid, o) in &self.overlay {
            if o.as_ref().is_some_and(|o| o.parent == id) && !out.contains(cid) {
                out.push(*cid);
            }
        }
        out.sort_unstable();
        out
    }

    /// Parent kinds and acyclicity, for every object whose parent this transaction set; and
    /// (a deleted object's children were deleted with it or refused in `Delete`).
    fn check_structure(&self) -> Result<(), TxError> {
        // The last op that set each object's parent is the one to blame.
        let mut last: HashMap<Id, usize> = HashMap::new();
        for &(op, id) in &self.reparented {
            last.insert(id, op);
        }
        let mut checks: Vec<(usize, Id)> = last.into_iter().map(|(id, op)| (op, id)).collect();
        // Latest first: the op that closed a cycle is reported, not an earlier one on it.
        checks.sort_unstable_by(|a, b| b.cmp(a));
        for &(op, id) in &checks {
            let Some(obj) = self.lookup(id) else { continue };
            let (allowed, may_be_root) = obj.kind.allowed_parents();
            if obj.parent == 0 {
                if !may_be_root {
                    return Err(TxError::NeedsParent {
                        op,
                        id,
                        kind: obj.kind.name().into(),
                    });
                }
                continue;
            }
            let Some(parent) = self.lookup(obj.parent) else {
                return Err(TxError::UnknownObject { op, id: obj.parent });
            };
            if !allowed.contains(&parent.kind) {
                return Err(TxError::WrongParentKind {
                    op,
                    id,
                    kind: obj.kind.name().into(),
                    parent_kind: parent.kind.name().into(),
                });
            }
            // Walk up: a cycle returns to `id`. Bounded by the number of objects.
            let mut cur = obj.parent;
            let limit = self.model.objects.len() + self.overlay.len() + 1;
            for _ in 0..limit {
                if cur == 0 {
                    break;
                }
                if cur == id {
                    return Err(TxError::Cycle {
                        op,
                        id,
                        parent: obj.parent,
                    });
                }
                cur = self.lookup(cur).map_or(0, |o| o.parent);
            }
        }
        Ok(())
    }
}

fn finite(op: usize, id: Id, field: &str, value: f64) -> Result<(), TxError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(TxError::NonFinite {
            op,
            id,
            field: field.into(),
            value,
        })
    }
}

/// Every one of `values` finite; the first that is not is named `field[k]` (the name made only
/// then).
fn finite_each(op: usize, id: Id, field: &str, values: &[f64]) -> Result<(), TxError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(k) => finite(op, id, &format!("{field}[{k}]"), values[k]),
    }
}

fn check_name(op: usize, id: Id, name: &str) -> Result<(), TxError> {
    if name.len() > MAX_NAME_BYTES {
        return Err(TxError::TooLarge {
            op,
            id,
            field: "name".into(),
            requested: name.len() as u64,
            limit: MAX_NAME_BYTES as u64,
        });
    }
    Ok(())
}

/// Finite, rotation orthonormal with determinant +1 (to 1e-6: poses composed in f64 by a
/// planner drift a little; the keeper does not renormalise them).
pub(crate) fn check_pose(op: usize, id: Id, field: &str, p: &Pose) -> Result<(), TxError> {
    finite_each(op, id, field, p)?;
    let r = nalgebra::Matrix3::new(p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]);
    let err = (r.transpose() * r - nalgebra::Matrix3::identity())
        .abs()
        .max();
    if err > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err(TxError::NotRigid {
            op,
            id,
            field: field.into(),
        });
    }
    Ok(())
}

fn check_kinematics(op: usize, id: Id, k: &Kinematics) -> Result<(), TxError> {
    match k {
        Kinematics::Joint {
            a,
            d,
            alpha,
            theta,
            offset,
            qlim,
            ..
        } => {
            for (f, v) in [
                ("a", a),
                ("d", d),
                ("alpha", alpha),
                ("theta", theta),
                ("offset", offset),
            ] {
                finite(op, id, f, *v)?;
            }
            check_qlim(op, id, qlim)?;
        }
        Kinematics::Robot { tool, .. } | Kinematics::FloatingRobot { tool, .. } => {
            check_pose(op, id, "tool", tool)?
        }
        Kinematics::Axis {
            index,
            parent,
            placement,
            axis,
            offset,
            qlim,
            ..
        } => {
            check_pose(op, id, "placement", placement)?;
            finite_each(op, id, "axis", axis)?;
            let norm = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-6 {
                return Err(TxError::InvalidValue {
                    op,
                    id,
                    field: "axis".into(),
                    reason: format!("{axis:?} is not a unit vector (norm {norm})"),
                });
            }
            finite(op, id, "offset", *offset)?;
            check_qlim(op, id, qlim)?;
            if parent > index {
                return Err(TxError::InvalidValue {
                    op,
                    id,
                    field: "parent".into(),
                    reason: format!(
                        "link frame {parent} is not before joint {index} (parents come first: at most {index})"
                    ),
                });
            }
        }
        Kinematics::Mimic { .. } => {
            let Some((axis, leader, multiplier, offset)) = k.mimic_parts() else {
                return Ok(());
            };
            check_kinematics(op, id, &axis)?;
            finite(op, id, "multiplier", multiplier)?;
            finite(op, id, "offset", offset)?;
            // the record holds leader + 1 above the joint kind's 8 bits
            if let Some(l) = leader.filter(|l| *l >= 0xff_ffff) {
                return Err(TxError::InvalidValue {
                    op,
                    id,
                    field: "leader".into(),
                    reason: format!("joint index {l} is past the record's 2^24 − 2"),
                });
            }
        }
    }
    Ok(())
}

fn check_qlim(op: usize, id: Id, qlim: &[f64; 2]) -> Result<(), TxError> {
    if qlim[0].is_nan() || qlim[1].is_nan() {
        return Err(TxError::NonFinite {
            op,
            id,
            field: "qlim".into(),
            value: f64::NAN,
        });
    }
    if qlim[0] > qlim[1] {
        return Err(TxError::InvalidValue {
            op,
            id,
            field: "qlim".into(),
            reason: format!("[{}, {}] is reversed", qlim[0], qlim[1]),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transaction::Transaction;

    /// The children index as a rebuild from the objects gives it.
    fn rebuilt(m: &Store) -> HashMap<Id, BTreeSet<Id>> {
        let mut out: HashMap<Id, BTreeSet<Id>> = HashMap::new();
        for o in m.objects.values() {
            out.entry(o.parent).or_default().insert(o.id);
        }
        out
    }

    /// Two writers read an object at the same version and each commits a pose computed from
    /// it: with [`Op::Expect`] the second is refused as a conflict (nothing changed), and built
    /// again from the new version it commits; an unrelated aspect (a rename) or another
    /// object does not conflict; a precondition on a version never committed, on no aspect or
    /// alone in its transaction is refused as such.
    #[test]
    fn a_stale_read_modify_write_is_refused_as_a_conflict() {
        let mut m = Store::new();
        let mut tx = Transaction::new();
        tx.create(Kind::Item, "a", None);
        tx.create(Kind::Item, "b", None);
        let created = m.apply(&tx).expect("create").created;
        let (a, b) = (created[0], created[1]);
        let read = m.version;
        let moved = |x: f64| {
            let mut p = IDENTITY;
            p[3] = x;
            p
        };
        let mut first = Transaction::new();
        first.expect(a, aspect::POSE, read).set_pose(a, moved(1.0));
        let mut second = Transaction::new();
        second.expect(a, aspect::POSE, read).set_pose(a, moved(1.0));
        m.apply(&first).expect("the first writer commits");
        let before = m.version;
        let e = m.apply(&second).expect_err("the second read a stale pose");
        assert_eq!(
            e,
            TxError::Conflict {
                op: 0,
                id: a,
                aspects: "pose".into(),
                read,
                changed: before,
            }
        );
        assert_eq!(
            (m.version, m.get(a).map(|o| o.pose[3])),
            (before, Some(1.0))
        );
        let mut again = Transaction::new();
        again
            .expect(a, aspect::POSE, m.version)
            .set_pose(a, moved(2.0));
        m.apply(&again).expect("built again from the new version");
        // A rename of `a` and a move of `b` leave a's pose unchanged since `now`.
        let now = m.version;
        let mut other = Transaction::new();
        other.set_name(a, "a2").set_pose(b, moved(5.0));
        m.apply(&other).expect("rename");
        let mut pose_only = Transaction::new();
        pose_only
            .expect(a, aspect::POSE, now)
            .set_pose(a, moved(3.0));
        m.apply(&pose_only).expect("only the name changed");
        let mut with_structure = Transaction::new();
        with_structure
            .expect(a, aspect::POSE | aspect::STRUCTURE, now)
            .set_pose(a, moved(4.0));
        assert!(matches!(
            m.apply(&with_structure),
            Err(TxError::Conflict { ref aspects, .. }) if aspects == "structure, pose"
        ));
        for (aspects, version) in [(0, now), (aspect::SELECTION, now), (aspect::POSE, 1000)] {
            let mut bad = Transaction::new();
            bad.expect(a, aspects, version).set_pose(a, moved(0.0));
            assert!(
                matches!(m.apply(&bad), Err(TxError::InvalidValue { ref field, .. }) if field == "expect"),
                "{aspects} at {version}"
            );
        }
        let mut alone = Transaction::new();
        alone.expect(a, aspect::POSE, m.version);
        assert_eq!(m.apply(&alone), Err(TxError::Empty));
        let mut gone = Transaction::new();
        gone.expect(99, aspect::POSE, m.version)
            .set_pose(a, moved(0.0));
        assert_eq!(
            m.apply(&gone),
            Err(TxError::UnknownObject { op: 0, id: 99 })
        );
    }

    /// A store rebuilt from a checkpoint does not know when its objects last changed: a
    /// precondition read before the checkpoint conflicts (a retry reads again), one read at or
    /// after it passes; a deleted object's stamps go with it.
    #[test]
    fn preconditions_after_a_checkpoint_are_checked_against_it() {
        let mut m = Store::new();
        let mut tx = Transaction::new();
        tx.create(Kind::Item, "a", None);
        let a = m.apply(&tx).expect("create").created[0];
        for _ in 0..3 {
            let mut t = Transaction::new();
            t.set_name(a, "x");
            m.apply(&t).expect("rename");
        }
        let objects: Vec<Object> = m.objects().cloned().collect();
        let mut r = Store::from_parts(m.version, m.next_id, objects, None);
        assert_eq!(r.changed_at(a, aspect::POSE), Some(4));
        let mut stale = Transaction::new();
        stale.expect(a, aspect::POSE, 2).set_pose(a, IDENTITY);
        assert!(matches!(
            r.apply(&stale),
            Err(TxError::Conflict { changed: 4, .. })
        ));
        let mut fresh = Transaction::new();
        fresh.expect(a, aspect::POSE, 4).set_pose(a, IDENTITY);
        r.apply(&fresh).expect("read at the checkpoint");
        let mut del = Transaction::new();
        del.delete(a, false);
        r.apply(&del).expect("delete");
        assert!(r.stamps.is_empty() && r.changed_at(a, aspect::ALL).is_none());
    }

    /// The children index is maintained incrementally (only where a parent changed); after
    /// every commit of a random mix of creates, re-parentings, recursive deletes and poses it
    /// equals the index rebuilt from scratch — no stale entry, no empty set left behind.
    #[test]
    fn children_index_follows_every_commit() {
        let mut m = Store::new();
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move |n: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % n.max(1)
        };
        let (mut committed, mut refused) = (0, 0);
        for step in 0..3000 {
            let ids: Vec<Id> = m.objects.keys().copied().collect();
            let pick = |r: u64| ids.get(r as usize).copied();
            let mut tx = Transaction::new();
            for _ in 0..1 + next(3) {
                let any = pick(next(ids.len() as u64 + 1));
                match next(10) {
                    0..=3 => {
                        let parent = any.map(ObjRef::Id);
                        tx.create(Kind::Solid, &format!("s{step}"), parent);
                    }
                    4..=5 => {
                        if let (Some(a), Some(b)) = (any, pick(next(ids.len() as u64))) {
                            tx.attach(a, b);
                        }
                    }
                    6 => {
                        if let Some(a) = any {
                            tx.detach(a);
                        }
                    }
                    7 => {
                        if let Some(a) = any {
                            tx.delete(a, next(2) == 0);
                        }
                    }
                    _ => {
                        if let Some(a) = any {
                            tx.set_pose(a, IDENTITY);
                        }
                    }
                }
            }
            if tx.is_empty() {
                continue;
            }
            match m.apply(&tx) {
                Ok(_) => committed += 1,
                Err(_) => refused += 1,
            }
            assert_eq!(m.children, rebuilt(&m), "after step {step}: {tx:?}");
        }
        assert!(committed > 1000 && refused > 100, "{committed} / {refused}");
    }
}
