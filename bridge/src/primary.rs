//! The bridge beside the keeper that owns the model (`robosim bridge --listen ENDPOINT`).
//!
//! One loop, one thread of ours (Zenoh runs its own): wait for the keeper's change event (at
//! most one heartbeat period), then
//! 1. publish every transaction committed since the last one published, in order, from the
//!    keeper's log ([`Client::log_since`]) — or a heartbeat with the keeper's version;
//! 2. answer snapshot and log queries (late joiners and replicas catching up);
//! 3. forward remote writers' transactions to the keeper, all at once (pipelined), and answer
//!    each with the keeper's verdict after the keeper has journaled it;
//! 4. pass on the newest state record of each state service at most `--state-hz` times a
//!    second.
//!
//! The bridge holds no model: a bridge restarted (or killed and restarted) serves the same
//! history, because the log it serves is the keeper's.

use crate::{BridgeArgs, BridgeError, LogMsg, Result, StateMsg, decode, encode, key, zerr};
use robosim_instance_space::replica::LogAnswer;
use robosim_instance_space::state::StateSubscriber;
use robosim_instance_space::{Client, Reader, Session, TxError};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// What the bridge has published so far.
struct Published {
    version: u64,
    library_gen: u64,
    at: Instant,
}

/// The bridge's attachment to the keeper: a client (its log, snapshots, writes) and a reader
/// (its change event). Made again when the keeper comes back after it died.
struct KeeperLink {
    client: Client,
    reader: Reader,
}

impl KeeperLink {
    fn attach(session: &Session) -> Result<KeeperLink> {
        Ok(KeeperLink {
            client: Client::connect(session, "bridge")?,
            reader: Reader::attach(session, "bridge")?,
        })
    }
}

/// How often a bridge whose keeper died looks for the restarted one.
const KEEPER_POLL: Duration = Duration::from_millis(100);

pub fn serve(session: &Session, endpoint: &str, args: &BridgeArgs) -> Result<()> {
    let mut link = Some(KeeperLink::attach(session)?);
    let signals = session.node("bridge-signals", true)?;
    let registration = session.register("bridge", &[])?;
    let z = zenoh::open(crate::zenoh_config(Some(endpoint), None)?)
        .wait()
        .map_err(zerr(format!("listen on {endpoint}")))?;
    let k = |what: &str| key(&args.key, what);
    let snapshots = z
        .declare_queryable(k("snapshot"))
        .wait()
        .map_err(zerr("declare snapshot queryable"))?;
    let logs = z
        .declare_queryable(k("log"))
        .wait()
        .map_err(zerr("declare log queryable"))?;
    let txs = z
        .declare_queryable(k("tx"))
        .wait()
        .map_err(zerr("declare tx queryable"))?;
    let log_pub = z
        .declare_publisher(k("log"))
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .express(true)
        .wait()
        .map_err(zerr("declare log publisher"))?;
    let mut states = StatePassing::new(session, args, &z)?;
    eprintln!(
        "bridge: session {} served on {endpoint} as {:?}{}",
        session.name(),
        args.key,
        if args.read_only {
            " (read-only: remote writers are refused)"
        } else {
            ""
        }
    );
    let heartbeat = Duration::from_millis(args.heartbeat_ms.max(1));
    let mut published = Published {
        version: match &mut link {
            Some(l) => current_version(&mut l.client)?,
            None => 0,
        },
        library_gen: 0,
        at: Instant::now() - heartbeat,
    };
    let mut last_activity = Instant::now();
    let queries = Queries {
        snapshots: &snapshots,
        logs: &logs,
        txs: &txs,
    };
    while signals.wait(Duration::ZERO).is_ok() {
        let Some(l) = &mut link else {
            // The keeper died (kill -9, a crash): wait for it to come back — `robosim up` or
            // `robosim space` on this session — and carry on from it. Meanwhile remote
            // writers are refused by name; snapshot and log queries wait (replicas ask again).
            refuse_writes(
                &txs,
                "the primary's keeper is not running (it is restarting?)",
            );
            states.pass(session, &z)?;
            if session.processes().iter().any(|p| p.role == "space") {
                match KeeperLink::attach(session) {
                    Ok(mut l) => match current_version(&mut l.client) {
                        Ok(v) => {
                            eprintln!(
                                "bridge: the keeper of session {} is back at version {v}; publishing from it",
                                session.name()
                            );
                            // The restarted keeper counts its library publications afresh:
                            // replicas get its library again.
                            published.library_gen = 0;
                            published.at = Instant::now() - heartbeat;
                            link = Some(l);
                            last_activity = Instant::now();
                            continue;
                        }
                        Err(e) => eprintln!("bridge: the restarted keeper: {e}; trying again"),
                    },
                    Err(e) => eprintln!("bridge: the restarted keeper: {e}; trying again"),
                }
            }
            std::thread::sleep(KEEPER_POLL);
            continue;
        };
        match pass(l, &queries, &log_pub, &mut published, heartbeat, args) {
            Ok(active) => {
                if active {
                    last_activity = Instant::now();
                } else {
                    crate::poll_sleep(last_activity);
                }
            }
            // The keeper went away: what the bridge published stays published; it waits
            // for the keeper to come back rather than leave its replicas stale.
            Err(e @ (BridgeError::Client(_) | BridgeError::Reader(_))) => {
                eprintln!(
                    "bridge: lost the keeper of session {} ({e}); waiting for it to restart",
                    session.name()
                );
                link = None;
                continue;
            }
            Err(e) => return Err(e),
        }
        states.pass(session, &z)?;
    }
    drop(registration);
    eprintln!("bridge: stopped");
    Ok(())
}

/// The bridge's Zenoh queryables.
struct Queries<'a> {
    snapshots:
        &'a zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>,
    logs: &'a zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>,
    txs: &'a zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>,
}

/// One pass over the keeper and the queries (module docs, steps 1–3); whether anything
/// happened. An error of the client or the reader is the keeper's absence to the caller.
fn pass(
    l: &mut KeeperLink,
    q: &Queries<'_>,
    log_pub: &zenoh::pubsub::Publisher<'_>,
    published: &mut Published,
    heartbeat: Duration,
    args: &BridgeArgs,
) -> Result<bool> {
    // Zenoh's queries do not wake the keeper's change event: poll both (see poll_sleep).
    let mut active = l.reader.wait_event(Duration::ZERO)?.is_some();
    let before = published.version;
    publish_log(&mut l.client, log_pub, published, heartbeat)?;
    active |= published.version != before;
    while let Ok(Some(query)) = q.snapshots.try_recv() {
        active = true;
        let snap = l.client.snapshot()?;
        let _ = query.reply(query.key_expr().clone(), encode(&snap)).wait();
    }
    while let Ok(Some(query)) = q.logs.try_recv() {
        active = true;
        let asked = query
            .payload()
            .and_then(|p| decode::<(u64, u64)>(&p.to_bytes()));
        let answer = match asked {
            Some((since, lib_gen)) => l.client.log_since(since, lib_gen)?,
            None => LogAnswer::Gone {
                oldest: 0,
                version: published.version,
            },
        };
        let _ = query
            .reply(query.key_expr().clone(), encode(&answer))
            .express(true)
            .wait();
    }
    active |= forward_writes(&mut l.client, q.txs, args)? > 0;
    Ok(active)
}

/// Answers every waiting remote transaction with a refusal saying `why` (nothing forwarded).
fn refuse_writes(
    txs: &zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>,
    why: &str,
) {
    while let Ok(Some(q)) = txs.try_recv() {
        let verdict: std::result::Result<robosim_instance_space::Applied, TxError> =
            Err(TxError::Forward {
                reason: why.to_owned(),
            });
        let _ = q
            .reply(q.key_expr().clone(), encode(&verdict))
            .express(true)
            .wait();
    }
}

/// The keeper's version now (a log request from beyond any version answers with it).
fn current_version(client: &mut Client) -> Result<u64> {
    Ok(match client.log_since(u64::MAX, 0)? {
        LogAnswer::Gone { version, .. } | LogAnswer::Entries { version, .. } => version,
    })
}

/// Publishes what the keeper committed since `p.version` (all of it, in messages of at most
/// [`robosim_instance_space::replica::LOG_ANSWER_BYTES`]), or a heartbeat when nothing was and
/// the period has passed.
fn publish_log(
    client: &mut Client,
    publisher: &zenoh::pubsub::Publisher<'_>,
    p: &mut Published,
    heartbeat: Duration,
) -> Result<()> {
    loop {
        match client.log_since(p.version, p.library_gen)? {
            LogAnswer::Entries {
                version,
                entries,
                library,
            } => {
                if entries.is_empty() && library.is_none() && p.at.elapsed() < heartbeat {
                    return Ok(());
                }
                let msg = LogMsg {
                    after: p.version,
                    version,
                    entries,
                    library,
                };
                publisher
                    .put(encode(&msg))
                    .wait()
                    .map_err(zerr("publish log"))?;
                p.at = Instant::now();
                if let Some((g, _)) = &msg.library {
                    p.library_gen = *g;
                }
                match msg.entries.last() {
                    Some((last, _)) if *last < version => p.version = *last,
                    Some((last, _)) => {
                        p.version = *last;
                        return Ok(());
                    }
                    None => return Ok(()),
                }
            }
            // The keeper's log no longer reaches back to what was last published (more was
            // committed between two of our passes than the log holds), or the keeper's model
            // was replaced: replicas notice the jump in the heartbeat and take a snapshot.
            LogAnswer::Gone { version, .. } => {
                eprintln!(
                    "bridge: the keeper's log no longer holds version {}; replicas resynchronise from a snapshot",
                    p.version + 1
                );
                p.version = version;
            }
        }
    }
}

/// Forwards every waiting remote transaction to the keeper (pipelined), then answers each with
/// the keeper's verdict; with `--read-only`, refuses them.
fn forward_writes(
    client: &mut Client,
    txs: &zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>,
    args: &BridgeArgs,
) -> Result<usize> {
    let mut sent = Vec::new();
    let mut count = 0;
    while let Ok(Some(q)) = txs.try_recv() {
        count += 1;
        let bytes = q
            .payload()
            .map(|p| p.to_bytes().into_owned())
            .unwrap_or_default();
        if args.read_only {
            let verdict: std::result::Result<robosim_instance_space::Applied, TxError> =
                Err(TxError::Forward {
                    reason: format!(
                        "the space {:?} is served read-only (robosim bridge --read-only)",
                        args.key
                    ),
                });
            let _ = q
                .reply(q.key_expr().clone(), encode(&verdict))
                .express(true)
                .wait();
            continue;
        }
        match client.submit_raw(&bytes) {
            Ok(p) => sent.push((q, p)),
            Err(robosim_instance_space::ClientError::TooManyInFlight) => {
                // Wait for what is in flight, then this one.
                for (q, p) in sent.drain(..) {
                    answer(client, q, p)?;
                }
                let p = client.submit_raw(&bytes)?;
                sent.push((q, p));
            }
            Err(e) => return Err(e.into()),
        }
    }
    for (q, p) in sent {
        answer(client, q, p)?;
    }
    Ok(count)
}

fn answer(
    client: &mut Client,
    q: zenoh::query::Query,
    p: robosim_instance_space::Pending,
) -> Result<()> {
    let (verdict, lost) = match client.wait(p) {
        Ok(verdict) => (verdict, None),
        // The writer hears why (the keeper died with its transaction in flight), and the
        // bridge goes on to wait for the keeper.
        Err(e) => (
            Err(TxError::Forward {
                reason: format!("the primary's keeper: {e}"),
            }),
            Some(e),
        ),
    };
    let _ = q
        .reply(q.key_expr().clone(), encode(&verdict))
        .express(true)
        .wait();
    match lost {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// The state services passed on: each opened when its simulator appears, its newest record
/// sent at most once per period.
struct StatePassing {
    period: Option<Duration>,
    services: Vec<StateService>,
}

struct StateService {
    name: String,
    sub: Option<StateSubscriber>,
    publisher: zenoh::pubsub::Publisher<'static>,
    last_sent: Option<Instant>,
    last_try: Option<Instant>,
    newest: Option<robosim_instance_space::state::StateRecord>,
}

impl StatePassing {
    fn new(_session: &Session, args: &BridgeArgs, z: &zenoh::Session) -> Result<Self> {
        let mut services = Vec::new();
        for name in &args.states {
            let publisher = z
                .declare_publisher(key(&args.key, &format!("state/{name}")))
                .congestion_control(zenoh::qos::CongestionControl::Drop)
                .wait()
                .map_err(zerr(format!("declare state publisher {name}")))?;
            services.push(StateService {
                name: name.clone(),
                sub: None,
                publisher,
                last_sent: None,
                last_try: None,
                newest: None,
            });
        }
        Ok(StatePassing {
            period: crate::state_period(args.state_hz),
            services,
        })
    }

    fn pass(&mut self, session: &Session, _z: &zenoh::Session) -> Result<()> {
        let Some(period) = self.period else {
            return Ok(());
        };
        for s in &mut self.services {
            if s.sub.is_none() {
                // The simulator may start later; look for it once a second.
                if s.last_try
                    .is_some_and(|t| t.elapsed() < Duration::from_secs(1))
                {
                    continue;
                }
                s.last_try = Some(Instant::now());
                s.sub = StateSubscriber::open(session, &s.name, "bridge-state").ok();
            }
            let Some(sub) = &mut s.sub else { continue };
            match sub.drain() {
                Ok(records) => {
                    if let Some(r) = records.into_iter().last() {
                        s.newest = Some(r);
                    }
                }
                Err(e) => {
                    eprintln!("bridge: state {}: {e}; reopening", s.name);
                    s.sub = None;
                    continue;
                }
            }
            if s.last_sent.is_some_and(|t| t.elapsed() < period) {
                continue;
            }
            if let Some(r) = s.newest.take() {
                s.publisher
                    .put(encode(&StateMsg::from_record(&r)))
                    .wait()
                    .map_err(zerr(format!("publish state {}", s.name)))?;
                s.last_sent = Some(Instant::now());
            }
        }
        Ok(())
    }
}
