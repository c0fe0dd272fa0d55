//! The space keeper (`robosim space`): the one writer of the Instance Space.
//!
//! It owns the session's long-lived services (a service vanishes with the process that
//! created it, so readers and writers come and go while the keeper stays), takes transactions
//! from any process over iceoryx2 request-response, and for each group of requests that arrive
//! together:
//! 1. validates and applies each transaction in arrival order ([`Store::apply`]); a refused one
//!    changes nothing and gets its typed error;
//! 2. appends each committed one to the journal and syncs once (group commit);
//! 3. publishes what changed — one geometry update holding the changed objects' geometry, the
//!    objects head with the object chunks (of [`OBJECT_CHUNK`] objects each) whose records
//!    changed if any structure/appearance/kinematics/dynamics/geometry or the selection
//!    changed, the pose chunks (of
//!    [`POSE_CHUNK`] objects each) holding a pose that changed, and always the poses head
//!    (version and chunk generations), which every snapshot starts from — then the change
//!    records. A one-body pose transaction thus publishes one chunk and the head: its cost
//!    follows what it moved, not the size of the model.
//! 4. only then acknowledges, and notifies readers and waiting clients.

use crate::journal::{self, Journal, JournalError, RecoveryReport};
use crate::layout::{
    ChangeRec, GEOMETRY_UPDATE_MAX_WORDS, OBJECT_CHUNK, OBJECT_PATCH_MAX, ObjectsHeader,
    POSE_CHUNK, PatchEntry, PatchRec, PoseRec, PosesHeader, SegmentWriter,
};
use crate::object::{Id, aspect};
use crate::replica::{LOG_MAGIC, Log, LogAnswer, PublishedLibrary, SNAPSHOT_MAGIC, SpaceSnapshot};
use crate::services;
use crate::session::{KeeperLock, Registration, Session, SessionError};
use crate::store::{Applied, Store};
use crate::transaction::Transaction;
use crate::transaction::TxError;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use std::collections::HashMap;
use std::time::{Duration, Instant};

type Pub = iceoryx2::port::publisher::Publisher<ipc::Service, [u64], ()>;
type Server = iceoryx2::port::server::Server<ipc::Service, [u8], (), [u8], ()>;
type Notifier = iceoryx2::port::notifier::Notifier<ipc::Service>;
type Listener = iceoryx2::port::listener::Listener<ipc::Service>;
type PubSubService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u64], ()>;

/// Event ids on the keeper's request event.
pub(crate) mod events {
    /// A client sent a request.
    pub const REQUEST: usize = 0;
    /// A reader attached or subscribed to a pose chunk: deliver history now.
    pub const HELLO: usize = 1;
    /// A reader wants every pose at once (attaching, or after a keeper restart): publish the
    /// pose base unless the one published is current. Implies [`HELLO`].
    pub const BASE: usize = 2;
    /// A reader lacks geometry (attaching, after a keeper restart, or having missed an
    /// update): publish the geometry base unless the one published is current. Implies
    /// [`HELLO`].
    pub const GEOMETRY_BASE: usize = 3;
    /// A reader lacks object chunks (attaching, after a keeper restart, or having missed an
    /// objects head): publish the objects base unless the one published is current. Implies
    /// [`HELLO`].
    pub const OBJECTS_BASE: usize = 4;
    /// On the change event: the keeper died (emitted by iceoryx2's dead-node cleanup).
    pub const KEEPER_DEAD: usize = 7;
}

#[derive(Debug, thiserror::Error)]
pub enum KeeperError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error(transparent)]
    Journal(#[from] JournalError),
    #[error("another keeper is running in session {session} (pid {pid})")]
    AlreadyRunning { session: String, pid: u32 },
    /// iceoryx2 refused `what`; its error is the source (matched by variant where it matters).
    #[error("iceoryx2 {what}: {source}")]
    Ipc {
        what: String,
        #[source]
        source: crate::error::Cause,
    },
    /// A replica was handed a transaction that does not follow its model.
    #[error("replica out of step: {0}")]
    OutOfStep(#[from] OutOfStep),
}

/// Why a replica's model and the one it follows differ ([`Keeper::apply_upstream`]): the
/// replica takes a new snapshot.
#[derive(Debug, thiserror::Error)]
pub enum OutOfStep {
    /// The next entry is not the version after the replica's.
    #[error("transaction {version} does not follow version {model}")]
    Gap { version: u64, model: u64 },
    /// The entry did not decode or this model refused it.
    #[error("transaction {version} was refused here: {source}")]
    Refused { version: u64, source: TxError },
}

fn ipc<E: std::error::Error + Send + Sync + 'static>(
    what: impl Into<String>,
) -> impl FnOnce(E) -> KeeperError {
    let what = what.into();
    move |e| KeeperError::Ipc {
        what,
        source: Box::new(e),
    }
}

/// Tunables. The defaults suit a workstation session.
#[derive(Debug, Clone)]
pub struct KeeperOptions {
    /// Write a checkpoint after this many journaled transactions.
    pub checkpoint_every: u64,
    /// The most requests applied in one group (one journal sync).
    pub max_batch: usize,
    /// How long the loop sleeps when idle.
    pub idle_wait: Duration,
    /// Readers per session (sizes the shared-memory pools).
    pub max_readers: usize,
    /// Writers per session.
    pub max_clients: usize,
    /// Copies of the journal (1 or 2). With 2, every record is also written to a mirror file
    /// and both are synced (together) before the acknowledgement, so one damaged record — a
    /// flipped bit, a bad sector — is read from the other copy instead of cutting every record
    /// after it. Cost: docs/bench/journal.md.
    pub journal_copies: u8,
    /// Sync the journal before acknowledging. Only benchmarks that isolate the cost of
    /// applying and publishing turn this off; it is never off in a session.
    pub durable: bool,
    /// The spin window: after serving a group, the keeper keeps polling for the next request
    /// (yielding the CPU between polls) for this long before it blocks on the request event
    /// again. A client that sends its next request within the window skips one event wake-up
    /// (≈ 50 µs on a small VM); the price is up to one core for the window after every
    /// request. Zero blocks at once (`KeeperOptions::default`); a session's keeper takes
    /// [`spin_from_env`] (default [`DEFAULT_SPIN_US`]); docs/bench/python.md has the
    /// measurement.
    pub spin: Duration,
    /// Answers in a fixed-size response pool of [`RESPONSE_CAP`] bytes each (larger answers
    /// go in parts). `false` restores the resizable pool, whose per-client connection is
    /// ~200 MB of bookkeeping that the keeper initialises when a client connects and scans
    /// when it leaves (a quarter-second stall per departure); only the detach benchmark turns
    /// it off, to measure the difference.
    pub static_responses: bool,
    /// A replica's keeper (`robosim bridge --connect`): its model comes from another keeper
    /// through [`Keeper::apply_upstream`]; its writers' transactions are not applied here but
    /// handed out by [`Keeper::take_forwarded`] and answered by [`Keeper::answer_forwarded`]
    /// once the other keeper has committed (or refused) them.
    pub replica: bool,
}

/// The environment variable that sets the spin window, in µs, of a keeper
/// ([`KeeperOptions::spin`]) and of a client waiting for its answer ([`crate::Client`]).
pub const SPIN_ENV: &str = "ROBOSIM_SPIN_US";

/// The spin window of a session's keeper and of a client when [`SPIN_ENV`] is unset, µs. With
/// 100 µs on both sides a Python `set_joints` round trip (release build, 2-core VM) took p50
/// 38–48 µs against 76–95 µs blocking, measured interleaved in one run (docs/bench/python.md);
/// the keeper's CPU while a planner streams rose from 22–28 % to 27–32 % of a core, and an idle
/// keeper does not spin. `ROBOSIM_SPIN_US=0` blocks at once, as before.
pub const DEFAULT_SPIN_US: u64 = 100;

/// The spin window named by [`SPIN_ENV`] ([`DEFAULT_SPIN_US`] when unset); an unreadable value
/// is an error naming the variable.
pub fn spin_from_env() -> Result<Duration, String> {
    match std::env::var(SPIN_ENV) {
        Err(_) => Ok(Duration::from_micros(DEFAULT_SPIN_US)),
        Ok(v) => v
            .trim()
            .parse::<u64>()
            .ok()
            .filter(|us| *us <= 1_000_000)
            .map(Duration::from_micros)
            .ok_or_else(|| {
                format!("{SPIN_ENV}={v:?}: expected a whole number of microseconds, 0 to 1000000")
            }),
    }
}

/// The largest answer sent in one response; a larger one is sent in parts, each fetched by a
/// continuation request ([`MORE_MAGIC`]).
pub(crate) const RESPONSE_CAP: usize = 4096;
/// The start of a continuation request: `MORE_MAGIC`, then the answer's token (u64 LE). A
/// transaction's encoding never starts with 0xFF (not a bincode varint tag).
pub(crate) const MORE_MAGIC: [u8; 5] = [0xFF, b'M', b'O', b'R', b'E'];
/// Response tags (first byte of every response).
pub(crate) mod answer {
    /// The whole answer follows.
    pub const WHOLE: u8 = 0;
    /// A part: token (u64 LE), total length (u64 LE), the part's offset in the answer (u64
    /// LE), then its bytes. Parts are sent in order, one per request (the first, then one per
    /// continuation request).
    pub const PART: u8 = 1;
    /// The continuation named an answer the keeper no longer holds.
    pub const EXPIRED: u8 = 2;
    /// Header length of a part.
    pub const PART_HEADER: usize = 25;
}
/// A keeper's epoch: the wall clock in ns when it started (or replaced its model), so a
/// reader tells a new keeper's segments from an old one's.
fn wall_clock_epoch() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_nanos() as u64)
}

/// The largest segment [`Keeper::send`] writes through the keeper's scratch words (1 MB).
const SCRATCH_WORDS: usize = 1 << 17;

/// Large answers not yet fully fetched, at most this many (the oldest go first).
const MAX_LARGE_ANSWERS: usize = 64;

impl Default for KeeperOptions {
    fn default() -> Self {
        KeeperOptions {
            checkpoint_every: 100_000,
            max_batch: 4096,
            idle_wait: Duration::from_millis(20),
            max_readers: 16,
            max_clients: 16,
            journal_copies: 2,
            durable: true,
            spin: Duration::ZERO,
            static_responses: true,
            replica: false,
        }
    }
}

/// Per-client in-flight requests; clients pipeline up to this many.
pub(crate) const MAX_IN_FLIGHT: usize = 64;
/// How many old snapshots a reader may hold while taking a new one.
pub(crate) const MAX_HELD_SNAPSHOTS: usize = 4;

pub struct Keeper {
    session: Session,
    opts: KeeperOptions,
    node: Node<ipc::Service>,
    model: Store,
    journal: Journal,
    epoch: u64,
    server: Server,
    req_listener: Listener,
    ack_notifier: Notifier,
    change_notifier: Notifier,
    changes_pub: Pub,
    /// The objects head (header, chunk generations, the chunks a structural commit changed).
    objects_pub: Pub,
    /// The objects base (every object chunk, on request) and the (epoch, structure version) of
    /// the last one published.
    objects_base_pub: Pub,
    objects_base_published: Option<(u64, u64)>,
    /// Each object chunk's segment as last published and its generation (the structure
    /// version it was published at); the chunks to carry with the next objects head.
    obj_chunks: Vec<Vec<u64>>,
    obj_gen: Vec<u64>,
    obj_dirty: Vec<bool>,
    /// Each object chunk's lineage: the generation at which it was last carried whole (by an
    /// objects head, or served by the objects base when a head carried nothing), and the records
    /// patched in it since (indices, ascending) — what the next objects head carries for it
    /// when it changed by patches alone ([`crate::layout::PatchEntry`]). `obj_whole`: it changed
    /// otherwise (encoded again, extended, new) since the last head, so it goes whole.
    obj_since: Vec<u64>,
    obj_patched: Vec<Vec<u32>>,
    obj_whole: Vec<bool>,
    poses_pub: Pub,
    /// The pose base (every pose of one version, on request) and the (epoch, version) of the
    /// last one published.
    base_pub: Pub,
    base_published: Option<(u64, u64)>,
    /// One publisher per pose chunk, made when the chunk first changes in an epoch (see
    /// [`Keeper::publish_all`]), and the version each chunk was last published at.
    chunk_pubs: Vec<Option<(Pub, PubSubService)>>,
    chunk_gen: Vec<u64>,
    /// Chunks to publish with the next head.
    chunk_dirty: Vec<bool>,
    /// Geometry updates, the geometry base, and the (epoch, structure version) of the last base
    /// published.
    geometry_pub: Pub,
    geometry_base_pub: Pub,
    geometry_base_published: Option<(u64, u64)>,
    library: Option<Pub>,
    // Caches so a pose change costs one record update plus one copy of its chunk.
    order: Vec<Id>,
    index: HashMap<Id, usize>,
    poses: Vec<PoseRec>,
    structure_version: u64,
    last_connect_update: Instant,
    /// When the last group was served (the spin window runs from here).
    last_served: Option<Instant>,
    /// Large answers being fetched in parts: token → (encoded answer, next offset).
    large: std::collections::BTreeMap<u64, (Vec<u8>, usize)>,
    next_token: u64,
    /// The last committed transactions, for replicas catching up ([`crate::replica`]).
    log: Log,
    /// The Library Space as last published, and how many times it was published.
    library_files: PublishedLibrary,
    library_gen: u64,
    /// Replica: writers' transactions held until the other keeper answers (ticket → request),
    /// and the ones not yet handed to the bridge.
    held: HashMap<u64, ActiveRequest>,
    to_forward: Vec<(u64, Vec<u8>)>,
    /// Where [`Keeper::send`] writes a segment before copying it into a sample.
    scratch: std::cell::RefCell<Vec<u64>>,
    _registration: Registration,
    _services: Vec<Box<dyn std::any::Any>>,
    /// Held until everything above is dropped (the journal closed).
    _lock: KeeperLock,
}

/// What the keeper sends back for one request.
enum Reply {
    Tx(Result<Applied, TxError>),
    More(u64),
    /// Already encoded (a snapshot or a log answer).
    Bytes(Vec<u8>),
}

type ActiveRequest = iceoryx2::active_request::ActiveRequest<ipc::Service, [u8], (), [u8], ()>;

/// Where a starting keeper's model comes from.
enum Source {
    /// The session's journal and checkpoints.
    Recover,
    /// Given (a replica's snapshot); the data directory is reset to it.
    Given(Box<Store>),
}

/// What one group did (for benchmarks and logs).
#[derive(Debug, Default, Clone, Copy)]
pub struct GroupStats {
    pub committed: usize,
    pub refused: usize,
}

/// How a keeper service's subscribers queue samples: buffered, kept for late joiners, held.
struct SubscriberQueue {
    buffer: usize,
    history: usize,
    borrowed: usize,
}

/// Opens or creates one of the keeper's publish-subscribe services (`suffix` in `session`):
/// one publisher (the keeper), overflow-safe, sized for the session's readers and clients.
fn pubsub_service(
    session: &Session,
    node: &Node<ipc::Service>,
    opts: &KeeperOptions,
    suffix: &str,
    q: SubscriberQueue,
) -> Result<PubSubService, KeeperError> {
    let name = session.service(suffix)?;
    session
        .open_or_create_service(|| {
            node.service_builder(&name)
                .publish_subscribe::<[u64]>()
                .history_size(q.history)
                .subscriber_max_buffer_size(q.buffer)
                .subscriber_max_borrowed_samples(q.borrowed)
                .enable_safe_overflow(true)
                .max_publishers(1)
                .max_subscribers(opts.max_readers)
                .max_nodes(opts.max_clients + opts.max_readers + 4)
                .open_or_create()
        })
        .map_err(ipc(format!("create service {suffix}")))
}

impl Keeper {
    /// Recovers the session's model from its journal and checkpoints, creates the services and
    /// registers as the session's `space` process. Fails if a keeper already runs there.
    pub fn start(
        session: &Session,
        opts: KeeperOptions,
    ) -> Result<(Keeper, RecoveryReport), KeeperError> {
        Keeper::start_from(session, opts, Source::Recover)
    }

    /// Starts a keeper whose model is `model` (a replica's snapshot): the session's data
    /// directory is reset to it (older journals and checkpoints removed), then everything is
    /// as [`Keeper::start`].
    pub fn start_with(
        session: &Session,
        opts: KeeperOptions,
        model: Store,
    ) -> Result<Keeper, KeeperError> {
        Keeper::start_from(session, opts, Source::Given(Box::new(model))).map(|(k, _)| k)
    }

    fn start_from(
        session: &Session,
        opts: KeeperOptions,
        source: Source,
    ) -> Result<(Keeper, RecoveryReport), KeeperError> {
        // One keeper per session, by an OS lock taken before the journal is touched: two
        // keepers started at the same instant both passed the registry check below, both
        // recovered, and the one that lost the race for the services had already replaced the
        // other's journal mirror (issue 34 item 2).
        let lock = session.lock_keeper()?;
        if let Some(p) = session
            .processes()
            .into_iter()
            .find(|p| p.role == "space" && p.pid != std::process::id())
        {
            return Err(KeeperError::AlreadyRunning {
                session: session.name().to_owned(),
                pid: p.pid,
            });
        }
        let node = session.node("space", true)?;
        // A keeper killed with -9 leaves its node behind; reclaim its resources now (this also
        // fires the dead-notifier event readers listen to). Services are opened-or-created:
        // readers that outlived the old keeper keep them alive, and their ports connect to the
        // new keeper's publishers without re-attaching.
        let _ = node.blocking_cleanup_dead_nodes(Duration::from_secs(2));
        let (model, journal, report) = match source {
            Source::Recover => journal::recover_copies(&session.data_dir(), opts.journal_copies)?,
            Source::Given(model) => {
                let j = journal::reset(&session.data_dir(), &model, opts.journal_copies)?;
                (*model, j, RecoveryReport::default())
            }
        };
        let epoch = wall_clock_epoch();

        let req_event = {
            let name = session.service(services::REQUEST_EVENT)?;
            session.open_or_create_service(|| {
                node.service_builder(&name)
                    .event()
                    .max_notifiers(opts.max_clients + opts.max_readers + 4)
                    .max_listeners(2)
                    .max_nodes(opts.max_clients + opts.max_readers + 4)
                    .open_or_create()
            })
        }
        .map_err(ipc("create request event"))?;
        let req_listener = req_event
            .listener_builder()
            .create()
            .map_err(ipc("create request listener"))?;
        let ack_event = {
            let name = session.service(services::ACK_EVENT)?;
            session.open_or_create_service(|| {
                node.service_builder(&name)
                    .event()
                    .max_notifiers(2)
                    .max_listeners(opts.max_clients + 4)
                    .max_nodes(opts.max_clients + opts.max_readers + 4)
                    .open_or_create()
            })
        }
        .map_err(ipc("create ack event"))?;
        let ack_notifier = ack_event
            .notifier_builder()
            .create()
            .map_err(ipc("create ack notifier"))?;
        let change_event = {
            let name = session.service(services::CHANGE_EVENT)?;
            session.open_or_create_service(|| {
                node.service_builder(&name)
                    .event()
                    .max_notifiers(2)
                    .max_listeners(opts.max_readers + 4)
                    .max_nodes(opts.max_clients + opts.max_readers + 4)
                    .notifier_dead_event(EventId::new(events::KEEPER_DEAD))
                    .open_or_create()
            })
        }
        .map_err(ipc("create change event"))?;
        let change_notifier = change_event
            .notifier_builder()
            .create()
            .map_err(ipc("create change notifier"))?;

        let pubsub = |suffix: &str, buffer: usize, history: usize, borrowed: usize| {
            pubsub_service(
                session,
                &node,
                &opts,
                suffix,
                SubscriberQueue {
                    buffer,
                    history,
                    borrowed,
                },
            )
        };
        let publisher = |svc: &iceoryx2::service::port_factory::publish_subscribe::PortFactory<
            ipc::Service,
            [u64],
            (),
        >,
                         len: usize,
                         what: &str|
         -> Result<Pub, KeeperError> {
            svc.publisher_builder()
                .initial_max_slice_len(len)
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .max_loaned_samples(1)
                .create()
                .map_err(ipc(format!("create publisher {what}")))
        };
        let changes_svc = pubsub(services::CHANGES, 256, 16, 4)?;
        let changes_pub = publisher(&changes_svc, 64, "changes")?;
        let objects_svc = pubsub(services::OBJECTS, 2, 1, MAX_HELD_SNAPSHOTS + 1)?;
        let objects_pub = publisher(&objects_svc, 1024, "objects")?;
        let objects_base_svc = pubsub(services::OBJECTS_BASE, 1, 1, MAX_HELD_SNAPSHOTS + 1)?;
        let objects_base_pub = publisher(&objects_base_svc, 1024, "objects base")?;
        let poses_svc = pubsub(services::POSES, 2, 1, MAX_HELD_SNAPSHOTS + 1)?;
        let poses_pub = publisher(&poses_svc, 1024, "poses")?;
        let base_svc = pubsub(services::POSE_BASE, 1, 1, MAX_HELD_SNAPSHOTS + 1)?;
        let base_pub = publisher(&base_svc, 1024, "pose base")?;
        // Geometry: readers copy what an update carries and let go of it, so few samples are
        // borrowed; a base stays mapped while a snapshot uses it.
        let geometry_svc = pubsub(services::GEOMETRY, 8, 0, 2)?;
        let geometry_pub = publisher(&geometry_svc, 1024, "geometry")?;
        let geometry_base_svc = pubsub(services::GEOMETRY_BASE, 1, 1, MAX_HELD_SNAPSHOTS + 1)?;
        let geometry_base_pub = publisher(&geometry_base_svc, 1024, "geometry base")?;

        // The request service last: a writer that can connect (`Client::connect`, which is
        // how launchers and tests wait for a keeper) finds every other service of the keeper
        // already there. Made first, it opened a window in which a reader attaching got
        // `DoesNotExist` for space/objects — wide enough to fail tests once the response pool
        // was preallocated (a fixed pool takes a while to make).
        let rr = {
            let name = session.service(services::REQUESTS)?;
            session.open_or_create_service(|| {
                node.service_builder(&name)
                    .request_response::<[u8], [u8]>()
                    .max_clients(opts.max_clients)
                    .max_servers(1)
                    .max_active_requests_per_client(MAX_IN_FLIGHT)
                    .max_response_buffer_size(1)
                    .max_borrowed_responses_per_pending_response(1)
                    .max_loaned_requests(4)
                    .enable_safe_overflow_for_requests(false)
                    .enable_safe_overflow_for_responses(false)
                    .max_nodes(opts.max_clients + opts.max_readers + 4)
                    .open_or_create()
            })
        }
        .map_err(ipc("create request service"))?;
        // The response pool. iceoryx2 keeps, per client connection, one flag per response
        // chunk for every channel (2 × in-flight + loans) and every segment the pool may
        // grow to (255 for a resizable pool): with a resizable pool that is ~200 MB written
        // when a client connects and scanned when it leaves (`UsedChunkList::remove_all`),
        // a quarter second in which the keeper serves nobody. A fixed pool has one segment;
        // answers larger than its chunks go in parts (see `send_answer`). The pool holds what
        // can be in use at once: every client's in-flight answers, each buffered or borrowed
        // (this keeper answers each request at once, once, and keeps no request), not
        // iceoryx2's worst case for servers that hold requests.
        let server = if opts.static_responses {
            let need = opts.max_clients * MAX_IN_FLIGHT * 2 + 1;
            rr.server_builder()
                .max_loaned_responses_per_request(1)
                .initial_max_slice_len(RESPONSE_CAP)
                .allocation_strategy(AllocationStrategy::Static)
                .override_response_preallocation(move |worst| need.min(worst))
                .create()
        } else {
            rr.server_builder()
                .max_loaned_responses_per_request(1)
                .initial_max_slice_len(256)
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .create()
        }
        .map_err(ipc("create server"))?;
        // What recovery lost is written before the keeper registers, so a launcher that
        // waits for the registration (`robosim up`) finds it and says it aloud.
        let lost_note = session.run_dir().join(journal::LOST_NOTE);
        let notice = report.notice();
        if notice.is_empty() {
            let _ = std::fs::remove_file(&lost_note);
        } else {
            crate::session::write_private(&lost_note, notice.as_bytes())?;
        }
        let registration = session.register(
            "space",
            &[
                services::REQUESTS,
                services::OBJECTS,
                services::POSES,
                services::CHANGES,
                services::GEOMETRY,
            ],
        )?;
        let mut keeper = Keeper {
            session: session.clone(),
            opts,
            node,
            model,
            journal,
            epoch,
            server,
            req_listener,
            ack_notifier,
            change_notifier,
            changes_pub,
            objects_pub,
            objects_base_pub,
            objects_base_published: None,
            obj_chunks: Vec::new(),
            obj_gen: Vec::new(),
            obj_dirty: Vec::new(),
            obj_since: Vec::new(),
            obj_patched: Vec::new(),
            obj_whole: Vec::new(),
            poses_pub,
            base_pub,
            base_published: None,
            chunk_pubs: Vec::new(),
            chunk_gen: Vec::new(),
            chunk_dirty: Vec::new(),
            geometry_pub,
            geometry_base_pub,
            geometry_base_published: None,
            library: None,
            order: Vec::new(),
            index: HashMap::new(),
            poses: Vec::new(),
            structure_version: 0,
            last_connect_update: Instant::now(),
            last_served: None,
            large: std::collections::BTreeMap::new(),
            next_token: 1,
            log: Log::default(),
            library_files: PublishedLibrary::default(),
            library_gen: 0,
            held: HashMap::new(),
            to_forward: Vec::new(),
            scratch: std::cell::RefCell::default(),
            _registration: registration,
            _lock: lock,
            _services: vec![
                Box::new(rr),
                Box::new(req_event),
                Box::new(ack_event),
                Box::new(change_event),
                Box::new(changes_svc),
                Box::new(objects_svc),
                Box::new(objects_base_svc),
                Box::new(poses_svc),
                Box::new(base_svc),
                Box::new(geometry_svc),
                Box::new(geometry_base_svc),
            ],
        };
        keeper.publish_all()?;
        Ok((keeper, report))
    }

    pub fn store(&self) -> &Store {
        &self.model
    }
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Applies a transaction from inside the keeper's process (e.g. loading the start-up
    /// scene): the same validation, journal, publication and announcement as a remote one.
    pub fn commit_local(&mut self, tx: &Transaction) -> Result<Applied, TxError> {
        let bytes = tx
            .without_preconditions()
            .unwrap_or_else(|| tx.clone())
            .encode();
        let result = self.model.apply(tx);
        if let Ok(applied) = &result {
            self.journal
                .append(applied.version, &bytes)
                .map_err(|e| TxError::Malformed {
                    message: format!("journal: {e}"),
                })?;
            self.log.push(applied.version, &bytes);
            self.finish_group(std::slice::from_ref(applied))
                .map_err(|e| TxError::Malformed {
                    message: e.to_string(),
                })?;
        }
        result
    }

    /// Publishes the session's Library Space: the library's source files (name, text), already
    /// checked by the caller. Any process can then list and instantiate its declarations
    /// ([`crate::Reader::library_files`]).
    pub fn publish_library(&mut self, files: &[(String, String)]) -> Result<(), KeeperError> {
        self.publish_library_checked(files, None)
    }

    /// [`Keeper::publish_library`] with the checked library's encoding beside the sources
    /// (`robosim_library::Library::encode_checked`, opaque here), so that readers decode it
    /// instead of parsing and checking the sources again ([`crate::Reader::library`]).
    pub fn publish_library_checked(
        &mut self,
        files: &[(String, String)],
        checked: Option<&[u8]>,
    ) -> Result<(), KeeperError> {
        if self.library.is_none() {
            let svc = pubsub_service(
                &self.session,
                &self.node,
                &self.opts,
                services::LIBRARY,
                SubscriberQueue {
                    buffer: 1,
                    history: 1,
                    borrowed: 1,
                },
            )?;
            let p = svc
                .publisher_builder()
                .initial_max_slice_len(1 << 14)
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .max_loaned_samples(1)
                .create()
                .map_err(ipc("create library publisher"))?;
            self.library = Some(p);
            self._services.push(Box::new(svc));
        }
        self.library_files = PublishedLibrary {
            files: files.to_vec(),
            checked: checked.map(<[u8]>::to_vec),
        };
        self.library_gen += 1;
        let words = crate::layout::encode_library(files, checked);
        if let Some(p) = &self.library {
            let mut sample = p.loan_slice(words.len()).map_err(ipc("loan library"))?;
            sample.payload_mut().copy_from_slice(&words);
            sample.send().map_err(ipc("send library"))?;
        }
        Ok(())
    }

    /// Has the process been asked to stop (SIGINT/SIGTERM)? For loops that drive the keeper
    /// with [`Keeper::step`] themselves; then call [`Keeper::checkpoint`].
    pub fn interrupted(&self) -> bool {
        self.node.wait(Duration::ZERO).is_err()
    }

    /// Writes a checkpoint of the model now (what [`Keeper::run`] does when it stops).
    pub fn checkpoint(&mut self) -> Result<(), KeeperError> {
        Ok(self.journal.checkpoint(&self.model)?)
    }

    /// Runs until SIGINT/SIGTERM, then writes a checkpoint and returns.
    pub fn run(&mut self) -> Result<(), KeeperError> {
        while self.node.wait(Duration::ZERO).is_ok() {
            self.step(self.opts.idle_wait)?;
        }
        self.journal.checkpoint(&self.model)?;
        Ok(())
    }

    /// One iteration: wait (at most `wait`) for requests, then serve every pending one as a
    /// group. Within the spin window after the last group ([`KeeperOptions::spin`]) the wait
    /// polls instead of blocking.
    pub fn step(&mut self, wait: Duration) -> Result<GroupStats, KeeperError> {
        let (mut hello, mut base, mut geometry_base, mut objects_base) =
            (false, false, false, false);
        let mut on_event = |e: iceoryx2::prelude::EventId| {
            base |= e == EventId::new(events::BASE);
            geometry_base |= e == EventId::new(events::GEOMETRY_BASE);
            objects_base |= e == EventId::new(events::OBJECTS_BASE);
            hello |= e == EventId::new(events::HELLO) || base || geometry_base || objects_base;
        };
        let mut ready = self.server.has_requests().unwrap_or(false);
        if !ready && let Some(at) = self.last_served {
            let until = at + self.opts.spin;
            while Instant::now() < until {
                std::hint::spin_loop();
                if self.server.has_requests().unwrap_or(false) {
                    ready = true;
                    break;
                }
                std::thread::yield_now();
            }
        }
        if !ready {
            crate::session::timed_wait_events(&self.req_listener, |e| on_event(e.id), wait)
                .map_err(ipc("wait for requests"))?;
        } else {
            let _ = self.req_listener.try_wait(|e| on_event(e.id));
        }
        if hello || self.last_connect_update.elapsed() > Duration::from_millis(50) {
            self.update_connections();
        }
        if base {
            self.publish_base()?;
        }
        if geometry_base {
            self.publish_geometry_base()?;
        }
        if objects_base {
            self.publish_objects_base()?;
        }
        let mut pending = Vec::new();
        let mut applied = Vec::new();
        let mut stats = GroupStats::default();
        while pending.len() < self.opts.max_batch {
            let Some(req) = self.server.receive().map_err(ipc("receive request"))? else {
                break;
            };
            let payload = req.payload();
            if let Some(token) = payload
                .strip_prefix(&MORE_MAGIC[..])
                .and_then(|t| <[u8; 8]>::try_from(t).ok())
            {
                pending.push((req, Reply::More(u64::from_le_bytes(token))));
                continue;
            }
            if payload == &SNAPSHOT_MAGIC[..] {
                self.log.start();
                pending.push((req, Reply::Bytes(self.snapshot_answer())));
                continue;
            }
            if let Some(rest) = payload.strip_prefix(&LOG_MAGIC[..]) {
                self.log.start();
                let answer = self.log_answer(rest);
                pending.push((req, Reply::Bytes(answer)));
                continue;
            }
            let tx = Transaction::decode(payload);
            if self.opts.replica && tx.is_ok() {
                // Not ours to apply: the bridge forwards it to the keeper that owns the model.
                let ticket = self.next_token;
                self.next_token += 1;
                self.to_forward.push((ticket, payload.to_vec()));
                self.held.insert(ticket, req);
                continue;
            }
            match tx.and_then(|tx| self.model.apply(&tx).map(|a| (a, tx))) {
                Ok((a, tx)) => {
                    // Journaled and logged as committed: without its preconditions, decided
                    // here against this model's versions (a replay, or a replica, must not
                    // decide them again against a model rebuilt from a checkpoint).
                    let committed = tx.without_preconditions().map(|c| c.encode());
                    let bytes = committed.as_deref().unwrap_or(payload);
                    self.journal.append(a.version, bytes)?;
                    self.log.push(a.version, bytes);
                    applied.push(a.clone());
                    stats.committed += 1;
                    pending.push((req, Reply::Tx(Ok(a))));
                }
                Err(e) => {
                    stats.refused += 1;
                    pending.push((req, Reply::Tx(Err(e))));
                }
            }
        }
        if pending.is_empty() {
            if !self.to_forward.is_empty() {
                self.last_served = Some(Instant::now());
                return Ok(stats);
            }
            if self
                .last_served
                .is_some_and(|at| at.elapsed() >= self.opts.spin)
            {
                self.last_served = None;
            }
            return Ok(stats);
        }
        self.finish_group(&applied)?;
        for (req, reply) in pending {
            let bytes = match reply {
                Reply::Tx(result) => {
                    let bytes = bincode::serde::encode_to_vec(&result, bincode::config::standard())
                        .unwrap_or_default();
                    self.first_part(bytes)
                }
                Reply::More(token) => self.next_part(token),
                Reply::Bytes(bytes) => self.first_part(bytes),
            };
            match req.loan_slice_uninit(bytes.len()) {
                Ok(r) => {
                    // A client that died mid-request cannot be answered; the commit stands.
                    let _ = r.write_from_slice(&bytes).send();
                }
                Err(_) => continue,
            }
        }
        let _ = self.ack_notifier.notify();
        if !self.opts.spin.is_zero() {
            self.last_served = Some(Instant::now());
        }
        Ok(stats)
    }

    /// The answer to a snapshot request: the whole model and library, encoded.
    fn snapshot_answer(&self) -> Vec<u8> {
        let snap = SpaceSnapshot {
            model: journal::encode_store(&self.model),
            library: self.library_files.clone(),
            library_gen: self.library_gen,
        };
        bincode::serde::encode_to_vec(&snap, bincode::config::standard()).unwrap_or_default()
    }

    /// The answer to a log request (`rest`: the asker's version and library generation).
    fn log_answer(&self, rest: &[u8]) -> Vec<u8> {
        let word = |at: usize| {
            rest.get(at..at + 8)
                .and_then(|b| <[u8; 8]>::try_from(b).ok())
                .map(u64::from_le_bytes)
        };
        let version = self.model.version;
        let answer = match (word(0), word(8)) {
            (Some(since), Some(lib_gen)) => match self.log.after(since, version) {
                Ok(entries) => LogAnswer::Entries {
                    version,
                    entries,
                    library: (lib_gen != self.library_gen)
                        .then(|| (self.library_gen, self.library_files.clone())),
                },
                Err(gone) => gone,
            },
            // A request cut short cannot be answered with entries; a snapshot mends it.
            _ => LogAnswer::Gone { oldest: 0, version },
        };
        bincode::serde::encode_to_vec(&answer, bincode::config::standard()).unwrap_or_default()
    }

    /// Replica: the writers' transactions received since the last call, (ticket, encoded
    /// transaction) in arrival order. Each must be answered with [`Keeper::answer_forwarded`].
    pub fn take_forwarded(&mut self) -> Vec<(u64, Vec<u8>)> {
        std::mem::take(&mut self.to_forward)
    }

    /// How many forwarded transactions wait for their answer.
    pub fn forwarded_in_flight(&self) -> usize {
        self.held.len()
    }

    /// Replica: answers the writer of forwarded transaction `ticket` with the other keeper's
    /// verdict. Call it for a commit only once [`Keeper::apply_upstream`] has brought this
    /// model to the commit's version, so the writer reads its own write. A writer that left
    /// meanwhile is skipped.
    pub fn answer_forwarded(&mut self, ticket: u64, verdict: &Result<Applied, TxError>) {
        let Some(req) = self.held.remove(&ticket) else {
            return;
        };
        let bytes =
            bincode::serde::encode_to_vec(verdict, bincode::config::standard()).unwrap_or_default();
        let bytes = self.first_part(bytes);
        if let Ok(r) = req.loan_slice_uninit(bytes.len()) {
            let _ = r.write_from_slice(&bytes).send();
        }
        let _ = self.ack_notifier.notify();
    }

    /// Replica: applies transactions the other keeper committed, `(version, encoded)`, in
    /// order, then journals, publishes and announces them as one group. Entries at or below
    /// this model's version are skipped (already applied); one that does not follow it, does
    /// not decode or is refused here means the two models differ, and is an error (take a new
    /// snapshot): the entries before it stay applied.
    pub fn apply_upstream(&mut self, entries: &[(u64, Vec<u8>)]) -> Result<usize, KeeperError> {
        let mut applied = Vec::new();
        let mut failure = None;
        for (version, bytes) in entries {
            if *version <= self.model.version {
                continue;
            }
            if *version != self.model.version + 1 {
                failure = Some(OutOfStep::Gap {
                    version: *version,
                    model: self.model.version,
                });
                break;
            }
            match Transaction::decode(bytes).and_then(|tx| self.model.apply(&tx)) {
                Ok(a) => {
                    self.journal.append(a.version, bytes)?;
                    self.log.push(a.version, bytes);
                    applied.push(a);
                }
                Err(e) => {
                    failure = Some(OutOfStep::Refused {
                        version: *version,
                        source: e,
                    });
                    break;
                }
            }
        }
        self.finish_group(&applied)?;
        match failure {
            Some(why) => Err(why.into()),
            None => Ok(applied.len()),
        }
    }

    /// Replaces the whole model (a replica's new snapshot): the data directory is reset to
    /// it, every segment republished under a new epoch (readers start over, as after a keeper
    /// restart) and the change announced.
    pub fn replace_model(&mut self, model: Store) -> Result<(), KeeperError> {
        self.journal = journal::reset(&self.session.data_dir(), &model, self.opts.journal_copies)?;
        self.model = model;
        self.log.clear();
        self.epoch = wall_clock_epoch().max(self.epoch + 1);
        self.chunk_gen.clear();
        self.chunk_dirty.clear();
        self.obj_chunks.clear();
        self.obj_gen.clear();
        self.obj_dirty.clear();
        self.obj_since.clear();
        self.obj_patched.clear();
        self.obj_whole.clear();
        self.publish_all()?;
        let _ = self.change_notifier.notify();
        Ok(())
    }

    /// Publishes the objects head (every object chunk) and the poses head (a keeper starting,
    /// or a replica's model replaced). Geometry waits for a reader to ask for the base (its
    /// epoch is new, so every reader does).
    ///
    /// The pose chunks are not published on their own services here: in a new epoch every
    /// reader takes its chunks from a pose base (asked for, `Reader::collect_pose_chunks`), so
    /// the head names them at this version and a chunk's service is made when the chunk first
    /// changes. Making every chunk's service at start (391 iceoryx2 services at 10⁵ objects,
    /// milliseconds each) held a restarting keeper, or a replica joining, for seconds.
    fn publish_all(&mut self) -> Result<(), KeeperError> {
        self.rebuild_structure(None)?;
        let version = self.model.version;
        for (g, d) in self.chunk_gen.iter_mut().zip(&mut self.chunk_dirty) {
            if *d {
                *g = version;
                *d = false;
            }
        }
        self.publish_poses()
    }

    /// The response carrying `answer`: whole when it fits [`RESPONSE_CAP`], else its first
    /// part (the rest is kept for the client's continuation requests).
    fn first_part(&mut self, answer: Vec<u8>) -> Vec<u8> {
        if answer.len() < RESPONSE_CAP {
            let mut out = Vec::with_capacity(answer.len() + 1);
            out.push(answer::WHOLE);
            out.extend_from_slice(&answer);
            return out;
        }
        let token = self.next_token;
        self.next_token += 1;
        while self.large.len() >= MAX_LARGE_ANSWERS {
            self.large.pop_first();
        }
        self.large.insert(token, (answer, 0));
        self.next_part(token)
    }

    /// The next part of large answer `token` (forgotten once its last part is sent).
    fn next_part(&mut self, token: u64) -> Vec<u8> {
        let Some((answer, offset)) = self.large.get_mut(&token) else {
            return vec![answer::EXPIRED];
        };
        let end = (*offset + RESPONSE_CAP - answer::PART_HEADER).min(answer.len());
        let mut out = Vec::with_capacity(answer::PART_HEADER + end - *offset);
        out.push(answer::PART);
        out.extend_from_slice(&token.to_le_bytes());
        out.extend_from_slice(&(answer.len() as u64).to_le_bytes());
        out.extend_from_slice(&(*offset as u64).to_le_bytes());
        out.extend_from_slice(&answer[*offset..end]);
        *offset = end;
        if end == answer.len() {
            self.large.remove(&token);
        }
        out
    }

    /// Durability, then publication and announcement of a group of committed transactions.
    fn finish_group(&mut self, applied: &[Applied]) -> Result<(), KeeperError> {
        if applied.is_empty() {
            return Ok(());
        }
        if self.opts.durable {
            self.journal.sync()?;
        }
        let mut structure = false;
        // Objects whose record changed (or that came or went).
        let mut restructured: Vec<Id> = Vec::new();
        let mut geometry_changed: Vec<Id> = Vec::new();
        let mut posed: Vec<Id> = Vec::new();
        for a in applied {
            for &(id, asp) in &a.changes {
                let record = aspect::STRUCTURE
                    | aspect::APPEARANCE
                    | aspect::KINEMATICS
                    | aspect::DYNAMICS
                    | aspect::GEOMETRY;
                if asp & (record | aspect::SELECTION) != 0 {
                    structure = true;
                }
                if asp & record != 0 {
                    restructured.push(id);
                }
                if asp & aspect::GEOMETRY != 0 {
                    geometry_changed.push(id);
                }
                if asp & aspect::POSE != 0 {
                    posed.push(id);
                }
            }
        }
        geometry_changed.sort_unstable();
        geometry_changed.dedup();
        if !geometry_changed.is_empty() {
            self.publish_geometry_update(&geometry_changed)?;
        }
        if structure {
            restructured.sort_unstable();
            restructured.dedup();
            self.rebuild_structure(Some(&restructured))?;
        }
        // Moved objects, and those a structural change may have moved (a reparent): their pose
        // records are compared, and their chunks marked when they differ.
        for id in posed.into_iter().chain(restructured) {
            if let (Some(&i), Some(o)) = (self.index.get(&id), self.model.get(id)) {
                let rec = crate::encode::pose_rec(o);
                if self.poses[i] != rec {
                    self.poses[i] = rec;
                    if let Some(d) = self.chunk_dirty.get_mut(i / POSE_CHUNK) {
                        *d = true;
                    }
                }
            }
        }
        self.publish_poses()?;
        self.publish_changes(applied)?;
        let _ = self.change_notifier.notify();
        if self.journal.since_checkpoint >= self.opts.checkpoint_every {
            self.journal.checkpoint(&self.model)?;
        }
        Ok(())
    }

    fn update_connections(&mut self) {
        // In the order of publication, the bases first and the poses head last: a reader that
        // receives a head from a service's history finds in the others' histories what was
        // published before it (a base included).
        let _ = self.objects_base_pub.update_connections();
        let _ = self.base_pub.update_connections();
        let _ = self.geometry_base_pub.update_connections();
        let _ = self.geometry_pub.update_connections();
        let _ = self.objects_pub.update_connections();
        for (p, _) in self.chunk_pubs.iter().flatten() {
            let _ = p.update_connections();
        }
        let _ = self.changes_pub.update_connections();
        let _ = self.poses_pub.update_connections();
        if let Some(p) = &self.library {
            let _ = p.update_connections();
        }
        self.last_connect_update = Instant::now();
    }

    /// Publishes the segment `w` on `publisher`. A segment up to [`SCRATCH_WORDS`] is written
    /// once into the keeper's scratch words and copied into an uninitialised sample: `loan_slice`
    /// first wrote the whole sample with zeros, element by element — a third of the keeper's
    /// time in a one-body geometry change at 10⁵ objects (issue 37 item 6). Larger ones (the
    /// bases, published on request) are written into a zeroed sample as before.
    fn send(&self, publisher: &Pub, w: &SegmentWriter<'_>, what: &str) -> Result<(), KeeperError> {
        let words = w.words();
        if words <= SCRATCH_WORDS {
            let mut scratch = self.scratch.borrow_mut();
            if scratch.len() < words {
                scratch.resize(words, 0);
            }
            let out = &mut scratch[..words];
            w.write(out);
            let sample = publisher
                .loan_slice_uninit(words)
                .map_err(ipc(format!("loan {what}")))?;
            sample
                .write_from_slice(out)
                .send()
                .map_err(ipc(format!("send {what}")))?;
            return Ok(());
        }
        let mut sample = publisher
            .loan_slice(words)
            .map_err(ipc(format!("loan {what}")))?;
        w.write(sample.payload_mut());
        sample.send().map_err(ipc(format!("send {what}")))?;
        Ok(())
    }

    /// The object chunks and the pose caches after a structural change of the objects
    /// `changed` (ascending; `None`: everything, as when a keeper starts), then the objects
    /// head carrying the chunks that changed. When no object came or went, only the chunks of
    /// `changed` are encoded again, and when objects were only added after the last one (ids
    /// grow, so a create appends) those and the chunks from the first new one:
    /// O(changed chunks + objects / [`OBJECT_CHUNK`]). Otherwise (a delete, an object made with
    /// a smaller id) the order, the pose records and every chunk are rebuilt — O(objects) here —
    /// but only the chunks that differ are published (as a delete republishes the pose chunks
    /// after it). The pose records of `changed` are refreshed by the caller.
    fn rebuild_structure(&mut self, changed: Option<&[Id]>) -> Result<(), KeeperError> {
        let n = self.model.len();
        let version = self.model.version;
        if let Some(new) = changed.and_then(|ids| self.appended(ids, n)) {
            // In place: the objects kept are where they were; `new` (maybe none) goes after them.
            let start = self.order.len();
            for id in new {
                if let Some(o) = self.model.get(id) {
                    self.index.insert(id, self.order.len());
                    self.order.push(id);
                    self.poses.push(crate::encode::pose_rec(o));
                }
            }
            let chunks = n.div_ceil(POSE_CHUNK);
            self.chunk_gen.resize(chunks, 0);
            self.chunk_dirty.resize(chunks, false);
            // The pose chunks of the objects appended, if any (a change to existing objects
            // alone marked the last chunk too, republishing it for nothing).
            if start < self.order.len() {
                for d in &mut self.chunk_dirty[start / POSE_CHUNK..] {
                    *d = true;
                }
            }
            // A changed object's record is patched where it is in its chunk when nothing else
            // of the chunk changes (its names, its geometry index): O(1) per object. Encoding
            // the whole chunk again — 256 records, each looked up in the model — was most of a
            // one-body geometry change at 10⁵ objects (issue 37 item 6).
            let mut ks: Vec<usize> = Vec::new();
            for id in changed.unwrap_or(&[]) {
                let Some(&i) = self.index.get(id) else {
                    continue;
                };
                if i < start && !self.patch_object(i, version) {
                    ks.push(i / OBJECT_CHUNK);
                }
            }
            ks.dedup();
            for k in ks {
                self.encode_object_chunk(k, version);
            }
            if start < n {
                // The objects appended: the chunk they start in keeps its records and gains
                // theirs (copied, not encoded again); the chunks after it are new.
                let first = start / OBJECT_CHUNK;
                if !self.extend_object_chunk(first, start, version) {
                    self.encode_object_chunk(first, version);
                }
                for k in first + 1..n.div_ceil(OBJECT_CHUNK) {
                    self.encode_object_chunk(k, version);
                }
            }
        } else {
            let old_poses = std::mem::take(&mut self.poses);
            self.order.clear();
            self.index.clear();
            self.poses.reserve(n);
            for (i, o) in self.model.objects().enumerate() {
                self.order.push(o.id);
                self.index.insert(o.id, i);
                self.poses.push(crate::encode::pose_rec(o));
            }
            let chunks = n.div_ceil(POSE_CHUNK);
            let first_time = self.chunk_gen.is_empty();
            self.chunk_gen.resize(chunks, 0);
            self.chunk_dirty.resize(chunks, false);
            for k in 0..chunks {
                // A chunk is the same only if its records *and its length* are: the newest
                // object deleted leaves the last chunk's first records as they were, and a
                // chunk kept under its old generation then had one record more than the head
                // said (readers exited: "section 1 is out of bounds", issue 34 item 4).
                let range = k * POSE_CHUNK..((k + 1) * POSE_CHUNK).min(n);
                let was = k * POSE_CHUNK..((k + 1) * POSE_CHUNK).min(old_poses.len());
                if first_time || old_poses.get(was) != Some(&self.poses[range]) {
                    self.chunk_dirty[k] = true;
                }
            }
            // Chunks past the end go with their publishers (readers stop asking for them).
            self.chunk_pubs.truncate(chunks);
            let chunks = n.div_ceil(OBJECT_CHUNK);
            self.obj_chunks.truncate(chunks);
            self.obj_gen.truncate(chunks);
            self.obj_dirty.truncate(chunks);
            self.obj_since.truncate(chunks);
            self.obj_patched.truncate(chunks);
            self.obj_whole.truncate(chunks);
            for k in 0..chunks {
                self.encode_object_chunk(k, version);
            }
        }
        self.structure_version = version;
        self.publish_objects_head()
    }

    /// The objects `changed` (ascending) brought that the caches lack, when the caches can
    /// follow in place: every changed object is in the model, none left it, and those new to
    /// the caches (none, for a change to existing objects) all come after the last one (ids
    /// grow, so a create appends). `None`: rebuild.
    fn appended(&self, changed: &[Id], n: usize) -> Option<Vec<Id>> {
        let last = self.order.last().copied().unwrap_or(0);
        let new: Vec<Id> = changed
            .iter()
            .copied()
            .filter(|id| !self.index.contains_key(id))
            .collect();
        (self.obj_chunks.len() == self.order.len().div_ceil(OBJECT_CHUNK)
            && n == self.order.len() + new.len()
            && new.iter().all(|&id| id > last)
            && changed.iter().all(|&id| self.model.get(id).is_some()))
        .then_some(new)
    }

    /// Patches the record of object `i` (in the caches) where it is in its object chunk
    /// ([`crate::encode::patch_object_rec`]); a chunk whose record changed takes generation
    /// `version`, notes the record among those patched since it was last carried whole, and
    /// is marked for the next objects head. `false` when the chunk must be encoded again
    /// instead.
    fn patch_object(&mut self, i: usize, version: u64) -> bool {
        let k = i / OBJECT_CHUNK;
        let (Some(o), Some(words)) = (
            self.order.get(i).and_then(|&id| self.model.get(id)),
            self.obj_chunks.get_mut(k),
        ) else {
            return false;
        };
        let mut names = Vec::new();
        match crate::encode::patch_object_rec(words, i % OBJECT_CHUNK, o, &mut names) {
            None => false,
            Some(false) => true,
            Some(true) => {
                crate::encode::set_chunk_generation(words, version);
                self.obj_gen[k] = version;
                self.obj_dirty[k] = true;
                let j = (i % OBJECT_CHUNK) as u32;
                if let Some(patched) = self.obj_patched.get_mut(k)
                    && let Err(at) = patched.binary_search(&j)
                {
                    patched.insert(at, j);
                }
                true
            }
        }
    }

    /// Object chunk `k`, which held the objects before `start` (all of them in the caches
    /// now), extended by the objects from `start` on that fall in it
    /// ([`crate::encode::extend_object_chunk`]), at generation `version` and marked for the
    /// next objects head. `false` (nothing done) when the chunk is not such a one: encode it.
    fn extend_object_chunk(&mut self, k: usize, start: usize, version: u64) -> bool {
        let end = ((k + 1) * OBJECT_CHUNK).min(self.order.len());
        let Some(old) = self.obj_chunks.get(k) else {
            return false;
        };
        let held = crate::layout::Segment::parse(old)
            .and_then(|s| s.record::<crate::layout::ObjectChunkHeader>(0).copied())
            .ok();
        if held.is_none_or(|h| h.first as usize + h.count as usize != start || start >= end) {
            return false;
        }
        let model = &self.model;
        let added = self.order[start..end]
            .iter()
            .filter_map(|&id| model.get(id));
        let Some(words) = crate::encode::extend_object_chunk(old, added, version) else {
            return false;
        };
        self.obj_chunks[k] = words;
        self.obj_gen[k] = version;
        self.obj_dirty[k] = true;
        self.obj_whole[k] = true;
        true
    }

    /// Encodes object chunk `k` from the model; if it differs from the one last published (or
    /// is new) it takes generation `version` and is marked for the next objects head.
    fn encode_object_chunk(&mut self, k: usize, version: u64) {
        let range = k * OBJECT_CHUNK..((k + 1) * OBJECT_CHUNK).min(self.order.len());
        let objects = self.order[range.clone()]
            .iter()
            .filter_map(|&id| self.model.get(id));
        match self.obj_chunks.get_mut(k) {
            Some(old) => {
                let mut words = crate::encode::object_chunk(objects, range.start, self.obj_gen[k]);
                if words != *old {
                    crate::encode::set_chunk_generation(&mut words, version);
                    *old = words;
                    self.obj_gen[k] = version;
                    self.obj_dirty[k] = true;
                    self.obj_whole[k] = true;
                }
            }
            None => {
                // Chunks are encoded in order: this one is the next.
                self.obj_chunks
                    .push(crate::encode::object_chunk(objects, range.start, version));
                self.obj_gen.push(version);
                self.obj_dirty.push(true);
                self.obj_since.push(version);
                self.obj_patched.push(Vec::new());
                self.obj_whole.push(true);
            }
        }
    }

    fn objects_header(&self) -> [ObjectsHeader; 1] {
        [ObjectsHeader::new(
            self.structure_version,
            self.epoch,
            self.order.len(),
            self.model.selection(),
        )]
    }

    /// Publishes the objects head: the header, every chunk's generation, and the chunks marked
    /// since the last head — a chunk whose records alone changed since it was last carried
    /// whole as those records (up to [`OBJECT_PATCH_MAX`] of them: O(changed records), not
    /// O([`OBJECT_CHUNK`])), any other whole — none when they pass
    /// [`GEOMETRY_UPDATE_MAX_WORDS`] (readers then take the objects base, which serves every
    /// chunk whole at its generation: the lineages of the chunks marked start there).
    fn publish_objects_head(&mut self) -> Result<(), KeeperError> {
        let mut whole: Vec<usize> = Vec::new();
        let mut patches: Vec<PatchEntry> = Vec::new();
        let mut patched: Vec<PatchRec> = Vec::new();
        let mut words = 0;
        let marked: Vec<usize> = (0..self.obj_dirty.len())
            .filter(|&k| self.obj_dirty[k])
            .collect();
        for &k in &marked {
            let list = &self.obj_patched[k];
            let entry = (!self.obj_whole[k] && list.len() <= OBJECT_PATCH_MAX)
                .then(|| {
                    crate::encode::chunk_patches(
                        &self.obj_chunks[k],
                        k,
                        self.obj_gen[k],
                        self.obj_since[k],
                        list,
                        &mut patched,
                    )
                })
                .flatten();
            match entry {
                Some(e) => {
                    words += e.len as usize * std::mem::size_of::<PatchRec>() / 8;
                    patches.push(e);
                }
                None => {
                    words += self.obj_chunks[k].len();
                    whole.push(k);
                }
            }
        }
        let fits = words <= GEOMETRY_UPDATE_MAX_WORDS;
        if !fits {
            patches.clear();
            patched.clear();
        }
        let carried: Vec<(usize, &[u64])> = whole
            .iter()
            .filter(|_| fits)
            .map(|&k| (k, self.obj_chunks[k].as_slice()))
            .collect();
        self.send_objects(&self.objects_pub, &carried, &patches, &patched, "objects")?;
        // Carried whole (or by nothing: the objects base then serves them whole at their
        // generations): new lineages.
        let restart: &[usize] = if fits { &whole } else { &marked };
        for &k in restart {
            self.obj_since[k] = self.obj_gen[k];
            self.obj_patched[k].clear();
            self.obj_whole[k] = false;
        }
        self.obj_dirty.iter_mut().for_each(|d| *d = false);
        Ok(())
    }

    /// Sends an objects publication carrying the chunks `carried` whole and the record
    /// patches `patches` (records `patched`) on `publisher`.
    fn send_objects(
        &self,
        publisher: &Pub,
        carried: &[(usize, &[u64])],
        patches: &[PatchEntry],
        patched: &[PatchRec],
        what: &str,
    ) -> Result<(), KeeperError> {
        let header = self.objects_header();
        let entries = crate::encode::chunk_entries(&self.obj_gen, carried);
        let w = crate::encode::objects_writer(
            &header,
            &self.obj_gen,
            &entries,
            carried,
            patches,
            patched,
        );
        self.send(publisher, &w, what)
    }

    /// Publishes the objects base — every object chunk at the current structure version —
    /// unless the last one published is of this structure version. O(objects), once per
    /// request, never per commit.
    fn publish_objects_base(&mut self) -> Result<(), KeeperError> {
        let now = (self.epoch, self.structure_version);
        if self.objects_base_published == Some(now) {
            return Ok(());
        }
        let carried: Vec<(usize, &[u64])> = self
            .obj_chunks
            .iter()
            .enumerate()
            .map(|(k, c)| (k, c.as_slice()))
            .collect();
        self.send_objects(&self.objects_base_pub, &carried, &[], &[], "objects base")?;
        self.objects_base_published = Some(now);
        Ok(())
    }

    /// Publishes the changed pose chunks, then the head that names their generations: a
    /// reader that has the head finds every chunk it names already published.
    fn publish_poses(&mut self) -> Result<(), KeeperError> {
        let version = self.model.version;
        for k in 0..self.chunk_dirty.len() {
            if !self.chunk_dirty[k] {
                continue;
            }
            if self.chunk_pubs.len() <= k {
                self.chunk_pubs.resize_with(k + 1, || None);
            }
            if self.chunk_pubs[k].is_none() {
                self.chunk_pubs[k] = Some(self.chunk_publisher(k)?);
            }
            let Some((publisher, _)) = &self.chunk_pubs[k] else {
                continue;
            };
            let first = k * POSE_CHUNK;
            let recs = &self.poses[first..(first + POSE_CHUNK).min(self.poses.len())];
            let header = [crate::encode::pose_chunk_header(
                self.epoch,
                version,
                first,
                recs.len(),
            )];
            self.send(
                publisher,
                &crate::encode::pose_chunk_writer(&header, recs),
                "pose chunk",
            )?;
            self.chunk_gen[k] = version;
            self.chunk_dirty[k] = false;
        }
        let header = [self.poses_header()];
        let mut w = SegmentWriter::new();
        w.push(&header).push(&self.chunk_gen);
        self.send(&self.poses_pub, &w, "poses")
    }

    /// Publishes the pose base — the current head and every pose record in one sample — unless
    /// the last one published is of this version (a new subscriber then has it from the
    /// service's history). O(objects), once per request, never per commit.
    fn publish_base(&mut self) -> Result<(), KeeperError> {
        let now = (self.epoch, self.model.version);
        if self.base_published == Some(now) {
            return Ok(());
        }
        let header = [self.poses_header()];
        let mut w = SegmentWriter::new();
        w.push(&header).push(&self.chunk_gen).push(&self.poses);
        self.send(&self.base_pub, &w, "pose base")?;
        self.base_published = Some(now);
        Ok(())
    }

    fn poses_header(&self) -> PosesHeader {
        PosesHeader {
            version: self.model.version,
            structure_version: self.structure_version,
            epoch: self.epoch,
            count: self.poses.len() as u64,
            chunk_len: POSE_CHUNK as u64,
        }
    }

    /// Opens or creates the service of pose chunk `k` and its publisher.
    fn chunk_publisher(&mut self, k: usize) -> Result<(Pub, PubSubService), KeeperError> {
        let svc = pubsub_service(
            &self.session,
            &self.node,
            &self.opts,
            &services::pose_chunk(k),
            SubscriberQueue {
                buffer: 2,
                history: 1,
                borrowed: MAX_HELD_SNAPSHOTS + 1,
            },
        )?;
        let header = [crate::encode::pose_chunk_header(0, 0, 0, POSE_CHUNK)];
        let full = [PoseRec {
            id: 0,
            pose: [0.0; 12],
            joint: 0.0,
        }; POSE_CHUNK];
        let words = crate::encode::pose_chunk_writer(&header, &full).words();
        let p = svc
            .publisher_builder()
            .initial_max_slice_len(words)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .max_loaned_samples(1)
            .create()
            .map_err(ipc(format!("create publisher of pose chunk {k}")))?;
        Ok((p, svc))
    }

    fn publish_changes(&mut self, applied: &[Applied]) -> Result<(), KeeperError> {
        let now = crate::monotonic_ns();
        let mut recs = Vec::with_capacity(applied.len());
        let mut ids = Vec::new();
        for a in applied {
            recs.push(ChangeRec {
                version: a.version,
                aspects: a.aspects(),
                ids_start: ids.len() as u64,
                ids_len: a.changes.len() as u64,
                published_ns: now,
            });
            ids.extend(a.changes.iter().map(|c| c.0));
        }
        let mut w = SegmentWriter::new();
        w.push(&recs).push(&ids);
        self.send(&self.changes_pub, &w, "changes")
    }

    /// Publishes the geometry of `ids` (ascending; those deleted or without geometry are
    /// skipped) as one update, unless it is larger than [`GEOMETRY_UPDATE_MAX_WORDS`]: readers
    /// then find it in no update and ask for the base. Before the objects head, so a reader
    /// that sees the new structure finds the update already published.
    fn publish_geometry_update(&mut self, ids: &[Id]) -> Result<(), KeeperError> {
        // The geometry alone is held to the limit; the bundle's index adds 32 B per object.
        let Some(bundle) = crate::encode::GeometryBundle::new(
            self.epoch,
            self.model.version,
            ids.iter().filter_map(|&id| self.model.get(id)),
            GEOMETRY_UPDATE_MAX_WORDS,
        ) else {
            return Ok(());
        };
        if bundle.is_empty() {
            return Ok(());
        }
        self.send(&self.geometry_pub, &bundle.writer(), "geometry update")
    }

    /// Publishes the geometry base — every object's geometry at the current structure version —
    /// unless the last one published is of this structure version (a new subscriber then has it
    /// from the service's history). O(geometry), once per request, never per commit.
    fn publish_geometry_base(&mut self) -> Result<(), KeeperError> {
        let now = (self.epoch, self.structure_version);
        if self.geometry_base_published == Some(now) {
            return Ok(());
        }
        let Some(bundle) = crate::encode::GeometryBundle::new(
            self.epoch,
            self.structure_version,
            self.model.objects(),
            usize::MAX,
        ) else {
            return Ok(());
        };
        self.send(&self.geometry_base_pub, &bundle.writer(), "geometry base")?;
        self.geometry_base_published = Some(now);
        Ok(())
    }
}
