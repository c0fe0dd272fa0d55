//! High-rate state: a running simulator owns the dynamic state (joint values, body poses,
//! time) and publishes it on its own service, `state/<name>`, with a sequence number and the
//! structure version it applies to, so readers see structure and state coherently: a state
//! record whose `structure_version` is newer than the reader's snapshot waits for that
//! snapshot; an older one refers to a structure the reader has already replaced.
//!
//! The service lives as long as the simulator: when it dies, readers see no new records (and
//! `StateSubscriber::publisher_alive` turns false); the keeper and the Instance Space are
//! unaffected.

use crate::layout::{PoseRec, Segment, SegmentWriter};
use crate::session::{Session, SessionError};
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;
use std::time::Duration;

type Pub = iceoryx2::port::publisher::Publisher<ipc::Service, [u64], ()>;
type Sub = iceoryx2::port::subscriber::Subscriber<ipc::Service, [u64], ()>;
type Sample = iceoryx2::sample::Sample<ipc::Service, [u64], ()>;

#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error("no state service {name:?} in session {session} (is the simulator running?)")]
    NoPublisher { session: String, name: String },
    /// iceoryx2 refused `what`; its error is the source (matched by variant where it matters).
    #[error("iceoryx2 {what}: {source}")]
    Ipc {
        what: String,
        #[source]
        source: crate::error::Cause,
    },
    /// The receiver of a command died (killed, crashed) before answering it: no receiver is
    /// left, or iceoryx2 finds every receiver's node dead (its process gone without cleaning
    /// up). Said as soon as it is seen, not after the sender's timeout.
    #[error(
        "the {name} of session {session} died before answering (its process ended without stopping: killed or crashed); start it again (`robosim up SCENE --with {name}` or `robosim {name}`)"
    )]
    ReceiverDead { session: String, name: String },
    #[error("malformed state record: {0}")]
    Layout(#[from] crate::layout::LayoutError),
}

fn ipc<E: std::error::Error + Send + Sync + 'static>(
    what: &'static str,
) -> impl FnOnce(E) -> StateError {
    move |e| StateError::Ipc {
        what: what.to_owned(),
        source: Box::new(e),
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct StateHeader {
    /// Increases by one per published record.
    pub seq: u64,
    /// The Instance Space version whose structure this state applies to.
    pub structure_version: u64,
    /// Simulated time, s.
    pub t: f64,
    /// CLOCK_MONOTONIC ns at publication.
    pub published_ns: u64,
}

/// One joint's state: the link object id, position (rad or m), velocity, effort (N·m or N).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct JointStateRec {
    pub id: u64,
    pub q: f64,
    pub qd: f64,
    pub effort: f64,
}

/// A state record as a reader receives it (copied out of shared memory: it is small).
#[derive(Debug, Clone, PartialEq)]
pub struct StateRecord {
    pub header: StateHeader,
    pub joints: Vec<JointStateRec>,
    pub bodies: Vec<PoseRec>,
}

fn service_name(name: &str) -> String {
    format!("state/{name}")
}

pub struct StatePublisher {
    _node: Node<ipc::Service>,
    publisher: Pub,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    seq: u64,
    _services: Vec<Box<dyn std::any::Any>>,
}

impl StatePublisher {
    /// Creates the state service `name` in `session` (the caller owns it).
    pub fn create(session: &Session, name: &str) -> Result<Self, StateError> {
        let node = session.node(&format!("state-{name}"), false)?;
        let svc = node
            .service_builder(&session.service(&service_name(name))?)
            .publish_subscribe::<[u64]>()
            .history_size(1)
            .subscriber_max_buffer_size(256)
            .subscriber_max_borrowed_samples(2)
            .enable_safe_overflow(true)
            .max_publishers(1)
            .max_subscribers(16)
            .open_or_create()
            .map_err(ipc("create state service"))?;
        let publisher = svc
            .publisher_builder()
            .initial_max_slice_len(256)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(ipc("create state publisher"))?;
        let ev = node
            .service_builder(&session.service(&format!("{}/event", service_name(name)))?)
            .event()
            .open_or_create()
            .map_err(ipc("create state event"))?;
        let notifier = ev
            .notifier_builder()
            .create()
            .map_err(ipc("create state notifier"))?;
        Ok(StatePublisher {
            _node: node,
            publisher,
            notifier,
            seq: 0,
            _services: vec![Box::new(svc), Box::new(ev)],
        })
    }

    /// Publishes one record; returns its sequence number.
    pub fn publish(
        &mut self,
        structure_version: u64,
        t: f64,
        joints: &[JointStateRec],
        bodies: &[PoseRec],
    ) -> Result<u64, StateError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.seq += 1;
        let header = [StateHeader {
            seq: self.seq,
            structure_version,
            t,
            published_ns: crate::monotonic_ns(),
        }];
        let mut w = SegmentWriter::new();
        w.push(&header).push(joints).push(bodies);
        let _ = self.publisher.update_connections();
        let mut s = self
            .publisher
            .loan_slice(w.words())
            .map_err(ipc("loan state"))?;
        w.write(s.payload_mut());
        s.send().map_err(ipc("send state"))?;
        let _ = self.notifier.notify();
        Ok(self.seq)
    }
}

pub struct StateSubscriber {
    _node: Node<ipc::Service>,
    sub: Sub,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    _services: Vec<Box<dyn std::any::Any>>,
}

impl StateSubscriber {
    pub fn open(session: &Session, name: &str, role: &str) -> Result<Self, StateError> {
        let node = session.node(role, false)?;
        let none = || StateError::NoPublisher {
            session: session.name().to_owned(),
            name: name.to_owned(),
        };
        let svc = node
            .service_builder(&session.service(&service_name(name))?)
            .publish_subscribe::<[u64]>()
            .open()
            .map_err(|_| none())?;
        let sub = svc
            .subscriber_builder()
            .create()
            .map_err(ipc("subscribe state"))?;
        let ev = node
            .service_builder(&session.service(&format!("{}/event", service_name(name)))?)
            .event()
            .open()
            .map_err(|_| none())?;
        let listener = ev
            .listener_builder()
            .create()
            .map_err(ipc("listen to state"))?;
        Ok(StateSubscriber {
            _node: node,
            sub,
            listener,
            _services: vec![Box::new(svc), Box::new(ev)],
        })
    }

    fn decode(s: &Sample) -> Result<StateRecord, StateError> {
        let seg = Segment::parse(s.payload())?;
        Ok(StateRecord {
            header: *seg.record::<StateHeader>(0)?,
            joints: seg.section::<JointStateRec>(1)?.to_vec(),
            bodies: seg.section::<PoseRec>(2)?.to_vec(),
        })
    }

    /// Every record received since the last call, oldest first.
    pub fn drain(&mut self) -> Result<Vec<StateRecord>, StateError> {
        let mut out = Vec::new();
        while let Some(s) = self.sub.receive().map_err(ipc("receive state"))? {
            out.push(Self::decode(&s)?);
        }
        Ok(out)
    }

    /// Waits up to `timeout` for records, then drains them.
    pub fn wait(&mut self, timeout: Duration) -> Result<Vec<StateRecord>, StateError> {
        let out = self.drain()?;
        if !out.is_empty() {
            return Ok(out);
        }
        crate::session::timed_wait_events(&self.listener, |_| {}, timeout)
            .map_err(ipc("wait for state"))?;
        self.drain()
    }
}

/// Commands to a state owner (the simulator): opaque bytes over request-response on
/// `state/<name>/commands`; any number of senders, one receiver — the service's owner — which
/// answers each command (e.g. "ok" or why it was refused). The sender waits for the answer, so
/// a command is never lost with a sender that exits right after sending.
pub struct CommandReceiver {
    _node: Node<ipc::Service>,
    server: iceoryx2::port::server::Server<ipc::Service, [u8], (), [u8], ()>,
    _services: Vec<Box<dyn std::any::Any>>,
}

/// A received command; answer it with [`PendingCommand::reply`].
pub struct PendingCommand {
    request: iceoryx2::active_request::ActiveRequest<ipc::Service, [u8], (), [u8], ()>,
}

impl PendingCommand {
    pub fn bytes(&self) -> &[u8] {
        self.request.payload()
    }
    /// Sends the answer (a sender that already gave up is ignored). An answer longer than
    /// [`MAX_ANSWER`] is replaced by a refusal that says so.
    pub fn reply(self, answer: &[u8]) {
        let too_long;
        let payload = if answer.is_empty() {
            &b" "[..]
        } else if answer.len() > MAX_ANSWER {
            too_long = format!(
                "refused: the answer is {} bytes, more than a command answer holds ({MAX_ANSWER})",
                answer.len()
            );
            too_long.as_bytes()
        } else {
            answer
        };
        if let Ok(r) = self.request.loan_slice_uninit(payload.len()) {
            let _ = r.write_from_slice(payload).send();
        }
    }
}

/// The longest answer to a command, bytes. Answers come from a fixed pool of this size: a
/// resizable pool made iceoryx2 scan ~255 segments' bookkeeping whenever a sender left (every
/// `robosim simctl` run), which stalled the daemon for a quarter of a second each time — a
/// test polling `simctl get` at 50 Hz slowed the daemon's stepping by 4× (found in stop 33).
pub const MAX_ANSWER: usize = 256 * 1024;
/// Senders send one command at a time; a few in flight leave room for a sender that gave up.
const COMMANDS_IN_FLIGHT: usize = 4;
const MAX_SENDERS: usize = 16;

fn command_service(name: &str) -> String {
    format!("{}/commands", service_name(name))
}

impl CommandReceiver {
    pub fn create(session: &Session, name: &str) -> Result<Self, StateError> {
        let node = session.node(&format!("commands-{name}"), false)?;
        let svc = node
            .service_builder(&session.service(&command_service(name))?)
            .request_response::<[u8], [u8]>()
            .max_clients(MAX_SENDERS)
            .max_servers(1)
            .max_active_requests_per_client(COMMANDS_IN_FLIGHT)
            .max_response_buffer_size(1)
            .max_borrowed_responses_per_pending_response(1)
            .enable_safe_overflow_for_requests(false)
            .open_or_create()
            .map_err(ipc("create command service"))?;
        // Every sender's commands in flight, each answer buffered or borrowed (answered at once,
        // once), as the keeper sizes its pool (keeper.rs).
        let need = MAX_SENDERS * COMMANDS_IN_FLIGHT * 2 + 1;
        let server = svc
            .server_builder()
            .max_loaned_responses_per_request(1)
            .initial_max_slice_len(MAX_ANSWER)
            .allocation_strategy(AllocationStrategy::Static)
            .override_response_preallocation(move |worst| need.min(worst))
            .create()
            .map_err(ipc("create command server"))?;
        Ok(CommandReceiver {
            _node: node,
            server,
            _services: vec![Box::new(svc)],
        })
    }
    /// Every command received since the last call, oldest first.
    pub fn drain(&mut self) -> Result<Vec<PendingCommand>, StateError> {
        let mut out = Vec::new();
        while let Some(request) = self.server.receive().map_err(ipc("receive command"))? {
            out.push(PendingCommand { request });
        }
        Ok(out)
    }
}

pub struct CommandSender {
    node: Node<ipc::Service>,
    client: iceoryx2::port::client::Client<ipc::Service, [u8], (), [u8], ()>,
    service: iceoryx2::service::port_factory::request_response::PortFactory<
        ipc::Service,
        [u8],
        (),
        [u8],
        (),
    >,
    session: String,
    name: String,
}

/// How often a sender waiting for an answer checks that its receiver is alive.
const LIVENESS_EVERY: Duration = Duration::from_millis(20);

impl CommandSender {
    pub fn open(session: &Session, name: &str, role: &str) -> Result<Self, StateError> {
        let node = session.node(role, false)?;
        let none = || StateError::NoPublisher {
            session: session.name().to_owned(),
            name: name.to_owned(),
        };
        let svc = node
            .service_builder(&session.service(&command_service(name))?)
            .request_response::<[u8], [u8]>()
            .open()
            .map_err(|_| none())?;
        let client = svc
            .client_builder()
            .initial_max_slice_len(256)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(ipc("create command client"))?;
        Ok(CommandSender {
            node,
            client,
            service: svc,
            session: session.name().to_owned(),
            name: name.to_owned(),
        })
    }

    /// Whether a receiver of this service is alive: some server of it whose node iceoryx2
    /// does not find dead (a node it cannot judge — no permission, inconsistent — counts as
    /// alive: only a death seen is reported).
    fn receiver_alive(&self) -> bool {
        use iceoryx2::node::NodeState;
        use iceoryx2::service::port_factory::PortFactory as _;
        let mut servers = Vec::new();
        self.service.dynamic_config().list_servers(|s| {
            servers.push(s.node_id);
            CallbackProgression::Continue
        });
        servers.into_iter().any(
            |id| match Node::<ipc::Service>::state_of(self.node.config(), id) {
                Ok(Some(NodeState::Dead(_))) | Ok(None) => false,
                Ok(Some(_)) | Err(_) => true,
            },
        )
    }

    /// Sends one command and waits (up to `timeout`) for the receiver's answer; a receiver
    /// that dies meanwhile (or is dead already) is [`StateError::ReceiverDead`] at once.
    pub fn send(&mut self, bytes: &[u8], timeout: Duration) -> Result<Vec<u8>, StateError> {
        let r = self
            .client
            .loan_slice_uninit(bytes.len().max(1))
            .map_err(ipc("loan command"))?;
        let payload = if bytes.is_empty() { &b" "[..] } else { bytes };
        let pending = r
            .write_from_slice(payload)
            .send()
            .map_err(ipc("send command"))?;
        let start = std::time::Instant::now();
        let mut next_check = start;
        loop {
            if let Some(resp) = pending.receive().map_err(ipc("receive answer"))? {
                return Ok(resp.payload().to_vec());
            }
            if std::time::Instant::now() >= next_check {
                next_check += LIVENESS_EVERY;
                if !self.receiver_alive() {
                    return Err(StateError::ReceiverDead {
                        session: self.session.clone(),
                        name: self.name.clone(),
                    });
                }
            }
            if start.elapsed() > timeout {
                return Err(StateError::Ipc {
                    what: "command".into(),
                    source: format!("no answer within {timeout:?}").into(),
                });
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }
}
