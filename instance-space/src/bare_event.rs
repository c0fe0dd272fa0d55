//! A bare iceoryx2 event between two processes — a notifier here, a listener there, nothing of
//! the Instance Space in between — so that the benches measure the change-notification latency
//! of a keeper beside iceoryx2's own wake-up latency, in the same run and on the same iceoryx2
//! configuration (the session's). Used by `robosim bench scale` and its listener process
//! (`robosim bench ipc-reader --bare`).

use crate::error::Cause;
use crate::session::{Session, SessionError};
use iceoryx2::prelude::*;
use std::time::{Duration, Instant};

/// Events carry their sequence number modulo this, so that a lost or merged wake-up is seen.
pub const EVENT_IDS: usize = 256;

/// The service suffix of the bare event `tag` in a session.
fn suffix(tag: &str) -> String {
    format!("bench/bare-event/{tag}")
}

/// What went wrong with the bare event.
#[derive(Debug, thiserror::Error)]
pub enum BareEventError {
    #[error(transparent)]
    Session(#[from] SessionError),
    /// iceoryx2 refused `what`; its error is the source.
    #[error("iceoryx2 {what}: {source}")]
    Ipc {
        what: &'static str,
        #[source]
        source: Cause,
    },
    /// The listener woke for an event other than the next one: one was lost or two merged.
    #[error("bare event {got} arrived where {expected} was due")]
    OutOfOrder { expected: usize, got: usize },
    #[error("no bare event within {0:?}")]
    Timeout(Duration),
}

fn ipc<E: std::error::Error + Send + Sync + 'static>(
    what: &'static str,
) -> impl FnOnce(E) -> BareEventError {
    move |e| BareEventError::Ipc {
        what,
        source: Box::new(e),
    }
}

type EventService = iceoryx2::service::port_factory::event::PortFactory<ipc::Service>;

fn service(
    session: &Session,
    node: &Node<ipc::Service>,
    tag: &str,
) -> Result<EventService, BareEventError> {
    node.service_builder(&session.service(&suffix(tag))?)
        .event()
        .event_id_max_value(EVENT_IDS - 1)
        .open_or_create()
        .map_err(ipc("open or create the bare event"))
}

/// The notifying side: one event per [`BareNotifier::notify`], stamped just before.
pub struct BareNotifier {
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    sent: usize,
    _service: EventService,
    _node: Node<ipc::Service>,
}

impl BareNotifier {
    /// Creates bare event `tag` in `session` with its notifier.
    pub fn create(session: &Session, tag: &str) -> Result<BareNotifier, BareEventError> {
        let node = session.node("bare-notifier", false)?;
        let svc = service(session, &node, tag)?;
        let notifier = svc
            .notifier_builder()
            .create()
            .map_err(ipc("create the bare notifier"))?;
        Ok(BareNotifier {
            notifier,
            sent: 0,
            _service: svc,
            _node: node,
        })
    }

    /// Notifies the next event; returns CLOCK_MONOTONIC (ns) taken just before.
    pub fn notify(&mut self) -> Result<u64, BareEventError> {
        let id = EventId::new(self.sent % EVENT_IDS);
        let t = crate::monotonic_ns();
        self.notifier
            .notify_with_custom_event_id(id)
            .map_err(ipc("notify the bare event"))?;
        self.sent += 1;
        Ok(t)
    }

    /// Processes listening now.
    pub fn listeners(&self) -> usize {
        self._service.dynamic_config().number_of_listeners()
    }
}

/// The listening side: opens bare event `tag` in `session` (waiting up to `timeout` for it),
/// calls `ready` once listening, then blocks for `count` events and returns CLOCK_MONOTONIC
/// (ns) when each wait returned, in order. An event out of sequence is an error.
pub fn listen(
    session: &Session,
    tag: &str,
    count: usize,
    timeout: Duration,
    ready: impl FnOnce(),
) -> Result<Vec<u64>, BareEventError> {
    let node = session.node("bare-listener", false)?;
    let svc = service(session, &node, tag)?;
    let listener = svc
        .listener_builder()
        .create()
        .map_err(ipc("create the bare listener"))?;
    ready();
    let mut woke = Vec::with_capacity(count);
    let mut last = Instant::now();
    let mut ids = Vec::new();
    while woke.len() < count {
        ids.clear();
        crate::session::timed_wait_events(
            &listener,
            |e| ids.push(e.id.as_value()),
            Duration::from_secs(1),
        )
        .map_err(ipc("wait for the bare event"))?;
        // Stamped when the wait returns, as `Reader::wait_event` stamps a change.
        let t = crate::monotonic_ns();
        for &id in &ids {
            let expected = woke.len() % EVENT_IDS;
            if id != expected {
                return Err(BareEventError::OutOfOrder { expected, got: id });
            }
            woke.push(t);
        }
        if !ids.is_empty() {
            last = Instant::now();
        } else if last.elapsed() > timeout {
            return Err(BareEventError::Timeout(timeout));
        }
    }
    Ok(woke)
}
