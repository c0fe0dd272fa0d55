//! Transactions: what a writer asks the keeper to do, built with [`Transaction`]'s builder
//! methods, validated and applied as a whole by [`crate::Store::apply`].
//!
//! Objects the transaction creates are referred to by [`ObjRef::New`]`(k)`, the k-th create of
//! the same transaction; the keeper assigns their ids and returns them in order.

use crate::object::{Appearance, Id, Kind, Kinematics, MassProps, Pose};
use serde::{Deserialize, Serialize};

/// An object: an existing id, or the k-th object this transaction creates.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, bincode::Encode, bincode::Decode,
)]
pub enum ObjRef {
    Id(Id),
    New(u32),
}

impl From<Id> for ObjRef {
    fn from(id: Id) -> Self {
        ObjRef::Id(id)
    }
}

/// Geometry as a writer sends it: vertices (m) and polygons as vertex-index lists,
/// counter-clockwise seen from outside. The keeper computes planes, penalty planes, the edge
/// list and the bounding box (seed §3.3: the redundant forms are derived, never sent).
#[derive(
    Debug, Clone, PartialEq, Serialize, Deserialize, bincode::Encode, bincode::Decode, Default,
)]
pub struct GeometryInput {
    pub vertices: Vec<[f64; 3]>,
    pub polygons: Vec<Vec<u32>>,
}

impl GeometryInput {
    /// From a validated polyhedron (its derived forms are recomputed by the keeper).
    pub fn from_polyhedron(p: &robosim_geometry::Polyhedron) -> Self {
        GeometryInput {
            vertices: p.vertices.iter().map(|v| [v.x, v.y, v.z]).collect(),
            polygons: (0..p.polygons.len())
                .map(|i| p.polygon_indices(i).to_vec())
                .collect(),
        }
    }
}

/// One operation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, bincode::Encode, bincode::Decode)]
pub enum Op {
    Create {
        kind: Kind,
        name: String,
        parent: Option<ObjRef>,
    },
    Delete {
        id: ObjRef,
        recursive: bool,
    },
    /// Attach (`Some`) or detach (`None`).
    SetParent {
        id: ObjRef,
        parent: Option<ObjRef>,
    },
    SetName {
        id: ObjRef,
        name: String,
    },
    /// The declaration and parameters an instance came from (JSON text; empty: none).
    SetOrigin {
        id: ObjRef,
        origin: String,
    },
    SetPose {
        id: ObjRef,
        pose: Pose,
    },
    SetJoint {
        id: ObjRef,
        value: f64,
    },
    SetAppearance {
        id: ObjRef,
        appearance: Appearance,
    },
    SetKinematics {
        id: ObjRef,
        kinematics: Option<Kinematics>,
    },
    SetDynamics {
        id: ObjRef,
        dynamics: Option<MassProps>,
    },
    SetGeometry {
        id: ObjRef,
        geometry: Option<GeometryInput>,
    },
    /// Sets the session's selection ([`crate::Selection`]): an object and optionally one of
    /// its polygons, or nothing (`id: None`).
    Select {
        id: Option<ObjRef>,
        polygon: Option<u32>,
    },
    /// A precondition, not a change: the transaction is refused with
    /// [`crate::TxError::Conflict`] (and changes nothing) when any of `aspects` ([`crate::aspect`]
    /// bits of [`crate::aspect::ALL`]) of object `id` was changed by a transaction committed
    /// after `version`. A writer that computed its change from what it read at `version` (a
    /// relative move: `pose · T`, one joint of a robot's q) sends this with it, so a concurrent
    /// write to the same object is never overwritten unseen; [`crate::Client::transact_fresh`]
    /// reads again and retries. Decided by the keeper that owns the model; the journal and the
    /// replicas' log hold the transaction without it ([`Transaction::without_preconditions`]).
    Expect {
        id: Id,
        aspects: u64,
        version: u64,
    },
}

impl Op {
    /// Whether this op is a precondition ([`Op::Expect`]) rather than a change.
    pub fn is_precondition(&self) -> bool {
        matches!(self, Op::Expect { .. })
    }
}

/// An ordered list of operations, applied all or nothing.
///
/// The operations are private so that the count of creates (what the next
/// [`Transaction::create`] answers, `ObjRef::New(k)`) cannot drift from them: a writer that
/// builds a model of N objects in one transaction pays O(N), not O(N²) for counting them again
/// on every create. On the wire (serde and bincode) a transaction is only its operations.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(from = "TxWire", into = "TxWire")]
pub struct Transaction {
    ops: Vec<Op>,
    /// How many of `ops` are [`Op::Create`].
    creates: u32,
}

/// [`Transaction`]'s serde form: `{"ops": [...]}`.
#[derive(Serialize, Deserialize)]
struct TxWire {
    ops: Vec<Op>,
}

impl From<TxWire> for Transaction {
    fn from(w: TxWire) -> Self {
        Transaction::from_ops(w.ops)
    }
}

impl From<Transaction> for TxWire {
    fn from(t: Transaction) -> Self {
        TxWire { ops: t.ops }
    }
}

impl bincode::Encode for Transaction {
    fn encode<E: bincode::enc::Encoder>(
        &self,
        encoder: &mut E,
    ) -> Result<(), bincode::error::EncodeError> {
        self.ops.encode(encoder)
    }
}

impl<C> bincode::Decode<C> for Transaction {
    fn decode<D: bincode::de::Decoder<Context = C>>(
        decoder: &mut D,
    ) -> Result<Self, bincode::error::DecodeError> {
        Ok(Transaction::from_ops(Vec::<Op>::decode(decoder)?))
    }
}
bincode::impl_borrow_decode!(Transaction);

impl Transaction {
    pub fn new() -> Self {
        Transaction::default()
    }
    /// A transaction of these operations, in order.
    pub fn from_ops(ops: Vec<Op>) -> Self {
        let creates = ops
            .iter()
            .filter(|o| matches!(o, Op::Create { .. }))
            .count() as u32;
        Transaction { ops, creates }
    }
    /// The operations, in order.
    pub fn ops(&self) -> &[Op] {
        &self.ops
    }
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }
    pub fn len(&self) -> usize {
        self.ops.len()
    }
    /// Appends one operation (a create among them is `ObjRef::New` of the creates before it).
    pub fn push(&mut self, op: Op) -> &mut Self {
        if matches!(op, Op::Create { .. }) {
            self.creates += 1;
        }
        self.ops.push(op);
        self
    }
    /// Creates an object; returns its reference for later ops of this transaction.
    pub fn create(&mut self, kind: Kind, name: &str, parent: Option<ObjRef>) -> ObjRef {
        let k = self.creates;
        self.push(Op::Create {
            kind,
            name: name.to_owned(),
            parent,
        });
        ObjRef::New(k)
    }
    pub fn delete(&mut self, id: impl Into<ObjRef>, recursive: bool) -> &mut Self {
        self.ops.push(Op::Delete {
            id: id.into(),
            recursive,
        });
        self
    }
    pub fn attach(&mut self, id: impl Into<ObjRef>, parent: impl Into<ObjRef>) -> &mut Self {
        self.ops.push(Op::SetParent {
            id: id.into(),
            parent: Some(parent.into()),
        });
        self
    }
    pub fn detach(&mut self, id: impl Into<ObjRef>) -> &mut Self {
        self.ops.push(Op::SetParent {
            id: id.into(),
            parent: None,
        });
        self
    }
    pub fn set_name(&mut self, id: impl Into<ObjRef>, name: &str) -> &mut Self {
        self.ops.push(Op::SetName {
            id: id.into(),
            name: name.to_owned(),
        });
        self
    }
    pub fn set_origin(&mut self, id: impl Into<ObjRef>, origin: &str) -> &mut Self {
        self.ops.push(Op::SetOrigin {
            id: id.into(),
            origin: origin.to_owned(),
        });
        self
    }
    pub fn set_pose(&mut self, id: impl Into<ObjRef>, pose: Pose) -> &mut Self {
        self.ops.push(Op::SetPose {
            id: id.into(),
            pose,
        });
        self
    }
    pub fn set_joint(&mut self, id: impl Into<ObjRef>, value: f64) -> &mut Self {
        self.ops.push(Op::SetJoint {
            id: id.into(),
            value,
        });
        self
    }
    pub fn set_appearance(&mut self, id: impl Into<ObjRef>, appearance: Appearance) -> &mut Self {
        self.ops.push(Op::SetAppearance {
            id: id.into(),
            appearance,
        });
        self
    }
    pub fn set_kinematics(
        &mut self,
        id: impl Into<ObjRef>,
        kinematics: Option<Kinematics>,
    ) -> &mut Self {
        self.ops.push(Op::SetKinematics {
            id: id.into(),
            kinematics,
        });
        self
    }
    pub fn set_dynamics(
        &mut self,
        id: impl Into<ObjRef>,
        dynamics: Option<MassProps>,
    ) -> &mut Self {
        self.ops.push(Op::SetDynamics {
            id: id.into(),
            dynamics,
        });
        self
    }
    pub fn set_geometry(
        &mut self,
        id: impl Into<ObjRef>,
        geometry: Option<GeometryInput>,
    ) -> &mut Self {
        self.ops.push(Op::SetGeometry {
            id: id.into(),
            geometry,
        });
        self
    }

    /// Selects object `id` (and polygon `polygon` of its geometry), or clears the selection.
    pub fn select(&mut self, id: Option<ObjRef>, polygon: Option<u32>) -> &mut Self {
        self.ops.push(Op::Select { id, polygon });
        self
    }

    /// Adds a precondition ([`Op::Expect`]): refused unless none of `aspects` of `id` changed
    /// after `version` (the version the writer read `id` at).
    pub fn expect(&mut self, id: Id, aspects: u64, version: u64) -> &mut Self {
        self.ops.push(Op::Expect {
            id,
            aspects,
            version,
        });
        self
    }

    /// Adds, for every existing object this transaction changes, a precondition
    /// ([`Op::Expect`]) that the aspects it changes were not changed after `version`: a writer
    /// that computed the transaction from what it read at `version` overwrites no concurrent
    /// write unseen. Objects it creates or only selects need none.
    pub fn expect_unchanged_since(&mut self, version: u64) -> &mut Self {
        use crate::object::aspect::*;
        let mut written: std::collections::BTreeMap<Id, u64> = Default::default();
        for op in &self.ops {
            let (id, aspects) = match op {
                Op::Create { .. } | Op::Select { .. } | Op::Expect { .. } => continue,
                Op::Delete { id, .. } => (id, ALL),
                Op::SetParent { id, .. } | Op::SetName { id, .. } | Op::SetOrigin { id, .. } => {
                    (id, STRUCTURE)
                }
                Op::SetPose { id, .. } | Op::SetJoint { id, .. } => (id, POSE),
                Op::SetAppearance { id, .. } => (id, APPEARANCE),
                Op::SetKinematics { id, .. } => (id, KINEMATICS),
                Op::SetDynamics { id, .. } => (id, DYNAMICS),
                Op::SetGeometry { id, .. } => (id, GEOMETRY),
            };
            if let ObjRef::Id(id) = id {
                *written.entry(*id).or_default() |= aspects;
            }
        }
        for (id, aspects) in written {
            self.expect(id, aspects, version);
        }
        self
    }

    /// Whether any op is a precondition ([`Op::Expect`]).
    pub fn has_preconditions(&self) -> bool {
        self.ops.iter().any(Op::is_precondition)
    }

    /// The transaction as committed: its changes without its preconditions (what the keeper
    /// journals and sends to replicas, so replaying it never depends on versions it was
    /// checked against). `None` when it has no precondition (the transaction is its own
    /// committed form).
    pub fn without_preconditions(&self) -> Option<Transaction> {
        self.has_preconditions().then(|| {
            Transaction::from_ops(
                self.ops
                    .iter()
                    .filter(|o| !o.is_precondition())
                    .cloned()
                    .collect(),
            )
        })
    }

    /// The wire form (bincode 2, standard configuration).
    pub fn encode(&self) -> Vec<u8> {
        // Encoding plain data into a Vec cannot fail.
        bincode::encode_to_vec(self, bincode::config::standard()).unwrap_or_default()
    }

    /// Decodes the wire form. A length prefix that claims more memory than the message could
    /// describe (e.g. 10^12 vertices in a 40-byte request) is refused before any allocation.
    pub fn decode(bytes: &[u8]) -> Result<Self, TxError> {
        // Decoded size is at most ~32× the encoded size for our types (an empty inner Vec is
        // 1 byte on the wire, 24 in memory), so this limit never refuses an honest message.
        const CAP: usize = 1 << 34;
        let limit = bytes.len().saturating_mul(32).saturating_add(4096).min(CAP);
        let too_large = |e: &bincode::error::DecodeError| {
            matches!(e, bincode::error::DecodeError::LimitExceeded)
        };
        let result = decode_limited(bytes, limit);
        match result {
            Ok((tx, used)) if used == bytes.len() => Ok(tx),
            Ok((_, used)) => Err(TxError::Malformed {
                message: format!(
                    "{} trailing bytes after the transaction",
                    bytes.len() - used
                ),
            }),
            Err(e) if too_large(&e) => Err(TxError::TooLarge {
                op: 0,
                id: 0,
                field: "request".into(),
                requested: u64::MAX,
                limit: limit as u64,
            }),
            Err(e) => Err(TxError::Malformed {
                message: e.to_string(),
            }),
        }
    }
}

/// bincode's limit is a const generic; pick the smallest power of two ≥ `limit`.
fn decode_limited(
    bytes: &[u8],
    limit: usize,
) -> Result<(Transaction, usize), bincode::error::DecodeError> {
    use bincode::config::standard;
    macro_rules! try_limit {
        ($($n:literal),*) => {
            $( if limit <= (1usize << $n) { return bincode::decode_from_slice(bytes, standard().with_limit::<{ 1usize << $n }>()); } )*
        };
    }
    try_limit!(16, 20, 24, 28, 30, 32);
    bincode::decode_from_slice(bytes, standard().with_limit::<{ 1usize << 34 }>())
}

/// Why a transaction was refused. `op` is the index of the offending operation in the
/// transaction; `id` the object (0 for one the transaction was creating).
#[derive(Debug, Clone, PartialEq, thiserror::Error, Serialize, Deserialize)]
pub enum TxError {
    #[error("op {op}: object {id} does not exist")]
    UnknownObject { op: usize, id: Id },
    #[error("op {op}: `new {reference}` refers to no earlier create in this transaction")]
    UnknownNewRef { op: usize, reference: u32 },
    #[error("op {op}: object {id}: {field} is not finite ({value})")]
    NonFinite {
        op: usize,
        id: Id,
        field: String,
        value: f64,
    },
    #[error("op {op}: object {id}: {field}: {reason}")]
    InvalidValue {
        op: usize,
        id: Id,
        field: String,
        reason: String,
    },
    #[error("op {op}: object {id}: geometry refused: {reason}")]
    InvalidGeometry { op: usize, id: Id, reason: String },
    #[error(
        "op {op}: object {id}: making {parent} its parent would close a cycle in the hierarchy"
    )]
    Cycle { op: usize, id: Id, parent: Id },
    #[error("op {op}: object {id}: a {kind} cannot be a child of a {parent_kind}")]
    WrongParentKind {
        op: usize,
        id: Id,
        kind: String,
        parent_kind: String,
    },
    #[error("op {op}: object {id}: a {kind} needs a parent")]
    NeedsParent { op: usize, id: Id, kind: String },
    #[error(
        "op {op}: object {id} still has {children} children; delete them first or delete recursively"
    )]
    HasChildren { op: usize, id: Id, children: usize },
    #[error("op {op}: object {id}: {field} asks for {requested} elements; the limit is {limit}")]
    TooLarge {
        op: usize,
        id: Id,
        field: String,
        requested: u64,
        limit: u64,
    },
    #[error("op {op}: object {id}: {field} is not a rigid transform (orthonormal, det +1)")]
    NotRigid { op: usize, id: Id, field: String },
    #[error("malformed transaction: {message}")]
    Malformed { message: String },
    /// An [`Op::Expect`] precondition failed: another transaction changed the object after the
    /// version the writer read it at. Nothing was changed; read the object again and rebuild
    /// the transaction ([`crate::Client::transact_fresh`] does).
    #[error(
        "op {op}: object {id}: its {aspects} changed at version {changed}, after version {read} this transaction was computed from (a concurrent write; read it again and retry)"
    )]
    Conflict {
        op: usize,
        id: Id,
        /// The aspects expected unchanged that did change, by name (`pose`, `structure`, …).
        aspects: String,
        /// The version the writer read the object at.
        read: u64,
        /// The version of the latest transaction that changed one of them.
        changed: u64,
    },
    #[error("the transaction is empty")]
    Empty,
    /// A replica's bridge could not have the transaction decided by the keeper that owns the
    /// model (`robosim bridge`): refused there by flag, or no answer (then it may have been
    /// committed: the replica shows it when it arrives).
    #[error("not committed through the bridge: {reason}")]
    Forward { reason: String },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_creates() -> Transaction {
        let mut tx = Transaction::new();
        let a = tx.create(Kind::Solid, "a", None);
        tx.set_name(a, "a2");
        let b = tx.create(Kind::Solid, "b", Some(a));
        assert_eq!((a, b), (ObjRef::New(0), ObjRef::New(1)));
        tx
    }

    /// `Op::Expect` is the last variant, so every op journaled before it existed keeps its
    /// tag and old journals decode as they were written; the committed form drops only the
    /// preconditions.
    #[test]
    fn preconditions_leave_old_encodings_and_the_committed_form_alone() {
        let mut tx = Transaction::new();
        tx.select(None, None);
        // One op (length 1), tag 11 (Select), two `None`s.
        assert_eq!(tx.encode(), vec![1, 11, 0, 0]);
        assert!(tx.without_preconditions().is_none());
        let mut with = Transaction::new();
        with.expect(7, crate::aspect::POSE, 3)
            .set_joint(ObjRef::Id(7), 0.5)
            .expect(8, crate::aspect::ALL, 3);
        assert_eq!(with.encode()[1], 12, "Expect's tag follows Select's");
        assert_eq!(
            Transaction::decode(&with.encode()).expect("round trip"),
            with
        );
        let committed = with.without_preconditions().expect("it has preconditions");
        assert_eq!(
            committed.ops(),
            &[Op::SetJoint {
                id: ObjRef::Id(7),
                value: 0.5
            }]
        );
    }

    /// The count of creates survives both wire forms: the next create after decoding refers
    /// to the third object, not the first (a stale count would alias two new objects).
    #[test]
    fn creates_count_survives_the_wire() {
        let tx = two_creates();
        let mut back = Transaction::decode(&tx.encode()).expect("round trip");
        assert_eq!(back, tx);
        assert_eq!(back.create(Kind::Solid, "c", None), ObjRef::New(2));
        let json = serde_json::to_string(&tx).expect("round trip");
        assert!(json.starts_with("{\"ops\":["), "{json}");
        let mut back: Transaction = serde_json::from_str(&json).expect("round trip");
        assert_eq!(back, tx);
        assert_eq!(back.create(Kind::Solid, "c", None), ObjRef::New(2));
        let mut built = Transaction::from_ops(tx.ops().to_vec());
        built.push(Op::Create {
            kind: Kind::Solid,
            name: "c".into(),
            parent: None,
        });
        assert_eq!(built.create(Kind::Solid, "d", None), ObjRef::New(3));
    }
}
