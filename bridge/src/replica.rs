//! The replica side (`robosim bridge --connect ENDPOINT`): a keeper in replica mode for this
//! machine's session, kept equal to the primary's.
//!
//! * Start: the primary's snapshot (asked for until the primary answers) becomes the session's
//!   model — its data directory is reset to it — and library. A restarted replica starts from a
//!   new snapshot too: its journal could hold a history the primary no longer has.
//! * Then every [`LogMsg`] is applied in order. A message that does not follow the replica's
//!   version (messages lost while the link was down) or a heartbeat naming a newer version
//!   makes the replica ask the primary's log for what it lacks; when the log no longer reaches
//!   back, a new snapshot replaces the model (readers start over, as after a keeper restart).
//! * Local writers' transactions go to the primary; a commit is answered once the replica has
//!   applied it (the writer reads its own write), a refusal at once; no answer within
//!   `--tx-timeout-ms` is a [`TxError::Forward`] saying the transaction may have been
//!   committed.

use crate::{BridgeArgs, BridgeError, LogMsg, Result, StateMsg, decode, encode, key, zerr};
use robosim_instance_space::replica::{LogAnswer, PublishedLibrary, SpaceSnapshot};
use robosim_instance_space::state::StatePublisher;
use robosim_instance_space::{Applied, Keeper, KeeperOptions, Session, Store, TxError};
use std::time::{Duration, Instant};
use zenoh::Wait;

type Verdict = std::result::Result<Applied, TxError>;
type Replies = zenoh::handlers::FifoChannelHandler<zenoh::query::Reply>;

/// A forwarded transaction: its ticket in the keeper, the primary's pending answer, when sent.
struct InFlight {
    ticket: u64,
    replies: Replies,
    sent: Instant,
}

struct Replica<'a> {
    args: &'a BridgeArgs,
    z: zenoh::Session,
    keeper: Keeper,
    library_gen: u64,
    /// Commits waiting for the replica to reach their version before their writer is answered.
    committed: Vec<(u64, Verdict)>,
    in_flight: Vec<InFlight>,
    /// The newest version the primary is known to have.
    primary_version: u64,
    last_heard: Instant,
    connected: bool,
}

pub fn follow(session: &Session, endpoint: &str, args: &BridgeArgs) -> Result<()> {
    let z = zenoh::open(crate::zenoh_config(None, Some(endpoint))?)
        .wait()
        .map_err(zerr(format!("connect to {endpoint}")))?;
    eprintln!(
        "bridge: session {} follows {:?} at {endpoint}",
        session.name(),
        args.key
    );
    let signals = session.node("bridge-signals", true)?;
    let stop = || signals.wait(Duration::ZERO).is_err();
    let snap = snapshot(&z, args, Some(&stop))?
        .ok_or_else(|| BridgeError::Snapshot("stopped before the primary answered".into()))?;
    let model = decode_model(&snap)?;
    let version = model.version;
    // No fsync and one journal copy: a replica that restarts takes a new snapshot from the
    // primary (whose keeper is the durable one), so its own journal is never what it recovers
    // from; syncing it cost milliseconds per applied group.
    let opts = KeeperOptions {
        replica: true,
        durable: false,
        journal_copies: 1,
        spin: Duration::ZERO,
        ..KeeperOptions::default()
    };
    let keeper = Keeper::start_with(session, opts, model)?;
    let log_sub = z
        .declare_subscriber(key(&args.key, "log"))
        .wait()
        .map_err(zerr("subscribe to the log"))?;
    let mut states = StateRelay::new(&z, args)?;
    let mut r = Replica {
        args,
        z,
        keeper,
        library_gen: 0,
        committed: Vec::new(),
        in_flight: Vec::new(),
        primary_version: version,
        last_heard: Instant::now(),
        connected: true,
    };
    r.set_library(snap.library_gen, &snap.library)?;
    eprintln!("bridge: replica at version {version}");
    let mut last_activity = Instant::now();
    while !r.keeper.interrupted() {
        if !r.in_flight.is_empty() || !r.committed.is_empty() {
            last_activity = Instant::now();
        }
        let before = r.keeper.store().version;
        let served = r.keeper.step(Duration::ZERO)?;
        if served.committed + served.refused == 0 {
            crate::poll_sleep(last_activity);
        }
        r.forward()?;
        while let Ok(Some(sample)) = log_sub.try_recv() {
            match decode::<LogMsg>(&sample.payload().to_bytes()) {
                Some(msg) => r.on_log(msg)?,
                None => eprintln!("bridge: ignored a log message that does not decode"),
            }
        }
        if r.keeper.store().version < r.primary_version {
            r.catch_up()?;
        }
        r.collect_answers();
        r.answer_committed();
        states.relay(r.keeper.session())?;
        if r.keeper.store().version != before || r.keeper.forwarded_in_flight() > 0 {
            last_activity = Instant::now();
        }
        let silent = r.last_heard.elapsed()
            > Duration::from_millis(args.heartbeat_ms.saturating_mul(10).max(2000));
        if silent && r.connected {
            eprintln!(
                "bridge: no word from the primary for {:?}; reconnecting",
                r.last_heard.elapsed()
            );
            r.connected = false;
        }
    }
    r.keeper.checkpoint()?;
    eprintln!("bridge: stopped at version {}", r.keeper.store().version);
    Ok(())
}

/// The primary's snapshot; with `wait_until_stopped`, asked again until it answers or the
/// function says stop (`None`); without, `None` when it does not answer.
fn snapshot(
    z: &zenoh::Session,
    args: &BridgeArgs,
    wait_until_stopped: Option<&dyn Fn() -> bool>,
) -> Result<Option<SpaceSnapshot>> {
    let mut said = false;
    loop {
        let replies = z
            .get(key(&args.key, "snapshot"))
            .timeout(Duration::from_secs(10))
            .wait()
            .map_err(zerr("ask for a snapshot"))?;
        if let Ok(reply) = replies.recv() {
            match reply.result() {
                Ok(sample) => {
                    return match decode::<SpaceSnapshot>(&sample.payload().to_bytes()) {
                        Some(s) => Ok(Some(s)),
                        None => Err(BridgeError::Snapshot("does not decode".into())),
                    };
                }
                Err(e) => {
                    return Err(BridgeError::Snapshot(format!(
                        "the primary refused: {}",
                        String::from_utf8_lossy(&e.payload().to_bytes())
                    )));
                }
            }
        }
        let Some(stopped) = wait_until_stopped else {
            return Ok(None);
        };
        if !said {
            eprintln!("bridge: waiting for the primary to answer");
            said = true;
        }
        if stopped() {
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn decode_model(snap: &SpaceSnapshot) -> Result<Store> {
    robosim_instance_space::journal::decode_store(&snap.model).map_err(BridgeError::SnapshotModel)
}

impl Replica<'_> {
    fn set_library(&mut self, generation: u64, library: &PublishedLibrary) -> Result<()> {
        if generation != self.library_gen {
            self.keeper
                .publish_library_checked(&library.files, library.checked.as_deref())?;
            self.library_gen = generation;
        }
        Ok(())
    }

    fn heard(&mut self) {
        self.last_heard = Instant::now();
        if !self.connected {
            eprintln!("bridge: the primary is back");
            self.connected = true;
        }
    }

    fn on_log(&mut self, msg: LogMsg) -> Result<()> {
        self.heard();
        self.primary_version = self.primary_version.max(msg.version);
        if let Some((g, files)) = &msg.library {
            self.set_library(*g, files)?;
        }
        let mine = self.keeper.store().version;
        if msg.entries.is_empty() {
            return Ok(());
        }
        if msg.after > mine {
            // Something between was lost on the way: the log has it (catch_up, next pass).
            return Ok(());
        }
        self.apply(&msg.entries)
    }

    /// Applies the primary's transactions; a replica found out of step takes a new snapshot.
    fn apply(&mut self, entries: &[(u64, Vec<u8>)]) -> Result<()> {
        match self.keeper.apply_upstream(entries) {
            Ok(_) => Ok(()),
            Err(robosim_instance_space::KeeperError::OutOfStep(why)) => {
                eprintln!("bridge: {why}; taking a new snapshot");
                self.resync()
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Asks the primary's log for everything after this replica's version.
    fn catch_up(&mut self) -> Result<()> {
        loop {
            let mine = self.keeper.store().version;
            let replies = self
                .z
                .get(key(&self.args.key, "log"))
                .payload(encode(&(mine, self.library_gen)))
                .timeout(Duration::from_secs(5))
                .express(true)
                .wait()
                .map_err(zerr("ask the log"))?;
            let Ok(reply) = replies.recv() else {
                return Ok(()); // no answer: the link is down; the next heartbeat retries
            };
            let Ok(sample) = reply.result() else {
                return Ok(());
            };
            self.heard();
            match decode::<LogAnswer>(&sample.payload().to_bytes()) {
                Some(LogAnswer::Entries {
                    version,
                    entries,
                    library,
                }) => {
                    self.primary_version = self.primary_version.max(version);
                    if let Some((g, files)) = library {
                        self.set_library(g, &files)?;
                    }
                    if entries.is_empty() {
                        return Ok(());
                    }
                    self.apply(&entries)?;
                    if self.keeper.store().version >= version {
                        return Ok(());
                    }
                }
                Some(LogAnswer::Gone { .. }) | None => return self.resync(),
            }
        }
    }

    /// Replaces the model by a new snapshot of the primary's.
    fn resync(&mut self) -> Result<()> {
        let Some(snap) = snapshot(&self.z, self.args, None)? else {
            return Ok(()); // the link is down; tried again on the next heartbeat
        };
        let model = decode_model(&snap)?;
        let version = model.version;
        self.keeper.replace_model(model)?;
        self.library_gen = 0;
        self.set_library(snap.library_gen, &snap.library)?;
        self.primary_version = self.primary_version.max(version);
        eprintln!("bridge: resynchronised from a snapshot at version {version}");
        Ok(())
    }

    /// Sends the local writers' new transactions to the primary.
    fn forward(&mut self) -> Result<()> {
        for (ticket, bytes) in self.keeper.take_forwarded() {
            let sent = self
                .z
                .get(key(&self.args.key, "tx"))
                .payload(bytes)
                .timeout(Duration::from_millis(self.args.tx_timeout_ms))
                .express(true)
                .wait();
            match sent {
                Ok(replies) => self.in_flight.push(InFlight {
                    ticket,
                    replies,
                    sent: Instant::now(),
                }),
                Err(e) => self.keeper.answer_forwarded(
                    ticket,
                    &Err(TxError::Forward {
                        reason: format!("could not send it to the primary: {e}"),
                    }),
                ),
            }
        }
        Ok(())
    }

    /// Takes the primary's verdicts that arrived: refusals are answered now, commits once
    /// applied here.
    fn collect_answers(&mut self) {
        let timeout = Duration::from_millis(self.args.tx_timeout_ms);
        let mut still = Vec::new();
        for f in std::mem::take(&mut self.in_flight) {
            let verdict: Option<Verdict> = match f.replies.try_recv() {
                Ok(Some(reply)) => Some(match reply.result() {
                    Ok(sample) => {
                        decode::<Verdict>(&sample.payload().to_bytes()).unwrap_or_else(|| {
                            Err(TxError::Forward {
                                reason: "the primary's answer does not decode".into(),
                            })
                        })
                    }
                    Err(e) => Err(TxError::Forward {
                        reason: format!(
                            "the primary answered with an error: {}",
                            String::from_utf8_lossy(&e.payload().to_bytes())
                        ),
                    }),
                }),
                // The channel closes when the query ends without a reply (timeout or no
                // primary); a margin past the timeout covers a reply still on its way.
                Ok(None) if f.sent.elapsed() < timeout + Duration::from_millis(500) => None,
                Ok(None) | Err(_) => Some(Err(TxError::Forward {
                    reason: format!(
                        "no answer from the primary within {} ms (it may have been committed: the replica shows it once the link is back)",
                        self.args.tx_timeout_ms
                    ),
                })),
            };
            match verdict {
                None => still.push(f),
                Some(Ok(applied)) => {
                    self.primary_version = self.primary_version.max(applied.version);
                    self.committed.push((f.ticket, Ok(applied)));
                }
                Some(refused) => self.keeper.answer_forwarded(f.ticket, &refused),
            }
        }
        self.in_flight = still;
    }

    /// Answers the writers whose commits this replica has now applied.
    fn answer_committed(&mut self) {
        let mine = self.keeper.store().version;
        let mut still = Vec::new();
        for (ticket, verdict) in std::mem::take(&mut self.committed) {
            match &verdict {
                Ok(a) if a.version > mine => still.push((ticket, verdict)),
                _ => self.keeper.answer_forwarded(ticket, &verdict),
            }
        }
        self.committed = still;
    }
}

/// The primary's state records republished on this session's state services.
struct StateRelay {
    subs: Vec<(
        String,
        zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
        Option<StatePublisher>,
    )>,
}

impl StateRelay {
    fn new(z: &zenoh::Session, args: &BridgeArgs) -> Result<Self> {
        let mut subs = Vec::new();
        if crate::state_period(args.state_hz).is_some() {
            for name in &args.states {
                let sub = z
                    .declare_subscriber(key(&args.key, &format!("state/{name}")))
                    .wait()
                    .map_err(zerr(format!("subscribe to state {name}")))?;
                subs.push((name.clone(), sub, None));
            }
        }
        Ok(StateRelay { subs })
    }

    fn relay(&mut self, session: &Session) -> Result<()> {
        for (name, sub, publisher) in &mut self.subs {
            let mut newest = None;
            while let Ok(Some(s)) = sub.try_recv() {
                newest = decode::<StateMsg>(&s.payload().to_bytes());
            }
            let Some(msg) = newest else { continue };
            let Some((joints, bodies)) = msg.records() else {
                eprintln!("bridge: state {name}: a record of the wrong length; dropped");
                continue;
            };
            if publisher.is_none() {
                match StatePublisher::create(session, name) {
                    Ok(p) => *publisher = Some(p),
                    Err(e) => {
                        eprintln!("bridge: state {name}: {e}");
                        continue;
                    }
                }
            }
            if let Some(p) = publisher
                && let Err(e) = p.publish(msg.structure_version, msg.t, &joints, &bodies)
            {
                eprintln!("bridge: state {name}: {e}");
            }
        }
        Ok(())
    }
}
