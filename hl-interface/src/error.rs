//! The protocol's one error type: what an op or the transport answers as
//! `{"ok": false, "error": {"kind", "message"}}` (DESIGN.md, "The query protocol").
//!
//! Entry points: [`ProtocolError`], [`ErrorKind`] ([`ErrorKind::as_str`] is the wire name,
//! [`ErrorKind::from_wire`] reads one back).

use std::fmt;
use std::sync::Arc;

/// A refused request: a machine-readable [`ErrorKind`] and a message naming the field (or
/// input line) and the reason. The wire carries the kind and the message only; on the Rust
/// side a refusal made from a typed error ([`ProtocolError::caused`]) keeps that error as its
/// `source()` (downcast it to match on it). Two refusals are equal when kind and message are
/// (what a client sees).
#[derive(Debug, Clone)]
pub struct ProtocolError {
    pub kind: ErrorKind,
    pub message: String,
    /// The error the message was made from, where there is one (not serialised).
    cause: Option<Arc<dyn std::error::Error + Send + Sync>>,
}

impl ProtocolError {
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        ProtocolError {
            kind,
            message: message.into(),
            cause: None,
        }
    }

    /// A refusal of `kind` whose message is `e`'s, keeping `e` as the source.
    pub fn caused(kind: ErrorKind, e: impl std::error::Error + Send + Sync + 'static) -> Self {
        ProtocolError {
            kind,
            message: e.to_string(),
            cause: Some(Arc::new(e)),
        }
    }

    /// The same refusal keeping `e` as its source (the message is left as it is: it should
    /// name what `e` says, and where).
    pub fn with_source(mut self, e: impl std::error::Error + Send + Sync + 'static) -> Self {
        self.cause = Some(Arc::new(e));
        self
    }

    /// `bad_request`: the request is malformed (the message names the field).
    pub fn bad_request(message: impl Into<String>) -> Self {
        ProtocolError::new(ErrorKind::BadRequest, message)
    }
}

impl fmt::Display for ProtocolError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.kind, self.message)
    }
}

impl std::error::Error for ProtocolError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.cause
            .as_deref()
            .map(|e| e as &(dyn std::error::Error + 'static))
    }
}

/// What a client sees: the kind and the message (the kept cause is not compared).
impl PartialEq for ProtocolError {
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind && self.message == other.message
    }
}

impl Eq for ProtocolError {}

/// Why a request was refused. The wire names ([`ErrorKind::as_str`]) are part of the
/// protocol's contract; the area that answers each is in parentheses.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum ErrorKind {
    /// `parse_error` (transport): the line is empty, not UTF-8 or not JSON.
    ParseError,
    /// `bad_request` (every area): a field is missing, of the wrong type or out of range.
    BadRequest,
    /// `unknown_op` (transport): no area answers the op.
    UnknownOp,
    /// `internal_error` (transport): an op panicked — a bug in the op.
    InternalError,
    /// `unknown_robot` (kinematics, dynamics, collision): no robot of that name.
    UnknownRobot,
    /// `bad_robot` (kinematics, collision): the inline robot could not be read.
    BadRobot,
    /// `invalid_robot` (dynamics): the robot's mass properties are unusable.
    InvalidRobot,
    /// `invalid_request` (dynamics): a field of the request is unusable.
    InvalidRequest,
    /// `unreachable` (kinematics, `ik`): the pose is out of the arm's reach.
    Unreachable,
    /// `not_converged` (kinematics, `ik`): the numeric solver did not converge.
    NotConverged,
    /// `not_applicable` (kinematics, `ik`): the method does not apply to this robot.
    NotApplicable,
    /// `singular` (dynamics): the mass matrix is singular.
    Singular,
    /// `overflow` (dynamics): finite inputs whose result leaves f64's range (q̇ = 1e200).
    Overflow,
    /// `diverged` (dynamics): the integration blew up or could not keep its error bound.
    Diverged,
    /// `too_many_steps` (dynamics): `simulate` exceeded its step budget.
    TooManySteps,
    /// `bad_shape` (collision): a shape could not be built.
    BadShape,
    /// `library_error` (library): the library file could not be loaded or evaluated.
    LibraryError,
    /// `unknown_declaration` (library): no declaration of that name.
    UnknownDeclaration,
    /// `bad_parameter` (library): no such parameter, or a value it cannot take.
    BadParameter,
    /// `bad_model` (automation): the fault model could not be loaded.
    BadModel,
    /// `bad_alarm` (automation): an alarm entry is malformed.
    BadAlarm,
    /// `unknown_alarm` (automation): the model has no alarm of that name.
    UnknownAlarm,
    /// `unknown_fault` (automation): the model has no failure mode of that name.
    UnknownFault,
    /// `session` (session ops): the session could not be read (keeper gone, segment torn).
    Session,
    /// `transaction` (session ops): the keeper refused or did not acknowledge a transaction.
    Transaction,
    /// `conflict` (session ops): a relative edit (`posttranslate`, a joint of a robot's q) lost
    /// to concurrent writes to the same object on every one of its attempts; nothing of it was
    /// committed.
    Conflict,
    /// `joint_limit` (session ops): a commanded joint value is outside the joint's limits.
    JointLimit,
    /// `unknown_object` (session ops): no object of that name or id in the Instance Space.
    UnknownObject,
    /// `check` (session ops): the collision check could not run.
    Check,
    /// `scene` (session ops): the session's scene could not be compiled into core models.
    Scene,
    /// Any other kind, by its wire name: e.g. a kind passed through from another server.
    Other(String),
}

/// Every named kind with its wire name (the table [`ErrorKind::as_str`] and
/// [`ErrorKind::from_wire`] share).
const NAMED: &[(ErrorKind, &str)] = &[
    (ErrorKind::ParseError, "parse_error"),
    (ErrorKind::BadRequest, "bad_request"),
    (ErrorKind::UnknownOp, "unknown_op"),
    (ErrorKind::InternalError, "internal_error"),
    (ErrorKind::UnknownRobot, "unknown_robot"),
    (ErrorKind::BadRobot, "bad_robot"),
    (ErrorKind::InvalidRobot, "invalid_robot"),
    (ErrorKind::InvalidRequest, "invalid_request"),
    (ErrorKind::Unreachable, "unreachable"),
    (ErrorKind::NotConverged, "not_converged"),
    (ErrorKind::NotApplicable, "not_applicable"),
    (ErrorKind::Singular, "singular"),
    (ErrorKind::Overflow, "overflow"),
    (ErrorKind::Diverged, "diverged"),
    (ErrorKind::TooManySteps, "too_many_steps"),
    (ErrorKind::BadShape, "bad_shape"),
    (ErrorKind::LibraryError, "library_error"),
    (ErrorKind::UnknownDeclaration, "unknown_declaration"),
    (ErrorKind::BadParameter, "bad_parameter"),
    (ErrorKind::BadModel, "bad_model"),
    (ErrorKind::BadAlarm, "bad_alarm"),
    (ErrorKind::UnknownAlarm, "unknown_alarm"),
    (ErrorKind::UnknownFault, "unknown_fault"),
    (ErrorKind::Session, "session"),
    (ErrorKind::Transaction, "transaction"),
    (ErrorKind::Conflict, "conflict"),
    (ErrorKind::JointLimit, "joint_limit"),
    (ErrorKind::UnknownObject, "unknown_object"),
    (ErrorKind::Check, "check"),
    (ErrorKind::Scene, "scene"),
];

impl ErrorKind {
    /// The wire name (`"bad_request"`, ...).
    pub fn as_str(&self) -> &str {
        match self {
            ErrorKind::Other(s) => s,
            kind => NAMED
                .iter()
                .find(|(k, _)| k == kind)
                .map_or("", |(_, name)| name),
        }
    }

    /// The kind of wire name `name`: a named kind when there is one, else [`ErrorKind::Other`]
    /// (so `from_wire(k).as_str() == k` for every `k`).
    pub fn from_wire(name: &str) -> Self {
        NAMED
            .iter()
            .find(|(_, n)| *n == name)
            .map_or_else(|| ErrorKind::Other(name.to_owned()), |(k, _)| k.clone())
    }
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl From<&str> for ErrorKind {
    fn from(name: &str) -> Self {
        ErrorKind::from_wire(name)
    }
}

/// Lets tests and clients compare a kind with its wire name: `e.kind == "bad_request"`.
impl PartialEq<str> for ErrorKind {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl PartialEq<&str> for ErrorKind {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_names_round_trip() {
        for (kind, name) in NAMED {
            assert_eq!(kind.as_str(), *name);
            assert_eq!(&ErrorKind::from_wire(name), kind);
        }
        // a kind this server does not name (e.g. passed through from another) survives
        assert_eq!(
            ErrorKind::from_wire("quota_exceeded"),
            ErrorKind::Other("quota_exceeded".to_owned())
        );
        assert_eq!(
            ErrorKind::from_wire("quota_exceeded").as_str(),
            "quota_exceeded"
        );
    }
}
