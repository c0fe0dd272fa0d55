//! Writers: send transactions to the session's keeper over iceoryx2 request-response.
//!
//! [`Client::transact`] sends one and waits for its acknowledgement (durable, published).
//! [`Client::submit`] + [`Client::wait`] pipeline many (up to the keeper's in-flight limit), which
//! is how a writer gets group commit: the keeper syncs the journal once for everything that
//! arrived together.

use crate::keeper::{MAX_IN_FLIGHT, MORE_MAGIC, RESPONSE_CAP, answer, events};
use crate::replica::{LOG_MAGIC, LogAnswer, SNAPSHOT_MAGIC, SpaceSnapshot};
use crate::services;
use crate::session::{Session, SessionError};
use crate::store::Applied;
use crate::transaction::Transaction;
use crate::transaction::TxError;
use iceoryx2::identifiers::UniqueNodeId;
use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use std::time::{Duration, Instant};

type IoxClient = iceoryx2::port::client::Client<ipc::Service, [u8], (), [u8], ()>;
type IoxPending = iceoryx2::pending_response::PendingResponse<ipc::Service, [u8], (), [u8], ()>;

/// A committed transaction: its version, created ids and change set.
pub type Committed = Applied;

#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error(transparent)]
    Session(#[from] SessionError),
    /// A keeper's service could not be opened: none runs, or (`cause`) iceoryx2 refused it.
    #[error(
        "no keeper is running in session {session} (start one with `robosim space` or `robosim up`; opening its {service} service: {cause})"
    )]
    NoKeeper {
        session: String,
        service: String,
        #[source]
        cause: crate::error::Cause,
    },
    #[error("transaction refused: {0}")]
    Refused(#[from] TxError),
    /// [`Client::transact_fresh`] rebuilt its transaction from a fresh read `attempts` times and
    /// every time another writer changed what it read before the keeper applied it
    /// ([`TxError::Conflict`]); nothing of it was committed.
    #[error(
        "conflict: the edit lost to concurrent writes {attempts} times in a row and was not committed; the last: {last}"
    )]
    Conflict { attempts: u32, last: TxError },
    #[error(
        "the keeper went away before answering (it may have committed the transaction; check the version after it restarts)"
    )]
    KeeperGone,
    #[error("no answer from the keeper within {0:?}")]
    Timeout(Duration),
    #[error("more than {MAX_IN_FLIGHT} transactions in flight; wait for some first")]
    TooManyInFlight,
    /// The session's keeper serves at most `limit` writers at once and that many are
    /// connected (each `robosim query`, editor, simulator, rules process is one).
    #[error(
        "session {session} already has its limit of {limit} writers connected; stop one, or start the session's keeper with more ({MAX_CLIENTS_ENV}=N robosim up …)"
    )]
    TooManyClients { session: String, limit: usize },
    /// A transaction larger than one request may be.
    #[error(
        "the transaction is {bytes} bytes encoded; a request may be at most {limit} bytes (split it into several transactions)"
    )]
    TooLarge { bytes: usize, limit: usize },
    /// The shared memory for requests could not grow to hold this one.
    #[error(
        "the transaction is {bytes} bytes encoded and the shared memory could not grow to hold it (is /dev/shm full?)"
    )]
    OutOfSharedMemory { bytes: usize },
    /// iceoryx2 refused `what`; its error is the source (matched by variant where it matters).
    #[error("iceoryx2 {what}: {source}")]
    Ipc {
        what: String,
        #[source]
        source: crate::error::Cause,
    },
}

fn ipc<E: std::error::Error + Send + Sync + 'static>(
    what: &'static str,
) -> impl FnOnce(E) -> ClientError {
    move |e| ClientError::Ipc {
        what: what.to_owned(),
        source: Box::new(e),
    }
}

/// How many times [`Client::transact_fresh`] builds and sends a read-modify-write before it
/// gives up on conflicts. Each conflict means another writer committed in between, so N
/// writers racing on one object need at most N attempts each.
pub const MAX_FRESH_ATTEMPTS: u32 = 64;

/// The environment variable that sets how many writers and readers a session's keeper serves
/// at once ([`crate::KeeperOptions::max_clients`] and `max_readers`; default 16 each).
pub const MAX_CLIENTS_ENV: &str = "ROBOSIM_MAX_CLIENTS";

/// The writer and reader limit [`MAX_CLIENTS_ENV`] names (`None` when unset); an unreadable
/// value is an error naming the variable.
pub fn max_clients_from_env() -> Result<Option<usize>, String> {
    match std::env::var(MAX_CLIENTS_ENV) {
        Err(_) => Ok(None),
        Ok(v) => v
            .trim()
            .parse::<usize>()
            .ok()
            .filter(|n| (1..=MAX_CLIENTS_CEILING).contains(n))
            .map(Some)
            .ok_or_else(|| {
                format!(
                    "{MAX_CLIENTS_ENV}={v:?}: expected a whole number of processes, 1 to {MAX_CLIENTS_CEILING}"
                )
            }),
    }
}

/// The most writers (and readers) [`MAX_CLIENTS_ENV`] may ask for: each costs the keeper a
/// response pool share and every service a port slot.
pub const MAX_CLIENTS_CEILING: usize = 256;

/// The largest encoded transaction a client sends (a request of more is refused before any
/// shared memory is asked for: [`ClientError::TooLarge`]). 512 MiB: four times a 10⁵-object
/// model with geometry in one transaction.
pub const MAX_REQUEST_BYTES: usize = 1 << 29;

/// How often a waiting writer asks whether the keeper is still alive.
pub const LIVENESS_PERIOD: Duration = Duration::from_millis(50);

/// How long [`Client::connect`] waits for a keeper whose services exist to register (one
/// starting up).
const CONNECT_WAIT: Duration = Duration::from_secs(10);

/// The alive node named `space` (the keeper's role) in this session's iceoryx2 world.
fn keeper_node(config: &iceoryx2::config::Config) -> Option<UniqueNodeId> {
    let mut found = None;
    let _ = Node::<ipc::Service>::list(config, |state| {
        if let NodeState::Alive(view) = &state
            && view
                .details()
                .as_ref()
                .is_some_and(|d| d.name().as_str() == "space")
        {
            found = Some(*view.id());
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    });
    found
}

/// A transaction sent and not yet answered.
pub struct Pending {
    inner: IoxPending,
}

pub struct Client {
    session: Session,
    config: iceoryx2::config::Config,
    /// The keeper's iceoryx2 node when we connected: its liveness is how a dead keeper is
    /// told from a slow one (iceoryx2 keeps a killed server's ports "connected").
    keeper: Option<UniqueNodeId>,
    /// Set once the keeper is known dead: every later request fails at once.
    keeper_gone: bool,
    _node: Node<ipc::Service>,
    client: IoxClient,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    acks: iceoryx2::port::listener::Listener<ipc::Service>,
    timeout: Duration,
    /// How long [`Client::wait`] polls for the answer before blocking on the event.
    spin: Duration,
    _services: Vec<Box<dyn std::any::Any>>,
}

impl Client {
    /// The most transactions one client may have in flight (submitted, not yet answered).
    pub const MAX_IN_FLIGHT: usize = MAX_IN_FLIGHT;

    /// Connects to the keeper of `session` as a process of role `role` (used in its node name).
    pub fn connect(session: &Session, role: &str) -> Result<Self, ClientError> {
        let node = session.node(role, false)?;
        let no_keeper = |service: &str, e: crate::error::Cause| ClientError::NoKeeper {
            session: session.name().to_owned(),
            service: service.to_owned(),
            cause: e,
        };
        let rr = node
            .service_builder(&session.service(services::REQUESTS)?)
            .request_response::<[u8], [u8]>()
            .open()
            .map_err(|e| no_keeper(services::REQUESTS, Box::new(e)))?;
        let client = rr
            .client_builder()
            .initial_max_slice_len(4096)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| match e {
                iceoryx2::service::port_factory::client::ClientCreateError::ExceedsMaxSupportedClients => {
                    ClientError::TooManyClients {
                        session: session.name().to_owned(),
                        limit: rr.static_config().max_clients(),
                    }
                }
                e => ipc("create client")(e),
            })?;
        let req_event = node
            .service_builder(&session.service(services::REQUEST_EVENT)?)
            .event()
            .open()
            .map_err(|e| no_keeper(services::REQUEST_EVENT, Box::new(e)))?;
        let notifier = req_event
            .notifier_builder()
            .create()
            .map_err(ipc("create request notifier"))?;
        let ack_event = node
            .service_builder(&session.service(services::ACK_EVENT)?)
            .event()
            .open()
            .map_err(|e| no_keeper(services::ACK_EVENT, Box::new(e)))?;
        let acks = ack_event
            .listener_builder()
            .create()
            .map_err(ipc("create ack listener"))?;
        // A keeper makes its request service before its server port (whose fixed response
        // pool takes a while) and registers in the session after both: until then a request
        // would find no server and no keeper, and be taken for one sent to a dead keeper.
        let registered = || session.processes().iter().any(|p| p.role == "space");
        let start = Instant::now();
        while !registered() {
            if start.elapsed() > CONNECT_WAIT {
                return Err(no_keeper(
                    services::REQUESTS,
                    format!("its keeper did not register within {CONNECT_WAIT:?}").into(),
                ));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let config = session.iox_config()?;
        let keeper = keeper_node(&config);
        // A message built from the environment, not a wrapped error: boxed as the cause.
        let spin = crate::keeper::spin_from_env().map_err(|message| ClientError::Ipc {
            what: "spin window".into(),
            source: message.into(),
        })?;
        Ok(Client {
            session: session.clone(),
            config,
            keeper,
            keeper_gone: false,
            _node: node,
            client,
            notifier,
            acks,
            timeout: Duration::from_secs(30),
            spin,
            _services: vec![Box::new(rr), Box::new(req_event), Box::new(ack_event)],
        })
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    /// How long [`Client::transact`] waits for an answer (default 30 s).
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// How long [`Client::wait`] polls for its answer (yielding the CPU between polls) before
    /// it blocks on the acknowledgement event; zero blocks at once. The default comes from
    /// `ROBOSIM_SPIN_US` ([`crate::keeper::SPIN_ENV`]), read at connect, else
    /// [`crate::keeper::DEFAULT_SPIN_US`].
    pub fn set_spin(&mut self, spin: Duration) {
        self.spin = spin;
    }

    /// Sends `tx` and waits until the keeper has journaled, published and acknowledged it.
    pub fn transact(&mut self, tx: &Transaction) -> Result<Committed, ClientError> {
        let p = self.submit(tx)?;
        Ok(self.wait(p)??)
    }

    /// A read-modify-write (a relative move, one joint of a robot's q) committed against the
    /// model as it is when the keeper applies it: `build(attempt)` reads the model (a fresh
    /// snapshot) and returns the transaction computed from it, with an [`crate::Op::Expect`]
    /// for every object it read at the snapshot's version
    /// ([`Transaction::expect`]). When another writer changed one of them in between, the
    /// keeper refuses it ([`TxError::Conflict`], nothing changed) and it is built again from
    /// a new read, at most [`MAX_FRESH_ATTEMPTS`] times; then [`ClientError::Conflict`].
    ///
    /// A fresh read after a conflict sees the conflicting write: the keeper publishes a group
    /// of commits before it answers any request of the group.
    pub fn transact_fresh<E: From<ClientError>>(
        &mut self,
        mut build: impl FnMut(u32) -> Result<Transaction, E>,
    ) -> Result<Committed, E> {
        let mut attempt = 0;
        loop {
            let tx = build(attempt)?;
            attempt += 1;
            match self.transact(&tx) {
                Err(ClientError::Refused(e @ TxError::Conflict { .. })) => {
                    if attempt >= MAX_FRESH_ATTEMPTS {
                        return Err(ClientError::Conflict {
                            attempts: attempt,
                            last: e,
                        }
                        .into());
                    }
                }
                other => return other.map_err(E::from),
            }
        }
    }

    /// Sends `tx` without waiting.
    pub fn submit(&mut self, tx: &Transaction) -> Result<Pending, ClientError> {
        self.submit_raw(&tx.encode())
    }

    /// Sends already-encoded bytes (tests use this to send malformed requests).
    pub fn submit_raw(&mut self, bytes: &[u8]) -> Result<Pending, ClientError> {
        if self.keeper_gone {
            return Err(ClientError::KeeperGone);
        }
        if bytes.len() > MAX_REQUEST_BYTES {
            return Err(ClientError::TooLarge {
                bytes: bytes.len(),
                limit: MAX_REQUEST_BYTES,
            });
        }
        use iceoryx2::port::LoanError;
        let req = self
            .client
            .loan_slice_uninit(bytes.len().max(1))
            .map_err(|e| match e {
                LoanError::ExceedsMaxLoans => ClientError::TooManyInFlight,
                LoanError::OutOfMemory | LoanError::ExceedsMaxLoanSize => {
                    ClientError::OutOfSharedMemory { bytes: bytes.len() }
                }
                e => ipc("loan request")(e),
            })?;
        let payload = if bytes.is_empty() { &[0u8][..] } else { bytes };
        let inner = req.write_from_slice(payload).send().map_err(|e| match e {
            iceoryx2::port::client::RequestSendError::ExceedsMaxActiveRequests => {
                ClientError::TooManyInFlight
            }
            e => ipc("send request")(e),
        })?;
        let _ = self
            .notifier
            .notify_with_custom_event_id(EventId::new(events::REQUEST));
        Ok(Pending { inner })
    }

    /// Is the keeper we connected to still alive? Asks iceoryx2 for the state of its node: a
    /// process killed with SIGKILL leaves its node `Dead` (its monitoring lock is released), a
    /// keeper that stopped cleanly leaves none. Without a known node (a keeper older than the
    /// client's view), the session's process registry answers.
    fn keeper_alive(&mut self) -> bool {
        if self.keeper_gone {
            return false;
        }
        let alive = match self.keeper {
            Some(id) => match Node::<ipc::Service>::state_of(&self.config, id) {
                Ok(Some(NodeState::Dead(_))) | Ok(None) => false,
                // Alive, inaccessible, undefined or not listable: not proof of death.
                Ok(Some(_)) | Err(_) => true,
            },
            None => self.session.processes().iter().any(|p| p.role == "space"),
        };
        self.keeper_gone = !alive;
        alive
    }

    /// Waits for the answer to `p`: the outer error is transport, the inner the keeper's verdict.
    /// A keeper that died (even by `kill -9`) ends the wait with [`ClientError::KeeperGone`]
    /// within [`LIVENESS_PERIOD`], and every later request of this client fails the same way
    /// at once.
    pub fn wait(&mut self, p: Pending) -> Result<Result<Committed, TxError>, ClientError> {
        let bytes = self.wait_answer(p)?;
        decode_answer(&bytes)
    }

    /// The whole model and library of the keeper at its current version (for a bridge that
    /// keeps a replica: [`crate::replica`]).
    pub fn snapshot(&mut self) -> Result<SpaceSnapshot, ClientError> {
        let p = self.submit_raw(&SNAPSHOT_MAGIC)?;
        let bytes = self.wait_answer(p)?;
        decode(&bytes, "decode snapshot")
    }

    /// The transactions the keeper committed after `version`, and its library when its
    /// generation is not `library_gen` ([`crate::replica`]).
    pub fn log_since(&mut self, version: u64, library_gen: u64) -> Result<LogAnswer, ClientError> {
        let mut req = LOG_MAGIC.to_vec();
        req.extend_from_slice(&version.to_le_bytes());
        req.extend_from_slice(&library_gen.to_le_bytes());
        let p = self.submit_raw(&req)?;
        let bytes = self.wait_answer(p)?;
        decode(&bytes, "decode log answer")
    }

    /// The whole encoded answer to `p`, its parts fetched and joined. The continuation requests
    /// are pipelined, [`PART_WINDOW`] in flight: one round trip per part made a replica's join
    /// to a model of 10⁵ bodies take seconds (docs/bench/bridge.md).
    fn wait_answer(&mut self, p: Pending) -> Result<Vec<u8>, ClientError> {
        let cut = |why: &str| ClientError::Ipc {
            what: "receive response".into(),
            source: format!("the keeper's answer was cut off or expired: {why}").into(),
        };
        let resp = self.wait_response(&p)?;
        drop(p);
        let (token, total, first) = match resp.first() {
            Some(&answer::WHOLE) => return Ok(resp[1..].to_vec()),
            Some(&answer::PART) => {
                let part = Part::parse(&resp).ok_or_else(|| cut("a part too short"))?;
                if part.offset != 0 {
                    return Err(cut("the first part is not at offset 0"));
                }
                (part.token, part.total, part.bytes)
            }
            _ => return Err(cut("no answer tag")),
        };
        let mut whole = Vec::with_capacity(total);
        whole.extend_from_slice(first);
        let step = RESPONSE_CAP - answer::PART_HEADER;
        let mut to_ask = total.saturating_sub(whole.len()).div_ceil(step);
        let mut more = MORE_MAGIC.to_vec();
        more.extend_from_slice(&token.to_le_bytes());
        let mut asked = std::collections::VecDeque::new();
        while whole.len() < total {
            while to_ask > 0 && asked.len() < PART_WINDOW {
                asked.push_back(self.submit_raw(&more)?);
                to_ask -= 1;
            }
            let Some(p) = asked.pop_front() else {
                return Err(cut("fewer parts than its length"));
            };
            let resp = self.wait_response(&p)?;
            let part = (resp.first() == Some(&answer::PART))
                .then(|| Part::parse(&resp))
                .flatten()
                .ok_or_else(|| cut("a continuation was not a part"))?;
            if part.token != token || part.total != total || part.offset != whole.len() {
                return Err(cut("a part out of order"));
            }
            if part.bytes.is_empty() || whole.len() + part.bytes.len() > total {
                return Err(cut("a part of the wrong length"));
            }
            whole.extend_from_slice(part.bytes);
        }
        Ok(whole)
    }

    /// The bytes of the next response to `p` (see [`Client::wait`] for the errors).
    fn wait_response(&mut self, p: &Pending) -> Result<Vec<u8>, ClientError> {
        let start = Instant::now();
        let mut checked = start;
        if self.keeper_gone {
            return Err(ClientError::KeeperGone);
        }
        // The spin window: poll for the answer before paying for a blocking wake-up.
        while start.elapsed() < self.spin {
            if let Some(resp) = p.inner.receive().map_err(ipc("receive response"))? {
                return Ok(resp.payload().to_vec());
            }
            std::hint::spin_loop();
            std::thread::yield_now();
        }
        loop {
            if let Some(resp) = p.inner.receive().map_err(ipc("receive response"))? {
                return Ok(resp.payload().to_vec());
            }
            // iceoryx2 may report the connection down while it is being re-established; only
            // a keeper that is really gone ends the wait.
            if !p.inner.is_connected() && !self.keeper_alive() {
                return Err(ClientError::KeeperGone);
            }
            if checked.elapsed() >= LIVENESS_PERIOD {
                checked = Instant::now();
                if !self.keeper_alive() {
                    return Err(ClientError::KeeperGone);
                }
            }
            let elapsed = start.elapsed();
            if elapsed >= self.timeout {
                return Err(ClientError::Timeout(self.timeout));
            }
            let _ = self.acks.timed_wait(
                |_| {},
                (self.timeout - elapsed).min(Duration::from_millis(5)),
            );
        }
    }
}

/// Continuation requests a client keeps in flight while it fetches a large answer's parts (of
/// the keeper's [`MAX_IN_FLIGHT`] per client).
const PART_WINDOW: usize = 16;

/// One part of a large answer, as [`answer::PART`] lays it out.
struct Part<'a> {
    token: u64,
    total: usize,
    offset: usize,
    bytes: &'a [u8],
}

impl<'a> Part<'a> {
    fn parse(resp: &'a [u8]) -> Option<Part<'a>> {
        let word = |at: usize| {
            resp.get(at..at + 8)
                .and_then(|b| <[u8; 8]>::try_from(b).ok())
                .map(u64::from_le_bytes)
        };
        Some(Part {
            token: word(1)?,
            total: usize::try_from(word(9)?).ok()?,
            offset: usize::try_from(word(17)?).ok()?,
            bytes: resp.get(answer::PART_HEADER..)?,
        })
    }
}

/// The keeper's verdict from its encoded answer.
fn decode_answer(bytes: &[u8]) -> Result<Result<Committed, TxError>, ClientError> {
    decode(bytes, "decode response")
}

fn decode<T: serde::de::DeserializeOwned>(bytes: &[u8], what: &str) -> Result<T, ClientError> {
    bincode::serde::decode_from_slice::<T, _>(bytes, bincode::config::standard())
        .map(|(r, _)| r)
        .map_err(|e| ClientError::Ipc {
            what: what.into(),
            source: Box::new(e),
        })
}
