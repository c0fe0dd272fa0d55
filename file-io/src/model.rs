//! The saved model: every object of an Instance Space at one version, in the keeper's own
//! checkpoint form ([`ObjectData`]), and the session's Library Space additions; read from a
//! [`Snapshot`] and turned back into one [`Transaction`].
//!
//! Entry points: [`SavedModel::from_snapshot`], [`SavedModel::plan`] (validation and creation
//! order), [`SavedModel::to_transaction`] (replace or merge), [`SavedModel::counts`].

use crate::error::{FileError, ModelProblem};
use robosim_instance_space::{
    Appearance, GeometryInput, IDENTITY, Id, Kind, ObjRef, ObjectData, Op, Snapshot, Transaction,
};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};

/// One source file of a session's Library Space that the standard library does not have.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LibrarySource {
    /// The name the Library Space knows it by (its path when it was loaded).
    pub name: String,
    pub text: String,
}

/// A whole model as a file holds it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SavedModel {
    /// The Instance Space version the model was read at. Informational: loading it commits a
    /// new version in the target session.
    pub version: u64,
    /// Every object, sorted by id; `parent` refers to ids of this list (0: a root).
    pub objects: Vec<ObjectData>,
    /// The session's Library Space files beyond the standard library, in load order.
    pub library: Vec<LibrarySource>,
}

/// How a loaded model meets the session's current one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoadMode {
    /// Delete every object of the session, then create the file's (one transaction).
    Replace,
    /// Create the file's objects beside the session's, with new ids (one transaction).
    Merge,
}

/// The transaction that loads a model, and which file object each of its ops came from.
pub struct LoadPlan {
    pub tx: Transaction,
    /// Per op: the index into [`SavedModel::objects`] it writes (`None`: a delete of the
    /// session's objects).
    pub op_object: Vec<Option<usize>>,
}

impl SavedModel {
    /// Reads every object of `snap` (ids, parents, names, poses, joint values, appearance,
    /// kinematics, dynamics, geometry as vertices and polygons, origins). `library` is the
    /// session's Library Space as (name, text); the standard library's files are left out.
    pub fn from_snapshot(snap: &Snapshot, library: &[(String, String)]) -> Self {
        let standard: Vec<(String, String)> = robosim_library::Library::standard()
            .map(|l| l.sources())
            .unwrap_or_default();
        let mut objects = Vec::with_capacity(snap.len());
        for i in 0..snap.len() {
            let rec = snap.rec(i);
            let pose = &snap.poses()[i];
            let geometry = snap.geometry(i).map(|g| GeometryInput {
                vertices: g.vertices.to_vec(),
                polygons: g
                    .polygons
                    .iter()
                    .map(|p| {
                        g.indices
                            .get(p.start as usize..(p.start + p.len) as usize)
                            .map(<[u32]>::to_vec)
                            .unwrap_or_default()
                    })
                    .collect(),
            });
            objects.push(ObjectData {
                id: rec.id,
                // The keeper publishes only kinds it validated; an unknown tag (a newer keeper)
                // reads as the most permissive kind and is refused on load if misplaced.
                kind: rec.kind().unwrap_or(Kind::Solid),
                parent: rec.parent,
                name: snap.name(i).to_owned(),
                pose: pose.pose,
                joint: pose.joint,
                appearance: rec.appearance(),
                kinematics: rec.kinematics(),
                dynamics: rec.dynamics(),
                geometry,
                geom_gen: rec.geom_gen,
                origin: snap.origin(i).to_owned(),
            });
        }
        objects.sort_by_key(|o| o.id);
        SavedModel {
            version: snap.version(),
            objects,
            library: library
                .iter()
                .filter(|f| !standard.contains(f))
                .map(|(name, text)| LibrarySource {
                    name: name.clone(),
                    text: text.clone(),
                })
                .collect(),
        }
    }

    /// Checks the structure (ids unique and non-zero, every parent in the file, no cycle) and
    /// returns the objects' indices parents first: roots by id, then depth first, children by
    /// id — the order [`Self::to_transaction`] creates them in.
    pub fn plan(&self) -> Result<Vec<usize>, ModelProblem> {
        let mut by_id: HashMap<Id, usize> = HashMap::with_capacity(self.objects.len());
        for (i, o) in self.objects.iter().enumerate() {
            if o.id == 0 {
                return Err(ModelProblem::ZeroId { index: i });
            }
            if let Some(first) = by_id.insert(o.id, i) {
                return Err(ModelProblem::DuplicateId {
                    id: o.id,
                    first,
                    second: i,
                });
            }
        }
        let mut children: BTreeMap<Id, Vec<usize>> = BTreeMap::new();
        for (i, o) in self.objects.iter().enumerate() {
            if o.parent != 0 && !by_id.contains_key(&o.parent) {
                return Err(ModelProblem::MissingParent {
                    id: o.id,
                    name: o.name.clone(),
                    parent: o.parent,
                });
            }
            children.entry(o.parent).or_default().push(i);
        }
        for v in children.values_mut() {
            v.sort_by_key(|&i| self.objects[i].id);
        }
        let mut order = Vec::with_capacity(self.objects.len());
        let mut stack: Vec<usize> = children.get(&0).cloned().unwrap_or_default();
        stack.reverse();
        while let Some(i) = stack.pop() {
            order.push(i);
            if let Some(kids) = children.get(&self.objects[i].id) {
                stack.extend(kids.iter().rev());
            }
        }
        if order.len() < self.objects.len() {
            // Whatever no root reaches hangs in a cycle.
            let mut reached = vec![false; self.objects.len()];
            for &i in &order {
                reached[i] = true;
            }
            let i = reached.iter().position(|r| !r).unwrap_or(0);
            return Err(ModelProblem::Cycle {
                id: self.objects[i].id,
                name: self.objects[i].name.clone(),
            });
        }
        Ok(order)
    }

    /// The one transaction that loads this model: with `replace_roots` (the session's current
    /// roots), deletes of those first; then every object created parents first with all its
    /// aspects, parent references mapped to the new objects (the keeper assigns new ids).
    pub fn to_transaction(&self, replace_roots: &[Id]) -> Result<LoadPlan, ModelProblem> {
        let order = self.plan()?;
        let mut ops = Vec::with_capacity(replace_roots.len() + order.len() * 4);
        let mut op_object = Vec::with_capacity(ops.capacity());
        for &r in replace_roots {
            ops.push(Op::Delete {
                id: ObjRef::Id(r),
                recursive: true,
            });
            op_object.push(None);
        }
        let mut new_ref: HashMap<Id, ObjRef> = HashMap::with_capacity(order.len());
        for (k, &i) in order.iter().enumerate() {
            let o = &self.objects[i];
            let me = ObjRef::New(k as u32);
            let mut push = |op: Op| {
                ops.push(op);
                op_object.push(Some(i));
            };
            push(Op::Create {
                kind: o.kind,
                name: o.name.clone(),
                parent: (o.parent != 0).then(|| new_ref[&o.parent]),
            });
            new_ref.insert(o.id, me);
            if o.pose != IDENTITY {
                push(Op::SetPose {
                    id: me,
                    pose: o.pose,
                });
            }
            if o.joint != 0.0 {
                push(Op::SetJoint {
                    id: me,
                    value: o.joint,
                });
            }
            if o.appearance != Appearance::default() {
                push(Op::SetAppearance {
                    id: me,
                    appearance: o.appearance,
                });
            }
            if o.kinematics.is_some() {
                push(Op::SetKinematics {
                    id: me,
                    kinematics: o.kinematics,
                });
            }
            if o.dynamics.is_some() {
                push(Op::SetDynamics {
                    id: me,
                    dynamics: o.dynamics,
                });
            }
            if let Some(g) = &o.geometry {
                push(Op::SetGeometry {
                    id: me,
                    geometry: Some(g.clone()),
                });
            }
            if !o.origin.is_empty() {
                push(Op::SetOrigin {
                    id: me,
                    origin: o.origin.clone(),
                });
            }
        }
        Ok(LoadPlan {
            tx: Transaction::from_ops(ops),
            op_object,
        })
    }

    /// Objects per kind, in kind order (scene, robot, item, link, solid, part).
    pub fn counts(&self) -> BTreeMap<Kind, usize> {
        let mut m = BTreeMap::new();
        for o in &self.objects {
            *m.entry(o.kind).or_insert(0) += 1;
        }
        m
    }

    /// Total vertices over every object's geometry.
    pub fn vertex_count(&self) -> usize {
        self.objects
            .iter()
            .filter_map(|o| o.geometry.as_ref())
            .map(|g| g.vertices.len())
            .sum()
    }
}

/// A refusal of the keeper, blamed on the file object whose op it names.
pub(crate) fn blame(
    path: &std::path::Path,
    model: &SavedModel,
    plan: &LoadPlan,
    session: &str,
    e: robosim_instance_space::TxError,
) -> FileError {
    use robosim_instance_space::TxError as T;
    let op = match &e {
        T::UnknownObject { op, .. }
        | T::UnknownNewRef { op, .. }
        | T::NonFinite { op, .. }
        | T::InvalidValue { op, .. }
        | T::InvalidGeometry { op, .. }
        | T::Cycle { op, .. }
        | T::WrongParentKind { op, .. }
        | T::NeedsParent { op, .. }
        | T::HasChildren { op, .. }
        | T::TooLarge { op, .. }
        | T::NotRigid { op, .. }
        | T::Conflict { op, .. } => Some(*op),
        T::Malformed { .. } | T::Empty | T::Forward { .. } => None,
    };
    match op
        .and_then(|op| plan.op_object.get(op).copied().flatten())
        .and_then(|i| model.objects.get(i))
    {
        Some(o) => FileError::Refused {
            path: path.to_owned(),
            session: session.to_owned(),
            id: o.id,
            name: o.name.clone(),
            source: Box::new(e),
        },
        None => FileError::RefusedWhole {
            path: path.to_owned(),
            session: session.to_owned(),
            source: Box::new(e),
        },
    }
}
