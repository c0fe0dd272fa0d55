//! `robosim bridge`: a session's Instance Space and Library Space carried to other machines
//! over Zenoh (issue 18; docs/bridge.md).
//!
//! * [`primary`] — `--listen ENDPOINT`, beside the keeper that owns the model: answers
//!   snapshots and log requests, publishes every committed transaction in order (with a
//!   heartbeat carrying the keeper's version), forwards remote writers' transactions to the
//!   keeper and answers only once it has journaled them, and passes the simulator's state on at
//!   a bounded rate.
//! * [`replica`] — `--connect ENDPOINT`, on another machine: runs a keeper in replica mode for
//!   its own session (local displays, planners and simulators attach to it unchanged), fills it
//!   from a snapshot, applies the primary's transactions in order, catches up after a lost link
//!   from the primary keeper's log (or a new snapshot when the log no longer reaches back), and
//!   forwards its own writers' transactions.
//! * [`sweep_link`] — `robosim sweep-host` and `robosim sweep --remote`: line pipes to worker
//!   processes on other machines (a host starts them; a coordinator sends lines and hears
//!   their output and their end, or the host's).
//!
//! What crosses the wire (all bincode, under the key prefix `--key`, default `robosim`):
//! `<key>/snapshot` (query → [`SpaceSnapshot`]), `<key>/log` (query (version, library
//! generation) → [`LogAnswer`]; and published [`LogMsg`]s), `<key>/tx` (query: an encoded
//! transaction → `Result<Applied, TxError>`), `<key>/state/<name>` (published [`StateMsg`]).

#![forbid(unsafe_code)]

pub mod primary;
pub mod replica;
pub mod sweep_link;

use robosim_instance_space::layout::PoseRec;
use robosim_instance_space::state::{JointStateRec, StateHeader, StateRecord};
use serde::{Deserialize, Serialize};
use std::time::Duration;

#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// Zenoh refused `what`; its error is the source.
    #[error("zenoh {what}: {source}")]
    Zenoh {
        what: String,
        #[source]
        source: robosim_instance_space::Cause,
    },
    #[error(transparent)]
    Session(#[from] robosim_instance_space::SessionError),
    #[error(transparent)]
    Client(#[from] robosim_instance_space::ClientError),
    #[error(transparent)]
    Reader(#[from] robosim_instance_space::ReaderError),
    #[error(transparent)]
    Keeper(#[from] robosim_instance_space::KeeperError),
    /// The primary's snapshot did not come (the message says how).
    #[error("the primary's snapshot: {0}")]
    Snapshot(String),
    /// The primary's snapshot came and its model does not decode.
    #[error("the primary's snapshot: {0}")]
    SnapshotModel(#[source] robosim_instance_space::journal::StoreDecodeError),
    #[error("{0}")]
    Usage(String),
}

pub type Result<T> = std::result::Result<T, BridgeError>;

pub(crate) fn zerr<E: Into<robosim_instance_space::Cause>>(
    what: impl Into<String>,
) -> impl FnOnce(E) -> BridgeError {
    let what = what.into();
    move |e| BridgeError::Zenoh {
        what,
        source: e.into(),
    }
}

/// `robosim bridge` (exactly one of `--listen` and `--connect`).
#[derive(Debug, Clone)]
pub struct BridgeArgs {
    /// Serve this session's space on a Zenoh endpoint, e.g. tcp/0.0.0.0:7447 (the bridge
    /// listens there and nowhere else; no multicast scouting).
    pub listen: Option<String>,
    /// Keep this session a replica of the space served at a Zenoh endpoint, e.g.
    /// tcp/10.0.0.1:7447 (reconnects until stopped). The session must have no keeper: this
    /// bridge becomes its keeper, and the session's model is replaced by the primary's.
    pub connect: Option<String>,
    /// With --listen: refuse remote writers (replicas read; their transactions are refused
    /// with a clear error).
    pub read_only: bool,
    /// Key prefix of this space on the Zenoh network (several spaces can share one network).
    pub key: String,
    /// High-rate state services passed to the replica (`state/<name>`, the simulator's is
    /// `simulator`).
    pub states: Vec<String>,
    /// The most state records per second passed on per service (the newest is sent; the ones
    /// between are dropped). 0 passes none.
    pub state_hz: f64,
    /// With --connect: how long a forwarded transaction waits for the primary's answer, ms.
    pub tx_timeout_ms: u64,
    /// Heartbeat period of the primary, ms (a replica that hears of a newer version catches up;
    /// how soon a restored link resynchronises when nothing is being written).
    pub heartbeat_ms: u64,
}

/// What the primary publishes on `<key>/log`: the transactions after `after`, consecutive
/// (empty for a heartbeat), the keeper's version when sent and the library when it changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogMsg {
    pub after: u64,
    pub version: u64,
    pub entries: Vec<(u64, Vec<u8>)>,
    pub library: Option<(u64, robosim_instance_space::replica::PublishedLibrary)>,
}

/// A state record as it crosses the wire: the header's fields and the records' bytes (the
/// same `#[repr(C)]` little-endian records as in shared memory).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateMsg {
    pub structure_version: u64,
    pub t: f64,
    pub joints: Vec<u8>,
    pub bodies: Vec<u8>,
}

impl StateMsg {
    pub fn from_record(r: &StateRecord) -> Self {
        StateMsg {
            structure_version: r.header.structure_version,
            t: r.header.t,
            joints: bytemuck::cast_slice(&r.joints).to_vec(),
            bodies: bytemuck::cast_slice(&r.bodies).to_vec(),
        }
    }
    /// The records, or `None` when a length is not a whole number of records.
    pub fn records(&self) -> Option<(Vec<JointStateRec>, Vec<PoseRec>)> {
        let whole = |len: usize, size: usize| len.is_multiple_of(size);
        if !whole(self.joints.len(), size_of::<JointStateRec>())
            || !whole(self.bodies.len(), size_of::<PoseRec>())
        {
            return None;
        }
        fn read<T: bytemuck::Pod>(b: &[u8]) -> Vec<T> {
            b.chunks_exact(size_of::<T>())
                .map(bytemuck::pod_read_unaligned)
                .collect()
        }
        Some((read(&self.joints), read(&self.bodies)))
    }
}

const _: () = assert!(size_of::<StateHeader>() == 32);

pub(crate) fn encode<T: Serialize>(v: &T) -> Vec<u8> {
    bincode::serde::encode_to_vec(v, bincode::config::standard()).unwrap_or_default()
}

pub(crate) fn decode<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Option<T> {
    bincode::serde::decode_from_slice(bytes, bincode::config::standard())
        .ok()
        .map(|(v, _)| v)
}

/// The Zenoh configuration of a bridge: peer mode, TCP only, no multicast scouting and no
/// gossip (it talks to the endpoint it is given, and only there), a short lease so a cut link
/// is noticed within seconds, reconnection retried every second, no transmission batching.
pub(crate) fn zenoh_config(listen: Option<&str>, connect: Option<&str>) -> Result<zenoh::Config> {
    let mut c = zenoh::Config::default();
    let json = |v: &[&str]| {
        format!(
            "[{}]",
            v.iter()
                .map(|e| format!("{e:?}"))
                .collect::<Vec<_>>()
                .join(",")
        )
    };
    let set = |c: &mut zenoh::Config, key: &str, value: &str| {
        c.insert_json5(key, value)
            .map_err(|e| BridgeError::Usage(format!("zenoh configuration {key} = {value}: {e}")))
    };
    set(&mut c, "mode", "\"peer\"")?;
    set(&mut c, "scouting/multicast/enabled", "false")?;
    set(&mut c, "scouting/gossip/enabled", "false")?;
    set(
        &mut c,
        "listen/endpoints",
        &json(&listen.into_iter().collect::<Vec<_>>()),
    )?;
    set(
        &mut c,
        "connect/endpoints",
        &json(&connect.into_iter().collect::<Vec<_>>()),
    )?;
    set(
        &mut c,
        "connect/retry",
        "{period_init_ms: 250, period_max_ms: 1000, period_increase_factor: 2}",
    )?;
    set(&mut c, "transport/link/tx/lease", "3000")?;
    // No batching in Zenoh's transmission queue: it held messages for milliseconds here
    // (heartbeat put → subscriber 6–8 ms with it, under 4 ms without, localhost). The bridge
    // batches itself: one log message carries every transaction committed since the last.
    set(&mut c, "transport/link/tx/queue/batching/enabled", "false")?;
    Ok(c)
}

pub(crate) fn key(prefix: &str, what: &str) -> String {
    format!("{prefix}/{what}")
}

/// Runs the bridge for `session` until SIGINT/SIGTERM.
pub fn run(session: Option<&str>, args: &BridgeArgs) -> Result<()> {
    if args.key.is_empty() || args.key.contains(['*', '$', '#', '?']) {
        return Err(BridgeError::Usage(format!(
            "--key {:?}: a Zenoh key prefix without wildcards or `?`",
            args.key
        )));
    }
    if !args.state_hz.is_finite() || args.state_hz < 0.0 {
        return Err(BridgeError::Usage(format!(
            "--state-hz {}: a rate, 0 or more",
            args.state_hz
        )));
    }
    match (&args.listen, &args.connect) {
        (Some(endpoint), None) => {
            let session = robosim_instance_space::Session::existing(session)?;
            primary::serve(&session, endpoint, args)
        }
        (None, Some(endpoint)) => {
            let session = robosim_instance_space::Session::open(session)?;
            replica::follow(&session, endpoint, args)
        }
        _ => Err(BridgeError::Usage(
            "give exactly one of --listen ENDPOINT and --connect ENDPOINT".into(),
        )),
    }
}

/// How long a bridge loop sleeps between polls of its shared-memory events and Zenoh: 100 µs
/// while there was traffic in the last 100 ms, 1 ms after. The loops poll instead of blocking
/// on the iceoryx2 event with a timeout because that timeout is kept in the kernel's coarse
/// ticks here: a replica blocked "100 µs" woke on an 8 ms grid, which was the whole of the
/// replica's lag (`thread::sleep` uses high-resolution timers).
pub(crate) fn poll_sleep(last_activity: std::time::Instant) {
    std::thread::sleep(if last_activity.elapsed() < Duration::from_millis(100) {
        Duration::from_micros(100)
    } else {
        Duration::from_millis(1)
    });
}

/// The state rate as a period (None: pass nothing).
pub(crate) fn state_period(hz: f64) -> Option<Duration> {
    (hz > 0.0).then(|| Duration::from_secs_f64(1.0 / hz))
}
