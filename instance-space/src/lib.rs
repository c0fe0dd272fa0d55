//! The Instance Space (seed §3.2–3.3, DESIGN.md): the working model — geometry, part-whole
//! structure, display data, collision data, kinematics and dynamics — as flat, index-addressed
//! `#[repr(C)]` records in zero-copy shared memory (iceoryx2), written only through validated
//! transactions that the space keeper journals, applies, publishes and announces.
//!
//! Entry points:
//! * [`Store`], [`Transaction`], [`TxError`] — the plain model and the all-or-nothing writes.
//! * [`Keeper`] — the `robosim space` process: owns the services, serialises transactions,
//!   journals them ([`journal`]) and publishes snapshots and change records.
//! * [`Client`] — sends transactions to the keeper (request-response), pipelined or one by one.
//! * [`Reader`] / [`Snapshot`] — map the published model without copying it; wait for changes.
//! * [`state`] — the simulator's high-rate state service.
//! * [`Session`] — namespacing of shared memory, files and processes.
//!
//! `unsafe` appears once, in [`monotonic_ns`]; the shared-memory views are safe `bytemuck`
//! casts over iceoryx2 samples.
#![deny(unsafe_code)]

pub mod bare_event;
mod client;
mod encode;
mod error;
pub mod journal;
mod keeper;
pub mod layout;
mod object;
mod reader;
pub mod record;
pub mod replica;
mod scratch;
mod session;
pub mod state;
mod store;
mod transaction;
mod view;

pub use client::{
    Client, ClientError, Committed, MAX_CLIENTS_ENV, MAX_FRESH_ATTEMPTS, MAX_REQUEST_BYTES,
    Pending, max_clients_from_env,
};
pub use error::{Cause, error_chain};
pub use journal::ObjectData;
pub use keeper::{
    DEFAULT_SPIN_US, Keeper, KeeperError, KeeperOptions, OutOfStep, SPIN_ENV, spin_from_env,
};
pub use object::{
    Appearance, DhConvention, FloatingBase, IDENTITY, Id, JointKind, Kind, Kinematics,
    MAX_ELEMENTS, MassProps, Object, Pose, Selection, aspect,
};
pub use reader::{
    Change, FollowTrouble, GeometryView, LibraryPublication, ObjectView, Reader, ReaderError,
    Snapshot, compose,
};
pub use scratch::{ScratchKeeper, ThreadKeeper};
pub use session::{
    OpenOrCreateError, ProcInfo, Registration, Session, SessionError, default_session_name,
    exit_words, home, pid_alive, remove_shm_files, running_sessions, write_private,
};
pub use store::{Applied, INERTIA_TOL, Store, mass_props, principal_moments};
pub use transaction::{GeometryInput, ObjRef, Op, Transaction, TxError};
pub use view::{JointMimic, JointOrigin, JointView, RobotView};

/// Service suffixes inside a session (see [`Session::service`]).
pub mod services {
    pub const REQUESTS: &str = "space/tx";
    pub const REQUEST_EVENT: &str = "space/tx-event";
    pub const ACK_EVENT: &str = "space/ack-event";
    /// The objects head: the objects' header, every object chunk's generation, and the chunks
    /// the last structural commit changed (see [`crate::layout`]).
    pub const OBJECTS: &str = "space/objects";
    /// The objects base: every object chunk of one structure version, published on a reader's
    /// request.
    pub const OBJECTS_BASE: &str = "space/objects-base";
    /// The poses head (version and chunk generations); the chunks are [`pose_chunk`].
    pub const POSES: &str = "space/poses";
    /// The pose base: every pose of one version, published on a reader's request (see
    /// [`crate::layout`]).
    pub const POSE_BASE: &str = "space/pose-base";
    pub const CHANGES: &str = "space/changes";
    pub const CHANGE_EVENT: &str = "space/changed";
    /// The Library Space: the session's library as source files.
    pub const LIBRARY: &str = "space/library";
    /// Pose chunk `k`: the poses of objects `k·POSE_CHUNK ..` (see [`crate::layout::POSE_CHUNK`]).
    pub fn pose_chunk(k: usize) -> String {
        format!("space/poses/{k}")
    }
    /// Geometry updates: the geometry each group of commits changed (see [`crate::layout`]).
    pub const GEOMETRY: &str = "space/geometry";
    /// The geometry base: every object's geometry, published on a reader's request.
    pub const GEOMETRY_BASE: &str = "space/geometry-base";
}

/// CLOCK_MONOTONIC in ns: comparable across processes on one machine (unlike
/// `std::time::Instant`, whose origin is private), and immune to wall-clock steps.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    #[expect(
        unsafe_code,
        reason = "clock_gettime(2) has no safe std wrapper that exposes the raw clock"
    )]
    // SAFETY: `ts` is a valid, writable timespec owned by this frame; CLOCK_MONOTONIC always
    // exists on Linux, so the call only writes `ts`.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    if rc != 0 {
        return 0;
    }
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// iceoryx2 prints a start-up notice at Info level; keep the terminal for the program's own
/// output unless asked for more (`verbose` 1–3: warnings, info, debug) or less (`quiet`:
/// fatal errors only).
pub fn set_iceoryx2_log_level(quiet: bool, verbose: u8) {
    use iceoryx2::prelude::LogLevel;
    let level = match (quiet, verbose) {
        (true, _) => LogLevel::Fatal,
        (false, 0) => LogLevel::Error,
        (false, 1) => LogLevel::Warn,
        (false, 2) => LogLevel::Info,
        (false, _) => LogLevel::Debug,
    };
    iceoryx2::prelude::set_log_level(level);
}
